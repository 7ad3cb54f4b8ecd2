"""Independent reference of the tooth-structure mesh (contact model 3) and its ISO 6336-1 check.

Contract: /work/shared/spec/tooth-structure.md (section 1), base model
/work/shared/spec/gear-mesh-model.md (section 2, standard geometry; section 4, Johnson's law).
Written from the published formulas as the spec restates them, without reading the FMU's source.

Contents
--------
* ``Wheel`` / ``Pair``: standard spur geometry (module, z, alpha_0, x, ha, dedendum,
  rack_tip_radius, bore radius) and the derived quantities of the potential-energy method.
* Structural compliance of one tooth and its body as a function of the contact's roll distance
  ``s`` from that wheel's tangent point (``tooth_compliance``):
    - bending, shear, axial compression: the alpha-integrals of Yang & Lin (1987) as extended by
      Tian (2004), integrated by Gauss-Legendre quadrature (the integrands are analytic);
    - the straight segment between base and root circle (Chen & Shao 2011), closed form derived
      below (``straight_segment_compliance``);
    - the fillet-foundation compliance of Sainsot, Velex & Duverger (2004) with theta_f of the
      improved method of Ma et al. (rack-generated root).
* ``beam_compliance_direct``: an independent evaluation of the same beam model, by direct
  integration of M^2/EI + 1.2 V^2/GA + N^2/EA along the tooth centre line, with the tooth
  half-thickness from the polar involute equation and the internal forces from the force vector
  (no use of the alpha-substitution).  Used by the tests to check the transcription.
* Weber's local contact (Weber 1949; Weber & Banaschek 1953) and the closed form of the pair,
  delta = F/(pi b E*) ln(C/F), solved for F through the lower branch of Lambert W in logarithms.
* Johnson's line contact (contact model 1; paper eq. 5.1), also through Lambert W.
* Quasi-static mesh over one mesh cycle (``static_mesh``) and the single-pair stiffness
  (``single_pair_stiffness``), ISO 6336-1 method B (``iso_c_prime``, ``iso_c_gamma_alpha``).

Units: SI throughout (m, N, Pa); stiffness per unit face width is reported in N/(mm um)
(1 N/(mm um) = 1e9 N/m^2).

Sign conventions used (spec section 1): alpha_2 is the half tooth angle on the base circle,
alpha_1 = s/r_b - alpha_2 the angle between the line of action and the normal to the tooth centre
line at the load point (positive when the load line meets the centre line outside the base
circle; alpha_1 < 0 is possible low on the flank of a small pinion and the formulas stay valid).
In the integrals the variable t = -alpha, where alpha is the involute parameter of Tian's
profile x = r_b[cos a + (a + alpha_2) sin a], y = r_b[(a + alpha_2) cos a - sin a]; the load
point is t = -alpha_1 and the base circle t = alpha_2.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq, minimize_scalar
from scipy.special import lambertw

# --------------------------------------------------------------------------------------------
# Constants
# --------------------------------------------------------------------------------------------

E_STEEL = 2.1e11       # project default (FMU start value)
NU_STEEL = 0.3
E_ISO = 2.06e11        # ISO 6336-1 values are for steel/steel with E = 206 000 N/mm^2

N_PER_MM_UM = 1e9      # 1 N/(mm um) in N/m^2 (stiffness per unit face width)

# Sainsot, Velex & Duverger (2004), Table 1: X* = A/theta_f^2 + B h_f^2 + C h_f/theta_f
# + D/theta_f + E h_f + F for X* = L*, M*, P*, Q* (theta_f in rad, h_f = r_f / r_bore).
SAINSOT = {
    #      A            B            C            D            E        F
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}

# ISO 6336-1:2006 method B, eq. for q' [mm um / N] (spec section 1, "The external check").
ISO_C = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)

# Gauss-Legendre nodes for the alpha-integrals (analytic integrands on closed intervals:
# 48 nodes reach double precision, checked against adaptive quadrature in the tests).
_GL_N = 48
_GL_X, _GL_W = np.polynomial.legendre.leggauss(_GL_N)


class GeometryError(ValueError):
    """Geometry that cannot exist or lies outside the model's domain."""


def involute(a):
    return math.tan(a) - a


def inverse_involute(v: float) -> float:
    """alpha in (0, pi/2) with tan(alpha) - alpha = v (Newton from the small-angle start)."""
    if not v > 0.0:
        raise GeometryError(f"inv(alpha) = {v!r} <= 0")
    a = min((3.0 * v) ** (1.0 / 3.0), 1.4)
    for _ in range(100):
        da = (math.tan(a) - a - v) / math.tan(a) ** 2
        a -= da
        if abs(da) < 1e-16 * a:
            break
    return a


def gauss(f, a: float, b: float, n: int | None = None) -> float:
    """Gauss-Legendre quadrature of a vectorized f over [a, b]."""
    if n is None:
        x, w = _GL_X, _GL_W
    else:
        x, w = np.polynomial.legendre.leggauss(n)
    half = 0.5 * (b - a)
    t = 0.5 * (a + b) + half * x
    return float(half * np.dot(w, f(t)))


# --------------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------------

@dataclass
class Wheel:
    """One wheel of standard geometry (module m [m], coefficients relative to m)."""

    z: int
    m: float
    x: float = 0.0
    alpha0: float = math.radians(20.0)
    ha: float = 1.0
    dedendum: float = 1.25
    rack_tip_radius: float = 0.38
    r_bore: float | None = None          # None: 0.5 * r_f (see BORE_FRACTION)
    E: float = E_STEEL
    nu: float = NU_STEEL

    BORE_FRACTION = 0.5

    def __post_init__(self):
        m, z, x, a0 = self.m, self.z, self.x, self.alpha0
        self.r = m * z / 2.0                                   # reference radius
        self.r_b = self.r * math.cos(a0)                       # base radius
        self.r_a = self.r + m * (self.ha + x)                  # tip radius
        self.r_f = m * (z / 2.0 - self.dedendum + x)           # root radius (spec section 1)
        if self.r_bore is None:
            self.r_bore = self.BORE_FRACTION * self.r_f
        if not 0.0 < self.r_bore < self.r_f:
            raise GeometryError(f"bore radius {self.r_bore!r} m must lie in (0, r_f = {self.r_f!r} m)")
        # half tooth angle on the base circle (spec section 1):
        # alpha_2 = pi/(2z) + inv(alpha_0) + 2 x tan(alpha_0)/z
        self.alpha_2 = math.pi / (2.0 * z) + involute(a0) + 2.0 * x * math.tan(a0) / z
        # lower end of the involute profile used by the beam (spec: alpha_t rule)
        if self.r_f < self.r_b:
            self.phi_root = 0.0                                # involute from the base circle
            self.alpha_t = self.alpha_2
        else:
            self.phi_root = math.sqrt((self.r_f / self.r_b) ** 2 - 1.0)
            self.alpha_t = self.alpha_2 - self.phi_root
        # tip thickness (angle): half angle at r_a is alpha_2 - inv(arccos(r_b/r_a))
        self.tip_half_angle = self.alpha_2 - involute(math.acos(self.r_b / self.r_a))
        if self.tip_half_angle <= 0.0:
            raise GeometryError(f"pointed tooth: z = {z}, x = {x}, tip half angle "
                                f"{self.tip_half_angle!r} rad <= 0")
        self.s_tip = math.sqrt(self.r_a ** 2 - self.r_b ** 2)  # roll distance of the tip
        # Rack-generated form (undercut) limit: the rack's straight flank ends at depth
        # (dedendum - rho (1 - sin a0)) m below its reference line; the involute it generates
        # begins at roll distance r sin a0 - m (that depth - x)/sin a0 (negative: no undercut).
        h_lin = self.dedendum - self.rack_tip_radius * (1.0 - math.sin(a0)) - x
        self.s_form = self.r * math.sin(a0) - m * h_lin / math.sin(a0)
        # Fillet foundation (Sainsot et al. 2004) with theta_f of Ma et al.'s improved method:
        # theta_f = [pi/2 + 2 tan(a0)(dedendum - rho) + 2 rho / cos(a0)] / z
        rho = self.rack_tip_radius
        self.theta_f = (math.pi / 2.0 + 2.0 * math.tan(a0) * (self.dedendum - rho)
                        + 2.0 * rho / math.cos(a0)) / z
        self.S_f = 2.0 * self.r_f * self.theta_f               # root thickness (arc)
        self.h_f = self.r_f / self.r_bore
        tf, hf = self.theta_f, self.h_f
        self.sainsot = {k: A / tf ** 2 + B * hf ** 2 + C * hf / tf + D / tf + E_ * hf + F
                        for k, (A, B, C, D, E_, F) in SAINSOT.items()}

    # ---- per contact position -----------------------------------------------------------------
    def alpha_1(self, s):
        """Load angle at the contact, s = roll distance from the tangent point (spec section 1)."""
        return s / self.r_b - self.alpha_2

    def u_f(self, s):
        """Sainsot's u_f = r_b / cos(alpha_1) - r_f (unclamped)."""
        return self.r_b / math.cos(self.alpha_1(s)) - self.r_f

    def weber_h(self, s):
        """Distance from the contact point to the tooth centre line along the line of action:
        h = r_b (alpha_1 + alpha_2 - tan alpha_1) = s - r_b tan(alpha_1)."""
        a1 = self.alpha_1(s)
        return self.r_b * (a1 + self.alpha_2 - math.tan(a1))


@dataclass
class Pair:
    """Spur pair A (driving, usually the pinion) / B, face width b [m]."""

    A: Wheel
    B: Wheel
    b: float = 0.02
    warn_messages: list = field(default_factory=list)

    def __post_init__(self):
        A, B = self.A, self.B
        if A.m != B.m or A.alpha0 != B.alpha0:
            raise GeometryError("module and pressure angle must agree")
        m, a0 = A.m, A.alpha0
        # operating pressure angle from the involute equation (gear-mesh-model.md section 2)
        inv_w = involute(a0) + 2.0 * math.tan(a0) * (A.x + B.x) / (A.z + B.z)
        self.alpha_w = inverse_involute(inv_w)
        self.d = m * (A.z + B.z) / 2.0 * math.cos(a0) / math.cos(self.alpha_w)
        self.L = self.d * math.sin(self.alpha_w)
        self.s_b = A.s_tip                       # A's tip
        self.s_a = self.L - B.s_tip              # B's tip
        self.p_b = 2.0 * math.pi * A.r_b / A.z
        self.eps = (self.s_b - self.s_a) / self.p_b
        if self.s_a < 0.0 or self.s_b > self.L:
            raise GeometryError(f"interference: [s_a, s_b] = [{self.s_a!r}, {self.s_b!r}] not in "
                                f"[0, L = {self.L!r}]")
        if not 1.0 - 1e-9 <= self.eps <= 2.0 + 1e-9:
            raise GeometryError(f"contact ratio {self.eps!r} outside [1, 2]")
        # active profile start of each wheel must lie on its rack-generated involute
        for name, w, s_start in (("A", A, self.s_a), ("B", B, self.L - self.s_b)):
            if s_start < w.s_form:
                raise GeometryError(f"wheel {name}: active profile starts at roll distance "
                                    f"{s_start!r} m, below the rack-generated involute (it "
                                    f"begins at {w.s_form!r} m; fillet interference)")
            if w.s_form < 0.0:
                msg = (f"wheel {name} (z = {w.z}, x = {w.x}) is undercut (form roll distance "
                       f"{w.s_form!r} m < 0); the active profile is not checked against it")
                self.warn_messages.append(msg)
                warnings.warn(msg, stacklevel=2)
            if s_start < w.r_b * w.phi_root:
                raise GeometryError(f"wheel {name}: active profile below the root circle")
            if w.u_f(s_start) < 0.0:
                msg = (f"wheel {name} (z = {w.z}, x = {w.x}): Sainsot's u_f < 0 on the active "
                       f"profile (min {w.u_f(s_start)!r} m); u_f = 0 used there")
                self.warn_messages.append(msg)
                warnings.warn(msg, stacklevel=2)
        self.E_star = 1.0 / ((1.0 - A.nu ** 2) / A.E + (1.0 - B.nu ** 2) / B.E)

    def s_B(self, s_A, delta=0.0):
        return self.L + delta - s_A


def standard_pair(zA, zB, m, xA=0.0, xB=0.0, b=0.02, E=E_STEEL, nu=NU_STEEL, **kw) -> Pair:
    return Pair(Wheel(zA, m, xA, E=E, nu=nu, **kw), Wheel(zB, m, xB, E=E, nu=nu, **kw), b=b)


# --------------------------------------------------------------------------------------------
# Structure: one tooth and its body
# --------------------------------------------------------------------------------------------

def alpha_integrals(w: Wheel, s: float, b: float, n: int | None = None) -> dict:
    """Bending, shear and axial compliances [m/N] of the involute part of the tooth
    (Yang & Lin 1987; Tian 2004), integrated from the contact t = -alpha_1 to t = alpha_t:

        1/k_b  = int 3 {1 + cos a1 [(a2 - t) sin t - cos t]}^2 (a2 - t) cos t
                     / (2 E b [sin t + (a2 - t) cos t]^3) dt
        1/k_sh = int 1.2 (1 + nu) (a2 - t) cos t cos^2 a1 / (E b [sin t + (a2 - t) cos t]) dt
        1/k_a  = int (a2 - t) cos t sin^2 a1 / (2 E b [sin t + (a2 - t) cos t]) dt
    """
    a1, a2, E, nu = w.alpha_1(s), w.alpha_2, w.E, w.nu
    lo, hi = -a1, w.alpha_t
    if lo > hi:
        raise GeometryError(f"contact at roll distance {s!r} m lies below the tooth's involute")
    c1, s1 = math.cos(a1), math.sin(a1)

    def den(t):
        return np.sin(t) + (a2 - t) * np.cos(t)

    def fb(t):
        return 3.0 * (1.0 + c1 * ((a2 - t) * np.sin(t) - np.cos(t))) ** 2 * (a2 - t) * np.cos(t) \
            / (2.0 * E * b * den(t) ** 3)

    def fs(t):
        return 1.2 * (1.0 + nu) * (a2 - t) * np.cos(t) * c1 ** 2 / (E * b * den(t))

    def fa(t):
        return (a2 - t) * np.cos(t) * s1 ** 2 / (2.0 * E * b * den(t))

    return {"bending": gauss(fb, lo, hi, n), "shear": gauss(fs, lo, hi, n),
            "axial": gauss(fa, lo, hi, n)}


def straight_segment_compliance(w: Wheel, s: float, b: float) -> dict:
    """Chen & Shao (2011): the part of the tooth between the base circle and a root circle that
    lies below it, taken as a beam of constant half-thickness h_b = r_b sin(alpha_2).

    Derivation (written here, not copied): the beam runs along the centre line from the root,
    x_f = sqrt(r_f^2 - h_b^2) (where the straight flank meets the root circle), to the base circle
    point x_0 = r_b cos(alpha_2); length d = x_0 - x_f.  The contact force F acts along the line
    of action at the contact point (x_P, y_P) = r_b[cos a1 + (a1 + a2) sin a1,
    (a1 + a2) cos a1 - sin a1], with components F cos a1 normal to the centre line and F sin a1
    along it.  The bending moment at section x is
        M(x) = F [cos a1 (x_P - x) - sin a1 y_P] = F (r_b - x cos a1),
    because cos a1 x_P - sin a1 y_P = r_b (the line of action is tangent to the base circle).
    With u = x_0 - x in [0, d] and a = r_b - x_0 cos a1 (moment arm at the base circle section),
    M = F (a + u cos a1), and with I = 2 h_b^3 b / 3, A = 2 h_b b, G = E / (2 (1 + nu)):
        1/k_b1  = int_0^d (a + u cos a1)^2 du / (E I)
                = [3 a^2 d + 3 a cos(a1) d^2 + cos^2(a1) d^3] / (2 E b h_b^3)
        1/k_sh1 = 1.2 cos^2(a1) d / (G A) = 1.2 (1 + nu) cos^2(a1) d / (E b h_b)
        1/k_a1  = sin^2(a1) d / (E A)     = sin^2(a1) d / (2 E b h_b)
    Zero when the root circle is not below the base circle.
    """
    if w.r_f >= w.r_b:
        return {"bending": 0.0, "shear": 0.0, "axial": 0.0}
    a1, E, nu = w.alpha_1(s), w.E, w.nu
    hb = w.r_b * math.sin(w.alpha_2)
    x0 = w.r_b * math.cos(w.alpha_2)
    xf = math.sqrt(w.r_f ** 2 - hb ** 2)
    d = x0 - xf
    c1, s1 = math.cos(a1), math.sin(a1)
    a = w.r_b - x0 * c1
    return {
        "bending": (3.0 * a * a * d + 3.0 * a * c1 * d * d + c1 * c1 * d ** 3) / (2.0 * E * b * hb ** 3),
        "shear": 1.2 * (1.0 + nu) * c1 * c1 * d / (E * b * hb),
        "axial": s1 * s1 * d / (2.0 * E * b * hb),
    }


def fillet_compliance(w: Wheel, s: float, b: float) -> float:
    """Sainsot, Velex & Duverger (2004), fillet-foundation compliance [m/N]:
        1/k_f = cos^2(a1)/(E b) [L* (u_f/S_f)^2 + M* (u_f/S_f) + P* (1 + Q* tan^2 a1)],
    u_f = r_b / cos(a1) - r_f clamped at 0 (spec: outside the fit's domain), S_f = 2 r_f theta_f."""
    a1 = w.alpha_1(s)
    uf = max(w.u_f(s), 0.0)
    q = uf / w.S_f
    X = w.sainsot
    return math.cos(a1) ** 2 / (w.E * b) * (X["L"] * q * q + X["M"] * q
                                           + X["P"] * (1.0 + X["Q"] * math.tan(a1) ** 2))


def tooth_compliance(w: Wheel, s: float, b: float) -> dict:
    """All structural compliance terms [m/N] of one tooth and body at roll distance s."""
    ai = alpha_integrals(w, s, b)
    st = straight_segment_compliance(w, s, b)
    out = {k: ai[k] for k in ai}
    out.update({"straight_" + k: v for k, v in st.items()})
    out["fillet"] = fillet_compliance(w, s, b)
    out["total"] = sum(v for k, v in out.items())
    return out


def structure_compliance(pair: Pair, s_A: float, delta: float = 0.0) -> float:
    """1/k_s = sum over both teeth and bodies [m/N]; s_B = L + delta - s_A."""
    s_B = pair.s_B(s_A, delta)
    return tooth_compliance(pair.A, s_A, pair.b)["total"] + tooth_compliance(pair.B, s_B, pair.b)["total"]


# --------------------------------------------------------------------------------------------
# Independent check: direct beam integration over the involute tooth
# --------------------------------------------------------------------------------------------

def beam_compliance_direct(w: Wheel, s: float, b: float, epsrel: float = 1e-13):
    """The same cantilever beam evaluated without the alpha-substitution.

    Profile: polar involute.  A profile point at roll angle phi (radius r = r_b sqrt(1 + phi^2),
    pressure angle atan(phi)) has the polar angle beta = alpha_2 - inv(atan phi) from the tooth
    centre line, so x = r cos(beta) along the centre line, half-thickness y = r sin(beta).
    Load: at the contact point P (phi_P = s / r_b) along the line of action, i.e. along P - T
    where T is the base-circle point at polar angle alpha_2 - phi_P; the force on the tooth is
    F_vec = -F (P - T)/|P - T|.  Internal forces at the section x (cut normal to the centre
    line): N = F_vec.x (axial), V = F_vec.y (shear), M = ((P - (x, 0)) x F_vec)_z.
    Energy U = 1/2 int [M^2/(E I) + 1.2 V^2/(G A) + N^2/(E A)] dx with I = b (2y)^3/12,
    A = 2 y b, G = E/(2(1 + nu)); compliance 1/k = 2U/F^2.  Integrated over phi in
    [phi_root, phi_P] with dx = (dx/dphi) dphi, and for r_f < r_b over the straight segment
    of half-thickness r_b sin(alpha_2) from sqrt(r_f^2 - y^2) up to the base circle.
    Adaptive quadrature (scipy.integrate.quad); returns (dict of compliances, dict of the
    quadrature's absolute error estimates).
    """
    from scipy.integrate import quad

    E, nu, rb, a2 = w.E, w.nu, w.r_b, w.alpha_2
    G = E / (2.0 * (1.0 + nu))
    phiP = s / rb
    P = np.array([rb * math.sqrt(1 + phiP ** 2) * math.cos(a2 - (phiP - math.atan(phiP))),
                  rb * math.sqrt(1 + phiP ** 2) * math.sin(a2 - (phiP - math.atan(phiP)))])
    T = rb * np.array([math.cos(a2 - phiP), math.sin(a2 - phiP)])
    u = (P - T) / np.linalg.norm(P - T)
    Fv = -u                                                     # unit force on the tooth

    def forces(x):
        N = Fv[0]
        V = Fv[1]
        M = (P[0] - x) * Fv[1] - P[1] * Fv[0]
        return M, V, N

    def dens(x, y):
        M, V, N = forces(x)
        I = b * (2.0 * y) ** 3 / 12.0
        A = 2.0 * y * b
        return M * M / (E * I), 1.2 * V * V / (G * A), N * N / (E * A)

    def xy(phi):
        r = rb * math.sqrt(1.0 + phi * phi)
        beta = a2 - (phi - math.atan(phi))
        return r * math.cos(beta), r * math.sin(beta), r, beta

    def dxdphi(phi):
        x, y, r, beta = xy(phi)
        drdphi = rb * phi / math.sqrt(1.0 + phi * phi)
        dbeta = -phi * phi / (1.0 + phi * phi)
        return drdphi * math.cos(beta) - r * math.sin(beta) * dbeta

    out, err = {}, {}
    for i, name in enumerate(("bending", "shear", "axial")):
        def f(phi, i=i):
            x, y, _, _ = xy(phi)
            return dens(x, y)[i] * dxdphi(phi)
        val, e = quad(f, w.phi_root, phiP, epsabs=0.0, epsrel=epsrel, limit=200)
        out[name], err[name] = val, e
        if w.r_f < w.r_b:
            yb = rb * math.sin(a2)
            x0 = rb * math.cos(a2)
            xf = math.sqrt(w.r_f ** 2 - yb ** 2)
            val, e = quad(lambda x, i=i: dens(x, yb)[i], xf, x0, epsabs=0.0, epsrel=epsrel)
        else:
            val, e = 0.0, 0.0
        out["straight_" + name], err["straight_" + name] = val, e
    return out, err


# --------------------------------------------------------------------------------------------
# Local contact (Weber) and the closed form of the pair
# --------------------------------------------------------------------------------------------

def weber_w(w: Wheel, s_i: float, F: float, R: float, E_star: float, b: float) -> float:
    """Weber's local contact deformation of body i [m] (Weber 1949, Weber & Banaschek 1953):
        w_i = 2 F (1 - nu_i^2)/(pi E_i b) [ln(2 h_i / b_H) - nu_i/(2 (1 - nu_i))],
    b_H = sqrt(4 F R / (pi b E*)) (Hertz half-width), h_i = r_b (a1 + a2 - tan a1)."""
    bH = math.sqrt(4.0 * F * R / (math.pi * b * E_star))
    h = w.weber_h(s_i)
    return 2.0 * F * (1.0 - w.nu ** 2) / (math.pi * w.E * b) * (
        math.log(2.0 * h / bH) - w.nu / (2.0 * (1.0 - w.nu)))


def ln_C(pair: Pair, s_A: float, delta: float = 0.0) -> float:
    """ln C(s_A) of the closed form delta = F/(pi b E*) ln(C/F) (spec section 1):
        ln C = E* sum_i [(1 - nu_i^2)/E_i][ln(pi b E* h_i^2 / R) - nu_i/(1 - nu_i)] + pi b E*/k_s
    with R = s_A s_B/(s_A + s_B), s_B = L + delta - s_A (the spec evaluates it at delta = 0)."""
    Es, b = pair.E_star, pair.b
    s_B = pair.s_B(s_A, delta)
    R = s_A * s_B / (s_A + s_B)
    out = 0.0
    for w, s in ((pair.A, s_A), (pair.B, s_B)):
        h = w.weber_h(s)
        out += Es * (1.0 - w.nu ** 2) / w.E * (math.log(math.pi * b * Es * h * h / R)
                                               - w.nu / (1.0 - w.nu))
    return out + math.pi * b * Es * structure_compliance(pair, s_A, delta)


def model3_delta(pair: Pair, s_A: float, F: float, lnC: float | None = None) -> float:
    """Explicit penetration for force F [N] (closed form)."""
    if lnC is None:
        lnC = ln_C(pair, s_A)
    return F / (math.pi * pair.b * pair.E_star) * (lnC - math.log(F))


def _t_of(lam: float) -> float:
    """t = -W_{-1}(-x) for x = exp(-lam): the root t >= 1 of t - ln t = lam.  Computed with
    scipy's lambertw on the lower branch (x = e^-lam is representable for lam < 700) and
    polished by Newton steps on t - ln t - lam (working in logarithms)."""
    if lam <= 1.0:
        raise ValueError(f"outside the log law's range: ln(C) - ln(pi b E* delta) = {lam!r} <= 1")
    if lam < 700.0:
        t = float(-lambertw(-math.exp(-lam), -1).real)
    else:
        t = lam + math.log(lam)
    for _ in range(4):
        t -= (t - math.log(t) - lam) / (1.0 - 1.0 / t)
    return t


def model3_force(pair: Pair, s_A: float, delta: float, lnC: float | None = None):
    """Force F [N] and tangent stiffness dF/d(delta) [N/m] of one pair at penetration delta.

    y = F/C solves y ln y = -x with x = pi b E* delta / C, y = -x / W_{-1}(-x).  With
    t = -W_{-1}(-x) (t - ln t = -ln x = ln C - ln(pi b E* delta)), F = C x/t = pi b E* delta / t,
    and from delta = F/(pi b E*) (ln C - ln F): d(delta)/dF = (t - 1)/(pi b E*)."""
    if delta <= 0.0:
        return 0.0, 0.0
    if lnC is None:
        lnC = ln_C(pair, s_A)
    k0 = math.pi * pair.b * pair.E_star
    t = _t_of(lnC - math.log(k0 * delta))
    return k0 * delta / t, k0 / (t - 1.0)


# --------------------------------------------------------------------------------------------
# Contact model 1: Johnson line contact (paper eq. 5.1, gear-mesh-model.md section 4)
# --------------------------------------------------------------------------------------------

def johnson_force(pair: Pair, delta: float):
    """F [N] and dF/d(delta) of one pair: N per unit width from
    delta = N/(pi E*) [ln(4 pi E* rho/N) - 1], rho = rho_A + rho_B = L + delta.
    x = e delta/(4 rho), y = -x/W_{-1}(-x), N = 4 pi E* rho y / e.  Tangent: the spec's
    dN/d(delta) = pi E*/(-1 - ln y) holds rho fixed; with rho = L + delta the total derivative
    adds dN/d(rho) = N/rho - pi E* delta/((t - 1) rho) (t = -ln y), a relative 1e-5..1e-4."""
    if delta <= 0.0:
        return 0.0, 0.0
    Es, rho = pair.E_star, pair.L + delta
    x = math.e * delta / (4.0 * rho)
    if x >= 1.0 / math.e:
        raise ValueError("Johnson law out of range")
    t = _t_of(-math.log(x))                     # t = -W_{-1}(-x), y = x/t, -ln y = t
    N = 4.0 * math.pi * Es * rho / math.e * (x / t)
    k = math.pi * Es / (t - 1.0)
    return pair.b * N, pair.b * (k + N / rho - k * delta / rho)


def johnson_delta(pair: Pair, F: float) -> float:
    """Explicit: penetration for force F [N] (fixed point in rho = L + delta, converges in a
    few steps since delta << L)."""
    N = F / pair.b
    Es = pair.E_star
    d = 0.0
    for _ in range(50):
        new = N / (math.pi * Es) * (math.log(4.0 * math.pi * Es * (pair.L + d) / N) - 1.0)
        if abs(new - d) <= 1e-16 * abs(new):
            return new
        d = new
    return d


# --------------------------------------------------------------------------------------------
# Quasi-static mesh
# --------------------------------------------------------------------------------------------

def pair_force(pair: Pair, model: int, s_A: float, delta: float, lnC=None):
    if model == 1:
        return johnson_force(pair, delta)
    if model == 3:
        return model3_force(pair, s_A, delta, lnC)
    raise ValueError(f"contact model {model}")


def pair_delta(pair: Pair, model: int, s_A: float, F: float, lnC=None) -> float:
    if model == 1:
        return johnson_delta(pair, F)
    return model3_delta(pair, s_A, F, lnC)


def static_balance(pair: Pair, model: int, s0: float, W: float, exact_sB: bool = False) -> dict:
    """Static dte at wheel position s0 (s_A of the pair entering at B's tip, s0 in
    [s_a, s_a + p_b)): the delta shared by the gated pairs s_A = s0 + k p_b such that
    sum_i F_i(delta) = W (brentq).

    Gating (gear-mesh-model.md section 3): s_A <= s_b and s_A - delta >= s_a.  The second
    condition depends on delta; a pair is kept when the balance including it satisfies it
    (else it is dropped and the balance re-solved, which raises delta, so the result is
    consistent).  C(s_A) at s_B = L - s_A (spec); exact_sB = True evaluates it at
    s_B = L + delta - s_A instead (to measure what the spec's simplification costs)."""
    cand = [s0 + k * pair.p_b for k in range(-2, 3)]
    cand = [s for s in cand if pair.s_a - 1e-15 <= s <= pair.s_b + 1e-15]
    lnCs = {s: (ln_C(pair, s) if model == 3 else None) for s in cand}
    while True:
        d_hi = max(pair_delta(pair, model, s, W, lnCs[s]) for s in cand)

        def lnc(s, d):
            return ln_C(pair, s, d) if exact_sB else lnCs[s]

        def f(d):
            return sum(pair_force(pair, model, s, d, lnc(s, d))[0] for s in cand) - W

        if len(cand) == 1 and not exact_sB:
            d = d_hi                                  # explicit closed form
        else:
            if exact_sB:
                d_hi *= 1.1                           # C at L + delta - s_A: delta grows < 1 %
            d = brentq(f, d_hi * 1e-6, d_hi, xtol=1e-22, rtol=1e-15, maxiter=200)
        out = [s for s in cand if s - d < pair.s_a]
        if not out or len(cand) == 1:
            break
        cand = [s for s in cand if s not in out]
    forces = [pair_force(pair, model, s, d, lnc(s, d)) for s in cand]
    return {"delta": d, "pairs": cand, "F": [F for F, _ in forces],
            "k_tangent": sum(k for _, k in forces), "k_secant": W / d}


def static_mesh(pair: Pair, model: int, line_load: float = 3e5, n_gauss: int = 12,
                exact_sB: bool = False) -> dict:
    """Quasi-static mesh over one mesh cycle at total force W = line_load * b (line_load in N/m;
    300 N/mm = 3e5 N/m).  The cycle s0 in [s_a, s_a + p_b) is split where the number of gated
    pairs changes: [s_a, s_a + delta_2] (the entering pair still outside B's tip by the
    penetration), [., s_b - p_b] (two pairs), [s_b - p_b, s_a + p_b] (one pair); each piece is
    integrated by n_gauss-point Gauss-Legendre.  Returns per-unit-width means (N/m^2) of the
    secant W/dte and of the tangent sum dF_i/d(delta), the mean dte, and the samples."""
    W = line_load * pair.b
    s_a, s_b, p_b = pair.s_a, pair.s_b, pair.p_b
    d2 = static_balance(pair, model, s_a + 0.5 * (s_b - p_b - s_a), W)["delta"]
    cuts = [s_a, min(s_a + d2, s_b - p_b), s_b - p_b, s_a + p_b]
    x, wts = np.polynomial.legendre.leggauss(n_gauss)
    acc = {"secant": 0.0, "tangent": 0.0, "dte": 0.0}
    samples = []
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        if hi <= lo:
            continue
        half = 0.5 * (hi - lo)
        for xi, wi in zip(x, wts):
            s0 = 0.5 * (lo + hi) + half * xi
            r = static_balance(pair, model, s0, W, exact_sB)
            acc["secant"] += wi * half * r["k_secant"]
            acc["tangent"] += wi * half * r["k_tangent"]
            acc["dte"] += wi * half * r["delta"]
            samples.append((s0, r["delta"], r["k_secant"], r["k_tangent"], len(r["pairs"])))
    b = pair.b
    return {"mean_secant": acc["secant"] / p_b / b, "mean_tangent": acc["tangent"] / p_b / b,
            "mean_dte": acc["dte"] / p_b, "secant_of_mean_dte": W / (acc["dte"] / p_b) / b,
            "samples": samples}


def single_pair_stiffness(pair: Pair, model: int, s_A: float, line_load: float = 3e5) -> float:
    """Secant stiffness per unit width [N/m^2] of one pair carrying the whole load at s_A."""
    W = line_load * pair.b
    return W / pair_delta(pair, model, s_A, W) / pair.b


def single_pair_peak(pair: Pair, model: int, line_load: float = 3e5, zone: str = "single"):
    """Peak of the single-pair secant stiffness over the single-contact zone
    [s_b - p_b, s_a + p_b] (zone = 'single', ISO's c') or over the whole path [s_a, s_b]
    (zone = 'path').  Returns (peak per unit width [N/m^2], s_A at the peak)."""
    lo, hi = ((pair.s_b - pair.p_b, pair.s_a + pair.p_b) if zone == "single"
              else (pair.s_a, pair.s_b))

    def neg(s):
        return -single_pair_stiffness(pair, model, s, line_load)

    grid = np.linspace(lo, hi, 41)
    vals = [neg(s) for s in grid]
    i = int(np.argmin(vals))
    best_s, best = grid[i], vals[i]
    a, c = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    if c > a:
        r = minimize_scalar(neg, bounds=(a, c), method="bounded", options={"xatol": 1e-9 * pair.L})
        if r.fun < best:
            best_s, best = r.x, r.fun
    return -best, best_s


# --------------------------------------------------------------------------------------------
# ISO 6336-1 method B
# --------------------------------------------------------------------------------------------

def iso_q_prime(z1, z2, x1, x2) -> float:
    """q' [mm um/N] = C1 + C2/z1 + C3/z2 + C4 x1 + C5 x1/z1 + C6 x2 + C7 x2/z2 + C8 x1^2 + C9 x2^2
    (ISO 6336-1:2006, eq. for the theoretical single stiffness of solid spur gears)."""
    C = ISO_C
    return (C[0] + C[1] / z1 + C[2] / z2 + C[3] * x1 + C[4] * x1 / z1 + C[5] * x2
            + C[6] * x2 / z2 + C[7] * x1 ** 2 + C[8] * x2 ** 2)


def iso_c_prime(z1, z2, x1, x2, dedendum=1.25, C_M=0.8, C_R=1.0) -> float:
    """c' = c'_th C_M C_R C_B [N/(mm um)], c'_th = 1/q', C_B = 1 + 0.5 (1.2 - dedendum)."""
    C_B = 1.0 + 0.5 * (1.2 - dedendum)
    return 1.0 / iso_q_prime(z1, z2, x1, x2) * C_M * C_R * C_B


def iso_c_gamma_alpha(c_prime: float, eps_alpha: float) -> float:
    """Mean mesh stiffness c_gamma_alpha = c' (0.75 eps_alpha + 0.25) [N/(mm um)]."""
    return c_prime * (0.75 * eps_alpha + 0.25)


# --------------------------------------------------------------------------------------------
# The ISO comparison table
# --------------------------------------------------------------------------------------------

# (zA, zB, module [mm], xA, xB): z 17..100, x -0.5..0.5, module 2..8; pinion = A (ISO's z1).
TABLE_PAIRS = [
    (17, 34, 2, 0.3, 0.0),
    (17, 100, 3, 0.5, -0.5),
    (18, 72, 5, 0.25, -0.25),
    (20, 30, 4, 0.0, 0.0),
    (20, 40, 6, 0.2, 0.1),
    (24, 48, 2, 0.0, 0.0),
    (25, 75, 8, 0.1, -0.1),
    (26, 100, 4, 0.3, -0.5),
    (30, 30, 5, 0.0, 0.0),
    (30, 60, 3, 0.2, -0.2),
    (35, 70, 4, 0.5, 0.5),
    (40, 80, 2, 0.0, 0.0),
    (50, 100, 6, -0.5, 0.0),
    (60, 100, 8, 0.5, -0.5),
    (100, 100, 2, 0.0, 0.0),
]


def table_row(zA, zB, m_mm, xA, xB, E=E_ISO, nu=NU_STEEL, line_load=3e5, bore_fraction=0.5):
    m = m_mm * 1e-3
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        A = Wheel(zA, m, xA, E=E, nu=nu, r_bore=bore_fraction * m * (zA / 2 - 1.25 + xA))
        B = Wheel(zB, m, xB, E=E, nu=nu, r_bore=bore_fraction * m * (zB / 2 - 1.25 + xB))
        pair = Pair(A, B)
    c1 = iso_c_prime(zA, zB, xA, xB)
    cga = iso_c_gamma_alpha(c1, pair.eps)
    row = {"zA": zA, "zB": zB, "m": m_mm, "xA": xA, "xB": xB, "eps": pair.eps,
           "c_prime": c1, "c_gamma_alpha": cga, "warnings": [str(c.message) for c in caught]}
    for model in (1, 3):
        mesh = static_mesh(pair, model, line_load)
        peak, _ = single_pair_peak(pair, model, line_load, "single")
        row[f"m{model}_mean"] = mesh["mean_secant"] / N_PER_MM_UM
        row[f"m{model}_mean_tangent"] = mesh["mean_tangent"] / N_PER_MM_UM
        row[f"m{model}_peak"] = peak / N_PER_MM_UM
    return row
