"""Self-tests of the planetary extension of the independent gear-train reference
(tests/reference_model/train_ref.py, GENERAL mode): the checks of planetary.md sections 3, 4 and
6, run ON THE REFERENCE (no FMU), on the scenes scenes/train/planetary-*.toml and power-split.toml.

    .venv/bin/python -m pytest -q tests/python/test_planetary_ref.py

Every bound says where it comes from (physics or a numerical argument); none is read off a run.
The dynamic-load bounds use the argument of test_train_ref.py (test_static_load_at_speed): the
force of a damped mesh stays within (0, 2F) (dynamic factor below 2), so the part of a mesh
period not completed by the window shifts a mean force by at most F/N_periods, plus the
trapezoid rule's error at each pair switch, 2F dt/T_mesh.
"""

import math
import os
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests"))

from reference_model import train_ref as T  # noqa: E402

RTOL = 1e-10          # the references' integration tolerance
EPS = 2.0 ** -52


def run(name):
    sc = T.load_scene(name)
    tr, inputs = T.scene_model(sc)
    res = tr.simulate(sc["stop_time"], sc["output_interval"], inputs, rtol=RTOL)
    return sc, tr, res


@pytest.fixture(scope="module")
def simple():
    return run("planetary-simple")


@pytest.fixture(scope="module")
def pin():
    return run("planetary-pin-error")


def set_data(tr, sun_mesh=1, ring_mesh=None):
    g = tr.meshes[sun_mesh - 1].g
    zs = g.zA
    zr = next(m.g.zB for m in tr.meshes if m.internal)
    return zs, zr, g


def mean_force_bound(F0, tr, w_rel, T_end, dt, z):
    """test_static_load_at_speed's bound: F0/floor(periods) + 2 F0 dt/T_mesh, the mesh period
    from the sun's start speed relative to the carrier."""
    t_mesh = 2 * math.pi / (z * w_rel)
    periods = T_end / t_mesh
    return F0 / math.floor(periods) + 2 * F0 * dt / t_mesh


# ------------------------------------------------------------------------------ 1. kinematics
def test_willis_ratio(simple):
    """planetary.md section 6, Willis: mean w_carrier / w_sun = z_sun/(z_sun + z_ring).

    Exact identity (section 3's relative angles, ring fixed: theta_ring_rel = theta_c, sun and
    carrier both sigma -1): e_sun + e_ring = rs theta_s - (rs + rr) theta_c for each planet,
    e = dte - dte(0).  So theta_c(T)/theta_s(T) = rs/(rs + rr) - (de_s + de_r)/((rs + rr)
    theta_s(T)); rs/(rs + rr) = zs/(zs + zr) (base radii are m z cos(a0)/2).  A priori bound:
    each dte stays in (0, delta_1(2F)) (forward contact, dynamic factor < 2), theta_s(T) >=
    0.9 w_s(0) T.  The identity itself is checked to rounding: the angles of a few rad carry
    ~1e-15 relative, times rr ~ 0.05 m: bound 1e-12 m."""
    sc, tr, res = simple
    zs, zr, g = set_data(tr)
    rs, rr = g.rAb, tr.meshes[3].g.rBb
    ths = res.column("body[1].theta")
    thc = res.column("body[2].theta")
    for k in range(3):
        es = res.column(f"mesh[{k + 1}].dte") - tr.meshes[k].dte0
        er = res.column(f"mesh[{k + 4}].dte") - tr.meshes[k + 3].dte0
        assert np.max(np.abs(es + er - (rs * ths - (rs + rr) * thc))) < 1e-12
    T_end = res.column("time")[-1]
    F = 50.0 / (3 * rs)
    d1 = T.static_delta(tr.meshes[0], 2 * F, 1) + T.static_delta(tr.meshes[3], 2 * F, 1)
    bound = d1 / ((rs + rr) * 0.9 * tr.bodies[0].w0 * T_end)
    assert bound < 1e-4          # discriminates: one tooth more on the ring is a 1 % change
    assert abs(thc[-1] / ths[-1] - zs / (zs + zr)) < bound


def test_loop_mesh_dte_is_its_placement_plus_relative_angles(simple):
    """planetary.md section 4 (agreed form): a loop-closing mesh's dte = delta0 + rAb
    theta_A_rel - rBb theta_B_rel, theta_rel = theta - sigma sigma_c theta_c, and delta0 lies
    within [-j_n - 0.01 p_b, 0.01 p_b].  Bound: the body angles (a few rad) carry ~1e-15 rad,
    times radii ~0.05 m: 1e-12 m; the integrated coordinate itself is precise to ~1e-16 m."""
    sc, tr, res = simple
    loops = [m for m in tr.meshes if m.loop]
    assert [m.m for m in loops] == [2, 3]          # planets 2, 3 close loops through the sun
    th = {i: res.column(f"body[{i + 1}].theta") for i in range(tr.nb)}
    for m in loops:
        g = m.g
        assert -g.backlash - 0.01 * g.p_b <= m.dte0 <= 0.01 * g.p_b
        sc_ = tr.sigma[m.carrier]
        thA = th[m.A] - m.sgA * sc_ * th[m.carrier]
        thB = th[m.B] - m.sgB * sc_ * th[m.carrier]
        want = m.dte0 + g.rAb * thA - g.rBb * thB
        assert np.max(np.abs(res.column(f"mesh[{m.m}].dte") - want)) < 1e-12


def test_senses_and_placement(simple):
    """Agreed rules: sun -1 (body 1), planets +1 (external mesh), carrier -1 (its own part);
    planets placed from the fixed ring within (-pi/z, pi/z]; the placing meshes start at their
    dte_start; the orbit radius is the sun-planet pair's nominal operating distance."""
    sc, tr, res = simple
    assert tr.sigma == [-1, -1, 1, 1, 1]
    for i in (2, 3, 4):
        z = tr.meshes[0].g.zB
        assert -math.pi / z < tr.psi0[i] <= math.pi / z
        assert tr.R[i] == tr.meshes[0].g.d_nominal
    for m in tr.meshes:
        if not m.loop:
            assert m.dte0 == sc["start_values"][f"mesh[{m.m}].dte_start"]


def test_orbital_inertia_in_E_kin(simple):
    """E_kin(0) = sum J w^2/2 + sum_planets m R^2 w_c^2/2 (planetary.md section 3), exactly up
    to rounding (1e-14 relative)."""
    sc, tr, res = simple
    sv = sc["start_values"]
    e = 0.0
    for i in range(1, tr.nb + 1):
        e += 0.5 * sv[f"body[{i}].J"] * sv[f"body[{i}].w_start"] ** 2
    wc = sv["body[2].w_start"]
    for i in (3, 4, 5):
        e += 0.5 * sv[f"body[{i}].m"] * tr.R[i - 1] ** 2 * wc ** 2
    assert abs(res.column("E_kin")[0] - e) < 1e-14 * e


# ------------------------------------------------------------------------------ 2. torques
def test_static_start_torques_and_housing(simple):
    """At t = 0 (the quasi-static start: every edge coordinate unaccelerated) each sun-planet
    mesh carries T_s/(N rb_s) (equal, in-phase planets: 21/3 teeth per spacing), the ring's
    reaction housing.tau = T_s z_ring/z_sun, and the carrier's load T_s (1 + z_ring/z_sun)
    balances both: housing.tau = T_sun + T_carrier in absolute terms (sun forward = clockwise:
    -50; carrier load -c w_c, carrier forward clockwise: + c w_c).  Bound 1e-8 relative: the
    quasi-static solve converges to edge accelerations below 1e-6 of one penetration scale per
    ms^2 (a force error ~1e-9 relative)."""
    sc, tr, res = simple
    zs, zr, g = set_data(tr)
    Ts = tr.bodies[0].tau
    for k in (1, 2, 3):
        F = res.column(f"mesh[{k}].F_fwd")[0]
        assert abs(F - Ts / (3 * g.rAb)) < 1e-8 * F
    h = res.column("housing.tau")[0]
    assert abs(h - Ts * zr / zs) < 1e-8 * h
    Tc = tr.bodies[1].c * tr.bodies[1].w0
    assert abs(Tc - Ts * (1 + zr / zs)) < 1e-12 * Tc
    assert abs(h - (Tc - Ts)) < 1e-8 * h


def test_mean_torques_at_steady_speed(simple):
    """planetary.md section 6, torques and load sharing at steady speed: the time-mean normal
    force of every sun-planet mesh is T_s/(N rb_s); housing.tau's mean is T_s z_ring/z_sun
    (the carrier's T_s (1 + z_ring/z_sun) minus the sun's T_s).  Bound: the module docstring's
    per-mesh bound; housing.tau = sum over the planets of the ring meshes' torques, so its
    bound is N x that bound x rb_r."""
    sc, tr, res = simple
    zs, zr, g = set_data(tr)
    Ts = tr.bodies[0].tau
    t = res.column("time")
    T_end, dt = t[-1], sc["output_interval"]
    w_rel = tr.bodies[0].w0 - tr.bodies[1].w0
    F0 = Ts / (3 * g.rAb)
    bound = mean_force_bound(F0, tr, w_rel, T_end, dt, zs)
    assert bound < 0.2 * F0
    for k in (1, 2, 3):
        mean = np.trapezoid(res.column(f"mesh[{k}].F_fwd"), t) / T_end
        assert abs(mean - F0) < bound, (k, mean, F0, bound)
    rr = tr.meshes[3].g.rBb
    h = np.trapezoid(res.column("housing.tau"), t) / T_end
    assert abs(h - Ts * zr / zs) < 3 * bound * rr


def test_pin_error_keeps_the_sum_and_changes_the_share(pin):
    """planetary.md section 6: a tangential pin error on one planet changes its share, the sum
    over the planets stays T_sun/rb_sun.  Sum: the per-mesh bound x N (each mean within it).
    Share: planet 1's mean force exceeds the equal share by more than that bound (the loop
    shift 1.6 et = 3.2 um is comparable to the static penetration, ~4 um)."""
    sc, tr, res = pin
    zs, zr, g = set_data(tr)
    Ts = tr.bodies[0].tau
    t = res.column("time")
    T_end, dt = t[-1], sc["output_interval"]
    w_rel = tr.bodies[0].w0 - tr.bodies[1].w0
    F0 = Ts / (3 * g.rAb)
    bound = mean_force_bound(F0, tr, w_rel, T_end, dt, zs)
    means = [np.trapezoid(res.column(f"mesh[{k}].F_fwd"), t) / T_end for k in (1, 2, 3)]
    # the sum's bound: 2 x the total force's period remainder (all planets share one window)
    assert abs(sum(means) - Ts / g.rAb) < 3 * bound
    assert means[0] > F0 + bound
    assert tr.bodies[2].pin_t == 2e-6


def test_static_shares_phasing_and_pin_error():
    """The quasi-static start (a fixed sun, no floating member): the sum of the sun-planet forces
    is T_sun/rb_sun in every case (1e-8: the solve's convergence).  The INSTANTANEOUS shares are
    equal only when the planets mesh in phase: every planet closes the same loop penetration
    (sun and ring are rigid), and a mesh with two pairs in contact is stiffer than one with one,
    so out-of-phase planets share by their momentary pair counts; planetary.md section 6 asks
    for equal MEAN forces (test_mean_torques_at_steady_speed).  planetary-simple (21/3 = 7 teeth
    per spacing, in phase): equal to 1e-6 (the loop penetrations agree to rounding, ~1e-16 m of
    ~1e-6 m, the solve to 1e-8).  planetary-pin-error's 20/22/64 set (20/3 teeth: out of phase):
    unequal without error; with the scene's 2 um pin error planet 1's share grows by more than
    30 % (the loop shift 1.6 et = 3.2 um against a static penetration of about 4 um); at 20 um (the
    scale first suggested for this scene) planet 1 takes all of it, planets 2 and 3 float."""
    def start_forces(sv):
        sv = T.quasi_static_start(sv)
        tr = T.GearTrain(sv)
        y = tr.initial_state()
        tau = np.array([b.tau for b in tr.bodies])
        row = tr.outputs(0.0, y, tr.classify(0.0, y, tau), 0.0)
        names = tr.output_names()
        F = [row[names.index(f"mesh[{k}].F_fwd")] for k in (1, 2, 3)]
        Fsum = tau[0] / tr.meshes[0].g.rAb
        assert abs(sum(F) - Fsum) < 1e-8 * Fsum
        return F
    F = start_forces(T.load_scene("planetary-simple")["start_values"])
    assert max(F) - min(F) < 1e-6 * max(F)
    sv0 = T.load_scene("planetary-pin-error")["start_values"]
    out = {et: start_forces({**sv0, "body[3].pin_error_t": et}) for et in (0.0, 2e-6, 2e-5)}
    assert max(out[0.0]) - min(out[0.0]) > 0.1 * max(out[0.0])        # out of phase
    assert out[2e-6][0] > 1.3 * out[0.0][0]
    assert out[2e-5][1] == 0.0 and out[2e-5][2] == 0.0


# ------------------------------------------------------------------------------ 3. energy
@pytest.mark.parametrize("name", ["planetary-simple", "planetary-mounted", "planetary-pin-error",
                                  "planetary-two-stage", "power-split"])
def test_energy_residual(name):
    """E_kin + E_el + W_loss - W_ext - E_gate is conserved (the housing does no work; W_ext
    includes the drags, relative for the planets).  Bound rtol x max E_kin, the argument of
    test_train_ref.test_energy_residual.  Over the first 10 ms of each scene."""
    sc = T.load_scene(name)
    tr, inputs = T.scene_model(sc)
    res = tr.simulate(0.01, sc["output_interval"], inputs, rtol=RTOL)
    assert np.max(np.abs(res.column("energy_residual"))) < RTOL * res.column("E_kin").max()


def test_housing_tau_of_the_torque_arm():
    """planetary-mounted: housing.tau is the torque the shaft to the housing applies to body 0,
    with the ring's sense: housing.tau = sigma_ring x shaft torque exactly.  At the start the arm
    carries the ring's reaction T_s z_r/z_s, changed by the planets' bearing drag c_p on their
    speed relative to the carrier, w_rel = (w_s - w_c) z_s/z_p: each planet's two mesh forces
    differ by c_p w_rel/rb_p, which moves the ring torque by N c_p w_rel z_r/z_p; and the drag's
    power P = N c_p w_rel^2, not balanced by the load, decelerates the train, which takes at most
    J_s |a_s| <= P/w_s off the sun's mesh torque (the reflected inertia exceeds J_s), times
    z_r/z_s on the ring."""
    sc = T.load_scene("planetary-mounted")
    sv = sc["start_values"]
    tr, inputs = T.scene_model(sc)
    res = tr.simulate(0.002, sc["output_interval"], inputs, rtol=RTOL)
    Ts, zs, zp, zr, N = 40.0, 24, 20, 64, 4
    ws, wc, cp = sv["body[1].w_start"], sv["body[2].w_start"], sv["body[4].c"]
    w_rel = (ws - wc) * zs / zp
    bound = N * cp * w_rel * zr / zp + N * cp * w_rel ** 2 / ws * zr / zs
    s = res.column("shaft[1].tau")
    assert abs(s[0] - Ts * zr / zs) < bound
    assert bound < 0.01 * Ts * zr / zs
    np.testing.assert_array_equal(res.column("housing.tau"), tr.sigma[2] * s)


def test_power_split_kinematics():
    """power-split: no housing, two degrees of freedom (sun and carrier free), every mesh on its
    backward flank (the generator brakes the sun): at the start w_sun = (1 + zr/zs) w_c +
    (zr/zs) w_r in forward terms (sun, carrier -1, ring +1), housing.tau = 0 throughout."""
    sc = T.load_scene("power-split")
    tr, inputs = T.scene_model(sc)
    assert tr.free == [0, 1] and tr.sigma[:3] == [-1, -1, 1]
    sv = sc["start_values"]
    ws, wc, wr = (sv[f"body[{i}].w_start"] for i in (1, 2, 3))
    assert abs(ws - ((1 + 78 / 30) * wc + 78 / 30 * wr)) < 1e-12 * ws
    res = tr.simulate(0.002, sc["output_interval"], inputs, rtol=RTOL)
    assert np.all(res.column("housing.tau") == 0.0)
    for m in range(1, 9):
        assert np.all(res.column(f"mesh[{m}].n_bwd") >= 1) and np.all(res.column(f"mesh[{m}].F_fwd") == 0)


# ------------------------------------------------------------------------------ 4. refusals
def base():
    return dict(T.load_scene("planetary-simple")["start_values"])


@pytest.mark.parametrize("change,text", [
    ({"mesh[1].A": 0, "n_bodies": 5}, "jammed"),                       # sun and ring fixed
    ({"body[2].carrier": 1}, "itself carried"),
    ({"mesh[1].center_angle": 0.3}, "center_angle"),
    ({"body[4].orbit_angle": 2 * math.pi / 3 + 0.05}, "assembly condition"),
    ({"body[3].carrier": 3}, "cannot carry itself"),
    ({"mesh[2].A": 2}, "its own carrier"),
], ids=["jammed", "carried-carrier", "center_angle", "assembly", "self", "own-carrier"])
def test_refusals_name_the_elements(change, text):
    with pytest.raises(ValueError) as info:
        T.GearTrain({**base(), **change})
    assert text in str(info.value), str(info.value)
