"""Tests of the independent reference of the tooth-structure mesh (contact model 3) and of its
ISO 6336-1 comparison: tests/reference_model/tooth_structure_ref.py.

    .venv/bin/python -m pytest tests/python/test_tooth_structure_ref.py

Needs no FMU (no fixture of conftest.py is used).  Runtime a few seconds.
"""

import math
import os
import sys
import warnings

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import lambertw

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests"))

from reference_model import tooth_structure_ref as T  # noqa: E402

EPS = np.finfo(float).eps

# Wheels for the transcription check: root circle below the base circle (straight Chen & Shao
# segment present) and above it (involute from the root circle), small and large z, +/- shift.
WHEELS = [
    (17, 2e-3, 0.3),    # r_f < r_b
    (20, 4e-3, 0.0),    # r_f < r_b
    (30, 5e-3, -0.2),   # r_f < r_b
    (60, 8e-3, 0.5),    # r_f > r_b
    (100, 2e-3, 0.0),   # r_f > r_b
    (100, 3e-3, -0.5),  # r_f < r_b
]


def load_positions(w):
    """Roll distances from the lowest point of the involute part (above the form and root
    circles) to the tip."""
    lo = max(w.s_form, w.r_b * w.phi_root, 0.0) + 0.05 * (w.s_tip - max(w.s_form, 0.0))
    return [lo, 0.5 * (lo + w.s_tip), w.s_tip]


# --------------------------------------------------------------------------------------------
# 1. The alpha-integrals and Chen & Shao's closed form against a direct beam integration
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("z,m,x", WHEELS)
def test_alpha_integrals_match_direct_beam_integration(z, m, x):
    """Both sides evaluate the same cantilever (section normal to the centre line, half-thickness
    from the involute, load along the line of action at the contact).  The direct side uses the
    polar involute, the force vector and M = (P - X) x F, not the alpha-substitution.

    Tolerance, derived from the quadrature errors: the adaptive side reports an absolute error
    estimate e_q; the Gauss-Legendre side (48 nodes, analytic integrand) is bounded by its
    change to 96 nodes e_g; each side also carries rounding of ~100 ulp of the value (sum of
    ~100 terms).  Accept |a - b| <= 10 (e_q + e_g) + 200 eps |a|.  A transcription error
    (a wrong power, factor or sign) changes the value at O(1)."""
    b = 0.01
    w = T.Wheel(z, m, x)
    for s in load_positions(w):
        gl = T.alpha_integrals(w, s, b)
        gl2 = T.alpha_integrals(w, s, b, n=96)
        st = T.straight_segment_compliance(w, s, b)
        direct, err = T.beam_compliance_direct(w, s, b)
        for k in ("bending", "shear", "axial"):
            a, d = gl[k], direct[k]
            tol = 10.0 * (err[k] + abs(gl2[k] - a)) + 200 * EPS * abs(a)
            assert abs(a - d) <= tol, (z, x, s, k, a, d, tol)
            a, d = st[k], direct["straight_" + k]
            tol = 10.0 * err["straight_" + k] + 200 * EPS * abs(a)
            assert abs(a - d) <= tol, (z, x, s, "straight_" + k, a, d, tol)
        if w.r_f >= w.r_b:
            assert all(st[k] == 0.0 for k in st)
        else:
            assert st["bending"] > 0.0


def test_beam_energy_matches_force_times_displacement():
    """U = F^2/(2k): the compliance from the alpha-integrals equals 2U/F^2 of the direct beam
    for a unit force, and scales as 1/b and 1/E (linear elasticity)."""
    w = T.Wheel(20, 4e-3, 0.0)
    s = 0.5 * (w.s_tip + w.s_form)
    c1 = T.tooth_compliance(w, s, 0.01)["total"]
    c2 = T.tooth_compliance(w, s, 0.02)["total"]
    assert c1 == pytest.approx(2.0 * c2, rel=1e-13)
    w2 = T.Wheel(20, 4e-3, 0.0, E=2 * w.E)
    assert T.tooth_compliance(w2, s, 0.01)["total"] == pytest.approx(0.5 * c1, rel=1e-13)


# --------------------------------------------------------------------------------------------
# 2. Fillet foundation inputs
# --------------------------------------------------------------------------------------------

def test_theta_f_is_the_rack_generated_root_half_angle():
    """Ma et al.'s theta_f = [pi/2 + 2 tan a0 (hf - rho) + 2 rho/cos a0]/z equals the half
    angle of the tooth at the root circle derived from the generating rack: the rack's tip flat
    (width pi/2 - 2 hf tan a0 - 2 rho (1 - sin a0)/cos a0, in modules) rolls on the reference
    circle and cuts the root space, so the tooth keeps 2 pi/z minus that flat's angle
    (flat m / r = 2 flat / z), independent of the shift x."""
    a0 = math.radians(20)
    for z, x, hf, rho in [(20, 0.0, 1.25, 0.38), (37, 0.4, 1.25, 0.25), (80, -0.3, 1.4, 0.3)]:
        w = T.Wheel(z, 3e-3, x, dedendum=hf, rack_tip_radius=rho)
        flat = math.pi / 2 - 2 * hf * math.tan(a0) - 2 * rho * (1 - math.sin(a0)) / math.cos(a0)
        half = 0.5 * (2 * math.pi / z - 2 * flat / z)
        assert w.theta_f == pytest.approx(half, rel=1e-14)
        assert w.S_f == pytest.approx(2 * w.r_f * w.theta_f, rel=1e-15)
        assert w.h_f == pytest.approx(w.r_f / w.r_bore, rel=1e-15)


def test_sainsot_table_and_u_f_clamp():
    w = T.Wheel(20, 4e-3, 0.0)
    tf, hf = w.theta_f, w.h_f
    # P* evaluated by hand from the table row (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3,
    # 0.2895, 0.9236)
    P = -50.952e-5 / tf ** 2 + 185.50e-3 * hf ** 2 + 0.0538e-4 * hf / tf + 53.300e-3 / tf \
        + 0.2895 * hf + 0.9236
    assert w.sainsot["P"] == pytest.approx(P, rel=1e-15)
    # u_f = r_b / cos(alpha_1) - r_f: where the load line crosses the centre line
    s = 0.012
    a1 = s / w.r_b - w.alpha_2
    assert w.u_f(s) == pytest.approx(w.r_b / math.cos(a1) - w.r_f, rel=1e-15)
    # negative u_f (large wheel, positive shift): clamp at 0 and one warning at construction
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pair = T.standard_pair(60, 100, 8e-3, 0.5, -0.5)
    msgs = [str(c.message) for c in caught if "u_f" in str(c.message)]
    assert len(msgs) == 1 and "wheel A" in msgs[0]
    sA = pair.s_a
    assert pair.A.u_f(sA) < 0.0
    X = pair.A.sainsot
    a1 = pair.A.alpha_1(sA)
    expect = math.cos(a1) ** 2 / (pair.A.E * pair.b) * X["P"] * (1 + X["Q"] * math.tan(a1) ** 2)
    assert T.fillet_compliance(pair.A, sA, pair.b) == pytest.approx(expect, rel=1e-14)


# --------------------------------------------------------------------------------------------
# 3. Weber's local contact and the closed form of the pair
# --------------------------------------------------------------------------------------------

PAIR_2030 = dict(zA=20, zB=30, m=4e-3, xA=0.0, xB=0.0)


def pair_2030(**kw):
    return T.standard_pair(20, 30, 4e-3, 0.0, 0.0, **kw)


@pytest.mark.parametrize("line_load", [30e3, 3e5, 1.5e6])
def test_closed_form_against_separate_terms(line_load):
    """delta = w_A + w_B + F/k_s with the Weber terms computed separately (each with its own
    logarithm and b_H) equals F/(pi b E*) ln(C/F); and the force from delta through W_{-1}
    equals the root of the separated sum found by brentq.  Both are double-precision
    identities; the sums of 3 terms of one sign lose at most a few ulp, brentq is run to
    rtol 4 eps: 1e-12 relative leaves a margin of 1000."""
    pair = pair_2030()
    F = line_load * pair.b
    for s in np.linspace(pair.s_a, pair.s_b, 5):
        sB = pair.L - s
        R = s * sB / (s + sB)

        def separated(Fx):
            return (T.weber_w(pair.A, s, Fx, R, pair.E_star, pair.b)
                    + T.weber_w(pair.B, sB, Fx, R, pair.E_star, pair.b)
                    + Fx * T.structure_compliance(pair, s))

        d = separated(F)
        assert T.model3_delta(pair, s, F) == pytest.approx(d, rel=1e-12)
        F_closed, _ = T.model3_force(pair, s, d)
        F_num = brentq(lambda Fx: separated(Fx) - d, 0.5 * F, 2.0 * F, xtol=1e-300, rtol=4 * EPS)
        assert F_closed == pytest.approx(F_num, rel=1e-12)
        assert F_closed == pytest.approx(F, rel=1e-12)


def test_lambert_w_in_logs():
    """t = -W_{-1}(-e^-lam) for the large lam of the pair (C ~ e^40..50): the value from the
    log form satisfies t - ln t = lam and agrees with scipy's lambertw where exp(-lam) is
    representable."""
    for lam in [1.5, 5.0, 20.0, 38.5, 50.0, 120.0, 650.0, 900.0]:
        t = T._t_of(lam)
        assert t - math.log(t) == pytest.approx(lam, rel=4 * EPS)
        if lam < 700:
            assert t == pytest.approx(float(-lambertw(-math.exp(-lam), -1).real), rel=1e-13)
    pair = pair_2030()
    assert 30.0 < T.ln_C(pair, 0.5 * (pair.s_a + pair.s_b)) < 60.0


def test_tangent_stiffness():
    """dF/d(delta) of both models against a central difference (step 1e-5 delta: truncation
    ~1e-10, rounding ~1e-11)."""
    pair = pair_2030()
    W = 3e5 * pair.b
    for s in np.linspace(pair.s_a, pair.s_b, 4):
        d = T.model3_delta(pair, s, W)
        h = 1e-5 * d
        for fn in (lambda dd: T.model3_force(pair, s, dd), lambda dd: T.johnson_force(pair, dd)):
            fd = (fn(d + h)[0] - fn(d - h)[0]) / (2 * h)
            assert fn(d)[1] == pytest.approx(fd, rel=1e-8)


def test_C_at_zero_penetration():
    """The spec evaluates C at s_B = L - s_A.  Measured against s_B = L + delta - s_A at 300 N/mm:
    the mean secant moves by ~5e-4 (20/30 m 4); per position up to ~5e-3 at the tips of small
    modules (reported, see the module docstring of the table tool)."""
    pair = pair_2030()
    a = T.static_mesh(pair, 3)["mean_secant"]
    b = T.static_mesh(pair, 3, exact_sB=True)["mean_secant"]
    assert abs(b / a - 1.0) < 1e-3


# --------------------------------------------------------------------------------------------
# 4. Johnson (contact model 1) and the issue's numbers
# --------------------------------------------------------------------------------------------

def test_johnson_matches_paper_law_and_base_reference():
    pair = pair_2030()
    for N in (1e4, 3e5, 2e6):
        d = T.johnson_delta(pair, N * pair.b)
        F, _ = T.johnson_force(pair, d)
        assert F / pair.b == pytest.approx(N, rel=1e-12)
        rho = pair.L + d
        assert d == pytest.approx(N / (math.pi * pair.E_star)
                                  * (math.log(4 * math.pi * pair.E_star * rho / N) - 1), rel=1e-13)
    try:
        from reference_model import gearmesh_ref as G
        johnson_N = G.johnson_N
    except Exception:  # being edited elsewhere: the check above already pins eq. 5.1
        pytest.skip("gearmesh_ref.johnson_N not importable")
    d = 9e-6
    assert T.johnson_force(pair, d)[0] / pair.b == pytest.approx(
        johnson_N(d, pair.L + d, pair.E_star), rel=1e-13)


def test_johnson_stiffness_2030_as_in_the_issue():
    """Issue 9: the contact-only FMU at 300 N/mm, 20/30 m 4 x 0: mean secant mesh stiffness
    50 N/(mm um), single pair 33, 'c_gamma_alpha 18.3, c' 12.6'.  The issue prints two
    digits from a slow dynamic run: accept 3 % (rounding 1 %, residual vibration and sampling of
    a dynamic run).  Its ISO values are those of C_B = 1 (12.58, 18.29); the spec's
    C_B = 0.975 gives 12.26 and 17.83.  Against the issue's ISO values the ratios are 2.62 and
    2.76 (its "2.6-2.75"); against the spec's (C_B = 0.975, 2.5 % lower) 2.68 and 2.83."""
    pair = pair_2030()   # E = 2.1e11, as the FMU
    mesh = T.static_mesh(pair, 1)
    mean = mesh["mean_secant"] / T.N_PER_MM_UM
    peak, _ = T.single_pair_peak(pair, 1)
    peak /= T.N_PER_MM_UM
    assert mean == pytest.approx(50.0, rel=0.03)
    assert peak == pytest.approx(33.0, rel=0.03)
    c1 = T.iso_c_prime(20, 30, 0, 0)
    cga = T.iso_c_gamma_alpha(c1, pair.eps)
    assert T.iso_c_prime(20, 30, 0, 0, dedendum=1.2) == pytest.approx(12.6, abs=0.05)
    assert T.iso_c_gamma_alpha(T.iso_c_prime(20, 30, 0, 0, dedendum=1.2), pair.eps) \
        == pytest.approx(18.3, abs=0.05)
    c1_issue = T.iso_c_prime(20, 30, 0, 0, dedendum=1.2)
    cga_issue = T.iso_c_gamma_alpha(c1_issue, pair.eps)
    assert 2.6 <= peak / c1_issue <= 2.8
    assert 2.6 <= mean / cga_issue <= 2.8
    assert 2.6 <= peak / c1 <= 2.9
    assert 2.6 <= mean / cga <= 2.9


# --------------------------------------------------------------------------------------------
# 5. The quasi-static mesh cycle
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("model", [1, 3])
def test_static_balance_and_cycle_mean(model):
    """sum F_i = W at every sampled position, gating consistent with the solved delta, the
    fraction of the cycle in double contact equals eps - 1 (up to delta/p_b), and the piecewise
    Gauss mean equals a dense midpoint mean (4000 points; the midpoint rule's error at the two
    jumps per cycle is below jump/4000 ~ 2e-4 of the mean: accept 1e-3)."""
    pair = pair_2030()
    W = 3e5 * pair.b
    mesh = T.static_mesh(pair, model)
    for s0, d, ks, kt, n in mesh["samples"]:
        r = T.static_balance(pair, model, s0, W)
        assert sum(r["F"]) == pytest.approx(W, rel=1e-12)
        assert all(pair.s_a <= s - d and s <= pair.s_b for s in r["pairs"])
    N = 4000
    s0s = pair.s_a + (np.arange(N) + 0.5) / N * pair.p_b
    res = [T.static_balance(pair, model, s0, W) for s0 in s0s]
    dense = np.mean([r["k_secant"] for r in res]) / pair.b
    assert mesh["mean_secant"] == pytest.approx(dense, rel=1e-3)
    frac2 = np.mean([len(r["pairs"]) == 2 for r in res])
    assert frac2 == pytest.approx(pair.eps - 1.0, abs=2.0 / N + 2 * mesh["mean_dte"] / pair.p_b)


def test_per_unit_width_invariance():
    """Stiffness per unit face width does not depend on b (all terms scale with b)."""
    a = T.static_mesh(T.standard_pair(20, 30, 4e-3, b=0.01), 3)["mean_secant"]
    b = T.static_mesh(T.standard_pair(20, 30, 4e-3, b=0.05), 3)["mean_secant"]
    assert a == pytest.approx(b, rel=1e-12)


# --------------------------------------------------------------------------------------------
# 6. ISO 6336-1 method B
# --------------------------------------------------------------------------------------------

def test_iso_formulas_and_units():
    # q' [mm um/N] for z 20/30, x 0: C1 + C2/20 + C3/30
    q = 0.04723 + 0.15551 / 20 + 0.25791 / 30
    assert T.iso_q_prime(20, 30, 0, 0) == pytest.approx(q, rel=1e-15)
    # c'_th = 1/q' ~ 15.7 N/(mm um); C_M = 0.8, C_R = 1, C_B(1.25) = 0.975
    assert T.iso_c_prime(20, 30, 0, 0) == pytest.approx(1 / q * 0.8 * 0.975, rel=1e-15)
    assert T.iso_c_gamma_alpha(10.0, 1.6) == pytest.approx(10.0 * (0.75 * 1.6 + 0.25), rel=1e-15)
    # all terms of q'
    z1, z2, x1, x2 = 23, 71, 0.3, -0.2
    C = T.ISO_C
    q = (C[0] + C[1] / z1 + C[2] / z2 + C[3] * x1 + C[4] * x1 / z1 + C[5] * x2 + C[6] * x2 / z2
         + C[7] * x1 ** 2 + C[8] * x2 ** 2)
    assert T.iso_q_prime(z1, z2, x1, x2) == pytest.approx(q, rel=1e-15)
    # units: a stiffness per unit width of 1 N/(mm um) is 1 N / (1e-3 m * 1e-6 m) = 1e9 N/m^2
    assert T.N_PER_MM_UM == 1e9
    # ISO's single stiffness of steel spur gears is 12-16 N/(mm um) over the table's range
    for zA, zB, m, xA, xB in T.TABLE_PAIRS:
        assert 11.0 < T.iso_c_prime(zA, zB, xA, xB) < 17.0


def test_iso_table_runs_and_is_reported():
    """The table (tools/iso_table_ref.py prints it).  Not a fit: only what must hold whatever
    the ratios are - contact-only (model 1) is far stiffer than ISO, model 3 is finite and
    positive, and its mean is not above its tangent mean (log law: tangent > secant)."""
    rows = [T.table_row(*p) for p in T.TABLE_PAIRS[:6]]
    for r in rows:
        assert r["m1_mean"] / r["c_gamma_alpha"] > 1.8
        assert r["m1_peak"] / r["c_prime"] > 1.8
        assert 0.0 < r["m3_mean"] <= r["m3_mean_tangent"]
        assert 0.0 < r["m3_peak"] < r["m1_peak"]


# --------------------------------------------------------------------------------------------
# 7. Geometry that cannot exist
# --------------------------------------------------------------------------------------------

def test_rejected_geometry():
    with pytest.raises(T.GeometryError, match="pointed"):
        T.Wheel(10, 1e-3, 0.8)
    with pytest.raises(T.GeometryError, match="below the rack-generated involute"):
        T.standard_pair(26, 100, 4e-3, 0.0, -0.5)
    with pytest.raises(T.GeometryError, match="bore"):
        T.Wheel(20, 4e-3, 0.0, r_bore=0.04)
