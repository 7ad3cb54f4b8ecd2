#!/usr/bin/env python3
"""Natural frequencies and mode shapes of a gear train (lateral.md section 5) through its FMU.

    .venv/bin/python tools/modes.py SCENE [--fmu target/fmu/SpurGearTrain.fmu]
        [--plot modes.png] [--speed W1:W2 [--points 15] [--campbell campbell.png]]

SCENE is a train scene (scenes/train/*.toml) or a gearbox file. The train starts in static balance
under the scene's start loads (static_start = true) and is linearized there through Model
Exchange's directional derivatives (fmi2GetDirectionalDerivative, by central differences in the
binary: fmi2-slave/src/directional.rs): J = d(der(x))/dx over the coordinates in use and their
rates, the lateral bodies' translations included (lateral.md). Each mode is an eigenvalue
lambda = -zeta w + i w sqrt(1 - zeta^2) of J: its natural frequency |lambda| / (2 pi), its damped
frequency Im(lambda) / (2 pi) and its damping ratio -Re(lambda) / |lambda|. On a turning carrier
the Coriolis terms of the planets' translations are in J's velocity block, so the frequencies are
those of the gyroscopic system (undamped, |lambda| is exact). The meshes keep the modes of the
balance (the flanks in contact, the pairs on their segments), so a mode is that of the mesh's
current stiffness: its mean over a mesh cycle is what a lumped mesh with k_lumped_varies = false
gives exactly.

Each mode is classified by its central members (the bodies that are not planets): rotational when
they only turn, translational when they only translate, a planet mode when they stay still, mixed
otherwise (Lin & Parker 1999; an equally spaced set of identical planets has only the first
three, translational ones double). Rotations count as r theta with r the body's largest gear
radius (a carrier's orbit radius), as Lin & Parker's u = r theta.

A speed-driven body's speed is given, not free: its coordinate is left out (it comes first).
Mode shapes are the bodies' rotations per mode (d theta_i / d q from the outputs' directional
derivatives) and their translations, drawn on the layout (tools/train_layout.py) with --plot.
With --speed the start speeds of the scene are scaled so that body 1 turns at W1 ... W2 rad/s
and the frequencies are drawn against it (Campbell diagram) with each mesh's tooth frequency
z_A |w_A - w_c| / (2 pi) as an excitation line; a torsional model's modes move only as the
balance moves, a lateral one's also split and shift with the carrier's Coriolis and centrifugal
terms.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import train_layout as TL  # noqa: E402

DEFAULT_FMU = ROOT / "target" / "fmu" / "SpurGearTrain.fmu"


def _set(model, md_vars, name, value):
    v = md_vars[name]
    if v.type == "Real":
        model.setReal([v.valueReference], [float(value)])
    elif v.type in ("Integer", "Enumeration"):
        model.setInteger([v.valueReference], [int(value)])
    elif v.type == "Boolean":
        model.setBoolean([v.valueReference], [bool(value)])
    else:
        model.setString([v.valueReference], [str(value)])


def lateral_bodies(start_values: dict, n: int) -> list[int]:
    """The lateral bodies, whose x and y follow the rotations among the coordinates."""
    return [i for i in range(1, n + 1) if bool(start_values.get(f"body[{i}].lateral", False))]


def linearize(fmu: Path, start_values: dict, static_start: bool = True) -> dict:
    """The train's Jacobian about its static balance (the FMU's static start, or with
    static_start=False the start values' own deflections), and what reads it.

    Returns {'J': d(der(x))/dx over the free coordinates and rates (values first, then rates),
    'coords': their names, 'T': d(body theta)/d(coordinate value) (bodies x coords), 'X':
    d(body x, y)/d(coordinate value) (2 bodies x coords, x then y per body), 'n_bodies'}."""
    import fmpy
    from fmpy.fmi2 import FMU2Model

    md = fmpy.read_model_description(fmu)
    unzip = fmpy.extract(fmu)
    by_name = {v.name: v for v in md.modelVariables}
    m = FMU2Model(guid=md.guid, unzipDirectory=unzip,
                  modelIdentifier=md.modelExchange.modelIdentifier, instanceName="modes")
    m.instantiate()
    try:
        m.setupExperiment(startTime=0.0)
        m.enterInitializationMode()
        for name, value in start_values.items():
            _set(m, by_name, name, value)
        _set(m, by_name, "static_start", static_start)
        m.exitInitializationMode()
        while True:
            info = m.newDiscreteStates()
            if not info[0]:
                break
        m.enterContinuousTimeMode()
        n = int(start_values.get("n_bodies", by_name["n_bodies"].start))
        driven = sum(1 for i in range(1, n + 1)
                     if int(start_values.get(f"body[{i}].drive", 0)) == 1)
        n_coords = n + 2 * len(lateral_bodies(start_values, n))
        coords = list(range(driven + 1, n_coords + 1))
        value = [by_name[f"coordinate[{k}].value"].valueReference for k in coords]
        rate = [by_name[f"coordinate[{k}].rate"].valueReference for k in coords]
        der = [by_name[f"der(coordinate[{k}].{w})"].valueReference
               for w in ("value", "rate") for k in coords]
        states = value + rate
        J = np.array([m.getDirectionalDerivative(der, [s], [1.0]) for s in states]).T
        thetas = [by_name[f"body[{i}].theta"].valueReference for i in range(1, n + 1)]
        T = np.array([m.getDirectionalDerivative(thetas, [s], [1.0]) for s in value]).T
        xy = [by_name[f"body[{i}].{c}"].valueReference for i in range(1, n + 1) for c in "xy"]
        X = np.array([m.getDirectionalDerivative(xy, [s], [1.0]) for s in value]).T
        m.terminate()
    finally:
        m.freeInstance()
    return {"J": J, "coords": [f"coordinate[{k}]" for k in coords], "T": T, "X": X,
            "n_bodies": n}


def _radii(start_values: dict, n: int) -> np.ndarray:
    """Each body's radius for its rotation's share (Lin & Parker's u = r theta): its largest
    base radius, a carrier's largest orbit radius."""
    lay = TL.layout(start_values)
    r = np.ones(n)
    for i, b in lay["bodies"].items():
        radii = [g["r_b"] for g in b["gears"]] + [lay["bodies"][p]["R"] for p in b["planets"]]
        if radii:
            r[i - 1] = max(radii)
    return r


def classify(rot: np.ndarray, trans: np.ndarray, central: list[int]) -> str:
    """rotational, translational, planet or mixed, from the central members' shares (rot: r
    theta per body; trans: (x, y) per body) against the shape's largest entry."""
    big = max(np.max(np.abs(rot)), np.max(np.abs(trans)), 1e-300)
    turns = max((abs(rot[i]) for i in central), default=0.0) > 1e-4 * big
    moves = max((np.hypot(*trans[i]) for i in central), default=0.0) > 1e-4 * big
    return {(True, False): "rotational", (False, True): "translational",
            (False, False): "planet", (True, True): "mixed"}[(turns, moves)]


def modes(lin: dict, start_values: dict | None = None) -> list[dict]:
    """The modes in ascending natural frequency [Hz] with damped frequency, damping ratio,
    shape (each body's rotation, unit largest, and translation 'trans') and kind. Rigid
    rotations (zero frequency) come from K = -J[rates, values]'s null space. With the scene's
    start values the kinds tell rotational, translational and planet modes apart."""
    J = lin["J"]
    c = len(lin["coords"])
    n = lin["n_bodies"]
    K = -J[c:, :c]
    kl, kv = np.linalg.eig(K)
    top = max(np.max(np.abs(kl)), 1e-300)
    rigid = [kv[:, k].real for k in range(c) if abs(kl[k]) <= 1e-9 * top]
    lam, vec = np.linalg.eig(J)
    osc = [k for k in range(2 * c) if lam[k].imag > 1e-6 * math.sqrt(top)]
    X = lin.get("X", np.zeros((2 * n, c)))
    r = _radii(start_values, n) if start_values else np.ones(n)
    central = ([i - 1 for i in range(1, n + 1)
                if not int(start_values.get(f"body[{i}].carrier", 0))]
               if start_values else list(range(n)))
    out = []
    shapes = [(0.0, 0.0, v) for v in rigid]
    for k in osc:
        v = vec[:c, k]
        v = v * np.conj(v[np.argmax(np.abs(v))])
        shapes.append((lam[k], abs(lam[k]), v.real))
    for near, w, v in sorted(shapes, key=lambda x: x[1]):
        rot, trans = lin["T"] @ v, (X @ v).reshape(n, 2)
        big = max(np.max(np.abs(rot)), np.max(np.abs(trans)))
        if big > 0:
            rot, trans = rot / big, trans / big
        kind = "rigid rotation" if w == 0 else classify(r * rot, trans, central)
        zeta = -complex(near).real / w if w > 0 else 0.0
        out.append({"f": w / (2 * math.pi), "f_damped": abs(complex(near).imag) / (2 * math.pi),
                    "zeta": zeta, "shape": rot, "trans": trans, "kind": kind})
    return out


def multiplicities(ms: list[dict], rel: float = 1e-6) -> list[tuple[float, int, str]]:
    """The distinct frequencies with their multiplicity and kind: frequencies within `rel` of
    each other are one (the Jacobian's differences resolve a double mode to about 1e-8)."""
    out: list[list] = []
    for md in ms:
        if out and abs(md["f"] - out[-1][0]) <= rel * max(md["f"], 1e-300):
            out[-1][1] += 1
        else:
            out.append([md["f"], 1, md["kind"]])
    return [tuple(o) for o in out]


def print_table(ms: list[dict], n_bodies: int) -> None:
    print("| mode | f [Hz] | f damped [Hz] | damping ratio | kind | largest rotations (body: share) |")
    print("|---|---|---|---|---|---|")
    for k, md in enumerate(ms, 1):
        top = [i for i in np.argsort(-np.abs(md["shape"]))[:3] if abs(md["shape"][i]) > 1e-6]
        rot = ", ".join(f"{i + 1}: {md['shape'][i]:+.2f}" for i in top) or "-"
        print(f"| {k} | {abs(md['f']):.2f} | {md['f_damped']:.2f} | {md['zeta']:.4f} | {md['kind']} "
              f"| {rot} |")


def plot_shapes(start_values: dict, ms: list[dict], path: Path) -> None:
    """Each mode on the layout: every body's gears, a spoke turned by its modal rotation (the
    largest 45 degrees), red forward, blue backward, and a green arrow for its translation."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lay = TL.layout(start_values)
    shown = [md for md in ms if md["f"] > 0][:6]
    if not shown:
        return
    fig, axes = plt.subplots(1, len(shown), figsize=(3.2 * len(shown), 3.4), squeeze=False)
    for ax, md in zip(axes[0], shown):
        for i, b in lay["bodies"].items():
            c = b["center"]
            r = max((g["r_w"] for g in b["gears"]), default=0.0)
            if r == 0.0:
                continue
            ax.add_patch(plt.Circle(c, r, fill=False, color="0.6", lw=0.8))
            a = md["shape"][i - 1]
            turn = b["sigma"] * math.radians(45.0) * a
            ax.plot([c[0], c[0] + r * math.cos(turn)], [c[1], c[1] + r * math.sin(turn)],
                    color="tab:red" if a >= 0 else "tab:blue", lw=2)
            ax.plot([c[0], c[0] + r], [c[1], c[1]], color="0.8", lw=0.8)
            # A translation (lateral bodies; a planet's in its carrier's frame, which starts
            # at 0): an arrow from the centre, the largest half the body's radius.
            t = md.get("trans", np.zeros((len(md["shape"]), 2)))[i - 1]
            if np.hypot(*t) > 1e-6:
                if b["carrier"]:
                    a_p = b["orbit_angle"]
                    t = [t[0] * math.cos(a_p) - t[1] * math.sin(a_p),
                         t[0] * math.sin(a_p) + t[1] * math.cos(a_p)]
                ax.annotate("", xy=(c[0] + 0.5 * r * t[0], c[1] + 0.5 * r * t[1]), xytext=c,
                            arrowprops={"arrowstyle": "->", "color": "tab:green", "lw": 1.5})
        ax.set_aspect("equal")
        ax.autoscale()
        ax.set_title(f"{md['f']:.1f} Hz, {md['kind']}", fontsize=9)
        ax.axis("off")
    fig.suptitle("Mode shapes: each body's rotation (grey: at rest) and translation (green)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def campbell(fmu: Path, start_values: dict, w1: float, w2: float, points: int, path: Path):
    """Frequencies against body 1's speed, with each mesh's tooth frequency."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    w0 = float(start_values.get("body[1].w_start", 0.0))
    if w0 == 0.0:
        raise SystemExit("--speed needs a scene whose body 1 turns (body[1].w_start != 0)")
    speeds = np.linspace(w1, w2, points)
    freqs = []
    for w in speeds:
        sv = dict(start_values)
        for k, v in start_values.items():
            if k.endswith(".w_start") or k.endswith(".w_in"):
                sv[k] = float(v) * w / w0
        freqs.append([md["f"] for md in modes(linearize(fmu, sv), sv) if md["f"] > 0])
    fig, ax = plt.subplots(figsize=(6, 4))
    for k in range(min(len(f) for f in freqs)):
        ax.plot(speeds, [f[k] for f in freqs], "k-", lw=1)
    lay = TL.layout(start_values)
    drawn = set()
    for mnum, mesh in lay["meshes"].items():
        # Absolute speeds (forward speed times forward sense), A's relative to its carrier.
        a, c = mesh["A"], mesh["carrier"] or 0

        def absolute(i):
            if not i:
                return 0.0
            return lay["bodies"][i]["sigma"] * float(start_values.get(f"body[{i}].w_start", 0.0))

        wa, wc = absolute(a), absolute(c)
        z = next((g["z"] for g in lay["gears"] if g["mesh"] == mnum and g["side"] == "A"), 0)
        rel = abs(wa - wc) / w0
        # Meshes of one tooth frequency (a planetary set's) share a line.
        slope = round(z * rel, 9)
        if z and rel > 0 and slope not in drawn:
            drawn.add(slope)
            ax.plot(speeds, z * rel * speeds / (2 * math.pi), "--", lw=0.8,
                    label=f"mesh[{mnum}] tooth frequency")
    ax.set_xlabel("body 1 speed [rad/s]")
    ax.set_ylabel("frequency [Hz]")
    ax.set_ylim(0, 1.2 * max(max(f) for f in freqs))
    ax.legend(fontsize=7)
    ax.set_title("Campbell diagram: natural frequencies (solid), tooth frequencies (dashed)",
                 fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--fmu", type=Path, default=DEFAULT_FMU)
    ap.add_argument("--plot", type=Path)
    ap.add_argument("--speed")
    ap.add_argument("--points", type=int, default=15)
    ap.add_argument("--campbell", type=Path, default=Path("campbell.png"))
    a = ap.parse_args(argv)
    sv = TL.load_scene(a.scene)
    lin = linearize(a.fmu, sv)
    ms = modes(lin, sv)
    print_table(ms, lin["n_bodies"])
    if a.plot:
        plot_shapes(sv, ms, a.plot)
        print(f"mode shapes: {a.plot}")
    if a.speed:
        w1, w2 = (float(x) for x in a.speed.split(":"))
        campbell(a.fmu, sv, w1, w2, a.points, a.campbell)
        print(f"Campbell diagram: {a.campbell}")


if __name__ == "__main__":
    main()
