#!/usr/bin/env python3
"""Dynamic-factor maps and the run-up / run-down through the first mesh resonance (issue 11).

Usage:
    .venv/bin/python tools/dynamic_factor.py [--fmu target/fmu/SpurGearMesh.fmu]
        [--workers N | --scheduler tcp://host:8786] [--docs docs] [--data out/studies] [--quick]

1. K_v = F_max / F_static over speed x torque, F_static = tau_A / rAb (the static mesh force),
   for two rigs: the paper's (scenes/damped.toml: 22/33 teeth, contact ratio 1.1, chi = 10 s/m)
   and a standard pair (20/40 teeth, module 4 mm, 20 deg, contact ratio 1.64; RIGS below).
   Each point holds a speed: running start at w_A_start = w, w_B_start = w zA/zB, and the
   viscous load c_load = tau_A (zB/zA)^2 / w whose steady state is that speed, so the rig neither
   speeds up nor slows down; dte_start is the quasi-static penetration, and the statistics skip
   the settling time (stats_start).
2. Run-up and run-down of the paper rig through its first mesh resonance at a constant mean
   mesh force: constant torques tau_A = F rAb + J_A a, tau_B = J_B a zA/zB - F rBb (c_load = 0)
   make w_A a straight ramp of slope +-a while the mesh carries F on average. One long run per
   direction, so every window starts from the previous window's final state; its statistics come
   from differences of the FMU's running statistics at the window's ends. Run at two ramp rates:
   the branches must not depend on the rate (quasi-static sweep).

Writes <docs>/dynamic-factor.png, dynamic-factor.csv, run-up-down.png, run-up-down.csv; the map
points are kept in <data>/dynamic-factor-<rig>.parquet (a re-run skips the points done; a
rebuilt FMU or changed rig runs them all again).
"""

from __future__ import annotations

import argparse
import hashlib
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import sweep as S  # noqa: E402

ROOT = S.ROOT
sys.path.insert(0, str(ROOT / "tests"))
from reference_model import gearmesh_ref as G  # noqa: E402  (Johnson's law, quasi-static dte)

STEEL_DENSITY = 7850.0


def disc_inertia(radius, width):
    """A solid steel disc: how the FMU's defaults for the paper rig were chosen, too."""
    return 0.5 * STEEL_DENSITY * math.pi * width * radius**4


# The standard pair: 20/40 teeth, module 4 mm, 20 deg, no profile shift, addendum 1, 20 mm face,
# steel, solid-disc wheels of the pitch radii (40 and 80 mm). chi = 1 s/m gives the mesh about 3 %
# of critical damping at 50 N.m (Hunt-Crossley damping is chi times the force, so it scales with
# the load).
STANDARD = dict(
    geometry=2, zA=20, zB=40, module=0.004, width=0.02, backlash=1e-4, chi=1.0,
    J_A=disc_inertia(0.040, 0.02), J_B=disc_inertia(0.080, 0.02),
)

# Per rig: base start values, speed grid (w_A, rad/s), torque grid (tau_A, N.m), settling time
# (stats_start) and run length. Settling: the slowest start transient, at the lowest torque,
# decays as exp(-zeta w_n t) with zeta w_n = chi F_static / (2 m_e); the settling time is >= 8 of
# those time constants (see docs/studies.md).
RIGS = {
    "paper": dict(
        base=None,  # scenes/damped.toml
        speeds=(40.0, 900.0, 44),
        torques=(25.0, 400.0, 16),
        stats_start=0.1,
        stop_time=0.2,
    ),
    "standard": dict(
        base=STANDARD,
        speeds=(200.0, 5000.0, 49),
        torques=(10.0, 150.0, 15),
        stats_start=0.03,
        stop_time=0.05,
    ),
}
QUICK = dict(speeds_n=6, torques_n=3)
CSV_COLUMNS = ["rig", "w_A", "tau_A", "mesh_frequency_Hz", "F_static", "F_max", "K_v", "dte_mean", "dte_std",
               "dte_min", "dte_max", "separated_fraction", "t_backward", "w_A_stats_start", "w_A_end",
               "status", "error"]

# Run-up / run-down: paper rig, tau_A = 100 N.m worth of mean mesh force, chi = 10 s/m.
RAMP = dict(torque=100.0, w_lo=100.0, w_hi=550.0, rates=(20.0, 10.0), window=2.0)


# ---------------------------------------------------------------------------------------------
# Rig data from the FMU and the reference model
# ---------------------------------------------------------------------------------------------

def rig_base(name):
    if RIGS[name]["base"] is not None:
        return dict(RIGS[name]["base"])
    start, _ = S.load_scene(ROOT / "scenes" / "damped.toml")
    return start


def rig_constants(fmu, base):
    """rAb, rBb, zA, zB, J_A, J_B and the pairs in contact at t = 0, from the FMU itself."""
    import fmpy

    names = ["rAb", "rBb", "n_fwd"]
    r = fmpy.simulate_fmu(str(fmu), stop_time=1e-9, output_interval=1e-9, output=names,
                          start_values=dict(base, dte_start=1e-7))
    md = {v.name: v for v in fmpy.read_model_description(str(fmu)).modelVariables}
    const = {n: float(r[n][0]) for n in names}
    for n in ("zA", "zB", "J_A", "J_B"):
        const[n] = float(base.get(n, md[n].start))
    return const


def quasi_static_dte(start, const):
    """The reference model's quasi-static penetration (Johnson's law) for these start values;
    the FMU-only parameters (statistics) do not enter it."""
    known = {k: v for k, v in start.items() if k in G.DEFAULTS}
    return G.quasi_static_dte(known, int(const["n_fwd"]))


def held_speed_point(base, const, w, tau):
    """Start values that hold w_A = w at the drive torque tau (see the module docstring)."""
    ratio = const["zB"] / const["zA"]
    start = dict(base, tau_A=tau, w_A_start=w, w_B_start=w / ratio, c_load=tau * ratio**2 / w)
    start["dte_start"] = quasi_static_dte(start, const)
    return start


# ---------------------------------------------------------------------------------------------
# 1. Dynamic-factor maps
# ---------------------------------------------------------------------------------------------

def map_points(name, base, const, quick):
    rig = RIGS[name]
    ws = np.linspace(*rig["speeds"][:2], QUICK["speeds_n"] if quick else rig["speeds"][2])
    taus = np.linspace(*rig["torques"][:2], QUICK["torques_n"] if quick else rig["torques"][2])
    points = []
    for w in ws:
        for tau in taus:
            start = held_speed_point(base, const, float(w), float(tau))
            start.update(statistics=True, stats_start=rig["stats_start"])
            points.append({"key": {"w_A": float(w), "tau_A": float(tau)}, "start": start})
    return points


def run_map(client, fmu_bytes, fmu, name, data_dir, quick):
    """One rig's map through tools/sweep.py's machinery; returns its table with K_v."""
    import pandas as pd

    base = rig_base(name)
    const = rig_constants(fmu, base)
    rig = RIGS[name]
    points = map_points(name, base, const, quick)
    meta = {"study": "dynamic-factor", "rig": name, "base": base, "stop_time": rig["stop_time"],
            "stats_start": rig["stats_start"], "varied": ["w_A", "tau_A"],
            "fmu_sha256": hashlib.sha256(fmu_bytes).hexdigest()}
    out = Path(data_dir) / f"dynamic-factor-{name}{'-quick' if quick else ''}.parquet"
    rows, new, elapsed = S.sweep(points, ["w_A", "tau_A"], str(out), meta, client, fmu_bytes,
                                 rig["stop_time"], 4, 300.0, replace_other=True)
    if new:
        print(f"{name}: {S.summary(new, elapsed, n_workers(client))}", file=sys.stderr)
    df = pd.DataFrame(rows)
    window = rig["stop_time"] - rig["stats_start"]
    df.insert(0, "rig", name)
    df["F_static"] = df["tau_A"] / const["rAb"]
    df["K_v"] = df["F_max"] / df["F_static"]
    df["separated_fraction"] = df["t_separated"] / window
    df["mesh_frequency_Hz"] = df["w_A"] * const["zA"] / (2 * math.pi)
    return df, const


def n_workers(client):
    return len(client.scheduler_info(n_workers=-1)["workers"])


def plot_maps(tables, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    from matplotlib.ticker import FormatStrFormatter

    fig, axes = plt.subplots(1, len(tables), figsize=(6.4 * len(tables), 4.8), squeeze=False)
    for ax, (name, (df, const)) in zip(axes[0], tables.items()):
        ok = df["status"] == S.STATUS_OK
        grid = df.assign(v=df["K_v"].where(ok)).pivot_table(
            index="tau_A", columns="w_A", values="v", dropna=False)
        sep = df.assign(v=df["separated_fraction"].where(ok)).pivot_table(
            index="tau_A", columns="w_A", values="v", dropna=False)
        xs, ys = grid.columns.to_numpy(float), grid.index.to_numpy(float)
        z = grid.to_numpy(float)
        norm = LogNorm(vmin=1.0, vmax=max(2.0, np.nanmax(z)))  # a few impact points reach K_v > 10
        m = ax.pcolormesh(S._edges(xs), S._edges(ys), z, shading="flat", cmap="magma", norm=norm)
        cb = fig.colorbar(m, ax=ax, label="K_v = F_max / (tau_A / rAb)")
        cb.ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
        cb.ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
        if len(xs) > 1 and len(ys) > 1 and np.nanmax(sep.to_numpy(float)) > 0:
            ax.contour(xs, ys, sep.to_numpy(float) > 0, levels=[0.5], colors="cyan", linewidths=1.0)
        ax.set_xlabel("w_A [rad/s] (held speed of the pinion)")
        ax.set_ylabel("tau_A [N.m]")
        za = const["zA"]
        sec = ax.secondary_xaxis("top", functions=(lambda w, za=za: w * za / (2e3 * math.pi),
                                                   lambda f, za=za: f * 2e3 * math.pi / za))
        sec.set_xlabel("mesh frequency [kHz]")
        ax.set_title(f"{name} rig: {int(const['zA'])}/{int(const['zB'])} teeth "
                     "(cyan: teeth separate)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# 2. Run-up / run-down
# ---------------------------------------------------------------------------------------------

def ramp_start(base, const, force, w0, rate):
    """Constant torques that ramp w_A at `rate` [rad/s^2] from w0 with mean mesh force `force`:
    A: J_A a = tau_A - F rAb; B: J_B a zA/zB = F rBb + tau_B (mu = 0, c_load = 0)."""
    ratio = const["zB"] / const["zA"]
    start = dict(base, c_load=0.0, w_A_start=w0, w_B_start=w0 / ratio,
                 tau_A=force * const["rAb"] + const["J_A"] * rate,
                 tau_B=const["J_B"] * rate / ratio - force * const["rBb"],
                 statistics=True, stats_start=0.0)
    # The quasi-static penetration of the held-speed rig with the same mean force.
    start["dte_start"] = quasi_static_dte(
        dict(start, tau_A=force * const["rAb"], tau_B=0.0, c_load=force * const["rBb"] / (w0 / ratio)), const)
    return start


def ramp_task(fmu_bytes, digest, start, t_end, n_windows):
    """Worker task: one long run, a communication step per window; per window the statistics
    from differences of the running ones (integrals of dte and dte^2, times separated and
    backward), exact along the internal steps. stats_start = 0, so they cover [0, t]."""
    runner = S.runner_of(fmu_bytes, digest)
    runner.start(start, t_end)
    rows, fmu_time = [], 0.0
    try:
        prev = dict(t=0.0, w=start["w_A_start"], i1=0.0, i2=0.0, sep=0.0, bwd=0.0)
        for k in range(n_windows):
            t0, t1 = t_end * k / n_windows, t_end * (k + 1) / n_windows
            fmu_time += runner.step(t0, t1 - t0)
            mean, rms = runner.get("dte_mean"), runner.get("dte_rms")
            cur = dict(t=t1, w=runner.get("w_A"), i1=mean * t1, i2=rms * rms * t1,
                       sep=runner.get("t_separated"), bwd=runner.get("t_backward"))
            dt = t1 - t0
            m1, m2 = (cur["i1"] - prev["i1"]) / dt, (cur["i2"] - prev["i2"]) / dt
            rows.append(dict(t_start=t0, t_end=t1, w_A=0.5 * (prev["w"] + cur["w"]),
                             dte_mean=m1, dte_std=math.sqrt(max(m2 - m1 * m1, 0.0)),
                             separated_fraction=(cur["sep"] - prev["sep"]) / dt,
                             backward_fraction=(cur["bwd"] - prev["bwd"]) / dt))
            prev = cur
    finally:
        runner.free()
    return rows, fmu_time


def run_ramps(client, fmu_bytes, fmu, quick):
    """Up and down at each rate, in parallel on the cluster; returns one table."""
    import pandas as pd

    base = rig_base("paper")
    const = rig_constants(fmu, base)
    force = RAMP["torque"] / const["rAb"]
    future, digest = S.ship_fmu(client, fmu_bytes)
    rates = RAMP["rates"][:1] if quick else RAMP["rates"]
    span = RAMP["w_hi"] - RAMP["w_lo"]
    if quick:
        span = 60.0
    jobs = {}
    for rate in rates:
        rate_q = rate * (10.0 if quick else 1.0)
        for direction, w0, a in (("up", RAMP["w_lo"], rate_q), ("down", RAMP["w_lo"] + span, -rate_q)):
            start = ramp_start(base, const, force, w0, a)
            t_end = span / rate_q
            n = int(round(span / RAMP["window"]))
            jobs[(direction, rate_q)] = client.submit(ramp_task, future, digest, start, t_end, n, pure=False)
    frames = []
    for (direction, rate), f in jobs.items():
        rows, fmu_time = f.result()
        print(f"ramp {direction} at {rate:g} rad/s^2: {rows[-1]['t_end']:.1f} s simulated, "
              f"fmi2DoStep {fmu_time:.2f} s", file=sys.stderr)
        frames.append(pd.DataFrame(rows).assign(direction=direction, rate=rate))
    df = pd.concat(frames, ignore_index=True)
    df["F_mean"] = force
    df["mesh_frequency_Hz"] = df["w_A"] * const["zA"] / (2 * math.pi)
    return df


def jumps(df, factor=1.5):
    """Per run, the windows where the dte fluctuation (RMS about the mean) changes by more than
    `factor` from one window to the next: [(speed, ratio)], the jumps of the branches."""
    out = {}
    for (direction, rate), d in df.groupby(["direction", "rate"]):
        s, w = d["dte_std"].to_numpy(), d["w_A"].to_numpy()
        ratio = s[1:] / s[:-1]
        big = np.flatnonzero(np.abs(np.log(ratio)) > math.log(factor))
        out[(direction, rate)] = [(0.5 * (w[k] + w[k + 1]), float(ratio[k])) for k in big]
    return out


def plot_ramps(df, fixed, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8.5, 6.4), sharex=True)
    styles = {"up": ("tab:blue", "run-up"), "down": ("tab:red", "run-down")}
    for (direction, rate), d in df.groupby(["direction", "rate"]):
        color, label = styles[direction]
        ls = "-" if rate == df["rate"].max() else ":"  # the slower ramp dotted, under it where equal
        a1.plot(d["w_A"], 1e6 * d["dte_std"], ls, color=color, label=f"{label}, {rate:g} rad/s²")
        a2.plot(d["w_A"], d["separated_fraction"], ls, color=color)
    if fixed is not None and len(fixed):
        a1.plot(fixed["w_A"], 1e6 * fixed["dte_std"], "k.", ms=5, label="fixed speed, quasi-static start")
        a2.plot(fixed["w_A"], fixed["separated_fraction"], "k.", ms=5)
    a1.set_ylabel("RMS of dte - mean [um]")
    a2.set_ylabel("time separated / window")
    a2.set_xlabel("w_A [rad/s]")
    a1.legend(fontsize=8)
    a1.set_title(f"paper rig, mean mesh force {df['F_mean'].iloc[0]:.0f} N (tau_A = {RAMP['torque']:g} N.m), "
                 "chi = 10 s/m: jump and hysteresis", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fmu", default=str(S.DEFAULT_FMU))
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--scheduler", default=None)
    ap.add_argument("--docs", default=str(ROOT / "docs"))
    ap.add_argument("--data", default=str(ROOT / "out" / "studies"))
    ap.add_argument("--quick", action="store_true", help="coarse grids and short ramps (smoke test)")
    args = ap.parse_args(argv)
    import pandas as pd

    fmu_bytes = Path(args.fmu).read_bytes()
    S.check_variables(S.model_variables(args.fmu), [], S.STATS)
    docs = Path(args.docs)
    docs.mkdir(parents=True, exist_ok=True)
    client = S.make_client(args.workers or os.cpu_count() or 1, args.scheduler)
    t0 = time.perf_counter()
    try:
        tables = {name: run_map(client, fmu_bytes, args.fmu, name, args.data, args.quick) for name in RIGS}
        ramps = run_ramps(client, fmu_bytes, args.fmu, args.quick)
    finally:
        client.close()
        if not args.scheduler and client.cluster is not None:
            client.cluster.close()
    maps = pd.concat([df for df, _ in tables.values()], ignore_index=True)
    maps["dte_std"] = np.sqrt(np.maximum(maps["dte_rms"] ** 2 - maps["dte_mean"] ** 2, 0.0))
    maps[CSV_COLUMNS].to_csv(docs / "dynamic-factor.csv", index=False, float_format="%.6g")
    plot_maps(tables, docs / "dynamic-factor.png")
    fixed = maps[(maps["rig"] == "paper") & (maps["tau_A"] == RAMP["torque"]) & (maps["status"] == S.STATUS_OK)
                 & maps["w_A"].between(ramps["w_A"].min(), ramps["w_A"].max())]
    ramps.to_csv(docs / "run-up-down.csv", index=False, float_format="%.6g")
    plot_ramps(ramps, fixed, docs / "run-up-down.png")
    report(maps, ramps)
    print(f"{time.perf_counter() - t0:.1f} s; wrote {docs}/dynamic-factor.png, dynamic-factor.csv, "
          "run-up-down.png, run-up-down.csv", file=sys.stderr)
    return 0


def report(maps, ramps):
    """The numbers docs/studies.md quotes."""
    for rig, d in maps.groupby("rig"):
        ok = d[d["status"] == S.STATUS_OK]
        top = ok.loc[ok["K_v"].idxmax()] if len(ok) else None
        print(f"{rig}: {len(ok)}/{len(d)} points ok; K_v {ok['K_v'].min():.3f}..{ok['K_v'].max():.3f}"
              + (f", largest at w_A = {top['w_A']:.0f} rad/s, tau_A = {top['tau_A']:.0f} N.m" if top is not None else "")
              + f"; separated at {int((ok['t_separated'] > 0).sum())} points")
    for (direction, rate), js in sorted(jumps(ramps).items()):
        text = ", ".join(f"{w:.0f} rad/s (x {r:.2f})" for w, r in js) or "none"
        print(f"ramp {direction} at {rate:g} rad/s^2: jumps of the dte RMS at w_A = {text}")


if __name__ == "__main__":
    sys.exit(main())
