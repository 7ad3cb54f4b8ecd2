"""Self-tests of the internal gear pair and the actual centre distance in the independent
references (gearmesh_ref.py, train_ref.py): the checks of planetary.md sections 1-2, run ON THE
REFERENCE.

    .venv/bin/python -m pytest tests/python/test_internal_ref.py

Every bound says where it comes from (a numerical or physical argument); none is read off a run.
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

RTOL = 1e-10          # the references' integration tolerance
EPS = 2.0 ** -52      # double precision

# the pair of scenes/internal-damped.toml (module 2 mm, 20/60, xB = 0.5; xB = 0.3 is refused, see
# test_pinion_profile_must_lie_on_its_rack_generated_involute)
PAIR = dict(geometry=2, internal=True, module=0.002, zA=20, zB=60, xB=0.5, width=0.02,
            backlash=5e-5)
DYN = dict(PAIR, J_A=5e-3, J_B=0.5)


def geo(**sv):
    return G.Geometry(G.make_params(sv))


# ------------------------------------------------------------------------------ 1. geometry
def test_spec_number_zero_shifts_refused_and_xB_cures():
    """planetary.md section 1: standard 20/60 at 20 deg, m = 2 mm, zero shifts: s_a = -0.075 mm
    (printed to 0.001 mm: bound half a unit, 5e-7 m), refused with the number in the message;
    a positive xB cures it."""
    sv = dict(PAIR, xB=0.0)
    with pytest.raises(G.GeometryError, match=r"s_a = -7\.49") as info:
        geo(**sv)
    assert "xB" in str(info.value)
    # the same number from the section's formulas, by hand
    m, a0 = 0.002, math.radians(20)
    rBb = m * 60 * math.cos(a0) / 2
    s_a = math.sqrt((m * 60 / 2 - m) ** 2 - rBb ** 2) - m * 40 / 2 * math.sin(a0)
    assert abs(s_a + 0.075e-3) <= 5e-7
    g = geo(**PAIR)
    assert g.s_a > 0.0 and 1.0 < g.eps < 2.0


def test_pinion_profile_must_lie_on_its_rack_generated_involute():
    """The project's rule kept by the FMU (not the spec's): the contact must not reach the
    pinion's flank below where an ISO 53 rack cutter's straight flank generates the involute,
    form_start_A = m (zA/2 sin a0 - (h - xA)/sin a0), h = 1.25 - 0.38 (1 - sin a0); for 20/60,
    m = 2 mm, xA = 0 that is 0.993 mm from the tangent point.  xB = 0.3 passes the spec's rules
    (s_a = 0.702 mm > 0, eps 1.818) but the ring's tip reaches into the pinion's root fillet:
    refused, with both numbers in the message.  xB = 0.5: alpha_w = 23.30 deg, d = 40.925 mm,
    s_a = 1.194 mm, eps = 1.735, accepted.  The numbers are printed to the last digit shown
    (bound half a unit); the formula by hand agrees to rounding (terms of O(7e-3 m), one ulp
    ~1e-18 m; a few roundings: bound 1e-17 m).  The ring is cut by a pinion-type cutter: the rule is not applied to it."""
    m, a0 = 0.002, math.radians(20)
    h = 1.25 - 0.38 * (1 - math.sin(a0))
    start = m * (20 / 2 * math.sin(a0) - h / math.sin(a0))
    assert abs(start - 0.993e-3) <= 0.5e-6
    with pytest.raises(G.GeometryError, match=r"active profile below the involute") as info:
        geo(**dict(PAIR, xB=0.3))
    msg = str(info.value)
    assert "s_a = 0.000702" in msg and "(0.000992983" in msg and "xB" in msg
    g = geo(**PAIR)
    assert PAIR["xB"] == 0.5
    assert abs(g.form_start_A - start) <= 1e-17
    assert g.s_a > g.form_start_A
    assert abs(math.degrees(g.alpha_w) - 23.30) <= 0.005
    assert abs(g.d - 40.925e-3) <= 0.5e-6
    assert abs(g.s_a - 1.194e-3) <= 0.5e-6
    assert abs(g.eps - 1.735) <= 0.0005
    # the same pair at an actual centre distance is checked there: scenes/train/internal.toml's
    # +20 um lowers s_a to 1.144 mm, still above 0.993 mm
    g = geo(**PAIR, center_distance_error=2e-5)
    assert abs(g.s_a - 1.144e-3) <= 0.5e-6 and g.s_a > start


def test_internal_geometry_identities():
    """Section 1's relations, at the nominal and at actual centre distances.  Bound: each side
    is a handful of roundings of O(0.1 m) numbers (~1e-17 m each); 1e-15 m is 100x that and
    still 1e-10 of the smallest quantity compared (the backlash, 5e-5 m)."""
    for err in (0.0, 2e-5, -3e-5):
        g = geo(**PAIR, center_distance_error=err)
        aw = g.alpha_w
        assert abs(g.rBb - g.rAb - g.d * math.cos(aw)) < 1e-15
        assert abs(g.L - g.d * math.sin(aw)) < 1e-15
        assert abs(g.s_b - math.sqrt(g.r_tipA ** 2 - g.rAb ** 2)) < 1e-15
        assert abs(g.s_a - (math.sqrt(g.r_tipB ** 2 - g.rBb ** 2) - g.L)) < 1e-15
        assert abs(g.eps - (g.s_b - g.s_a) / g.p_b) < 1e-12
        # closure rBb eB - rAb tA = 2 d cos(aw) inv(aw) + j_n; tB = 2 pi/zB - eB
        lhs = g.rBb * g.eB - g.rAb * g.tA
        assert abs(lhs - (2 * g.d * math.cos(aw) * G.involute(aw) + g.backlash_actual)) < 1e-15
        assert abs(g.tB - (2 * math.pi / g.zB - g.eB)) < 1e-15
        assert abs(g.center_distance - (g.d_nominal + err)) < 1e-17 + EPS * g.d_nominal
    g = geo(**PAIR)
    assert g.r_tipA == pytest.approx(0.022, abs=1e-15)
    assert g.r_tipB == pytest.approx(0.060 - 0.002 * (1 - 0.5), abs=1e-15)   # tips point inwards
    # the ring's space on the reference circle m (pi/2 + 2 xB tan a0) (+ half the backlash in
    # the base-circle space), i.e. eB = that/r + 2 inv(a0) + j/(2 rBb)
    a0 = math.radians(20)
    e_ref = 0.002 * (math.pi / 2 + 2 * 0.5 * math.tan(a0))
    assert abs(g.eB - (e_ref / 0.060 + 2 * G.involute(a0) + 5e-5 / (2 * g.rBb))) < 1e-15


@pytest.mark.parametrize("sv,exc,text", [
    (dict(PAIR, geometry=1), G.GeometryError, "standard geometry"),
    (dict(PAIR, zA=60, zB=20), G.GeometryError, "smaller than zB"),
    (dict(PAIR, zA=10, zB=30, xB=0.0), G.GeometryError, "r_Ba"),     # ring tips inside rBb
    (dict(PAIR, xA=1.4, xB=1.7), G.GeometryError, "pointed tooth"),  # pinion with no top land
    (dict(PAIR, zA=20, zB=40, xB=0.0), G.GeometryError, "s_a = -"),  # interference
    (dict(PAIR, addendum=0.5), G.GeometryError, "eps = 0.85"),       # short teeth: eps < 1
    (dict(PAIR, xB=0.3), G.GeometryError, "below the involute"),     # ring tip in the fillet
    (dict(PAIR, center_distance_error=1e-4), G.GeometryError, "jams"),
])
def test_internal_refusals_name_the_numbers(sv, exc, text):
    with pytest.raises(exc, match=text) as info:
        geo(**sv)
    assert any(ch.isdigit() for ch in str(info.value))


def test_contact_model_3_refused_for_internal():
    with pytest.raises(ValueError, match="not available yet"):
        G.GearMesh(dict(PAIR, contact_model=3))
    with pytest.raises(ValueError, match="not available yet"):
        T.GearTrain({**internal_train_sv(), "mesh[1].contact_model": 3})


def test_initial_objects_from_the_spec_phi_formulas():
    """Section 1's initial values and object table, literally: f1 touches at a (s_A = s_a,
    delta = 0); f2 is one pitch on (s_A = s_a + p_b, delta = 0); b1 has s_A = sigma_b1 (the
    reference's enumeration) and delta = -j_n; b2 lies in the backward window.  Bound 1e-15 m:
    O(1) angles times O(0.05 m) radii, a few roundings."""
    for err in (0.0, 3e-5):
        g = geo(**PAIR, center_distance_error=err)
        aw, L, j = g.alpha_w, g.L, g.backlash_actual
        fA, fB = aw - g.s_a / g.rAb, aw - (g.s_a + L) / g.rBb
        sA_f = lambda pA: g.rAb * (aw - pA)
        sB_f = lambda pB: g.rBb * (aw - pB)
        assert abs(sA_f(fA) - g.s_a) < 1e-15 and abs(sA_f(fA) - sB_f(fB) + L) < 1e-15
        f2A, f2B = fA - g.dA, fB - g.dB
        assert abs(sA_f(f2A) - (g.s_a + g.p_b)) < 1e-15
        assert abs(sA_f(f2A) - sB_f(f2B) + L) < 1e-15
        b1A, b1B = f2A + g.tA, fB - g.tB
        sA_b = g.rAb * (aw + b1A)
        sB_b = g.rBb * (aw + b1B)
        assert abs(sA_b - g.sigma_b1) < 1e-15
        assert abs((sA_b - sB_b + L) - (-j)) < 1e-15
        inside = [p for p in (b1A - g.dA, b1A + g.dA) if -g.phi_max <= p <= -g.phi_min]
        assert len(inside) == 1


# ------------------------------------------------------------------------------ 2. dynamics
@pytest.fixture(scope="module")
def damped_run():
    sc = G.load_scene("internal-damped")
    m = G.GearMesh(sc["start_values"])
    return sc, m, m.simulate(sc["stop_time"], sc["output_interval"], rtol=RTOL)


def test_steady_drive_same_way_and_ratio(damped_run):
    """Section 1 check: w_A/w_B = zB/zA in steady drive, both the same way (forward positive in
    the interface frame, theta_B = -psi_B).  Exact identity: rBb Delta theta_B = rAb Delta
    theta_A - Delta dte, so the angle ratio differs from zB/zA by at most (zB/zA) |Delta dte| /
    (rAb Delta theta_A - |Delta dte|); the bound uses the largest |Delta dte| the trace shows
    (its range) plus rounding."""
    sc, m, res = damped_run
    g = m.g
    r = res.grid()
    col = lambda n: r[:, res.names.index(n)]
    assert np.all(col("w_A") > 0) and np.all(col("w_B") > 0)
    dth_A = col("theta_A")[-1] - col("theta_A")[0]
    dth_B = col("theta_B")[-1] - col("theta_B")[0]
    dte_rng = np.ptp(col("dte"))
    bound = 3.0 * dte_rng / (g.rAb * dth_A - dte_rng) + 1e-12
    assert abs(dth_A / dth_B - 3.0) <= bound
    assert bound < 5e-4      # tells 60/20 from 61/20 (ratio 3.05) or 60/19 by >= 100x


def test_static_load_at_rest_uses_the_internal_law():
    """Section 1 check: constant tau_A balanced by the brake tau_B = -tau_A rBb/rAb, at rest,
    started at the double-contact static penetration: nothing moves, sum F_n = tau_A/rAb, each
    pair half, and delta solves Johnson's law with rho_B - rho_A = L - delta.  Wheel A starts
    0.4 p_b further on than the single mesh's start (which puts f1's ring tip exactly on point a,
    a gate boundary) so that both pairs sit well inside the double-contact zone of length
    (eps - 1) p_b = 0.73 p_b.  The state is an
    equilibrium to rounding (accelerations ~ 1e-16 x 1e3 N x rAb / J_A ~ 1e-15 rad/s2), so the
    integrator keeps it to far below 1e-9 relative (bound).  The law: johnson_delta is eq. 5.1
    in closed form (a few roundings, 1e-14 relative); with the EXTERNAL radius sum L + delta the
    same force gives a penetration 1e3 x that bound away, so the check tells the two apart."""
    tau = 20.0
    g = geo(**PAIR)
    sv = dict(DYN, tau_A=tau, tau_B=-tau * g.rBb / g.rAb)
    d = G.quasi_static_dte(sv, 2)
    m = G.GearMesh(dict(sv, dte_start=d))
    y0 = m.initial_state()
    y0[0] += 0.4 * g.p_b / g.rAb
    res = m.simulate(0.01, 1e-3, rtol=RTOL, y0=y0)
    F = res.column("F_fwd")
    assert np.all(res.column("n_fwd") == 2) and not res.events
    assert np.max(np.abs(F - tau / g.rAb)) <= 1e-9 * tau / g.rAb
    assert np.max(np.abs(res.column("F_f1") - res.column("F_f2"))) <= 1e-9 * F.max()
    assert np.max(np.abs(res.column("w_A"))) < 1e-9
    assert np.max(np.abs(res.column("dte") - d)) <= 1e-9 * d
    N = (tau / g.rAb) / 2 / m.p["width"]
    assert abs(G.johnson_delta(N, g.L - d, g.E_star) - d) <= 1e-14 * d
    assert abs(G.johnson_delta(N, g.L + d, g.E_star) - d) > 1e3 * 1e-14 * d


def energy_balance(model, res):
    """(E1 - E0 - W + D, sum of the gate jumps, sum of |jumps|) as in test_reference_model."""
    seg0, segN = res.energy["segments"][0], res.energy["segments"][-1]
    y0, y1 = seg0[2](seg0[0]), segN[2](segN[1])
    E0 = model.kinetic_energy(y0) + model.elastic_energy(y0, seg0[3])
    E1 = model.kinetic_energy(y1) + model.elastic_energy(y1, segN[3])
    dU = [model.elastic_energy(y, a) - model.elastic_energy(y, b)
          for _, y, b, a in res.energy["jumps"]]
    return E1 - E0 - y1[4] + y1[5], sum(dU), sum(abs(x) for x in dU), y1


@pytest.mark.parametrize("extra", [dict(mu=0.0, chi=0.0), dict(mu=0.1, chi=20.0)],
                         ids=["elastic", "dissipative"])
def test_energy_balance(extra):
    """Section 1 check 'Energy, as before': kinetic + elastic energy (the internal law's
    integral, rho = L - s) changes only by the work of tau_A, c_load, the dissipated energy
    (integral of P_loss) and the gate jumps.  Energies ~100 J integrated at rtol 1e-11: errors
    ~1e-9 J; bound 1e-7 J.  A gate jump here is ~F delta/2 ~ 5e-4 J, so one missing or spurious
    jump, or a torque inconsistent with d(delta)/dt (wrong s_B or sign: the friction part
    of the power would not equal -F_t v_s), shows.  P_loss >= 0 (friction and damping only
    dissipate; -1e-9 W for an event instant's rounding)."""
    sv = dict(DYN, tau_A=20.0, c_load=3.0, w_A_start=60.0, w_B_start=20.0, **extra)
    m = G.GearMesh(sv)
    res = m.simulate(0.02, 1e-4, rtol=1e-11, energy=True)
    resid, jumps, total, y1 = energy_balance(m, res)
    assert total > 1e2 * 1e-7
    assert abs(resid - jumps) < 1e-7
    if extra["mu"] == 0.0:
        assert abs(y1[5]) < 1e-12
    else:
        assert y1[5] > 1e-2
        assert res.column("P_loss").min() >= -1e-9


def test_friction_torque_flips_at_the_pitch_point(damped_run):
    """Section 1 check (mu = 0.05): per carrying pair, v_s = omega_A s_A - omega_B s_B is zero at
    the pitch point s_A = rAb tan(alpha_w) (= rAb L/(rBb - rAb)), so the pair's friction torque
    on A (interface sign +F_t s_A) is > 0 before it and < 0 after.  Pairs within 1 mm of the
    pitch point are left out: there rigid rolling gives |v_s| >= w_A (1 - rAb/rBb) 1 mm = 0.04
    m/s, while the mesh vibration changes it by at most |d(dte)/dt| s_B/rBb < 0.01 m/s, so the
    sign is the rolling one and tanh(v_s/v_reg) is not near 0."""
    sc, m, res = damped_run
    g = m.g
    s_pitch = g.rAb * math.tan(g.alpha_w)
    assert abs(s_pitch - g.rAb * g.L / (g.rBb - g.rAb)) < 1e-15
    seen = {1: 0, -1: 0}
    for t0, t1, solf, cfg in res_segments(m, sc):
        for t in np.linspace(t0, t1, 7)[1:-1]:
            for flank, k, sA, sB, Fn, Ft, vs in m.pair_forces(solf(t), cfg):
                if flank != 1 or Fn < 1.0 or abs(sA - s_pitch) < 1e-3:
                    continue
                side = 1 if sA < s_pitch else -1
                assert np.sign(Ft * sA) == side, (t, sA, Ft)
                assert abs(sB - (sA + g.L - solf(t)[1])) < 1e-15     # s_B = s_A + L - delta
                seen[side] += 1
    assert seen[1] > 20 and seen[-1] > 20


def res_segments(m, sc):
    """The integration segments of the scene (the energy bookkeeping keeps them)."""
    res = m.simulate(sc["stop_time"], sc["output_interval"], rtol=RTOL, energy=True)
    return [(t0, t1, (lambda s: lambda t: s(t)[:4])(solf), cfg)
            for t0, t1, solf, cfg in res.energy["segments"] if t1 > t0]


def test_contact_ratio_from_s_a_and_s_b(damped_run):
    """Section 1 check: in steady forward drive the share of wheel A's roll u_A = rAb theta_A
    spent in double contact is eps - 1 = (s_b - s_a)/p_b - 1.  The upper gate s_A = s_b moves
    with u_A, the lower one (s_A - delta = s_a) with u_B = u_A - (dte - dte_start): each
    double-contact interval is (eps - 1) p_b up to the change of dte between its ends, so over
    whole cycles the share is eps - 1 within 2 x range(dte)/p_b.  And 2 zA switches per
    revolution of A."""
    sc, m, res = damped_run
    g = m.g
    t = res.table[:, 0]
    thA = res.column("theta_A")
    ev = [(te, nb, na) for te, nb, _bb, na, _ba in res.events]
    starts = [i for i, e in enumerate(ev) if e[1] == 1 and e[2] == 2]
    assert len(starts) >= 5
    th_at = lambda te: thA[np.flatnonzero(t == te)[0]]
    dbl = tot = 0.0
    for i0, i1 in zip(starts, starts[1:]):
        tot += th_at(ev[i1][0]) - th_at(ev[i0][0])
        ends = [e for e in ev[i0 + 1:i1 + 1] if e[1] == 2 and e[2] == 1]
        assert len(ends) == 1
        dbl += th_at(ends[0][0]) - th_at(ev[i0][0])
    share = dbl / tot
    bound = 2 * np.ptp(res.column("dte")) / g.p_b + 1e-9
    assert abs(share - (g.eps - 1)) <= bound, (share, g.eps - 1, bound)
    revs = (thA[-1] - thA[0]) / (2 * math.pi)
    assert abs(len(ev) / revs - 2 * g.zA) <= 2 / revs + 1e-9


# ------------------------------------------------------------------------------ 3. centre distance
def test_zero_error_is_todays_path_exactly():
    """center_distance_error = 0 (explicit) runs the code of the nominal geometry: every number
    and a damped run are bit-identical to the defaults'."""
    for sv in ({}, dict(geometry=2, zA=20, zB=40, module=0.002), PAIR):
        a, b = geo(**sv), geo(**sv, center_distance_error=0.0)
        assert vars(a) == vars(b)
        assert a.backlash_actual == a.backlash == sv.get("backlash", 1e-4)
    sc = G.load_scene("damped")
    ra = G.GearMesh(sc["start_values"]).simulate(0.01, 1e-4)
    rb = G.GearMesh(dict(sc["start_values"], center_distance_error=0.0)).simulate(0.01, 1e-4)
    assert np.array_equal(ra.table, rb.table)


EXT = dict(geometry=2, module=0.002, zA=20, zB=40, backlash=5e-5)


@pytest.mark.parametrize("base,sign", [(EXT, 1.0), (PAIR, -1.0), ({}, 1.0)],
                         ids=["external", "internal", "paper"])
def test_backlash_opens_or_closes_by_2_sin_alpha(base, sign):
    """Section 2: moving the axes apart opens an external pair's backlash and closes an internal
    pair's (and the reverse).  Quantitatively j_n(d) = const +- 2 (d cos aw) inv(aw) with d cos aw
    fixed gives dj/dd = +-2 sin(aw) and d2j/dd2 = +-2 cos(aw)^2/(d sin(aw)); Taylor's remainder
    bounds |Delta j - (+-2 sin(aw0) Delta d)| by max|j''| Delta d^2/2 (j'' changes by ~Delta d/d
    ~ 1e-3 relative over the step: factor 1.01), plus rounding (1e-17 m)."""
    g0 = geo(**base)
    for dd in (4e-5, -2e-5):
        g1 = geo(**base, center_distance_error=dd)
        dj = g1.backlash_actual - g0.backlash
        assert np.sign(dj) == sign * np.sign(dd)
        aw = max(g0.alpha_w, g1.alpha_w)
        j2 = 2 * math.cos(min(g0.alpha_w, g1.alpha_w)) ** 2 / (min(g0.d, g1.d) * math.sin(aw))
        assert abs(dj - sign * 2 * math.sin(g0.alpha_w) * dd) <= 1.01 * j2 * dd * dd / 2 + 1e-17


@pytest.mark.parametrize("base,errs", [(EXT, (0.0, 4e-5, -3e-5)), (PAIR, (0.0, 2e-5, -4e-5)),
                                       ({}, (0.0, 1e-4, -2e-5))],
                         ids=["external", "internal", "paper"])
def test_actual_backlash_from_the_operating_pitch_circles(base, errs):
    """An independent route to backlash_actual: the circumferential play on the operating pitch
    circles r_w = rb/cos(aw) of the actual geometry, j_t = p_w - s_wA - s_wB (external) or
    e_wB - s_wA (internal: the ring's space, which narrows outwards like an external tooth),
    with s_w = r_w (t - 2 inv aw), e_wB = r_wB (eB - 2 inv aw), p_w = 2 pi r_wA/zA; normal
    backlash j_n = j_t cos(aw).  Also cos(aw) = (rAb +- rBb)/d, L = d sin(aw) and s_a from the
    tip radii.  Bound: ~10 roundings of terms up to O(d) (0.5 m paper, 0.06 m standard):
    10 x d x 1.1e-16, times 10."""
    for err in errs:
        g = geo(**base, center_distance_error=err)
        aw, inv = g.alpha_w, G.involute(g.alpha_w)
        rwA, rwB = g.rAb / math.cos(aw), g.rBb / math.cos(aw)
        sA = rwA * (g.tA - 2 * inv)
        if g.internal:
            jt = rwB * (g.eB - 2 * inv) - sA
            c = g.rBb - g.rAb
            s_a = math.sqrt(g.r_tipB ** 2 - g.rBb ** 2) - g.L
        else:
            jt = 2 * math.pi * rwA / g.zA - sA - rwB * (g.tB - 2 * inv)
            c = g.rAb + g.rBb
            s_a = g.L - math.sqrt(g.r_tipB ** 2 - g.rBb ** 2)
        tol = 100 * g.d * 1.1e-16
        assert abs(jt * math.cos(aw) - g.backlash_actual) <= tol
        assert abs(math.cos(aw) - c / g.d) <= 4 * EPS
        assert abs(g.L - g.d * math.sin(aw)) <= tol
        assert abs(g.s_a - s_a) <= tol
        assert g.center_distance == g.d


def test_centre_distance_refusals():
    """Section 2: the actual geometry may jam the teeth (j_n < 0) or drop eps below 1; the
    messages give the numbers."""
    with pytest.raises(G.GeometryError, match=r"jams.*j_n = -"):
        geo(**EXT, center_distance_error=-8e-5)        # 50 um - 2 sin(20 deg) 80 um < 0
    with pytest.raises(G.GeometryError, match=r"eps = 0\.9.*center_distance_error"):
        geo(center_distance_error=2e-3)                # paper pair, eps 1.1 at the nominal


def test_centre_distance_scene_crosses_the_actual_backlash():
    """scenes/center-distance.toml's trace: while the backward flank carries, dte = -j_act -
    delta_b < -j_act, with j_act = backlash_actual (77.4 um), not the nominal 50 um; while the
    forward flank carries, dte > 0.  Rows with a positive force (an event instant's row can sit
    on the flank with zero force); slack 1e-18 m for the CSV's 15 printed digits (4e-20 m)."""
    sc = G.load_scene("center-distance")
    g = geo(**{k: v for k, v in sc["start_values"].items()})
    names, table = G.read_table_csv(os.path.join(ROOT, "tests", "reference", "center-distance.csv"))
    col = lambda n: table[:, names.index(n)]
    bwd, fwd = col("F_bwd") > 0, col("F_fwd") > 0
    assert bwd.sum() > 50 and fwd.sum() > 50
    assert np.all(col("dte")[bwd] <= -g.backlash_actual + 1e-18)
    assert np.all(col("dte")[fwd] >= -1e-18)
    assert col("dte").min() < -g.backlash_actual < -sc["start_values"]["backlash"]


# ------------------------------------------------------------------------------ 4. the train
def internal_train_sv():
    """Two bodies, one internal mesh: the train form of scenes/internal-damped.toml.
    body[1].angle_start puts tooth 0's forward root where the single mesh starts f1: the
    internal frame is the housing frame rotated by pi (center_angle 0, sigma_1 = -1), so
    chi = psi_1 - pi and chi - tA/2 = phiA(f1) - dte_start/rAb."""
    sv = G.load_scene("internal-damped")["start_values"]
    g = geo(**sv)
    ang = math.pi + g.alpha_w - g.s_a / g.rAb + g.tA / 2 - sv["dte_start"] / g.rAb
    tsv = {"n_bodies": 2, "n_shafts": 0, "n_meshes": 1, "body[1].J": sv["J_A"],
           "body[2].J": sv["J_B"], "body[1].c": 0.0, "body[2].c": sv["c_load"],
           "body[1].tau": sv["tau_A"], "body[2].tau": 0.0, "body[1].w_start": sv["w_A_start"],
           "body[2].w_start": sv["w_B_start"], "body[1].angle_start": ang,
           "mesh[1].A": 1, "mesh[1].B": 2}
    for k in ("geometry", "internal", "module", "zA", "zB", "xA", "xB", "width", "backlash",
              "chi", "mu", "dte_start"):
        tsv[f"mesh[1].{k}"] = sv[k]
    return tsv


def test_two_body_train_is_the_single_internal_mesh():
    """gear-train.md section 7 for an internal mesh: one mesh, two bodies, placed as the single
    mesh starts = the single mesh's trace.  Bound 0.2 x internal-damped's compare tolerance:
    both references are converged to 1/10 of it (regenerate*.py's acceptance), so two
    converged references of the same trajectory differ by at most 2/10.  Event times: gate
    events move at >= rAb w_A ~ 1 m/s along the line: 0.2 x 1.9e-9 m / 1 m/s < 1e-9 s."""
    sc = G.load_scene("internal-damped")
    tr = T.GearTrain(internal_train_sv())
    assert tr.sigma == [-1, -1]                     # the internal mesh keeps the sense
    rt = tr.simulate(sc["stop_time"], sc["output_interval"], rtol=RTOL)
    rm = G.GearMesh(sc["start_values"]).simulate(sc["stop_time"], sc["output_interval"], rtol=RTOL)
    gt, gm = rt.grid(), rm.grid()
    assert gt.shape[0] == gm.shape[0]
    tol = sc["compare"]["tolerance"]
    for tn, mn in {"mesh[1].dte": "dte", "body[1].w": "w_A", "body[2].w": "w_B",
                   "mesh[1].F_fwd": "F_fwd", "mesh[1].F_f1": "F_f1", "mesh[1].F_f2": "F_f2",
                   "mesh[1].P_loss": "P_loss"}.items():
        d = np.max(np.abs(gt[:, rt.names.index(tn)] - gm[:, rm.names.index(mn)]))
        assert d <= 0.2 * tol[mn], (tn, d, tol[mn])
    for tn, mn in (("mesh[1].n_fwd", "n_fwd"), ("mesh[1].n_bwd", "n_bwd")):
        assert np.array_equal(gt[:, rt.names.index(tn)], gm[:, rm.names.index(mn)])
    assert len(rt.events) == len(rm.events)
    assert max(abs(a[0] - b[0]) for a, b in zip(rt.events, rm.events)) < 1e-9


def ring_roots(psi, mount, beta_frame, s, z, t, flank, k):
    """planetary.md section 1: ring tooth k (mesh-frame numbering) has forward root
    chi + k dz + t/2 and backward root chi + k dz - t/2, chi = s (psi + mount - beta_frame)."""
    chi = s * (psi + mount - beta_frame)
    return chi + k * 2 * math.pi / z + (t / 2 if flank == 1 else -t / 2)


INTERNAL_PLACEMENTS = [
    internal_train_sv(),
    # mirrored internal mesh: body 2 (sigma +1) is A of the internal mesh 2; mounts, centre
    # angles, a negative dte_start and a centre distance error
    {"n_bodies": 3, "n_shafts": 0, "n_meshes": 2, "mesh[1].A": 1, "mesh[1].B": 2,
     "mesh[2].A": 2, "mesh[2].B": 3, "mesh[1].geometry": 2, "mesh[1].module": 0.002,
     "mesh[1].zA": 20, "mesh[1].zB": 40, "mesh[2].geometry": 2, "mesh[2].internal": True,
     "mesh[2].module": 0.002, "mesh[2].zA": 20, "mesh[2].zB": 60, "mesh[2].xB": 0.5,
     "mesh[2].center_angle": 1.0, "mesh[2].mount_A": 0.03, "mesh[2].mount_B": -0.2,
     "mesh[2].dte_start": -2e-5, "mesh[2].center_distance_error": 2e-5,
     "body[1].angle_start": 0.4},
    # the ring placed first (body 1 is the ring, B of the internal mesh)
    {"n_bodies": 2, "n_shafts": 0, "n_meshes": 1, "mesh[1].A": 2, "mesh[1].B": 1,
     "mesh[1].geometry": 2, "mesh[1].internal": True, "mesh[1].module": 0.002,
     "mesh[1].zA": 20, "mesh[1].zB": 60, "mesh[1].xB": 0.5, "mesh[1].center_angle": -2.0,
     "mesh[1].dte_start": 1e-6, "body[1].angle_start": 0.7},
]


@pytest.mark.parametrize("sv", INTERNAL_PLACEMENTS, ids=["single", "mirrored", "ring-first"])
def test_internal_placement_from_the_spec_roots(sv):
    """planetary.md sections 1 and 3, literally (not train_ref's offsets): in the frame rotated
    by beta + pi and mirrored when sigma_A = +1, with teeth numbered in each body's forward
    sense (pinion axis chi - n dA, ring axis chi - n dB: both s sigma = -1), the pairs of an
    internal mesh have forward delta = s_A - s_B + L = dte_start and backward delta =
    -backlash_actual - dte_start.  Bound 1e-12 m: rounding of O(1) angles times radii is
    ~1e-16 m; a wrong frame or root is off by a fraction of p_b (~1e-3 m)."""
    tr = T.GearTrain(sv)
    for mesh in tr.meshes:
        if not mesh.internal:
            continue
        g, s = mesh.g, -tr.sigma[mesh.A]
        assert tr.sigma[mesh.B] == tr.sigma[mesh.A]
        bf = mesh.beta + math.pi
        psiA, psiB = tr.psi0[mesh.A], tr.psi0[mesh.B]
        k = np.arange(-30, 90)
        for flank, want in ((1, mesh.dte0), (-1, -g.backlash_actual - mesh.dte0)):
            chiA = s * (psiA + mesh.mount_A - bf)
            rA = chiA + k * g.dA + (-g.tA / 2 if flank == 1 else g.tA / 2)
            rB = ring_roots(psiB, mesh.mount_B, bf, s, g.zB, g.tB, flank, k)
            if flank == 1:
                sA, sB = g.rAb * (g.alpha_w - rA), g.rBb * (g.alpha_w - rB)
            else:
                sA, sB = g.rAb * (g.alpha_w + rA), g.rBb * (g.alpha_w + rB)
            delta = sA[:, None] - sB[None, :] + g.L
            assert np.min(np.abs(delta - want)) < 1e-12, (mesh.m, flank)


@pytest.fixture(scope="module")
def train_scene_run():
    sc = T.load_scene("internal")
    tr, inputs = T.scene_model(sc)
    return sc, tr, tr.simulate(sc["stop_time"], sc["output_interval"], inputs, rtol=RTOL)


def test_train_scene_start_and_senses(train_scene_run):
    """scenes/train/internal.toml stores quasi_static_start's numbers (recomputed to the last
    digits, 1e-12 relative); senses -1, +1, +1 (external flips, internal keeps)."""
    sc, tr, _res = train_scene_run
    sv = sc["start_values"]
    qs = T.quasi_static_start(sv)
    for k, v in qs.items():
        if "dte_start" in k or "w_start" in k:
            assert abs(v - sv[k]) <= 1e-12 * abs(v), (k, v, sv[k])
    assert tr.sigma == [-1, 1, 1]
    g2 = tr.meshes[1].g
    assert g2.backlash_actual < sv["mesh[2].backlash"]          # axes apart: an internal pair closes


def test_train_ratio_and_energy(train_scene_run):
    """Across the internal mesh both bodies turn forward with mean speed ratio zB/zA (bound from
    the dte change over the run, as test_steady_drive_same_way_and_ratio); the energy residual
    stays below rtol x max E_kin (test_train_ref.test_energy_residual's argument) while the
    gate energy and the losses are > 100x that."""
    sc, tr, res = train_scene_run
    r = res.grid()
    col = lambda n: r[:, res.names.index(n)]
    assert np.all(col("body[2].w") > 0) and np.all(col("body[3].w") > 0)
    g = tr.meshes[1].g
    d2, d3 = (col(f"body[{i}].theta")[-1] - col(f"body[{i}].theta")[0] for i in (2, 3))
    rng = np.ptp(col("mesh[2].dte"))
    assert abs(d2 / d3 - 3.0) <= 3.0 * rng / (g.rAb * d2 - rng) + 1e-12
    bound = RTOL * res.column("E_kin").max()
    assert np.max(np.abs(res.column("energy_residual"))) < bound
    assert np.max(np.abs(res.column("E_gate"))) > 1e2 * bound
    assert res.column("W_loss")[-1] > 1e2 * bound
