#!/usr/bin/env python3
"""Runs the paper's scene (Kosenko & Gusev 2012, test rig) through the packaged FMU with FMPy.

Usage: paper_scene.py <SpurGearMesh.fmu> <outdir>

Scene: constant drive torque tau_A = 100 N.m on A, viscous load c_load = 2 N.m.s/rad on B,
backlash 1e-4 m, w_A(0) = 100 rad/s, w_B(0) = 100/1.5 rad/s, stop 0.1 s, output every 1e-5 s,
chi = 0 (the paper: no damping). The same scene with chi = 10 s/m (about 3 % of critical damping
of the mesh vibration) is run for comparison.

Writes <outdir>/paper-scene.csv (chi = 0), <outdir>/paper-scene-damped.csv (chi = 10 s/m),
<outdir>/paper-scene.png, and prints a summary.
"""

import math
import sys
from pathlib import Path

import numpy as np
import fmpy

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STOP = 0.1
DT = 1e-5
SCENE = dict(
    tau_A=100.0,
    c_load=2.0,
    backlash=1e-4,
    w_A_start=100.0,
    w_B_start=100.0 / 1.5,
)
CHI_DAMPED = 10.0
CALCULATED = ["rAb", "rBb", "line_of_action", "contact_ratio"]


def simulate(fmu, md, chi):
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    start = dict(SCENE, chi=chi)
    res = fmpy.simulate_fmu(
        fmu,
        model_description=md,
        start_time=0.0,
        stop_time=STOP,
        output_interval=DT,
        start_values=start,
        output=outputs,
    )
    return res, outputs


def calculated(fmu, md):
    """Calculated parameters of the scene (base radii, L, contact ratio) from an initialized instance."""
    from fmpy.fmi2 import FMU2Slave

    unzip = fmpy.extract(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzip,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="calc",
    )
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setReal([vr[k] for k in SCENE], list(SCENE.values()))
    s.exitInitializationMode()
    vals = dict(zip(CALCULATED, s.getReal([vr[k] for k in CALCULATED])))
    vals["zA"] = s.getInteger([vr["zA"]])[0]
    vals["zB"] = s.getInteger([vr["zB"]])[0]
    for k in ("width", "E_A", "E_B", "nu_A", "nu_B"):
        vals[k] = s.getReal([vr[k]])[0]
    s.terminate()
    s.freeInstance()
    return vals


def write_csv(path, res, names):
    cols = ["time"] + names
    data = np.column_stack([res[c].astype(float) for c in cols])
    fmt = ["%.17g"] * len(cols)
    for j, c in enumerate(cols):
        if res.dtype[c].kind in "iub":
            fmt[j] = "%d"
    np.savetxt(path, data, fmt=fmt, delimiter=",", header=",".join(cols), comments="")


def johnson_delta(n_per_width, rho, e_star):
    """Johnson line contact (spec §4): penetration for a force per unit width (explicit in N)."""
    return n_per_width / (math.pi * e_star) * (math.log(4 * math.pi * e_star * rho / n_per_width) - 1)


def spans(mask, t):
    """Time intervals [t0, t1] where a sampled mask is true (ends at the neighbouring samples' midpoints)."""
    m = np.concatenate([[False], mask, [False]]).astype(int)
    d = np.diff(m)
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1
    half = 0.5 * DT
    return [(max(t[a] - half, t[0]), min(t[b] + half, t[-1])) for a, b in zip(starts, ends)]


def stats(res, z_a):
    """Contact statistics: time fractions, per-mesh-cycle double contact, F_f1 = F_f2 check, speed ratio."""
    n_f, n_b = res["n_fwd"], res["n_bwd"]
    n_tot = n_f + n_b
    out = dict(
        double=float(np.mean(n_tot == 2)),
        single=float(np.mean(n_tot == 1)),
        none=float(np.mean(n_tot == 0)),
        backward=float(np.mean(n_b > 0)),
    )
    # Mesh cycles by the angle of A: cycle k is theta_A in [k, k+1) * 2 pi/zA (t = 0 starts one,
    # with f1 entering at point a). Only complete cycles count.
    cyc = np.floor(res["theta_A"] * z_a / (2 * math.pi)).astype(int)
    fracs, clean = [], []
    # The t = 0 sample does not count as a separation: the teeth just touch there (dte = 0).
    apart = (n_tot == 0) & (res["time"] > 0)
    for k in range(cyc.min(), cyc.max()):
        m = cyc == k
        if not m.any():
            continue
        sep = bool(np.any(apart[m]) or np.any(n_b[m] > 0))
        fracs.append((k, float(np.mean(n_f[m] == 2)), sep))
        if not sep:
            clean.append(fracs[-1][1])
    out["cycles"] = fracs
    out["clean_double"] = clean
    d2 = n_f == 2
    out["max_dF_double"] = float(np.max(np.abs(res["F_f1"][d2] - res["F_f2"][d2]))) if d2.any() else float("nan")
    out["max_F_double"] = float(np.max(res["F_f1"][d2])) if d2.any() else float("nan")
    # Mean speed ratio over whole mesh cycles (the ratio oscillates at the mesh frequency).
    full = (cyc >= 0) & (cyc < cyc.max())
    out["ratio"] = float(np.mean(res["w_A"][full]) / np.mean(res["w_B"][full]))
    out["n_events"] = int(res["n_events"][-1])
    return out


def summary(title, s, z_a, z_b):
    print(f"== {title}")
    print(
        f"  time in contact: double {100 * s['double']:.1f} %, single {100 * s['single']:.1f} %, "
        f"none {100 * s['none']:.1f} % (backward flank {100 * s['backward']:.1f} %); {s['n_events']} events"
    )
    sep = [k for k, _, bad in s["cycles"] if bad]
    clean = s["clean_double"]
    if clean:
        print(
            f"  double-contact fraction per mesh cycle without separation ({len(clean)} of {len(s['cycles'])} "
            f"cycles): mean {100 * np.mean(clean):.1f} %, range {100 * min(clean):.1f}..{100 * max(clean):.1f} % "
            f"(contact ratio 1.1 -> 10 %; sampled every {DT:g} s, ~0.35 % of a cycle)"
        )
    else:
        print("  every mesh cycle has separations")
    if sep:
        print(f"  cycles with separation or backward contact: first {sep[0]}, {len(sep)} in all")
    print(
        f"  max |F_f1 - F_f2| in double contact: {s['max_dF_double']:.3g} N "
        f"(forces up to {s['max_F_double']:.0f} N)"
    )
    print(f"  mean w_A / w_B over whole mesh cycles: {s['ratio']:.6f} (zB/zA = {z_b / z_a:.6f})")


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        sys.exit(2)
    fmu, outdir = sys.argv[1], Path(sys.argv[2])
    outdir.mkdir(parents=True, exist_ok=True)
    md = fmpy.read_model_description(fmu)
    calc = calculated(fmu, md)
    z_a, z_b = calc["zA"], calc["zB"]

    res0, names = simulate(fmu, md, 0.0)
    res1, _ = simulate(fmu, md, CHI_DAMPED)
    write_csv(outdir / "paper-scene.csv", res0, names)
    write_csv(outdir / "paper-scene-damped.csv", res1, names)

    # Static penetrations under tau_A (reference lines): sum F_n = tau_A/rAb, shared by 1 or 2 pairs.
    e_star = 1.0 / ((1 - calc["nu_A"] ** 2) / calc["E_A"] + (1 - calc["nu_B"] ** 2) / calc["E_B"])
    n_tot = SCENE["tau_A"] / calc["rAb"] / calc["width"]
    rho = calc["line_of_action"]
    d_single = johnson_delta(n_tot, rho, e_star)
    d_double = johnson_delta(n_tot / 2, rho, e_star)
    f_static = SCENE["tau_A"] / calc["rAb"]

    s0, s1 = stats(res0, z_a), stats(res1, z_a)
    print(
        f"paper scene: tau_A = {SCENE['tau_A']} N.m, c_load = {SCENE['c_load']} N.m.s/rad, backlash = "
        f"{SCENE['backlash']} m, w_A(0) = {SCENE['w_A_start']} rad/s, contact ratio {calc['contact_ratio']:.4f}"
    )
    print(
        f"static load: F = tau_A/rAb = {f_static:.1f} N; penetration single {d_single:.4e} m, "
        f"double {d_double:.4e} m (each pair {f_static / 2:.1f} N)"
    )
    summary("chi = 0 (paper scene): out/paper-scene.csv", s0, z_a, z_b)
    summary(f"chi = {CHI_DAMPED} s/m (damped): out/paper-scene-damped.csv", s1, z_a, z_b)

    # ---- figure ------------------------------------------------------------------------------
    um = 1e6
    t0, t1 = res0["time"], res1["time"]
    t_mesh = 2 * math.pi / (z_a * SCENE["w_A_start"])
    fig = plt.figure(figsize=(13, 15), constrained_layout=True)
    gs = fig.add_gridspec(5, 2)

    ax = fig.add_subplot(gs[0, :])
    ax.plot(t1 * 1e3, res1["dte"] * um, color="tab:orange", lw=0.8, label=f"chi = {CHI_DAMPED:g} s/m")
    ax.plot(t0 * 1e3, res0["dte"] * um, color="tab:blue", lw=0.6, label="chi = 0 (paper scene)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_ylabel("dte [um]")
    ax.set_xlabel("t [ms]")
    ax.set_title("(a) dynamic transmission error over the run (below 0: teeth apart, inside the backlash)")
    ax.legend(loc="lower left")

    ax = fig.add_subplot(gs[1, :])
    for name, c in (("F_f1", "tab:blue"), ("F_f2", "tab:red"), ("F_b1", "tab:green"), ("F_b2", "tab:purple")):
        ax.plot(t0 * 1e3, res0[name], color=c, lw=0.6, label=name)
    ax.axhline(f_static, color="k", ls="--", lw=0.7, label="tau_A/rAb")
    ax.set_ylabel("normal force [N]")
    ax.set_xlabel("t [ms]")
    ax.set_ylim(top=1.25 * max(np.max(res0[n]) for n in ("F_f1", "F_f2", "F_b1", "F_b2")))
    ax.set_title("(b) contact forces, chi = 0: the switches pump the mesh vibration until the teeth rattle")
    ax.legend(loc="upper left", ncol=5)

    def zoom(col, res, t_from, title, s):
        t = res["time"]
        m = (t >= t_from) & (t <= t_from + 3 * t_mesh)
        tz = t[m]
        dbl = spans(res["n_fwd"][m] == 2, tz)
        none = spans((res["n_fwd"][m] + res["n_bwd"][m]) == 0, tz)
        axd = fig.add_subplot(gs[2, col])
        axf = fig.add_subplot(gs[3, col], sharex=axd)
        for a in (axd, axf):
            for i, (u, v) in enumerate(dbl):
                a.axvspan(u * 1e3, v * 1e3, color="gold", alpha=0.35, lw=0, label="double contact" if i == 0 else None)
            for i, (u, v) in enumerate(none):
                a.axvspan(u * 1e3, v * 1e3, color="grey", alpha=0.2, lw=0, label="no contact" if i == 0 else None)
        axd.plot(tz * 1e3, res["dte"][m] * um, color="tab:blue", lw=1.0, label="dte")
        axd.axhline(d_single * um, color="k", ls="--", lw=0.7, label=f"static single {d_single * um:.2f} um")
        axd.axhline(d_double * um, color="k", ls=":", lw=0.9, label=f"static double {d_double * um:.3f} um")
        axd.set_ylabel("dte [um]")
        axd.set_title(title)
        axd.legend(loc="upper right", fontsize=7)
        axf.plot(tz * 1e3, res["F_f1"][m], color="tab:blue", lw=1.6, label="F_f1")
        axf.plot(tz * 1e3, res["F_f2"][m], color="tab:red", lw=1.0, ls="--", label="F_f2")
        axf.axhline(f_static, color="k", ls="--", lw=0.7, label="tau_A/rAb")
        axf.axhline(f_static / 2, color="k", ls=":", lw=0.9, label="tau_A/rAb/2")
        axf.set_ylabel("normal force [N]")
        axf.set_xlabel("t [ms]")
        axf.legend(loc="upper right", fontsize=7)
        axf.text(0.01, 0.95, f"whole run: max |F_f1 - F_f2| in double contact = {s['max_dF_double']:.3g} N",
                 transform=axf.transAxes, fontsize=8, va="top")
        return axd, axf

    zoom(0, res0, 0.0, "(c) chi = 0, first 3 mesh cycles: dte drops when the 2nd pair enters, F_f1 = F_f2", s0)
    t_last = t1[-1] - 3 * t_mesh * 1.02
    zoom(1, res1, t_last, f"(d) chi = {CHI_DAMPED:g} s/m, last 3 mesh cycles (period {t_mesh * 1e3:.2f} ms)", s1)

    ax = fig.add_subplot(gs[4, 0])
    ax.plot(t0 * 1e3, res0["w_A"] / res0["w_B"], color="tab:blue", lw=0.5, label="chi = 0")
    ax.plot(t1 * 1e3, res1["w_A"] / res1["w_B"], color="tab:orange", lw=0.5, label=f"chi = {CHI_DAMPED:g} s/m")
    ax.axhline(z_b / z_a, color="k", ls="--", lw=0.7, label="zB/zA")
    ax.set_ylabel("w_A / w_B")
    ax.set_xlabel("t [ms]")
    ax.set_title("(e) speed ratio")
    ax.legend(loc="upper right", fontsize=7)

    ax = fig.add_subplot(gs[4, 1])
    for s, lab, c in ((s0, "chi = 0", "tab:blue"), (s1, f"chi = {CHI_DAMPED:g} s/m", "tab:orange")):
        k = np.array([c_[0] for c_ in s["cycles"]])
        f = np.array([c_[1] for c_ in s["cycles"]]) * 100
        sep = np.array([c_[2] for c_ in s["cycles"]])
        ax.plot(k[~sep], f[~sep], "o", color=c, ms=4, label=f"{lab}: cycles without separation")
        ax.plot(k[sep], f[sep], "x", color=c, ms=5, label=f"{lab}: cycles with separation")
    ax.axhline(100 * (calc["contact_ratio"] - 1), color="k", ls="--", lw=0.7, label="contact ratio - 1")
    ax.set_xlabel("mesh cycle (by theta_A)")
    ax.set_ylabel("double contact [% of cycle]")
    ax.set_title("(f) double-contact share per mesh cycle")
    ax.legend(loc="upper right", fontsize=7)

    fig.suptitle(
        "SpurGearMesh, paper scene: tau_A = 100 N.m, c_load = 2 N.m.s/rad, backlash 0.1 mm, "
        "w_A(0) = 100 rad/s, zA/zB = 22/33"
    )
    png = outdir / "paper-scene.png"
    fig.savefig(png, dpi=110)
    print(f"wrote {outdir / 'paper-scene.csv'}, {outdir / 'paper-scene-damped.csv'}, {png}")


if __name__ == "__main__":
    main()
