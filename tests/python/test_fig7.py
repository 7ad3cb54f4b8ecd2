"""The paper's Fig. 7 (§6.2): the rigid contact force is "an averaging" of the compliant one.

Damped paper scene (chi = 10 s/m), run through the packaged FMU with contact_model = 1 (Johnson)
and 2 (rigid, forward locked from t = 0). Means of F_fwd over whole mesh cycles (2 pi/zA of
rotation of A), computed as tools/paper_scene.py does for its Fig. 7 summary.

Why the means agree, and by how much. With mu = 0, tau_B = 0 and no backward contact, A's torque
balance J_A dw_A/dt = tau_A - rAb F_fwd gives over any interval of length T

    mean F_fwd = (tau_A - J_A (w_A(end) - w_A(start)) / T) / rAb,

for either contact model. So the cycle means differ exactly by the kinetic term
J_A/rAb (dw_A_rigid/T_rigid - dw_A_compliant/T_compliant): the cycle-to-cycle change of A's speed,
which differs between the models only by the mesh vibration (J_A dw_A = rAb m_eff dv, v = d(dte)/dt).
The tests check
1. that the difference is that kinetic term, cycle by cycle, up to numerics: the sampling error of
   the cycle means (estimated by redoing them on every other sample, 2 dt; the trapezoid is O(dt^2)
   once the gate switches are located, so the change from dt to 2 dt is about 3 times the error at
   dt; we allow 3 times the change) plus the internal solver's relative tolerance (rel_tol = 1e-6)
   times the force, as the balance cannot hold better than the states it is made of;
2. that after the start transient (cycles starting at t >= 0.02 s) the relative difference is below
   an a priori bound from the parameters alone (paper_scene.fig7_a_priori: the periodic mesh
   vibration forced by the gate switches, damped by chi, drifts from cycle to cycle only because the
   rig speeds up; plus the decaying start transient), about 6e-4 here;
3. the premises: the backward flank never carries, and the compliant teeth do not separate in the
   window (the a priori estimate assumes the linear, contacting mesh).
"""

import math
import sys
from pathlib import Path

import fmpy
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import paper_scene as ps  # noqa: E402

REL_TOL = 1e-6  # the FMU's default internal rel_tol


@pytest.fixture(scope="module")
def damped(fmu_path):
    fmu = str(fmu_path)
    md = fmpy.read_model_description(fmu)
    calc = ps.calculated(fmu, md)
    rc = ps.fig7_run(fmu, md, ps.CHI_DAMPED, 1)
    rr = ps.fig7_run(fmu, md, ps.CHI_DAMPED, 2)
    fine = ps.fig7_compare(ps.Trace(rc, calc), ps.Trace(rr, calc), calc)
    coarse = ps.fig7_compare(ps.Trace(rc, calc, every=2), ps.Trace(rr, calc, every=2), calc)
    return dict(calc=calc, rc=rc, rr=rr, fine=fine, coarse=coarse)


def sampling_error(d):
    """Per cycle: 3 x the change of the cycle-mean difference and of the kinetic term from dt to 2 dt."""
    f, c = d["fine"], d["coarse"]
    n = len(f["k"])
    assert len(c["k"]) == n
    return 3 * (np.abs(f["diff"] - c["diff"]) + np.abs(f["kinetic"] - c["kinetic"]))


def test_premises(damped):
    d = damped
    assert np.max(np.abs(d["rc"]["F_bwd"])) == 0 and np.max(np.abs(d["rr"]["F_bwd"])) == 0
    assert np.all(d["rr"]["n_fwd"] >= 1), "rigid contact must stay forward locked"
    f = d["fine"]
    assert len(f["k"]) >= 30, "the 0.1 s run holds about 35 whole mesh cycles"
    w = f["t0"] >= ps.FIG7_WINDOW
    assert not np.any(f["separated"][w]), "the damped mesh must not separate after the start transient"
    # Every gate switch was found inside its sample interval (else the step integration is off).
    calc = d["calc"]
    assert ps.Trace(d["rc"], calc).unlocated == 0 and ps.Trace(d["rr"], calc).unlocated == 0


def test_cycle_means_differ_by_the_kinetic_term(damped):
    """Every whole cycle, start transient included: |mean F_c - mean F_r| <= |kinetic term| + numerics."""
    f = damped["fine"]
    eps = sampling_error(damped) + REL_TOL * f["F_r"]
    bound = np.abs(f["kinetic"]) + eps
    bad = np.flatnonzero(np.abs(f["diff"]) > bound)
    assert bad.size == 0, [
        (int(k), float(f["diff"][k]), float(f["kinetic"][k]), float(eps[k])) for k in bad
    ]
    # The kinetic term is the whole difference, not just an upper bound.
    resid = np.abs(f["diff"] - f["kinetic"])
    assert np.all(resid <= eps), float(np.max(resid / eps))


def test_rigid_force_is_the_cycle_average_after_the_transient(damped):
    f, calc = damped["fine"], damped["calc"]
    ap = ps.fig7_a_priori(calc, ps.CHI_DAMPED, ps.FIG7_WINDOW)
    assert math.isfinite(ap["rel"]) and ap["rel"] < 1e-3, ap
    w = f["t0"] >= ps.FIG7_WINDOW
    assert np.sum(w) >= 25
    eps = (sampling_error(damped) + REL_TOL * f["F_r"]) / f["F_r"]
    rel = np.abs(f["rel"])
    assert np.all(rel[w] <= ap["rel"] + eps[w]), (float(np.max(rel[w])), ap["rel"])
    # The rigid force itself: rigid rolling from the spec's exact check, F = (tau_A - J_A dw_A/dt)/rAb
    # with dw_A/dt between its values at the start speed and at the end speed of the run.
    i = calc["rBb"] / calc["rAb"]
    j_eff = calc["J_A"] + calc["J_B"] / i**2

    def force(w_a):
        return (ps.SCENE["tau_A"] - calc["J_A"] * (ps.SCENE["tau_A"] - ps.SCENE["c_load"] * w_a / i**2) / j_eff) / calc["rAb"]

    w_end = damped["rr"]["w_A"][-1]
    assert np.all((f["F_r"] >= force(ps.SCENE["w_A_start"])) & (f["F_r"] <= force(w_end)))
