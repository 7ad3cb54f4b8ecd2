"""How well the co-simulated two-stage drivetrain (engine, two gear stages, shaft) matches the
monolithic train (issue 24, points 3-4).

    .venv/bin/python cosim/drivetrain.py ssp          # target/cosim/two-stage.ssp (FMUs in target/fmu)
    .venv/bin/python cosim/drivetrain_study.py        # about 5 minutes on 2 cores

Runs the monolithic SpurGearTrain (the reference) and the co-simulation at communication steps
h = 1e-3 ... 1e-6 s in four masters: libcosim and FMPy's simulate_ssp on the .ssp, and a master
of our own (cosim/drivetrain.py run_master) with held inputs and with input derivatives.
Measures every mesh's dte error and the shaft torque error (max over the run, on the reference's
output grid), the observed order, the coupling's stability limit (linear theory and the measured
blow-up) against the shaft's frequency, and the CPU time of each run.  Writes
docs/cosim-accuracy.png, out/cosim-study.json, and the generated block of docs/cosim.md (between
its "study" markers): the numbers in that page come from here.
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.linalg import expm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "cosim"))
import drivetrain as D  # noqa: E402

HS = [1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6, 1e-6]
Q3 = ["mesh1.dte", "mesh2.dte", "shaft.tau"]
MASTERS = {  # name -> (label, runner(h, T))
    "libcosim": ("libcosim (.ssp)", lambda h, T, ssp: D.run_libcosim_ssp(ssp, h, T)),
    "fmpy": ("FMPy simulate_ssp (.ssp)", lambda h, T, ssp: D.run_fmpy_ssp(ssp, h, T)),
    "jacobi": ("own master, Jacobi, held inputs", lambda h, T, ssp: D.run_master(h, T, dt_out=max(h, 1e-5))),
    "jacobi+d": ("own master, Jacobi, input derivatives",
                 lambda h, T, ssp: D.run_master(h, T, derivatives=1, dt_out=max(h, 1e-5))),
}
SWEEP_T = 0.06  # [s]
BEGIN, END = "<!-- study:begin (cosim/drivetrain_study.py writes this block) -->", "<!-- study:end -->"


# ---- linear theory of the coupling ---------------------------------------------------------------

def two_inertia_limit(k, d, Ja, Jb):
    """Jacobi with zero-order hold on a spring-damper between two inertias, each integrated
    exactly with the held torque.  With x the twist, w2 = k (1/Ja + 1/Jb), c = d (1/Ja + 1/Jb),
    one step is x' = (1 - a/2) x + h (1 - c h/2) v, v' = -h w2 x + (1 - c h) v (a = w2 h^2):
    trace 2 - a/2 - c h, determinant 1 - c h + a/2.  Jury: |det| < 1 and |tr| < 1 + det, i.e.
    h < 2 c / w2 = 2 d / k (det < 1) and h < 2 / c.  Without damping (d = 0) det > 1 at every h:
    unstable at every step, growing by sqrt(1 + a/2) a step."""
    w2 = k * (1 / Ja + 1 / Jb)
    c = d * (1 / Ja + 1 / Jb)
    return {"omega_s": math.sqrt(w2), "zeta_s": c / (2 * math.sqrt(w2)), "h_det": 2 * d / k, "h_trace": 2 / c,
            "h_max": min(2 * d / k, 2 / c)}


def linear_model(s, k_mesh, F_mesh):
    """The drivetrain linearized about its running state: gear m's two wheels joined by the mesh
    stiffness k_mesh[m] and Hunt-Crossley damping chi F_mesh[m] along the line of action.
    Returns (A1, B1, A2, B2, K) of x1' = A1 x1 + B1 u, x2' = A2 x2 + B2 u, u = K [x1; x2]
    with x_m = [theta_A, theta_B, w_A, w_B] of gear m and u the shaft torque."""
    def gear(p, rAb, rBb, km, cm, tau_sign_A, tau_sign_B):
        J = np.diag([p["J_A"], p["J_B"]])
        r = np.array([rAb, -rBb])                        # dte = r . theta
        Kt = np.outer(r, r) * km                         # torques -r F, F = km dte + cm dte'
        Ct = np.outer(r, r) * cm + np.diag([0.0, p["c_load"]])
        Ji = np.linalg.inv(J)
        A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Ji @ Kt, -Ji @ Ct]])
        B = np.concatenate([np.zeros(2), Ji @ np.array([tau_sign_A, tau_sign_B])])[:, None]
        return A, B

    sys.path.insert(0, str(ROOT / "tests"))
    from reference_model import train_ref as T

    tr = T.GearTrain(s["train"])
    g1, g2 = tr.meshes[0].g, tr.meshes[1].g
    p1, p2 = s["gear1"], s["gear2"]
    A1, B1 = gear(p1, g1.rAb, g1.rBb, k_mesh[0], p1["chi"] * F_mesh[0], 0.0, -1.0)   # -u on wheel B
    A2, B2 = gear(p2, g2.rAb, g2.rBb, k_mesh[1], p2["chi"] * F_mesh[1], 1.0, 0.0)    # +u on wheel A
    k, d = s["shaft"]["k"], s["shaft"]["d"]
    K = np.zeros((1, 8))
    K[0, 1], K[0, 3], K[0, 4], K[0, 6] = k, d, -k, -d                  # k (thB1 - thA2) + d (wB1 - wA2)
    return A1, B1, A2, B2, K


def _zoh(A, B, h):
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = A * h, B * h
    E = expm(M)
    return E[:n, :n], E[:n, n:]


def _foh(A, B, h):
    """Phi = e^(A h), G0 = int_0^h e^(A (h - s)) B ds, G1 = int_0^h e^(A (h - s)) B s ds."""
    n = A.shape[0]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n], M[:n, n:n + 1], M[n, n + 1] = A * h, B * h, 1.0
    E = expm(M)
    return E[:n, :n], E[:n, n:n + 1], E[:n, n + 1:n + 2] * h


def spectral_radius(model, h, delay=0, derivatives=False):
    """Largest |eigenvalue| of one co-simulation step (exact subsystems, held shaft torque from
    the state delay steps back, or with derivatives the torque's first-order Taylor polynomial
    u_k + u'_k (t - t_k), u' = K x' of the coupled system), without the rigid rotation's
    eigenvalue 1."""
    A1, B1, A2, B2, K = model
    P1, G1, H1 = _foh(A1, B1, h)
    P2, G2, H2 = _foh(A2, B2, h)
    P = np.zeros((8, 8))
    P[:4, :4], P[4:, 4:] = P1, P2
    G = np.vstack([G1, G2])
    if derivatives:
        A = np.zeros((8, 8))
        A[:4, :4], A[4:, 4:] = A1, A2
        B = np.vstack([B1, B2])
        M = P + G @ K + np.vstack([H1, H2]) @ K @ (A + B @ K)
    elif delay == 0:
        M = P + G @ K
    else:
        M = np.block([[P, G @ K], [np.eye(8), np.zeros((8, 8))]])
    ev = np.linalg.eigvals(M)
    ev = ev[np.argsort(np.abs(ev - 1.0))][1:]      # drop the rigid rotation (eigenvalue 1)
    return float(np.max(np.abs(ev)))


def stability_limit(model, delay, lo=1e-6, hi=2e-3, derivatives=False):
    """Smallest h with spectral radius > 1 (a scan, then bisection)."""
    hs = np.geomspace(lo, hi, 200)
    r = [spectral_radius(model, h, delay, derivatives) for h in hs]
    i = next(i for i, v in enumerate(r) if v > 1 + 1e-10)
    a, b = hs[i - 1], hs[i]
    for _ in range(40):
        m = math.sqrt(a * b)
        (a, b) = (m, b) if spectral_radius(model, m, delay, derivatives) <= 1 + 1e-10 else (a, m)
    return b


def modes(model):
    """Natural frequencies [rad/s] and damping ratios of the whole linear drivetrain."""
    A1, B1, A2, B2, K = model
    A = np.zeros((8, 8))
    A[:4, :4], A[4:, 4:] = A1, A2
    A += np.vstack([B1, B2]) @ K
    ev = np.linalg.eigvals(A)
    ev = ev[ev.imag > 1e-6]
    return sorted((float(abs(e)), float(-e.real / abs(e))) for e in ev)


# ---- the measured blow-up -----------------------------------------------------------------------

def growth(run, ref, t_stop):
    """Growth rate [1/s] of the shaft torque error: ln(max error over [0.04, 0.06) s / max error
    over [0, 0.02) s) / 0.04 s; inf when the run ended early (blow-up).  A stable coupling's error
    decays from its start (the rate is negative); an unstable one grows from the start until the
    teeth separate and it saturates, so the early windows are the ones that tell (0.06 s <= t_stop)."""
    if run.get("_unstable") or run["time"][-1] < t_stop * (1 - 1e-9):
        return math.inf
    e = np.abs(run["shaft.tau"] - np.interp(run["time"], ref["time"], ref["shaft.tau"]))
    t = run["time"]
    late = e[(t >= 0.04) & (t < 0.06)].max()
    early = e[t < 0.02].max()
    if not np.isfinite(late):
        return math.inf
    return math.log(late / early) / 0.04


def order_fit(hs, es):
    """Least-squares slope of log e against log h."""
    return float(np.polyfit(np.log(hs), np.log(es), 1)[0])


def h_for(err, hs, es, p):
    """The step that gives error err, from the smallest-h point and the observed order p."""
    return hs[-1] * (err / es[-1]) ** (1 / p)


# ---- the study ----------------------------------------------------------------------------------

def study(ssp, t_stop, quick=False):
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.ERROR)
    f = D.fmu_paths()
    s = D.system()
    res = {"t_stop": t_stop, "rel_tol": D.REL_TOL, "hs": HS}
    ref = D.run_monolithic(f["train"], t_stop, 1e-5, extra=("mesh[1].k_mesh", "mesh[2].k_mesh",
                                                           "mesh[1].F_fwd", "mesh[2].F_fwd"))
    res["ranges"] = {q: float(np.ptp(ref[q])) for q in Q3}
    # the reference's own error: the train at a tolerance 100 times tighter
    tight = D.run_monolithic(f["train"], t_stop, 1e-5, rel_tol=D.REL_TOL / 100)
    res["ref_error"] = D.errors(ref, tight)
    # cost of the monolithic run at the scene's output interval and at 1e-5
    res["cost_mono"] = {}
    for dt in (1e-4, 1e-5):
        runs = [D.run_monolithic(f["train"], t_stop, dt) for _ in range(3)]
        res["cost_mono"][str(dt)] = float(np.median([r["_cpu"] for r in runs]))
    # errors and costs per master and h
    res["err"], res["cost"] = {}, {}
    for m, (label, fn) in MASTERS.items():
        res["err"][m], res["cost"][m] = {}, {}
        for h in HS:
            if quick and h < 1e-5:
                continue
            try:
                run = fn(h, t_stop, ssp)
                e = D.errors(run, ref)
                if run.get("_unstable"):
                    e = {q: math.inf for q in Q3}
            except Exception as ex:  # noqa: BLE001  a blown-up run: an FMU refuses its state
                print(f"{m} h={h:g}: {ex}".splitlines()[0], file=sys.stderr)
                e, run = {q: math.inf for q in Q3}, {"_cpu": math.nan}
            res["err"][m][str(h)] = e
            res["cost"][m][str(h)] = run["_cpu"]
            print(f"{m:9s} h={h:7.0e}  " + "  ".join(f"{q} {e[q]:.3g}" for q in Q3)
                  + f"  cpu {run['_cpu']:.2f} s", flush=True)
    # point 4 at equal h: Gauss-Seidel and second-order derivatives
    res["variants"] = {}
    for name, kw in {"gauss-seidel": {"scheme": "gauss-seidel"},
                     "jacobi+d2": {"derivatives": 2}}.items():
        res["variants"][name] = {}
        for h in (1e-4, 1e-5):
            run = D.run_master(h, t_stop, dt_out=max(h, 1e-5), **kw)
            res["variants"][name][str(h)] = D.errors(run, ref)
    # linear theory and the measured limit
    k_mesh = [float(np.mean(ref["mesh[1].k_mesh"])), float(np.mean(ref["mesh[2].k_mesh"]))]
    F_mesh = [float(np.mean(ref["mesh[1].F_fwd"])), float(np.mean(ref["mesh[2].F_fwd"]))]
    model = linear_model(s, k_mesh, F_mesh)
    two = two_inertia_limit(s["shaft"]["k"], s["shaft"]["d"], s["gear1"]["J_B"], s["gear2"]["J_A"])
    res["theory"] = {"k_mesh": k_mesh, "F_mesh": F_mesh, "two_inertia": two,
                     "h_max_jacobi": stability_limit(model, 0), "h_max_delayed": stability_limit(model, 1),
                     "h_max_derivatives": stability_limit(model, 0, derivatives=True),
                     "modes": modes(model)}
    # steps that divide the run: t_stop / n for n on a geometric scale.  The sweep drives the
    # drivetrain with a constant torque (D.STEADY_SCENE): the ripple adds a forced error that grows
    # with the angle drift however stable the coupling is, which the growth criterion would read
    # as instability; its stiffness tau_ripple order^2 (80 N.m/rad) is 1e-3 of the shaft's, so the
    # limit is the same.
    t_sweep = SWEEP_T
    ref_long = D.run_monolithic(f["train"], t_sweep, 1e-5, scene=D.STEADY_SCENE)
    sweep = np.unique([t_sweep / n for n in np.round(t_sweep / np.geomspace(2.5e-5, 4e-4, 9 if quick else 21))])
    res["sweep"] = {"t_stop": t_sweep, "hs": [float(h) for h in sweep], "jacobi": [], "delayed": [], "jacobi+d": []}
    for h in sweep:
        for name, kw in (("jacobi", {}), ("delayed", {"delay": 1}), ("jacobi+d", {"derivatives": 1})):
            try:
                run = D.run_master(float(h), t_sweep, dt_out=float(h), blowup=1e5, scene=D.STEADY_SCENE, **kw)
                g = growth(run, ref_long, t_sweep)
            except RuntimeError:
                g = math.inf
            res["sweep"][name].append(g)
        print(f"sweep h={h:.2e}: growth " + ", ".join(f"{n} {res['sweep'][n][-1]:.3g}/s"
                                                       for n in ("jacobi", "delayed", "jacobi+d")), flush=True)
    return res


def measured_limit(res, name, rate=0.0):
    """The first h of the sweep whose shaft torque error grows (rate > `rate` per second; with
    rate = inf: whose run blows up, an FMU refusing a penetration beyond its tooth), and the one
    before it."""
    hs, g = res["sweep"]["hs"], res["sweep"][name]
    for i, (h, v) in enumerate(zip(hs, g)):
        if v > rate or (math.isinf(rate) and math.isinf(v)):
            return (hs[i - 1] if i else None), h
    return hs[-1], None


def orders(res, m):
    """Observed order per quantity over h = 1e-5 ... 1e-6 (the asymptotic range)."""
    hs = [h for h in HS if h <= 1e-5 and str(h) in res["err"][m]]
    out = {}
    for q in Q3:
        es = [res["err"][m][str(h)][q] for h in hs]
        out[q] = order_fit(hs, es) if len(hs) >= 2 and all(np.isfinite(es)) else math.nan
    return out


def plot(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), constrained_layout=True)
    units = {"mesh1.dte": "m", "mesh2.dte": "m", "shaft.tau": "N.m"}
    styles = {"libcosim": "o-", "fmpy": "s--", "jacobi": "^-", "jacobi+d": "v-"}
    th = res["theory"]
    for ax, q in zip(axes, Q3):
        for m, (label, _) in MASTERS.items():
            hs = [h for h in HS if str(h) in res["err"][m]]
            es = np.array([res["err"][m][str(h)][q] for h in hs])
            fin = np.isfinite(es)
            ax.loglog(np.array(hs)[fin], es[fin], styles[m], label=label)
        ax.axhline(res["ranges"][q], color="0.5", lw=0.8, ls=":")
        ax.text(1.1e-6, res["ranges"][q] * 1.15, "range over the run", color="0.4", fontsize=8)
        ax.axhline(max(res["ref_error"][q], 1e-300), color="0.7", lw=0.8, ls="-.")
        for hm, ls, lab in ((th["h_max_jacobi"], "-", "limit, Jacobi"), (th["h_max_delayed"], "--", "limit, delayed")):
            ax.axvline(hm, color="r", lw=0.8, ls=ls)
        ax.axvline(2 / th["two_inertia"]["omega_s"], color="k", lw=0.6, ls=":")
        ax.set_xlabel("communication step h [s]")
        ax.set_ylabel(f"max |{q} - monolithic| [{units[q]}]")
        ax.set_title(q)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.suptitle("Two-stage drivetrain driven by an engine (firing order 2): co-simulation against the "
                 f"monolithic SpurGearTrain (0..{res['t_stop']} s; red: linear stability limits, Jacobi solid, delayed dashed; "
                 "dotted black: 2/omega_s; dash-dot: the reference's own error)", fontsize=9)
    fig.savefig(path, dpi=110)


def _e(x):
    if not np.isfinite(x):
        return "unstable"
    return f"{x:.2g}"


def markdown(res):
    th, two = res["theory"], res["theory"]["two_inertia"]
    L = []
    L.append(f"Run: `{res['command']}` ({res['date']}); scene `{D.SCENE.name}` (engine with its firing "
             f"ripple); every FMU at rel_tol {res['rel_tol']:g}, "
             f"0 to {res['t_stop']} s, errors on the reference's 1e-5 s grid (the run's own grid where h > 1e-5).")
    L.append("")
    L.append("Ranges over the run (monolithic): " + ", ".join(
        f"{q} {res['ranges'][q]:.3g}" for q in Q3) + ". The reference's own error (against rel_tol "
        f"{res['rel_tol'] / 100:g}): " + ", ".join(f"{q} {res['ref_error'][q]:.2g}" for q in Q3) + ".")
    L.append("")
    L.append("**Max error against the monolithic train** (dte in m, shaft torque in N.m) and CPU seconds "
             "per run (`time.process_time`, instantiation included):")
    L.append("")
    hdr = "| h [s] | " + " | ".join(f"{MASTERS[m][0]}: dte1, dte2, tau" for m in MASTERS) + " | CPU s: " + \
        ", ".join(MASTERS) + " |"
    L.append(hdr)
    L.append("|" + "---|" * (2 + len(MASTERS)))
    for h in HS:
        cells = []
        for m in MASTERS:
            e = res["err"][m].get(str(h))
            cells.append("—" if e is None else ", ".join(_e(e[q]) for q in Q3))
        cost = ", ".join(f"{res['cost'][m][str(h)]:.2f}" if str(h) in res["cost"][m] and
                         np.isfinite(res["cost"][m][str(h)]) else "—" for m in MASTERS)
        L.append(f"| {h:g} | " + " | ".join(cells) + f" | {cost} |")
    cm = res["cost_mono"]
    L.append(f"| monolithic SpurGearTrain | reference | | | | CPU {cm['1e-05']:.2f} s (output every 1e-5 s), "
             f"{cm['0.0001']:.2f} s (every 1e-4 s) |")
    L.append("")
    L.append("**Observed order** (least-squares slope of log error against log h over h = 1e-5 ... 1e-6):")
    L.append("")
    L.append("| master | mesh1.dte | mesh2.dte | shaft.tau |")
    L.append("|---|---|---|---|")
    for m in MASTERS:
        o = orders(res, m)
        L.append(f"| {MASTERS[m][0]} | " + " | ".join(f"{o[q]:.2f}" for q in Q3) + " |")
    L.append("")
    L.append("**Other couplings at equal h** (own master; max errors dte1, dte2, tau):")
    L.append("")
    L.append("| coupling | h = 1e-4 | h = 1e-5 |")
    L.append("|---|---|---|")
    rows = [("Jacobi, held inputs", res["err"]["jacobi"]), ("Jacobi, input derivatives (order 1)", res["err"]["jacobi+d"]),
            ("Jacobi, input derivatives (orders 1 and 2)", res["variants"]["jacobi+d2"]),
            ("Gauss-Seidel (gear1 first), held inputs", res["variants"]["gauss-seidel"]),
            ("libcosim", res["err"]["libcosim"]), ("FMPy simulate_ssp", res["err"]["fmpy"])]
    for name, d in rows:
        L.append(f"| {name} | " + " | ".join(", ".join(_e(d[str(h)][q]) for q in Q3) for h in (1e-4, 1e-5)) + " |")
    L.append("")
    L.append("**Stability.** Shaft alone between the bare wheels (J_B of stage 1, J_A of stage 2): "
             f"omega_s = sqrt(k (1/J_2 + 1/J_3)) = {two['omega_s']:.0f} rad/s, damping ratio "
             f"{two['zeta_s']:.3f}, 2/omega_s = {2 / two['omega_s']:.3g} s. Jacobi with held torque, "
             f"two inertias: h < min(2 d/k, 2/c) = min({two['h_det']:.3g}, {two['h_trace']:.3g}) s = "
             f"{two['h_max']:.3g} s (= 4 zeta_s/omega_s = {4 * two['zeta_s'] / two['omega_s']:.3g} s).")
    L.append("")
    L.append("Linearized drivetrain (mean mesh stiffness " + ", ".join(f"{k:.3g}" for k in th["k_mesh"])
             + " N/m, Hunt-Crossley damping chi F): modes " + ", ".join(
                 f"{w:.0f} rad/s (zeta {z:.3f})" for w, z in th["modes"])
             + f". Spectral radius of one step = 1 at h = {th['h_max_jacobi']:.3g} s (Jacobi) and "
             f"{th['h_max_delayed']:.3g} s (one step of delay, what libcosim and FMPy do).")
    L.append("")
    L.append("Measured (own master, 0 to {} s, scene `{}`: the constant drive, the ripple's forced error "
             "left out; unstable = the shaft torque error grows: its maximum over "
             "0.04-0.06 s exceeds that over 0-0.02 s; a stable coupling's error decays from the start):"
             .format(res["sweep"]["t_stop"], D.STEADY_SCENE.name))
    L.append("")
    L.append("| coupling | last stable h | first unstable h | theory |")
    L.append("|---|---|---|---|")
    for name, label, theory, rate in (
            ("jacobi", "Jacobi, held inputs (error grows)", th["h_max_jacobi"], 0.0),
            ("delayed", "Jacobi with one step of delay, as libcosim and FMPy (error grows)", th["h_max_delayed"], 0.0),
            ("jacobi+d", "Jacobi, input derivatives (run blows up: its error is too small and too "
             "irregular for the growth criterion)", th["h_max_derivatives"], math.inf)):
        a, b = measured_limit(res, name, rate)
        L.append(f"| {label} | {a if a is None else f'{a:.3g}'} | {b if b is None else f'{b:.3g}'} | "
                 f"{'—' if theory is None else f'{theory:.3g}'} |")
    L.append("")
    L.append("Growth rates of the sweep [1/s]: " + "; ".join(
        f"h {h:.3g}: " + ", ".join(f"{n} {res['sweep'][n][i]:.3g}" for n in ("jacobi", "delayed", "jacobi+d"))
        for i, h in enumerate(res["sweep"]["hs"])) + ".")
    L.append("")
    L.append("**Which h for which error** (from the smallest-h error and the observed order; relative to "
             "each quantity's range over the run):")
    L.append("")
    L.append("| master | target: 1 % of the range | 0.1 % | 0.01 % |")
    L.append("|---|---|---|---|")
    mono = res["cost_mono"]["0.0001"]
    for m in MASTERS:
        o = orders(res, m)
        hs = [h for h in HS if h <= 1e-5 and str(h) in res["err"][m]]
        cells = []
        for frac in (1e-2, 1e-3, 1e-4):
            need = []
            for q in Q3:
                es = [res["err"][m][str(h)][q] for h in hs]
                need.append(h_for(frac * res["ranges"][q], hs, es, o[q]))
            hn = min(need)
            cpu = res["cost"][m]["1e-06"] * 1e-6 / hn   # CPU time grows as 1/h (the runs above)
            cells.append(f"h = {hn:.2g} s: about {cpu:.3g} s CPU, {cpu / mono:.3g} x the monolithic run")
        L.append(f"| {MASTERS[m][0]} | " + " | ".join(cells) + " |")
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("ssp", nargs="?", default=str(D.DEFAULT_SSP))
    ap.add_argument("--stop", type=float, default=0.05, help="stop time [s] (the scene's)")
    ap.add_argument("--quick", action="store_true", help="h >= 1e-5 only, a coarse sweep (a smoke run)")
    ap.add_argument("--png", default=str(ROOT / "docs" / "cosim-accuracy.png"))
    ap.add_argument("--json", default=str(ROOT / "out" / "cosim-study.json"))
    ap.add_argument("--doc", default=str(ROOT / "docs" / "cosim.md"))
    a = ap.parse_args(argv)
    res = study(a.ssp, a.stop, a.quick)
    res["command"] = "python cosim/drivetrain_study.py" + (" --quick" if a.quick else "") + \
        (f" --stop {a.stop:g}" if a.stop != 0.05 else "")
    res["date"] = time.strftime("%Y-%m-%d", time.gmtime())
    Path(a.json).parent.mkdir(parents=True, exist_ok=True)
    Path(a.json).write_text(json.dumps(res, indent=1, default=float))
    plot(res, a.png)
    md = markdown(res)
    print(md)
    doc = Path(a.doc)
    if doc.exists() and BEGIN in doc.read_text():
        text = doc.read_text()
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
        doc.write_text(head + BEGIN + "\n" + md + "\n" + END + tail)
        print(f"wrote {doc}")
    print(f"wrote {a.png}, {a.json}")


if __name__ == "__main__":
    sys.exit(main())
