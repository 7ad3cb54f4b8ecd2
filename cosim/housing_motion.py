"""A moving housing drives SpurGearMesh (issue 8, point 7; rig-and-modes.md §3-§4).

The gearbox sits on a vehicle frame. The housing C rocks about the wheel axes and shakes along
O_A O_B (the line of centres, the direction of B's slider S):

    rocking      theta_C(t) = A sin(2 pi f t)       A = 0.01 rad (0.57 deg), f = 4 Hz
                                                    (a body pitch/roll mode of the frame)
    mounting     x_C(t)     = X sin(2 pi f_x t)     X = 0.1 mm, f_x = 40 Hz (engine 2nd order at
                                                    1200 rpm; peak 6.3 m/s^2, about 0.64 g)

The master (this script) turns the motion into the FMU's inputs at every communication point
t_k = k h, through FMPy's low-level API (instantiate, set inputs, doStep, read outputs):

    alpha_housing = theta_C''(t_k) = -A (2 pi f)^2 sin(2 pi f t_k)                  [rad/s^2]
    a_housing_x   = x_C''(t_k) - Omega(t_k)^2 (d + x_slider(t_k))                    [m/s^2]

with Omega = theta_C' and d = (rAb + rBb)/cos(alpha_w) the centre distance: the centripetal
term of B's guide, which rig-and-modes.md §4 leaves to the master (here 3e-4 of the shaking).
The rotation is taken about O_A; the tangential acceleration of O_B's guide (alpha d) is across
the slider and goes to the bearing, not into the model.

Hold. A co-simulation FMU holds its inputs over a step: on [t_k, t_{k+1}) the wheels feel
alpha(t_k), not alpha(t). While the mesh carries, the pair turns as one rotor of inertia
J_eq = J_A + J_B/i^2 (i = rBb/rAb), and the housing drives it with (J_A - J_B/i) alpha, so
    delta w_A := w_A - w_A,rigid housing ~ (J_A - J_B/i)/J_eq (Omega(t) - Omega(0))
(minus a slow viscous decay). The held input integrates to h sum_j alpha(t_j) instead of
Omega(t_k) - Omega(0): they differ by (h/2)(alpha(t_k) - alpha(0)) + O(t h^2 max|alpha''|)
(tests/python/test_cosim.py derives it and checks it in free flight). Here that is at most
h max|alpha| |J_A - J_B/i|/J_eq = 4.6e-4 rad/s against a delta w_A of up to 0.36 rad/s.
--hold mean gives the FMU the step's mean alpha, (Omega(t_{k+1}) - Omega(t_k))/h, and removes
that error at the communication points.

Rig: the paper's (tau_A = 100 N.m, c_load = 2 N.m.s/rad, backlash 0.1 mm, zA/zB = 22/33,
w_A(0) = 100 rad/s, w_B(0) = 100/1.5, dte(0) = the quasi-static double-contact penetration),
Johnson contact with chi = 10 s/m, and the slider of §3: k_S = 1e9 N/m, m_S = 44.4 kg,
c_S = 3 % of critical (2 zeta sqrt(k_S m_S) = 1.26e4 N.s/m; the slider's own frequency is
755 Hz, far above the 40 Hz shaking, so x_slider follows the load quasi-statically).

    python cosim/housing_motion.py                      # target/cosim/housing-motion.{csv,png}
    python cosim/housing_motion.py --stop 1 --step 5e-5 --hold mean --out /tmp/hm

Writes one CSV (the moving-housing run and the rigid-housing run side by side) and a plot of
dte, x_slider, F_B_x, F_B_y and w_A - w_A,rigid housing (with the rigid-rotor estimate).
"""

import argparse
import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FMU = ROOT / "target" / "fmu" / "SpurGearMesh.fmu"

# The paper's rig (tools/paper_scene.py) with the damping of its damped variant.
PAPER = dict(tau_A=100.0, c_load=2.0, backlash=1e-4, w_A_start=100.0, w_B_start=100.0 / 1.5, chi=10.0)
SLIDER_K, SLIDER_M, SLIDER_ZETA = 1e9, 44.4, 0.03
SLIDER = dict(
    slider_stiffness=SLIDER_K,
    slider_mass=SLIDER_M,
    slider_damping=SLIDER_ZETA * 2.0 * math.sqrt(SLIDER_K * SLIDER_M),
)
RECORDED = ["w_A", "w_B", "theta_B", "dte", "x_slider", "F_B_x", "F_B_y", "F_fwd", "F_bwd",
            "energy_residual"]
RECORDED_INT = ["n_fwd", "n_bwd"]


@dataclass
class HousingMotion:
    """The housing's motion: a rocking theta_C(t) about the wheel axes (amplitude A [rad],
    frequency f [Hz]; shape "sin": A sin(2 pi f t), or "1-cos": A (1 - cos(2 pi f t)), which
    starts at rest) and a shaking x_C(t) = X sin(2 pi f_x t) of the mounting along O_A O_B."""

    A: float = 0.01
    f: float = 4.0
    X: float = 1e-4
    f_x: float = 40.0
    shape: str = "sin"  # "sin": theta_C = A sin(w t); "1-cos": theta_C = A (1 - cos(w t)), Omega(0) = 0

    @property
    def w(self):
        return 2.0 * math.pi * self.f

    def theta(self, t):
        s = math.sin(self.w * t) if self.shape == "sin" else 1.0 - math.cos(self.w * t)
        return self.A * s

    def omega(self, t):
        """Omega = theta_C'(t) [rad/s]."""
        c = math.cos(self.w * t) if self.shape == "sin" else math.sin(self.w * t)
        return self.A * self.w * c

    def alpha(self, t):
        """theta_C''(t) [rad/s^2]."""
        s = -math.sin(self.w * t) if self.shape == "sin" else math.cos(self.w * t)
        return self.A * self.w**2 * s

    def alpha_max(self):
        return self.A * self.w**2

    def alpha_dd_max(self):
        """max |theta_C''''|: the bound of the hold error's remainder."""
        return self.A * self.w**4

    def a_mount(self, t):
        """x_C''(t) [m/s^2]."""
        wx = 2.0 * math.pi * self.f_x
        return -self.X * wx**2 * math.sin(wx * t)


def quasi_static_dte(fmu_values, pairs=2):
    """Penetration of `pairs` pairs under the quasi-static mesh force of the paper rig at t = 0:
    the pair as one rotor, (J_A + J_B/i^2) dw_A/dt = tau_A - c_load w_A/i^2, and
    F = (J_B dw_B/dt + c_load w_B)/rBb; Johnson's law (gear-mesh-model.md §4) with
    rho_A + rho_B = L + delta, by fixed-point iteration (delta/L ~ 1e-5)."""
    v = fmu_values
    i = v["rBb"] / v["rAb"]
    j_eq = v["J_A"] + v["J_B"] / i**2
    dw_a = (v["tau_A"] - v["c_load"] * v["w_A_start"] / i**2) / j_eq
    force = (v["J_B"] * dw_a / i + v["c_load"] * v["w_B_start"]) / v["rBb"]
    e_star = 1.0 / ((1 - v["nu_A"] ** 2) / v["E_A"] + (1 - v["nu_B"] ** 2) / v["E_B"])
    n = force / pairs / v["width"]

    def johnson(rho):
        return n / (math.pi * e_star) * (math.log(4 * math.pi * e_star * rho / n) - 1)

    d = johnson(v["line_of_action"])
    for _ in range(6):
        d = johnson(v["line_of_action"] + d)
    return d


class GearSlave:
    """SpurGearMesh through FMPy's FMU2Slave, by variable name."""

    def __init__(self, fmu=FMU, name="gear"):
        import fmpy
        from fmpy.fmi2 import FMU2Slave

        self.md = fmpy.read_model_description(str(fmu))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.unzip = fmpy.extract(str(fmu))
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzip,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.slave.instantiate()

    def set(self, **values):
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Real":
                self.slave.setReal([v.valueReference], [float(value)])
            else:
                self.slave.setInteger([v.valueReference], [int(value)])

    def get(self, names):
        reals = [n for n in names if self.vars[n].type == "Real"]
        ints = [n for n in names if self.vars[n].type != "Real"]
        out = dict(zip(reals, self.slave.getReal([self.vars[n].valueReference for n in reals])))
        out.update(zip(ints, self.slave.getInteger([self.vars[n].valueReference for n in ints])))
        return out

    def close(self):
        try:
            self.slave.terminate()
        finally:
            self.slave.freeInstance()
            shutil.rmtree(self.unzip, ignore_errors=True)


def rig_values(fmu=FMU, **params):
    """The parameters and calculated parameters an initialized instance with `params` reports."""
    g = GearSlave(fmu, name="rig")
    try:
        g.slave.setupExperiment(startTime=0.0)
        g.slave.enterInitializationMode()
        g.set(**params)
        g.slave.exitInitializationMode()
        names = ["rAb", "rBb", "alpha_w", "line_of_action", "J_A", "J_B", "width", "E_A", "E_B", "nu_A",
                 "nu_B", "tau_A", "c_load", "w_A_start", "w_B_start", "rel_tol"]
        return g.get(names)
    finally:
        g.close()


def run(params, motion, h, t_stop, fmu=FMU, hold="sample", record_every=1, tolerance=None,
        recorded=RECORDED, recorded_int=RECORDED_INT):
    """Steps the FMU from 0 to t_stop with the communication step h. Before each step from t_k
    the housing inputs are set (motion=None: a rigid housing, both 0):
        hold="sample": alpha(t_k) and a_x(t_k), held by the FMU over the step (what a
                       co-simulation master does with a sampled signal);
        hold="mean":   the step's means, (Omega(t_{k+1}) - Omega(t_k))/h and
                       (x_C'(t_{k+1}) - x_C'(t_k))/h.
    Returns arrays on t = 0, record_every h, ... (the values at t = 0 first), with 'time' and
    the inputs applied on the step that starts at each row ('alpha_housing', 'a_housing_x';
    the last row repeats the last step's)."""
    n = int(round(t_stop / h))
    if not math.isclose(n * h, t_stop, rel_tol=1e-12):
        raise ValueError(f"t_stop = {t_stop} is not a multiple of h = {h}")
    g = GearSlave(fmu)
    try:
        g.slave.setupExperiment(tolerance=tolerance, startTime=0.0, stopTime=t_stop)
        g.slave.enterInitializationMode()
        g.set(**params)
        g.slave.exitInitializationMode()
        d = None
        if motion is not None:
            v = g.get(["rAb", "rBb", "alpha_w"])
            d = (v["rAb"] + v["rBb"]) / math.cos(v["alpha_w"])  # centre distance O_A O_B
        names = list(recorded) + list(recorded_int)
        rec = {k: [] for k in ["time", "alpha_housing", "a_housing_x"] + names}
        out = g.get(names)
        for k in range(n):
            t = k * h
            if motion is None:
                alpha, a_x = 0.0, 0.0
            elif hold == "sample":
                alpha = motion.alpha(t)
                a_x = motion.a_mount(t) - motion.omega(t) ** 2 * (d + out["x_slider"])
            elif hold == "mean":
                t1 = (k + 1) * h
                alpha = (motion.omega(t1) - motion.omega(t)) / h
                wx = 2.0 * math.pi * motion.f_x
                v_mount = (motion.X * wx * (math.cos(wx * t1) - math.cos(wx * t))) / h
                a_x = v_mount - motion.omega(t) ** 2 * (d + out["x_slider"])
            else:
                raise ValueError(hold)
            if k % record_every == 0:
                rec["time"].append(t)
                rec["alpha_housing"].append(alpha)
                rec["a_housing_x"].append(a_x)
                for name in names:
                    rec[name].append(out[name])
            g.set(alpha_housing=alpha, a_housing_x=a_x)
            g.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            out = g.get(names)
        if n % record_every == 0:
            rec["time"].append(n * h)
            rec["alpha_housing"].append(alpha)
            rec["a_housing_x"].append(a_x)
            for name in names:
                rec[name].append(out[name])
        rec["n_steps"] = g.get(["n_steps"])["n_steps"]
    finally:
        g.close()
    return {k: (np.asarray(v) if isinstance(v, list) else v) for k, v in rec.items()}


def rigid_rotor_delta_w_a(values, motion_run, h_record):
    """delta w_A of the pair as one rotor: J_eq d(delta)/dt = -(c_load/i^2) delta + (J_A - J_B/i) alpha,
    with alpha as the FMU saw it (held over each recorded step; exact for record_every = 1)."""
    i = values["rBb"] / values["rAb"]
    j_eq = values["J_A"] + values["J_B"] / i**2
    lam = values["c_load"] / i**2 / j_eq
    g = (values["J_A"] - values["J_B"] / i) / j_eq
    alpha = motion_run["alpha_housing"]
    out = np.zeros_like(alpha)
    decay = math.exp(-lam * h_record)
    gain = (1.0 - decay) / lam if lam > 0 else h_record
    for k in range(1, len(alpha)):
        out[k] = decay * out[k - 1] + g * alpha[k - 1] * gain
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmu", default=str(FMU))
    ap.add_argument("--step", type=float, default=1e-4, help="communication step h [s]")
    ap.add_argument("--stop", type=float, default=0.5, help="stop time [s]")
    ap.add_argument("--hold", choices=["sample", "mean"], default="sample")
    ap.add_argument("--out", default=str(ROOT / "target" / "cosim"), help="output directory")
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    params = dict(PAPER, **SLIDER)
    values = rig_values(args.fmu, **params)
    params["dte_start"] = quasi_static_dte(values, pairs=2)
    motion = HousingMotion()
    moving = run(params, motion, args.step, args.stop, fmu=args.fmu, hold=args.hold)
    rigid = run(params, None, args.step, args.stop, fmu=args.fmu)
    t = moving["time"]
    dw = moving["w_A"] - rigid["w_A"]
    estimate = rigid_rotor_delta_w_a(values, moving, args.step)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cols = {"time": t, "alpha_housing": moving["alpha_housing"], "a_housing_x": moving["a_housing_x"]}
    for name in RECORDED + RECORDED_INT:
        cols[name] = moving[name]
        cols[f"{name}_rigid_housing"] = rigid[name]
    cols["w_A_minus_rigid_housing"] = dw
    cols["w_A_minus_rigid_housing_rigid_rotor"] = estimate
    csv = out / "housing-motion.csv"
    fmt = ["%d" if c.startswith(("n_fwd", "n_bwd")) else "%.12g" for c in cols]
    np.savetxt(csv, np.column_stack(list(cols.values())), delimiter=",", fmt=fmt,
               header=",".join(cols), comments="")

    fig, ax = plt.subplots(5, 1, figsize=(9, 12), sharex=True)
    ax[0].plot(t, rigid["dte"] * 1e6, lw=0.6, color="0.6", label="rigid housing")
    ax[0].plot(t, moving["dte"] * 1e6, lw=0.6, label="moving housing")
    ax[0].set_ylabel("dte [um]")
    ax[1].plot(t, rigid["x_slider"] * 1e6, lw=0.6, color="0.6", label="rigid housing")
    ax[1].plot(t, moving["x_slider"] * 1e6, lw=0.6, label="moving housing")
    ax[1].set_ylabel("x_slider [um]")
    ax[2].plot(t, rigid["F_B_x"], lw=0.6, color="0.6", label="rigid housing")
    ax[2].plot(t, moving["F_B_x"], lw=0.6, label="moving housing")
    ax[2].set_ylabel("F_B_x [N]")
    ax[3].plot(t, rigid["F_B_y"], lw=0.6, color="0.6", label="rigid housing")
    ax[3].plot(t, moving["F_B_y"], lw=0.6, label="moving housing")
    ax[3].set_ylabel("F_B_y [N]")
    ax[4].plot(t, dw, lw=0.8, label="w_A - w_A,rigid housing (FMU)")
    ax[4].plot(t, estimate, "--", lw=0.8, label="pair as one rotor: (J_A - J_B/i)/J_eq * int alpha")
    ax[4].set_ylabel("delta w_A [rad/s]")
    ax[4].set_xlabel("t [s]")
    for a in ax:
        a.grid(True, lw=0.3)
        a.legend(loc="upper right", fontsize=8)
    ax[0].set_title(
        f"Paper rig, slider k_S = {SLIDER_K:g} N/m; housing rocking {motion.A} rad at {motion.f:g} Hz, "
        f"mounting {motion.X * 1e3:g} mm at {motion.f_x:g} Hz (h = {args.step:g} s, hold: {args.hold})",
        fontsize=9,
    )
    fig.tight_layout()
    png = out / "housing-motion.png"
    fig.savefig(png, dpi=120)

    i = values["rBb"] / values["rAb"]
    j_eq = values["J_A"] + values["J_B"] / i**2
    hold_bound = args.step * motion.alpha_max() * abs(values["J_A"] - values["J_B"] / i) / j_eq
    print(f"{csv}\n{png}")
    print(f"max |w_A - w_A,rigid housing| = {np.max(np.abs(dw)):.4g} rad/s; "
          f"rigid-rotor estimate {np.max(np.abs(estimate)):.4g}; "
          f"max |FMU - estimate| = {np.max(np.abs(dw - estimate)):.3g} rad/s")
    print(f"hold error of the sampled alpha (first order): <= {hold_bound:.2g} rad/s")
    print(f"x_slider: {moving['x_slider'].min() * 1e6:.3f} .. {moving['x_slider'].max() * 1e6:.3f} um "
          f"(rigid housing {rigid['x_slider'].min() * 1e6:.3f} .. {rigid['x_slider'].max() * 1e6:.3f})")
    print(f"F_B_x: {moving['F_B_x'].min():.1f} .. {moving['F_B_x'].max():.1f} N; "
          f"F_B_y: {moving['F_B_y'].min():.1f} .. {moving['F_B_y'].max():.1f} N")
    print(f"n_bwd > 0 in {np.count_nonzero(moving['n_bwd'])} of {len(t)} samples (rigid housing: "
          f"{np.count_nonzero(rigid['n_bwd'])})")


if __name__ == "__main__":
    main()
