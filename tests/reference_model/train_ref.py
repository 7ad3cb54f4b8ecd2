"""Independent reference model of the SpurGearTrain FMU (/work/shared/spec/gear-train.md).

Bodies (rigid rotors), shafts (linear torsional spring-dampers) and meshes (the single-mesh
model of gear-mesh-model.md, contact model 1: Johnson line contact, Hunt-Crossley damping chi,
regularized Coulomb friction mu, backlash, forward and backward flanks, contact ratio in [1, 2]).
Written from the specification; it shares with the single-mesh reference gearmesh_ref.py only
its pure functions (geometry front ends, Johnson law, parameter defaults, the tie rule `_side`).

STATE.  Not the body angles themselves but the TREE COORDINATES, a linear change of them:

    x = [theta_1, c_1, ..., c_{n-1}],   y = [x, dx/dt, W_ext, W_loss]

theta_1 is body 1's forward angle; c_k is the coordinate of edge k (meshes 1..n_meshes first,
then shafts 1..n_shafts): for a mesh e_m = rAb theta_A - rBb theta_B (so dte_m = e_m +
dte_start_m), for a shaft q_j = theta_a - theta_b (its twist is q_j + twist_start_j).  A tree on
n bodies has n - 1 edges, each the parent edge of exactly one body, so theta = T x with an
invertible T (built by walking the tree from body 1) and x = E theta.  Integrating e_m directly
keeps the penetrations' error absolute (a few 1e-16 m), instead of a difference of two large
angles; this is what gearmesh_ref does for its one mesh ([theta_A, e, w_A, v]).

TEETH, from the body angles alone (spec sections 2-4).  Body i has forward sense sigma_i
(sigma_1 = -1, flipped across a mesh, kept across a shaft) and absolute angle
psi_i = psi_i(0) + sigma_i theta_i.  Mesh m maps to its paper frame with s_m = -sigma_A
(s_m = +1: rotation by beta = center_angle; s_m = -1: rotation and mirror):
chi = s_m (psi + mount - beta) is a gear's tooth-0 axis in that frame.  Teeth are numbered
n = ..., -1, 0, 1, ... in the body's forward sense (tooth n's axis at psi + mount + sigma n 2pi/z
in the housing frame), i.e. at chi + s_m sigma n dz in the mesh frame: chi - n dA for gear A
(s_m sigma_A = -1) and chi + n dB for gear B.  The spec's roots "chi + k dz -+ t/2" give, with
u = rb theta (line-of-action travel) and the offsets fixed at t = 0 (section "Placement"):

    forward,  A tooth n:  s_A = SfA + u_A + n p_b       B tooth n:  s_B = SfB - u_B - n p_b
    backward, A tooth n:  s_A = SbA - u_A - n p_b       B tooth n:  s_B = SbB + u_B + n p_b

    SfA = rAb (alpha_w - chiA0 + tA/2)          SfB = rBb (alpha_w + pi - chiB0 + tB/2)
    SbA = rAb (alpha_w + chiA0 + tA/2)          SbB = rBb (alpha_w - pi + chiB0 + tB/2)

A pair (n_A, n_B) has delta = s_A + s_B - L, which depends on n_B - n_A only: the teeth that
mesh are those with n_B - n_A = K_f (forward) or K_b (backward), fixed at placement so that the
forward delta equals dte_start (then the backward delta is -backlash - dte by the thickness
identity of gear-mesh-model.md section 2; checked at placement).  Pairs are ENUMERATED by n_A
(no contact objects, no jumps).  n_A is the unwrapped tooth count: the physical tooth is
n_A mod z_A; the identity f1/f2, b1/b2 uses n_A mod m_c of the unwrapped count, as an
object-tracking implementation's jumps by m_c pairs do.

FORCES (gear-mesh-model.md sections 3-5).  A pair carries iff gated (s_A <= s_b: inside A's tip;
s_B <= L - s_a: inside B's tip, which is the spec's s_A - max(delta, 0) >= s_a for delta > 0),
inside the m_c-pitch window s_A >= s_b - m_c p_b (only restrictive when contacts_per_flank <
eps), its flank's delta > 0 and (chi > 0) 1 + chi d(delta)/dt > 0.  All carrying pairs of a flank
share delta, rho_A + rho_B = L + delta and the Johnson force; F_n = width N (1 + chi d(delta)/dt),
F_t = mu tanh(v_s/v_reg) F_n, torques as the single mesh's table, in forward terms (interface
sign): forward flank -F_n rAb + F_t s_A on A, F_n rBb - F_t s_B on B; backward flank
F_n rAb + F_t s_A on A, -F_n rBb - F_t s_B on B.  Bodies: J dw/dt = tau - c w + mesh torques +
shaft torques; shaft j adds -tau_j to body a and +tau_j to body b,
tau_j = k (q_j + twist_start) + d dq_j/dt.

INTEGRATION as gearmesh_ref: solve_ivp (DOP853) with the carrying set of EVERY mesh fixed inside
a call (the Johnson force extended oddly through 0, the damping factor unclamped, so the
right-hand side is smooth there); every event that can change any mesh's set is terminal:
each flank's delta through 0; the gate boundaries (periodic functions sin(pi xi/p_b), zero at
every pair's boundary: s_A = s_b, which also covers the window boundary s_b - m_c p_b, and
s_B = L - s_a); damped release 1 +- chi v = 0; input-table breakpoints.  Event functions are
signed to be >= 0 just after a restart (ties broken by first, then second time derivatives,
gearmesh_ref's rule), only + -> - crossings are detected; non-terminal guards at the zeros of
each mesh's v and of the meshed bodies' speeds catch a sign change hidden inside one step, and
the step is capped so no gate coordinate moves more than p_b/8 per step.

ENERGY: E_kin = sum J w^2/2; E_el = the carrying pairs' width * int_0^delta N + the shafts'
k twist^2/2; W_ext = int sum (tau_i - c_i w_i) w_i (inputs and drag, as the single mesh's
W_ext includes c_load); W_loss = int (mesh P_loss + shafts' d (dq/dt)^2); E_gate = the sum of
the jumps of E_el at events (pairs entering or leaving the gate loaded, damped releases);
energy_residual = E_kin + E_el + W_loss - W_ext - E_gate - (its value at t = 0).

INTERNAL MESHES (planetary.md section 1; mesh[m].internal = true, standard geometry).  Across an
internal mesh the forward sense is KEPT (planetary.md section 3).  Its frame is the housing frame
rotated by beta + pi (O_B at (-d, 0)) and mirrored when sigma_A = +1: chi = s_m (psi + mount -
beta - pi).  With s_m sigma_B = -1 the ring's tooth n has its axis at chi - n dB, and section 1's
roots (forward chi + k dz + tB/2, backward chi + k dz - tB/2) with s_B = rBb (alpha_w -+ phiB) give

    forward,  B tooth n:  s_B = rBb (alpha_w - chiB0 - tB/2) + u_B + n p_b
    backward, B tooth n:  s_B = rBb (alpha_w + chiB0 - tB/2) - u_B - n p_b

and delta = s_A - s_B + L.  In terms of s~_B = 2 L - s_B these are the external forms above
(SfB = 2L - rBb (alpha_w - chiB0 - tB/2), SbB = 2L - rBb (alpha_w + chiB0 - tB/2)), with
delta = s_A + s~_B - L and the ring's tip gate s_B >= L + s_a written s~_B <= L - s_a: so the
pairing, gating, events and placement code is shared, and only the force differs: rho_B - rho_A
= L - delta in the Johnson law, and the real s_B = s_A + L - delta in the friction and torques
(whose forward-sense table is the external one: planetary.md section 1's paper-frame table with
theta_B = -psi_B).

LUMPED MESHES (mesh[m].contact_model = 4, lateral.md section 4; torsional only, no lateral
bodies).  The same law as lumped_ref.py (its docstring states it): per flank in contact
(delta > 0, forward dte, backward -j_n - dte with the actual backlash) F = k_eff delta +
c_lumped d(delta)/dt, not clipped, no chi, no friction, torques as model 1's normal force;
k_eff = k_lumped, or k_lumped n/eps with mesh[m].k_lumped_varies, n the flank's pairs whose s_A
lies in [s_a, s_b] (A's coordinate only: the lower gate edge is s_a, not model 1's B-tip edge).
MeshState.kf (kb) holds the gated pairs of a flank in contact (empty in the gap), so n_fwd,
n_bwd = n_g there and 0 in the gap; F_f1 ... F_b2 = F/n_g per gated object; P_loss = c_lumped
(d delta/dt)^2; the extra output mesh[m].k_mesh (only for a lumped mesh, after its P_loss) = the
sum of k_eff over the flanks in contact.  Events: delta through 0 and, on a flank in contact, the
gate edges s_A = s_b and s_A = s_a (periodic functions of u_A); no release event.  E_el = k_eff
delta^2/2 per flank in contact; a stiffness switch is a jump of E_el, booked in E_gate.

CENTRE DISTANCE (planetary.md section 2): mesh[m].center_distance_error goes to the single
mesh's Geometry, which computes alpha_w, d, L, s_a and the actual backlash at the actual
distance; the train uses those everywhere (center_angle is still the direction of O_A -> O_B).

PLANETARY TRAINS (planetary.md sections 3-4; GENERAL mode, used when an element names the
housing, a body has a carrier, or the meshes and shafts close a loop; a tree without these runs
the code above unchanged, bit for bit).  Decisions agreed with the Rust side where the spec is
silent:
  * body 0 is the housing (index n_bodies internally): a mesh end 0 is a fixed gear, a shaft end
    0 a torsional mount.  Forward senses walk from body 1 over meshes and shafts, never through
    the housing; an unreached part takes -1 at its lowest index; for body 0 a mesh uses the sense
    it gives from its other end (external: opposite, internal: the same).
  * body[i].carrier = c: planet i turns about an axis fixed in c.  Its orbit radius R_i is the
    NOMINAL operating centre distance of its lowest-index mesh with a central member (a body on
    a housing-fixed axis, or body 0); its axis in the carrier's frame is (R_i + pin_error_r)
    (cos phi, sin phi) + pin_error_t (-sin phi, cos phi), phi = orbit_angle; central members on
    the carrier's axis.  A mesh with a planet is in its carrier's frame: d = |O_B - O_A| + its
    center_distance_error (the single-mesh Geometry at center_distance_error = d - d_nominal),
    beta = direction O_A -> O_B (+ pi for an internal pair), mirrored when sigma_A = +1, angles
    relative to the carrier: theta_rel = theta - sigma sigma_c theta_c.  Its torques on A and B
    are the single mesh's; the carrier gets minus their sum in absolute terms.  Orbital inertia
    body[i].m R_i^2 is added to the carrier's J; a planet's drag acts on its speed relative to
    its carrier, which takes the reaction.  housing.tau = the absolute (counter-clockwise)
    torques meshes and shafts apply to body 0 (a carrier's reactions go to the carrier).
  * Placement: breadth-first from the housing (psi 0) if any element names it, else from body 1
    (psi = angle_start; a carrier is at 0 regardless).  Every carrier starts at psi 0; the queue
    starts [root, carriers in ascending index]; each popped body places the unplaced bodies of
    its meshes (index order; gear-train.md section 4 in the mesh's frame, psi in (-pi/z, pi/z])
    then of its shafts.  Every other mesh CLOSES A LOOP: the tooth pairing whose forward
    penetration delta0 (from the placed angles) lies nearest -j_n/2; its dte = delta0 + e;
    refused when delta0 > 0.01 p_b or -j_n - delta0 > 0.01 p_b.
  * Coordinates: x = [theta of the FREE bodies, coordinates of the INDEPENDENT edges], a basis
    of the body angles: the placing edges (each brings in a new body) plus any loop edge that
    raises the rank, then free bodies in ascending index until the basis is complete (the rigid
    degrees of freedom).  theta = T x; a dependent loop mesh has e = ce . x with its
    coefficients on the free bodies zero (they vanish analytically: its row lies in the span of
    the edge rows), so its dte is a combination of small edge coordinates and keeps a few 1e-16 m
    however far the bodies turn.
  * Refused, naming the elements: indices out of range, self-joins, a carried carrier, a planet
    meshing with a planet of another carrier or with its own carrier, a planet with no mesh or no
    central member, a nonzero center_angle in a carrier's frame, an unconnected body, conflicting
    senses around a loop, a jammed body (no rigid rolling of the meshes, shafts absent, turns it).

BEARING FORCES (lateral.md sections 3 and 6, for a purely torsional train: every centre held
where planetary.md section 3 puts it; simulate(bearing_forces=True), or a scene that compares
any of them, adds the outputs body[i].Fx, body[i].Fy, housing.Fx, housing.Fy [N]).
  * A mesh's force on gear B, per carrying pair, in the single mesh's paper frame (O_A at the
    origin, O_B at (d, 0), or (-d, 0) for an internal pair; A's forward sense clockwise): the
    normal force F_n along the flank's line of action, n_f = (sin aw, -cos aw) forward and its
    mirror about the line of centres n_b = (sin aw, cos aw) backward, and the friction force F_t
    along the flank's tangent, t_f = (cos aw, sin aw) forward, t_b = (-cos aw, sin aw) backward;
    A receives the opposite.  F_t is the torques' (gear-mesh-model.md section 4, planetary.md
    section 1).  Derivation: with K_A = rAb (cos aw, sin aw), u = n_f and the contact point
    C = K_A + s_A u, the moment about O_A of -F_n u - F_t t_f at C is F_n rAb - F_t s_A (K_A x u
    = -rAb, K_A x t_f = 0, u x t_f = 1), the table's torque on A; about O_B = (d, 0) the moment
    of F_n u + F_t t_f is F_n (d cos aw - rAb) + F_t (s_A - L) = F_n rBb - F_t s_B (external;
    s_B = L - s_A up to delta), and about O_B = (-d, 0) it is -F_n (rAb + d cos aw) + F_t (s_A +
    L) = -F_n rBb + F_t s_B (internal: rBb - rAb = d cos aw, s_B = s_A + L up to delta): the
    single mesh's torques on B.  The backward flank is the mirror image (y -> -y) of all this.
    For the lumped mesh F_n is its spring-damper force and F_t = 0.  The normal forces push the
    gears apart along n (lateral.md section 3).
  * Paper frame -> the frame the mesh sits in (gear-train.md section 3, planetary.md section 3):
    v = Rot(beta_frame) (v_x, s_m v_y), s_m = -sigma_A (mirrored when sigma_A = +1), beta_frame
    = beta (+ pi for an internal pair); a mesh in a carrier's frame is turned further by the
    carrier's absolute angle psi_c = sigma_c theta_c (0 at t = 0) into the housing frame.
  * A body on a housing-fixed axis (carriers included): (Fx, Fy) in the housing frame = minus
    the sum of its meshes' forces, and for a carrier plus the sum of its planets' pin forces P_n
    (the carrier receives -P_n from each).  Its centre does not move, so its mass does not enter.
  * A planet n of carrier c: its pin exerts P_n = m_n a_n - (sum of its meshes' forces), with
    a_n the acceleration of its centre p_n = Rot(psi_c) r_n moving with the carrier, r_n its pin
    in the carrier's frame (planet_position: R_n + pin_error_r radially, pin_error_t
    tangentially), a_n = Rot(psi_c) (-Omega^2 r_n + alpha J r_n), Omega = sigma_c w_c and alpha
    = sigma_c dw_c/dt (absolute, counter-clockwise; dw_c/dt from the equations of motion at that
    instant, with the torque inputs at t), J the quarter turn, m_n = body[n].m.  Reported in the
    carrier's frame at the pin: Fx = P_n . e_r (radially outwards), Fy = P_n . e_t (tangentially,
    counter-clockwise), e_r = r_n/|r_n|, e_t = J e_r.  A planet's meshes are all in its carrier's
    frame, so P_n is formed there.  (The orbital inertia in the torsional equations stays m R^2
    with the nominal R; a_n uses the actual pin r_n, as the bearing force is defined.)
  * housing.Fx, housing.Fy: the forces of the meshes with a gear in the housing (an end 0) on
    that gear, minus the bearing forces of every body on a housing-fixed axis (the housing
    holds those bearings).  Newton's third law makes it -sum_n m_n a_n in the housing frame.

Readings of the spec where it leaves room are listed in the report and marked in the code.
"""

from __future__ import annotations

import bisect
import csv
import math
import os
import re
import tomllib
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import quad, solve_ivp

from . import gearmesh_ref as G
from . import deviations_ref as D

CAPACITY = {"body": 16, "shaft": 15, "mesh": 16}

# Single-mesh parameters that do not belong to a pair (spec section 1): bodies carry inertia,
# drag, start speed and torque; solver and tolerance belong to the whole train.
NOT_PER_MESH = {"J_A", "J_B", "c_load", "w_A_start", "w_B_start", "tau_A", "tau_B",
                "solver", "rel_tol", "restitution", "slider_stiffness"}
MESH_PAIR_KEYS = [k for k in G.DEFAULTS if k not in NOT_PER_MESH]
MESH_PLACE_KEYS = {"A": 0, "B": 0, "center_angle": 0.0, "mount_A": 0.0, "mount_B": 0.0}
SHAFT_KEYS = ("a", "b", "k", "d", "twist_start")
BODY_KEYS = ("J", "c", "w_start", "tau", "tau_ripple", "ripple_order", "ripple_phase",
             "carrier", "orbit_angle", "m", "pin_error_r", "pin_error_t")
INTEGER_KEYS = {"n_bodies", "n_shafts", "n_meshes", "solver"}
TOP_KEYS = {"n_bodies": 4, "n_shafts": 1, "n_meshes": 2, "rel_tol": 1e-6, "solver": 1}


def train_defaults() -> dict:
    """The defaults agreed with the Rust side: a two-stage reducer (paper-geometry 22/33 meshes)
    with a compliant intermediate shaft between bodies 2 and 3."""
    d = dict(TOP_KEYS)
    nbc = CAPACITY["body"]
    J = [0.4, 2.0, 0.4, 2.0] + [1.0] * (nbc - 4)
    w = [100.0, 100.0 / 1.5, 100.0 / 1.5, 100.0 / 2.25] + [0.0] * (nbc - 4)
    for i in range(1, CAPACITY["body"] + 1):
        d[f"body[{i}].J"] = J[i - 1]
        d[f"body[{i}].c"] = 2.0 if i == 4 else 0.0
        d[f"body[{i}].w_start"] = w[i - 1]
        d[f"body[{i}].tau"] = 100.0 if i == 1 else 0.0
        d[f"body[{i}].tau_ripple"] = d[f"body[{i}].ripple_order"] = d[f"body[{i}].ripple_phase"] = 0.0
        # planetary.md section 3 (defaults agreed with the Rust side): a housing-fixed axis
        d[f"body[{i}].carrier"] = 0
        d[f"body[{i}].orbit_angle"] = d[f"body[{i}].m"] = 0.0
        d[f"body[{i}].pin_error_r"] = d[f"body[{i}].pin_error_t"] = 0.0
    d["body[1].angle_start"] = 0.0
    for j in range(1, CAPACITY["shaft"] + 1):
        a, b, dd = (2, 3, 5.0) if j == 1 else (1, 2, 0.0)
        d.update({f"shaft[{j}].a": a, f"shaft[{j}].b": b, f"shaft[{j}].k": 1e5,
                  f"shaft[{j}].d": dd, f"shaft[{j}].twist_start": 0.0})
    for m in range(1, CAPACITY["mesh"] + 1):
        d.update({f"mesh[{m}].A": 2 * m - 1, f"mesh[{m}].B": 2 * m, f"mesh[{m}].center_angle": 0.0,
                  f"mesh[{m}].mount_A": 0.0, f"mesh[{m}].mount_B": 0.0})
        for k in MESH_PAIR_KEYS:
            d[f"mesh[{m}].{k}"] = G.DEFAULTS[k]
        d[f"mesh[{m}].chi"] = 10.0   # agreed train default (the single mesh's default is 0)
    return d


DEFAULTS = train_defaults()
_NAME = re.compile(r"^(body|shaft|mesh)\[(\d+)\]\.(\w+)$")


def make_train_params(start_values: dict | None = None) -> dict:
    """Defaults overridden by start_values (FMI names); types checked like gearmesh_ref."""
    p = dict(DEFAULTS)
    for key, v in (start_values or {}).items():
        if key not in DEFAULTS:
            m = _NAME.match(key)
            if m and int(m.group(2)) > CAPACITY[m.group(1)]:
                raise KeyError(f"{key}: index {m.group(2)} beyond the capacity "
                               f"{CAPACITY[m.group(1)]} of {m.group(1)} elements")
            raise KeyError(f"unknown train parameter/input {key!r}")
        m = _NAME.match(key)
        base = m.group(3) if m else key
        if m and m.group(1) == "mesh" and base in G.BOOLEAN_PARAMS:
            if not isinstance(v, bool):
                raise TypeError(f"{key} must be a boolean")
        elif m and m.group(1) == "mesh" and base in G.STRING_PARAMS:
            if not isinstance(v, str):
                raise TypeError(f"{key} must be a string")
        elif (key in INTEGER_KEYS or (m and m.group(1) == "mesh" and
                                      (base in G.INTEGER_PARAMS or base in ("A", "B")))
              or (m and m.group(1) == "shaft" and base in ("a", "b"))
              or (m and m.group(1) == "body" and base == "carrier")):
            if isinstance(v, bool) or int(v) != v:
                raise TypeError(f"{key} must be an integer")
            v = int(v)
        else:
            v = float(v)
        p[key] = v
    return p


# --------------------------------------------------------------------------------------------
# Inputs: body[i].tau, piecewise linear between table rows (fmpy semantics, as InputTable)
# --------------------------------------------------------------------------------------------

class TrainInputs:
    def __init__(self, times, values):
        """times: list of t; values: array (len(times), n_bodies) of body torques."""
        self.t = [float(x) for x in times]
        self.v = np.asarray(values, dtype=float).reshape(len(self.t), -1)
        if any(t2 < t1 for t1, t2 in zip(self.t, self.t[1:])):
            raise ValueError("input table times must be non-decreasing")
        self.breaks = sorted(set(self.t))

    @classmethod
    def constant(cls, taus):
        return cls([0.0], [list(taus)])

    @classmethod
    def from_csv(cls, path, defaults):
        """Columns time and any body[i].tau; absent columns keep the parameter's value."""
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        head = [h.strip().strip('"') for h in rows[0]]
        data = [[float(x) for x in r] for r in rows[1:] if r and any(c.strip() for c in r)]
        col = {h: i for i, h in enumerate(head)}
        vals = []
        for r in data:
            vals.append([r[col[f"body[{i + 1}].tau"]] if f"body[{i + 1}].tau" in col else defaults[i]
                         for i in range(len(defaults))])
        return cls([r[col["time"]] for r in data], vals)

    def next_break(self, t):
        i = bisect.bisect_right(self.breaks, t)
        return self.breaks[i] if i < len(self.breaks) else math.inf

    def segment(self, t):
        """(t0, value at t0, slope) valid on [t, next_break(t))."""
        ts, v = self.t, self.v
        zero = np.zeros(v.shape[1])
        if len(ts) == 1 or t < ts[0]:
            return (t, v[0].copy(), zero)
        i = bisect.bisect_right(ts, t) - 1
        if i >= len(ts) - 1:
            return (t, v[-1].copy(), zero)
        return (ts[i], v[i].copy(), (v[i + 1] - v[i]) / (ts[i + 1] - ts[i]))

    def max_abs(self):
        return np.max(np.abs(self.v), axis=0)


def tau_at(seg, t):
    return seg[1] + seg[2] * (t - seg[0])


# --------------------------------------------------------------------------------------------
# Elements
# --------------------------------------------------------------------------------------------

@dataclass
class Body:
    J: float
    c: float
    w0: float
    tau: float
    ripple: tuple = (0.0, 0.0, 0.0)   # amplitude, order, phase: + A sin(order theta + phase)
    carrier: int = 0                  # body[i].carrier (1-based; 0 = a housing-fixed axis)
    orbit: float = 0.0                # body[i].orbit_angle
    mass: float = 0.0                 # body[i].m (orbital inertia m R^2 on the carrier)
    pin_r: float = 0.0                # body[i].pin_error_r, pin_error_t
    pin_t: float = 0.0


@dataclass
class Shaft:
    j: int          # 1-based index
    a: int          # 0-based body indices
    b: int
    k: float
    d: float
    twist0: float


@dataclass
class MeshState:
    """Logical state of one mesh between two restarts."""
    on_f: bool
    on_b: bool
    kf: tuple       # A tooth numbers n_A of the carrying forward pairs
    kb: tuple       # same, backward pairs
    sig: dict = field(default_factory=dict)   # sign multipliers of the event functions

    @property
    def key(self):
        return (self.kf, self.kb)


@dataclass
class Config:
    meshes: tuple   # MeshState per mesh
    acc: np.ndarray = None   # body accelerations at the restart (for tie breaking)

    @property
    def key(self):
        return tuple(ms.key for ms in self.meshes)


class TrainMesh:
    """One gear pair of the train: geometry, tooth offsets, pair enumeration, forces."""

    def __init__(self, m: int, p: dict, A: int, B: int, beta: float, mount_A: float, mount_B: float):
        self.m = m                      # 1-based index
        self.p = p                      # single-mesh parameter dict (make_params)
        self.g = G.Geometry(p)
        self.internal = self.g.internal
        self.A, self.B = A, B           # 0-based body indices
        self.beta, self.mount_A, self.mount_B = beta, mount_A, mount_B
        # the frame's rotation: beta (external), beta + pi (internal: O_B at (-d, 0))
        self.beta_frame = beta + math.pi if self.internal else beta
        self.dte0 = p["dte_start"]
        self.width, self.chi, self.mu, self.v_reg = p["width"], p["chi"], p["mu"], p["v_reg"]
        self.bwd = bool(p["backward_contacts"])
        g = self.g
        self.window_active = g.eps > g.m_c + 1e-12
        # contact_model = 4, the lumped mesh (module docstring, LUMPED MESHES)
        self.lumped = p["contact_model"] == 4
        self.k_l, self.c_l = p["k_lumped"], p["c_lumped"]
        self.varies = bool(p["k_lumped_varies"])

    def k_eff(self, n):
        """Lumped mesh: k_lumped, or k_lumped n / eps with k_lumped_varies (n gated pairs)."""
        return self.k_l * n / self.g.eps if self.varies else self.k_l

    # ---------------------------------------------------------------- placement (spec 3-4)
    def chi_of(self, psi, mount):
        return self.s * (psi + mount - self.beta_frame)

    def psi_of(self, chi, mount):
        return self.s * chi + self.beta_frame - mount      # inverse of chi_of (s = +-1)

    def place_other(self, psi_known, known_is_A):
        """psi(0) of the gear not yet placed: forward delta of the pairs = dte_start, reduced to
        (-pi/z, pi/z] of that gear by whole teeth (spec section 4)."""
        g = self.g
        aw = g.alpha_w
        if self.internal:
            # delta = rAb(aw - chiA + tA/2) - rBb(aw - chiB - tB/2) + L for tooth 0 of each
            # (then reduce psi by whole teeth, which changes only the pairing)
            if known_is_A:
                chiA = self.chi_of(psi_known, self.mount_A)
                sA = g.rAb * (aw - chiA + g.tA / 2)
                chiB = aw - g.tB / 2 - (sA + g.L - self.dte0) / g.rBb
                return reduce_angle(self.psi_of(chiB, self.mount_B), g.zB)
            chiB = self.chi_of(psi_known, self.mount_B)
            sB = g.rBb * (aw - chiB - g.tB / 2)
            chiA = aw + g.tA / 2 - (sB - g.L + self.dte0) / g.rAb
            return reduce_angle(self.psi_of(chiA, self.mount_A), g.zA)
        # delta(i, j) = rAb(aw - chiA - i dA + tA/2) + rBb(aw + pi - chiB - j dB + tB/2) - L
        # (mesh-frame tooth indices i, j); any integer i + j: choose 0, then reduce psi.
        if known_is_A:
            chiA = self.chi_of(psi_known, self.mount_A)
            chiB = (g.rAb * (aw - chiA + g.tA / 2) + g.rBb * (aw + math.pi + g.tB / 2)
                    - g.L - self.dte0) / g.rBb
            return reduce_angle(self.psi_of(chiB, self.mount_B), g.zB)
        chiB = self.chi_of(psi_known, self.mount_B)
        chiA = (g.rAb * (aw + g.tA / 2) + g.rBb * (aw + math.pi - chiB + g.tB / 2)
                - g.L - self.dte0) / g.rAb
        return reduce_angle(self.psi_of(chiA, self.mount_A), g.zA)

    def set_offsets_loop(self, psiA0, psiB0, train):
        """A mesh that closes a loop (planetary.md section 4): the tooth pairing whose forward
        penetration delta0 (from the placed angles) lies nearest -j_n/2, the middle of its actual
        backlash; delta0 replaces dte_start.  Refused when either flank starts more than 1 % of
        p_b into its teeth."""
        g = self.g
        pb, j = g.p_b, g.backlash
        self._offsets(psiA0, psiB0)
        c0 = self.SfA + self.SfB - g.L
        K = round((c0 + 0.5 * j) / pb)
        delta0 = c0 - K * pb
        if train.check_assembly and (delta0 > 0.01 * pb or -j - delta0 > 0.01 * pb):
            flank, pen = (("forward", delta0) if delta0 > 0.01 * pb else ("backward", -j - delta0))
            hint = ""
            for X in (self.A, self.B):
                if X != train.H and train.carrier_of[X] is not None:
                    hint = (f"; {train._body_name(X)} sits at orbit angle "
                            f"{train.bodies[X].orbit!r} rad: in a simple planetary set "
                            "(z_sun + z_ring) (psi_n - psi_1) / (2 pi) must be an integer "
                            "(the assembly condition)")
            raise ValueError(
                f"mesh[{self.m}] closes a loop and cannot be assembled as placed: its {flank} "
                f"flank would start {pen!r} m into its teeth (more than 1 % of the base pitch "
                f"p_b = {pb!r} m; actual backlash {j!r} m){hint}")
        self.dte0 = delta0
        self._pairings()

    def _offsets(self, psiA0, psiB0):
        g = self.g
        aw = g.alpha_w
        chiA0 = self.chi_of(psiA0, self.mount_A)
        chiB0 = self.chi_of(psiB0, self.mount_B)
        self.SfA = g.rAb * (aw - chiA0 + g.tA / 2)
        self.SbA = g.rAb * (aw + chiA0 + g.tA / 2)
        if self.internal:    # s~_B = 2 L - s_B (module docstring, INTERNAL MESHES)
            self.SfB = 2.0 * g.L - g.rBb * (aw - chiB0 - g.tB / 2)
            self.SbB = 2.0 * g.L - g.rBb * (aw + chiB0 - g.tB / 2)
        else:
            self.SfB = g.rBb * (aw + math.pi - chiB0 + g.tB / 2)
            self.SbB = g.rBb * (aw - math.pi + chiB0 + g.tB / 2)

    def set_offsets(self, psiA0, psiB0):
        """Tooth offsets SfA, SfB, SbA, SbB and the pairings K_f, K_b (module docstring)."""
        self._offsets(psiA0, psiB0)
        self._pairings()

    def _pairings(self):
        g = self.g
        pb = g.p_b
        # forward: delta = SfA + SfB - L - K_f p_b (at t = 0) = dte_start
        cf = self.SfA + self.SfB - g.L - self.dte0
        self.Kf = round(cf / pb)
        # backward: delta_b = SbA + SbB - L + K_b p_b = -backlash - dte_start
        cb = -g.backlash - self.dte0 - (self.SbA + self.SbB - g.L)
        self.Kb = round(cb / pb)
        res_f, res_b = cf - self.Kf * pb, cb - self.Kb * pb
        # rounding of O(1) angles times radii: a few 1e-16 m; 1e-12 m flags a wrong identity
        if abs(res_f) > 1e-12 or abs(res_b) > 1e-12:
            raise RuntimeError(f"mesh[{self.m}]: placement residuals {res_f!r}, {res_b!r} m "
                               "(forward/backward pairing inconsistent with the tooth thickness)")

    # ---------------------------------------------------------------- pair geometry
    def sA_f(self, uA, n):
        return self.SfA + uA + n * self.g.p_b

    # s_B below is s~_B = 2 L - s_B for an internal mesh (module docstring)
    def sB_f(self, uB, n):         # n: A tooth number; the B tooth is n + K_f
        return self.SfB - uB - (n + self.Kf) * self.g.p_b

    def sA_b(self, uA, n):
        return self.SbA - uA - n * self.g.p_b

    def sB_b(self, uB, n):
        return self.SbB + uB + (n + self.Kb) * self.g.p_b

    def candidates(self, sA0, sgn):
        """A tooth numbers n whose s_A = sA0 + sgn n p_b can lie in [s_b - 2 p_b, s_b] (the
        gate and the window lie there, eps <= 2), with a margin of one pair each side."""
        g = self.g
        a = (g.s_b - 2.0 * g.p_b - sA0) / g.p_b * sgn
        b = (g.s_b - sA0) / g.p_b * sgn
        return range(math.floor(min(a, b)) - 1, math.ceil(max(a, b)) + 2)

    def object_name(self, flank, n):
        mc = self.g.m_c
        if flank == 1:
            return "f1" if n % mc == 0 else "f2"
        return "b1" if n % mc == 1 % mc else "b2"

    # ---------------------------------------------------------------- forces
    def torques(self, uA, dte, wA, wB, v, kf, kb, detail=False):
        """Mesh torques on A and B (forward sense) and P_loss for fixed carrying sets."""
        if self.lumped:
            return self._torques_lumped(dte, v, kf, kb, detail)
        g = self.g
        rAb, rBb, L, kap = g.rAb, g.rBb, g.L, g.kappa
        mA = mB = ploss = 0.0
        forces = []
        for flank, ks in ((1, kf), (-1, kb)):
            if not ks:
                continue
            d, dd = (dte, v) if flank == 1 else (-g.backlash - dte, -v)
            # odd extension through 0: smooth inside a segment, never used past an event;
            # radius sum L + d (external), L - d (internal); kap*x is exact for kap = 1
            N = (G.johnson_N(d, L + kap * d, g.E_star) if d >= 0.0
                 else -G.johnson_N(-d, L - kap * d, g.E_star))
            Fn = self.width * N * (1.0 + self.chi * dd)
            ploss += len(ks) * self.width * N * self.chi * dd * dd
            for n in ks:
                sA = self.sA_f(uA, n) if flank == 1 else self.sA_b(uA, n)
                # the real s_B: L + delta - s_A (external), s_A + L - delta (internal)
                sB = L + kap * d - kap * sA
                if self.mu != 0.0:
                    vs = -wA * sA + wB * sB       # paper frame: omega_A = -w_A, omega_B = w_B
                    Ft = self.mu * math.tanh(vs / self.v_reg) * Fn
                    ploss += Ft * vs
                else:
                    Ft = 0.0
                if flank == 1:
                    mA += -Fn * rAb + Ft * sA
                    mB += Fn * rBb - Ft * sB
                else:
                    mA += Fn * rAb + Ft * sA
                    mB += -Fn * rBb - Ft * sB
                if detail:
                    forces.append((flank, n, Fn, Ft))
        if detail:
            return mA, mB, ploss, forces
        return mA, mB, ploss

    def _torques_lumped(self, dte, v, kf, kb, detail):
        """The lumped mesh: per flank in contact (kf, kb: its gated pairs) F = k_eff delta +
        c_lumped d(delta)/dt (not clipped), acting as model 1's normal force of that flank; each
        gated object reports F / n_g; P_loss = c_lumped (d delta/dt)^2."""
        g = self.g
        mA = mB = ploss = 0.0
        forces = []
        for flank, ks in ((1, kf), (-1, kb)):
            if not ks:
                continue
            d, dd = (dte, v) if flank == 1 else (-g.backlash - dte, -v)
            F = self.k_eff(len(ks)) * d + self.c_l * dd
            ploss += self.c_l * dd * dd
            mA -= flank * F * g.rAb
            mB += flank * F * g.rBb
            if detail:
                forces += [(flank, n, F / len(ks), 0.0) for n in ks]
        if detail:
            return mA, mB, ploss, forces
        return mA, mB, ploss

    def force_on_B(self, forces):
        """The mesh's force on gear B (gear A takes its opposite), in the frame the mesh sits in:
        the housing's, or its carrier's for a mesh in a carrier's frame (module docstring,
        BEARING FORCES).  forces: torques(detail=True)'s (flank, n, F_n, F_t) per carrying pair."""
        ca, sa = math.cos(self.g.alpha_w), math.sin(self.g.alpha_w)
        fx = fy = 0.0
        for flank, _n, Fn, Ft in forces:
            if flank == 1:      # n_f = (sin aw, -cos aw), tangent (cos aw, sin aw)
                fx += Fn * sa + Ft * ca
                fy += -Fn * ca + Ft * sa
            else:               # n_b = (sin aw, cos aw), tangent (-cos aw, sin aw)
                fx += Fn * sa - Ft * ca
                fy += Fn * ca + Ft * sa
        fy *= self.s            # the paper frame is mirrored when sigma_A = +1 (s = -1)
        cb, sb = math.cos(self.beta_frame), math.sin(self.beta_frame)
        return np.array([cb * fx - sb * fy, sb * fx + cb * fy])

    def k_mesh(self, ms):
        """Lumped mesh output k_mesh: the sum of k_eff over the flanks in contact."""
        return sum(self.k_eff(len(ks)) for ks in (ms.kf, ms.kb) if ks)

    def elastic_energy(self, dte, ms):
        g = self.g
        if self.lumped:     # k_eff delta^2 / 2 per flank in contact
            return sum(0.5 * self.k_eff(len(ks)) * d * d
                       for ks, d in ((ms.kf, dte), (ms.kb, -g.backlash - dte)) if ks)
        U = 0.0
        if ms.kf:
            U += len(ms.kf) * pair_energy(self, dte)
        if ms.kb:
            U += len(ms.kb) * pair_energy(self, -g.backlash - dte)
        return U


_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)


def johnson_energy_fixed_rho(delta, rho, E_star):
    """int_0^delta N(s; rho) ds at FIXED rho_A + rho_B = rho, in closed form [J/m].

    With x = e s/(4 rho), y = e N/(4 pi E* rho) and y ln y = -x: dx = -(ln y + 1) dy, so
    int_0^X y dx = Y^2 (-2 ln Y - 1)/4 (its X-derivative is Y), and with t = -ln Y
    (johnson_t) the integral is (4 pi E* rho^2/e^2) Y^2 (2 t - 1)."""
    X = G.E_NUM * delta / (4.0 * rho)
    t = G.johnson_t(X)
    Y = X / t
    return 4.0 * math.pi * E_star * rho * rho / G.E_NUM ** 2 * Y * Y * (2.0 * t - 1.0)


def pair_energy(mesh, delta):
    """width * int_0^delta N(s; rho = L + s) ds [J] (0 for delta <= 0): the closed form at
    rho = L + delta plus the correction int_0^delta [N(s; L + s) - N(s; L + delta)] ds, of
    relative size ~delta/L.  Its integrand behaves like N ~ s/ln(1/s) at s = 0; the substitution
    s = delta u^2 smooths that, and 12-point Gauss-Legendre then agrees with adaptive quadrature
    (epsrel 1e-13) to a few 1e-15 relative for delta <= 1e-5 m and 3e-13 at 1e-3 m
    (test_train_ref.py), at 1/20 of its cost."""
    if delta <= 0.0:
        return 0.0
    g = mesh.g
    kap = g.kappa        # internal mesh: rho(s) = L - s
    rho = g.L + kap * delta
    main = johnson_energy_fixed_rho(delta, rho, g.E_star)
    corr = 0.0
    for xi, wi in zip(_GL_X, _GL_W):     # s = delta u^2, u in (0, 1): ds = 2 delta u du
        u = 0.5 * (xi + 1.0)
        s_ = delta * u * u
        corr += wi * u * (G.johnson_N(s_, g.L + kap * s_, g.E_star) - G.johnson_N(s_, rho, g.E_star))
    return mesh.width * (main + delta * corr)


def pair_energy_quad(mesh, delta):
    """The same by adaptive quadrature (slow; for the test of pair_energy)."""
    if delta <= 0.0:
        return 0.0
    g = mesh.g
    val, _ = quad(lambda s: G.johnson_N(s, g.L + g.kappa * s, g.E_star), 0.0, delta,
                  epsabs=0.0, epsrel=1e-13, limit=200)
    return mesh.width * val


def _rot(angle, v):
    """The vector v turned counter-clockwise by angle."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def reduce_angle(psi, z):
    """psi - k 2pi/z in (-pi/z, pi/z]."""
    P = 2.0 * math.pi / z
    r = psi - P * round(psi / P)
    if r <= -P / 2:
        r += P
    elif r > P / 2:
        r -= P
    return r


# --------------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------------

@dataclass
class Result:
    names: list
    table: np.ndarray      # grid rows + two rows (before, after) at each event, time-sorted
    events: list           # (t, y, cfg_before, cfg_after), merged per instant
    n_restarts: int
    n_missed: int = 0
    n_hidden: int = 0
    train: "GearTrain" = None

    def column(self, name):
        return self.table[:, self.names.index(name)]

    def grid(self):
        t = self.table[:, 0]
        keep = np.ones(len(t), bool)
        keep[1:] = t[1:] != t[:-1]
        keep[:-1] &= t[:-1] != t[1:]
        return self.table[keep]

    def pair_changes(self):
        """Per event and mesh, the pairs that started or stopped carrying:
        (t, m, flank, n_A, +1 entering / -1 leaving, s_A, on_before, on_after)."""
        tr = self.train
        out = []
        for t, y, cb, ca in self.events:
            th = tr.T @ y[:tr.n]
            for mesh, b, a in zip(tr.meshes, cb.meshes, ca.meshes):
                uA = mesh.g.rAb * (tr._rel(mesh, th)[0] if tr.general else th[mesh.A])
                for flank, kb_, ka_, on_b, on_a in ((1, b.kf, a.kf, b.on_f, a.on_f),
                                                    (-1, b.kb, a.kb, b.on_b, a.on_b)):
                    sA = mesh.sA_f if flank == 1 else mesh.sA_b
                    for n in sorted(set(ka_) - set(kb_)):
                        out.append((t, mesh.m, flank, n, +1, sA(uA, n), on_b, on_a))
                    for n in sorted(set(kb_) - set(ka_)):
                        out.append((t, mesh.m, flank, n, -1, sA(uA, n), on_b, on_a))
        return out

    def write_csv(self, path):
        write_table_csv(path, self.names, self.table)


def write_table_csv(path, names, table):
    ints = {i for i, n in enumerate(names) if n.endswith(".n_fwd") or n.endswith(".n_bwd")}
    with open(path, "w", newline="") as f:
        f.write(",".join(f'"{n}"' for n in names) + "\n")
        for row in table:
            f.write(",".join(str(int(round(v))) if i in ints else f"{v:.15g}"
                             for i, v in enumerate(row)) + "\n")


read_table_csv = G.read_table_csv


# --------------------------------------------------------------------------------------------
# The train
# --------------------------------------------------------------------------------------------

class GearTrain:
    TOL_DELTA = G.GearMesh.TOL_DELTA
    TOL_POS = G.GearMesh.TOL_POS
    TOL_REL = G.GearMesh.TOL_REL
    _side = G.GearMesh._side          # tie rule: the single reference's, unchanged
    check_assembly = True             # False only for scene design (a mount angle search)

    def __init__(self, start_values: dict | None = None):
        self.p = p = make_train_params(start_values)
        nb, ns, nm = p["n_bodies"], p["n_shafts"], p["n_meshes"]
        self._check_counts(nb, ns, nm)
        self.nb, self.ns, self.nm = nb, ns, nm
        self.bodies = [Body(p[f"body[{i}].J"], p[f"body[{i}].c"], p[f"body[{i}].w_start"],
                            p[f"body[{i}].tau"], (p[f"body[{i}].tau_ripple"], p[f"body[{i}].ripple_order"],
                                                  p[f"body[{i}].ripple_phase"]),
                            p[f"body[{i}].carrier"], p[f"body[{i}].orbit_angle"], p[f"body[{i}].m"],
                            p[f"body[{i}].pin_error_r"], p[f"body[{i}].pin_error_t"])
                       for i in range(1, nb + 1)]
        # the angle-locked ripples in use: (body index, amplitude, order, phase)
        self.ripples = [(i, *b.ripple) for i, b in enumerate(self.bodies) if b.ripple[0] != 0.0]
        for i, b in enumerate(self.bodies, 1):
            if not (b.J > 0.0 and math.isfinite(b.J)):
                raise ValueError(f"body[{i}].J = {b.J!r} must be > 0")
            if not b.c >= 0.0:
                raise ValueError(f"body[{i}].c = {b.c!r} must be >= 0")
        self.H = nb                           # the housing (body 0) as a 0-based index
        self.edges = self._edges()            # (name, a, b) 0-based, meshes first
        # GENERAL mode (planetary.md sections 3-4): the housing named, a carrier, or a loop.
        # Otherwise the tree code below runs exactly as before (bit-identical traces).
        self.general = (any(self.H in (a, b) for _n, a, b in self.edges)
                        or any(b.carrier != 0 for b in self.bodies) or _has_cycle(nb, self.edges))
        if not self.general:
            self._check_topology()
        self.shafts = []
        for j in range(1, ns + 1):
            _nm_, sa, sb = self.edges[nm + j - 1]
            s = Shaft(j, sa, sb, p[f"shaft[{j}].k"], p[f"shaft[{j}].d"], p[f"shaft[{j}].twist_start"])
            if not (s.k > 0.0 and math.isfinite(s.k)):
                raise ValueError(f"shaft[{j}].k = {s.k!r} must be > 0")
            if not s.d >= 0.0:
                raise ValueError(f"shaft[{j}].d = {s.d!r} must be >= 0")
            self.shafts.append(s)
        self.meshes = [self._make_mesh(m) for m in range(1, nm + 1)]
        self.J = np.array([b.J for b in self.bodies])
        if self.general:
            self._setup_general()
        else:
            self._build_tree()
            self._place()
        self.n = nb                           # position coordinates: theta_1 + n_b - 1 edges

    # ---------------------------------------------------------------- validation
    @staticmethod
    def _check_counts(nb, ns, nm):
        bad = []
        if isinstance(nb, bool) or not 1 <= nb <= CAPACITY["body"]:
            bad.append(f"n_bodies = {nb} (1..{CAPACITY['body']})")
        if not 0 <= ns <= CAPACITY["shaft"]:
            bad.append(f"n_shafts = {ns} (0..{CAPACITY['shaft']})")
        if not 0 <= nm <= CAPACITY["mesh"]:
            bad.append(f"n_meshes = {nm} (0..{CAPACITY['mesh']})")
        if bad:
            raise ValueError("element counts out of range: " + ", ".join(bad))

    def _edges(self):
        p, out = self.p, []
        for m in range(1, self.p["n_meshes"] + 1):
            out.append((f"mesh[{m}]", p[f"mesh[{m}].A"], p[f"mesh[{m}].B"], "A", "B"))
        for j in range(1, self.p["n_shafts"] + 1):
            out.append((f"shaft[{j}]", p[f"shaft[{j}].a"], p[f"shaft[{j}].b"], "a", "b"))
        bad = []
        for name, a, b, la, lb in out:
            for lab, v in ((la, a), (lb, b)):
                if not 0 <= v <= self.nb:
                    bad.append(f"{name}.{lab} = {v} is not a body index in 0..{self.nb} "
                               "(0 = the housing)")
            if a == b:
                what = "the housing" if a == 0 else f"body[{a}]"
                bad.append(f"{name} joins {what} to itself ({name}.{la} = {name}.{lb} = {a})")
        if bad:
            raise ValueError("invalid train topology: " + "; ".join(bad))
        # 0-based body indices; the housing (0) becomes self.H = n_bodies
        return [(name, (a - 1) if a else self.H, (b - 1) if b else self.H)
                for name, a, b, _la, _lb in out]

    def _check_topology(self):
        """Tree: no cycle, every body connected to body 1.  Names the elements."""
        adj = {i: [] for i in range(self.nb)}
        problems = []
        for name, a, b in self.edges:
            path = _tree_path(adj, a, b)
            if path is not None:
                cyc = path + [name]
                problems.append("cycle through " + ", ".join(cyc) +
                                " (a cycle over-constrains rigid rotation; planetary sets are out of scope)")
            else:
                adj[a].append((b, name))
                adj[b].append((a, name))
        seen = {0}
        todo = deque([0])
        while todo:
            i = todo.popleft()
            for j, _ in adj[i]:
                if j not in seen:
                    seen.add(j)
                    todo.append(j)
        lost = [f"body[{i + 1}]" for i in range(self.nb) if i not in seen]
        if lost:
            problems.append(", ".join(lost) + " not connected to body[1] by shafts or meshes")
        if problems:
            raise ValueError("the train is not a tree: " + "; ".join(problems))

    def _make_mesh(self, m, cde=None, beta=None):
        """cde, beta: a mesh in a carrier's frame gets its centre distance error (relative to
        its nominal distance) and direction from the planets' positions (_setup_general)."""
        p = self.p
        sv = {k: p[f"mesh[{m}].{k}"] for k in MESH_PAIR_KEYS}
        if cde is not None:
            sv["center_distance_error"] = cde
        mp = G.make_params(sv)
        cm = mp["contact_model"]
        if mp["internal"] and cm == 3:
            raise ValueError(f"mesh[{m}]: contact_model = 3 (tooth structure) is not available yet "
                             "for an internal mesh (planetary.md section 1)")
        if cm == 2:
            raise ValueError(f"mesh[{m}].contact_model = 2: rigid contact is not available in a "
                             "gear train (gear-train.md section 1); use 1 (Johnson) or 3")
        if cm == 4:
            # the lumped mesh (lateral.md section 4): its refusals (ValueError) in lumped_ref
            from . import lumped_ref as LR
            LR.check_lumped_params(mp, f"mesh[{m}]: ")
        elif cm == 3 or D.deviations_active(mp):
            raise NotImplementedError(f"mesh[{m}]: contact model 3 and shape deviations are not "
                                      "implemented in the train reference (contact models 1 and 4)")
        elif cm != 1:
            raise ValueError(f"mesh[{m}].contact_model = {cm}: must be 1, 3 or 4")
        try:
            _nm_, A, B = self.edges[m - 1]
            return TrainMesh(m, mp, A, B,
                             p[f"mesh[{m}].center_angle"] if beta is None else beta,
                             p[f"mesh[{m}].mount_A"], p[f"mesh[{m}].mount_B"])
        except G.GeometryError as e:
            raise G.GeometryError(f"mesh[{m}]: {e}") from None

    # ---------------------------------------------------------------- general mode
    # planetary.md sections 3-4 with the decisions agreed with the Rust side (module docstring,
    # PLANETARY TRAINS).  Indices are 0-based; self.H = n_bodies is the housing (body 0).
    def _body_name(self, i):
        return "the housing (body 0)" if i == self.H else f"body[{i + 1}]"

    def _setup_general(self):
        nb, nm, H = self.nb, self.nm, self.H
        bodies = self.bodies
        # ---- carriers
        bad = []
        self.carrier_of = [None] * nb            # 0-based carrier of each planet
        for i, b in enumerate(bodies):
            c = b.carrier
            if c == 0:
                continue
            if not 1 <= c <= nb:
                bad.append(f"body[{i + 1}].carrier = {c} is not a body index in 0..{nb}")
            elif c == i + 1:
                bad.append(f"body[{i + 1}].carrier = {c}: a body cannot carry itself")
            elif bodies[c - 1].carrier != 0:
                bad.append(f"body[{i + 1}].carrier = {c}: body[{c}] is itself carried (by "
                           f"body[{bodies[c - 1].carrier}]); a carrier turns about a housing-fixed axis")
            else:
                self.carrier_of[i] = c - 1
        if bad:
            raise ValueError("invalid train topology: " + "; ".join(bad))
        self.carriers = sorted({c for c in self.carrier_of if c is not None})
        planet = lambda i: i != H and self.carrier_of[i] is not None
        # ---- each mesh's frame: the carrier of its planet(s), or the housing (None)
        frames = []
        for mesh in self.meshes:
            A, B = mesh.A, mesh.B
            cA = self.carrier_of[A] if planet(A) else None
            cB = self.carrier_of[B] if planet(B) else None
            if cA is not None and cB is not None and cA != cB:
                bad.append(f"mesh[{mesh.m}] joins {self._body_name(A)} (a planet of body[{cA + 1}]) "
                           f"to {self._body_name(B)} (a planet of body[{cB + 1}])")
            c = cA if cA is not None else cB
            for X in (A, B):
                if c is not None and X == c:
                    bad.append(f"mesh[{mesh.m}] joins a planet to its own carrier body[{c + 1}]")
            if c is not None and self.p[f"mesh[{mesh.m}].center_angle"] != 0.0:
                bad.append(f"mesh[{mesh.m}].center_angle = {self.p[f'mesh[{mesh.m}].center_angle']!r}: "
                           f"a mesh in the frame of carrier body[{c + 1}] takes its direction from "
                           "the planets' positions; center_angle must be 0")
            frames.append(c)
        meshed = {X for mesh in self.meshes for X in (mesh.A, mesh.B)}
        for i in range(nb):
            if planet(i) and i not in meshed:
                bad.append(f"body[{i + 1}] is a planet of body[{self.carrier_of[i] + 1}] with no mesh")
        if bad:
            raise ValueError("invalid train topology: " + "; ".join(bad))
        # ---- connectivity over meshes, shafts and carrier ties
        housing_named = any(H in (a, b) for _n, a, b in self.edges)
        adj = {i: set() for i in range(nb + 1)}
        for _n, a, b in self.edges:
            adj[a].add(b)
            adj[b].add(a)
        for i in range(nb):
            if planet(i):
                adj[i].add(self.carrier_of[i])
                adj[self.carrier_of[i]].add(i)
        root = H if housing_named else 0
        seen, todo = {root}, deque([root])
        while todo:
            i = todo.popleft()
            for j in adj[i]:
                if j not in seen:
                    seen.add(j)
                    todo.append(j)
        lost = [f"body[{i + 1}]" for i in range(nb) if i not in seen]
        if lost:
            raise ValueError("invalid train topology: " + ", ".join(lost) + " not connected to the "
                             "rest by a mesh, a shaft or a carrier tie")
        # ---- forward senses: walks over meshes and shafts, never through the housing
        sig = [0] * nb
        nbr = {i: [] for i in range(nb)}
        for k, (name, a, b) in enumerate(self.edges):
            if H in (a, b):
                continue
            keep = k >= nm or self.meshes[k].internal
            nbr[a].append((b, keep, name))
            nbr[b].append((a, keep, name))
        up = [None] * nb                 # (parent body, edge name) of the walk

        def chain(i):
            out = [(i, None)]
            while up[i] is not None:
                i, nm_ = up[i]
                out[-1] = (out[-1][0], nm_)
                out.append((i, None))
            return out
        for start in range(nb):
            if sig[start]:
                continue
            sig[start] = -1
            todo = deque([start])
            while todo:
                i = todo.popleft()
                for j, keep, name in nbr[i]:
                    want = sig[i] if keep else -sig[i]
                    if sig[j] == 0:
                        sig[j] = want
                        up[j] = (i, name)
                        todo.append(j)
                    elif sig[j] != want:
                        ci, cj = chain(i), chain(j)
                        common = {b for b, _ in ci} & {b for b, _ in cj}
                        loop = ([e for b, e in ci if b not in common]
                                + [e for b, e in cj if b not in common][::-1] + [name])
                        raise ValueError(
                            "invalid train topology: conflicting forward senses around the loop "
                            "through " + ", ".join(loop) + " (an external mesh flips the sense, an "
                            "internal mesh and a shaft keep it): the train cannot turn")
        self.sigma = sig
        for mesh, c in zip(self.meshes, frames):
            if mesh.A == H:      # a fixed external gear: the sense the mesh gives from B
                sA = sig[mesh.B] if mesh.internal else -sig[mesh.B]
                sB = sig[mesh.B]
            elif mesh.B == H:
                sA = sig[mesh.A]
                sB = sig[mesh.A] if mesh.internal else -sig[mesh.A]
            else:
                sA, sB = sig[mesh.A], sig[mesh.B]
            mesh.sgA, mesh.sgB = sA, sB
        for s_ in self.shafts:
            s_.sg = sig[s_.b] if s_.a == H else sig[s_.a]
            if H not in (s_.a, s_.b) and sig[s_.a] != sig[s_.b]:
                raise RuntimeError(f"shaft[{s_.j}] joins bodies of opposite senses")
        # ---- planets: orbit radius (nominal operating distance of the lowest-index mesh with
        # a central member), positions in the carrier frame, meshes rebuilt at those distances
        self.R = [0.0] * nb
        for i in range(nb):
            if not planet(i):
                continue
            for mesh in self.meshes:
                if i in (mesh.A, mesh.B):
                    other = mesh.B if i == mesh.A else mesh.A
                    if not planet(other):
                        self.R[i] = mesh.g.d_nominal
                        break
            else:
                raise ValueError(f"invalid train topology: body[{i + 1}], a planet of "
                                 f"body[{self.carrier_of[i] + 1}], meshes with no central member "
                                 "(its orbit radius is undefined)")
        for k, c in enumerate(frames):
            mesh = self.meshes[k]
            if c is None:
                mesh.carrier = None
                continue
            A, B = mesh.A, mesh.B
            if planet(A) and planet(B):
                OA, OB = self.planet_position(A), self.planet_position(B)
                dx, dy = OB[0] - OA[0], OB[1] - OA[1]
                dist, beta = math.hypot(dx, dy), math.atan2(dy, dx)
            else:
                P = B if planet(B) else A
                b = bodies[P]
                rad = self.R[P] + b.pin_r
                # polar form about the planet's own ray: exactly R with no pin error
                dist = math.hypot(rad, b.pin_t)
                beta = b.orbit + math.atan2(b.pin_t, rad) + (0.0 if P == B else math.pi)
            cde_user = self.p[f"mesh[{mesh.m}].center_distance_error"]
            cde = (dist - mesh.g.d_nominal) + cde_user
            new = self._make_mesh(mesh.m, cde=cde, beta=beta)
            new.sgA, new.sgB = mesh.sgA, mesh.sgB
            new.carrier = c
            new.dist_from_positions = dist
            self.meshes[k] = new
        for mesh in self.meshes:
            mesh.s = -mesh.sgA                         # paper frame: mirrored when sigma_A = +1
            if mesh.carrier is not None:
                sc = sig[mesh.carrier]
                mesh.kA, mesh.kB = mesh.sgA * sc, mesh.sgB * sc
        # orbital inertia on the carriers
        self.J_orbit = np.zeros(nb)
        for i in range(nb):
            if planet(i):
                self.J_orbit[self.carrier_of[i]] += bodies[i].mass * self.R[i] ** 2
        self.J = self.J + self.J_orbit
        self._place_general(root)
        self._coordinates_general()

    def planet_position(self, i):
        """Planet i's axis in its carrier's frame (planetary.md section 3)."""
        b = self.bodies[i]
        ph = b.orbit
        rad = self.R[i] + b.pin_r
        return (rad * math.cos(ph) - b.pin_t * math.sin(ph), rad * math.sin(ph) + b.pin_t * math.cos(ph))

    def _place_general(self, root):
        """Breadth-first placement (planetary.md section 4 with the agreed queue)."""
        nb, nm, H = self.nb, self.nm, self.H
        psi = [None] * (nb + 1)
        psi[H] = 0.0
        for c in self.carriers:
            psi[c] = 0.0
        if root == 0 and psi[0] is None:
            psi[0] = self.p["body[1].angle_start"]
        queue = deque([root] + [c for c in self.carriers if c != root])
        placing = []                     # edge indices in placement order
        self.parent = [None] * nb
        while queue:
            i = queue.popleft()
            for k, mesh in enumerate(self.meshes):
                if i not in (mesh.A, mesh.B):
                    continue
                j = mesh.B if i == mesh.A else mesh.A
                if psi[j] is not None:
                    continue
                psi[j] = mesh.place_other(psi[i], known_is_A=(i == mesh.A))
                self.parent[j] = (k, i)
                placing.append(k)
                queue.append(j)
            for s_ in self.shafts:
                if i not in (s_.a, s_.b):
                    continue
                j = s_.b if i == s_.a else s_.a
                if psi[j] is not None:
                    continue
                tw = s_.twist0
                psi[j] = psi[i] - s_.sg * tw if i == s_.a else psi[i] + s_.sg * tw
                self.parent[j] = (nm + s_.j - 1, i)
                placing.append(nm + s_.j - 1)
                queue.append(j)
        if any(v is None for v in psi):
            raise RuntimeError("placement did not reach every body")
        self.psi0 = psi[:nb]
        self.placing = placing
        placed_by = set(placing)
        for s_ in self.shafts:       # a shaft closing a loop: its twist from the placed angles
            if nm + s_.j - 1 not in placed_by:
                s_.twist0 = s_.sg * (psi[s_.a] - psi[s_.b])
        for k, mesh in enumerate(self.meshes):
            if k in placed_by:
                mesh.loop = False
                mesh.set_offsets(psi[mesh.A], psi[mesh.B])
            else:
                mesh.loop = True
                mesh.set_offsets_loop(psi[mesh.A], psi[mesh.B], self)

    def _rel_row(self, X, k, c):
        """Row over the bodies of theta_X relative to carrier c (k = sigma_X sigma_c)."""
        row = np.zeros(self.nb)
        if X != self.H:
            row[X] = 1.0
        if c is not None:
            row[c] -= k
        return row

    def _coordinates_general(self):
        """x = [theta of the free bodies (ascending index), coordinates of the independent
        edges (index order: meshes, then shafts)]; theta = T x.  The placing edges are
        independent (each brings in a new body); a loop edge becomes a coordinate only if it
        raises the rank.  The other loop meshes' e = ce . x over edge coordinates only (their
        coefficients on the free bodies vanish analytically and are set to 0), so every dte keeps
        the precision of a few 1e-16 m however far the bodies turn (planetary.md section 4)."""
        nb, nm, H = self.nb, self.nm, self.H
        rows = []
        for mesh in self.meshes:
            c = mesh.carrier
            kA = mesh.kA if c is not None else 0.0
            kB = mesh.kB if c is not None else 0.0
            mesh.rowA = self._rel_row(mesh.A, kA, c)
            mesh.rowB = self._rel_row(mesh.B, kB, c)
            rows.append(mesh.g.rAb * mesh.rowA - mesh.g.rBb * mesh.rowB)
        for s_ in self.shafts:
            r = np.zeros(nb)
            if s_.a != H:
                r[s_.a] += 1.0
            if s_.b != H:
                r[s_.b] -= 1.0
            rows.append(r)
        Eall = np.array(rows).reshape(len(rows), nb)
        self.E_all = Eall
        norm = lambda r: r / max(np.max(np.abs(r)), 1e-300)

        def rank(M):
            if len(M) == 0:
                return 0
            sv = np.linalg.svd(np.array([norm(r) for r in M]), compute_uv=False)
            return int(np.sum(sv > 1e-9 * sv[0]))
        indep = []
        for k in self.placing:
            if rank([Eall[q] for q in indep + [k]]) != len(indep) + 1:
                raise RuntimeError(f"placing edge {self.edges[k][0]} is not independent")
            indep.append(k)
        for k in range(len(self.edges)):
            if k not in indep and rank([Eall[q] for q in indep + [k]]) == len(indep) + 1:
                indep.append(k)
        indep.sort()
        free = []
        for i in range(nb):
            cand = [Eall[q] for q in indep] + [np.eye(nb)[f] for f in free + [i]]
            if rank(cand) == len(cand):
                free.append(i)
        if len(free) + len(indep) != nb:
            raise RuntimeError("coordinates: no basis")
        # jammed bodies: no rigid rolling motion of the meshes (shafts absent) turns them
        if nm:
            Em = np.array([norm(Eall[k]) for k in range(nm)])
            _u, sv, vt = np.linalg.svd(Em)
            r = int(np.sum(sv > 1e-9 * sv[0])) if len(sv) else 0
            null = vt[r:]
            jam = [f"body[{i + 1}]" for i in range(nb)
                   if null.shape[0] == 0 or np.max(np.abs(null[:, i])) < 1e-9]
            if jam:
                raise ValueError("invalid train topology: jammed: no rigid rolling motion of the "
                                 "meshes lets " + ", ".join(jam) + " turn")
        self.free, self.indep = free, indep
        E = np.zeros((nb, nb))
        for r_, f in enumerate(free):
            E[r_, f] = 1.0
        col = {}
        for r_, k in enumerate(indep):
            E[len(free) + r_] = Eall[k]
            col[k] = len(free) + r_
        T = np.linalg.inv(E)
        if not np.allclose(E @ T, np.eye(nb), rtol=0, atol=1e-9):
            raise RuntimeError("coordinates: E T != I")
        self.T, self.E = T, E
        nf = len(free)
        for k, mesh in enumerate(self.meshes):
            mesh.cA = mesh.g.rAb * (mesh.rowA @ T)
            mesh.cB = mesh.g.rBb * (mesh.rowB @ T)
            if k in col:
                mesh.ie = col[k]
                mesh.ce = np.eye(nb)[col[k]]
            else:
                mesh.ie = None
                ce = Eall[k] @ T
                scale = mesh.g.rAb + mesh.g.rBb
                if nf and np.max(np.abs(ce[:nf])) > 1e-9 * scale:
                    raise RuntimeError(f"mesh[{mesh.m}]: loop coordinate depends on a free body")
                ce[:nf] = 0.0
                mesh.ce = ce
        for s_ in self.shafts:
            k = nm + s_.j - 1
            s_.iq = col.get(k)
            if s_.iq is None:        # a shaft closing a loop: q = cq . x
                cq = Eall[k] @ T
                if nf and np.max(np.abs(cq[:nf])) > 1e-9:
                    raise RuntimeError(f"shaft[{s_.j}]: loop coordinate depends on a free body")
                cq[:nf] = 0.0
                s_.cq = cq
            else:
                s_.cq = np.eye(nb)[s_.iq]
        self.order = list(range(nb))

    # ---------------------------------------------------------------- tree coordinates
    def _build_tree(self):
        """BFS from body 1: senses sigma, parent edges, theta = T x, x = E theta."""
        nb = self.nb
        self.sigma = [0] * nb
        self.sigma[0] = -1
        self.order = [0]
        self.parent = [None] * nb        # (edge index, parent body)
        adj = {i: [] for i in range(nb)}
        for k, (_name, a, b) in enumerate(self.edges):
            adj[a].append((k, b))
            adj[b].append((k, a))
        todo = deque([0])
        while todo:
            i = todo.popleft()
            for k, j in adj[i]:
                if j == 0 or self.parent[j] is not None:
                    continue
                self.parent[j] = (k, i)
                # an external mesh flips the sense; an internal mesh and a shaft keep it
                flips = k < self.nm and not self.meshes[k].internal
                self.sigma[j] = -self.sigma[i] if flips else self.sigma[i]
                self.order.append(j)
                todo.append(j)
        T = np.zeros((nb, nb))
        T[0, 0] = 1.0
        E = np.zeros((nb, nb))
        E[0, 0] = 1.0
        for k, (_name, a, b) in enumerate(self.edges):
            if k < self.nm:
                g = self.meshes[k].g
                E[k + 1, a], E[k + 1, b] = g.rAb, -g.rBb       # e = rAb thA - rBb thB
            else:
                E[k + 1, a], E[k + 1, b] = 1.0, -1.0           # q = tha - thb
        for j in self.order[1:]:
            k, i = self.parent[j]
            unit = np.zeros(nb)
            unit[k + 1] = 1.0
            _name, a, b = self.edges[k]
            if k < self.nm:
                g = self.meshes[k].g
                T[j] = (g.rAb * T[i] - unit) / g.rBb if j == b else (unit + g.rBb * T[i]) / g.rAb
            else:
                T[j] = T[i] - unit if j == b else T[i] + unit
        if not np.allclose(E @ T, np.eye(nb), rtol=0, atol=1e-12):
            raise RuntimeError("tree coordinates: E T != I")
        self.T, self.E = T, E
        for mesh in self.meshes:
            mesh.s = -self.sigma[mesh.A]                # paper frame: mirrored when sigma_A = +1
            mesh.ie = self.meshes.index(mesh) + 1       # its edge coordinate's index in x
            mesh.cA = mesh.g.rAb * T[mesh.A]            # u_A = cA . x
            mesh.cB = mesh.g.rBb * T[mesh.B]
        for s in self.shafts:
            s.iq = self.nm + s.j                        # index of q_j in x
            if self.sigma[s.a] != self.sigma[s.b]:      # impossible in a tree (spec section 2)
                raise RuntimeError(f"shaft[{s.j}] joins bodies of opposite senses")

    def _place(self):
        """psi_i(0) by walking the tree from body 1 (spec section 4)."""
        psi = [None] * self.nb
        psi[0] = self.p["body[1].angle_start"]
        for j in self.order[1:]:
            k, i = self.parent[j]
            if k < self.nm:
                mesh = self.meshes[k]
                psi[j] = mesh.place_other(psi[i], known_is_A=(i == mesh.A))
            else:
                s = self.shafts[k - self.nm]
                tw = s.twist0
                psi[j] = psi[i] - self.sigma[s.a] * tw if i == s.a else psi[i] + self.sigma[s.a] * tw
        self.psi0 = psi
        for mesh in self.meshes:
            mesh.set_offsets(psi[mesh.A], psi[mesh.B])

    def initial_state(self):
        w = np.array([b.w0 for b in self.bodies])
        xd = self.E @ w
        return np.concatenate([np.zeros(self.n), xd, [0.0, 0.0]])

    # ---------------------------------------------------------------- general-mode dynamics
    def _e(self, mesh, x):
        """The mesh coordinate e = rAb theta_A_rel - rBb theta_B_rel (dte = e + dte0)."""
        return x[mesh.ie] if mesh.ie is not None else float(np.dot(mesh.ce, x))

    def _q(self, s_, x):
        return x[s_.iq] if s_.iq is not None else float(np.dot(s_.cq, x))

    def _rel(self, mesh, v):
        """(A, B) relative to the mesh's frame of a body vector v (angles, speeds or
        accelerations; the housing's entry is 0)."""
        A, B = mesh.A, mesh.B
        va = v[A] if A != self.H else 0.0
        vb = v[B] if B != self.H else 0.0
        if mesh.carrier is not None:
            vc = v[mesh.carrier]
            va -= mesh.kA * vc
            vb -= mesh.kB * vc
        return va, vb

    def _apply_mesh(self, Q, mesh, mA, mB):
        """Adds the mesh's forward torques to its bodies and the carrier's reaction; returns the
        absolute (counter-clockwise) torque on the housing."""
        A, B, H = mesh.A, mesh.B, self.H
        hous = 0.0
        if A != H:
            Q[A] += mA
        else:
            hous += mesh.sgA * mA
        if B != H:
            Q[B] += mB
        else:
            hous += mesh.sgB * mB
        if mesh.carrier is not None:
            c = mesh.carrier
            Q[c] -= self.sigma[c] * (mesh.sgA * mA + mesh.sgB * mB)
        return hous

    def _drag(self, w):
        """Drag torques (forward) and their power: a planet's drag acts on its speed relative to
        its carrier, the carrier takes the reaction."""
        Q = np.zeros(self.nb)
        P = 0.0
        for i, b in enumerate(self.bodies):
            if b.c == 0.0:
                continue
            c = self.carrier_of[i]
            if c is None:
                Q[i] -= b.c * w[i]
                P -= b.c * w[i] * w[i]
            else:
                k = self.sigma[i] * self.sigma[c]
                wr = w[i] - k * w[c]
                Q[i] -= b.c * wr
                Q[c] += k * b.c * wr
                P -= b.c * wr * wr
        return Q, P

    def _forces_general(self, x, xd, tau, kfkb, detail=False):
        """Generalized forces (forward), power lost, housing torque."""
        th, w = self.T @ x, self.T @ xd
        tau = self.with_ripples(tau, th)
        Qd, Pd = self._drag(w)
        Q = tau + Qd
        pl = 0.0
        hous = 0.0
        for mesh, (kf, kb) in zip(self.meshes, kfkb):
            if kf or kb:
                thA, _thB = self._rel(mesh, th)
                wA, wB = self._rel(mesh, w)
                e = self._e(mesh, x)
                v = self._e(mesh, xd)
                mA, mB, pp = mesh.torques(mesh.g.rAb * thA, e + mesh.dte0, wA, wB, v, kf, kb)
                hous += self._apply_mesh(Q, mesh, mA, mB)
                pl += pp
        for s_ in self.shafts:
            q, qd = self._q(s_, x), self._q(s_, xd)
            ts = s_.k * (q + s_.twist0) + s_.d * qd
            if s_.a != self.H:
                Q[s_.a] -= ts
            else:
                hous -= s_.sg * ts
            if s_.b != self.H:
                Q[s_.b] += ts
            else:
                hous += s_.sg * ts
            pl += s_.d * qd * qd
        return Q, pl, w, tau, Pd, hous

    def _make_rhs_general(self, cfg, seg):
        n = self.n
        E, J = self.E, self.J
        t0, v0, dv = seg
        kfkb = [(ms.kf, ms.kb) for ms in cfg.meshes]

        def rhs(t, y):
            x, xd = y[:n], y[n:2 * n]
            Q, pl, w, tau, Pd, _h = self._forces_general(x, xd, v0 + dv * (t - t0), kfkb)
            out = np.empty(2 * n + 2)
            out[:n] = xd
            out[n:2 * n] = E @ (Q / J)
            out[2 * n] = float(np.dot(tau, w)) + Pd
            out[2 * n + 1] = pl
            return out
        return rhs

    def _mesh_kin_general(self, mesh, y, acc):
        n = self.n
        x, xd = y[:n], y[n:2 * n]
        th, w = self.T @ x, self.T @ xd
        g = mesh.g
        thA, thB = self._rel(mesh, th)
        wA, wB = self._rel(mesh, w)
        aA, aB = self._rel(mesh, acc)
        return dict(uA=g.rAb * thA, uB=g.rBb * thB, wA=wA, wB=wB, aA=aA, aB=aB,
                    e=self._e(mesh, x) + mesh.dte0, v=self._e(mesh, xd), e2=g.rAb * aA - g.rBb * aB)

    # ---------------------------------------------------------------- dynamics
    def forces(self, t, y, cfg, tau):
        """Generalized torques on the bodies and the power lost, for fixed carrying sets."""
        n = self.n
        if self.general:
            Q, pl, w, _tau, _Pd, _h = self._forces_general(
                y[:n], y[n:2 * n], tau, [(ms.kf, ms.kb) for ms in cfg.meshes])
            return Q, pl, w
        x, xd = y[:n], y[n:2 * n]
        th, w = self.T @ x, self.T @ xd
        Q = self.with_ripples(tau, th) - np.array([b.c for b in self.bodies]) * w
        pl = 0.0
        for mesh, ms in zip(self.meshes, cfg.meshes):
            if ms.kf or ms.kb:
                mA, mB, pp = mesh.torques(mesh.g.rAb * th[mesh.A], x[mesh.ie] + mesh.dte0,
                                          w[mesh.A], w[mesh.B], xd[mesh.ie], ms.kf, ms.kb)
                Q[mesh.A] += mA
                Q[mesh.B] += mB
                pl += pp
        for s in self.shafts:
            ts = s.k * (x[s.iq] + s.twist0) + s.d * xd[s.iq]
            Q[s.a] -= ts
            Q[s.b] += ts
            pl += s.d * xd[s.iq] ** 2
        return Q, pl, w

    def with_ripples(self, tau, th):
        """The bodies' torques with each angle-locked ripple A sin(order theta + phase) added."""
        if not self.ripples:
            return tau
        tau = np.array(tau, dtype=float)
        for i, a, order, phase in self.ripples:
            tau[i] += a * math.sin(order * th[i] + phase)
        return tau

    def make_rhs(self, cfg, seg):
        if self.general:
            return self._make_rhs_general(cfg, seg)
        n = self.n
        T, E = self.T, self.E
        J = np.array([b.J for b in self.bodies])
        c = np.array([b.c for b in self.bodies])
        t0, v0, dv = seg
        active = [(mesh, ms.kf, ms.kb) for mesh, ms in zip(self.meshes, cfg.meshes) if ms.kf or ms.kb]
        shafts = self.shafts
        ripples = self.ripples

        def rhs(t, y):
            x, xd = y[:n], y[n:2 * n]
            w = T @ xd
            th = T @ x if (active or ripples) else None
            tau = self.with_ripples(v0 + dv * (t - t0), th)
            Q = tau - c * w
            pl = 0.0
            if active:
                for mesh, kf, kb in active:
                    A, B = mesh.A, mesh.B
                    mA, mB, pp = mesh.torques(mesh.g.rAb * th[A], x[mesh.ie] + mesh.dte0,
                                              w[A], w[B], xd[mesh.ie], kf, kb)
                    Q[A] += mA
                    Q[B] += mB
                    pl += pp
            for s in shafts:
                ts = s.k * (x[s.iq] + s.twist0) + s.d * xd[s.iq]
                Q[s.a] -= ts
                Q[s.b] += ts
                pl += s.d * xd[s.iq] ** 2
            xdd = E @ (Q / J)
            out = np.empty(2 * n + 2)
            out[:n] = xd
            out[n:2 * n] = xdd
            out[2 * n] = float(np.dot(tau - c * w, w))
            out[2 * n + 1] = pl
            return out
        return rhs

    def accelerations(self, t, y, cfg, tau):
        Q, _pl, _w = self.forces(t, y, cfg, tau)
        return Q / self.J

    # ---------------------------------------------------------------- classification
    def _mesh_kin(self, mesh, y, acc):
        if self.general:
            return self._mesh_kin_general(mesh, y, acc)
        n = self.n
        x, xd = y[:n], y[n:2 * n]
        th, w = self.T @ x, self.T @ xd
        g = mesh.g
        A, B = mesh.A, mesh.B
        return dict(uA=g.rAb * th[A], uB=g.rBb * th[B], wA=w[A], wB=w[B], aA=acc[A], aB=acc[B],
                    e=x[mesh.ie] + mesh.dte0, v=xd[mesh.ie], e2=g.rAb * acc[A] - g.rBb * acc[B])

    def _decide_mesh(self, mesh, k, tie_aware):
        """Carrying pairs of one mesh just after now (k: its kinematics)."""
        if mesh.lumped:
            return self._decide_mesh_lumped(mesh, k, tie_aware)
        g = mesh.g
        rAb, rBb, pb = g.rAb, g.rBb, g.p_b
        uA, uB, wA, wB, aA, aB = k["uA"], k["uB"], k["wA"], k["wB"], k["aA"], k["aB"]
        e, v, e2 = k["e"], k["v"], k["e2"]

        def side(c, c1, c2, tol):
            return self._side(c, c1, c2, tol) if tie_aware else c >= -tol

        on_f = side(e, v, e2, self.TOL_DELTA)
        on_b = mesh.bwd and side(-g.backlash - e, -v, -e2, self.TOL_DELTA)
        sig = {"df": 1.0 if on_f else -1.0}
        if mesh.bwd:
            sig["db"] = 1.0 if on_b else -1.0
        tipB = g.L - g.s_a                      # B's tip on the line of action
        lo_win = g.s_b - g.m_c * pb             # lower end of the tracking window
        kf, kb = [], []
        if on_f:
            rel = True
            if mesh.chi > 0.0:
                rel = side(1.0 + mesh.chi * v, mesh.chi * e2, 0.0, self.TOL_REL)
                sig["rf"] = 1.0 if rel else -1.0
            for n in mesh.candidates(mesh.sA_f(uA, 0), 1):
                sA, sB = mesh.sA_f(uA, n), mesh.sB_f(uB, n)
                ok = (side(g.s_b - sA, -rAb * wA, -rAb * aA, self.TOL_POS)
                      and side(tipB - sB, rBb * wB, rBb * aB, self.TOL_POS))
                if ok and mesh.window_active:
                    ok = side(sA - lo_win, rAb * wA, rAb * aA, self.TOL_POS)
                if ok and rel:
                    kf.append(n)
            sig["uf"] = self._periodic_sign(pb, mesh.sA_f(uA, 0) - g.s_b, rAb * wA, rAb * aA)
            sig["lf"] = self._periodic_sign(pb, mesh.sB_f(uB, -mesh.Kf) - tipB, -rBb * wB, -rBb * aB)
        if on_b:
            rel = True
            if mesh.chi > 0.0:
                rel = side(1.0 - mesh.chi * v, -mesh.chi * e2, 0.0, self.TOL_REL)
                sig["rb"] = 1.0 if rel else -1.0
            for n in mesh.candidates(mesh.sA_b(uA, 0), -1):
                sA, sB = mesh.sA_b(uA, n), mesh.sB_b(uB, n)
                ok = (side(g.s_b - sA, rAb * wA, rAb * aA, self.TOL_POS)
                      and side(tipB - sB, -rBb * wB, -rBb * aB, self.TOL_POS))
                if ok and mesh.window_active:
                    ok = side(sA - lo_win, -rAb * wA, -rAb * aA, self.TOL_POS)
                if ok and rel:
                    kb.append(n)
            sig["ub"] = self._periodic_sign(pb, mesh.sA_b(uA, 0) - g.s_b, -rAb * wA, -rAb * aA)
            sig["lb"] = self._periodic_sign(pb, mesh.sB_b(uB, -mesh.Kb) - tipB, rBb * wB, rBb * aB)
        return MeshState(on_f, on_b, tuple(kf), tuple(kb), sig)

    def _decide_mesh_lumped(self, mesh, k, tie_aware):
        """The lumped mesh: which flanks touch (delta > 0) and, for each, its gated pairs
        s_a <= s_A <= s_b (A's coordinate only; the m_c-pitch window as model 1 when
        contacts_per_flank < eps).  MeshState.kf (kb) = the gated pairs of a flank in contact,
        else empty.  Event signs: df/db the deflections, uf/ub the upper gate edges (as model
        1), lf/lb the lower edges s_A = s_a."""
        g = mesh.g
        rAb, pb = g.rAb, g.p_b
        uA, wA, aA = k["uA"], k["wA"], k["aA"]
        e, v, e2 = k["e"], k["v"], k["e2"]

        def side(c, c1, c2, tol):
            return self._side(c, c1, c2, tol) if tie_aware else c >= -tol

        on_f = side(e, v, e2, self.TOL_DELTA)
        on_b = mesh.bwd and side(-g.backlash - e, -v, -e2, self.TOL_DELTA)
        sig = {"df": 1.0 if on_f else -1.0}
        if mesh.bwd:
            sig["db"] = 1.0 if on_b else -1.0
        lo_win = g.s_b - g.m_c * pb
        out = {}
        for flank, on, sA_of in ((1, on_f, mesh.sA_f), (-1, on_b, mesh.sA_b)):
            ks = []
            if on:
                r1, r2 = flank * rAb * wA, flank * rAb * aA       # d s_A/dt, d2 s_A/dt2
                for n in mesh.candidates(sA_of(uA, 0), flank):
                    sA = sA_of(uA, n)
                    ok = (side(g.s_b - sA, -r1, -r2, self.TOL_POS)
                          and side(sA - g.s_a, r1, r2, self.TOL_POS))
                    if ok and mesh.window_active:
                        ok = side(sA - lo_win, r1, r2, self.TOL_POS)
                    if ok:
                        ks.append(n)
                f = "f" if flank == 1 else "b"
                sig["u" + f] = self._periodic_sign(pb, sA_of(uA, 0) - g.s_b, r1, r2)
                sig["l" + f] = self._periodic_sign(pb, sA_of(uA, 0) - g.s_a, r1, r2)
            out[flank] = tuple(ks)
        return MeshState(on_f, bool(on_b), out[1], out[-1], sig)

    def _periodic_sign(self, pb, xi, xi1, xi2):
        """Sign s such that s sin(pi xi/p_b) >= 0 just after now."""
        n = round(xi / pb)
        r = xi - n * pb
        parity = -1.0 if n % 2 else 1.0
        return parity * (1.0 if self._side(r, xi1, xi2, self.TOL_POS) else -1.0)

    def _decide(self, y, acc, tie_aware=True):
        states = tuple(self._decide_mesh(m, self._mesh_kin(m, y, acc), tie_aware) for m in self.meshes)
        return Config(states, acc)

    def classify(self, t, y, tau):
        """Contact state of every mesh just after a restart: ties are decided by time
        derivatives, which need the accelerations, which depend on the state: iterate from the
        state in which every tie counts as inside (as gearmesh_ref._classify)."""
        prelim = self._decide(y, np.zeros(self.nb), tie_aware=False)
        cfg = self._decide(y, self.accelerations(t, y, prelim, tau))
        for _ in range(6):
            acc = self.accelerations(t, y, cfg, tau)
            new = self._decide(y, acc)
            same = new.key == cfg.key and all(
                a.on_f == b.on_f and a.on_b == b.on_b for a, b in zip(new.meshes, cfg.meshes))
            if same:
                return new
            cfg = new
        return cfg

    # ---------------------------------------------------------------- events
    def make_events(self, cfg, y):
        """Terminal event functions (+ -> -) and non-terminal guards for one segment."""
        n = self.n
        evs = []
        side = self._side

        def add(fn, c, c1, c2, tol, band):
            # shift a function within a hair of zero to the side it moves to (no re-firing)
            after = side(c, c1, c2, tol)
            off = 0.0
            if after and c < band:
                off = band - c
            elif not after and c > -band:
                off = -(band + c)
            if off != 0.0:
                raw = fn
                fn = lambda t, yy: raw(t, yy) + off
            fn.terminal = True
            fn.direction = -1.0
            fn.band = band
            evs.append(fn)

        def add_periodic(pb, sig, coef, c0, xi, xi1, xi2):
            # sig * sin(pi (coef . x + c0)/p_b); xi, xi1, xi2: the argument and its derivatives
            kp = math.pi / pb
            s_, c_ = math.sin(kp * xi), math.cos(kp * xi)
            w1 = kp * xi1
            val, d1, d2 = sig * s_, sig * c_ * w1, sig * (c_ * kp * xi2 - s_ * w1 * w1)
            add(lambda t, yy: sig * math.sin(kp * (float(np.dot(coef, yy[:n])) + c0)),
                val, d1, d2, kp * self.TOL_POS, 1e-12)

        guards = []
        body_guard = set()
        for mesh, ms in zip(self.meshes, cfg.meshes):
            g = mesh.g
            k = self._mesh_kin(mesh, y, cfg.acc)
            ie, d0, jb = mesh.ie, mesh.dte0, g.backlash
            s, pb = ms.sig, g.p_b
            sdf = s["df"]
            if ie is not None:
                ef = lambda yy, ie=ie: yy[ie]
                vf = lambda yy, iv=n + ie: yy[iv]
            else:     # a loop mesh (general mode): e = ce . x over edge coordinates
                ef = lambda yy, ce=mesh.ce: float(np.dot(ce, yy[:n]))
                vf = lambda yy, ce=mesh.ce: float(np.dot(ce, yy[n:2 * n]))
            add(lambda t, yy, sdf=sdf, ef=ef, d0=d0: sdf * (ef(yy) + d0),
                sdf * k["e"], sdf * k["v"], sdf * k["e2"], self.TOL_DELTA, 1e-20)
            if mesh.bwd:
                sdb = s["db"]
                add(lambda t, yy, sdb=sdb, ef=ef, d0=d0, jb=jb: sdb * (-jb - ef(yy) - d0),
                    sdb * (-jb - k["e"]), -sdb * k["v"], -sdb * k["e2"], self.TOL_DELTA, 1e-20)
            tipB = g.L - g.s_a
            rAb, rBb = g.rAb, g.rBb
            if mesh.lumped:
                # lumped mesh: the gate edges s_A = s_b (u) and s_A = s_a (l) of a flank in
                # contact, both on A's coordinate; no release event (F is not clipped)
                for on, f, sgn, S0 in ((ms.on_f, "f", 1.0, mesh.SfA), (ms.on_b, "b", -1.0, mesh.SbA)):
                    if not on:
                        continue
                    for edge, s_edge in (("u", g.s_b), ("l", g.s_a)):
                        add_periodic(pb, s[edge + f], sgn * mesh.cA, S0 - s_edge,
                                     S0 + sgn * k["uA"] - s_edge, sgn * rAb * k["wA"],
                                     sgn * rAb * k["aA"])
            if not mesh.lumped and ms.on_f:
                # s_A(n) - s_b = SfA - s_b + u_A (mod p_b);  s_B(n) - tipB = SfB - tipB - u_B ...
                add_periodic(pb, s["uf"], mesh.cA, mesh.SfA - g.s_b,
                             mesh.sA_f(k["uA"], 0) - g.s_b, rAb * k["wA"], rAb * k["aA"])
                add_periodic(pb, s["lf"], -mesh.cB, mesh.SfB - tipB,
                             mesh.sB_f(k["uB"], -mesh.Kf) - tipB, -rBb * k["wB"], -rBb * k["aB"])
                if mesh.chi > 0.0:
                    srf, chi = s["rf"], mesh.chi
                    add(lambda t, yy, srf=srf, chi=chi, vf=vf: srf * (1.0 + chi * vf(yy)),
                        srf * (1.0 + chi * k["v"]), srf * chi * k["e2"], 0.0, self.TOL_REL, 1e-14)
            if not mesh.lumped and ms.on_b:
                add_periodic(pb, s["ub"], -mesh.cA, mesh.SbA - g.s_b,
                             mesh.sA_b(k["uA"], 0) - g.s_b, -rAb * k["wA"], -rAb * k["aA"])
                add_periodic(pb, s["lb"], mesh.cB, mesh.SbB - tipB,
                             mesh.sB_b(k["uB"], -mesh.Kb) - tipB, rBb * k["wB"], rBb * k["aB"])
                if mesh.chi > 0.0:
                    srb, chi = s["rb"], mesh.chi
                    add(lambda t, yy, srb=srb, chi=chi, vf=vf: srb * (1.0 - chi * vf(yy)),
                        srb * (1.0 - chi * k["v"]), -srb * chi * k["e2"], 0.0, self.TOL_REL, 1e-14)
            guards.append(lambda t, yy, vf=vf: vf(yy))          # extrema of delta
            if self.general:     # reversals of the gate coordinates (relative speeds)
                for c_ in (mesh.cA, mesh.cB):
                    if np.any(c_ != 0.0):
                        guards.append(lambda t, yy, row=c_: float(np.dot(row, yy[n:2 * n])))
            else:
                body_guard.update((mesh.A, mesh.B))
        for i in sorted(body_guard):                          # reversals of gate coordinates
            row = self.T[i]
            guards.append(lambda t, yy, row=row: float(np.dot(row, yy[n:2 * n])))
        for fn in guards:
            fn.terminal = False
            fn.direction = 0.0
        return evs, guards

    @staticmethod
    def _check_guards(sol, t0, evs, n_guard):
        """A contact-state change hidden inside one step straddles a guard root (gearmesh_ref's
        argument: between guard roots each function is monotone).  Returns its time or None."""
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
                    tc = brentq(lambda tt: fn(tt, sol.sol(tt)), t_lo, te, xtol=1e-16,
                                rtol=G.BRENT_RTOL)
                    best = min(best, tc)
            return best
        return None

    # ---------------------------------------------------------------- scales
    def delta_scale(self, mesh, inputs):
        """Characteristic penetration: one pair under the line force of the largest torques
        (sum of the input magnitudes and start drags), at least 1 N of line force."""
        g = mesh.g
        tmax = float(np.sum(inputs.max_abs())) + sum(b.c * abs(b.w0) for b in self.bodies)
        F = max(tmax / min(g.rAb, g.rBb), 1.0)
        if mesh.lumped:
            return F / mesh.k_eff(1)
        return G.johnson_delta(F / mesh.width, g.L, g.E_star)

    def atol(self, inputs, rtol):
        n = self.n
        wscale = max([1.0] + [abs(b.w0) for b in self.bodies])
        tmax = max(1.0, float(np.sum(inputs.max_abs())))
        pos = np.ones(n)
        for mesh in self.meshes:
            if mesh.ie is not None:
                pos[mesh.ie] = self.delta_scale(mesh, inputs)
        for s in self.shafts:
            if s.iq is not None:
                pos[s.iq] = max(tmax / s.k, abs(s.twist0), 1e-12)
        vel = pos * 1e4
        if self.general:
            for r_ in range(len(self.free)):
                vel[r_] = wscale
        else:
            vel[0] = wscale
        return np.concatenate([pos, vel, [1.0, 1.0]]) * rtol

    def max_step(self, cfg, y, span):
        """No gate coordinate moves more than p_b/8 in one step."""
        n = self.n
        w = self.T @ y[n:2 * n]
        acc = cfg.acc
        h = math.inf
        for mesh in self.meshes:
            g = mesh.g
            if self.general:
                wA, wB = self._rel(mesh, w)
                aA, aB = self._rel(mesh, acc)
                vline = (max(abs(g.rAb * wA), abs(g.rBb * wB))
                         + max(abs(g.rAb * aA), abs(g.rBb * aB)) * span)
                h = min(h, g.p_b / (8.0 * vline + 1e-300))
                continue
            vline = (max(abs(g.rAb * w[mesh.A]), abs(g.rBb * w[mesh.B]))
                     + max(abs(g.rAb * acc[mesh.A]), abs(g.rBb * acc[mesh.B])) * span)
            h = min(h, g.p_b / (8.0 * vline + 1e-300))
        return h

    # ---------------------------------------------------------------- main loop
    def simulate(self, stop_time, output_interval, inputs: TrainInputs | None = None,
                 rtol=1e-10, method="DOP853", perturb_w1=0.0, max_restarts=2_000_000,
                 bearing_forces=False):
        """Integrate over [0, stop_time]; sample on k*output_interval and at every event
        (two rows: before, after).  perturb_w1: added to body 1's start speed (only).
        bearing_forces: the outputs also have body[i].Fx, body[i].Fy, housing.Fx, housing.Fy."""
        if inputs is None:
            inputs = TrainInputs.constant([b.tau for b in self.bodies])
        self._inputs = inputs
        self.bearing_outputs = bool(bearing_forces)
        n = self.n
        y = self.initial_state()
        if perturb_w1:
            y[n:2 * n] = self.E @ (self.T @ y[n:2 * n] + np.eye(self.nb)[0] * perturb_w1)
        atol = self.atol(inputs, rtol)
        n_grid = int(round(stop_time / output_interval))
        grid = np.arange(n_grid + 1) * output_interval
        grid[-1] = stop_time
        t = 0.0
        seg = inputs.segment(t)
        cfg = self.classify(t, y, tau_at(seg, t))
        seg_max = 20.0 * output_interval
        segments, events = [], []
        n_restart = n_missed = n_hidden = 0
        while t < stop_time:
            seg = inputs.segment(t)
            t_brk = min(inputs.next_break(t), stop_time)
            t_hi = min(t_brk, t + seg_max)
            if stop_time - t_hi < 1e-3 * output_interval:
                t_hi = t_brk
            rhs = self.make_rhs(cfg, seg)
            evs, guards = self.make_events(cfg, y)
            hmax = min(output_interval, self.max_step(cfg, y, t_hi - t))
            sol = solve_ivp(rhs, (t, t_hi), y, method=method, rtol=rtol, atol=atol,
                            events=evs + guards, dense_output=True, max_step=hmax)
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
            segments.append((t, t_new, sol.sol, cfg, seg))
            n_restart += 1
            if n_restart > max_restarts:
                raise RuntimeError(f"more than {max_restarts} restarts at t = {t_new}")
            seg_new = inputs.segment(t_new) if t_new < stop_time else seg
            new = self.classify(t_new, y_new, tau_at(seg_new, t_new))
            if new.key != cfg.key:
                if not located:
                    n_missed += 1
                events.append((t_new, y_new, cfg, new))
            t, y, cfg = t_new, y_new, new
        return self._sample(grid, segments, events, n_restart, n_missed, n_hidden)

    # ---------------------------------------------------------------- outputs
    def output_names(self, bearing=None):
        """bearing: with the bearing forces (lateral.md section 6) before the energies; default:
        as the last simulate() ran (simulate(bearing_forces=...), off unless asked)."""
        if bearing is None:
            bearing = getattr(self, "bearing_outputs", False)
        names = ["time"]
        for i in range(1, self.nb + 1):
            names += [f"body[{i}].theta", f"body[{i}].w"]
        names += [f"shaft[{j}].tau" for j in range(1, self.ns + 1)]
        for m in range(1, self.nm + 1):
            names += [f"mesh[{m}].{v}" for v in ("dte", "F_fwd", "F_bwd", "n_fwd", "n_bwd", "F_f1",
                                                 "F_f2", "F_b1", "F_b2", "P_loss")]
            if self.meshes[m - 1].lumped:     # a lumped mesh also reports its k_mesh
                names.append(f"mesh[{m}].k_mesh")
        if self.general:
            names.append("housing.tau")
        if bearing:
            for i in range(1, self.nb + 1):
                names += [f"body[{i}].Fx", f"body[{i}].Fy"]
            names += ["housing.Fx", "housing.Fy"]
        return names + ["E_kin", "E_el", "E_gate", "W_ext", "W_loss", "energy_residual"]

    def elastic_energy(self, y, cfg):
        n = self.n
        U = 0.0
        for mesh, ms in zip(self.meshes, cfg.meshes):
            U += mesh.elastic_energy(self._e(mesh, y[:n]) + mesh.dte0, ms)
        for s in self.shafts:
            U += 0.5 * s.k * (self._q(s, y[:n]) + s.twist0) ** 2
        return U

    def _outputs_general(self, t, y, cfg, e_gate, bearing=False, tau=None):
        n = self.n
        x, xd = y[:n], y[n:2 * n]
        th, w = self.T @ x, self.T @ xd
        row = [t]
        for i in range(self.nb):
            row += [th[i], w[i]]
        hous = 0.0
        for s in self.shafts:
            ts = s.k * (self._q(s, x) + s.twist0) + s.d * self._q(s, xd)
            row.append(ts)
            if s.a == self.H:
                hous -= s.sg * ts
            if s.b == self.H:
                hous += s.sg * ts
        mesh_forces = []
        for mesh, ms in zip(self.meshes, cfg.meshes):
            dte = self._e(mesh, x) + mesh.dte0
            thA, _thB = self._rel(mesh, th)
            wA, wB = self._rel(mesh, w)
            mA, mB, pl, forces = mesh.torques(mesh.g.rAb * thA, dte, wA, wB, self._e(mesh, xd),
                                              ms.kf, ms.kb, detail=True)
            hous += self._apply_mesh(np.zeros(self.nb + 1), mesh, mA, mB)
            row += self._mesh_row(mesh, ms, dte, forces, pl)
            mesh_forces.append(forces)
        row.append(hous)
        if bearing:
            row += self.bearing_forces(t, y, cfg, th, w, mesh_forces, tau)
        E_kin = 0.5 * float(np.sum(self.J * w * w))
        E_el = self.elastic_energy(y, cfg)
        row += [E_kin, E_el, e_gate, y[2 * n], y[2 * n + 1]]
        return row

    @staticmethod
    def _mesh_row(mesh, ms, dte, forces, pl):
        """A mesh's output columns (output_names' order)."""
        F = {"f1": 0.0, "f2": 0.0, "b1": 0.0, "b2": 0.0}
        for flank, nA, Fn, _Ft in forces:
            # model 1: reported >= 0 (at an event instant delta may be -1e-21 on the side that
            # leaves); the lumped mesh's F is not clipped (lateral.md section 4, the brief)
            F[mesh.object_name(flank, nA)] += Fn if mesh.lumped else max(Fn, 0.0)
        row = [dte, F["f1"] + F["f2"], F["b1"] + F["b2"], len(ms.kf), len(ms.kb),
               F["f1"], F["f2"], F["b1"], F["b2"], pl]
        if mesh.lumped:
            row.append(mesh.k_mesh(ms))
        return row

    def outputs(self, t, y, cfg, e_gate, bearing=None, tau=None):
        """One output row (without energy_residual, added in _sample).  bearing: with the
        bearing forces (default: as output_names); tau: the torque inputs at t (default: the last
        simulate()'s inputs, else the body[i].tau parameters), for the accelerations they need."""
        if bearing is None:
            bearing = getattr(self, "bearing_outputs", False)
        if self.general:
            return self._outputs_general(t, y, cfg, e_gate, bearing, tau)
        n = self.n
        x, xd = y[:n], y[n:2 * n]
        th, w = self.T @ x, self.T @ xd
        row = [t]
        for i in range(self.nb):
            row += [th[i], w[i]]
        for s in self.shafts:
            row.append(s.k * (x[s.iq] + s.twist0) + s.d * xd[s.iq])
        mesh_forces = []
        for mesh, ms in zip(self.meshes, cfg.meshes):
            dte = x[mesh.ie] + mesh.dte0
            _mA, _mB, pl, forces = mesh.torques(mesh.g.rAb * th[mesh.A], dte, w[mesh.A],
                                                w[mesh.B], xd[mesh.ie], ms.kf, ms.kb, detail=True)
            row += self._mesh_row(mesh, ms, dte, forces, pl)
            mesh_forces.append(forces)
        if bearing:
            row += self.bearing_forces(t, y, cfg, th, w, mesh_forces, tau)
        E_kin = 0.5 * float(np.sum([b.J * wi * wi for b, wi in zip(self.bodies, w)]))
        E_el = self.elastic_energy(y, cfg)
        row += [E_kin, E_el, e_gate, y[2 * n], y[2 * n + 1]]
        return row

    def _tau_at(self, t):
        inputs = getattr(self, "_inputs", None)
        if inputs is None:
            return np.array([b.tau for b in self.bodies])
        return tau_at(inputs.segment(t), t)

    def is_planet(self, i):
        return self.general and i != self.H and self.carrier_of[i] is not None

    def bearing_forces(self, t, y, cfg, th, w, mesh_forces, tau=None):
        """[body[1].Fx, body[1].Fy, ..., housing.Fx, housing.Fy] (module docstring, BEARING
        FORCES): th, w the bodies' forward angles and speeds, mesh_forces each mesh's
        torques(detail=True) pairs."""
        nb = self.nb
        H = self.H if self.general else None
        planets = [i for i in range(nb) if self.is_planet(i)]

        def psi_abs(c):                      # a carrier's absolute angle (0 at t = 0)
            return self.psi0[c] + self.sigma[c] * th[c]
        # the meshes' forces on each body: a planet's in its carrier's frame, the others' (and
        # the housing's, row nb) in the housing frame
        F = np.zeros((nb + 1, 2))
        for mesh, forces in zip(self.meshes, mesh_forces):
            if not forces:
                continue
            fB = mesh.force_on_B(forces)
            c = getattr(mesh, "carrier", None)
            fB_h = _rot(psi_abs(c), fB) if c is not None else fB
            for X, sgn in ((mesh.B, 1.0), (mesh.A, -1.0)):
                if self.is_planet(X):
                    if self.carrier_of[X] != c:
                        raise RuntimeError(f"mesh[{mesh.m}]: a planet's mesh outside its carrier's frame")
                    F[X] += sgn * fB
                else:
                    F[nb if X == H else X] += sgn * fB_h
        out = np.zeros((nb, 2))
        pins_on_carrier = np.zeros((nb, 2))   # sum of P_n of each carrier's planets, housing frame
        if planets:
            acc = self.accelerations(t, y, cfg, self._tau_at(t) if tau is None else tau)
        for i in planets:
            c = self.carrier_of[i]
            r = np.array(self.planet_position(i))          # pin, carrier frame
            er = r / math.hypot(r[0], r[1])
            et = np.array([-er[1], er[0]])
            Om, al = self.sigma[c] * w[c], self.sigma[c] * acc[c]    # absolute, counter-clockwise
            a = -Om * Om * r + al * np.array([-r[1], r[0]])
            P = self.bodies[i].mass * a - F[i]             # the pin's force on the planet
            out[i] = (float(P @ er), float(P @ et))
            pins_on_carrier[c] += _rot(psi_abs(c), P)
        hous = F[nb].copy()
        for i in range(nb):
            if i in planets:
                continue
            out[i] = -F[i] + pins_on_carrier[i]
            hous -= out[i]
        return [float(v) for v in out.ravel()] + [float(hous[0]), float(hous[1])]

    def _sample(self, grid, segments, events, n_restart, n_missed, n_hidden):
        merged = []
        for ev in events:     # coincident events: one before/after pair
            if merged and ev[0] == merged[-1][0]:
                merged[-1] = (ev[0], ev[1], merged[-1][2], ev[3])
            else:
                merged.append(ev)
        merged = [ev for ev in merged if ev[2].key != ev[3].key]
        # E_gate: jumps of the elastic energy at the events
        jumps = [self.elastic_energy(ye, ca) - self.elastic_energy(ye, cb)
                 for _te, ye, cb, ca in merged]
        cum = np.concatenate([[0.0], np.cumsum(jumps)])
        ev_t = [ev[0] for ev in merged]

        rows = []
        seg_t0 = [s[0] for s in segments]
        for tg in grid:
            i = bisect.bisect_right(seg_t0, tg) - 1
            i = min(max(i, 0), len(segments) - 1)
            t0, t1, solf, c, _seg = segments[i]
            yy = solf(tg) if t1 > t0 else solf(t0)
            rows.append(self.outputs(tg, yy, c, cum[bisect.bisect_right(ev_t, tg)]))
        n_grid_rows = len(rows)
        for idx, (te, ye, cb, ca) in enumerate(merged):
            rows.append(self.outputs(te, ye, cb, cum[idx]))
            rows.append(self.outputs(te, ye, ca, cum[idx + 1]))
        order = sorted(range(len(rows)), key=lambda i: (rows[i][0], 0 if i < n_grid_rows else 1, i))
        ev_times = set(ev_t)
        table = np.array([rows[i] for i in order if not (i < n_grid_rows and rows[i][0] in ev_times)])
        names = self.output_names()
        ci = {nm: names.index(nm) for nm in ("E_kin", "E_el", "E_gate", "W_ext", "W_loss")}
        bal = (table[:, ci["E_kin"]] + table[:, ci["E_el"]] + table[:, ci["W_loss"]]
               - table[:, ci["W_ext"]] - table[:, ci["E_gate"]])
        table = np.column_stack([table, bal - bal[0]])
        return Result(names, table, merged, n_restart, n_missed, n_hidden, train=self)


def _has_cycle(nb, edges):
    """Whether the meshes and shafts (edges over bodies 0..nb, nb = the housing) close a loop."""
    parent = list(range(nb + 1))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for _name, a, b in edges:
        ra, rb = find(a), find(b)
        if ra == rb:
            return True
        parent[ra] = rb
    return False


def _tree_path(adj, a, b):
    """Edge names on the path a -> b in the forest adj, or None if not connected."""
    prev = {a: None}
    todo = deque([a])
    while todo:
        i = todo.popleft()
        if i == b:
            break
        for j, name in adj[i]:
            if j not in prev:
                prev[j] = (i, name)
                todo.append(j)
    if b not in prev:
        return None
    path = []
    i = b
    while prev[i] is not None:
        i, name = prev[i]
        path.append(name)
    return path[::-1]


# --------------------------------------------------------------------------------------------
# Rigid-train helpers: speed ratios and the quasi-static start
# --------------------------------------------------------------------------------------------

def rigid_ratios(train: GearTrain) -> np.ndarray:
    """r_i with w_i = r_i w_1 under rigid rolling (w_B = w_A rAb/rBb across a mesh, equal
    speeds across a shaft)."""
    r = np.zeros(train.nb)
    r[0] = 1.0
    for j in train.order[1:]:
        k, i = train.parent[j]
        if k < train.nm:
            g = train.meshes[k].g
            r[j] = r[i] * (g.rAb / g.rBb if j == train.meshes[k].B else g.rBb / g.rAb)
        else:
            r[j] = r[i]
    return r


def rigid_loads(train: GearTrain, w1: float, tau: np.ndarray):
    """Rigid train at speed w1 (w_i = r_i w1) under torques tau: the common acceleration a_1,
    the forward line force F_m of each mesh and the torque T_j of each shaft, from the n body
    equations J_i r_i a_1 = tau_i - c_i r_i w1 - F_m rAb [i = A] + F_m rBb [i = B] - T_j [i = a]
    + T_j [i = b] (n unknowns: a_1 and the n - 1 edge loads)."""
    nb = train.nb
    r = rigid_ratios(train)
    M = np.zeros((nb, nb))
    rhs = np.array([tau[i] - b.c * r[i] * w1 for i, b in enumerate(train.bodies)])
    for i, b in enumerate(train.bodies):
        M[i, 0] = b.J * r[i]
    for k, mesh in enumerate(train.meshes):
        M[mesh.A, k + 1] += mesh.g.rAb
        M[mesh.B, k + 1] -= mesh.g.rBb
    for s in train.shafts:
        M[s.a, s.iq] += 1.0
        M[s.b, s.iq] -= 1.0
    sol = np.linalg.solve(M, rhs)
    return sol[0], sol[1:train.nm + 1], sol[train.nm + 1:], r


def static_delta(mesh: TrainMesh, F: float, n_pairs: int) -> float:
    """Penetration at which n_pairs pairs carry the line force F > 0 (Johnson law with
    rho_A + rho_B = L + delta; fixed point as gearmesh_ref.quasi_static_dte)."""
    g = mesh.g
    if mesh.lumped:              # the lumped spring: F / k_eff (n = n_pairs when it varies)
        return F / mesh.k_eff(n_pairs)
    N = F / (n_pairs * mesh.width)
    d = G.johnson_delta(N, g.L, g.E_star)
    for _ in range(50):
        d_new = G.johnson_delta(N, g.L + g.kappa * d, g.E_star)   # L - d: internal mesh
        if d_new == d:
            break
        d = d_new
    return d


def quasi_static_start(start_values: dict, max_iter: int = 8, mount_groups=()) -> dict:
    """Start values for a start without the large first transient: every body at the rigid
    speed r_i * body[1].w_start, every mesh at the penetration and every shaft at the twist that
    carry the rigid train's loads at t = 0 (constant torques body[i].tau).  The number of
    carrying pairs of each mesh depends on the placement, which depends on dte_start and
    twist_start: iterate until the counts repeat.  Returns a new start-value dict."""
    sv = dict(start_values)
    tr = _unchecked_train(sv) if mount_groups else GearTrain(sv)
    if tr.general:
        return _quasi_static_general(sv, mount_groups)
    w1 = tr.bodies[0].w0
    r = rigid_ratios(tr)
    for i in range(tr.nb):
        sv[f"body[{i + 1}].w_start"] = float(r[i] * w1)
    counts = [1] * tr.nm
    for _ in range(max_iter):
        tr = GearTrain(sv)
        tau = np.array([b.tau for b in tr.bodies])
        _a1, F, Ts, _r = rigid_loads(tr, w1, tau)
        for k, mesh in enumerate(tr.meshes):
            if F[k] > 0.0:
                d = static_delta(mesh, F[k], counts[k])
            elif F[k] < 0.0:
                d = -mesh.g.backlash - static_delta(mesh, -F[k], counts[k])
            else:
                d = 0.0
            sv[f"mesh[{k + 1}].dte_start"] = float(d)
        for s, T in zip(tr.shafts, Ts):
            sv[f"shaft[{s.j}].twist_start"] = float(T / s.k)
        tr = GearTrain(sv)
        y = tr.initial_state()
        cfg = tr.classify(0.0, y, np.array([b.tau for b in tr.bodies]))
        new = [max(len(ms.kf), len(ms.kb), 1) for ms in cfg.meshes]
        if new == counts:
            return sv
        counts = new
    raise RuntimeError(f"quasi_static_start: pair counts do not settle ({counts})")


def _unchecked_train(sv):
    GearTrain.check_assembly = False
    try:
        return GearTrain(sv)
    finally:
        GearTrain.check_assembly = True


def rigid_kernel(train: GearTrain) -> np.ndarray:
    """General mode: the rigid motions (every mesh rolling, every shaft rigid) as the columns
    of K (n_bodies x f), normalised so that K restricted to the free bodies is the identity:
    w = K w_free."""
    nb, f = train.nb, len(train.free)
    if f == 0:
        return np.zeros((nb, 0))
    E = train.E
    # x = E theta: a rigid motion keeps every edge coordinate, so x = [w_free, 0]
    K = train.T[:, :f].copy()
    assert np.allclose(E[f:] @ K, 0.0, atol=1e-12)
    return K


def _quasi_static_general(start_values: dict, mount_groups=()) -> dict:
    """quasi_static_start for a train with the housing, carriers or loops (general mode).

    Speeds: the rigid motion through the free bodies' w_start (train.free: the bodies whose
    angles are state coordinates).  Loads: a loop makes the rigid train statically
    indeterminate, so the start is found on the compliant train itself: the dte_start of every
    placing mesh and the twist_start of every placing shaft (the placement's spanning tree) are
    solved so that at t = 0 every edge coordinate has zero acceleration: the train then starts
    accelerating as a rigid body (constant torques body[i].tau).  The loop meshes' start
    penetrations follow from the placement (planetary.md section 4), so the solve sees the
    actual load sharing (a pin error included).  scipy's hybrid Powell method on the
    unknowns scaled by one pair's Johnson penetration (meshes) or the rigid twist (shafts).

    mount_groups: lists of mount parameters of one gear (e.g. a sun's mount_A in each of its
    meshes), each group one more unknown, for a train where a loop mesh is independent of the
    placing edges (a carrier coupled to another set's sun: its start angle 0 and the shaft fix
    the sun, so the sun's tooth position on its body is what lets the set assemble unloaded)."""
    from scipy.optimize import root
    sv = dict(start_values)
    tr = _unchecked_train(sv)
    nb, f = tr.nb, len(tr.free)
    K = rigid_kernel(tr)
    w_free = np.array([tr.bodies[i].w0 for i in tr.free])
    w = K @ w_free if f else np.zeros(nb)
    for i in range(nb):
        sv[f"body[{i + 1}].w_start"] = float(w[i])
    tr = _unchecked_train(sv)
    if len(tr.placing) + len(mount_groups) != len(tr.indep):
        raise NotImplementedError(
            f"quasi_static_start: {len(tr.indep)} independent edges, {len(tr.placing)} placing "
            f"edges and {len(mount_groups)} mount groups: give one mount group per loop edge "
            "independent of the placing edges")
    tau = np.array([b.tau for b in tr.bodies])
    # first guess: the rigid train's minimum-norm edge loads
    Qd, _P = tr._drag(w)
    Eall = tr.E_all
    M = np.hstack([(tr.J[:, None] * K), Eall.T])
    sol = np.linalg.lstsq(M, tau + Qd, rcond=None)[0]
    lam = sol[f:]
    keys, u0, scale = [], [], []
    for k in tr.placing:
        if k < tr.nm:
            mesh = tr.meshes[k]
            F = lam[k]
            d = (static_delta(mesh, F, 1) if F > 0 else
                 (-mesh.g.backlash - static_delta(mesh, -F, 1) if F < 0 else 0.0))
            keys.append(f"mesh[{mesh.m}].dte_start")
            u0.append(d)
            scale.append(max(abs(d), 1e-7))
        else:
            s_ = tr.shafts[k - tr.nm]
            keys.append(f"shaft[{s_.j}].twist_start")
            u0.append(lam[k] / s_.k)
            scale.append(max(abs(lam[k] / s_.k), 1e-9))
    for grp in mount_groups:
        keys.append(tuple(grp))
        u0.append(float(sv.get(grp[0], 0.0)))
        scale.append(1e-4)
    u0, scale = np.array(u0), np.array(scale)

    def build(z, check=True):
        sv2 = dict(sv)
        for key, v in zip(keys, u0 + scale * z):
            for kk in (key if isinstance(key, tuple) else (key,)):
                sv2[kk] = float(v)
        GearTrain.check_assembly = check
        try:
            return sv2, GearTrain(sv2)
        finally:
            GearTrain.check_assembly = True
    if mount_groups:
        # first guess of each mount: turn the gear so that the loop meshes it closes start
        # near the first-guess penetration of their placing siblings (secant on delta0)
        nz = len(keys) - len(mount_groups)
        for gi, grp in enumerate(mount_groups):
            idx = nz + gi
            ms = [int(_NAME.match(k).group(2)) for k in grp]
            target = float(np.mean([d for k, d in zip(keys[:nz], u0[:nz]) if "dte_start" in k]))
            for _ in range(4):
                z = np.zeros(len(keys))
                d0 = build(z, check=False)[1].meshes[ms[0] - 1].dte0
                z[idx] = 1.0
                d1 = build(z, check=False)[1].meshes[ms[0] - 1].dte0
                u0[idx] += scale[idx] * (target - d0) / (d1 - d0)

    def resid(z):
        _sv2, t2 = build(z)
        y = t2.initial_state()
        cfg = t2.classify(0.0, y, tau)
        acc = t2.accelerations(0.0, y, cfg, tau)
        xdd = t2.E @ acc
        return xdd[f:] / (scale * 1e6)       # edge accelerations in units of scale per (1 ms)^2
    r = root(resid, np.zeros(len(u0)), method="hybr", options={"xtol": 1e-14})
    res = resid(r.x)
    if not np.all(np.abs(res) < 1e-6):
        raise RuntimeError(f"quasi_static_start: no static state found ({r.message}; residual "
                           f"{np.max(np.abs(res))!r})")
    sv2, _t2 = build(r.x)
    return sv2


# --------------------------------------------------------------------------------------------
# Idler phasing (spec section 7), closed form
# --------------------------------------------------------------------------------------------

def idler_switch_phase(start_values: dict, delta2: float | None = None) -> float:
    """Phase in [0, 1) of the pair switches of mesh 2 relative to mesh 1 for an idler.

    Set-up: the idler I is B of mesh 1 and A of mesh 2 (gear-train.md section 3), in steady
    forward drive (the idler turns at a steady forward speed).  SWITCH = a forward pair entering
    the gate at point a (the driven gear's tip reaches the line of action: the start of the
    double-contact interval when 1 < eps < 2).  PHASE = (time from a switch of mesh 1 to the next
    switch of mesh 2) / (mesh period 2 pi/(z_I w_I)).

    Derivation from spec section 3 (mesh frames) and the pair formulas of the module docstring.
    Let s1 = -sigma(A of mesh 1); then sigma_I = s1 (a mesh flips the sense), mesh 1's frame has
    s_m = s1 and mesh 2's s_m = -sigma_I = -s1.  With theta_I the idler's forward angle,
    psi_I = psi_I(0) + s1 theta_I, and dz = 2 pi/z_I:

    Mesh 1 (idler = B).  chi_B = s1 (psi_I + mount_B1 - beta_1) = chiB0 + theta_I; the forward
    root of idler tooth n is at chi_B + n dz - tB1/2, so s_B = rBb1 (alpha_w1 + pi - chi_B - n dz
    + tB1/2).  A pair enters at a when s_B = L1 - s_a1 (s_A - delta = s_a, the B tip): this
    depends on the idler alone, at
        theta_I = X1 - s1 (psi_I(0) + mount_B1 - beta_1) - n dz,
        X1 = alpha_w1 + pi + tB1/2 - (L1 - s_a1)/rBb1.
    Mesh 2 (idler = A).  chi_A = -s1 (psi_I + mount_A2 - beta_2) = chiA0 - theta_I; the forward
    root of idler tooth n is at chi_A - n dz - tA2/2, so s_A = rAb2 (alpha_w2 - chi_A + n dz +
    tA2/2).  A pair enters at a when s_A - delta2 = s_a2 (gear 3's tip, which sits at s_A =
    s_a2 + delta2 on the idler's side), at
        theta_I = X2 - s1 (psi_I(0) + mount_A2 - beta_2) - n dz,
        X2 = (s_a2 + delta2)/rAb2 - alpha_w2 - tA2/2.
    Both sets of switch angles are lattices of spacing dz; psi_I(0) cancels.  At a steady idler
    speed time is proportional to theta_I, so

        phase = frac( [ X2 - X1 + s1 ((beta_2 - beta_1) - (mount_A2 - mount_B1)) ] / dz )

              = frac( z_I/(2 pi) * [ s1 (beta_2 - beta_1 - mount_A2 + mount_B1)
                                     + (L1 - s_a1)/rBb1 + (s_a2 + delta2)/rAb2
                                     - alpha_w1 - alpha_w2 - (tB1 + tA2)/2 - pi ] ).

    The terms: z (beta_2 - beta_1)/(2 pi) is Parker & Lin's same-flank phase of two meshes
    around one gear; (tB1 + tA2)/2 (the idler's base tooth thickness angle) appears because the
    two meshes load OPPOSITE flanks of the idler's teeth; (L1 - s_a1)/rBb1 = tan of the
    idler's tip pressure angle (roll angle to its tip) and (s_a2 + delta2)/rAb2 - alpha_w2 the
    roll angle at which gear 3's tip meets the idler, measured from the pitch point; pi: mesh 1
    sees the idler from the far side of its line of centres.  delta2 (mesh 2's forward
    penetration, default mesh[2].dte_start) shifts the phase by delta2/(rAb2 dz) = delta2/p_b2.
    Valid for contacts_per_flank = 0 (m_c = ceil(eps): no window event) and 1 < eps < 2.
    """
    tr = GearTrain(start_values)
    if tr.nm < 2:
        raise ValueError("idler phase: needs meshes 1 and 2")
    m1, m2 = tr.meshes[0], tr.meshes[1]
    if m1.internal or m2.internal:
        raise NotImplementedError("idler phase: external meshes only")
    if m1.B != m2.A:
        raise ValueError("idler phase: the idler must be B of mesh 1 and A of mesh 2")
    g1, g2 = m1.g, m2.g
    z = g1.zB
    if g2.zA != z:
        raise ValueError(f"idler phase: the idler has {g1.zB} teeth in mesh 1, {g2.zA} in mesh 2")
    if delta2 is None:
        delta2 = m2.dte0
    s1 = -tr.sigma[m1.A]
    X1 = g1.alpha_w + math.pi + g1.tB / 2 - (g1.L - g1.s_a) / g1.rBb
    X2 = (g2.s_a + delta2) / g2.rAb - g2.alpha_w - g2.tA / 2
    arg = X2 - X1 + s1 * ((m2.beta - m1.beta) - (m2.mount_A - m1.mount_B))
    ph = arg / (2.0 * math.pi / z)
    return ph - math.floor(ph)


# --------------------------------------------------------------------------------------------
# Scenes and statistics
# --------------------------------------------------------------------------------------------

TRAIN_SCENES_DIR = os.path.join(G.SCENES_DIR, "train")
REF_RTOL = G.REF_RTOL


def load_scene(name_or_path):
    path = name_or_path
    if not path.endswith(".toml"):
        path = os.path.join(TRAIN_SCENES_DIR, name_or_path + ".toml")
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    scene["name"] = os.path.basename(path)[:-5]
    scene["path"] = path
    return scene


def scene_model(scene):
    tr = GearTrain(scene.get("start_values", {}))
    taus = [b.tau for b in tr.bodies]
    if "input_file" in scene:
        inputs = TrainInputs.from_csv(os.path.join(os.path.dirname(scene["path"]),
                                                   scene["input_file"]), taus)
    else:
        inputs = TrainInputs.constant(taus)
    return tr, inputs


def run_scene(scene, rtol=None, method="DOP853", perturb_rel=0.0):
    """perturb_rel: body 1's start speed perturbed by perturb_rel * max(|w_start|, 1)."""
    if rtol is None:
        rtol = float(scene.get("reference_rtol", REF_RTOL))
    tr, inputs = scene_model(scene)
    dw = perturb_rel * max(abs(tr.bodies[0].w0), 1.0)
    return tr.simulate(scene["stop_time"], scene["output_interval"], inputs, rtol=rtol,
                       method=method, perturb_w1=dw, bearing_forces=scene_wants_bearing(scene))


BEARING_OUTPUT = re.compile(r"^(body\[\d+\]|housing)\.F[xy]$")


def scene_wants_bearing(scene):
    """A scene's trace has the bearing forces when it compares any of them (the other scenes'
    traces keep their columns, which tools and the Rust runner's default columns mirror)."""
    return any(BEARING_OUTPUT.match(v) for v in scene.get("compare", {}).get("variables", []))


def statistics(names, table, output_interval, train: GearTrain):
    """Statistics over the output-grid rows (as gearmesh_ref.statistics, per element):

    body[i].mean_w                       mean speed [rad/s]
    mesh[m].mean_ratio                   mean(w_A)/mean(w_B)
    mesh[m].rms_dte, max_dte, min_dte    of dte on the grid [m]
    mesh[m].impacts_per_mesh_cycle       rising edges of (n_fwd > 0) and of (n_bwd > 0) between
                                         consecutive grid rows, per mesh cycle
                                         z_A |theta_A(end) - theta_A(0)|/(2 pi)
    mesh[m].flank_switches_per_mesh_cycle  changes of the flank last seen in contact, per cycle
    mesh[m].contact_fraction             share of grid rows with a pair in contact (either flank)
    mesh[m].bwd_contact_fraction         share of grid rows with backward contact (the rattle
                                         side when the drive is forward)
    """
    r = G.grid_rows(names, table, output_interval)
    col = lambda nm: r[:, names.index(nm)]
    out = {}
    for i in range(1, train.nb + 1):
        out[f"body[{i}].mean_w"] = float(np.mean(col(f"body[{i}].w")))
    for mesh in train.meshes:
        m = mesh.m
        pre = f"mesh[{m}]."
        dte = col(pre + "dte")
        nf, nb_ = col(pre + "n_fwd") > 0, col(pre + "n_bwd") > 0
        rises = int(np.sum(nf[1:] & ~nf[:-1]) + np.sum(nb_[1:] & ~nb_[:-1]))
        last, switches = 0, 0
        for f, b in zip(nf, nb_):
            sd = 1 if f else (-1 if b else 0)
            if sd:
                if last and sd != last:
                    switches += 1
                last = sd
        thA, _thB = _rel_columns(train, mesh, col, "theta")
        cycles = mesh.g.zA * abs(thA[-1] - thA[0]) / (2 * math.pi)
        per = (lambda k: k / cycles) if cycles > 0 else (lambda k: float("nan"))
        wA, wB = _rel_columns(train, mesh, col, "w")
        # speeds relative to the mesh's frame (a carrier's) in general mode; a fixed gear: nan
        mwB = float(np.mean(wB))
        out[pre + "mean_ratio"] = float(np.mean(wA)) / mwB if mwB != 0.0 else float("nan")
        out[pre + "rms_dte"] = float(np.sqrt(np.mean(dte ** 2)))
        out[pre + "max_dte"] = float(np.max(dte))
        out[pre + "min_dte"] = float(np.min(dte))
        out[pre + "impacts_per_mesh_cycle"] = float(per(rises))
        out[pre + "flank_switches_per_mesh_cycle"] = float(per(switches))
        out[pre + "contact_fraction"] = float(np.mean(nf | nb_))
        out[pre + "bwd_contact_fraction"] = float(np.mean(nb_))
    return out


def mesh_cycles(names, table, output_interval, train, m):
    r = G.grid_rows(names, table, output_interval)
    mesh = train.meshes[m - 1]
    thA, _thB = _rel_columns(train, mesh, lambda nm: r[:, names.index(nm)], "theta")
    return mesh.g.zA * abs(thA[-1] - thA[0]) / (2 * math.pi)


def _rel_columns(train, mesh, col, what):
    """Columns body[A].<what>, body[B].<what> (theta or w), relative to the mesh's carrier in
    general mode; a housing end reads 0."""
    def body(i):
        return col(f"body[{i + 1}].{what}") if i != getattr(train, "H", None) else 0.0
    a, b = body(mesh.A), body(mesh.B)
    if getattr(train, "general", False) and mesh.carrier is not None:
        c = body(mesh.carrier)
        a = a - mesh.kA * c
        b = b - mesh.kB * c
    return np.asarray(a, dtype=float) * np.ones(1), np.asarray(b, dtype=float) * np.ones(1)
