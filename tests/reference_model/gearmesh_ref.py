"""Independent reference model of the SpurGearMesh FMU.

Implements /work/shared/spec/gear-mesh-model.md (the contract) and the output set of
fmi-interface.md, built *differently* from an object-tracking implementation:

* No contact objects with jump events.  Tooth pairs are ENUMERATED from the wheel angles.
  With u_A = rAb*theta_A, u_B = rBb*theta_B (interface frame, forward positive):

    forward pair k :  s_A = s_a + u_A - k*p_b,          delta_f = u_A - u_B            (= dte)
    backward pair k:  s_A = sigma_b1 - u_A + k*p_b,     delta_b = -backlash - (u_A - u_B)

  k = 0 is object f1 at t = 0, k = -1 is f2 (f2 = f1 + one pitch), and
  sigma_b1 = 2*rAb*alpha_w - s_a - p_b + rAb*tA is b1's s_A at theta_A = 0.  Both follow from the
  spec's phi formulas with phiA = phiA(0) - theta_A, phiB = phiB(0) + theta_B (the paper frame's
  psi_A = -theta_A, psi_B = theta_B); delta_b = -backlash - dte follows from
  rAb*tA + rBb*tB = p_b + 2 d cos(alpha_w) inv(alpha_w) - backlash and L = d sin(alpha_w)
  (checked numerically in tests/python/test_reference_model.py).
  s_B = L + delta - s_A, so rho_A + rho_B = L + delta for every pair: all gated pairs on a flank
  share delta and the Johnson force N(delta).

* A pair carries force iff it is gated (s_A <= s_b and s_A - delta >= s_a), inside the m_c-pitch
  tracking window (s_A >= s_b - m_c*p_b; only restrictive when contacts_per_flank < eps),
  delta > 0 and (damped) 1 + chi*d(delta)/dt > 0.  Object identity: forward pair k is f1 if
  k = 0 (mod m_c), else f2; backward pair k is b1 if k = 0 (mod m_c), else b2.  A window of
  length m_c*p_b holds exactly one pair of each residue class, which is what an
  object-tracking implementation's f1/f2/b1/b2 follow.

* Integration: scipy.integrate.solve_ivp (DOP853 by default) with the SET OF CARRYING PAIRS
  FIXED inside each call, so the right-hand side is smooth there (the Johnson force is extended
  oddly through delta = 0, the damped force is not clamped).  Every event that can change the
  set is a terminal event; the integration restarts there with the set re-derived from the state.
  Events: delta of a flank crossing 0; a gate boundary of any pair (periodic functions
  sin(pi*xi/p_b), zero at every pair's boundary, on flanks with delta > 0); damped release
  1 + chi*d(delta)/dt = 0; and the breakpoints of the piecewise-linear input table.
  Each event function is multiplied by the sign that makes it >= 0 just after the restart
  (ties at the restart instant are broken with the first, then second time derivative), and
  only + -> - crossings are detected, so an event never re-fires at its own restart.
  Sign changes hidden inside one step (a dip below zero and back) are caught by non-terminal
  guards at the zeros of d(dte)/dt and of the wheel speeds (see _check_guards); the result
  counts them (n_hidden) and any state change found only at a segment end (n_missed, which
  stays 0 in every shipped scene).

* Internal state: [theta_A, e, w_A, v] with e = dte = rAb*theta_A - rBb*theta_B and v = de/dt
  (a linear change of the interface-frame state theta_A, theta_B, w_A, w_B).  The mesh
  coordinates e, v are integrated directly so that their error is controlled in absolute terms
  (a few 1e-16 m) instead of being a difference of two large angles.

contact_model = 2 (rigid contact, rig-and-modes.md section 2, without slider and housing motion)
is the separate class RigidMesh below (GearMesh.simulate dispatches to it); contact_model = 1
runs exactly the code above.  contact_model = 3 and the shape deviations (tooth-structure.md
sections 1-2: a penetration and force per pair) are deviations_ref.DevMesh, built on the same
pair enumeration and state; with contact model 1 and every deviation off (the defaults) it is
not used, so the traces of the base scenes do not change.  All can append the outputs F_B_x,
F_B_y (mesh force on B in the paper frame, rig-and-modes.md section 1;
simulate(bearing_force=...), default: rigid only).

contact_model = 4 (the lumped mesh, lateral.md section 4: one linear spring k_lumped and damper
c_lumped along each flank's line of action, optionally the square-wave stiffness k_lumped n/eps)
is lumped_ref.LumpedMesh, on the same pair enumeration and state; GearMesh.simulate dispatches to
it and its outputs are OUTPUT_NAMES + k_mesh.  Its parameters k_lumped, c_lumped,
k_lumped_varies are in DEFAULTS (ignored by the other models); slider_stiffness is known only so
that contact model 4 can refuse the slider (any other model refuses a nonzero value with
NotImplementedError: this reference has no slider).

INTERNAL PAIR (internal = true, planetary.md section 1; standard geometry only).  In the interface
frame (theta_B = -psi_B, forward drive turns both wheels the same way) the spec's internal objects
give exactly the enumeration above: forward pair k has s_A = s_a + u_A - k p_b and delta = dte,
backward pair k has s_A = sigma_b1 - u_A + k p_b (same sigma_b1) and delta = -backlash - dte (the
internal closure rBb eB - rAb tA = 2 d cos(alpha_w) inv(alpha_w) + j_n), and the gates are the
same conditions on s_A and delta.  The torque table and v_s = omega_A s_A - omega_B s_B, written
with w_A = -omega_A, w_B = -omega_B, are the external expressions in the interface frame.  What
differs: s_B = s_A + L - delta and the Johnson radius sum rho_B - rho_A = L - delta (Geometry.kappa
= -1 turns L + delta into L - delta).  Contact model 3 is refused (not available yet); rigid
contact, shape deviations and the bearing-force outputs are not implemented here for it.

CENTRE DISTANCE (center_distance_error, planetary.md section 2): Geometry recomputes alpha_w, d,
L, s_a and the backlash at the actual distance (base and tip radii and base thicknesses nominal);
with center_distance_error = 0 it does not run, so the nominal numbers are bit-identical.

Readings of the spec where it leaves room (each is marked where it is implemented):
* gate ties at a restart count as inside (closed gate, the spec's ">="); an exact equilibrium
  on a gate boundary selects "inside" (GearMesh._classify);
* reported forces are clamped at 0 (an event instant may leave delta at -1e-21);
* eps outside [1, 2] and zB/zA != zB_nominal/zA_nominal are rejected for both geometries;
* inputs are piecewise linear between the table rows (a repeated time is a step and the
  value after it holds from that time on, as fmpy's after_event);
* with center_distance_error != 0 every check (interference, eps, j_n >= 0) is made on the
  ACTUAL geometry only: a pair whose nominal geometry would be refused is accepted if its axes'
  actual position cures it;
* internal pair: the tip and trochoid interference check of planetary.md section 1 (pinion tip
  corners followed through the mesh) is NOT implemented in this reference; s_a < 0, r_Ba <= rBb,
  eps outside [1, 2] and pointed teeth (top land <= 0, backlash thinning included) are refused,
  and so is a pinion whose active profile reaches below the involute its rack cutter generates
  (the project's rule kept by the FMU, not the spec's: s_a < m (zA/2 sin a0 - (h - xA)/sin a0),
  h = 1.25 - 0.38 (1 - sin a0); Geometry._check_pinion_form).  The ring is cut by a pinion-type
  cutter: no such rule for it.  (This reference does not apply the rule to external pairs.)
"""

from __future__ import annotations

import bisect
import csv
import math
import os
import tomllib
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

E_NUM = math.e
# brentq's smallest admissible relative tolerance (4 eps; scipy rejects 4e-16 with ValueError)
BRENT_RTOL = 4.0 * np.finfo(float).eps
INV_E = 1.0 / math.e

OUTPUT_NAMES = [
    "time", "theta_A", "theta_B", "w_A", "w_B", "dte",
    "F_f1", "F_f2", "F_b1", "F_b2", "F_fwd", "F_bwd", "n_fwd", "n_bwd",
    "tau_mesh_A", "tau_mesh_B", "P_loss",
]
# Mesh force on B in the paper frame (rig-and-modes.md section 1).  Not in OUTPUT_NAMES, so that
# the committed traces of the compliant scenes and the FMU comparison's request list stay as they
# are; simulate(bearing_force=True) appends them (default: only with contact_model = 2).
BEARING_OUTPUT_NAMES = ["F_B_x", "F_B_y"]

# Parameter and input defaults (identical to the FMU's start values).
DEFAULTS = {
    "geometry": 1,
    "zA_nominal": 20, "zB_nominal": 30, "zA": 22, "zB": 33,
    "rA": 0.2, "alpha_factor": 2.8,
    "module": 0.01, "pressure_angle": 0.3490658503988659, "xA": 0.0, "xB": 0.0, "addendum": 1.0,
    "width": 0.02,
    "E_A": 2.1e11, "E_B": 2.1e11, "nu_A": 0.3, "nu_B": 0.3,
    "J_A": 0.4, "J_B": 2.0,
    "backlash": 1e-4,
    "chi": 0.0, "mu": 0.0, "v_reg": 0.01, "c_load": 0.0,
    "contacts_per_flank": 0, "backward_contacts": True,
    "w_A_start": 0.0, "w_B_start": 0.0, "dte_start": 0.0,
    "tau_A": 0.0, "tau_B": 0.0,
    "solver": 1, "rel_tol": 1e-6,
    "contact_model": 1, "restitution": 0.0,
    # contact model 3 (tooth-structure.md section 1); bore radius 0 = half the root radius
    "dedendum": 1.25, "rack_tip_radius": 0.38, "bore_radius_A": 0.0, "bore_radius_B": 0.0,
    # shape deviations (tooth-structure.md section 2), all off by default
    "tip_relief_A": 0.0, "tip_relief_length_A": 0.0, "tip_relief_B": 0.0, "tip_relief_length_B": 0.0,
    "tip_relief_shape": 1, "ecc_A": 0.0, "ecc_B": 0.0, "ecc_phase_A": 0.0, "ecc_phase_B": 0.0,
    "pitch_errors_A": "", "pitch_errors_B": "",
    # internal gear pair and the actual centre distance (planetary.md sections 1-2)
    "internal": False, "center_distance_error": 0.0,
    # the lumped mesh (contact_model = 4, lateral.md section 4; lumped_ref.py)
    "k_lumped": 4e8, "c_lumped": 0.0, "k_lumped_varies": False,
    # the paper's slider S (rig-and-modes.md): not modelled by this reference; known only so that
    # contact_model = 4 can refuse it (0 = no slider, the default)
    "slider_stiffness": 0.0,
}
INTEGER_PARAMS = {"geometry", "zA_nominal", "zB_nominal", "zA", "zB", "contacts_per_flank", "solver",
                  "contact_model", "tip_relief_shape"}
BOOLEAN_PARAMS = {"backward_contacts", "internal", "k_lumped_varies"}
STRING_PARAMS = {"pitch_errors_A", "pitch_errors_B"}


class GeometryError(ValueError):
    """Rejected gear data (raised at initialization, like the FMU)."""


class JohnsonRangeError(ValueError):
    """Penetration outside the Johnson law's range (x >= 1/e)."""


# --------------------------------------------------------------------------------------------
# Johnson line contact (paper eq. 5.1)
# --------------------------------------------------------------------------------------------

def johnson_t(x: float) -> float:
    """t = -W_{-1}(-x): the root t >= 1 of t - ln t = -ln x, for 0 < x < 1/e.

    y ln y = -x with y = exp(-t) = x/t.  Newton's method on the convex increasing function
    f(t) = t - ln t + ln x, started right of the root (t0 = L + ln L + 1 with L = -ln x, which
    satisfies f(t0) >= 0 for all L >= 1), converges monotonically.
    """
    if not x > 0.0:
        raise ValueError(f"johnson_t needs x > 0, got {x!r}")
    if x >= INV_E:
        raise JohnsonRangeError(f"x = {x!r} >= 1/e: outside the Johnson law's range")
    lam = -math.log(x)
    t = lam + math.log(lam) + 1.0
    for _ in range(200):
        dt = (t - math.log(t) - lam) / (1.0 - 1.0 / t)
        t -= dt
        if abs(dt) <= 2e-16 * t:
            break
    return t


def johnson_N(delta: float, rho_sum: float, E_star: float) -> float:
    """Force per unit face width [N/m] for penetration delta [m], rho_A + rho_B = rho_sum."""
    if delta <= 0.0:
        return 0.0
    x = E_NUM * delta / (4.0 * rho_sum)
    if x >= INV_E:
        raise JohnsonRangeError(
            f"penetration {delta!r} m reaches the Johnson law's limit 4(rho_A+rho_B)/e^2 = "
            f"{4.0 * rho_sum / E_NUM ** 2!r} m")
    t = johnson_t(x)
    return 4.0 * math.pi * E_star * rho_sum / E_NUM * (x / t)


def johnson_N_fixed_point(delta: float, rho_sum: float, E_star: float, iters: int = 10000) -> float:
    """Same force by the paper's iteration eta_{k+1} = nu (1 + eta_k ln eta_k), y = x eta."""
    x = E_NUM * delta / (4.0 * rho_sum)
    nu = -1.0 / math.log(x)
    eta = nu
    for _ in range(iters):
        new = nu * (1.0 + eta * math.log(eta))
        if abs(new - eta) <= 1e-17 * abs(eta):
            eta = new
            break
        eta = new
    y = x * eta
    return 4.0 * math.pi * E_star * rho_sum / E_NUM * y


def johnson_delta(N: float, rho_sum: float, E_star: float) -> float:
    """Paper eq. 5.1 read forwards: penetration for force N per unit width."""
    return N / (math.pi * E_star) * (math.log(4.0 * math.pi * E_star * rho_sum / N) - 1.0)


def involute(a: float) -> float:
    return math.tan(a) - a


def inverse_involute(v: float) -> float:
    """Angle a in (0, pi/2) with tan(a) - a = v."""
    if v <= 0.0:
        raise GeometryError(f"inv(alpha_w) = {v!r} <= 0: no operating pressure angle")
    a = (3.0 * v) ** (1.0 / 3.0)  # small-angle start, inv(a) ~ a^3/3
    a = min(a, 1.5)
    for _ in range(100):
        f = math.tan(a) - a - v
        da = f / math.tan(a) ** 2
        a -= da
        if abs(da) < 1e-16 * a:
            break
    return a


# --------------------------------------------------------------------------------------------
# Parameters and geometry
# --------------------------------------------------------------------------------------------

def make_params(start_values: dict | None = None) -> dict:
    p = dict(DEFAULTS)
    for k, v in (start_values or {}).items():
        if k not in DEFAULTS:
            raise KeyError(f"unknown parameter/input {k!r}")
        if k in BOOLEAN_PARAMS:
            if not isinstance(v, bool):
                raise TypeError(f"{k} must be a boolean")
        elif k in STRING_PARAMS:
            if not isinstance(v, str):
                raise TypeError(f"{k} must be a string")
        elif k in INTEGER_PARAMS:
            if int(v) != v:
                raise TypeError(f"{k} must be an integer")
            v = int(v)
        else:
            v = float(v)
        p[k] = v
    return p


class Geometry:
    """alpha_w, rAb, rBb, d, L, s_a, s_b, p_b, eps, m_c, tA, tB and derived values.

    internal = True (planetary.md section 1): A is a pinion inside the ring B (standard geometry
    only); kappa = -1 (+1 for an external pair) is the sign that turns the external formulas
    into the internal ones where they differ: rho_A + rho_B = L + delta becomes
    rho_B - rho_A = L - delta (= L + kappa delta), and s_B = rho - kappa s_A.  The ring's space
    on its base circle eB (and tB = 2 pi/zB - eB) replace the external tB formula.

    center_distance_error != 0 (planetary.md section 2): base radii, tip radii and base
    thicknesses stay those of the nominal geometry; alpha_w, d, L, s_a and the backlash follow
    from the actual centre distance (_actual_centre_distance).  With center_distance_error = 0
    that step is skipped, so every nominal number is computed exactly as before it existed.
    center_distance and backlash_actual are the calculated parameters of the same names;
    self.backlash is the actual backlash too (the backward flank's offset everywhere)."""

    def __init__(self, p: dict):
        j = p["backlash"]
        self.internal = bool(p.get("internal", False))
        self.kappa = -1.0 if self.internal else 1.0
        if p["geometry"] == 1:
            if self.internal:
                raise GeometryError("internal = true needs the standard geometry (geometry = 2); "
                                    "the paper geometry has no internal pair (planetary.md section 1)")
            self._paper(p, j)
        elif p["geometry"] == 2:
            if self.internal:
                self._standard_internal(p, j)
            else:
                self._standard(p, j)
        else:
            raise GeometryError(f"geometry must be 1 (paper) or 2 (standard), got {p['geometry']}")
        self.backlash = j
        self.center_distance_error = float(p.get("center_distance_error", 0.0))
        self.d_nominal = self.d
        if self.center_distance_error != 0.0:
            self._actual_centre_distance(self.center_distance_error)
        self.center_distance = self.d
        self.backlash_actual = self.backlash
        at = ""
        if self.center_distance_error != 0.0:
            at = (f" at the actual centre distance d = {self.d!r} m (nominal {self.d_nominal!r} m, "
                  f"center_distance_error = {self.center_distance_error!r} m)")
        self.eps = (self.s_b - self.s_a) / self.p_b
        if self.internal:
            if self.s_a < 0.0:
                raise GeometryError(
                    f"internal pair: s_a = {self.s_a!r} m < 0: the ring's tip circle (r_Ba = "
                    f"{self.r_tipB!r} m) reaches past K_A, involute interference at the pinion's "
                    f"root (sqrt(r_Ba^2 - rBb^2) = {self.tipB_roll!r} m < L = {self.L!r} m){at}; "
                    f"a positive xB cures it")
        elif self.s_a < 0.0 or self.s_b > self.L:
            raise GeometryError(
                f"interference: contact segment [s_a, s_b] = [{self.s_a!r}, {self.s_b!r}] m "
                f"must lie inside [0, L] = [0, {self.L!r}] m{at}")
        if self.eps < 1.0 - 1e-9:
            raise GeometryError(f"contact ratio eps = {self.eps!r} < 1 (s_a = {self.s_a!r} m, "
                                f"s_b = {self.s_b!r} m, p_b = {self.p_b!r} m){at}")
        if self.eps > 2.0 + 1e-9:
            raise GeometryError(f"contact ratio eps = {self.eps!r} > 2 (more than two pairs per flank)"
                                f"{at}")
        if self.internal:
            self._check_pinion_form(p, at)
        cpf = p["contacts_per_flank"]
        if cpf == 0:
            self.m_c = math.ceil(self.eps - 1e-9)
        elif cpf in (1, 2):
            self.m_c = cpf
        else:
            raise GeometryError(f"contacts_per_flank must be 0, 1 or 2, got {cpf}")
        self.E_star = 1.0 / ((1.0 - p["nu_A"] ** 2) / p["E_A"] + (1.0 - p["nu_B"] ** 2) / p["E_B"])
        aw = self.alpha_w
        # tracking window and initial tracking angles (spec section 3), for checks and tests
        self.phi_min = aw - self.s_b / self.rAb
        self.phi_max = self.phi_min + self.m_c * self.dA
        self.phiA_f1 = aw - self.s_a / self.rAb
        if self.internal:   # planetary.md section 1, "Initial values"
            self.phiB_f1 = aw - (self.s_a + self.L) / self.rBb
        else:
            self.phiB_f1 = aw + math.pi - (self.L - self.s_a) / self.rBb
        # b1's s_A at theta_A = 0: phiA(b1) = phiA(f2) + tA = phiA(f1) - dA + tA (both pair kinds)
        self.sigma_b1 = 2.0 * self.rAb * aw - self.s_a - self.p_b + self.rAb * self.tA

    # ISO 53 profile A rack cutter (dedendum and tip radius in modules), as the FMU's check
    CUTTER_DEDENDUM = 1.25
    CUTTER_TIP_RADIUS = 0.38

    def _check_pinion_form(self, p, at):
        """Internal pair: the pinion's active profile must lie on the involute its rack cutter
        generates (the project's rule 'active profile below the involute', the FMU's
        Geometry::check_teeth).  The cutter's straight flank ends h = 1.25 - 0.38 (1 - sin a0)
        modules below its datum line; the involute it generates begins at roll distance
        form_start_A = m (zA/2 sin a0 - (h - xA)/sin a0) from the base circle's tangent point, and
        the lowest contact on the pinion is s_a (the ring's tip).  Refused when form_start_A >
        s_a + 1e-12 L (the FMU's slack); form_start_A < 0 (a rack-undercut pinion) can never be
        (s_a >= 0 is checked before).  The ring (B) is cut by a pinion-type cutter, so the rule is not applied to it.
        Checked on the actual geometry (s_a at the actual centre distance)."""
        m, a0, zA, xA = p["module"], p["pressure_angle"], p["zA"], p["xA"]
        h = self.CUTTER_DEDENDUM - self.CUTTER_TIP_RADIUS * (1.0 - math.sin(a0))
        start = m * zA / 2.0 * math.sin(a0) - (h - xA) * m / math.sin(a0)
        self.form_start_A = start
        if start > self.s_a + 1e-12 * self.L:
            raise GeometryError(
                f"active profile below the involute: the contact reaches the pinion's (wheel A's) "
                f"flank s_a = {self.s_a!r} m from its base circle's tangent point, below where a "
                f"rack cutter's straight flank generates the involute ({start!r} m; lower down is "
                f"the root fillet: the ring's tip r_Ba = {self.r_tipB!r} m reaches into it){at}; "
                f"a larger xB cures it")

    def rho(self, delta):
        """rho_A + rho_B (external) or rho_B - rho_A (internal) of a pair at penetration delta:
        L + delta or L - delta; the Johnson law's radius sum."""
        return self.L + self.kappa * delta

    def _actual_centre_distance(self, err):
        """planetary.md section 2: the operating geometry at d = d_nominal + err.  Base radii,
        tip radii and the base thickness angles tA, tB (eB) are the nominal ones."""
        d = self.d + err
        c = self.rBb - self.rAb if self.internal else self.rAb + self.rBb   # = d cos(alpha_w)
        if not (d > 0.0 and c < d):
            raise GeometryError(
                f"center_distance_error = {err!r} m: the actual centre distance d = {d!r} m "
                f"leaves no line of action (d cos(alpha_w) = {c!r} m must be < d)")
        aw = math.acos(c / d)
        L = d * math.sin(aw)
        if self.internal:
            s_a = self.tipB_roll - L
            # j_n = rBb eB - rAb tA - 2 d cos(alpha_w) inv(alpha_w), rBb eB = p_b - rBb tB
            j = self.rBb * self.eB - self.rAb * self.tA - 2.0 * c * involute(aw)
        else:
            s_a = L - self.tipB_roll
            j = self.p_b + 2.0 * c * involute(aw) - self.rAb * self.tA - self.rBb * self.tB
        if j < 0.0:
            raise GeometryError(
                f"center_distance_error = {err!r} m jams the teeth: the actual backlash j_n = "
                f"{j!r} m < 0 at d = {d!r} m (nominal {self.d!r} m, backlash {self.backlash!r} m, "
                f"alpha_w = {aw!r} rad)")
        self.d, self.alpha_w, self.L, self.s_a, self.backlash = d, aw, L, s_a, j

    def _paper(self, p, j):
        zAn, zBn, zA, zB = p["zA_nominal"], p["zB_nominal"], p["zA"], p["zB"]
        if zB * zAn != zA * zBn:
            raise GeometryError(f"zB/zA = {zB}/{zA} must equal zB_nominal/zA_nominal = {zBn}/{zAn}")
        rA = p["rA"]
        n = zBn / zAn
        rB = n * rA
        self.d = rA + rB
        alpha_inf = math.atan(2.0 * math.pi / (zAn * (1.0 + n)))
        aw = p["alpha_factor"] * alpha_inf
        self.alpha_w = aw
        self.zA, self.zB = zA, zB
        self.rAb = rA * math.cos(aw)
        self.rBb = rB * math.cos(aw)
        self.L = self.d * math.sin(aw)
        ab = self.rAb * 2.0 * math.pi / zAn
        self.s_a = (self.L - ab) / 2.0
        self.s_b = self.s_a + ab
        self.dA = 2.0 * math.pi / zA
        self.dB = 2.0 * math.pi / zB
        self.p_b = self.rAb * self.dA
        self.r_tipA = math.hypot(self.rAb, self.s_b)
        self.r_tipB = math.hypot(self.rBb, self.L - self.s_a)
        self.tipB_roll = self.L - self.s_a       # sqrt(r_tipB^2 - rBb^2): B's tip on its involute
        # equal tooth thickness on the operating pitch circles (radii rA, rB):
        # s'_A + s'_B = (p_b - j)/cos(alpha_w), tA = s'_A/rA + 2 inv(alpha_w)
        s_op = (self.p_b - j) / (2.0 * math.cos(aw))
        self.tA = s_op / rA + 2.0 * involute(aw)
        self.tB = s_op / rB + 2.0 * involute(aw)

    def _standard(self, p, j):
        m, zA, zB = p["module"], p["zA"], p["zB"]
        a0, xA, xB, ha = p["pressure_angle"], p["xA"], p["xB"], p["addendum"]
        inv_w = involute(a0) + 2.0 * math.tan(a0) * (xA + xB) / (zA + zB)
        aw = inverse_involute(inv_w)
        self.alpha_w = aw
        self.zA, self.zB = zA, zB
        self.d = m * (zA + zB) / 2.0 * math.cos(a0) / math.cos(aw)
        self.rAb = m * zA * math.cos(a0) / 2.0
        self.rBb = m * zB * math.cos(a0) / 2.0
        self.L = self.d * math.sin(aw)
        self.r_tipA = m * zA / 2.0 + m * (ha + xA)
        self.r_tipB = m * zB / 2.0 + m * (ha + xB)
        if self.r_tipA <= self.rAb or self.r_tipB <= self.rBb:
            raise GeometryError(f"tip radius inside the base circle: r_tipA = {self.r_tipA!r}, "
                                f"rAb = {self.rAb!r}, r_tipB = {self.r_tipB!r}, rBb = {self.rBb!r}")
        self.s_b = math.sqrt(self.r_tipA ** 2 - self.rAb ** 2)
        self.tipB_roll = math.sqrt(self.r_tipB ** 2 - self.rBb ** 2)
        self.s_a = self.L - self.tipB_roll
        self.dA = 2.0 * math.pi / zA
        self.dB = 2.0 * math.pi / zB
        self.p_b = self.rAb * self.dA
        # thickness on the reference circle m(pi/2 + 2 x tan a0), base angular thickness
        # t = s/r + 2 inv(a0); then backlash/2 off each base arc
        self.tA = (math.pi + 4.0 * xA * math.tan(a0)) / zA + 2.0 * involute(a0) - j / (2.0 * self.rAb)
        self.tB = (math.pi + 4.0 * xB * math.tan(a0)) / zB + 2.0 * involute(a0) - j / (2.0 * self.rBb)

    def _standard_internal(self, p, j):
        """planetary.md section 1: pinion A (external teeth) inside ring B (internal teeth)."""
        m, zA, zB = p["module"], p["zA"], p["zB"]
        a0, xA, xB, ha = p["pressure_angle"], p["xA"], p["xB"], p["addendum"]
        if not zA < zB:
            raise GeometryError(f"internal pair: zA = {zA} must be smaller than zB = {zB}")
        inv_w = involute(a0) + 2.0 * math.tan(a0) * (xB - xA) / (zB - zA)
        aw = inverse_involute(inv_w)
        self.alpha_w = aw
        self.zA, self.zB = zA, zB
        self.d = m * (zB - zA) / 2.0 * math.cos(a0) / math.cos(aw)
        self.rAb = m * zA * math.cos(a0) / 2.0
        self.rBb = m * zB * math.cos(a0) / 2.0
        self.L = self.d * math.sin(aw)
        self.r_tipA = m * zA / 2.0 + m * (ha + xA)
        self.r_tipB = m * zB / 2.0 - m * (ha - xB)      # the ring's tips point inwards
        if self.r_tipA <= self.rAb:
            raise GeometryError(f"tip radius inside the base circle: r_tipA = {self.r_tipA!r}, "
                                f"rAb = {self.rAb!r}")
        if self.r_tipB <= self.rBb:
            raise GeometryError(f"internal pair: the ring's tip radius r_Ba = {self.r_tipB!r} m "
                                f"<= its base radius rBb = {self.rBb!r} m")
        self.s_b = math.sqrt(self.r_tipA ** 2 - self.rAb ** 2)
        self.tipB_roll = math.sqrt(self.r_tipB ** 2 - self.rBb ** 2)
        self.s_a = self.tipB_roll - self.L
        self.dA = 2.0 * math.pi / zA
        self.dB = 2.0 * math.pi / zB
        self.p_b = self.rAb * self.dA
        self.tA = (math.pi + 4.0 * xA * math.tan(a0)) / zA + 2.0 * involute(a0) - j / (2.0 * self.rAb)
        # the ring's tooth SPACE on its base circle (the negative of an external tooth with
        # shift xB, widened by half the backlash); its tooth is what is left of the pitch
        self.eB = (math.pi + 4.0 * xB * math.tan(a0)) / zB + 2.0 * involute(a0) + j / (2.0 * self.rBb)
        self.tB = 2.0 * math.pi / zB - self.eB
        # pointed teeth: angular thickness at the tip, tA - 2 inv(alpha) for the pinion; the
        # ring's tooth widens outwards (tB + 2 inv(alpha) at radius r) and its tip is its
        # innermost circle r_Ba
        landA = self.tA - 2.0 * involute(math.acos(self.rAb / self.r_tipA))
        landB = self.tB + 2.0 * involute(math.acos(self.rBb / self.r_tipB))
        if landA <= 0.0 or landB <= 0.0:
            raise GeometryError(
                f"pointed tooth (no top land): pinion tip thickness {landA * self.r_tipA!r} m at "
                f"r_Aa = {self.r_tipA!r} m, ring tip thickness {landB * self.r_tipB!r} m at "
                f"r_Ba = {self.r_tipB!r} m")
        self.top_land_A = landA * self.r_tipA
        self.top_land_B = landB * self.r_tipB


# --------------------------------------------------------------------------------------------
# Inputs: piecewise-linear table (fmpy semantics: repeated time = step, after-event value wins)
# --------------------------------------------------------------------------------------------

class InputTable:
    def __init__(self, times, tau_A, tau_B):
        self.t = [float(x) for x in times]
        self.a = [float(x) for x in tau_A]
        self.b = [float(x) for x in tau_B]
        if any(t2 < t1 for t1, t2 in zip(self.t, self.t[1:])):
            raise ValueError("input table times must be non-decreasing")
        self.breaks = sorted(set(self.t))

    @classmethod
    def constant(cls, tau_A, tau_B):
        return cls([0.0], [tau_A], [tau_B])

    @classmethod
    def from_csv(cls, path, tau_A_default, tau_B_default):
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        head = [h.strip().strip('"') for h in rows[0]]
        data = [[float(x) for x in r] for r in rows[1:] if r and any(c.strip() for c in r)]
        col = {h: i for i, h in enumerate(head)}
        times = [r[col["time"]] for r in data]
        ta = [r[col["tau_A"]] for r in data] if "tau_A" in col else [tau_A_default] * len(data)
        tb = [r[col["tau_B"]] for r in data] if "tau_B" in col else [tau_B_default] * len(data)
        return cls(times, ta, tb)

    def next_break(self, t: float) -> float:
        i = bisect.bisect_right(self.breaks, t)
        return self.breaks[i] if i < len(self.breaks) else math.inf

    def segment(self, t: float):
        """Linear pieces valid on [t, next_break(t)): returns (t0, a0, da, b0, db)."""
        ts = self.t
        if len(ts) == 1 or t < ts[0]:
            return (t, self.a[0], 0.0, self.b[0], 0.0)
        i = bisect.bisect_right(ts, t) - 1  # last row with time <= t (after-event value)
        if i >= len(ts) - 1:
            return (t, self.a[-1], 0.0, self.b[-1], 0.0)
        t0, t1 = ts[i], ts[i + 1]
        da = (self.a[i + 1] - self.a[i]) / (t1 - t0)
        db = (self.b[i + 1] - self.b[i]) / (t1 - t0)
        return (t0, self.a[i], da, self.b[i], db)

    def max_abs(self):
        return max(abs(x) for x in self.a), max(abs(x) for x in self.b)


# --------------------------------------------------------------------------------------------
# Simulation
# --------------------------------------------------------------------------------------------

@dataclass
class Config:
    """Logical contact state between two restarts."""
    on_f: bool                  # forward delta > 0
    on_b: bool                  # backward delta > 0
    kf: tuple                   # carrying forward pairs
    kb: tuple                   # carrying backward pairs
    sig: dict = field(default_factory=dict)  # sign multipliers of the event functions
    kin: tuple = ()             # uA, uB, wA, wB, aA, aB, e, v, d2e/dt2 at the restart

    @property
    def key(self):
        return (self.kf, self.kb)


@dataclass
class Result:
    names: list
    table: np.ndarray           # rows: grid samples + two rows at each event, time-sorted
    events: list                # (time, n_fwd_before, n_bwd_before, n_fwd_after, n_bwd_after)
    n_restarts: int
    energy: dict | None = None  # optional bookkeeping for the energy test
    n_missed: int = 0           # contact-state changes found only at a segment end
    n_hidden: int = 0           # sign changes hidden inside one step, found by the guards

    def column(self, name):
        return self.table[:, self.names.index(name)]

    def grid(self):
        """Rows on the output grid only (drops the duplicated event rows)."""
        t = self.table[:, 0]
        keep = np.ones(len(t), bool)
        keep[1:] = t[1:] != t[:-1]
        keep[:-1] &= t[:-1] != t[1:]
        return self.table[keep]

    def write_csv(self, path):
        write_table_csv(path, self.names, self.table)


def write_table_csv(path, names, table):
    ints = {names.index("n_fwd"), names.index("n_bwd")}
    with open(path, "w", newline="") as f:
        f.write(",".join(f'"{n}"' for n in names) + "\n")
        for row in table:
            f.write(",".join(str(int(round(v))) if i in ints else f"{v:.15g}"
                             for i, v in enumerate(row)) + "\n")


def read_table_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = [h.strip().strip('"') for h in rows[0]]
    table = np.array([[float(x) for x in r] for r in rows[1:] if r], dtype=float)
    return names, table


class GearMesh:
    def __init__(self, start_values: dict | None = None):
        self.p = make_params(start_values)
        self.g = Geometry(self.p)
        if self.p["contact_model"] not in (1, 2, 3, 4):
            raise ValueError(f"contact_model must be 1 (Johnson), 2 (rigid), 3 (tooth structure) "
                             f"or 4 (lumped), got {self.p['contact_model']}")
        if not 0.0 <= self.p["restitution"] <= 1.0:
            raise ValueError(f"restitution must lie in [0, 1], got {self.p['restitution']!r}")
        from . import deviations_ref as D
        self.deviations = D.deviations_active(self.p)
        # contact model 4 (lateral.md section 4): lumped_ref.LumpedMesh; its own checks (no shape
        # deviations, no slider) raise ValueError there.  The other models never see it.
        self.lumped = None
        if self.p["contact_model"] == 4:
            from . import lumped_ref as LR
            self.lumped = LR.LumpedMesh(self)
            self.dev_mesh = None
            return
        if self.p["slider_stiffness"] != 0.0:
            raise NotImplementedError("the slider S (slider_stiffness != 0) is not modelled by this "
                                      "reference")
        if self.g.internal:
            if self.p["contact_model"] == 3:
                raise ValueError("contact_model = 3 (tooth structure) is not available yet for an "
                                 "internal pair (planetary.md section 1: the ring tooth's structure "
                                 "is not specified)")
            if self.p["contact_model"] == 2 or self.deviations:
                raise NotImplementedError("internal pair: rigid contact and shape deviations are "
                                          "not implemented in this reference (contact model 1 only)")
        if self.p["contact_model"] == 3 and self.g.center_distance_error != 0.0:
            raise NotImplementedError("center_distance_error with contact_model = 3 is not "
                                      "implemented in this reference")
        if self.deviations and self.p["contact_model"] == 2:
            raise ValueError("shape deviations are not implemented for rigid contact in this reference")
        # contact model 3 or shape deviations: the per-pair mesh of deviations_ref (DevMesh);
        # contact model 1 without deviations keeps the code below, unchanged
        self.dev_mesh = (D.DevMesh(self) if self.p["contact_model"] == 3 or self.deviations
                         else None)

    # ---------------------------------------------------------------- mesh forces
    def _mesh(self, uA, e, wA, v, kf, kb, detail=False):
        """Mesh torques (interface sign) for a fixed set of carrying pairs.

        Returns (tau_mesh_A, tau_mesh_B, P_loss) or, with detail, also per-pair forces.
        The Johnson force is extended oddly through delta = 0 and the damping factor is not
        clamped: inside one integration segment the carrying set is fixed and this function
        is smooth; the segment ends (event) before either extension is used for real.
        """
        g, p = self.g, self.p
        rAb, rBb, L, E_star, kap = g.rAb, g.rBb, g.L, g.E_star, g.kappa
        width, chi, mu, v_reg = p["width"], p["chi"], p["mu"], p["v_reg"]
        wB = (rAb * wA - v) / rBb
        mA = mB = ploss = 0.0
        forces = []
        for flank, ks in ((1, kf), (-1, kb)):
            if not ks:
                continue
            if flank == 1:
                d, dd = e, v
            else:
                d, dd = -g.backlash - e, -v
            # radius sum L + d (external) or L - d (internal): kap = +-1 (exact: x*1.0 = x, so
            # the external numbers are those of the code before the internal pair existed)
            if d >= 0.0:
                N = johnson_N(d, L + kap * d, E_star)
            else:
                N = -johnson_N(-d, L - kap * d, E_star)
            Fn = width * N * (1.0 + chi * dd)
            pdamp = width * N * chi * dd * dd
            for k in ks:
                if flank == 1:
                    sA = g.s_a + uA - k * g.p_b
                else:
                    sA = g.sigma_b1 - uA + k * g.p_b
                # external: s_B = L + delta - s_A; internal: s_B = s_A + L - delta
                sB = L + kap * d - kap * sA
                if mu != 0.0:
                    # paper frame: omega_A = -w_A, omega_B = w_B (external) or -w_B (internal,
                    # with v_s = omega_A s_A - omega_B s_B): the same expression in w
                    vs = -wA * sA + wB * sB
                    Ft = mu * math.tanh(vs / v_reg) * Fn
                else:
                    vs = Ft = 0.0
                if flank == 1:
                    mA += -Fn * rAb + Ft * sA
                    mB += Fn * rBb - Ft * sB
                else:
                    mA += Fn * rAb + Ft * sA
                    mB += -Fn * rBb - Ft * sB
                ploss += Ft * vs + pdamp
                if detail:
                    forces.append((flank, k, Fn))
        if detail:
            return mA, mB, ploss, forces
        return mA, mB, ploss

    def _accel(self, y, kf, kb, tauA, tauB):
        g, p = self.g, self.p
        uA = g.rAb * y[0]
        wB = (g.rAb * y[2] - y[3]) / g.rBb
        mA, mB, _ = self._mesh(uA, y[1], y[2], y[3], kf, kb)
        aA = (tauA + mA) / p["J_A"]
        aB = (tauB - p["c_load"] * wB + mB) / p["J_B"]
        return aA, aB

    # ---------------------------------------------------------------- classification
    TOL_DELTA = 1e-16   # m: |delta| below this at a restart is a tie (broken by derivatives)
    TOL_POS = 1e-12     # m: same for gate positions along the line of action
    TOL_REL = 1e-12     # release function 1 + chi*ddelta

    T_TIE = 1e-12       # s: a function this close (in time) to its zero is a tie

    @classmethod
    def _side(cls, c, c1, c2, tol):
        """Is c >= 0 just after now, given c, dc/dt, d2c/dt2?

        |c| within tol, or within what c moves in T_TIE (far below the event root finder's
        time resolution would matter: its bracket is ~1e-15 s), counts as a tie at zero and
        is decided by the derivatives."""
        band = tol + abs(c1) * cls.T_TIE + 0.5 * abs(c2) * cls.T_TIE ** 2
        if c > band:
            return True
        if c < -band:
            return False
        if c1 != 0.0:
            return c1 > 0.0
        if c2 != 0.0:
            return c2 > 0.0
        return True  # exact standstill on a boundary: the spec's '>=' counts it as inside

    def _pair_candidates(self, flank, uA):
        g = self.g
        if flank == 1:   # s_A = s_a + uA - k p_b in [s_b - m_c p_b, s_b]
            lo = (uA + g.s_a - g.s_b) / g.p_b
            hi = (uA + g.s_a - g.s_b + g.m_c * g.p_b) / g.p_b
        else:            # s_A = sigma_b1 - uA + k p_b in [s_b - m_c p_b, s_b]
            lo = (g.s_b - g.m_c * g.p_b - g.sigma_b1 + uA) / g.p_b
            hi = (g.s_b - g.sigma_b1 + uA) / g.p_b
        return range(math.floor(lo) - 1, math.ceil(hi) + 2)

    def _decide(self, y, acc, tie_aware=True):
        g, p = self.g, self.p
        rAb, rBb, p_b = g.rAb, g.rBb, g.p_b
        thA, e, wA, v = y[0], y[1], y[2], y[3]
        uA = rAb * thA
        uB = uA - e
        wB = (rAb * wA - v) / rBb
        aA, aB = acc
        e2 = rAb * aA - rBb * aB
        chi = p["chi"]
        window_active = g.eps > g.m_c + 1e-12

        def side(c, c1, c2, tol):
            if tie_aware:
                return self._side(c, c1, c2, tol)
            return c >= -tol     # ties count as inside (closed gate, delta >= 0)

        on_f = side(e, v, e2, self.TOL_DELTA)
        on_b = p["backward_contacts"] and side(-g.backlash - e, -v, -e2, self.TOL_DELTA)
        sig = {"df": 1.0 if on_f else -1.0}
        if p["backward_contacts"]:
            sig["db"] = 1.0 if on_b else -1.0
        kf, kb = [], []
        if on_f:
            rel = True
            if chi > 0.0:
                rel = side(1.0 + chi * v, chi * e2, 0.0, self.TOL_REL)
                sig["rf"] = 1.0 if rel else -1.0
            for k in self._pair_candidates(1, uA):
                sA = g.s_a + uA - k * p_b
                ok = (side(g.s_b - sA, -rAb * wA, -rAb * aA, self.TOL_POS)
                      and side(uB - k * p_b, rBb * wB, rBb * aB, self.TOL_POS))
                if ok and window_active:
                    ok = side(sA - (g.s_b - g.m_c * p_b), rAb * wA, rAb * aA, self.TOL_POS)
                if ok and rel:
                    kf.append(k)
            sig["uf"] = self._periodic_sign(uA - (g.s_b - g.s_a), rAb * wA, rAb * aA)
            sig["lf"] = self._periodic_sign(uB, rBb * wB, rBb * aB)
        if on_b:
            rel = True
            if chi > 0.0:
                rel = side(1.0 - chi * v, -chi * e2, 0.0, self.TOL_REL)
                sig["rb"] = 1.0 if rel else -1.0
            jb = g.backlash
            for k in self._pair_candidates(-1, uA):
                sA = g.sigma_b1 - uA + k * p_b
                ok = (side(g.s_b - sA, rAb * wA, rAb * aA, self.TOL_POS)
                      and side(g.sigma_b1 + jb - uB + k * p_b - g.s_a, -rBb * wB, -rBb * aB,
                               self.TOL_POS))
                if ok and window_active:
                    ok = side(sA - (g.s_b - g.m_c * p_b), -rAb * wA, -rAb * aA, self.TOL_POS)
                if ok and rel:
                    kb.append(k)
            sig["ub"] = self._periodic_sign(uA - (g.sigma_b1 - g.s_b), rAb * wA, rAb * aA)
            sig["lb"] = self._periodic_sign(uB - (g.sigma_b1 + jb - g.s_a), rBb * wB, rBb * aB)
        kin = (uA, uB, wA, wB, aA, aB, e, v, e2)
        return Config(on_f, on_b, tuple(kf), tuple(kb), sig, kin)

    def _periodic_sign(self, xi, xi1, xi2):
        """Sign s such that s*sin(pi*xi/p_b) >= 0 just after now."""
        p_b = self.g.p_b
        n = round(xi / p_b)
        r = xi - n * p_b
        parity = -1.0 if n % 2 else 1.0
        return parity * (1.0 if self._side(r, xi1, xi2, self.TOL_POS) else -1.0)

    def _classify(self, y, tauA, tauB):
        """Contact state just after a restart.

        Conditions that are not ties are decided by their values; ties (a function at zero
        within rounding) by the sign of its first, else second time derivative, which needs the
        accelerations, which depend on the contact state: iterate from the state in which every
        tie counts as inside (the spec's closed gate s_A - delta >= s_a).  At an exact
        equilibrium on a boundary (e.g. wheels at rest with f1's B tooth exactly at point a and
        the load balanced) both "inside" and "outside" are self-consistent; this start selects
        "inside"."""
        prelim = self._decide(y, (0.0, 0.0), tie_aware=False)
        acc = self._accel(y, prelim.kf, prelim.kb, tauA, tauB)
        cfg = self._decide(y, acc)
        for _ in range(4):
            acc = self._accel(y, cfg.kf, cfg.kb, tauA, tauB)
            new = self._decide(y, acc)
            if new.key == cfg.key and new.on_f == cfg.on_f and new.on_b == cfg.on_b:
                return new
            cfg = new
        return cfg

    # ---------------------------------------------------------------- events
    def _make_events(self, cfg):
        """Terminal event functions for one segment (all detect + -> - crossings).

        Contact-state functions (delta of each flank, the periodic gate functions, damped
        release) are multiplied by the sign that makes them positive just after the restart.
        Monotonicity guards make every contact-state function monotone between restarts, so
        a sign change can never hide inside one step (a dip below zero and back):
          * extrema of each flank's delta that could carry it across zero (zeros of v),
          * reversals of either wheel (zeros of w_A, w_B) while a flank is closed,
          * a maximum step short enough that no gate coordinate moves p_b/8 in one step
            (set in simulate()).
        A function that is within a hair of zero at the restart (a tie broken by its time
        derivatives) is shifted by that hair to the side it moves to, so that it neither
        re-fires at its own restart nor lets the root finder return the restart instant.
        """
        g, p = self.g, self.p
        rAb, rBb, p_b = g.rAb, g.rBb, g.p_b
        k_pi = math.pi / p_b
        chi = p["chi"]
        uA, uB, wA, wB, aA, aB, e, v, e2 = cfg.kin
        evs = []

        def add(fn, c, c1, c2, tol, band):
            after = self._side(c, c1, c2, tol)
            off = 0.0
            if after and c < band:
                off = band - c
            elif not after and c > -band:
                off = -(band + c)
            if off != 0.0:
                raw = fn
                fn = lambda t, y: raw(t, y) + off
            fn.terminal = True
            fn.direction = -1.0
            fn.band = band
            evs.append(fn)

        def add_periodic(sig, c0, coef, xi, xi1, xi2):
            # sig * sin(pi*(coef.y - c0)/p_b), xi = its argument's current value
            s_, c_ = math.sin(k_pi * xi), math.cos(k_pi * xi)
            w1 = k_pi * xi1
            val, d1, d2 = sig * s_, sig * c_ * w1, sig * (c_ * k_pi * xi2 - s_ * w1 * w1)
            cA, cE = coef
            add(lambda t, y: sig * math.sin(k_pi * (cA * y[0] + cE * y[1] - c0)),
                val, d1, d2, k_pi * self.TOL_POS, 1e-12)

        s = cfg.sig
        sdf = s["df"]
        add(lambda t, y: sdf * y[1], sdf * e, sdf * v, sdf * e2, self.TOL_DELTA, 1e-20)
        bwd = p["backward_contacts"]
        if bwd:
            sdb, jb = s["db"], g.backlash
            add(lambda t, y: sdb * (-jb - y[1]), sdb * (-jb - e), -sdb * v, -sdb * e2,
                self.TOL_DELTA, 1e-20)
        if cfg.on_f:
            cu = g.s_b - g.s_a
            add_periodic(s["uf"], cu, (rAb, 0.0), uA - cu, rAb * wA, rAb * aA)
            add_periodic(s["lf"], 0.0, (rAb, -1.0), uB, rBb * wB, rBb * aB)
            if chi > 0.0:
                srf = s["rf"]
                add(lambda t, y: srf * (1.0 + chi * y[3]), srf * (1.0 + chi * v), srf * chi * e2,
                    0.0, self.TOL_REL, 1e-14)
        if cfg.on_b:
            cu_b = g.sigma_b1 - g.s_b
            cl_b = g.sigma_b1 + g.backlash - g.s_a
            add_periodic(s["ub"], cu_b, (rAb, 0.0), uA - cu_b, rAb * wA, rAb * aA)
            add_periodic(s["lb"], cl_b, (rAb, -1.0), uB - cl_b, rBb * wB, rBb * aB)
            if chi > 0.0:
                srb = s["rb"]
                add(lambda t, y: srb * (1.0 - chi * y[3]), srb * (1.0 - chi * v), -srb * chi * e2,
                    0.0, self.TOL_REL, 1e-14)
        # guards (non-terminal): zeros of v = d(dte)/dt (extrema of both flanks' delta) and of
        # the wheel speeds (reversals of the gate coordinates); see _check_guards.
        guards = []
        for fn in (lambda t, y: y[3],
                   lambda t, y: y[2],
                   lambda t, y: (rAb * y[2] - y[3]) / rBb):
            fn.terminal = False
            fn.direction = 0.0
            guards.append(fn)
        return evs, guards

    def _check_guards(self, sol, t0, evs, n_guard):
        """Find a contact-state change hidden inside one step.

        Between consecutive zeros of v, delta of each flank is monotone, and between zeros of
        w_A (w_B) every gate coordinate on A (B) is monotone and moves < p_b/8 per step; so a
        sign change of a contact-state function that solve_ivp could not see (a dip below zero
        and back within one step) must straddle a guard root.  At each guard root (in time
        order) every terminal function is evaluated; if one is negative there, its first root
        inside the step that contains the guard root is located and returned (the segment is
        then cut there, exactly as at a located event).  Returns None if nothing was hidden.
        """
        t_end = sol.t[-1]
        roots = []
        for tev in sol.t_events[len(evs):len(evs) + n_guard]:
            roots.extend(float(x) for x in tev if t0 < x < t_end)
        if not roots:
            return None
        from scipy.optimize import brentq
        steps = np.asarray(sol.t)
        for te in sorted(roots):
            ye = sol.sol(te)
            bad = [fn for fn in evs if fn(te, ye) < -fn.band]
            if not bad:
                continue
            i = int(np.searchsorted(steps, te, side="left")) - 1
            t_lo = float(steps[max(i, 0)])
            best = te
            for fn in bad:
                if fn(t_lo, sol.sol(t_lo)) > 0.0:
                    tc = brentq(lambda tt: fn(tt, sol.sol(tt)), t_lo, te, xtol=1e-16, rtol=BRENT_RTOL)
                    best = min(best, tc)
            return best
        return None

    # ---------------------------------------------------------------- outputs
    def outputs(self, t, y, cfg, bearing=False):
        if bearing:
            pairs = self.pair_forces(y, cfg)
            return self.outputs(t, y, cfg) + list(mesh_force_on_B(self.g, pairs))
        g = self.g
        thA, e, wA, v = y[0], y[1], y[2], y[3]
        uA = g.rAb * thA
        mA, mB, ploss, forces = self._mesh(uA, e, wA, v, cfg.kf, cfg.kb, detail=True)
        F = {"f1": 0.0, "f2": 0.0, "b1": 0.0, "b2": 0.0}
        for flank, k, Fn in forces:
            name = ("f" if flank == 1 else "b") + ("1" if k % g.m_c == 0 else "2")
            # reported >= 0: at an event instant the root finder may leave delta at -1e-21
            # (force -1e-13 N) on the side that is about to stop carrying
            F[name] += max(Fn, 0.0)
        thB = (uA - e) / g.rBb
        wB = (g.rAb * wA - v) / g.rBb
        return [t, thA, thB, wA, wB, e,
                F["f1"], F["f2"], F["b1"], F["b2"], F["f1"] + F["f2"], F["b1"] + F["b2"],
                len(cfg.kf), len(cfg.kb), mA, mB, ploss]

    def initial_state(self):
        p, g = self.p, self.g
        return np.array([p["dte_start"] / g.rAb, p["dte_start"], p["w_A_start"],
                         g.rAb * p["w_A_start"] - g.rBb * p["w_B_start"]], dtype=float)

    def delta_scale(self, inputs: InputTable):
        """Characteristic penetration [m]: single-pair Johnson penetration under the largest
        input torque (at least 1 N of line force)."""
        g, p = self.g, self.p
        ta, tb = inputs.max_abs()
        F = max(ta / g.rAb, tb / g.rBb, 1.0)
        return johnson_delta(F / p["width"], g.L, g.E_star)

    # ---------------------------------------------------------------- main loop
    def pair_forces(self, y, cfg):
        """Per carrying pair: (flank, k, s_A, s_B, F_n, F_t, v_s) as in _mesh (F_n clamped >= 0
        as in the reported forces).  Only for the bearing-force outputs; the dynamics use _mesh."""
        g, p = self.g, self.p
        rAb, rBb, L = g.rAb, g.rBb, g.L
        thA, e, wA, v = y[0], y[1], y[2], y[3]
        uA = rAb * thA
        wB = (rAb * wA - v) / rBb
        mA, mB, ploss, forces = self._mesh(uA, e, wA, v, cfg.kf, cfg.kb, detail=True)
        out = []
        for flank, k, Fn in forces:
            if flank == 1:
                d = e
                sA = g.s_a + uA - k * g.p_b
            else:
                d = -g.backlash - e
                sA = g.sigma_b1 - uA + k * g.p_b
            sB = L + g.kappa * d - g.kappa * sA
            vs = -wA * sA + wB * sB
            Fn = max(Fn, 0.0)
            Ft = p["mu"] * math.tanh(vs / p["v_reg"]) * Fn if p["mu"] != 0.0 else 0.0
            out.append((flank, k, sA, sB, Fn, Ft, vs))
        return out

    def simulate(self, stop_time, output_interval, inputs: InputTable | None = None,
                 rtol=1e-10, method="DOP853", energy=False, max_restarts=2_000_000,
                 perturb_w_A=0.0, y0=None, bearing_force=None, per_pair=False,
                 output_step_cap=True):
        """Integrate over [0, stop_time]; sample on k*output_interval and at every event.

        output_step_cap: solve_ivp's steps stay within the output interval (the default, for
        the reference traces); False leaves only the cap of 1/8 base pitch (for comparing
        methods, docs/integrators.md; the contact-model-1 path only).

        bearing_force: append the outputs F_B_x, F_B_y (default: only with contact_model = 2).
        contact_model = 3 or shape deviations run deviations_ref.DevMesh (outputs also k_mesh and
        load_share); per_pair = True forces it for contact model 1 without deviations (tests)."""
        if bearing_force is None:
            bearing_force = self.p["contact_model"] == 2
        if self.lumped is not None:
            if per_pair:
                raise ValueError("per_pair: the lumped mesh (contact_model = 4) tracks no pairs' forces")
            return self.lumped.simulate(stop_time, output_interval, inputs, rtol=rtol, method=method,
                                        energy=energy, max_restarts=max_restarts,
                                        perturb_w_A=perturb_w_A, y0=y0,
                                        bearing_force=bearing_force,
                                        output_step_cap=output_step_cap)
        if bearing_force and self.g.internal:
            raise NotImplementedError("bearing force outputs of an internal pair are not "
                                      "implemented in this reference")
        if per_pair and self.g.internal:
            raise NotImplementedError("per_pair: DevMesh has no internal pair in this reference")
        if self.dev_mesh is not None or per_pair:
            from . import deviations_ref as D
            dm = self.dev_mesh if self.dev_mesh is not None else D.DevMesh(self)
            return dm.simulate(stop_time, output_interval, inputs, rtol=rtol, method=method,
                               energy=energy, max_restarts=max_restarts, perturb_w_A=perturb_w_A,
                               y0=y0, bearing_force=bearing_force)
        if self.p["contact_model"] == 2:
            if energy:
                raise NotImplementedError("energy bookkeeping is for contact_model = 1 only")
            return RigidMesh(self).simulate(stop_time, output_interval, inputs, rtol=rtol,
                                            method=method, max_restarts=max_restarts,
                                            perturb_w_A=perturb_w_A, y0=y0,
                                            bearing_force=bearing_force)
        p, g = self.p, self.g
        if inputs is None:
            inputs = InputTable.constant(p["tau_A"], p["tau_B"])
        J_A, J_B, c_load = p["J_A"], p["J_B"], p["c_load"]
        rAb, rBb = g.rAb, g.rBb
        y = self.initial_state() if y0 is None else np.array(y0, float)
        y[2] += perturb_w_A
        y[3] += rAb * perturb_w_A
        if energy:
            y = np.concatenate([y, [0.0, 0.0]])
        n_state = len(y)

        dscale = self.delta_scale(inputs)
        wscale = max(1.0, abs(p["w_A_start"]), abs(p["w_B_start"]))
        atol = np.array([1.0, dscale, wscale, dscale * 1e4] + ([1.0, 1.0] if energy else [])) * rtol

        n_grid = int(round(stop_time / output_interval))
        grid = np.arange(n_grid + 1) * output_interval
        grid[-1] = stop_time

        mesh = self._mesh

        def make_rhs(cfg, seg):
            t0, a0, da, b0, db = seg
            kf, kb = cfg.kf, cfg.kb

            def rhs(t, y):
                wA, v = y[2], y[3]
                wB = (rAb * wA - v) / rBb
                tauA = a0 + da * (t - t0)
                tauB = b0 + db * (t - t0)
                if kf or kb:
                    mA, mB, pl = mesh(rAb * y[0], y[1], wA, v, kf, kb)
                else:
                    mA = mB = pl = 0.0
                aA = (tauA + mA) / J_A
                aB = (tauB - c_load * wB + mB) / J_B
                if energy:
                    return [wA, v, aA, rAb * aA - rBb * aB,
                            tauA * wA + tauB * wB - c_load * wB * wB, pl]
                return [wA, v, aA, rAb * aA - rBb * aB]
            return rhs

        jac_scale = atol / rtol

        def make_jac(rhs):
            """Central differences with fixed, scale-aware steps (scipy's adaptive num_jac
            diverges on the columns that do not enter the right-hand side, e.g. theta_A
            without friction).  Only Newton convergence depends on it, not the result."""
            def jac(t, y):
                J = np.empty((n_state, n_state))
                for i in range(n_state):
                    h = 1e-7 * max(abs(y[i]), jac_scale[i])
                    yp = np.array(y, dtype=float)
                    ym = yp.copy()
                    yp[i] += h
                    ym[i] -= h
                    J[:, i] = (np.asarray(rhs(t, yp)) - np.asarray(rhs(t, ym))) / (2 * h)
                return J
            return jac

        t = 0.0
        seg = inputs.segment(t)
        tau_now = lambda tt, sg: (sg[1] + sg[2] * (tt - sg[0]), sg[3] + sg[4] * (tt - sg[0]))
        cfg = self._classify(y, *tau_now(t, seg))
        seg_max = 20.0 * output_interval   # reclassify at least this often (missed-event guard)
        n_missed = 0
        n_hidden = 0
        segments = []    # (t0, t1, OdeSolution, cfg)
        events = []      # (t, y, cfg_before, cfg_after)
        energy_jumps = []
        n_restart = 0
        while t < stop_time:
            seg = inputs.segment(t)
            t_hi = min(inputs.next_break(t), stop_time, t + seg_max)
            if stop_time - t_hi < 1e-3 * output_interval:
                t_hi = min(inputs.next_break(t), stop_time)
            uA_, uB_, wA_, wB_, aA_, aB_ = cfg.kin[:6]
            line_speed = (max(abs(rAb * wA_), abs(rBb * wB_))
                          + max(abs(rAb * aA_), abs(rBb * aB_)) * (t_hi - t))
            max_step = min(output_interval if output_step_cap else np.inf,
                           g.p_b / (8.0 * line_speed + 1e-300))
            rhs = make_rhs(cfg, seg)
            extra = {}
            if method in ("Radau", "BDF", "LSODA"):
                extra["jac"] = make_jac(rhs)
            evs, guards = self._make_events(cfg)
            sol = solve_ivp(rhs, (t, t_hi), y, method=method, rtol=rtol,
                            atol=atol, events=evs + guards, dense_output=True,
                            max_step=max_step, **extra)
            if sol.status < 0:
                raise RuntimeError(f"solve_ivp failed at t = {t}: {sol.message}")
            t_new = float(sol.t[-1])
            y_new = sol.y[:, -1].copy()
            located = sol.status == 1
            t_cut = self._check_guards(sol, t, evs, len(guards))
            if t_cut is not None:
                t_new = t_cut
                y_new = np.asarray(sol.sol(t_cut), dtype=float).copy()
                located = True
                n_hidden += 1
            segments.append((t, t_new, sol.sol, cfg))
            n_restart += 1
            if n_restart > max_restarts:
                raise RuntimeError(f"more than {max_restarts} restarts (chattering?) at t = {t_new}")
            seg_new = inputs.segment(t_new) if t_new < stop_time else seg
            new = self._classify(y_new, *tau_now(t_new, seg_new))
            if new.key != cfg.key:
                if not located:
                    n_missed += 1   # state changed without a located event (double crossing
                    #                 inside one step): kept, and counted in the result
                events.append((t_new, y_new, cfg, new))
                if energy:
                    energy_jumps.append((t_new, y_new, cfg, new))
            t, y, cfg = t_new, y_new, new

        # ---- sample
        rows = []
        seg_t0 = [s[0] for s in segments]
        for tg in grid:
            i = bisect.bisect_right(seg_t0, tg) - 1
            i = min(max(i, 0), len(segments) - 1)
            t0, t1, solf, c = segments[i]
            yy = solf(tg) if t1 > t0 else solf(t0)
            rows.append(self.outputs(tg, yy, c, bearing_force))
        merged = []
        for ev in events:   # merge coincident events into one before/after pair
            if merged and ev[0] == merged[-1][0]:
                merged[-1] = (ev[0], ev[1], merged[-1][2], ev[3])
            else:
                merged.append(ev)
        ev_list = []
        for te, ye, cb, ca in merged:
            if cb.key == ca.key:
                continue
            rows.append(self.outputs(te, ye, cb, bearing_force))
            rows.append(self.outputs(te, ye, ca, bearing_force))
            ev_list.append((te, len(cb.kf), len(cb.kb), len(ca.kf), len(ca.kb)))
        # stable sort by time: grid rows first in insertion order, event rows keep before/after
        order = sorted(range(len(rows)), key=lambda i: (rows[i][0], 0 if i < len(grid) else 1, i))
        # a grid row coinciding exactly with an event time is dropped (the event rows cover it)
        ev_times = {e[0] for e in ev_list}
        table = np.array([rows[i] for i in order if not (i < len(grid) and rows[i][0] in ev_times)])
        res = Result(list(OUTPUT_NAMES) + (BEARING_OUTPUT_NAMES if bearing_force else []),
                     table, ev_list, n_restart, n_missed=n_missed,
                     n_hidden=n_hidden)
        if energy:
            res.energy = {"segments": segments, "jumps": energy_jumps}
        return res

    # ---------------------------------------------------------------- energy helpers
    def elastic_energy_pair(self, delta):
        """width * integral_0^delta N(s; rho = L + s) ds  [J] (rho = L - s: internal)."""
        from scipy.integrate import quad
        if delta <= 0.0:
            return 0.0
        g = self.g
        val, _ = quad(lambda s: johnson_N(s, g.L + g.kappa * s, g.E_star), 0.0, delta,
                      epsabs=0.0, epsrel=1e-13, limit=200)
        return self.p["width"] * val

    def elastic_energy(self, y, cfg):
        g = self.g
        U = 0.0
        if cfg.kf:
            U += len(cfg.kf) * self.elastic_energy_pair(y[1])
        if cfg.kb:
            U += len(cfg.kb) * self.elastic_energy_pair(-g.backlash - y[1])
        return U

    def kinetic_energy(self, y):
        g, p = self.g, self.p
        wB = (g.rAb * y[2] - y[3]) / g.rBb
        return 0.5 * p["J_A"] * y[2] ** 2 + 0.5 * p["J_B"] * wB ** 2


# --------------------------------------------------------------------------------------------
# Mesh force on B (rig-and-modes.md section 1), shared by both contact models
# --------------------------------------------------------------------------------------------

def line_vectors(g):
    """Paper-frame unit vectors: u (forward line of action), u_b (backward), the friction
    directions t_f = (cos a, sin a) and t_b = (-cos a, sin a)."""
    a = g.alpha_w
    ca, sa = math.cos(a), math.sin(a)
    return (sa, -ca), (sa, ca), (ca, sa), (-ca, sa)


def mesh_force_on_B(g, pairs):
    """F_B = sum_fwd [F_n u + F_t (cos a, sin a)] + sum_bwd [F_n u_b + F_t (-cos a, sin a)].
    pairs: (flank, k, s_A, s_B, F_n, F_t, v_s) per carrying pair."""
    u, ub, tf, tb = line_vectors(g)
    fx = fy = 0.0
    for flank, _k, _sA, _sB, Fn, Ft, _vs in pairs:
        n, tt = (u, tf) if flank == 1 else (ub, tb)
        fx += Fn * n[0] + Ft * tt[0]
        fy += Fn * n[1] + Ft * tt[1]
    return fx, fy


def contact_point_on_B(g, flank, sB):
    """Paper-frame contact point K_B - s_B u (forward) or K_B' - s_B u_b (backward)."""
    a = g.alpha_w
    ca, sa = math.cos(a), math.sin(a)
    if flank == 1:
        return g.d - g.rBb * ca - sB * sa, -g.rBb * sa + sB * ca
    return g.d - g.rBb * ca - sB * sa, g.rBb * sa - sB * ca


# --------------------------------------------------------------------------------------------
# Rigid contact (contact_model = 2, rig-and-modes.md section 2), no slider, fixed housing
# --------------------------------------------------------------------------------------------

FREE, FWD, BWD = 0, 1, -1
DBL_EPS = 2.220446049250313e-16


@dataclass
class RigidState:
    """Mode between two restarts.  mode FREE, FWD (delta_f = 0 held) or BWD (delta_b = 0 held);
    ks: the gated pairs of the locked flank (enumerated as in GearMesh: forward pair k has
    s_A = s_a + u_A - k p_b, backward pair k has s_A = sigma_b1 - u_A + k p_b); lo, hi: the gate
    boundaries (in u_A = rAb theta_A) just below and above, whose crossing is an event."""
    mode: int
    ks: tuple = ()
    lo: float = -math.inf
    hi: float = math.inf

    @property
    def key(self):
        return (self.mode, self.ks)

    @property
    def n_fwd(self):
        return len(self.ks) if self.mode == FWD else 0

    @property
    def n_bwd(self):
        return len(self.ks) if self.mode == BWD else 0


class RigidMesh:
    """Rigid (unilateral-constraint) contact with Newton impacts, built on the same enumerated
    pairs and state [theta_A, e, w_A, v] (e = dte, v = de/dt) as GearMesh.

    Free: no mesh force; events: delta_f = e or delta_b = -backlash - e reaching 0 from below
      (functions BAND - delta, terminal, + -> -; BAND = 1e-18 m keeps a flank the wheels have
      just left, with v = 0 and an acceleration of rounding size, from re-firing at once).
      Guards at the zeros of v catch a crossing hidden inside one step.
    Locked (FWD or BWD): e is held exactly (0 or -backlash) and v = 0 exactly (the right-hand
      side returns 0 for both); the total constraint force N along the line of action solves
      d^2 delta/dt^2 = 0 with each gated pair carrying F_n = N/n and F_t = mu tanh(v_s/v_reg) F_n
      (own s_A, s_B = L - s_A).  Events: N decreasing through 0 (release), u_A crossing a gate
      boundary (lo/hi; gated pairs re-derived, N re-checked), input breakpoints (N re-checked).
    Impact (flank reached with approach speed v_- > 0): P = (1+e) m_eff v_-, the relative
      speed becomes -e v_- (set exactly), then the lock rule of the brief; when it locks, the
      impulse is the plastic one m_eff v_- (the rebound is taken back along the line of action)
      and v = 0 exactly.
    backlash = 0: the constraint is two-sided (N of either sign, forward flank pairs when N >= 0,
      backward ones when N < 0): an impact is plastic (the rebound would hit the other flank at
      once) and the contact always locks; N reaching 0 moves the load to the other flank.
    """

    BAND = 1e-18        # m: a free flank fires when delta exceeds this
    TOL_GATE = 1e-12    # m: a gate boundary this close to u_A at a restart is a tie (direction)
    LOCK_TIME = 1e-6    # s: rebound flights shorter than this lock (no Zeno chatter)

    def __init__(self, model):
        self.m = model
        self.p, self.g = model.p, model.g
        g, p = self.g, self.p
        self.inv_meff = g.rAb ** 2 / p["J_A"] + g.rBb ** 2 / p["J_B"]
        self.m_eff = 1.0 / self.inv_meff
        self.two_sided = g.backlash == 0.0
        self.window = g.eps > g.m_c + 1e-12
        # gate boundaries in u_A, as residues mod p_b: forward s_A = s_a (u_A = k p_b) and
        # s_A = s_b (u_A = k p_b + s_b - s_a; the tracking window's s_b - m_c p_b has the same
        # residue); backward s_A = s_a (u_A = sigma_b1 - s_a + k p_b), s_A = s_b (sigma_b1 - s_b)
        self.res = {FWD: (0.0, g.s_b - g.s_a), BWD: (g.sigma_b1 - g.s_a, g.sigma_b1 - g.s_b)}

    # ------------------------------------------------------------ geometry of the locked flank
    def _sA(self, flank, uA, k):
        g = self.g
        return g.s_a + uA - k * g.p_b if flank == FWD else g.sigma_b1 - uA + k * g.p_b

    def _gated(self, flank, uA, wA, aA, ties_inside=False):
        """Pairs with s_a <= s_A <= s_b (and inside the tracking window) just after now, at
        delta = 0; a boundary within TOL_GATE is decided by the direction of motion of s_A
        (then its acceleration; at rest: inside)."""
        g = self.g
        rate, acc = (g.rAb * wA, g.rAb * aA) if flank == FWD else (-g.rAb * wA, -g.rAb * aA)
        tol = self.TOL_GATE

        def above(c, c1, c2):   # c >= 0 just after now, c' = c1, c'' = c2
            if c > tol:
                return True
            if c < -tol:
                return False
            if ties_inside:
                return True
            if c1 != 0.0:
                return c1 > 0.0
            if c2 != 0.0:
                return c2 > 0.0
            return True

        if flank == FWD:     # s_A in [s_a - p_b, s_b + p_b]
            k0 = math.floor((uA + g.s_a - g.s_b) / g.p_b) - 1
            k1 = math.ceil(uA / g.p_b) + 1
        else:
            k0 = math.floor((g.s_a - g.sigma_b1 + uA) / g.p_b) - 1
            k1 = math.ceil((g.s_b - g.sigma_b1 + uA) / g.p_b) + 1
        ks = []
        for k in range(k0, k1 + 1):
            sA = self._sA(flank, uA, k)
            ok = above(sA - g.s_a, rate, acc) and above(g.s_b - sA, -rate, -acc)
            if ok and self.window:
                ok = above(sA - (g.s_b - g.m_c * g.p_b), rate, acc)
            if ok:
                ks.append(k)
        return tuple(ks)

    def _bounds(self, flank, uA, wA, aA):
        """Nearest gate boundaries below and above u_A.  One within TOL_GATE (the one just
        crossed) is moved TOL_GATE behind the motion: a reversal right there is caught
        TOL_GATE late."""
        p_b = self.g.p_b
        tol = self.TOL_GATE
        s = wA if wA != 0.0 else aA
        lo, hi = -math.inf, math.inf
        for r in self.res[flank]:
            n = math.floor((uA - r) / p_b)
            for b in (r + (n - 1) * p_b, r + n * p_b, r + (n + 1) * p_b, r + (n + 2) * p_b):
                if abs(b - uA) <= tol:
                    if s >= 0.0:
                        lo = max(lo, b - tol)
                    if s <= 0.0:
                        hi = min(hi, b + tol)
                elif b < uA:
                    lo = max(lo, b)
                else:
                    hi = min(hi, b)
        return lo, hi

    # ------------------------------------------------------------ constraint force
    def _coeffs(self, flank, ks, uA, wA):
        """Per-unit-N torques on A and B (interface frame) and per-pair (k, s_A, s_B, f, v_s)
        with f = mu tanh(v_s/v_reg), for the locked flank (delta = 0, w_B = w_A rAb/rBb)."""
        g, p = self.g, self.p
        rAb, rBb, L = g.rAb, g.rBb, g.L
        mu, v_reg = p["mu"], p["v_reg"]
        wB = rAb * wA / rBb
        n = len(ks)
        cA = cB = 0.0
        per = []
        for k in ks:
            sA = self._sA(flank, uA, k)
            sB = L - sA
            vs = -wA * sA + wB * sB             # paper frame: omega_A = -w_A, omega_B = w_B
            f = mu * math.tanh(vs / v_reg) if mu != 0.0 else 0.0
            if flank == FWD:
                cA += -rAb + f * sA
                cB += rBb - f * sB
            else:
                cA += rAb + f * sA
                cB += -rBb - f * sB
            per.append((k, sA, sB, f, vs))
        return cA / n, cB / n, per

    def _constraint(self, flank, ks, uA, wA, tauA, tauB):
        """(N, aA, cA, cB, per): N >= 0 pushes the locked flank's teeth together."""
        g, p = self.g, self.p
        J_A, J_B = p["J_A"], p["J_B"]
        rAb, rBb = g.rAb, g.rBb
        wB = rAb * wA / rBb
        cA, cB, per = self._coeffs(flank, ks, uA, wA)
        # d^2 e/dt^2 = rAb aA - rBb aB = 0, aA = (tauA + N cA)/J_A, aB = (tauB - c wB + N cB)/J_B
        den = rAb * cA / J_A - rBb * cB / J_B
        if flank * den >= 0.0:
            raise RuntimeError(f"rigid contact jams: the constraint's mass coefficient {den!r} "
                               f"has the wrong sign (friction too large for this geometry)")
        N = (rBb * (tauB - p["c_load"] * wB) / J_B - rAb * tauA / J_A) / den
        aA = (tauA + N * cA) / J_A
        return N, aA, cA, cB, per

    def _free_acc(self, y, tauA, tauB):
        """aA, aB, d^2 e/dt^2 of the free motion."""
        g, p = self.g, self.p
        wB = (g.rAb * y[2] - y[3]) / g.rBb
        aA = tauA / p["J_A"]
        aB = (tauB - p["c_load"] * wB) / p["J_B"]
        return aA, aB, g.rAb * aA - g.rBb * aB

    def _try_lock(self, flank, y, tauA, tauB):
        """RigidState for the flank locked at state y (v = 0, e on the flank), or None if no pair
        is gated there or N < 0."""
        uA, wA = self.g.rAb * y[0], y[2]
        ks = self._gated(flank, uA, wA, 0.0, ties_inside=True)
        if not ks:
            return None
        _N, aA, *_ = self._constraint(flank, ks, uA, wA, tauA, tauB)
        ks = self._gated(flank, uA, wA, aA)
        if not ks:
            return None
        N, aA, *_ = self._constraint(flank, ks, uA, wA, tauA, tauB)
        if N < 0.0:
            return None
        lo, hi = self._bounds(flank, uA, wA, aA)
        return RigidState(flank, ks, lo, hi)

    def _lock(self, flank, y, tauA, tauB, prefer=None):
        """Lock on flank (one-sided), or with backlash = 0 on whichever flank carries N >= 0
        (prefer first).  Returns a RigidState or None."""
        if not self.two_sided:
            return self._try_lock(flank, y, tauA, tauB)
        order = (prefer, -prefer) if prefer else (FWD, BWD)
        for fl in order:
            st = self._try_lock(fl, y, tauA, tauB)
            if st is not None:
                return st
        raise RuntimeError("backlash = 0: neither flank can carry the constraint force")

    def _flank_value(self, flank):
        return 0.0 if flank == FWD else -self.g.backlash

    def v_res(self, y):
        g = self.g
        wB = (g.rAb * y[2] - y[3]) / g.rBb
        return 4.0 * DBL_EPS * (g.rAb * abs(y[2]) + g.rBb * abs(wB))

    # ------------------------------------------------------------ impact
    def impact(self, flank, y, tauA, tauB):
        """Newton impact on flank at state y (the flank at delta = 0, approach speed v_- > 0).

        Returns (state, y_after, kind) with kind 'lock' or 'rebound'."""
        g, p = self.g, self.p
        rAb, J_A = g.rAb, p["J_A"]
        y = np.array(y, dtype=float)
        y[1] = self._flank_value(flank)
        vm = flank * y[3]                               # approach speed d(delta)/dt > 0
        e = 0.0 if self.two_sided else p["restitution"]
        # Newton: J_A dw_A = -flank P rAb (J_B dw_B = +flank P rBb follows from the new v)
        P = (1.0 + e) * self.m_eff * vm
        y1 = y.copy()
        y1[2] = y[2] - flank * P * rAb / J_A
        y1[3] = -e * y[3]
        _aA, _aB, e2 = self._free_acc(y1, tauA, tauB)
        a = flank * e2                                  # approach acceleration after the impact
        lock = (e == 0.0 or (a > 0.0 and 2.0 * e * vm / a < self.LOCK_TIME)
                or e * vm <= self.v_res(y1))
        if lock:
            yL = y.copy()
            PL = self.m_eff * vm                        # plastic: the rebound taken back
            yL[2] = y[2] - flank * PL * rAb / J_A
            yL[3] = 0.0
            st = self._lock(flank, yL, tauA, tauB, prefer=flank)
            if st is not None:
                return st, yL, "lock"
        return RigidState(FREE), y1, "rebound"

    # ------------------------------------------------------------ start
    def start(self, y, tauA, tauB):
        """Mode at t = 0 (rules of the brief).  Returns (state, y, impact) with impact None or
        (y_before, kind)."""
        g, p = self.g, self.p
        e0 = y[1]
        if not (-g.backlash <= e0 <= 0.0):
            raise ValueError(f"rigid contact: dte_start = {e0!r} m lies outside [-backlash, 0] = "
                             f"[{-g.backlash!r}, 0] m")
        vres = self.v_res(y)
        flanks = []
        if e0 == 0.0:
            flanks.append(FWD)
        if e0 == -g.backlash and p["backward_contacts"]:
            flanks.append(BWD)
        if not flanks:
            return RigidState(FREE), y, None
        if self.two_sided:
            if abs(y[3]) > vres:
                fl = FWD if y[3] > 0 else BWD
                st, ya, kind = self.impact(fl, y, tauA, tauB)
                return st, ya, (y, kind)
            yL = np.array(y, float)
            yL[3] = 0.0
            return self._lock(FWD, yL, tauA, tauB), yL, None
        fl = flanks[0]
        dd = fl * y[3]
        if dd > vres:
            st, ya, kind = self.impact(fl, y, tauA, tauB)
            return st, ya, (y, kind)
        if dd < -vres:
            return RigidState(FREE), y, None
        yL = np.array(y, float)
        yL[3] = 0.0                  # relative speed exactly 0; w_A kept, w_B = w_A rAb/rBb
        st = self._lock(fl, yL, tauA, tauB)
        if st is not None:
            return st, yL, None
        return RigidState(FREE), y, None

    # ------------------------------------------------------------ outputs
    def pair_forces(self, st, y, tauA, tauB):
        """(N, per-pair list (flank, k, s_A, s_B, F_n, F_t, v_s), tau_mesh_A, tau_mesh_B)."""
        if st.mode == FREE:
            return 0.0, [], 0.0, 0.0
        uA, wA = self.g.rAb * y[0], y[2]
        N, _aA, cA, cB, per = self._constraint(st.mode, st.ks, uA, wA, tauA, tauB)
        Fn = N / len(st.ks)
        pairs = [(st.mode, k, sA, sB, Fn, f * Fn, vs) for k, sA, sB, f, vs in per]
        return N, pairs, N * cA, N * cB

    def outputs(self, t, y, st, tauA, tauB, bearing):
        g = self.g
        thA, e, wA, v = y[0], y[1], y[2], y[3]
        uA = g.rAb * thA
        N, pairs, mA, mB = self.pair_forces(st, y, tauA, tauB)
        F = {"f1": 0.0, "f2": 0.0, "b1": 0.0, "b2": 0.0}
        ploss = 0.0
        for flank, k, _sA, _sB, Fn, Ft, vs in pairs:
            F[("f" if flank == FWD else "b") + ("1" if k % g.m_c == 0 else "2")] += Fn
            ploss += Ft * vs
        row = [t, thA, (uA - e) / g.rBb, wA, (g.rAb * wA - v) / g.rBb, e,
               F["f1"], F["f2"], F["b1"], F["b2"], F["f1"] + F["f2"], F["b1"] + F["b2"],
               st.n_fwd, st.n_bwd, mA, mB, ploss]
        if bearing:
            row += list(mesh_force_on_B(g, pairs))
        return row

    # ------------------------------------------------------------ integration
    def _rhs(self, st, seg):
        g, p = self.g, self.p
        rAb, rBb, J_A, J_B, c = g.rAb, g.rBb, p["J_A"], p["J_B"], p["c_load"]
        t0, a0, da, b0, db = seg
        if st.mode == FREE:
            def rhs(t, y):
                tauA = a0 + da * (t - t0)
                tauB = b0 + db * (t - t0)
                wB = (rAb * y[2] - y[3]) / rBb
                aA = tauA / J_A
                aB = (tauB - c * wB) / J_B
                return [y[2], y[3], aA, rAb * aA - rBb * aB]
            return rhs
        fl, ks = st.mode, st.ks

        def rhs(t, y):
            tauA = a0 + da * (t - t0)
            tauB = b0 + db * (t - t0)
            _N, aA, *_ = self._constraint(fl, ks, rAb * y[0], y[2], tauA, tauB)
            return [y[2], 0.0, aA, 0.0]
        return rhs

    def _events(self, st, seg):
        g, p = self.g, self.p
        rAb = g.rAb
        t0, a0, da, b0, db = seg
        evs, guards = [], []

        def term(fn, kind):
            fn.terminal, fn.direction, fn.kind = True, -1.0, kind
            evs.append(fn)

        band, jb = self.BAND, g.backlash
        if st.mode == FREE:
            term(lambda t, y: band - y[1], ("impact", FWD))
            if p["backward_contacts"]:
                term(lambda t, y: band + jb + y[1], ("impact", BWD))
            gv = lambda t, y: y[3]
            gv.terminal, gv.direction = False, 0.0
            guards.append(gv)
        else:
            fl, ks = st.mode, st.ks

            def N_of(t, y):
                tauA = a0 + da * (t - t0)
                tauB = b0 + db * (t - t0)
                return self._constraint(fl, ks, rAb * y[0], y[2], tauA, tauB)[0]
            term(N_of, ("release", fl))
            lo, hi = st.lo, st.hi
            if math.isfinite(lo):
                term(lambda t, y: rAb * y[0] - lo, ("gate", fl))
            if math.isfinite(hi):
                term(lambda t, y: hi - rAb * y[0], ("gate", fl))
        return evs, guards

    def _hidden(self, sol, t0, evs, guards):
        """A flank crossing hidden inside one step of free flight (delta rising above 0 and
        back): between zeros of v, e is monotone, so it must straddle a zero of v.  Returns the
        time and event of the first such crossing, or None."""
        if not guards:
            return None
        from scipy.optimize import brentq
        t_end = sol.t[-1]
        roots = [float(x) for x in sol.t_events[len(evs)] if t0 < x < t_end]
        steps = np.asarray(sol.t)
        for tr in sorted(roots):
            yr = sol.sol(tr)
            bad = [fn for fn in evs if fn(tr, yr) < 0.0]
            if not bad:
                continue
            i = int(np.searchsorted(steps, tr, side="left")) - 1
            t_lo = float(steps[max(i, 0)])
            best, which = tr, bad[0]
            for fn in bad:
                if fn(t_lo, sol.sol(t_lo)) > 0.0:
                    tc = brentq(lambda tt: fn(tt, sol.sol(tt)), t_lo, tr, xtol=1e-16, rtol=BRENT_RTOL)
                    if tc < best:
                        best, which = tc, fn
            return best, which
        return None

    def simulate(self, stop_time, output_interval, inputs=None, rtol=1e-10, method="DOP853",
                 max_restarts=2_000_000, perturb_w_A=0.0, y0=None, bearing_force=True):
        p, g = self.p, self.g
        rAb = g.rAb
        if inputs is None:
            inputs = InputTable.constant(p["tau_A"], p["tau_B"])
        y = self.m.initial_state() if y0 is None else np.array(y0, float)
        # perturbation of the start speed: both wheels, rolling (v unchanged), unlike
        # GearMesh (w_B fixed): under the constraint a relative speed of rAb*perturb_w_A would
        # be an impact at t = 0 (the v_res rule), not a perturbed start of the same motion
        y[2] += perturb_w_A
        tau = lambda tt, sg: (sg[1] + sg[2] * (tt - sg[0]), sg[3] + sg[4] * (tt - sg[0]))

        dscale = max(g.backlash, 1e-6)
        wscale = max(1.0, abs(p["w_A_start"]), abs(p["w_B_start"]))
        atol = np.array([1.0, dscale, wscale, dscale * 1e4]) * rtol
        n_grid = int(round(stop_time / output_interval))
        grid = np.arange(n_grid + 1) * output_interval
        grid[-1] = stop_time

        t = 0.0
        seg = inputs.segment(t)
        st, y, imp = self.start(y, *tau(t, seg))
        events = []      # (t, y_before, st_before, seg_before, y_after, st_after, seg_after, kind)
        if imp is not None:
            events.append((0.0, imp[0], RigidState(FREE), seg, y, st, seg, "impact+" + imp[1]))
        segments = []    # (t0, t1, dense output, state, input segment)
        n_restart = n_hidden = n_missed = 0
        same_t, last_t = 0, None
        seg_max = 20.0 * output_interval
        while t < stop_time:
            seg = inputs.segment(t)
            t_brk = min(inputs.next_break(t), stop_time)
            t_hi = min(t_brk, t + seg_max)
            if stop_time - t_hi < 1e-3 * output_interval:
                t_hi = t_brk
            rhs = self._rhs(st, seg)
            evs, guards = self._events(st, seg)
            sol = solve_ivp(rhs, (t, t_hi), y, method=method, rtol=rtol, atol=atol,
                            events=evs + guards, dense_output=True, max_step=output_interval)
            if sol.status < 0:
                raise RuntimeError(f"solve_ivp failed at t = {t}: {sol.message}")
            t_new = float(sol.t[-1])
            y_new = sol.y[:, -1].copy()
            fired = None
            if sol.status == 1:
                for i, fn in enumerate(evs):
                    if len(sol.t_events[i]):
                        fired = fn
                        break
            hid = self._hidden(sol, t, evs, guards)
            if hid is not None and (fired is None or hid[0] < t_new):
                t_new, fired = hid
                y_new = np.asarray(sol.sol(t_new), dtype=float).copy()
                n_hidden += 1
            segments.append((t, t_new, sol.sol, st, seg))
            n_restart += 1
            if n_restart > max_restarts:
                raise RuntimeError(f"more than {max_restarts} restarts at t = {t_new}")
            seg_new = inputs.segment(t_new) if t_new < stop_time else seg
            tau_old, tau_new = tau(t_new, seg), tau(t_new, seg_new)
            kind = None
            new_st, y_after = st, y_new
            if fired is not None and fired.kind[0] == "impact":
                fl = fired.kind[1]
                y_new[1] = self._flank_value(fl)     # located at delta = BAND: on the flank
                new_st, y_after, k2 = self.impact(fl, y_new, *tau_new)
                kind = f"impact+{k2}"
                if fl * y_new[3] <= self.v_res(y_new) and new_st.mode == FREE:
                    _aA, _aB, e2 = self._free_acc(y_after, *tau_new)
                    if fl * e2 > 0.0:
                        raise RuntimeError(
                            f"rigid contact inconsistent at t = {t_new}: the flank is reached "
                            "at rest with N < 0 and a closing free acceleration (friction)")
            elif fired is not None and fired.kind[0] == "release":
                y_after = y_new.copy()
                y_after[3] = 0.0
                if self.two_sided:
                    new_st = self._lock(st.mode, y_after, *tau_new, prefer=-st.mode)
                    kind = "flank change"
                else:
                    new_st = RigidState(FREE)
                    kind = "release"
            elif st.mode != FREE:
                # gate event, input breakpoint or segment end: gated set and N re-derived
                new_st = self._lock(st.mode, y_new, *tau_new, prefer=st.mode)
                if new_st is None:
                    new_st = RigidState(FREE)
                if fired is not None and fired.kind[0] == "gate":
                    kind = "pair switch" if new_st.mode != FREE else "pair switch+release"
                elif new_st.key != st.key:
                    if t_new != t_brk:
                        n_missed += 1
                    kind = "input+release" if new_st.mode == FREE else "input+pair switch"
                elif t_new == t_brk and tau_old != tau_new:
                    kind = "input"          # N jumps with the input: rows before/after
            if kind is not None:
                events.append((t_new, y_new, st, seg, y_after, new_st, seg_new, kind))
            if t_new == last_t:
                same_t += 1
                if same_t > 100:
                    raise RuntimeError(f"rigid contact: more than 100 events at t = {t_new}")
            else:
                same_t, last_t = 0, t_new
            t, y, st = t_new, np.asarray(y_after, float), new_st

        # ---- sample
        rows, n_grid_rows = [], len(grid)
        seg_t0 = [s[0] for s in segments]
        for tg in grid:
            i = bisect.bisect_right(seg_t0, tg) - 1
            i = min(max(i, 0), len(segments) - 1)
            t0, t1, solf, sst, sseg = segments[i]
            yy = solf(tg) if t1 > t0 else solf(t0)
            if sst.mode != FREE:      # exact constraint values (the dense output keeps them too)
                yy = np.array(yy, float)
                yy[1], yy[3] = self._flank_value(sst.mode), 0.0
            rows.append(self.outputs(tg, yy, sst, *tau(tg, sseg), bearing_force))
        merged = []
        for ev in events:   # coincident events: first before, last after
            if merged and ev[0] == merged[-1][0]:
                m0 = merged[-1]
                merged[-1] = (ev[0], m0[1], m0[2], m0[3], ev[4], ev[5], ev[6], m0[7] + ", " + ev[7])
            else:
                merged.append(ev)
        ev_list = []
        for te, yb, sb, gb, ya, sa, ga, kind in merged:
            rows.append(self.outputs(te, yb, sb, *tau(te, gb), bearing_force))
            rows.append(self.outputs(te, ya, sa, *tau(te, ga), bearing_force))
            ev_list.append((te, sb.n_fwd, sb.n_bwd, sa.n_fwd, sa.n_bwd, kind))
        order = sorted(range(len(rows)), key=lambda i: (rows[i][0], 0 if i < n_grid_rows else 1, i))
        ev_times = {e[0] for e in ev_list}
        table = np.array([rows[i] for i in order
                          if not (i < n_grid_rows and rows[i][0] in ev_times)])
        names = list(OUTPUT_NAMES) + (BEARING_OUTPUT_NAMES if bearing_force else [])
        return Result(names, table, ev_list, n_restart, n_missed=n_missed, n_hidden=n_hidden)


# --------------------------------------------------------------------------------------------
# Scenes
# --------------------------------------------------------------------------------------------

SCENES_DIR = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..", "scenes"))


def load_scene(name_or_path):
    path = name_or_path
    if not path.endswith(".toml"):
        path = os.path.join(SCENES_DIR, name_or_path + ".toml")
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    scene["name"] = os.path.basename(path)[:-5]
    scene["path"] = path
    return scene


def scene_model(scene):
    model = GearMesh(scene.get("start_values", {}))
    p = model.p
    if "input_file" in scene:
        inputs = InputTable.from_csv(os.path.join(os.path.dirname(scene["path"]), scene["input_file"]),
                                     p["tau_A"], p["tau_B"])
    else:
        inputs = InputTable.constant(p["tau_A"], p["tau_B"])
    return model, inputs


REF_RTOL = 1e-10    # the reference traces' integration tolerance (a scene may set reference_rtol)


def scene_reference_rtol(scene):
    """rtol of a scene's reference trace: its top-level reference_rtol, else REF_RTOL."""
    return float(scene.get("reference_rtol", REF_RTOL))


def run_scene(scene, rtol=None, method="DOP853", perturb_rel=0.0, output_step_cap=True):
    if rtol is None:
        rtol = scene_reference_rtol(scene)
    model, inputs = scene_model(scene)
    dw = perturb_rel * max(abs(model.p["w_A_start"]), 1.0)
    extra = {} if output_step_cap else {"output_step_cap": False}
    return model.simulate(scene["stop_time"], scene["output_interval"], inputs, rtol=rtol,
                          method=method, perturb_w_A=dw, **extra)


# --------------------------------------------------------------------------------------------
# Statistics (mode = "statistics"); computed from the rows on the output grid only, so that an
# FMU's co-simulation output (communication points only) and this reference give the same
# numbers for the same trajectory.
# --------------------------------------------------------------------------------------------

def grid_rows(names, table, output_interval):
    t = table[:, names.index("time")]
    k = t / output_interval
    on = np.abs(k - np.round(k)) < 1e-6
    sub = table[on]
    # first row per grid time (a coinciding event row pair would otherwise count twice)
    ts = sub[:, names.index("time")]
    keep = np.ones(len(ts), bool)
    keep[1:] = ts[1:] != ts[:-1]
    return sub[keep]


def statistics(names, table, output_interval, zA):
    """Statistics of a scene, over the grid rows of the whole scene:

    mean_w_A, mean_w_B        mean speeds [rad/s]
    mean_w_A_over_w_B         mean(w_A) / mean(w_B)
    rms_dte                   sqrt(mean(dte^2)) [m]
    max_dte, min_dte          extrema of dte on the grid [m]
    impacts_per_mesh_cycle    contact onsets: rising edges of (n_fwd > 0) plus rising edges of
                              (n_bwd > 0) between consecutive grid rows, divided by the mesh
                              cycles zA * |theta_A(end) - theta_A(0)| / (2 pi)
    flank_switches_per_mesh_cycle
                              changes of the flank last seen in contact (forward if n_fwd > 0,
                              backward if n_bwd > 0; rows without contact keep the last one),
                              per mesh cycle; unlike impacts it does not depend on whether a short
                              bounce happens to be sampled
    """
    r = grid_rows(names, table, output_interval)
    col = lambda n: r[:, names.index(n)]
    wA, wB, dte, thA = col("w_A"), col("w_B"), col("dte"), col("theta_A")
    nf, nb = col("n_fwd") > 0, col("n_bwd") > 0
    rises = int(np.sum(nf[1:] & ~nf[:-1]) + np.sum(nb[1:] & ~nb[:-1]))
    last, switches = 0, 0
    for f, b in zip(nf, nb):
        side = 1 if f else (-1 if b else 0)
        if side:
            if last and side != last:
                switches += 1
            last = side
    cycles = zA * abs(thA[-1] - thA[0]) / (2 * math.pi)
    per = (lambda n: n / cycles) if cycles > 0 else (lambda n: float("nan"))
    return {
        "mean_w_A": float(np.mean(wA)),
        "mean_w_B": float(np.mean(wB)),
        "mean_w_A_over_w_B": float(np.mean(wA) / np.mean(wB)),
        "rms_dte": float(np.sqrt(np.mean(dte ** 2))),
        "max_dte": float(np.max(dte)),
        "min_dte": float(np.min(dte)),
        "impacts_per_mesh_cycle": float(per(rises)),
        "flank_switches_per_mesh_cycle": float(per(switches)),
    }


def quasi_static_dte(start_values: dict, n_pairs: int) -> float:
    """Forward penetration that carries the rigid-body line force at t = 0.

    Rigid rolling (w_B = w_A rAb/rBb) gives the common acceleration
    w_A' = (tau_A + (rAb/rBb)(tau_B - c_load w_B)) / (J_A + J_B (rAb/rBb)^2); the line force
    is F = (tau_A - J_A w_A')/rAb, shared by n_pairs pairs; delta solves the Johnson law
    (eq. 5.1) for N = F/(n_pairs width) with rho_A + rho_B = L + delta (fixed point; internal
    pair: rho_B - rho_A = L - delta).  contact_model = 4: F / k_eff, with k_eff = k_lumped n/eps
    (n = n_pairs) when k_lumped_varies, else k_lumped.
    Used for dte_start so that a scene starts without the large first transient."""
    m = GearMesh(start_values)
    p, g = m.p, m.g
    i = g.rAb / g.rBb
    wA = p["w_A_start"]
    wB = wA * i
    acc = (p["tau_A"] + i * (p["tau_B"] - p["c_load"] * wB)) / (p["J_A"] + p["J_B"] * i * i)
    F = (p["tau_A"] - p["J_A"] * acc) / g.rAb
    if F <= 0.0:
        raise ValueError("no forward load at t = 0")
    if m.lumped is not None:
        # contact model 4: the spring k_eff (n_pairs = n of k_lumped n/eps when it varies)
        return F / m.lumped.k_eff(n_pairs)
    N = F / (n_pairs * p["width"])
    d = johnson_delta(N, g.L, g.E_star)
    for _ in range(50):
        d_new = johnson_delta(N, g.L + g.kappa * d, g.E_star)   # L - d for an internal pair
        if d_new == d:
            break
        d = d_new
    return d
