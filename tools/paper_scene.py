#!/usr/bin/env python3
"""Runs the paper's scene (Kosenko & Gusev 2012, test rig) through the packaged FMU with FMPy.

Usage: paper_scene.py <SpurGearMesh.fmu> <outdir>

Scene: constant drive torque tau_A = 100 N.m on A, viscous load c_load = 2 N.m.s/rad on B,
backlash 1e-4 m, w_A(0) = 100 rad/s, w_B(0) = 100/1.5 rad/s, stop 0.1 s, output every 1e-5 s,
chi = 0 (the paper: no damping). The same scene with chi = 10 s/m (about 3 % of critical damping
of the mesh vibration) is run for comparison.

Writes <outdir>/paper-scene.csv (chi = 0), <outdir>/paper-scene-damped.csv (chi = 10 s/m),
<outdir>/paper-scene.png, and prints a summary.

The paper's Fig. 7 (§6.2, rigid against compliant contact force): both cases again with
contact_model = 1 and 2 (rigid, locked from t = 0), output every 1e-6 s; the means of F_fwd over
whole mesh cycles are compared. Writes <outdir>/fig7-rigid-vs-compliant.png, fig7-traces.csv
(F_fwd, n_fwd, theta_A, w_A of the four runs, every 1e-5 s), fig7-cycles.csv (per-cycle means)
and fig7-summary.md, and prints the numbers.
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
CALCULATED = ["rAb", "rBb", "line_of_action", "contact_ratio", "base_pitch"]


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
    for k in ("width", "E_A", "E_B", "nu_A", "nu_B", "J_A", "J_B"):
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


# ---- Fig. 7 (paper §6.2): rigid contact against the compliant mesh ------------------------------
# The paper: the rigid contact force is "an averaging" of the compliant one. Claim checked here:
# the mean compliant F_fwd over a whole mesh cycle (2 pi/zA of rotation of A) equals the rigid F_fwd
# over the same cycle, up to the cycle-to-cycle change of the wheels' speeds (torque balance below).

FIG7_DT = 1e-6  # output interval of the Fig. 7 runs: the cycle means need fine sampling
FIG7_WINDOW = 0.02  # statistics over the mesh cycles that start at t >= 0.02 s (after the start transient)
FIG7_CSV_EVERY = 10  # fig7-traces.csv keeps every 10th sample (the 1e-5 s grid of paper-scene.csv)
FIG7_OUTPUTS = ["F_fwd", "F_bwd", "n_fwd", "n_bwd", "theta_A", "w_A", "w_B", "dte"]
FIG7_CASES = (("damped", CHI_DAMPED), ("undamped", 0.0))


def fig7_run(fmu, md, chi, contact_model, dt=FIG7_DT):
    """The paper scene with damping chi and the given contact model (1 Johnson, 2 rigid).
    dte_start = 0: the rigid contact is forward locked from t = 0, the compliant teeth just touch."""
    start = dict(SCENE, chi=chi, contact_model=contact_model, dte_start=0.0)
    return fmpy.simulate_fmu(
        fmu,
        model_description=md,
        start_time=0.0,
        stop_time=STOP,
        output_interval=dt,
        start_values=start,
        output=FIG7_OUTPUTS,
    )


class Trace:
    """A sampled run as piecewise-linear signals with a step at each forward gate switch.

    All pairs on a flank share delta, so a pair entering the gate at delta > 0 adds its whole
    force at once (F_fwd jumps by half or doubles) and w_A gets a kink there. The trapezoid rule
    across such a step errs by up to |jump| dt/2, about 1e-4 of a cycle mean at dt = 1e-6 s. Here
    the switch time is located from theta_A (a pair enters where its s_A - max(delta, 0) reaches
    s_a, i.e. at mesh phase max(dte, 0)/p_b, and leaves at s_b, phase eps - 1; t = 0 is phase 0
    with f1 at point a), and each signal is extrapolated linearly to it from its own side: the
    error of the integrals and of interpolated values becomes O(dt^2).
    `every` keeps every n-th sample (the same run at a coarser interval, for the sampling error).
    """

    def __init__(self, res, calc, every=1):
        t = res["time"][::every].astype(float)
        self.raw = {k: res[k][::every] for k in res.dtype.names}
        self.phase = self.raw["theta_A"] * calc["zA"] / (2 * math.pi)
        n_f = self.raw["n_fwd"]
        ph, dte = self.phase, self.raw["dte"]
        frac_out = calc["contact_ratio"] - 1.0
        sw = np.flatnonzero((n_f[:-1] != n_f[1:]) & (n_f[:-1] > 0) & (n_f[1:] > 0))
        ts, self.unlocated = [], 0
        for i in sw:
            if n_f[i + 1] > n_f[i]:
                target = round(ph[i]) + max(dte[i], 0.0) / calc["base_pitch"]
            else:
                target = round(ph[i] - frac_out) + frac_out
            s = t[i] + (target - ph[i]) / (ph[i + 1] - ph[i]) * (t[i + 1] - t[i])
            if not t[i] <= s <= t[i + 1]:
                self.unlocated += 1
                s = min(max(s, t[i]), t[i + 1])
            ts.append(s)
        self.switches = np.array(ts)
        # Augmented time axis: each switch time twice (left and right limits).
        ins = np.repeat(sw + 1, 2)
        self.t = np.insert(t, ins, np.repeat(self.switches, 2))
        self.sig = {}
        n = len(t)
        for name in ("F_fwd", "F_bwd", "w_A", "w_B"):
            y = self.raw[name].astype(float)
            left, right = [], []
            for i, s in zip(sw, ts):
                a = y[i] + (y[i] - y[i - 1]) / (t[i] - t[i - 1]) * (s - t[i]) if i > 0 else y[i]
                b = y[i + 1] + (y[i + 2] - y[i + 1]) / (t[i + 2] - t[i + 1]) * (s - t[i + 1]) if i + 2 < n else y[i + 1]
                left.append(a)
                right.append(b)
            both = np.column_stack([left, right]).ravel() if len(sw) else np.array([])
            self.sig[name] = np.insert(y, ins, both)
        self._cum = {}

    def value(self, name, tq):
        """Signal at times tq (linear between the augmented nodes; right limit at a switch)."""
        y, t = self.sig[name], self.t
        j = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, len(t) - 2)
        h = t[j + 1] - t[j]
        return y[j] + (y[j + 1] - y[j]) * np.divide(tq - t[j], h, out=np.zeros_like(h), where=h > 0)

    def integral(self, name, tq):
        """Integral of the signal from t = 0 to tq."""
        if name not in self._cum:
            y = self.sig[name]
            self._cum[name] = np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(self.t))])
        t = self.t
        j = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, len(t) - 2)
        return self._cum[name][j] + 0.5 * (self.sig[name][j] + self.value(name, tq)) * (tq - t[j])

    def cycles(self):
        """Whole mesh cycles by the angle of A: cycle k is theta_A in [k, k+1) * 2 pi/zA.
        Returns start times (one more than cycles), mean F_fwd and F_bwd per cycle, w_A at the starts."""
        k = np.arange(0, int(math.floor(self.phase[-1])) + 1)
        tb = np.interp(k, self.phase, self.raw["time"].astype(float))
        dt = np.diff(tb)
        return dict(
            t=tb,
            F=np.diff(self.integral("F_fwd", tb)) / dt,
            F_bwd=np.diff(self.integral("F_bwd", tb)) / dt,
            w_A=self.value("w_A", tb),
        )


def fig7_compare(comp, rigid, calc):
    """Per whole mesh cycle: mean compliant and rigid F_fwd, relative difference, and the kinetic
    term of the torque balance of A, which is that difference exactly (mu = 0, tau_B = 0, no
    backward contact): over any interval, mean F_fwd = (tau_A - J_A (w_A(end) - w_A(start))/T)/rAb,
    so mean F_c - mean F_r = J_A/rAb (dw_A_r/T_r - dw_A_c/T_c)."""
    c, r = comp.cycles(), rigid.cycles()
    n = min(len(c["F"]), len(r["F"]))
    k_a = calc["J_A"] / calc["rAb"]
    slope_c = np.diff(c["w_A"])[:n] / np.diff(c["t"])[:n]
    slope_r = np.diff(r["w_A"])[:n] / np.diff(r["t"])[:n]
    t0, t1 = c["t"][:n], c["t"][1 : n + 1]
    m = (comp.raw["time"][:, None] >= t0) & (comp.raw["time"][:, None] < t1)  # samples x cycles
    apart = ((comp.raw["n_fwd"] == 0) & (comp.raw["time"] > 0)) | (comp.raw["n_bwd"] > 0)
    return dict(
        k=np.arange(n),
        t0=t0,
        t1=t1,
        F_c=c["F"][:n],
        F_r=r["F"][:n],
        diff=c["F"][:n] - r["F"][:n],
        rel=(c["F"][:n] - r["F"][:n]) / r["F"][:n],
        kinetic=k_a * (slope_r - slope_c),
        F_bwd_max=float(max(np.max(np.abs(c["F_bwd"][:n])), np.max(np.abs(r["F_bwd"][:n])))),
        separated=(apart[:, None] & m).any(axis=0),
    )


def fig7_a_priori(calc, chi, t_window):
    """Order-of-magnitude bound on |mean F_c - mean F_r| / F over one mesh cycle starting at
    t >= t_window, from the parameters alone (linearized mesh; damped case only).

    The difference is m_eff (v(t0) - v(t1))/T (torque balance of A, with the vibratory part of w_A
    written through v = d(dte)/dt: J_A dw_A = rAb m_eff dv; 1/m_eff = rAb^2/J_A + rBb^2/J_B). After the
    start transient the mesh vibration is the periodic response to the gate switches: each switch
    moves the static deflection by dX = delta_single - delta_double and launches a vibration of
    speed amplitude <= w_n dX, which decays by q = exp(-chi F T/(2 m_eff)) per cycle (Hunt-Crossley:
    damping coefficient chi F). v at the cycle start changes from cycle to cycle only because the
    cycle shortens as the rig speeds up (dT per cycle): a switch j cycles back shifts in phase by
    w_n j dT, so |dv| <= 2 w_n^2 dX dT sum_j j q^j = 2 w_n^2 dX dT q/(1-q)^2. The start transient
    (amplitude <= delta_single from dte(0) = 0) adds 2 w_n delta_single exp(-chi F t_window/(2 m_eff)).
    w_n is the double-contact (stiffer) one, the Johnson tangent stiffness at the static load."""
    r_a, r_b = calc["rAb"], calc["rBb"]
    m_eff = 1.0 / (r_a**2 / calc["J_A"] + r_b**2 / calc["J_B"])
    e_star = 1.0 / ((1 - calc["nu_A"] ** 2) / calc["E_A"] + (1 - calc["nu_B"] ** 2) / calc["E_B"])
    f = SCENE["tau_A"] / r_a
    n_w = f / calc["width"]
    rho = calc["line_of_action"]
    k_double = 2 * calc["width"] * math.pi * e_star / (math.log(4 * math.pi * e_star * rho / (n_w / 2)) - 2)
    w_n = math.sqrt(k_double / m_eff)
    d_single = johnson_delta(n_w, rho, e_star)
    dx = d_single - johnson_delta(n_w / 2, rho, e_star)
    w_a = SCENE["w_A_start"]
    period = 2 * math.pi / (calc["zA"] * w_a)
    # Rigid-rolling acceleration of A (spec §2 exact check), at the start speed (its largest value).
    i = r_b / r_a
    dw = (SCENE["tau_A"] - SCENE["c_load"] * w_a / i**2) / (calc["J_A"] + calc["J_B"] / i**2)
    d_period = period * dw * period / w_a
    decay = chi * f / (2 * m_eff)
    q = math.exp(-decay * period)
    dv_drift = 2 * w_n**2 * dx * d_period * q / (1 - q) ** 2 if q < 1 else math.inf
    dv_start = 2 * w_n * d_single * math.exp(-decay * t_window)
    bound = m_eff * (dv_drift + dv_start) / period / f
    return dict(
        m_eff=m_eff, w_n=w_n, dX=dx, period=period, d_period=d_period, q=q,
        rel_drift=m_eff * dv_drift / period / f, rel_start=m_eff * dv_start / period / f, rel=bound,
    )


def fig7_stats(cmp, dcmp, t_window):
    """Numbers for the summary: cycles starting at t >= t_window; `dcmp` is the same comparison on
    every other sample (2 dt), whose change estimates the sampling error of the cycle means."""
    w = cmp["t0"] >= t_window
    n = min(len(cmp["k"]), len(dcmp["k"]))
    samp = np.abs(cmp["diff"][:n] - dcmp["diff"][:n]) / cmp["F_r"][:n]
    total = np.sum(cmp["diff"][w] * (cmp["t1"] - cmp["t0"])[w]) / np.sum(cmp["F_r"][w] * (cmp["t1"] - cmp["t0"])[w])
    return dict(
        window=t_window,
        n_cycles=int(len(cmp["k"])),
        n_window=int(np.sum(w)),
        first=int(cmp["k"][w][0]) if w.any() else None,
        max_rel=float(np.max(np.abs(cmp["rel"][w]))),
        median_rel=float(np.median(np.abs(cmp["rel"][w]))),
        window_mean_rel=float(total),
        max_rel_all=float(np.max(np.abs(cmp["rel"]))),
        separated_window=int(np.sum(cmp["separated"][w])),
        separated_all=int(np.sum(cmp["separated"])),
        max_kinetic_residual=float(np.max(np.abs(cmp["diff"] - cmp["kinetic"]) / cmp["F_r"])),
        sampling=float(np.max(samp[w[:n]])),
        F_r_range=(float(np.min(cmp["F_r"])), float(np.max(cmp["F_r"]))),
        F_bwd_max=cmp["F_bwd_max"],
    )


def fig7(fmu, md, calc, outdir):
    """Runs, compares, plots and writes the Fig. 7 outputs; returns {case: (stats, a priori)}."""
    runs, cmps, out = {}, {}, {}
    for case, chi in FIG7_CASES:
        rc, rr = fig7_run(fmu, md, chi, 1), fig7_run(fmu, md, chi, 2)
        runs[case] = (rc, rr)
        tc, tr = Trace(rc, calc), Trace(rr, calc)
        cmp = fig7_compare(tc, tr, calc)
        dcmp = fig7_compare(Trace(rc, calc, every=2), Trace(rr, calc, every=2), calc)
        cmps[case] = cmp
        unloc = tc.unlocated + tr.unlocated
        st = fig7_stats(cmp, dcmp, FIG7_WINDOW)
        st["unlocated_switches"] = unloc
        out[case] = (st, fig7_a_priori(calc, chi, FIG7_WINDOW))

    # ---- traces and per-cycle CSV ------------------------------------------------------------
    cols, data = ["time"], [runs["damped"][0]["time"][::FIG7_CSV_EVERY]]
    for case, _ in FIG7_CASES:
        for model, res in (("compliant", runs[case][0]), ("rigid", runs[case][1])):
            for name in ("F_fwd", "n_fwd", "theta_A", "w_A"):
                cols.append(f"{name}_{model}_{case}")
                data.append(res[name][::FIG7_CSV_EVERY])
    fmt = ["%d" if c.startswith("n_") else "%.17g" for c in cols]
    np.savetxt(outdir / "fig7-traces.csv", np.column_stack(data), fmt=fmt, delimiter=",", header=",".join(cols), comments="")
    rows = []
    for case, _ in FIG7_CASES:
        c = cmps[case]
        for j in range(len(c["k"])):
            rows.append(
                f"{case},{c['k'][j]},{c['t0'][j]:.9f},{c['t1'][j]:.9f},{c['F_c'][j]:.9f},{c['F_r'][j]:.9f},"
                f"{c['rel'][j]:.6e},{c['kinetic'][j]:.9f},{int(c['separated'][j])}"
            )
    (outdir / "fig7-cycles.csv").write_text(
        "case,cycle,t_start,t_end,F_fwd_mean_compliant,F_fwd_mean_rigid,rel_diff,kinetic_term,separated\n"
        + "\n".join(rows) + "\n"
    )

    # ---- figure ------------------------------------------------------------------------------
    t_mesh = 2 * math.pi / (calc["zA"] * SCENE["w_A_start"])
    fig = plt.figure(figsize=(15, 9), constrained_layout=True)
    gs = fig.add_gridspec(2, 4)
    for row, (case, chi) in enumerate(FIG7_CASES):
        rc, rr = runs[case]
        c = cmps[case]
        st = out[case][0]
        ax = fig.add_subplot(gs[row, :3])
        ax.plot(rc["time"] * 1e3, rc["F_fwd"], color="tab:blue", lw=0.5, label="compliant (Johnson)")
        ax.plot(rr["time"] * 1e3, rr["F_fwd"], color="tab:red", lw=1.4, label="rigid contact")
        mid = 0.5 * (c["t0"] + c["t1"]) * 1e3
        ax.plot(mid, c["F_c"], "o", color="k", ms=3, label="compliant, mean over each mesh cycle")
        ax.axvline(FIG7_WINDOW * 1e3, color="grey", ls=":", lw=0.8)
        ax.set_xlabel("t [ms]")
        ax.set_ylabel("F_fwd, forward normal force [N]")
        ax.set_ylim(0, 1.12 * np.max(rc["F_fwd"]))
        ax.set_title(
            f"({'a' if case == 'damped' else 'b'}) chi = {chi:g} s/m ({case}); cycles from t = {FIG7_WINDOW:g} s (dotted): "
            f"|mean compliant - rigid| / rigid max {st['max_rel']:.1e}, median {st['median_rel']:.1e}"
            + (f"; {st['separated_window']} of {st['n_window']} cycles separate" if st["separated_window"] else ""),
            fontsize=10,
        )
        ax.legend(loc="upper left", fontsize=8, ncol=3)
        # Detail (the paper's zoom): the last three whole mesh cycles.
        axz = fig.add_subplot(gs[row, 3])
        z0, z1 = c["t0"][-3], c["t1"][-1]
        m = (rc["time"] >= z0 - 0.05 * t_mesh) & (rc["time"] <= z1 + 0.05 * t_mesh)
        axz.plot(rc["time"][m] * 1e3, rc["F_fwd"][m], color="tab:blue", lw=0.8)
        axz.plot(rr["time"][m] * 1e3, rr["F_fwd"][m], color="tab:red", lw=1.4)
        for j in range(len(c["k"]) - 3, len(c["k"])):
            axz.hlines(c["F_c"][j], c["t0"][j] * 1e3, c["t1"][j] * 1e3, color="k", lw=1.2, ls="--")
            axz.axvline(c["t0"][j] * 1e3, color="grey", lw=0.5)
        axz.axvline(c["t1"][-1] * 1e3, color="grey", lw=0.5)
        axz.set_xlabel("t [ms]")
        axz.set_title("detail: last 3 mesh cycles (grey: cycle starts,\ndashed: compliant cycle means)", fontsize=9)
    fig.suptitle(
        "Fig. 7 (paper §6.2): rigid contact force (red) as the average of the compliant one (blue); "
        "paper scene, tau_A = 100 N.m, c_load = 2 N.m.s/rad"
    )
    png = outdir / "fig7-rigid-vs-compliant.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)

    # ---- summary -----------------------------------------------------------------------------
    lines = [
        "# Fig. 7: rigid contact against the compliant mesh (paper scene)",
        "",
        f"Whole mesh cycles by the angle of A (2 pi/zA = 2 pi/{calc['zA']}); output interval {FIG7_DT:g} s; "
        f"statistics over the cycles that start at t >= {FIG7_WINDOW:g} s. "
        "rel = (mean compliant F_fwd - mean rigid F_fwd)/mean rigid F_fwd per cycle. "
        "Sampling error: change of the cycle-mean difference at twice the output interval.",
        "",
        "| case | cycles (window) | max abs rel | median abs rel | rel over the window | max abs rel, all cycles | "
        "cycles with separation (window) | sampling error | a priori bound |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for case, chi in FIG7_CASES:
        st, ap = out[case]
        lines.append(
            f"| {case} (chi = {chi:g}) | {st['n_cycles']} ({st['n_window']}) | {st['max_rel']:.2e} | {st['median_rel']:.2e} | "
            f"{st['window_mean_rel']:+.2e} | {st['max_rel_all']:.2e} | {st['separated_window']} | {st['sampling']:.1e} | "
            + (f"{ap['rel']:.1e} |" if math.isfinite(ap["rel"]) else "none (undamped) |")
        )
    lines += [
        "",
        "The difference per cycle is the kinetic term of A's torque balance, J_A/rAb (dw_A_r/T_r - dw_A_c/T_c); "
        "largest |difference - kinetic term| / F: "
        + ", ".join(f"{case} {out[case][0]['max_kinetic_residual']:.1e}" for case, _ in FIG7_CASES)
        + ".",
        f"Rigid F_fwd over the run: {out['damped'][0]['F_r_range'][0]:.2f} .. {out['damped'][0]['F_r_range'][1]:.2f} N "
        f"(backward flank: largest cycle mean of |F_bwd| {max(out[c][0]['F_bwd_max'] for c, _ in FIG7_CASES):g} N).",
        "",
        "Files: fig7-rigid-vs-compliant.png, fig7-traces.csv (every "
        f"{FIG7_CSV_EVERY}th sample, {FIG7_DT * FIG7_CSV_EVERY:g} s), fig7-cycles.csv (per-cycle means).",
    ]
    (outdir / "fig7-summary.md").write_text("\n".join(lines) + "\n")
    return out


def fig7_print(out):
    print(f"== Fig. 7: rigid vs compliant F_fwd, means over whole mesh cycles starting at t >= {FIG7_WINDOW:g} s")
    for case, chi in FIG7_CASES:
        st, ap = out[case]
        print(
            f"  {case} (chi = {chi:g}): {st['n_window']} of {st['n_cycles']} cycles; |mean compliant - rigid|/rigid "
            f"max {st['max_rel']:.2e}, median {st['median_rel']:.2e}; over the whole window {st['window_mean_rel']:+.2e}; "
            f"all cycles max {st['max_rel_all']:.2e}"
        )
        print(
            f"    sampling error {st['sampling']:.1e} (dt vs 2 dt); difference - kinetic term of A's torque balance "
            f"<= {st['max_kinetic_residual']:.1e}; cycles with separation: {st['separated_window']} in the window, "
            f"{st['separated_all']} in all"
            + (f"; a priori bound {ap['rel']:.1e} (drift {ap['rel_drift']:.1e} + start {ap['rel_start']:.1e})"
               if math.isfinite(ap["rel"]) else "")
        )
        if st["unlocated_switches"]:
            print(f"    warning: {st['unlocated_switches']} gate switches not found in their sample interval")


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
    plt.close(fig)
    print(f"wrote {outdir / 'paper-scene.csv'}, {outdir / 'paper-scene-damped.csv'}, {png}")

    fig7_print(fig7(fmu, md, calc, outdir))
    print(
        f"wrote {outdir / 'fig7-rigid-vs-compliant.png'}, {outdir / 'fig7-traces.csv'}, "
        f"{outdir / 'fig7-cycles.csv'}, {outdir / 'fig7-summary.md'}"
    )


if __name__ == "__main__":
    main()
