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
