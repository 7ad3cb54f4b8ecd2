"""Load sharing among three planets with a floating sun against a rigid one (lateral.md §7),
through SpurGearTrain's Co-Simulation in FMPy: the plot of docs/lateral.md.

The set is scenes/train/lateral-floating-sun.toml: a sun that only its three meshes hold,
planet 1 (body 3) ahead on its orbit by a tangential pin error. The same set with the sun on
its axis (`body[1].lateral = false`) is the rigid sun. For each pin error the FMU starts at the
static balance that the independent reference finds (tests/reference_model/lateral_ref.py's
static_start: the meshes' start deflections and the sun's displacement) and each planet's share
is its sun mesh's force at t = 0 over the three's sum. The rigid sun has such a balance only up
to about 2 um: beyond, planets 2 and 3 lose contact and turn freely in their backlash. The lower
panel follows the three sun mesh forces over the scene's 20 ms from that balance at 2 um, where
the pairs' switching moves them.

Usage: .venv/bin/python tools/load_sharing.py [--fmu target/fmu/SpurGearTrain.fmu]
           [--plot docs/lateral-load-sharing.png]
Prints a Markdown table of the static shares.
"""

import argparse
import sys
import tomllib
from pathlib import Path

import fmpy
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tests"))
import train_layout as TL  # noqa: E402
from reference_model import lateral_ref as LR  # noqa: E402

SUN_MESHES = [f"mesh[{m}].F_fwd" for m in (1, 2, 3)]


def sets() -> dict:
    """The scene's start values with the sun floating, and with it rigid (its lateral keys
    dropped); the scene's own start deflections go too: each pin error has its own."""
    sc = tomllib.loads((ROOT / "scenes/train/lateral-floating-sun.toml").read_text())
    sv = {k: v for k, v in sc["start_values"].items()
          if not k.endswith(("dte_start", "x_start", "y_start"))}
    rigid = {k: v for k, v in sv.items()
             if not (k.startswith("body[1].") and k.split(".", 1)[1] in TL.LATERAL_FIELDS)}
    return {"floating sun": sv, "rigid sun": rigid}, sc


def run(fmu: str, sv: dict, e: float, stop: float, dt: float):
    """The FMU from the reference's static balance with planet 1's pin error e [m]."""
    balance = LR.static_start({**sv, "body[3].pin_error_t": e})
    return fmpy.simulate_fmu(fmu, start_values=balance, stop_time=stop, output_interval=dt,
                             output=SUN_MESHES)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmu", default=str(ROOT / "target/fmu/SpurGearTrain.fmu"))
    ap.add_argument("--plot", default="")
    a = ap.parse_args()
    variants, sc = sets()
    errors_um = {"floating sun": [0.0, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0],
                 "rigid sun": [0.0, 0.5, 1.0, 1.5, 2.0]}
    shares = {name: [] for name in variants}
    for name, sv in variants.items():
        for e in errors_um[name]:
            r = run(a.fmu, sv, e * 1e-6, 1e-5, 1e-5)
            f = np.array([r[n][0] for n in SUN_MESHES])
            shares[name].append(f / f.sum())
    print("| sun | pin error of planet 1 [um] | planets 1, 2, 3 [%] |")
    print("|---|---|---|")
    for name in variants:
        for e, s in zip(errors_um[name], shares[name]):
            print(f"| {name} | {e:g} | " + ", ".join(f"{100 * x:.1f}" for x in s) + " |")
    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (ax, bx) = plt.subplots(2, 1, figsize=(7, 7))
        for (name, s), style in zip(shares.items(), ("-", "--")):
            s = np.array(s)
            for p in range(3):
                ax.plot(errors_um[name], 100 * s[:, p], style, marker="o", color=f"C{p}",
                        label=f"{name}, planet {p + 1}")
        ax.axhline(100 / 3, color="grey", lw=0.8)
        ax.set_xlabel("tangential pin error of planet 1 [um]")
        ax.set_ylabel("share of the sun's torque at static balance [%]")
        ax.legend(fontsize=7, ncol=2)
        ax.set_title("Three planets: a floating sun shares the load equally")
        e_plot = 2e-6
        for (name, sv), style in zip(variants.items(), ("-", "--")):
            r = run(a.fmu, sv, e_plot, sc["stop_time"], sc["output_interval"])
            for p, n in enumerate(SUN_MESHES):
                bx.plot(1e3 * r["time"], r[n], style, color=f"C{p}", lw=0.8,
                        label=f"{name}, planet {p + 1}")
        bx.set_xlabel("t [ms]")
        bx.set_ylabel("sun mesh force [N]")
        bx.set_title(f"planet 1 {1e6 * e_plot:g} um ahead, from the static balance")
        bx.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
