"""The checks of lateral.md section 7 through the packaged SpurGearTrain FMU (FMPy, Co-Simulation),
on the sets that tests/python/test_lateral_ref.py checks on the independent reference: the
bearing force of a pinion at static load, the floating sun's equal shares against a rigid sun's,
a rigidly held sun among planets in phase and out of phase, the centripetal load on a planet's
pin, and the energy balance of a set whose carrier accelerates.  Lin & Parker's frequencies and
the modal multiplicities go through the FMU's Jacobian in test_directional.py; the scenes
(scenes/train/lateral-*.toml) against their reference traces in test_train_scenes.py.

    .venv/bin/python -m pytest -q tests/python/test_lateral_fmu.py

Every bound says where it comes from; none is read off a run.
"""

import math

import fmpy
import numpy as np
import pytest

from test_lateral_ref import LR, lin_parker, pair, rigid_speeds, spinning_planet, three_planets

# The static start's acceptance (gear-model/src/model/train/statics.rs): the accelerations
# below 1e-10 of the elastic terms, or, once its steps stall at rounding, below 1e-6 of them.
STATIC_TOL = 1e-6


def run(fmu, sv, stop, dt, outputs, rel_tol=None):
    kw = {} if rel_tol is None else {"relative_tolerance": rel_tol}
    return fmpy.simulate_fmu(str(fmu), stop_time=stop, output_interval=dt, start_values=sv,
                             output=outputs, **kw)


def at_start(fmu, sv, outputs):
    """The outputs at t = 0 after the FMU's own static start."""
    r = run(fmu, {**sv, "static_start": True}, 1e-6, 1e-6, outputs)
    return {q: float(r[q][0]) for q in outputs}


@pytest.mark.parametrize("beta", [0.0, 0.7])
def test_a_pinion_bearing_at_static_load(beta, train_fmu_path):
    """lateral.md section 7, bearing forces: a lateral pinion (1e8 N/m) drives a wheel on a rigid
    axis through a lumped mesh (1e9 N/m), 100 N.m balanced on the wheel.  Its bearing holds it
    with F n_f, F = tau_A / rAb, n_f = Rot(beta) (sin aw, -cos aw) (test_lateral_ref derives
    it); the wheel's axis takes -F n_f and the housing nothing; the pinion sits at -F n_f / k.
    The FMU's static start on this linear problem converges to rounding, or at the worst stops
    at STATIC_TOL of the elastic terms: bound STATIC_TOL of each scale."""
    tau_A, k = 100.0, 1e8
    sv = pair(beta)
    g = LR.LateralTrain(sv).meshes[0].g
    sv.update({"body[1].tau": tau_A, "body[2].tau": -tau_A * g.rBb / g.rAb})
    names = ["body[1].x", "body[1].y", "body[1].Fx", "body[1].Fy", "body[2].Fx", "body[2].Fy",
             "housing.Fx", "housing.Fy", "mesh[1].delta_lat", "mesh[1].F_fwd"]
    r = at_start(train_fmu_path, sv, names)
    F = tau_A / g.rAb
    nf = np.array([math.cos(beta) * math.sin(g.alpha_w) + math.sin(beta) * math.cos(g.alpha_w),
                   math.sin(beta) * math.sin(g.alpha_w) - math.cos(beta) * math.cos(g.alpha_w)])
    for (xn, yn), want, s in ((("body[1].x", "body[1].y"), -F * nf / k, F / k),
                              (("body[1].Fx", "body[1].Fy"), F * nf, F),
                              (("body[2].Fx", "body[2].Fy"), -F * nf, F),
                              (("housing.Fx", "housing.Fy"), np.zeros(2), F)):
        for q, w in ((xn, want[0]), (yn, want[1])):
            assert abs(r[q] - w) <= STATIC_TOL * s, (q, r[q], w)
    assert abs(r["mesh[1].delta_lat"] + F / k) <= STATIC_TOL * F / k
    assert abs(r["mesh[1].F_fwd"] - F) <= STATIC_TOL * F


SHARES = [f"mesh[{k}].F_fwd" for k in (1, 2, 3)]


@pytest.mark.parametrize("lumped", [True, False], ids=["lumped", "johnson"])
def test_a_floating_sun_shares_the_load_equally(lumped, train_fmu_path):
    """lateral.md section 7, floating sun: three planets hold a sun without a bearing, so the set
    is statically determinate and the three sun meshes carry equal forces whatever planet 1's
    tangential pin error e_t, up to the turn of its line of centres by eps = e_t / R, which moves
    the shares by eps / sqrt(3) (Lami's theorem: test_lateral_ref).  Bound: 1.01 eps / sqrt(3)
    plus the static start's STATIC_TOL.  Their sum is the sun's torque over its base radius."""
    for et in (1e-6, 5e-6):
        sv = three_planets(True, et, lumped)
        tr = LR.LateralTrain(sv)
        r = at_start(train_fmu_path, sv, SHARES)
        F = np.array([r[q] for q in SHARES])
        eps = et / tr.R[2]
        assert np.max(np.abs(F / F.mean() - 1)) <= 1.01 * eps / math.sqrt(3) + STATIC_TOL, (et, F)
        assert abs(F.sum() * tr.meshes[0].g.rAb - 50.0) <= STATIC_TOL * 50.0


def test_a_rigid_sun_shares_unequally_with_a_pin_error(train_fmu_path):
    """The same set with the sun on a rigid axis (lumped meshes): equal shares without an error
    (symmetry, to the static start's STATIC_TOL), and planet 1's 1 um error against the meshes'
    0.9 um static deflection moves its share far from a third (the reference finds more than
    50 %; bound 10 %)."""
    for et, same in ((0.0, True), (1e-6, False)):
        r = at_start(train_fmu_path, three_planets(False, et, True), SHARES)
        F = np.array([r[q] for q in SHARES])
        spread = np.max(np.abs(F / F.mean() - 1))
        assert (spread <= STATIC_TOL) if same else (spread > 0.1), (et, F)


def test_the_pin_carries_the_centripetal_force(train_fmu_path):
    """lateral.md section 7: a lateral planet at carrier speed Omega = 300 rad/s, no load, settles
    at zeta = m R Omega^2 / (k - m Omega^2): its pin's radial force is -m R Omega^2 / (1 - m
    Omega^2 / k).  Started on the pin with 10 % of critical damping, after 20 ms the transient is
    below e^-30 (test_lateral_ref).  At rel_tol 1e-10 the FMU's global error stays far below the
    bound 1e-8 relative, itself 1e4 x below the (1 - m Omega^2 / k) correction, which the test also
    sees; the tangential force vanishes."""
    k, m, Om = 1e8, 0.3, 300.0
    sv = spinning_planet(Om, k, 0.2 * math.sqrt(k * m))
    R = math.hypot(*LR.LateralTrain(sv).planet_position(2))
    r = run(train_fmu_path, sv, 0.02, 1e-3, ["body[3].Fx", "body[3].Fy", "body[2].w"], rel_tol=1e-10)
    Fx, Fy, W = (float(r[q][-1]) for q in ("body[3].Fx", "body[3].Fy", "body[2].w"))
    want = -m * R * W ** 2 / (1 - m * W ** 2 / k)
    assert abs(Fx / want - 1) <= 1e-8, (Fx, want)
    assert abs(Fx / (-m * R * W ** 2) - 1) > 1e-4
    assert abs(Fy) <= 1e-8 * abs(Fx)


def test_energy_balance_with_coriolis_and_centrifugal_terms(train_fmu_path):
    """lateral.md section 7, energy (test_lateral_ref's set): sun, carrier and three planets
    lateral, the planets' bearing mode at twice the carrier's 300 rad/s, lumped meshes with 2 um
    of backlash (contact switching), planet 1's pin 3 um ahead, 5 N.m on the sun and nothing on
    the carrier: the set accelerates (Euler terms), the planets swing out and sideways (Coriolis).
    energy_residual = E_kin + E_el + W_loss - W_ext - E_gate stays within rel_tol x max E_kin
    (the state's relative error is of order rel_tol, the energy quadratic in it); the elastic
    energy's swing is far above that bound, so a missing term would show."""
    sv = rigid_speeds(three_planets(all_lateral=True, et=3e-6, w_sun=300.0 * (1 + 64 / 20),
                                    tau_sun=5.0, k_planet=0.3 * 600.0 ** 2))
    tol = 1e-10
    r = run(train_fmu_path, sv, 0.002, 5e-5, ["energy_residual", "E_kin", "E_el", "body[3].vx"], rel_tol=tol)
    bound = tol * np.max(r["E_kin"])
    assert np.max(np.abs(r["energy_residual"])) < bound
    assert np.ptp(r["E_el"]) > 1e4 * bound
    assert np.ptp(r["body[3].vx"]) > 0.1


def rigid_sun_set(zs):
    """Lin & Parker's inertias and bearings with only the planets lateral (5 % of critical), the
    square-wave lumped mesh (c_lumped 1000 N.s/m) and zs sun teeth: 24/20/64 (zs / 4 = 6, the
    planets mesh in phase) or 25/21/67 (scenes/train/lateral-four-planet.toml's set: out of
    phase); 200 N.m on the sun at 1104 rad/s against the carrier's drag."""
    sv = lin_parker(200.0)
    zp, zr = {24: (20, 64), 25: (21, 67)}[zs]
    for i in (1, 2, 3):
        sv[f"body[{i}].lateral"] = False
    for n in range(4):
        sv.update({f"body[{4 + n}].c_x": 812.4, f"body[{4 + n}].c_y": 812.4})
        for k, (za, zb) in ((1 + n, (zs, zp)), (5 + n, (zp, zr))):
            sv.update({f"mesh[{k}].zA": za, f"mesh[{k}].zB": zb, f"mesh[{k}].backlash": 5e-5,
                       f"mesh[{k}].c_lumped": 1000.0, f"mesh[{k}].k_lumped_varies": True})
    R = 3e-3 * (zs + zp) / 2
    W = 1104.0 * zs / (zs + zr)                     # the carrier's speed, ring held
    sv.update({"body[3].tau": 0.0, "body[3].c": 200.0 * (zs + zr) / zs / W,
               "body[3].J": 6.29 * R ** 2, "body[1].w_start": 1104.0})
    return rigid_speeds(sv)


def test_a_rigid_sun_among_planets_in_phase_feels_no_force(train_fmu_path):
    """lateral.md section 7 (Parker 2000): a sun on a rigid axis among 4 equally spaced identical
    planets.  With zs / 4 an integer the planets mesh in phase, their forces on the sun cancel at
    every instant and its bearing force stays at rounding (bound 1e-6 of a mesh force: the
    stiffness steps of the four meshes fall at the same instants, each located to the event
    tolerance).  With 25 teeth the harmonics (l 25 +- 1) / 4 integer drive it laterally by more
    than 10 % of a mesh force."""
    out = ["body[1].Fx", "body[1].Fy", "mesh[1].F_fwd"]
    biggest = {}
    for zs in (24, 25):
        r = run(train_fmu_path, {**rigid_sun_set(zs), "static_start": True}, 0.004, 1e-5, out, rel_tol=1e-7)
        biggest[zs] = np.max(np.hypot(r["body[1].Fx"], r["body[1].Fy"])) / np.mean(r["mesh[1].F_fwd"])
    assert biggest[24] <= 1e-6 and biggest[25] > 0.1, biggest
