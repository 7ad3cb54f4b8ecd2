"""SpurGearMesh in a real co-simulation (issue 3, point 4).

The loop (cosim/SystemStructure.ssd): the PI speed controller SpeedController (controller-fmu/)
sets gear.tau_A from gear.w_A; viscous load c_load = 2 on wheel B, chi = 10. Reference: ramp
0 -> 100 rad/s in 0.1 s, a +20 rad/s step at 0.2 s (the step saturates the torque at 2000 N.m).

Masters: libcosim (libcosimpy; the loop built with its API, and loaded from the .ssp) and FMPy
(fmpy.ssp.simulation.simulate_ssp on target/cosim/speed-loop.ssp).

Two checks against the same loop computed in one process (cosim/speed_loop.py):

1. Exact coupling. Both masters are Jacobi-type: every FMU steps from t_k to t_{k+1}, then
   outputs are copied to inputs. With the controller's sampled law (e_k = r(t_k) - w_A(t_k),
   I_{k+1} = I_k + ki h e_k, tau_{k+1} = sat(kp e_k + I_{k+1})) the gear holds tau_k over
   [t_k, t_{k+1}). The gear FMU driven through FMPy's low-level API with that law in Python
   reproduces every master to rounding: the runs differ only in how the communication times
   are computed (libcosim: integer nanoseconds; FMPy: a running sum), which the gear's error
   control (rel_tol = 1e-6) can turn into differences of order rel_tol * |w_A| ~ 1e-4 rad/s.

2. Coupling error. The reference is the continuous loop: the same gear FMU with the PI law
   applied at every step of h_f = 1.25e-6 s without the extra delay (its own error is O(h_f),
   measured by halving h_f). Argument for the masters' error, to first order in h:
   on [t_k, t_{k+1}) the gear sees the continuous law evaluated with information 1 to 2 steps
   old (P part: e at t_{k-1}; I part: a left Riemann sum up to t_k, i.e. the integral lagged
   by h/2 .. 3h/2). So, where the law is smooth, |delta tau| <= 2 h sup|d tau_c/dt|, and that
   slowly varying torque error reaches w_A through the closed loop of the rigid pair
   (J = J_A + J_B/i^2, c = c_load/i^2, i = zB/zA): |delta w| <= ||g||_1 sup|delta tau| with
   g the impulse response of s / (J s^2 + (c + kp) s + ki). Where the reference jumps (the
   w_ref step) the held torque is wrong by the jump |Delta tau| for at most 2 steps: an
   impulse 2 h |Delta tau| that wheel A takes alone before the mesh moves B, so
   |delta w_A| <= 2 h |Delta tau| / J_A. Together
       E(h) = max |w_A,master - w_A,ref| <= 2 h (|Delta tau| / J_A + ||g||_1 sup|d tau_c/dt|),
   linear in h: halving h halves the error. The test checks the bound and the ratio.

Plus a loose physical check: a rigid-gear model of the loop (SciPy) agrees within the effect
of the mesh compliance, and the controller FMU's own FMI behaviour.
"""

import ctypes
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "cosim"))

import build_ssp  # noqa: E402
import speed_loop as sl  # noqa: E402

T_STOP = 0.3
H = 1e-4  # the communication step of the .ssd
H_REF = 1.25e-6  # the reference's step
RECORD = 2.5e-5  # common output grid of the convergence study


@pytest.fixture(scope="module", autouse=True)
def quiet_libcosim():
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.WARNING)


@pytest.fixture(scope="module")
def controller_fmu():
    return build_ssp.build_controller_fmu()


@pytest.fixture(scope="module")
def ssp(fmu_path, controller_fmu, tmp_path_factory):
    return build_ssp.build_ssp(fmu_path, controller_fmu, tmp_path_factory.mktemp("cosim") / "speed-loop.ssp")


@pytest.fixture(scope="module")
def params():
    return sl.ssd_parameters()


@pytest.fixture(scope="module")
def reference(fmu_path, params):
    """The continuous loop at h_f = H_REF and at 2 H_REF (for the reference's own error)."""
    every = int(round(RECORD / H_REF))
    fine = sl.run_in_process(fmu_path, params, H_REF, T_STOP, coupling="direct", record_every=every)
    coarse = sl.run_in_process(fmu_path, params, 2 * H_REF, T_STOP, coupling="direct", record_every=every // 2)
    return fine, coarse


def on_grid(ref, h):
    """The reference's samples at t = h, 2h, ..., T_STOP (ref is on the RECORD grid)."""
    m = int(round(h / RECORD))
    out = {k: v[m - 1 :: m] for k, v in ref.items()}
    assert np.allclose(out["time"], h * np.arange(1, len(out["time"]) + 1), rtol=0, atol=1e-12)
    return out


# ---- the controller FMU ------------------------------------------------------------------------


def test_controller_crate_unit_tests():
    subprocess.run(
        ["cargo", "test", "-q", "--release", "-p", "speed_controller"],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )


def test_controller_fmu_is_valid_and_exports_all_of_fmi2(controller_fmu, tmp_path):
    import fmpy
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(controller_fmu)) == []
    md = fmpy.read_model_description(str(controller_fmu))
    assert md.coSimulation is not None and md.modelExchange is None
    unzip = fmpy.extract(str(controller_fmu), unzipdir=str(tmp_path / "ctl"))
    lib = ctypes.CDLL(str(Path(unzip) / "binaries" / "linux64" / "SpeedController.so"))
    header = (Path(fmpy.__file__).parent / "c-code" / "fmi2Functions.h").read_text()
    names = sorted(set(re.findall(r"#define (fmi2\w+)\s+fmi2FullName\(", header)))
    assert len(names) == 44
    missing = [n for n in names if not hasattr(lib, n)]
    assert missing == []


def test_controller_fmu_state_machine_and_law(controller_fmu, tmp_path):
    import fmpy
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    md = fmpy.read_model_description(str(controller_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = fmpy.extract(str(controller_fmu), unzipdir=str(tmp_path / "ctl"))
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier="SpeedController", instanceName="c")
    s.instantiate()
    try:
        with pytest.raises(FMICallException):  # doStep before initialization
            s.doStep(0.0, 1e-3)
        s.reset()
        s.setupExperiment(startTime=0.0)
        with pytest.raises(FMICallException):  # not admissible: kp >= 0
            s.setReal([vr["kp"]], [-1.0])
        s.reset()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.setReal([vr[k] for k in ("w_ref", "t_ramp", "kp", "ki", "tau_max")], [10.0, 0.0, 2.0, 50.0, 100.0])
        s.setReal([vr["w_A"]], [4.0])
        s.exitInitializationMode()
        # At t = 0: tau = kp e = 2 * 6; no dependence on the input after initialization.
        assert s.getReal([vr["tau"]]) == [12.0]
        s.setReal([vr["w_A"]], [0.0])
        assert s.getReal([vr["tau"]]) == [12.0]
        state = s.getFMUstate()
        s.doStep(0.0, 0.1)  # e_0 = 10: I = 50, tau = 2*10 + 50 = 70
        assert s.getReal([vr["integral"], vr["tau"], vr["error"]]) == pytest.approx([50.0, 70.0, 10.0])
        s.doStep(0.1, 0.1)  # e = 10: I would be 100, 20 + 100 > tau_max with e > 0: frozen
        assert s.getReal([vr["integral"], vr["tau"]]) == pytest.approx([50.0, 70.0])
        assert s.getBoolean([vr["saturated"]]) == [False]
        s.setReal([vr["w_A"]], [-30.0])
        s.doStep(0.2, 0.1)  # e = 40: integral frozen, 2*40 + 50 = 130 limited to 100
        assert s.getReal([vr["integral"], vr["tau"]]) == pytest.approx([50.0, 100.0])
        assert s.getBoolean([vr["saturated"]]) == [True]
        s.setFMUstate(state)
        assert s.getReal([vr["tau"], vr["integral"]]) == [12.0, 0.0]
        s.freeFMUstate(state)
        # Serialized states (fmi2-slave's envelope around the controller's payload).
        s.doStep(0.0, 0.1)
        blob = s.serializeFMUstate(s.getFMUstate())
        s.doStep(0.1, 0.1)
        s.setFMUstate(s.deSerializeFMUstate(blob))
        assert s.getReal([vr["integral"], vr["tau"]]) == pytest.approx([50.0, 70.0])
        with pytest.raises(FMICallException):  # corrupted
            s.deSerializeFMUstate(blob[:-1] + bytes([blob[-1] ^ 1]))
        s.reset()
        with pytest.raises(FMICallException):  # wrong communication point
            s.doStep(0.5, 0.1)
        s.reset()
        set_time = s.dll.fmi2SetTime  # a Model Exchange function: fmi2Error
        set_time.argtypes, set_time.restype = [ctypes.c_void_p, ctypes.c_double], ctypes.c_int
        assert set_time(s.component, 0.0) == 3
    finally:
        s.freeInstance()


# ---- the loop in the masters -------------------------------------------------------------------


def test_ssp_parameters_reach_libcosim(ssp, params):
    """libcosim only logs a warning for a parameter it cannot apply: read every one back."""
    got = sl.libcosim_parameters(ssp)
    assert got == params


def test_masters_reproduce_the_sampled_loop(fmu_path, controller_fmu, ssp, params):
    replica = sl.run_in_process(fmu_path, params, H, T_STOP, coupling="jacobi")
    runs = {
        "libcosim (API)": sl.run_libcosim(fmu_path, controller_fmu, params, H, T_STOP),
        "libcosim (SSP)": sl.run_libcosim_ssp(ssp, H, T_STOP),
        "FMPy (SSP)": sl.run_fmpy_ssp(ssp, H, T_STOP),
    }
    # rel_tol (1e-6) of the gear times the speed range: what different rounding of the
    # communication times can make of the gear's adaptive steps. A coupling that differs by
    # one step of delay differs by ~0.1 rad/s.
    tol = {"gear.w_A": 1e-4, "gear.w_B": 1e-4, "controller.tau": 0.05, "controller.integral": 0.05}
    for master, run in runs.items():
        assert np.allclose(run["time"], replica["time"], rtol=0, atol=1e-12), master
        for name, bound in tol.items():
            err = np.max(np.abs(run[name] - replica[name]))
            print(f"{master:15s} {name:20s} max |master - in-process| = {err:.3g}")
            assert err <= bound, f"{master}: {name} differs by {err} from the in-process loop"
    # The loop does what it should: w_A follows the reference, the step saturates the torque.
    w = runs["libcosim (API)"]["gear.w_A"]
    tau = runs["libcosim (API)"]["controller.tau"]
    assert abs(w[-1] - 120.0) < 1.0
    assert tau.max() == params["controller"]["tau_max"]
    assert np.all(runs["libcosim (API)"]["gear.dte"] >= 0.0)  # the forward flanks keep the load


def coupling_bound(h, ref, params):
    """2 h (|Delta tau| / J_A + ||g||_1 sup|d tau_c/dt|): see the module docstring."""
    from scipy import signal

    pg, pc = params["gear"], params["controller"]
    i = 33 / 22  # zB/zA of the gear's default geometry
    j, c = pg["J_A"] + pg["J_B"] / i**2, pg["c_load"] / i**2
    t = np.linspace(0.0, 1.0, 100001)
    _, g = signal.impulse(([1.0, 0.0], [j, c + pc["kp"], pc["ki"]]), T=t)
    g1 = np.trapezoid(np.abs(g), t)
    time, tau = ref["time"], ref["controller.tau"]
    rate = np.abs(np.diff(tau)) / np.diff(time)
    mid = 0.5 * (time[1:] + time[:-1])
    at_step = np.abs(mid - pc["t_step"]) <= RECORD
    jump = np.max(np.abs(np.diff(tau))[at_step])
    return 2 * h * (jump / pg["J_A"] + g1 * rate[~at_step].max())


def test_coupling_error_is_first_order_in_the_step(fmu_path, controller_fmu, ssp, params, reference):
    fine, coarse = reference
    ref_error = np.max(np.abs(fine["gear.w_A"] - coarse["gear.w_A"]))  # ~ the reference's own error
    errors = {}
    for h in (1e-4, 5e-5, 2.5e-5):
        errors["libcosim", h] = sl.run_libcosim(fmu_path, controller_fmu, params, h, T_STOP)
    for h in (1e-4, 5e-5):
        errors["FMPy", h] = sl.run_fmpy_ssp(ssp, h, T_STOP)
    print(f"\nreference (h_f = {H_REF}): |w(h_f) - w(2 h_f)| = {ref_error:.3g} rad/s")
    e = {}
    for (master, h), run in errors.items():
        r = on_grid(fine, h)
        diff = np.abs(run["gear.w_A"] - r["gear.w_A"])
        e[master, h] = diff.max()
        bound = coupling_bound(h, fine, params)
        print(
            f"{master:9s} h = {h:.3g}: max |w_A - w_A,ref| = {diff.max():.4f} rad/s at t = {run['time'][diff.argmax()]:.5f}; "
            f"at t = {T_STOP}: {diff[-1]:.5f}; bound {bound:.3f}"
        )
        assert diff.max() <= bound
    assert ref_error < 0.02 * e["libcosim", 2.5e-5]
    for master, hs in (("libcosim", (1e-4, 5e-5, 2.5e-5)), ("FMPy", (1e-4, 5e-5))):
        for h1, h2 in zip(hs, hs[1:]):
            ratio = e[master, h1] / e[master, h2]
            print(f"{master}: E({h1:.3g}) / E({h2:.3g}) = {ratio:.2f}")
            assert 1.6 <= ratio <= 2.4


def test_rigid_gear_model_of_the_loop(params, reference):
    """The continuous loop with rigid gears (w_B = w_A zA/zB), integrated by SciPy, apart from
    both FMUs. It differs from the compliant reference by the mesh compliance: w_A ripples with
    the tooth-pair stiffness (~0.1 rad/s) and takes the torque jump at the w_ref step alone for
    a fraction of a mesh period (~0.3 rad/s): within 0.5 rad/s (0.4 % of 120 rad/s)."""
    from scipy.integrate import solve_ivp

    pg, pc = params["gear"], params["controller"]
    i = 33 / 22
    j, c = pg["J_A"] + pg["J_B"] / i**2, pg["c_load"] / i**2
    kp, ki, tau_max = pc["kp"], pc["ki"], pc["tau_max"]

    def rhs(t, y):
        w, integral = y
        e = sl.reference_speed(pc, t) - w
        v = kp * e + integral
        frozen = (v > tau_max and e > 0) or (v < -tau_max and e < 0)
        return [(min(max(v, -tau_max), tau_max) - c * w) / j, 0.0 if frozen else ki * e]

    fine, _ = reference
    t = fine["time"]
    w, y0 = [], [0.0, 0.0]
    # Restart at the kinks of the reference speed.
    for a, b in ((0.0, pc["t_ramp"]), (pc["t_ramp"], pc["t_step"]), (pc["t_step"], T_STOP)):
        sel = (t > a) & (t <= b + 1e-12)
        sol = solve_ivp(rhs, (a, max(b, t[sel][-1])), y0, t_eval=t[sel], method="LSODA", rtol=1e-10, atol=1e-10, max_step=1e-4)
        assert sol.success
        w.append(sol.y[0])
        y0 = sol.y[:, -1]
    diff = np.abs(np.concatenate(w) - fine["gear.w_A"])
    print(f"\nrigid model vs compliant reference: max {diff.max():.3f} rad/s; after 0.25 s {diff[t > 0.25].max():.3f}")
    assert diff.max() < 0.5
    assert diff[t > 0.25].max() < 0.1


# ---- a moving housing (issue 8, point 7; rig-and-modes.md §3-§4) -------------------------------
#
# The housing inputs in the interface frame: J_A dw_A/dt = ... + J_A alpha_housing,
# J_B dw_B/dt = ... - J_B alpha_housing, m_S d^2x_S/dt^2 = ... - m_S a_housing_x.
# A co-simulation FMU holds its inputs over each communication step. The checks below use
# what that implies exactly, and bound what it costs against a continuous input.

import math  # noqa: E402

import housing_motion as hm  # noqa: E402

RAB_, RBB_ = 0.187872922544603, 0.281809383816904  # paper geometry, zA/zB = 22/33 (test vectors)
J_A_, J_B_ = 0.4, 2.0  # the defaults


def rounding_bound(n_ops, scale):
    """Rounding only: at most 8 ulp of the largest term per integrator step or communication
    step (a Dormand-Prince update sums 7 stage terms, plus the step's own addition)."""
    return 8.0 * n_ops * np.spacing(scale)


def free_flight_start(backlash=1e-4):
    """No torque, no load, the wheels in the middle of the backlash with equal flank speeds
    (rAb w_A = rBb w_B): no flank carries until the housing moves the mesh."""
    return dict(tau_A=0.0, tau_B=0.0, c_load=0.0, backlash=backlash, dte_start=-backlash / 2,
                w_A_start=100.0, w_B_start=100.0 * RAB_ / RBB_)


@pytest.mark.parametrize("solver", [1, 2])
@pytest.mark.parametrize("alpha", [1.0, -1.0])
def test_housing_free_flight_constant_alpha(new_instance, solver, alpha):
    """Free flight with a constant alpha_housing: w_A = w_A0 + alpha t, w_B = w_B0 - alpha t
    (spec §4, interface frame), and the flanks approach with rAb w_A - rBb w_B = (rAb + rBb) alpha t,
    so dte = dte0 + (rAb + rBb) alpha t^2/2 and theta_B = w_B0 t - alpha t^2/2.
    Tolerance: the speeds are linear in t, which any consistent Runge-Kutta or BDF step
    reproduces exactly; the angles are quadratic, exact for Dormand-Prince (order 5) but not
    for BDF's first-order start, so for solver 2 only the speeds are checked. What remains is
    rounding (rounding_bound over the integrator's and the master's steps).
    The run stays in the backlash: |dte - dte0| <= 0.47 m * 1 rad/s^2 * (0.01 s)^2/2 = 2.4e-5 m
    < backlash/2 = 5e-5 m."""
    sc = free_flight_start()
    inst = new_instance(name=f"ff{solver}{alpha}")
    inst.initialize(solver=solver, **sc)
    inst.set(alpha_housing=alpha)
    h, t_end = 1e-4, 0.01
    r = {k: np.asarray(v) for k, v in inst.run(t_end, h, ["w_A", "w_B", "dte", "theta_B", "F_fwd", "F_bwd",
                                                          "n_fwd", "n_bwd", "n_steps"]).items()}
    t = r["time"]
    assert np.all(r["n_fwd"] == 0) and np.all(r["n_bwd"] == 0) and np.all(r["F_fwd"] == 0) and np.all(r["F_bwd"] == 0)
    n_ops = r["n_steps"][-1] + len(t)
    w_b0 = sc["w_B_start"]
    tol_w = rounding_bound(n_ops, 100.0 + abs(alpha) * t_end)
    np.testing.assert_allclose(r["w_A"], 100.0 + alpha * t, rtol=0, atol=tol_w)
    np.testing.assert_allclose(r["w_B"], w_b0 - alpha * t, rtol=0, atol=tol_w)
    if solver == 1:
        np.testing.assert_allclose(r["dte"], sc["dte_start"] + (RAB_ + RBB_) * alpha * t**2 / 2, rtol=0,
                                   atol=rounding_bound(n_ops, RBB_ * w_b0 * t_end))
        np.testing.assert_allclose(r["theta_B"], w_b0 * t - alpha * t**2 / 2, rtol=0,
                                   atol=rounding_bound(n_ops, w_b0 * t_end))
    # Sharp: the housing's effect on the speeds is alpha t = 1e-2 rad/s, far above the bound.
    assert tol_w < 1e-9


@pytest.mark.parametrize("solver", [1, 2])
@pytest.mark.parametrize("tol", [1e-6, 1e-10])
def test_slider_free_flight_constant_housing_acceleration(new_instance, solver, tol):
    """The slider in free flight under a constant a_housing_x = a, undamped:
    m x'' = -k x - m a, x(0) = x'(0) = 0, so x_slider = -(a m/k)(1 - cos(sqrt(k/m) t)).
    k = 1e9 N/m, m = 44.4 kg (period 1.32 ms, 15 periods in 20 ms), a = 10 m/s^2.
    Tolerance from rel_tol: without torque the FMU's absolute tolerances are negligible
    (1e-12 m scale), so each step's local error is at most rel_tol |x| in x and rel_tol |v| in v,
    i.e. at most sqrt(5) rel_tol (a m/k) in the energy norm (x, v/omega) (|x| <= 2 a m/k,
    |v|/omega <= a m/k). The undamped oscillator's flow is a rotation in that norm: local errors
    add up without growth, so |x - x_exact| <= n_steps sqrt(5) rel_tol a m/k."""
    k, m, a = 1e9, 44.4, 10.0
    sc = free_flight_start()
    inst = new_instance(name=f"slider{solver}{tol}")
    inst.initialize(tolerance=tol, solver=solver, slider_stiffness=k, slider_mass=m, slider_damping=0.0, **sc)
    inst.set(a_housing_x=a)
    r = {k_: np.asarray(v) for k_, v in inst.run(0.02, 1e-4, ["x_slider", "w_A", "w_B", "dte", "F_B_x",
                                                               "n_fwd", "n_bwd", "n_steps"]).items()}
    t = r["time"]
    amp = a * m / k
    exact = -amp * (1.0 - np.cos(math.sqrt(k / m) * t))
    # Free flight: no contact (|x| <= 8.9e-7 m shifts the flanks by |x| sin(alpha_w) << 5e-5 m).
    assert np.all(r["n_fwd"] == 0) and np.all(r["n_bwd"] == 0) and np.all(r["F_B_x"] == 0)
    assert np.all(r["w_A"] == 100.0) and np.all(r["w_B"] == sc["w_B_start"])
    bound = r["n_steps"][-1] * math.sqrt(5.0) * tol * amp
    err = np.max(np.abs(r["x_slider"] - exact))
    print(f"\nsolver {solver} rel_tol {tol:g}: max |x - x_exact| = {err:.3g} m, bound {bound:.3g} m "
          f"({r['n_steps'][-1]} steps)")
    assert err <= bound
    assert bound < 0.02 * amp  # sharp: a wrong sign of a or a wrong m would be off by ~amp


def test_sampled_housing_input_hold_error(fmu_path):
    """A sinusoidal housing motion sampled at the communication points, in free flight:
    theta_C = A (1 - cos(w t)), alpha(t) = A w^2 cos(w t), Omega(0) = 0.
    The FMU holds alpha(t_k) over [t_k, t_k + h), so exactly (any consistent integrator, the
    speed being linear in t on each step): w_A(t_k) = w_A0 + h sum_{j<k} alpha(t_j).
    Against the continuous motion, w_A,c(t_k) = w_A0 + Omega(t_k), the difference is
        D_k = sum_j [int_{t_j}^{t_j+h} alpha dt - h alpha(t_j)]
            = sum_j [h^2/2 alpha'(t_j) + R_j],                 |R_j| <= h^3/6 max|alpha''|
    and sum_j h alpha'(t_j) = alpha(t_k) - alpha(0) - sum_j R'_j,  |R'_j| <= h^2/2 max|alpha''|,
    so  D_k = (h/2)(alpha(t_k) - alpha(0)) + E_k,  |E_k| <= (5/12) t_k h^2 max|alpha''|,
    max|alpha''| = A w^4: the hold error is first order, (h/2) times the input's change (at most
    h max|alpha|), with a second-order remainder. With the step's mean alpha,
    (Omega(t_{k+1}) - Omega(t_k))/h, the FMU reproduces Omega(t_k) exactly.
    A = 4e-5 rad keeps the run in the backlash: the flanks move by (rAb + rBb) theta_C <= 3.8e-5 m
    < backlash/2."""
    motion = hm.HousingMotion(A=4e-5, f=20.0, X=0.0, shape="1-cos")
    sc = free_flight_start()
    h, t_stop = 1e-4, 0.1
    runs = {hold: hm.run(sc, motion, h, t_stop, fmu=fmu_path, hold=hold) for hold in ("sample", "mean")}
    s = runs["sample"]
    t = s["time"]
    for r in runs.values():
        assert np.all(r["n_fwd"] == 0) and np.all(r["n_bwd"] == 0) and np.all(r["F_fwd"] == 0)
    w_a0, w_b0 = sc["w_A_start"], sc["w_B_start"]
    n_ops = max(r["n_steps"] for r in runs.values()) + len(t)
    rnd = rounding_bound(n_ops, w_a0)
    # (1) Exactly the held input.
    held = np.concatenate([[0.0], np.cumsum(h * s["alpha_housing"][:-1])])
    np.testing.assert_allclose(s["w_A"], w_a0 + held, rtol=0, atol=rnd)
    np.testing.assert_allclose(s["w_B"], w_b0 - held, rtol=0, atol=rnd)
    # (2) Against the continuous motion: the first-order hold term and the remainder bound.
    omega = np.array([motion.omega(x) for x in t])
    alpha = np.array([motion.alpha(x) for x in t])
    first = (h / 2) * (alpha - alpha[0])
    remainder = (5.0 / 12.0) * t * h**2 * motion.alpha_dd_max()
    dev = s["w_A"] - (w_a0 + omega - first)
    assert np.all(np.abs(dev) <= remainder + rnd)
    dev_b = s["w_B"] - (w_b0 - omega + first)
    assert np.all(np.abs(dev_b) <= remainder + rnd)
    # The first-order term is what the hold costs, resolved: it is > 10x the remainder bound
    # here (h A w^2 against (5/12) t h^2 A w^4: a ratio 12/(5 t h w^2) = 15 at t = 0.1 s), so
    # leaving it out fails.
    assert np.max(np.abs(first)) > 10 * (remainder[-1] + rnd)
    assert np.max(np.abs(s["w_A"] - (w_a0 + omega))) > remainder[-1] + rnd
    print(f"\nhold error: max (h/2)|alpha - alpha(0)| = {np.max(np.abs(first)):.3g} rad/s, "
          f"remainder bound {remainder[-1]:.3g}, max |w_A - model| = {np.max(np.abs(dev)):.3g}")
    # (3) The step's mean input: exact at the communication points (rounding of the mean adds
    # at most a few eps |Omega| per step).
    m = runs["mean"]
    rnd_mean = rnd + 4 * len(t) * np.finfo(float).eps * np.max(np.abs(omega))
    np.testing.assert_allclose(m["w_A"], w_a0 + omega, rtol=0, atol=rnd_mean)
    np.testing.assert_allclose(m["w_B"], w_b0 - omega, rtol=0, atol=rnd_mean)


@pytest.mark.parametrize("solver", [1, 2])
def test_rocking_housing_on_the_paper_rig(fmu_path, solver):
    """cosim/housing_motion.py's scene (paper rig in contact, Johnson mesh, chi = 10, the stiff
    slider, the housing rocking and shaking) runs, and the housing's torques enter with the
    right inertias at every instant, in contact too. With mu = 0 every mesh force acts on A with
    the arm rAb and on B with rBb (either flank), so rBb (B's equation) + rAb (A's) eliminates
    it, whatever the contact, damping or slider do:
        rBb J_A w_A + rAb J_B w_B - rBb tau_A t + rAb c_load theta_B
            - (rBb J_A - rAb J_B) h sum_{j<k} alpha(t_j)  = const,
    with the held alpha (the input as the FMU saw it). The invariant is linear in the states
    and its rate is constant over each communication step, so a Runge-Kutta step (weights
    summing to 1) or a BDF step (exact for linear functions of t) keeps it to rounding.
    A J_B alpha entering with the wrong sign would break it by 2 rAb J_B max|sum h alpha|
    (~0.1), a J_A alpha missing by rBb J_A max|...| (~0.03)."""
    params = dict(hm.PAPER, **hm.SLIDER, solver=solver)
    v = hm.rig_values(fmu_path, **params)
    params["dte_start"] = hm.quasi_static_dte(v, pairs=2)
    h, t_stop = 1e-4, 0.2
    r = hm.run(params, hm.HousingMotion(), h, t_stop, fmu=fmu_path)
    rigid = hm.run(params, None, h, t_stop, fmu=fmu_path)
    t = r["time"]
    assert len(t) == int(round(t_stop / h)) + 1 and np.isfinite(r["w_A"]).all()
    # In contact (the forward flanks carry at almost every sample; the undamped start may lift
    # them briefly), never on the backward flanks; the slider deflects.
    assert np.mean(r["n_fwd"] >= 1) > 0.95 and np.all(r["n_bwd"] == 0)
    assert np.all(r["x_slider"][t > 0.01] != 0)
    rab, rbb, ja, jb, c, tau = v["rAb"], v["rBb"], v["J_A"], v["J_B"], v["c_load"], v["tau_A"]
    held = np.concatenate([[0.0], np.cumsum(h * r["alpha_housing"][:-1])])
    terms = [rbb * ja * r["w_A"], rab * jb * r["w_B"], -rbb * tau * t, rab * c * r["theta_B"],
             -(rbb * ja - rab * jb) * held]
    inv = sum(terms)
    scale = max(np.max(np.abs(x)) for x in terms)
    bound = rounding_bound(r["n_steps"] + len(t), scale)
    err = np.max(np.abs(inv - inv[0]))
    print(f"\nsolver {solver}: invariant drift {err:.3g} (bound {bound:.3g}, {r['n_steps']} steps)")
    assert err <= bound
    assert bound < 1e-4 * rbb * ja * np.max(np.abs(held))  # sharp
    # The pair turns as one rotor (J_eq = J_A + J_B/i^2) under (J_A - J_B/i) alpha: delta w_A
    # follows that within the mesh vibration. Loose physical check: the correlation.
    dw = r["w_A"] - rigid["w_A"]
    est = hm.rigid_rotor_delta_w_a(v, r, h)
    assert np.corrcoef(dw, est)[0, 1] > 0.95
