"""Self-tests of the independent gear-train reference (tests/reference_model/train_ref.py):
the checks of gear-train.md section 7, run ON THE REFERENCE, plus placement and validation.

    .venv/bin/python -m pytest tests/python/test_train_ref.py

Every bound says where it comes from (physics or a numerical argument); none is read off a run.
"""

import math
import os
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests"))

from reference_model import gearmesh_ref as G  # noqa: E402
from reference_model import train_ref as T  # noqa: E402

RTOL = 1e-10   # the references' integration tolerance


def standard_mesh(m, zA, zB, chi=10.0, **extra):
    sv = {f"mesh[{m}].geometry": 2, f"mesh[{m}].module": 3e-3, f"mesh[{m}].zA": zA,
          f"mesh[{m}].zB": zB, f"mesh[{m}].chi": chi}
    sv.update({f"mesh[{m}].{k}": v for k, v in extra.items()})
    return sv


# ------------------------------------------------------------------------------ 1. one mesh
def single_mesh_pair(horizon):
    """The train scene single.toml and the single-mesh scene damped.toml, both references."""
    train_scene, mesh_scene = T.load_scene("single"), G.load_scene("damped")
    tr = T.GearTrain(train_scene["start_values"])
    res_t = tr.simulate(horizon, train_scene["output_interval"], rtol=RTOL)
    res_m = G.GearMesh(mesh_scene["start_values"]).simulate(horizon, mesh_scene["output_interval"],
                                                            rtol=RTOL)
    return train_scene, mesh_scene, tr, res_t, res_m


def test_single_toml_angle_start_is_the_stated_formula():
    """single.toml's body[1].angle_start = alpha_w - s_a/rAb + tA/2 - dte_start/rAb (its
    description derives it), to rounding of a few O(1) terms."""
    sc = T.load_scene("single")
    sv = sc["start_values"]
    g = G.Geometry(G.make_params(G.load_scene("damped")["start_values"]))
    want = g.alpha_w - g.s_a / g.rAb + g.tA / 2 - sv["mesh[1].dte_start"] / g.rAb
    assert abs(sv["body[1].angle_start"] - want) < 1e-15


def test_one_mesh_two_bodies_is_the_single_mesh():
    """gear-train.md section 7: one mesh, two bodies placed as section 4 says = the single mesh.

    Bound: 0.2 x the scene's compare tolerance.  regenerate.py and regenerate_train.py accept a
    trace scene only when its reference is converged to 1/10 of each tolerance (rtol 1e-10 vs
    1e-12), so two converged references of the same trajectory differ by at most 2/10 of it.
    Event times: with the states that close, gate events (coordinates moving at >= rAb w_A ~
    19 m/s along the line of action; no delta crossings in this scene) differ by at most
    0.2 x dte tolerance / 19 m/s ~ 2e-11 s; bound 1e-9 s (1e-5 of the output interval)."""
    train_scene, mesh_scene, tr, rt, rm = single_mesh_pair(0.1)
    tol = train_scene["compare"]["tolerance"]
    gt, gm = rt.grid(), rm.grid()
    assert gt.shape[0] == gm.shape[0]
    pairs = {"mesh[1].dte": "dte", "body[1].w": "w_A", "body[2].w": "w_B",
             "mesh[1].F_fwd": "F_fwd", "mesh[1].F_f1": "F_f1", "mesh[1].F_f2": "F_f2",
             "mesh[1].P_loss": "P_loss"}
    for tn, mn in pairs.items():
        d = np.max(np.abs(gt[:, rt.names.index(tn)] - gm[:, rm.names.index(mn)]))
        assert d <= 0.2 * tol[tn], (tn, d, tol[tn])
    # contact state on the grid, the angles (the train's start at 0, the single mesh's at
    # dte_start/rAb) and the events
    for tn, mn in (("mesh[1].n_fwd", "n_fwd"), ("mesh[1].n_bwd", "n_bwd")):
        assert np.array_equal(gt[:, rt.names.index(tn)], gm[:, rm.names.index(mn)])
    g = tr.meshes[0].g
    th = gt[:, rt.names.index("body[1].theta")] + tr.meshes[0].dte0 / g.rAb
    assert np.max(np.abs(th - gm[:, rm.names.index("theta_A")])) < 1e-9
    assert len(rt.events) == len(rm.events)
    assert max(abs(a[0] - b[0]) for a, b in zip(rt.events, rm.events)) < 1e-9


# ------------------------------------------------------------------------------ 2. placement
def tooth_roots(psi, mount, beta, s, z, t, flank):
    """Spec section 3 literally: roots chi + k dz -+ t/2 (mesh-frame k = -20..z+20)."""
    chi = s * (psi + mount - beta)
    k = np.arange(-20, z + 21)
    return chi + k * 2 * math.pi / z + (-t / 2 if flank == 1 else t / 2)


PLACEMENT_CASES = [
    # a mirrored mesh (sigma_A = +1), shafts, mounts, centre angles, negative dte_start
    {**standard_mesh(1, 20, 40), **standard_mesh(2, 18, 45), "mesh[1].center_angle": 0.7,
     "mesh[2].center_angle": -2.1, "mesh[1].mount_A": 0.05, "mesh[2].mount_B": -0.3,
     "mesh[1].dte_start": 1e-6, "mesh[2].dte_start": -3e-5, "shaft[1].twist_start": 0.02,
     "body[1].angle_start": 1.3},
    # idler (mesh 2 mirrored: its A has sigma = +1), the idler placed from body 3's side
    {"n_bodies": 3, "n_shafts": 0, "n_meshes": 2, "mesh[1].A": 1, "mesh[1].B": 2,
     "mesh[2].A": 2, "mesh[2].B": 3, **standard_mesh(1, 20, 31), **standard_mesh(2, 31, 40),
     "mesh[2].center_angle": 2.3, "mesh[1].mount_B": 0.01, "mesh[2].mount_A": 0.01,
     "body[1].angle_start": -0.4, "mesh[2].dte_start": 2e-6},
    # a body placed as A of its mesh (mesh 1 is 2 -> 1), paper geometry
    {"n_bodies": 2, "n_shafts": 0, "n_meshes": 1, "mesh[1].A": 2, "mesh[1].B": 1,
     "mesh[1].center_angle": 0.2, "mesh[1].dte_start": 4e-7, "body[1].angle_start": 0.3},
]


@pytest.mark.parametrize("sv", PLACEMENT_CASES)
def test_placement_puts_every_mesh_at_its_dte_start(sv):
    """Spec section 4, checked with section 3's root formulas directly (not train_ref's
    offsets): the tooth pairs of each mesh have forward delta = dte_start and backward delta =
    -backlash - dte_start; every body placed by a mesh has psi(0) in (-pi/z, pi/z]; a shaft
    keeps the twist.  Bound 1e-12 m: rounding of O(1) angles times radii is ~1e-16 m; a wrong
    placement is off by a fraction of p_b (~1e-2 m)."""
    tr = T.GearTrain(sv)
    for mesh in tr.meshes:
        g, s = mesh.g, -tr.sigma[mesh.A]
        psiA, psiB = tr.psi0[mesh.A], tr.psi0[mesh.B]
        for flank, want in ((1, mesh.dte0), (-1, -g.backlash - mesh.dte0)):
            rA = tooth_roots(psiA, mesh.mount_A, mesh.beta, s, g.zA, g.tA, flank)
            rB = tooth_roots(psiB, mesh.mount_B, mesh.beta, s, g.zB, g.tB, flank)
            if flank == 1:
                sA, sB = g.rAb * (g.alpha_w - rA), g.rBb * (g.alpha_w + math.pi - rB)
            else:
                sA, sB = g.rAb * (g.alpha_w + rA), g.rBb * (g.alpha_w - math.pi + rB)
            delta = sA[:, None] + sB[None, :] - g.L
            assert np.min(np.abs(delta - want)) < 1e-12, (mesh.m, flank)
    for j in tr.order[1:]:
        k, i = tr.parent[j]
        if k < tr.nm:
            mesh = tr.meshes[k]
            z = mesh.g.zA if j == mesh.A else mesh.g.zB
            assert -math.pi / z < tr.psi0[j] <= math.pi / z
        else:
            s = tr.shafts[k - tr.nm]
            twist = tr.sigma[s.a] * (tr.psi0[s.a] - tr.psi0[s.b])
            assert abs(twist - s.twist0) < 1e-15


def test_senses_flip_across_meshes_and_keep_across_shafts():
    tr = T.GearTrain({})
    assert tr.sigma == [-1, 1, 1, -1]


# ------------------------------------------------------------------------------ 3. two-stage
@pytest.fixture(scope="module")
def two_stage():
    sc = T.load_scene("two-stage")
    tr, inputs = T.scene_model(sc)
    res = tr.simulate(sc["stop_time"], sc["output_interval"], inputs, rtol=RTOL)
    return sc, tr, res


def test_scene_start_values_are_the_quasi_static_start():
    """The scenes store train_ref.quasi_static_start's numbers (so they start without the
    large first transient); recomputing them reproduces them to the last digits."""
    for name in ("two-stage", "idler", "rattle"):
        sv = T.load_scene(name)["start_values"]
        qs = T.quasi_static_start(sv)
        for k, v in qs.items():
            if "dte_start" in k or "twist_start" in k or "w_start" in k:
                assert abs(v - sv[k]) <= 1e-12 * abs(v) + 1e-300, (name, k, v, sv[k])


def test_mean_speed_ratio_is_zB_over_zA(two_stage):
    """Rigid kinematics across every mesh.  Over [0, T] the mean speed ratio is
    theta_A(T)/theta_B(T); rAb theta_A - rBb theta_B = dte - dte_start, so its relative
    deviation from rBb/rAb = zB/zA is |dte(T) - dte_start| / (rBb theta_B(T)).  Bound, a priori:
    dte stays in (0, delta_1(2F)) (forward contact throughout; dynamic factor of the damped mesh
    below 2; delta_1: one pair's Johnson penetration), theta_B(T) >= 0.9 w_B(0) T."""
    sc, tr, res = two_stage
    T_end = sc["stop_time"]
    tau = np.array([b.tau for b in tr.bodies])
    _a, F, _Ts, _r = T.rigid_loads(tr, tr.bodies[0].w0, tau)
    for k, mesh in enumerate(tr.meshes):
        g = mesh.g
        thA = res.column(f"body[{mesh.A + 1}].theta")[-1]
        thB = res.column(f"body[{mesh.B + 1}].theta")[-1]
        bound = T.static_delta(mesh, 2 * F[k], 1) / (g.rBb * 0.9 * tr.bodies[mesh.B].w0 * T_end)
        assert abs((thA / thB) / (g.zB / g.zA) - 1.0) < bound, mesh.m
        assert bound < 1e-3    # meaningful: one tooth more or less is a 2 % error


def test_static_load_at_rest():
    """Static load, exact: the two-stage train at rest, motor torque 50 N.m balanced by a brake
    of -250 N.m on body 4 (no drag needed at zero speed), started at the quasi-static state:
    it stays in equilibrium and every mesh's total normal force is the torque through it over
    rAb (50 N.m through mesh 1, 100 N.m through mesh 2).  Bound 1e-7 relative: an exact
    equilibrium drifts only by the integration error (rtol 1e-10 over ~1e3 steps) and the
    start penetration's rounding."""
    sv = dict(T.load_scene("two-stage")["start_values"])
    sv.update({"body[1].w_start": 0.0, "body[4].c": 0.0, "body[4].tau": -250.0})
    sv = T.quasi_static_start(sv)
    tr = T.GearTrain(sv)
    res = tr.simulate(0.005, 5e-4, rtol=RTOL)
    for m, torque in ((1, 50.0), (2, 100.0)):
        F = res.column(f"mesh[{m}].F_fwd")
        np.testing.assert_allclose(F, torque / tr.meshes[m - 1].g.rAb, rtol=1e-7)
        assert np.all(res.column(f"mesh[{m}].n_fwd") >= 1)
    assert np.max(np.abs(res.column("shaft[1].tau") - 100.0)) < 1e-5
    for i in range(1, 5):
        assert np.max(np.abs(res.column(f"body[{i}].w"))) < 1e-6


def test_static_load_at_speed(two_stage):
    """Static load at steady speed (two-stage.toml: torques balanced by drag at the start
    speeds): the time-mean normal force of mesh m is the torque through it over rAb.  A priori
    bound: the force ripple stays within (0, 2F) (dynamic factor < 2), so the part of a mesh
    period not completed by the window shifts the mean by at most F/N, N = whole mesh periods
    in the window (from the start speed); plus the trapezoid rule's error at each force jump,
    at most 2F x dt/2 per pair switch, 2 switches per period: 2F dt/T_mesh."""
    sc, tr, res = two_stage
    t = res.column("time")
    dt = sc["output_interval"]
    for m, torque in ((1, 50.0), (2, 100.0)):
        mesh = tr.meshes[m - 1]
        F0 = torque / mesh.g.rAb
        mean = np.trapezoid(res.column(f"mesh[{m}].F_fwd"), t) / t[-1]
        w = tr.bodies[mesh.A].w0
        periods = mesh.g.zA * w * t[-1] / (2 * math.pi)
        t_mesh = 2 * math.pi / (mesh.g.zA * w)
        bound = F0 / math.floor(periods) + 2 * F0 * dt / t_mesh
        assert abs(mean - F0) < bound, (m, mean, F0, bound)


# ------------------------------------------------------------------------------ 4. stiff shaft
def test_stiffer_shaft_tends_to_one_body():
    """Two bodies on a shaft (torque 100 N.m on J1 = 0.4, drag c = 2 on J2 = 2), started at the
    quasi-static twist, against one body of J = J1 + J2: W(t) = tau/c + (w0 - tau/c) e^{-ct/J}.
    First order in 1/k: the shaft torque T_s = J2 W' + c W changes at T_s' = c W' J1/J, the
    quasi-static twist speed is T_s'/k, and the start with w1 = w2 adds an undamped (d = 0)
    oscillation of the same amplitude, so |w_i - W| <= 2 (J_other/J) |T_s'(0)|/k (largest
    at t = 0, where |W'| is largest); 25 % margin for the O(1/k) drift of the drag on the
    twisting body (c J1 |W(inf) - W(0)|/(J^2 k) ~ 10 % of the main term here)."""
    J1, J2, c, tau, w0 = 0.4, 2.0, 2.0, 100.0, 100.0
    J = J1 + J2
    dW0 = (tau - c * w0) / J
    dTs = abs(c * dW0 * J1 / J)
    errs = []
    for k in (1e3, 1e4, 1e5, 1e6):
        sv = {"n_bodies": 2, "n_shafts": 1, "n_meshes": 0, "body[1].J": J1, "body[2].J": J2,
              "body[1].c": 0.0, "body[2].c": c, "body[1].tau": tau, "body[2].tau": 0.0,
              "body[1].w_start": w0, "shaft[1].a": 1, "shaft[1].b": 2, "shaft[1].k": k,
              "shaft[1].d": 0.0}
        tr = T.GearTrain(T.quasi_static_start(sv))
        res = tr.simulate(0.2, 1e-3, rtol=RTOL)
        t = res.column("time")
        W = tau / c + (w0 - tau / c) * np.exp(-c * t / J)
        e = [np.max(np.abs(res.column(f"body[{i}].w") - W)) for i in (1, 2)]
        for ei, Jo in zip(e, (J2, J1)):
            assert ei <= 1.25 * 2 * (Jo / J) * dTs / k, (k, e)
        errs.append(e[0])
    # and the limit is approached as 1/k (first order: ratio 10 per decade)
    for a, b in zip(errs, errs[1:]):
        assert 8.0 < a / b < 12.0, errs


# ------------------------------------------------------------------------------ 5. idler phasing
IDLER_BETAS = (1.0, 2.3, 3.9)


@pytest.fixture(scope="module", params=IDLER_BETAS)
def idler_run(request):
    sv = dict(T.load_scene("idler")["start_values"])
    sv["mesh[2].center_angle"] = request.param
    sv = T.quasi_static_start(sv)
    tr = T.GearTrain(sv)
    res = tr.simulate(0.03, 1e-4, rtol=RTOL)
    return sv, tr, res


def switch_rows(res, m):
    """Times of the forward pairs entering the gate while the flank is in contact (the
    switches of idler_switch_phase), with the table rows just after them."""
    tr = res.train
    out = []
    t_col = res.column("time")
    for (t, mm, flank, _n, sgn, sA, on_b, on_a) in res.pair_changes():
        if mm == m and flank == 1 and sgn == 1 and on_b and on_a:
            g = tr.meshes[m - 1].g
            # entering at point a (s_A = s_a + delta, delta of a few um), not at the window
            assert abs(sA - g.s_a) < 1e-3 * g.p_b
            out.append((t, int(np.nonzero(t_col == t)[0][-1])))
    return out


def test_idler_phase_in_the_idler_angle(idler_run):
    """The closed form (train_ref.idler_switch_phase) against the simulation, exactly: in the
    idler's angle, from each switch of mesh 1 to the next of mesh 2, with mesh 2's penetration
    at that switch.  Bound 1e-6 of a mesh period: the angles carry the integrator's global error
    (rtol 1e-10 on angles of a few rad: ~1e-9 rad, over dz = 0.2 rad: ~1e-8) and the event
    times are located to ~1e-13 s."""
    sv, tr, res = idler_run
    dz = 2 * math.pi / tr.meshes[0].g.zB
    th = res.column("body[2].theta")
    dte2 = res.column("mesh[2].dte")
    s1, s2 = switch_rows(res, 1), switch_rows(res, 2)
    assert len(s1) >= 8 and len(s2) >= 8
    checked = 0
    for t1, i1 in s1:
        nxt = [(t2, i2) for t2, i2 in s2 if t2 > t1]
        if not nxt:
            continue
        t2, i2 = nxt[0]
        ph = (th[i2] - th[i1]) / dz
        want = T.idler_switch_phase(sv, delta2=dte2[i2])
        assert 0.0 <= ph < 1.0 + 1e-9
        assert abs(ph - want) < 1e-6, (t1, ph, want)
        checked += 1
    assert checked >= 7


def test_idler_phase_in_time(idler_run):
    """Spec section 7 literally: time from a switch of mesh 1 to the next of mesh 2 over the mesh
    period, against the closed form at the start penetration.  A priori bound: (i) mesh 2's
    penetration stays within (0, delta_1(2 F2)) (dynamic factor < 2), moving the switch by at
    most delta_1(2 F2)/p_b2 of a period; (ii) the idler's speed deviates from its mean by at
    most the impulse of a torque ripple F rb (forces within (0, 2F)) over one mesh period,
    tau_I T_mesh / J_I relative to w_I, which bounds the time-vs-angle distortion of the phase."""
    sv, tr, res = idler_run
    m1, m2 = tr.meshes
    w_I = tr.bodies[1].w0
    t_mesh = 2 * math.pi / (m1.g.zB * w_I)
    tau = np.array([b.tau for b in tr.bodies])
    _a, F, _Ts, _r = T.rigid_loads(tr, tr.bodies[0].w0, tau)
    ripple = F[0] * m1.g.rBb * t_mesh / tr.bodies[1].J / w_I
    bound = T.static_delta(m2, 2 * F[1], 1) / m2.g.p_b + ripple
    assert bound < 0.05    # discriminates: the thickness term alone is ~0.4 of a period
    t_end = res.column("time")[-1]
    w_mean = res.column("body[2].theta")[-1] / t_end
    period = 2 * math.pi / (m1.g.zB * w_mean)
    want = T.idler_switch_phase(sv)
    s1, s2 = switch_rows(res, 1), switch_rows(res, 2)
    for t1, _ in s1:
        nxt = [t2 for t2, _ in s2 if t2 > t1]
        if nxt:
            ph = (nxt[0] - t1) / period
            d = abs(ph - want)
            assert min(d, 1 - d) < bound, (t1, ph, want, bound)


def test_idler_phase_formula_terms():
    """The closed form's dependence that Parker & Lin give: turning mesh 2's centre line by da
    shifts the phase by z da/(2 pi) (mod 1); a mount offset of the idler's gear in mesh 2 by
    the same angle cancels it (s1 = +1 here: body 1 is A of mesh 1)."""
    sv = dict(T.load_scene("idler")["start_values"])
    z = sv["mesh[1].zB"]
    p0 = T.idler_switch_phase(sv)
    da = 0.037
    p1 = T.idler_switch_phase({**sv, "mesh[2].center_angle": sv["mesh[2].center_angle"] + da})
    assert abs(((p1 - p0 - z * da / (2 * math.pi)) + 0.5) % 1.0 - 0.5) < 1e-12
    p2 = T.idler_switch_phase({**sv, "mesh[2].center_angle": sv["mesh[2].center_angle"] + da,
                               "mesh[2].mount_A": da})
    assert abs(((p2 - p0) + 0.5) % 1.0 - 0.5) < 1e-12


# ------------------------------------------------------------------------------ 6. energy
@pytest.mark.parametrize("extra", [{}, {"mesh[1].chi": 0.0, "mesh[2].chi": 0.0, "shaft[1].d": 0.0},
                                   {"mesh[1].mu": 0.1, "mesh[2].mu": 0.1}],
                         ids=["damped", "elastic", "friction"])
def test_energy_residual(extra):
    """E_kin + E_el + W_loss - W_ext - E_gate is conserved (the default train: two paper-
    geometry meshes, a damped shaft).  Bound rtol x max E_kin: the integrator keeps each step's
    error below rtol relative to the state; the vibrations are resolved, so the speeds' global
    relative error stays of order rtol, and the energy (quadratic in them) and the works
    (integrated with the state, same tolerance) drift by ~rtol x E_kin.  This lies over two
    orders below the gate energy, so a bookkeeping error of a pair entering loaded would show."""
    tr = T.GearTrain(extra)
    res = tr.simulate(0.01, 1e-4, rtol=RTOL)
    Ekin = res.column("E_kin")
    bound = RTOL * Ekin.max()
    assert np.max(np.abs(res.column("energy_residual"))) < bound
    assert np.max(np.abs(res.column("E_gate"))) > 1e2 * bound
    if not extra:
        assert res.column("W_loss")[-1] > 1e2 * bound      # damping is booked
    if extra.get("mesh[1].chi") == 0.0:
        assert np.all(res.column("W_loss") == 0.0)


def test_pair_energy_closed_form_against_quadrature():
    """E_el per pair = width int_0^delta N(s; L + s) ds: train_ref's closed form at fixed rho
    plus a Gauss-Legendre correction, against adaptive quadrature at epsrel 1e-13.  Bound 1e-12
    relative: the quadrature's own tolerance plus the correction's quadrature error, which is
    weighted by its relative size delta/L <= 6e-3 over this range."""
    mesh = T.GearTrain({}).meshes[0]
    for delta in (1e-12, 1e-9, 1e-7, 5.8e-7, 3e-6, 1e-5, 1e-4, 1e-3):
        a, b = T.pair_energy(mesh, delta), T.pair_energy_quad(mesh, delta)
        assert abs(a - b) <= 1e-12 * b, (delta, a, b)
    assert T.pair_energy(mesh, 0.0) == 0.0 and T.pair_energy(mesh, -1e-6) == 0.0


# ------------------------------------------------------------------------------ 7. validation
BAD = [
    # capacity 16 bodies, 15 shafts, 16 meshes (planetary.md section 5)
    ({"n_bodies": 17}, ValueError, "n_bodies = 17"),
    ({"n_bodies": 0}, ValueError, "n_bodies = 0"),
    ({"n_meshes": 17}, ValueError, "n_meshes = 17"),
    ({"n_shafts": 16}, ValueError, "n_shafts = 16"),
    ({"n_shafts": -1}, ValueError, "n_shafts = -1"),
    ({"shaft[1].b": 5}, ValueError, "shaft[1].b = 5"),
    ({"mesh[2].A": -1}, ValueError, "mesh[2].A = -1"),     # 0 (the housing) is admitted
    ({"shaft[1].a": 3}, ValueError, "shaft[1] joins body[3] to itself"),
    ({"mesh[1].B": 1}, ValueError, "mesh[1] joins body[1] to itself"),
    # loops are admitted (planetary.md section 4), but not one whose senses conflict: a shaft
    # (keeps the sense) alongside an external mesh (flips it) between bodies 1 and 2
    ({"shaft[2].a": 1, "shaft[2].b": 2, "n_shafts": 2}, ValueError,
     "conflicting forward senses"),
    ({"n_meshes": 1, "n_shafts": 2, "shaft[2].a": 2, "shaft[2].b": 3}, ValueError,
     "body[4] not connected"),
    ({"n_shafts": 0}, ValueError, "body[3], body[4] not connected"),
    ({"mesh[2].A": 4, "mesh[2].B": 2, "shaft[1].a": 2, "shaft[1].b": 4}, ValueError,
     "body[3] not connected"),
    ({"mesh[2].contact_model": 2}, ValueError, "rigid contact"),
    ({"mesh[1].contact_model": 3}, NotImplementedError, "mesh[1]"),
    ({"mesh[1].tip_relief_A": 1e-5, "mesh[1].tip_relief_length_A": 1e-3}, NotImplementedError,
     "deviations"),
    ({"body[3].J": 0.0}, ValueError, "body[3].J"),
    ({"shaft[1].k": 0.0}, ValueError, "shaft[1].k"),
    ({"mesh[2].zA": 23}, G.GeometryError, "mesh[2]"),
    ({"body[17].J": 1.0}, KeyError, "capacity"),
    ({"mesh[1].J_A": 1.0}, KeyError, "mesh[1].J_A"),
]


@pytest.mark.parametrize("sv,exc,text", BAD, ids=[b[2] for b in BAD])
def test_validation_errors_name_the_elements(sv, exc, text):
    with pytest.raises(exc) as info:
        T.GearTrain(sv)
    assert text in str(info.value), str(info.value)


def test_conflicting_loop_message_names_its_closing_element():
    """Three external gears in a triangle: the senses conflict around the loop (planetary.md
    section 4); the message names the loop's meshes."""
    sv = {"n_bodies": 3, "n_shafts": 0, "n_meshes": 3, "mesh[2].A": 2, "mesh[2].B": 3,
          "mesh[3].A": 3, "mesh[3].B": 1}
    with pytest.raises(ValueError) as info:
        T.GearTrain(sv)
    msg = str(info.value)
    assert "conflicting forward senses" in msg, msg
    for name in ("mesh[1]", "mesh[2]", "mesh[3]"):
        assert name in msg, msg


def test_defaults_are_the_agreed_ones():
    p = T.make_train_params({})
    assert (p["n_bodies"], p["n_shafts"], p["n_meshes"]) == (4, 1, 2)
    assert [p[f"body[{i}].J"] for i in range(1, 9)] == [0.4, 2.0, 0.4, 2.0] + [1.0] * 4
    assert [p[f"body[{i}].c"] for i in range(1, 9)] == [0, 0, 0, 2.0, 0, 0, 0, 0]
    assert p["body[4].w_start"] == 100 / 2.25 and p["body[1].tau"] == 100.0
    assert (p["shaft[1].a"], p["shaft[1].b"], p["shaft[1].k"], p["shaft[1].d"]) == (2, 3, 1e5, 5.0)
    assert (p["mesh[3].A"], p["mesh[3].B"], p["mesh[1].chi"], p["mesh[1].zA"]) == (5, 6, 10.0, 22)


# ------------------------------------------------------------------------------ 8. lumped mesh
# contact_model = 4 (lateral.md section 4): the train's law (train_ref.TrainMesh, pairs numbered
# by A's tooth count) against the single mesh's (lumped_ref.LumpedMesh, gearmesh_ref's pair
# enumeration): the same torsional model, two codes.
def single_scene_as_train(mesh_scene):
    """A single-mesh scene's start values and inputs as a one-mesh, two-body train (placed as
    scenes/train/single.toml: body[1].angle_start = alpha_w - s_a/rAb + tA/2 - dte_start/rAb)."""
    sv = mesh_scene["start_values"]
    m, inp = G.scene_model(mesh_scene)
    p, g = m.p, m.g
    tsv = {"n_bodies": 2, "n_shafts": 0, "n_meshes": 1,
           "body[1].J": p["J_A"], "body[2].J": p["J_B"], "body[1].c": 0.0, "body[2].c": p["c_load"],
           "body[1].tau": p["tau_A"], "body[2].tau": p["tau_B"],
           "body[1].w_start": p["w_A_start"], "body[2].w_start": p["w_B_start"],
           "body[1].angle_start": g.alpha_w - g.s_a / g.rAb + g.tA / 2 - p["dte_start"] / g.rAb,
           "mesh[1].A": 1, "mesh[1].B": 2}
    for k, v in sv.items():
        if k in T.MESH_PAIR_KEYS:
            tsv[f"mesh[1].{k}"] = v
    tinp = T.TrainInputs(inp.t, np.column_stack([inp.a, inp.b]))
    return m, inp, T.GearTrain(tsv), tinp


LUMPED_AS_TRAIN = {"dte": "mesh[1].dte", "w_A": "body[1].w", "w_B": "body[2].w",
                   "F_fwd": "mesh[1].F_fwd", "F_bwd": "mesh[1].F_bwd", "F_f1": "mesh[1].F_f1",
                   "F_f2": "mesh[1].F_f2", "P_loss": "mesh[1].P_loss", "k_mesh": "mesh[1].k_mesh"}


@pytest.mark.parametrize("name", ["lumped", "lumped-varies"])
def test_lumped_one_mesh_train_is_the_single_mesh(name):
    """The single-mesh lumped scenes (a load reversal with re-impacts; the square-wave
    stiffness) as one-mesh trains: every compared variable within 0.2 x the scene's tolerance
    (two references each converged to 1/10 of it, test_one_mesh_two_bodies_is_the_single_mesh's
    argument; the F_b1/F_b2 split too, within F_bwd's), the contact state (n_fwd, n_bwd) equal on
    the grid, the same events within 1e-9 s (the event times agree to rounding x the line speed
    and the speeds' integration error, ~1e-11 s)."""
    sc = G.load_scene(name)
    m, inp, tr, tinp = single_scene_as_train(sc)
    rm = m.simulate(sc["stop_time"], sc["output_interval"], inp, rtol=RTOL)
    rt = tr.simulate(sc["stop_time"], sc["output_interval"], tinp, rtol=RTOL)
    gm, gt = rm.grid(), rt.grid()
    tol = sc["compare"]["tolerance"]
    assert gm.shape[0] == gt.shape[0]
    pairs = dict(LUMPED_AS_TRAIN, F_b1="mesh[1].F_b1", F_b2="mesh[1].F_b2")
    for mn, tn in pairs.items():
        bound = 0.2 * tol.get(mn, tol.get("F_bwd", tol["F_fwd"]))
        d = np.max(np.abs(gt[:, rt.names.index(tn)] - gm[:, rm.names.index(mn)]))
        assert d <= bound, (mn, d, bound)
    for mn in ("n_fwd", "n_bwd"):
        assert np.array_equal(gt[:, rt.names.index(f"mesh[1].{mn}")], gm[:, rm.names.index(mn)])
    assert len(rt.events) == len(rm.events) > 20
    assert max(abs(a[0] - b[0]) for a, b in zip(rt.events, rm.events)) < 1e-9


def test_lumped_planetary_energy_residual():
    """scenes/train/lumped-planetary.toml (six lumped meshes, one with the square-wave
    stiffness) over its first 10 ms: E_kin + E_el + W_loss - W_ext - E_gate is conserved, bound
    rtol x max E_kin (test_energy_residual's argument); the stiffness switches of mesh 1 are
    booked in E_gate (> 100 x the bound) and the damping in W_loss; every lumped mesh reports
    k_mesh = k_lumped (constant ones) or k_lumped n/eps (mesh 1)."""
    sc = T.load_scene("lumped-planetary")
    tr, inputs = T.scene_model(sc)
    res = tr.simulate(0.01, sc["output_interval"], inputs, rtol=RTOL)
    bound = RTOL * res.column("E_kin").max()
    assert np.max(np.abs(res.column("energy_residual"))) < bound
    assert np.max(np.abs(res.column("E_gate"))) > 1e2 * bound
    assert res.column("W_loss")[-1] > 1e2 * bound
    k = sc["start_values"]["mesh[1].k_lumped"]
    eps = tr.meshes[0].g.eps
    assert np.allclose(res.column("mesh[1].k_mesh"), k * res.column("mesh[1].n_fwd") / eps,
                       rtol=1e-15, atol=0)
    for m in range(2, 7):
        assert np.all(res.column(f"mesh[{m}].k_mesh") == k)
    assert set(np.unique(res.column("mesh[1].n_fwd"))) == {1.0, 2.0}


def test_lumped_planetary_static_start():
    """scenes/train/lumped-planetary.toml stores train_ref.quasi_static_start's numbers (to the
    last digits, as test_scene_start_values_are_the_quasi_static_start); at t = 0 (rigid speeds:
    every mesh's d(delta)/dt = 0) each mesh's force is its spring's, F = k_eff dte with k_eff =
    k_lumped n/eps on the varying mesh 1 (n its gated pairs) and k_lumped on the others (1e-14);
    the set is at its Willis speeds with the carrier drag balancing the sun, so the sun-planet
    forces carry T_sun/rb_sun (1e-8: the static solve's convergence)."""
    sc = T.load_scene("lumped-planetary")
    sv = sc["start_values"]
    qs = T.quasi_static_start(sv)
    for k, v in qs.items():
        if "dte_start" in k or "w_start" in k:
            assert abs(v - sv[k]) <= 1e-12 * abs(v) + 1e-300, (k, v, sv[k])
    tr = T.GearTrain(sv)
    y = tr.initial_state()
    tau = np.array([b.tau for b in tr.bodies])
    row = tr.outputs(0.0, y, tr.classify(0.0, y, tau), 0.0)
    col = dict(zip(tr.output_names(), row))
    k = sv["mesh[1].k_lumped"]
    for mesh in tr.meshes:
        m = mesh.m
        n = col[f"mesh[{m}].n_fwd"]
        k_eff = k * n / mesh.g.eps if m == 1 else k
        assert n >= 1 and col[f"mesh[{m}].n_bwd"] == 0
        assert abs(col[f"mesh[{m}].F_fwd"] - k_eff * col[f"mesh[{m}].dte"]) <= 1e-14 * col[f"mesh[{m}].F_fwd"]
        assert col[f"mesh[{m}].k_mesh"] == k_eff
    Fsum = sum(col[f"mesh[{m}].F_fwd"] for m in (1, 2, 3))
    assert abs(Fsum - tau[0] / tr.meshes[0].g.rAb) <= 1e-8 * Fsum


LUMPED_BAD = [
    ({"mesh[1].contact_model": 4, "mesh[1].tip_relief_A": 1e-5, "mesh[1].tip_relief_length_A": 1e-3},
     ValueError, "mesh[1]: contact_model = 4"),
    ({"mesh[2].contact_model": 4, "mesh[2].k_lumped": 0.0}, ValueError, "mesh[2]: k_lumped"),
    ({"mesh[2].contact_model": 4, "mesh[2].c_lumped": -5.0}, ValueError, "mesh[2]: c_lumped"),
    ({"mesh[1].slider_stiffness": 1e8}, KeyError, "mesh[1].slider_stiffness"),
    ({"mesh[1].contact_model": 5}, ValueError, "must be 1, 3 or 4"),
]


@pytest.mark.parametrize("sv,exc,text", LUMPED_BAD, ids=[b[2] for b in LUMPED_BAD])
def test_lumped_validation_errors_name_the_mesh(sv, exc, text):
    with pytest.raises(exc) as info:
        T.GearTrain(sv)
    assert text in str(info.value), str(info.value)


# ------------------------------------------------------------------------------ 8. bearing forces
# lateral.md sections 6-7 for a torsional train (every centre held): body[i].Fx, body[i].Fy,
# housing.Fx, housing.Fy (train_ref's module docstring, BEARING FORCES).

def bearing_columns(res, i):
    return res.column(f"body[{i}].Fx"), res.column(f"body[{i}].Fy")


@pytest.mark.parametrize("pinion", [1, 2], ids=["pinion-body1-sigma-1", "pinion-body2-sigma+1-mirrored"])
def test_bearing_force_of_a_single_pair_at_static_load(pinion):
    """lateral.md section 7: a single external pair at static load: the pinion's bearing force is
    tau_A / rAb along n_f, the direction in which the forward flank pushes wheel B.  Gear-train.md
    section 3 places the pair: n_f = Rot(beta) (sin aw, -cos aw) when the pinion's forward sense
    is clockwise (sigma_A = -1), and its mirror image Rot(beta) (sin aw, cos aw) when it is
    counter-clockwise (sigma_A = +1: the pinion is body 2, reached from body 1 across the mesh).
    The wheel's bearing takes the opposite force and the housing nothing.  At rest (the torques
    balanced, no sliding, so no friction), started at the static load: bound 1e-7 relative as
    test_static_load_at_rest (the equilibrium drifts only by the integration error)."""
    tau_A, beta = 30.0, 0.7
    wheel = 3 - pinion
    sv = {"n_bodies": 2, "n_shafts": 0, "n_meshes": 1, "mesh[1].A": pinion, "mesh[1].B": wheel,
          "mesh[1].center_angle": beta, f"body[{pinion}].tau": tau_A, "body[1].w_start": 0.0,
          "body[2].c": 0.0}
    sv.update(standard_mesh(1, 17, 41))
    g = T.GearTrain(sv).meshes[0].g
    sv[f"body[{wheel}].tau"] = -tau_A * g.rBb / g.rAb
    tr = T.GearTrain(T.quasi_static_start(sv))
    assert tr.sigma[pinion - 1] == (-1 if pinion == 1 else 1)
    res = tr.simulate(0.002, 2e-4, rtol=RTOL, bearing_forces=True)
    F = tau_A / g.rAb
    s = -tr.sigma[pinion - 1]
    n_f = (math.cos(beta) * math.sin(g.alpha_w) + math.sin(beta) * s * math.cos(g.alpha_w),
           math.sin(beta) * math.sin(g.alpha_w) - math.cos(beta) * s * math.cos(g.alpha_w))
    for k, (fx, fy) in enumerate(zip(*bearing_columns(res, pinion))):
        assert math.hypot(fx - F * n_f[0], fy - F * n_f[1]) <= 1e-7 * F, (k, fx, fy, F, n_f)
    for a, b in zip(bearing_columns(res, wheel), bearing_columns(res, pinion)):
        np.testing.assert_allclose(a, -b, rtol=0, atol=1e-9 * F)
    for h in ("housing.Fx", "housing.Fy"):
        assert np.max(np.abs(res.column(h))) <= 1e-9 * F
    assert np.all(res.column("mesh[1].n_fwd") >= 1)


def friction_everywhere(sv, mu=0.05):
    out = dict(sv)
    for m in range(1, out["n_meshes"] + 1):
        out[f"mesh[{m}].mu"] = mu
    return out


def test_held_sun_among_planets_in_phase_feels_no_force():
    """lateral.md section 7: a rigidly held sun among N equally spaced identical planets without
    errors, in phase (z_sun / N an integer: planetary-simple, 21/18/57, 21/3 = 7): its bearing
    force is zero at every instant; so are the carrier's and the housing's (sum r_n = 0).  With
    friction on every mesh (mu 0.05: the friction forces cancel by the same symmetry).
    Bound: the three planets' trajectories differ only by rounding (orbit angles 2 pi/3 in
    floating point, placement) and by the integration error, which is not symmetric (mesh 1
    is a coordinate, meshes 2 and 3 close loops): at most the second-tolerance difference of a
    dte, ~1e-13 m (accuracy_planetary.md), times a mesh's tangent stiffness (< 2e9 N/m) per
    mesh, and the friction's response to a speed difference of the same order (mu F dv / v_reg,
    negligible): 1e-3 N, against 800 N per sun-planet mesh.  The control: the same set out of
    phase (planetary-pin-error's 20/22/64 without its pin error, 20/3 teeth per spacing), where
    the mesh harmonics drive the sun: its bearing force reaches more than 10 N."""
    horizon = 0.004
    for name, bound, want_zero in (("planetary-simple", 1e-3, True),
                                   ("planetary-pin-error", 10.0, False)):
        sv = friction_everywhere(T.load_scene(name)["start_values"])
        sv["body[3].pin_error_t"] = 0.0
        tr = T.GearTrain(sv)
        res = tr.simulate(horizon, 4e-5, rtol=RTOL, bearing_forces=True)
        sun = np.hypot(*bearing_columns(res, 1))
        load = res.column("mesh[1].F_fwd")
        assert np.min(load) > 100.0
        if want_zero:
            assert np.max(sun) <= bound, np.max(sun)
            assert np.max(np.hypot(*bearing_columns(res, 2))) <= 3 * bound
            assert np.max(np.hypot(res.column("housing.Fx"), res.column("housing.Fy"))) <= 3 * bound
            # while each planet's pin carries its two meshes' normal forces tangentially, times
            # cos(alpha_w) (the same alpha_w in both: the set's design), and friction's part, at
            # most mu (F_sun + F_ring) sin(alpha_w) < mu (F_sun + F_ring)
            g = tr.meshes[0].g
            Fy = res.column("body[3].Fy")
            both = load + res.column("mesh[4].F_fwd")
            assert abs(tr.meshes[3].g.alpha_w - g.alpha_w) < 1e-12
            assert np.all(np.abs(Fy - both * math.cos(g.alpha_w)) <= 0.05 * both)
        else:
            assert np.max(sun) > bound, np.max(sun)


def test_planet_pin_carries_the_centripetal_force():
    """lateral.md section 7: a planet at carrier speed Omega: its pin's radial force carries the
    centripetal m R Omega^2, inwards.  planetary-simple's loaded set with a heavy carrier
    (J 1e3: it turns at constant Omega, |alpha| <= 2 x 185.7 N.m / 1e3 kg.m^2 with the dynamic
    factor below 2), run twice: planets of m = 0.3 kg, and massless planets with the carrier's
    J raised by the orbital inertia they no longer add (bit for bit the same J, so the same
    trajectory to the last bit: the planets' mass enters the torsional equations only there).
    Each pin then carries exactly -m R Omega^2 more radially (Omega = -w_carrier's output, R the
    orbit radius: no pin error), and m R alpha tangentially, below the alpha bound.  Bound:
    rounding of P = m a - (mesh forces ~1 kN): 1e-12 x 1 kN."""
    sv = T.load_scene("planetary-simple")["start_values"]
    heavy = dict(sv, **{"body[2].J": 1e3})
    tr_m = T.GearTrain(heavy)
    light = dict(heavy, **{"body[2].J": 1e3 + tr_m.J_orbit[1]})
    for i in (3, 4, 5):
        light[f"body[{i}].m"] = 0.0
    tr_0 = T.GearTrain(light)
    assert tr_0.J[1] == tr_m.J[1]
    res_m = tr_m.simulate(0.003, 4e-5, rtol=RTOL, bearing_forces=True)
    res_0 = tr_0.simulate(0.003, 4e-5, rtol=RTOL, bearing_forces=True)
    assert np.array_equal(res_m.column("body[1].w"), res_0.column("body[1].w"))
    Om = res_m.column("body[2].w")
    m, R = 0.3, tr_m.R[2]
    alpha_max = 2 * 185.72 / 1e3
    assert np.ptp(Om) < 1e-4 * Om[0]
    for i in (3, 4, 5):
        dFx = res_m.column(f"body[{i}].Fx") - res_0.column(f"body[{i}].Fx")
        dFy = res_m.column(f"body[{i}].Fy") - res_0.column(f"body[{i}].Fy")
        np.testing.assert_allclose(dFx, -m * R * Om ** 2, rtol=0, atol=1e-9)
        assert np.max(np.abs(dFy)) <= m * R * alpha_max + 1e-9
        assert np.all(-m * R * Om ** 2 < -8.0)     # meaningful: ~8.7 N against the ~1e-9 bound


def test_bearing_forces_balance_the_torsional_carrier_and_the_housing():
    """The force directions against the spec's torque tables (gear-mesh-model.md section 4,
    planetary.md section 1), in planetary-bearings (pin error, friction on every mesh, an
    accelerating carrier), at the states of every contact event of its first 6 ms, before and
    after each:
      * the moment of the pins' forces on the carrier, -sum |r_n| Fy_n, is the torsional
        model's mesh reaction on the carrier (minus the sum of the meshes' torques, absolute)
        less the orbital inertia's sum m |r_n|^2 alpha.  For a mesh's forces acting at one
        contact point their moments about the carrier's axis cancel (action and reaction on one
        line), so the pin moment r_n x F is minus the meshes' torques; the spec's friction arms
        s_A + s_B = L + delta (external; L - delta internal) differ from one point's L by
        delta, so the identity holds to sum over carrying pairs |F_t| |delta| <= mu sum_m F_m
        |dte_m| (bound: twice that, plus 1e-12 of the torque).  A normal force on the wrong
        flank's line or a friction force of the wrong direction misses by about F rb or
        2 mu F L ~ 3 N.m;
      * the housing's force is -sum_n m_n a_n (Newton's third law over the meshes), a_n =
        Rot(psi_c) (-Omega^2 r_n + alpha J r_n): 0.5 mN from the pin error, to rounding of the
        kN forces it is formed from (1e-9 N)."""
    sc = T.load_scene("planetary-bearings")
    tr, inputs = T.scene_model(sc)
    res = tr.simulate(0.006, sc["output_interval"], inputs, rtol=RTOL, bearing_forces=True)
    assert len(res.events) > 20
    c = 1                                        # the carrier, body 2
    mu = sc["start_values"]["mesh[1].mu"]
    names = tr.output_names()
    planets = [i for i in range(tr.nb) if tr.is_planet(i)]
    n_checked = 0
    for t, y, cb, ca in res.events:
        tau = np.array([b.tau for b in tr.bodies])
        for cfg in (cb, ca):
            row = dict(zip(names, tr.outputs(t, y, cfg, 0.0, bearing=True, tau=tau)))
            Q, _pl, w = tr.forces(t, y, cfg, tau)
            Qd, _P = tr._drag(w)
            M_c = tr.sigma[c] * (Q[c] - Qd[c] - tau[c])          # meshes' reaction, absolute
            alpha = tr.sigma[c] * tr.accelerations(t, y, cfg, tau)[c]
            Om = tr.sigma[c] * w[c]
            psi_c = tr.sigma[c] * (tr.T @ y[:tr.n])[c]
            pins, inertia, ma = 0.0, 0.0, np.zeros(2)
            for i in planets:
                r = np.array(tr.planet_position(i))
                rn = math.hypot(*r)
                pins -= rn * row[f"body[{i + 1}].Fy"]
                m = tr.bodies[i].mass
                inertia += m * rn * rn * alpha
                ma += m * (-Om * Om * r + alpha * np.array([-r[1], r[0]]))
            slack = sum(mu * (row[f"mesh[{k}].F_fwd"] + row[f"mesh[{k}].F_bwd"])
                        * abs(row[f"mesh[{k}].dte"]) for k in range(1, tr.nm + 1))
            assert abs(pins - (M_c - inertia)) <= 2 * slack + 1e-12 * abs(M_c), (t, pins, M_c, inertia, slack)
            assert 1e-4 < 2 * slack < 0.1           # the bound is far below a wrong direction's error
            cs, sn = math.cos(psi_c), math.sin(psi_c)
            want = -np.array([cs * ma[0] - sn * ma[1], sn * ma[0] + cs * ma[1]])
            got = np.array([row["housing.Fx"], row["housing.Fy"]])
            assert np.max(np.abs(got - want)) <= 1e-9, (t, got, want)
            n_checked += 1
    assert n_checked > 40
