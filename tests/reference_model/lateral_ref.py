"""Independent reference of the lateral bodies of SpurGearTrain (lateral.md sections 1-3 and 6):
centres that move in the plane of the gears on spring-damper bearings, and meshes whose
penetrations follow them.  Written from the specification (lateral.md, planetary.md,
gear-train.md, gear-mesh-model.md) and the decisions of its brief; it reuses train_ref.GearTrain
for everything lateral.md leaves as it was (parameters, topology, forward senses, placement, the
angle coordinates, the mesh geometry and tooth pairs, the tie rule, the integration loop) and
replaces the dynamics, the contact decisions, the events and the outputs.

A train without a lateral body is train_ref's: make_train() and run_scene() hand it to train_ref
unchanged (bit-identical traces).  LateralTrain also runs such a train through its own equations
(the test of this module compares the two).

PARAMETERS (per body i, lateral.md section 1): body[i].lateral (Boolean, default false),
body[i].k_x, k_y [N/m], c_x, c_y [N.s/m] (>= 0, default 0), body[i].m [kg] (every lateral body's
translational mass, > 0), body[i].x_start, y_start, vx_start, vy_start (default 0).  Refused at
build (ValueError naming the body and the number): a negative or infinite k/c; a lateral body with
m <= 0; a lateral carrier with a planet that is not lateral (decision 7); a lateral body that
nothing holds in some direction: a zero bearing stiffness along a direction in which no mesh's
forward line of action moves it (decision 8: K_bearing + sum n_f n_f^T singular, n_f each
mesh's d(delta_lat)/dq at t = 0; the message names the direction in the body's axes).

COORDINATES (decision 1).  Generalized coordinates Th = [theta_1..theta_nb, q] (forward angles
as train_ref, then 2 per lateral body in ascending index), velocities V = [w, q'].  q_i is the
centre's displacement from its nominal position: (x, y) in the housing frame for a body on a
housing-fixed axis and for a carrier; (zeta, eta) for a planet, along its axes e_r, e_t (radial
and tangential at its ACTUAL pin, pin errors included), so its vector in the carrier frame is
B_i q_i, B_i = [e_r e_t].  Positions (housing frame): p_i = P_i + q_i (fixed axis), O_c + q_c
(carrier), p_n = O_c + q_c + Rot(psi_c) (P_n + B_n q_n) (planet; P_n its pin, psi_c = psi_c(0) +
sigma_c theta_c the carrier's absolute angle).  The integrator's state is
y = [x, q, x', q', W_ext, W_loss] with theta = T x (train_ref's angle coordinates: every mesh's
rotational dte keeps full precision) and q itself (small, absolute).

KINETIC ENERGY (lateral.md section 2, every term):
    T = sum_i J_i w_i^2 / 2 + sum_{lateral, not planets} m_i |q_i'|^2 / 2
        + sum_{lateral planets} m_n |p_n'|^2 / 2,
J_i the body's own inertia, plus m R^2 (nominal orbit radius, as train_ref) of each planet that is
not lateral, on its (then necessarily not lateral) carrier.  For a lateral planet, in its
carrier's frame (a rotation does not change |.|):
    Rot(-psi_c) p_n' = Rot(-psi_c) q_c' + B_n q_n' + Omega J r_n,   r_n = P_n + B_n q_n,
Omega = sigma_c w_c, J the quarter turn, q_c' only for a lateral carrier.  So p_n' = G_n V with
the 2 x N matrix G_n (columns: w_c -> sigma_c J r_n, q_n -> B_n, q_c -> Rot(-psi_c)), and
    T = V^T M V / 2,   M = diag(J, m) + sum_n m_n G_n^T G_n     (configuration dependent).
LAGRANGE'S EQUATIONS d/dt dT/dV - dT/dTh = Q are, for T = sum m |p'|^2/2 + ..., with
p'' = G V' + a0 (Kane's form of the same equations),
    M(Th) V' = Q - h,   h = sum_n m_n G_n^T a0_n,   a0_n = 2 Omega J B_n q_n' - Omega^2 r_n
(carrier frame): the Coriolis, centrifugal and (through G's w_c column) Euler terms, with the
carrier's speed free.  np.linalg.solve gives V'; test_lateral_ref checks h against
dM/dt V - dT/dTh by finite differences of T, and M against |p'|^2 from the positions.

MESH PENETRATION (decision 2).  A mesh sits in a frame F: the housing's, or its carrier's (then
its vectors turn with psi = psi_c).  n_f, n_b (normal force on B, forward/backward flank) and the
tangents t_f, t_b are train_ref.TrainMesh.force_on_B's directions in F (paper frame n_f =
(sin aw, -cos aw), n_b = (sin aw, cos aw), t_f = (cos aw, sin aw), t_b = (-cos aw, sin aw),
mirrored and turned into F).  With Dp_A, Dp_B the centres' displacements (housing frame: q_i on a
fixed axis, q_c for a carrier, q_c + Rot(psi_c) B_n q_n for a planet), the relative displacement
in F is
    D = Rot(-psi) (Dp_A - Dp_B) = Rot(-psi) u_h + u_c,
u_h = +-(q of A/B on housing-fixed axes, and of a planet's lateral carrier), u_c = +-B_n q_n of
lateral planets (+ for A, - for B): constant linear maps P_h, P_c of Th.  The penetrations are
    delta_f = dte + n_f . D,        delta_b = -j_n - dte + n_b . D,
dte = e + dte_start the rotational part (train_ref's mesh coordinate).  They enter the contact law
(Johnson with rho sum L + kappa delta, or the lumped spring), the gating (B's tip: s_A - delta >=
s_a, i.e. train_ref's s~_B + n . D <= L - s_a; A's tip s_A <= s_b unchanged), the Hunt-Crossley
rate, and every event.  The geometry (alpha_w, L, s_a, s_b, p_b, the tooth pairs) stays that of
the nominal centres (lateral.md section 3).  Output mesh[m].delta_lat = n_f . D.
  Jacobian: dD/dTh = JD = Rot(-psi) P_h + P_c, plus the column of theta_c: -sigma_c J Rot(-psi) u_h
(the turning of n with the carrier); D' = JD V.  Rotational rows: de/dTh = rAb rowA - rBb rowB,
rowX the body's forward angle relative to F (train_ref's theta - sigma sigma_c theta_c), with an
extra entry N for the housing's absolute angle when a gear sits in the housing (its generalized
force is housing.tau).

GENERALIZED FORCES (decisions 3-5), all as -dV/dTh or Rayleigh terms through the same Jacobians:
  * normal force of a flank, per carrying pair: Q -= F_n d(delta)/dTh, F_n = width N(delta)
    (1 + chi delta') (Johnson; the Hunt-Crossley damping through the same row, so its power is
    -F_n delta'), or for the lumped mesh the flank's total F = k_eff delta + c_lumped delta';
  * friction, per pair: the sliding velocity v_s = -w_A s_A + w_B s_B + t . D' (A's contact
    point relative to B's along the flank's tangent, in the mesh's frame: the carrier's rotation
    moves both centres and the contact point together and drops out; s_B = L + kappa delta -
    kappa s_A with the total delta), F_t = mu tanh(v_s/v_reg) F_n, Q -= F_t dv_s/dV, so its power
    is exactly -F_t v_s.  Sign check: with C the contact point and the centres fixed, A's
    velocity along t_f is omega_A (J C).t_f = omega_A C.n_f = -w_A s_A and B's is -w_B s_B:
    v_s > 0 means A slides along +t relative to B, and friction drags B along +t, as force_on_B
    says (F_t t on B);
  * rotations about the axes: the rows above give exactly the single mesh's torques (train_ref's
    table; its carrier reaction) plus, in a carrier's frame, the small torque -F n.(dD/dtheta_c)
    on the carrier;
  * bearings: -k q - c q' on each lateral coordinate (a planet: on zeta, eta and their
    carrier-frame rates); inputs, drags (a planet's on its speed relative to its carrier) and
    shafts as train_ref.
Energies: E_kin = T; E_el = the pairs' contact energy at the total delta (train_ref.pair_energy)
or k_eff delta^2/2, shafts, bearings sum k q^2/2; W_ext = int (tau - drag) . w; W_loss = int
(meshes' P_loss, with friction's F_t v_s; shaft and bearing dampers).

OUTPUTS (lateral.md section 6, decision 6), after train_ref's columns and housing.tau:
body[i].x, y, vx, vy (q and q' in the body's axes, 0 for a body that is not lateral),
mesh[m].delta_lat, then body[i].Fx, Fy and housing.Fx, Fy always:
  * a lateral body: its bearing's force -k q - c q' (housing frame; a planet's radial and
    tangential at its pin);
  * a body that is not lateral: the reaction that holds it (train_ref.bearing_forces' rule: on a
    housing-fixed axis minus its meshes' forces plus its planets' pin forces; a planet on a rigid
    pin m a - its meshes' forces, a its centre's acceleration with the carrier), where a lateral
    planet's pin passes its spring-damper force to the carrier;
  * the meshes' forces on the centres are force_on_B's (F_n n + F_t t on B, the opposite on A),
    which is -dV/dDp of the formulation above (d delta/dDp_B = -n, dv_s/dDp_B' = -t);
  * housing.Fx, Fy: the meshes' forces on gears in the housing minus the bearing forces of every
    body on a housing-fixed axis.  mesh[m].dte stays the rotational part.

INTEGRATION as train_ref: the carrying sets fixed inside a solve_ivp call (DOP853), terminal
events signed to be >= 0 just after a restart: each flank's total delta through 0, the gate
boundaries (A's tip on s_A; B's tip on s~_B + n . D; the lumped mesh's s_A = s_a, s_b), damped
release 1 + chi delta' = 0; non-terminal guards at the zeros of each flank's delta' and of the
gate coordinates' rates.

READINGS where the spec leaves room (marked READING in the code):
  * the sliding velocity's lateral part is the rate of D in the mesh's frame (decision 4);
    lateral.md section 3's "housing-frame rate of Dp_A - Dp_B" differs from it by Omega J D in a
    carrier's frame, a sliding the rigid rotation of the whole mesh with the carrier would make;
  * friction's moment arm s_B and v_s use the real s_B at the total penetration (the single
    mesh's L + kappa delta - kappa s_A with delta its penetration); the difference from the
    rotational one is of order |q| (lateral.md section 3's small-displacement error);
  * which teeth pair and A's tip gate follow the rotations alone; B's tip gate takes the total
    penetration (the spec's s_A - max(delta, 0) >= s_a); a lumped mesh's gates stay on s_A;
  * a lateral planet's orbital inertia comes from its actual pin (m |P_n + B_n q_n|^2 Omega^2
    within T); a planet that is not lateral keeps m R^2 with the nominal R (decision 1);
  * train_ref's step limit (no gate coordinate moves more than p_b/8 per step) is kept as is:
    a lateral impact the step does not resolve could throw a trial stage of the integrator out
    of the Johnson law's range (JohnsonRangeError), as a rotational one could in train_ref.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass

import numpy as np

from . import gearmesh_ref as G
from . import train_ref as T

LATERAL_KEYS = {"lateral": False, "k_x": 0.0, "k_y": 0.0, "c_x": 0.0, "c_y": 0.0,
                "x_start": 0.0, "y_start": 0.0, "vx_start": 0.0, "vy_start": 0.0}
_LAT_NAME = re.compile(r"^body\[(\d+)\]\.(" + "|".join(LATERAL_KEYS) + r")$")
_ZERO2 = np.zeros(2)


def _rot(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def _perp(v):
    """J v, the quarter turn counter-clockwise."""
    return np.array([-v[1], v[0]])


def split_start_values(start_values: dict):
    """(train_ref's start values, {body index (1-based): its lateral parameters})."""
    base, lat = {}, {}
    for key, v in start_values.items():
        m = _LAT_NAME.match(key)
        if not m:
            base[key] = v
            continue
        i, name = int(m.group(1)), m.group(2)
        if not 1 <= i <= T.CAPACITY["body"]:
            raise KeyError(f"{key}: index {i} beyond the capacity {T.CAPACITY['body']} of body elements")
        if name == "lateral":
            if not isinstance(v, bool):
                raise TypeError(f"{key} must be a boolean")
        else:
            if isinstance(v, bool):
                raise TypeError(f"{key} must be a real number")
            v = float(v)
        lat.setdefault(i, dict(LATERAL_KEYS))[name] = v
    return base, lat


def has_lateral(start_values: dict) -> bool:
    _base, lat = split_start_values(start_values)
    nb = start_values.get("n_bodies", T.DEFAULTS["n_bodies"])
    return any(d["lateral"] for i, d in lat.items() if i <= nb)


def make_train(start_values: dict | None = None):
    """LateralTrain when some body in use is lateral, else train_ref.GearTrain (unchanged)."""
    sv = dict(start_values or {})
    return LateralTrain(sv) if has_lateral(sv) else T.GearTrain(sv)


@dataclass
class MeshLat:
    """A mesh's lateral data (module docstring, MESH PENETRATION)."""
    c: int | None          # carrier whose frame the mesh sits in (None: the housing's)
    Ph: np.ndarray         # 2 x (N+1): u_h = Ph Th (housing-frame displacements, +A -B)
    Pc: np.ndarray         # 2 x (N+1): u_c = Pc Th (planets' carrier-frame displacements)
    on: bool               # some centre of the mesh moves
    n: dict                # flank (1, -1) -> unit normal (force on B) in the mesh's frame
    t: dict                # flank -> unit tangent
    rowA: np.ndarray       # N+1: d theta_A(relative to the frame)/dTh (entry N: housing angle)
    rowB: np.ndarray
    re: np.ndarray         # de/dTh = rAb rowA - rBb rowB


@dataclass
class LatPlanet:
    """A lateral planet's data for the mass matrix (module docstring, KINETIC ENERGY)."""
    c: int
    sc: float              # sigma of the carrier
    qi: int                # index of zeta in Th
    qc: int | None         # index of the carrier's x when it is lateral
    B: np.ndarray          # [e_r e_t]
    r0: np.ndarray         # pin, carrier frame
    m: float
    cols: np.ndarray
    ix: tuple


class LateralTrain(T.GearTrain):
    """SpurGearTrain with lateral bodies (module docstring)."""

    def __init__(self, start_values: dict | None = None):
        base, lat = split_start_values(dict(start_values or {}))
        super().__init__(base)
        if not self.general:
            self._tree_as_general()
        self._setup_lateral(lat)

    # ---------------------------------------------------------------- set-up
    def _tree_as_general(self):
        """train_ref's tree mode leaves out what its general mode has (no carriers, no housing
        end): fill it in, so one code path serves both.  The tree coordinates x = [theta_1,
        every edge] are general mode's with body 1 free and every edge placing."""
        self.carrier_of = [None] * self.nb
        self.R = [0.0] * self.nb
        self.free = [0]
        self.placing = self.indep = list(range(self.nm + self.ns))
        for mesh in self.meshes:
            mesh.carrier = None
            mesh.sgA, mesh.sgB = self.sigma[mesh.A], self.sigma[mesh.B]

    def _setup_lateral(self, lat):
        nb = self.nb
        params = []
        for i in range(nb):
            d = dict(LATERAL_KEYS)
            d.update(lat.get(i + 1, {}))
            for k in ("k_x", "k_y", "c_x", "c_y"):
                if not (d[k] >= 0.0 and math.isfinite(d[k])):
                    raise ValueError(f"body[{i + 1}].{k} = {d[k]!r} must be a finite number >= 0")
            params.append(d)
        self.lat_params = params
        self.is_lat = [bool(d["lateral"]) for d in params]
        for i in range(nb):
            if self.is_lat[i] and not (self.bodies[i].mass > 0.0 and math.isfinite(self.bodies[i].mass)):
                raise ValueError(f"body[{i + 1}] is lateral and needs a translational mass: "
                                 f"body[{i + 1}].m = {self.bodies[i].mass!r} kg must be > 0")
        for i in range(nb):
            c = self.carrier_of[i]
            if c is not None and self.is_lat[c] and not self.is_lat[i]:
                raise ValueError(f"body[{c + 1}] is a lateral carrier but its planet body[{i + 1}] "
                                 f"is not lateral (body[{i + 1}].lateral = false): a carrier with "
                                 "lateral = true needs all its planets lateral")
        self.lat_bodies = [i for i in range(nb) if self.is_lat[i]]
        self.qoff = {i: nb + 2 * j for j, i in enumerate(self.lat_bodies)}
        N = nb + 2 * len(self.lat_bodies)
        self.n = N
        self.axes = {}
        for i in self.lat_bodies:
            if self.carrier_of[i] is None:
                self.axes[i] = np.eye(2)
            else:
                r = np.array(self.planet_position(i))
                er = r / math.hypot(r[0], r[1])
                self.axes[i] = np.column_stack([er, _perp(er)])
        self.kq = np.array([params[i][k] for i in self.lat_bodies for k in ("k_x", "k_y")])
        self.cq = np.array([params[i][k] for i in self.lat_bodies for k in ("c_x", "c_y")])
        # constant part of M: spins (+ m R^2 of the planets that are not lateral), masses of the
        # lateral bodies that are not planets
        Jrot = np.array([b.J for b in self.bodies], dtype=float)
        for i in range(nb):
            c = self.carrier_of[i]
            if c is not None and not self.is_lat[i]:
                Jrot[c] += self.bodies[i].mass * self.R[i] ** 2
        self.M0 = np.zeros((N, N))
        self.M0[:nb, :nb] = np.diag(Jrot)
        self.lat_planets = []
        for i in self.lat_bodies:
            k = self.qoff[i]
            c = self.carrier_of[i]
            if c is None:
                self.M0[k, k] = self.M0[k + 1, k + 1] = self.bodies[i].mass
                continue
            qc = self.qoff[c] if self.is_lat[c] else None
            cols = np.array([c, k, k + 1] + ([qc, qc + 1] if qc is not None else []))
            self.lat_planets.append(LatPlanet(c, float(self.sigma[c]), k, qc, self.axes[i],
                                              np.array(self.planet_position(i)),
                                              self.bodies[i].mass, cols, np.ix_(cols, cols)))
        for mesh in self.meshes:
            mesh.lat = self._mesh_lateral(mesh)
        self._check_held()

    def _mesh_lateral(self, mesh):
        N, H = self.n, self.H
        Ph, Pc = np.zeros((2, N + 1)), np.zeros((2, N + 1))
        for X, s in ((mesh.A, 1.0), (mesh.B, -1.0)):
            if X == H:
                continue
            c = self.carrier_of[X]
            if c is not None:
                if self.is_lat[X]:
                    k = self.qoff[X]
                    Pc[:, k:k + 2] += s * self.axes[X]
                if self.is_lat[c]:
                    k = self.qoff[c]
                    Ph[:, k:k + 2] += s * np.eye(2)
            elif self.is_lat[X]:
                k = self.qoff[X]
                Ph[:, k:k + 2] += s * np.eye(2)

        def unit(flank, fn, ft):
            return mesh.force_on_B([(flank, 0, fn, ft)])

        def row(X, sg, k):
            r = np.zeros(N + 1)
            if X == H:
                r[N] = sg           # a gear in the housing: theta = sigma psi_H
            else:
                r[X] = 1.0
            if mesh.carrier is not None:
                r[mesh.carrier] -= k
            return r
        kA = getattr(mesh, "kA", 0.0)
        kB = getattr(mesh, "kB", 0.0)
        rowA, rowB = row(mesh.A, mesh.sgA, kA), row(mesh.B, mesh.sgB, kB)
        g = mesh.g
        return MeshLat(mesh.carrier, Ph, Pc, bool(Ph.any() or Pc.any()),
                       {1: unit(1, 1.0, 0.0), -1: unit(-1, 1.0, 0.0)},
                       {1: unit(1, 0.0, 1.0), -1: unit(-1, 0.0, 1.0)},
                       rowA, rowB, g.rAb * rowA - g.rBb * rowB)

    def _check_held(self):
        """Decision 8: K_bearing + sum over the meshes that move with q_i of g g^T nonsingular,
        g = d(delta_f)/dq_i at t = 0 (every carrier at psi = 0, so JD's q block is Ph + Pc)."""
        for i in self.lat_bodies:
            d = self.lat_params[i]
            zero = [a for a, k in enumerate((d["k_x"], d["k_y"])) if k == 0.0]
            if not zero:
                continue
            k0 = self.qoff[i]
            S, names = np.zeros((2, 2)), []
            for mesh in self.meshes:
                blk = (mesh.lat.Ph + mesh.lat.Pc)[:, k0:k0 + 2]
                if blk.any():
                    g = mesh.lat.n[1] @ blk
                    S += np.outer(g, g)
                    names.append(f"mesh[{mesh.m}]")
            frame = ("its carrier's frame (radial, tangential)" if self.carrier_of[i] is not None
                     else "the housing frame")
            if len(zero) == 2:
                w, vec = np.linalg.eigh(S)
                bad, v = w[0] <= 1e-12, vec[:, 0]
            else:
                a = zero[0]
                bad, v = S[a, a] <= 1e-12, np.eye(2)[a]
            if bad:
                ks = ", ".join(f"{k} = {d[k]!r} N/m" for k in ("k_x", "k_y"))
                raise ValueError(
                    f"body[{i + 1}] is lateral with a zero bearing stiffness ({ks}) and nothing "
                    f"holds it along ({v[0]:.6g}, {v[1]:.6g}) in {frame}: the forward lines of "
                    f"action of its meshes ({', '.join(names) or 'none'}) do not span the plane")

    # ---------------------------------------------------------------- state and kinematics
    def _state(self, y):
        nb, N = self.nb, self.n
        x, xd = y[:nb], y[N:N + nb]
        Th, V = np.empty(N), np.empty(N)
        Th[:nb], Th[nb:] = self.T @ x, y[nb:N]
        V[:nb], V[nb:] = self.T @ xd, y[N + nb:2 * N]
        return x, xd, Th, V

    def _psi(self, c, Th):
        return self.psi0[c] + self.sigma[c] * Th[c]

    def mass_matrix(self, Th, V):
        """M(Th) and h(Th, V) of M V' = Q - h (module docstring, KINETIC ENERGY)."""
        M = self.M0.copy()
        h = np.zeros(self.n)
        for pl in self.lat_planets:
            q, qd = Th[pl.qi:pl.qi + 2], V[pl.qi:pl.qi + 2]
            r = pl.r0 + pl.B @ q
            Om = pl.sc * V[pl.c]
            G = np.empty((2, len(pl.cols)))
            G[:, 0] = pl.sc * _perp(r)
            G[:, 1:3] = pl.B
            if pl.qc is not None:
                G[:, 3:5] = _rot(-self._psi(pl.c, Th))
            a0 = 2.0 * Om * _perp(pl.B @ qd) - Om * Om * r
            M[pl.ix] += pl.m * (G.T @ G)
            h[pl.cols] += pl.m * (G.T @ a0)
        return M, h

    def _lat(self, mesh, Th, V):
        """D, D' (mesh frame) and JD = dD/dTh (2 x N+1), or None when no centre moves."""
        L = mesh.lat
        if not L.on:
            return _ZERO2, _ZERO2, None
        N = self.n
        if L.c is None:
            JD = L.Ph + L.Pc
            D = JD[:, :N] @ Th
        else:
            R = _rot(-self._psi(L.c, Th))
            Dh = R @ (L.Ph[:, :N] @ Th)
            D = Dh + L.Pc[:, :N] @ Th
            JD = R @ L.Ph + L.Pc
            JD[:, L.c] -= self.sigma[L.c] * _perp(Dh)
        return D, JD[:, :N] @ V, JD

    def _lat_acc(self, mesh, Th, V, acc):
        """D'' (mesh frame) for the contact decisions' tie rule."""
        L = mesh.lat
        if not L.on:
            return _ZERO2
        N = self.n
        if L.c is None:
            return (L.Ph + L.Pc)[:, :N] @ acc
        c, sc = L.c, self.sigma[L.c]
        Phq = L.Ph[:, :N]
        uh, uh1, uh2 = Phq @ Th, Phq @ V, Phq @ acc
        Om, Omd = sc * V[c], sc * acc[c]
        R = _rot(-self._psi(c, Th))
        return (R @ (uh2 - 2.0 * Om * _perp(uh1) - Omd * _perp(uh) - Om * Om * uh)
                + L.Pc[:, :N] @ acc)

    # ---------------------------------------------------------------- forces and dynamics
    def _mesh_forces(self, mesh, Th, V, x, xd, kf, kb, Q):
        """Subtracts the mesh's generalized forces from Q (length N+1); returns P_loss and the
        carrying pairs' (flank, n_A, F_n, F_t)."""
        g, L = mesh.g, mesh.lat
        e = self._e(mesh, x) + mesh.dte0
        ve = self._e(mesh, xd)
        D, Dd, JD = self._lat(mesh, Th, V)
        thA, _thB = self._rel(mesh, Th)
        wA, wB = self._rel(mesh, V)
        uA = g.rAb * thA
        ploss = 0.0
        forces = []
        for flank, ks in ((1, kf), (-1, kb)):
            if not ks:
                continue
            n_ = L.n[flank]
            if flank == 1:
                d, dd, row = e + n_ @ D, ve + n_ @ Dd, L.re
            else:
                d, dd, row = -g.backlash - e + n_ @ D, -ve + n_ @ Dd, -L.re
            if JD is not None:
                row = row + n_ @ JD
            if mesh.lumped:
                F = mesh.k_eff(len(ks)) * d + mesh.c_l * dd
                Q -= F * row
                ploss += mesh.c_l * dd * dd
                forces += [(flank, n, F / len(ks), 0.0) for n in ks]
                continue
            kap = g.kappa
            N_ = (G.johnson_N(d, g.L + kap * d, g.E_star) if d >= 0.0
                  else -G.johnson_N(-d, g.L - kap * d, g.E_star))
            Fn = mesh.width * N_ * (1.0 + mesh.chi * dd)
            Q -= len(ks) * Fn * row
            ploss += len(ks) * mesh.width * N_ * mesh.chi * dd * dd
            if mesh.mu != 0.0:
                t_ = L.t[flank]
                vt = t_ @ Dd
                tJD = t_ @ JD if JD is not None else None
            for n in ks:
                sA = mesh.sA_f(uA, n) if flank == 1 else mesh.sA_b(uA, n)
                Ft = 0.0
                if mesh.mu != 0.0:
                    # READING: the real s_B at the total delta; the lateral sliding is the rate
                    # of D in the mesh's frame (vt), not in the housing's
                    sB = g.L + kap * d - kap * sA
                    vs = -wA * sA + wB * sB + vt
                    Ft = mesh.mu * math.tanh(vs / mesh.v_reg) * Fn
                    ploss += Ft * vs
                    rowv = -sA * L.rowA + sB * L.rowB
                    if tJD is not None:
                        rowv = rowv + tJD
                    Q -= Ft * rowv
                forces.append((flank, n, Fn, Ft))
        return ploss, forces

    def _forces(self, Th, V, x, xd, tau, kfkb):
        """Generalized forces Q (N+1: entry N the housing's absolute torque), P_loss, the power
        of the inputs and drags, and each mesh's (P_loss, pairs)."""
        nb, N, H = self.nb, self.n, self.H
        Q = np.zeros(N + 1)
        th, w = Th[:nb], V[:nb]
        tau = self.with_ripples(tau, th)
        Qd, Pd = self._drag(w)
        Q[:nb] = tau + Qd
        ploss = 0.0
        for s_ in self.shafts:
            q_, qd_ = self._q(s_, x), self._q(s_, xd)
            ts = s_.k * (q_ + s_.twist0) + s_.d * qd_
            if s_.a != H:
                Q[s_.a] -= ts
            else:
                Q[N] -= s_.sg * ts
            if s_.b != H:
                Q[s_.b] += ts
            else:
                Q[N] += s_.sg * ts
            ploss += s_.d * qd_ * qd_
        qd = V[nb:]
        Q[nb:N] -= self.kq * Th[nb:] + self.cq * qd
        ploss += float(np.dot(self.cq * qd, qd))
        per_mesh = []
        for mesh, (kf, kb) in zip(self.meshes, kfkb):
            pm = self._mesh_forces(mesh, Th, V, x, xd, kf, kb, Q) if (kf or kb) else (0.0, [])
            ploss += pm[0]
            per_mesh.append(pm)
        return Q, ploss, float(np.dot(tau, w)) + Pd, per_mesh

    def _accel(self, y, kfkb, tau):
        x, xd, Th, V = self._state(y)
        Q, pl, pext, _pm = self._forces(Th, V, x, xd, tau, kfkb)
        M, h = self.mass_matrix(Th, V)
        return np.linalg.solve(M, Q[:self.n] - h), pl, pext

    def accelerations(self, t, y, cfg, tau):
        """Generalized accelerations [theta'', q''] (length N)."""
        return self._accel(y, [(ms.kf, ms.kb) for ms in cfg.meshes], tau)[0]

    def make_rhs(self, cfg, seg):
        nb, N, E = self.nb, self.n, self.E
        t0, v0, dv = seg
        kfkb = [(ms.kf, ms.kb) for ms in cfg.meshes]

        def rhs(t, y):
            a, pl, pext = self._accel(y, kfkb, v0 + dv * (t - t0))
            out = np.empty(2 * N + 2)
            out[:N] = y[N:2 * N]
            out[N:N + nb] = E @ a[:nb]
            out[N + nb:2 * N] = a[nb:]
            out[2 * N] = pext
            out[2 * N + 1] = pl
            return out
        return rhs

    # ---------------------------------------------------------------- contact decisions
    def _mesh_kin(self, mesh, y, acc):
        x, xd, Th, V = self._state(y)
        g, L = mesh.g, mesh.lat
        thA, thB = self._rel(mesh, Th)
        wA, wB = self._rel(mesh, V)
        aA, aB = self._rel(mesh, acc)
        e = self._e(mesh, x) + mesh.dte0
        ve = self._e(mesh, xd)
        ae = g.rAb * aA - g.rBb * aB
        D, Dd, _JD = self._lat(mesh, Th, V)
        Ddd = self._lat_acc(mesh, Th, V, acc)
        lat = {fl: (L.n[fl] @ D, L.n[fl] @ Dd, L.n[fl] @ Ddd) for fl in (1, -1)}
        lf, lb = lat[1], lat[-1]
        return dict(uA=g.rAb * thA, uB=g.rBb * thB, wA=wA, wB=wB, aA=aA, aB=aB,
                    f=(e + lf[0], ve + lf[1], ae + lf[2]),
                    b=(-g.backlash - e + lb[0], -ve + lb[1], -ae + lb[2]), lat=lat)

    def _decide(self, y, acc, tie_aware=True):
        # the first pass (tie_aware False, train_ref.classify) decides on values alone
        a = acc if tie_aware else np.zeros(self.n)
        states = tuple((self._decide_lumped if mesh.lumped else self._decide_johnson)(
            mesh, self._mesh_kin(mesh, y, a), tie_aware) for mesh in self.meshes)
        return T.Config(states, a)

    def _decide_johnson(self, mesh, k, tie_aware):
        """train_ref._decide_mesh with the total penetrations: B's tip gate on s~_B + n . D."""
        g = mesh.g
        rAb, rBb, pb = g.rAb, g.rBb, g.p_b
        uA, uB, wA, wB, aA, aB = k["uA"], k["uB"], k["wA"], k["wB"], k["aA"], k["aB"]

        def side(c, c1, c2, tol):
            return self._side(c, c1, c2, tol) if tie_aware else c >= -tol

        on_f = side(*k["f"], self.TOL_DELTA)
        on_b = mesh.bwd and side(*k["b"], self.TOL_DELTA)
        sig = {"df": 1.0 if on_f else -1.0}
        if mesh.bwd:
            sig["db"] = 1.0 if on_b else -1.0
        tipB = g.L - g.s_a
        lo_win = g.s_b - g.m_c * pb
        out = {1: [], -1: []}
        for flank, on, tag in ((1, on_f, "f"), (-1, on_b, "b")):
            if not on:
                continue
            l0, l1, l2 = k["lat"][flank]
            _d, v, a2 = k[tag]
            rel = True
            if mesh.chi > 0.0:
                rel = side(1.0 + mesh.chi * v, mesh.chi * a2, 0.0, self.TOL_REL)
                sig["r" + tag] = 1.0 if rel else -1.0
            sA_of = mesh.sA_f if flank == 1 else mesh.sA_b
            sB_of = mesh.sB_f if flank == 1 else mesh.sB_b
            r1, r2 = flank * rAb * wA, flank * rAb * aA          # d s_A/dt, d2 s_A/dt2
            # READING: B's tip gate on the total penetration, s~_B + n . D (A's on s_A alone)
            b1, b2 = -flank * rBb * wB + l1, -flank * rBb * aB + l2   # d/dt, d2/dt2 of it
            for n in mesh.candidates(sA_of(uA, 0), flank):
                sA, sB = sA_of(uA, n), sB_of(uB, n) + l0
                ok = (side(g.s_b - sA, -r1, -r2, self.TOL_POS)
                      and side(tipB - sB, -b1, -b2, self.TOL_POS))
                if ok and mesh.window_active:
                    ok = side(sA - lo_win, r1, r2, self.TOL_POS)
                if ok and rel:
                    out[flank].append(n)
            Kp = mesh.Kf if flank == 1 else mesh.Kb
            sig["u" + tag] = self._periodic_sign(pb, sA_of(uA, 0) - g.s_b, r1, r2)
            sig["l" + tag] = self._periodic_sign(pb, sB_of(uB, -Kp) + l0 - tipB, b1, b2)
        return T.MeshState(on_f, bool(on_b), tuple(out[1]), tuple(out[-1]), sig)

    def _decide_lumped(self, mesh, k, tie_aware):
        """train_ref._decide_mesh_lumped with the total deflections (gates on s_A alone)."""
        g = mesh.g
        rAb, pb = g.rAb, g.p_b
        uA, wA, aA = k["uA"], k["wA"], k["aA"]

        def side(c, c1, c2, tol):
            return self._side(c, c1, c2, tol) if tie_aware else c >= -tol

        on_f = side(*k["f"], self.TOL_DELTA)
        on_b = mesh.bwd and side(*k["b"], self.TOL_DELTA)
        sig = {"df": 1.0 if on_f else -1.0}
        if mesh.bwd:
            sig["db"] = 1.0 if on_b else -1.0
        lo_win = g.s_b - g.m_c * pb
        out = {}
        for flank, on, sA_of in ((1, on_f, mesh.sA_f), (-1, on_b, mesh.sA_b)):
            ks = []
            if on:
                r1, r2 = flank * rAb * wA, flank * rAb * aA
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
        return T.MeshState(on_f, bool(on_b), out[1], out[-1], sig)

    # ---------------------------------------------------------------- events
    def _event_fns(self, mesh):
        """Functions of the state vector for one mesh's events and guards: the flanks' total
        penetrations and their rates, D, D', and the gate coordinates u_A, u_B with rates."""
        L, nb, N = mesh.lat, self.nb, self.n
        d0, jb = mesh.dte0, mesh.g.backlash
        if mesh.ie is not None:
            ef = lambda yy: yy[mesh.ie]
            vf = lambda yy: yy[N + mesh.ie]
        else:     # a loop mesh: e = ce . x over edge coordinates
            ef = lambda yy: float(np.dot(mesh.ce, yy[:nb]))
            vf = lambda yy: float(np.dot(mesh.ce, yy[N:N + nb]))
        if not L.on:
            D = Dd = lambda yy: _ZERO2
        elif L.c is None:
            P = (L.Ph + L.Pc)[:, nb:N]
            D = lambda yy: P @ yy[nb:N]
            Dd = lambda yy: P @ yy[N + nb:2 * N]
        else:
            Phq, Pcq = L.Ph[:, nb:N], L.Pc[:, nb:N]
            sc, Tc, psi0 = self.sigma[L.c], self.T[L.c], self.psi0[L.c]

            def D(yy):
                q = yy[nb:N]
                return _rot(-(psi0 + sc * float(Tc @ yy[:nb]))) @ (Phq @ q) + Pcq @ q

            def Dd(yy):
                q, qd = yy[nb:N], yy[N + nb:2 * N]
                Om = sc * float(Tc @ yy[N:N + nb])
                R = _rot(-(psi0 + sc * float(Tc @ yy[:nb])))
                return R @ (Phq @ qd - Om * _perp(Phq @ q)) + Pcq @ qd
        nf, nbk = L.n[1], L.n[-1]
        return dict(
            delta={1: lambda yy: ef(yy) + d0 + float(nf @ D(yy)),
                   -1: lambda yy: -jb - ef(yy) - d0 + float(nbk @ D(yy))},
            rate={1: lambda yy: vf(yy) + float(nf @ Dd(yy)),
                  -1: lambda yy: -vf(yy) + float(nbk @ Dd(yy))},
            lat={fl: (lambda yy, n_=L.n[fl]: float(n_ @ D(yy))) for fl in (1, -1)},
            latd={fl: (lambda yy, n_=L.n[fl]: float(n_ @ Dd(yy))) for fl in (1, -1)},
            uA=lambda yy: float(np.dot(mesh.cA, yy[:nb])),
            uB=lambda yy: float(np.dot(mesh.cB, yy[:nb])),
            wA=lambda yy: float(np.dot(mesh.cA, yy[N:N + nb])),
            wB=lambda yy: float(np.dot(mesh.cB, yy[N:N + nb])))

    def make_events(self, cfg, y):
        """train_ref.make_events with the total penetrations (module docstring, INTEGRATION)."""
        evs, guards = [], []
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

        def add_periodic(pb, sig, xi_of, xi, xi1, xi2):
            # sig * sin(pi xi/p_b); xi_of(yy) the argument, xi, xi1, xi2 its value and rates now
            kp = math.pi / pb
            s_, c_ = math.sin(kp * xi), math.cos(kp * xi)
            w1 = kp * xi1
            val, d1, d2 = sig * s_, sig * c_ * w1, sig * (c_ * kp * xi2 - s_ * w1 * w1)
            add(lambda t, yy: sig * math.sin(kp * xi_of(yy)), val, d1, d2, kp * self.TOL_POS, 1e-12)

        for mesh, ms in zip(self.meshes, cfg.meshes):
            g = mesh.g
            k = self._mesh_kin(mesh, y, cfg.acc)
            fns = self._event_fns(mesh)
            s, pb = ms.sig, g.p_b
            for flank, tag in ((1, "f"), (-1, "b")):
                if flank == -1 and not mesh.bwd:
                    continue
                sd = s["d" + tag]
                c0, c1, c2 = k[tag]
                add(lambda t, yy, sd=sd, fn=fns["delta"][flank]: sd * fn(yy),
                    sd * c0, sd * c1, sd * c2, self.TOL_DELTA, 1e-20)
            rAb, rBb = g.rAb, g.rBb
            tipB = g.L - g.s_a
            uA_of, uB_of = fns["uA"], fns["uB"]
            for flank, on, tag, S0A, S0B, Kp in ((1, ms.on_f, "f", mesh.SfA, mesh.SfB, mesh.Kf),
                                                  (-1, ms.on_b, "b", mesh.SbA, mesh.SbB, mesh.Kb)):
                if not on:
                    continue
                fl = float(flank)
                xiA = mesh.sA_f(k["uA"], 0) if flank == 1 else mesh.sA_b(k["uA"], 0)
                r1, r2 = fl * rAb * k["wA"], fl * rAb * k["aA"]
                edges = (("u", g.s_b), ("l", g.s_a)) if mesh.lumped else (("u", g.s_b),)
                for edge, s_edge in edges:
                    add_periodic(pb, s[edge + tag],
                                 lambda yy, S0A=S0A, fl=fl, s_edge=s_edge, uA_of=uA_of:
                                 S0A + fl * uA_of(yy) - s_edge,
                                 xiA - s_edge, r1, r2)
                if mesh.lumped:
                    continue
                # B's tip: s~_B(n) + n . D - tipB = S0B - fl u_B + n . D - tipB (mod p_b)
                l0, l1, l2 = k["lat"][flank]
                sB0 = (mesh.sB_f(k["uB"], -Kp) if flank == 1 else mesh.sB_b(k["uB"], -Kp)) + l0
                add_periodic(pb, s["l" + tag],
                             lambda yy, S0B=S0B, fl=fl, lat=fns["lat"][flank], uB_of=uB_of, tipB=tipB:
                             S0B - fl * uB_of(yy) + lat(yy) - tipB,
                             sB0 - tipB, -fl * rBb * k["wB"] + l1, -fl * rBb * k["aB"] + l2)
                if mesh.chi > 0.0:
                    sr, chi = s["r" + tag], mesh.chi
                    _d, v, a2 = k[tag]
                    add(lambda t, yy, sr=sr, chi=chi, fn=fns["rate"][flank]: sr * (1.0 + chi * fn(yy)),
                        sr * (1.0 + chi * v), sr * chi * a2, 0.0, self.TOL_REL, 1e-14)
            # guards: extrema of each flank's delta, reversals of the gate coordinates
            gs = [fns["rate"][1], fns["wA"]]
            if mesh.lat.on:
                if mesh.bwd:
                    gs.append(fns["rate"][-1])
                for fl in (1, -1):
                    gs.append(lambda yy, fl=fl, wB=fns["wB"], latd=fns["latd"][fl]:
                              -fl * wB(yy) + latd(yy))
            else:
                gs.append(fns["wB"])
            guards += [lambda t, yy, fn=fn: fn(yy) for fn in gs]
        for fn in guards:
            fn.terminal = False
            fn.direction = 0.0
        return evs, guards

    # ---------------------------------------------------------------- integration set-up
    def simulate(self, stop_time, output_interval, inputs=None, rtol=1e-10, method="DOP853",
                 perturb_w1=0.0, max_restarts=2_000_000):
        """train_ref.GearTrain.simulate; the start-speed perturbation goes through
        initial_state (the state is longer than train_ref's); the bearing forces are always
        outputs."""
        self._perturb_w1 = perturb_w1
        try:
            return super().simulate(stop_time, output_interval, inputs, rtol=rtol, method=method,
                                    max_restarts=max_restarts, bearing_forces=True)
        finally:
            self._perturb_w1 = 0.0

    def initial_state(self):
        nb, N = self.nb, self.n
        w = np.array([b.w0 for b in self.bodies])
        w[0] += getattr(self, "_perturb_w1", 0.0)
        y = np.zeros(2 * N + 2)
        y[N:N + nb] = self.E @ w
        for i in self.lat_bodies:
            k, d = self.qoff[i], self.lat_params[i]
            y[k:k + 2] = d["x_start"], d["y_start"]
            y[N + k:N + k + 2] = d["vx_start"], d["vy_start"]
        return y

    def lateral_scale(self, i, inputs):
        """Displacement scale of lateral body i: the smallest characteristic penetration of
        the meshes its displacement moves (it enters them directly)."""
        k0 = self.qoff[i]
        sc = [self.delta_scale(mesh, inputs) for mesh in self.meshes
              if (mesh.lat.Ph + mesh.lat.Pc)[:, k0:k0 + 2].any()]
        return min(sc) if sc else 1e-6

    def atol(self, inputs, rtol):
        N = self.n
        wscale = max([1.0] + [abs(b.w0) for b in self.bodies])
        tmax = max(1.0, float(np.sum(inputs.max_abs())))
        pos = np.ones(N)
        for mesh in self.meshes:
            if mesh.ie is not None:
                pos[mesh.ie] = self.delta_scale(mesh, inputs)
        for s in self.shafts:
            if s.iq is not None:
                pos[s.iq] = max(tmax / s.k, abs(s.twist0), 1e-12)
        for i in self.lat_bodies:
            pos[self.qoff[i]:self.qoff[i] + 2] = self.lateral_scale(i, inputs)
        vel = pos * 1e4
        vel[:len(self.free)] = wscale
        return np.concatenate([pos, vel, [1.0, 1.0]]) * rtol

    def max_step(self, cfg, y, span):
        """No gate coordinate moves more than p_b/8 in one step (train_ref's rule)."""
        nb, N = self.nb, self.n
        w = self.T @ y[N:N + nb]
        acc = cfg.acc[:nb]
        h = math.inf
        for mesh in self.meshes:
            g = mesh.g
            wA, wB = self._rel(mesh, w)
            aA, aB = self._rel(mesh, acc)
            vline = (max(abs(g.rAb * wA), abs(g.rBb * wB))
                     + max(abs(g.rAb * aA), abs(g.rBb * aB)) * span)
            h = min(h, g.p_b / (8.0 * vline + 1e-300))
        return h

    # ---------------------------------------------------------------- outputs
    def output_names(self, bearing=None):
        names = ["time"]
        for i in range(1, self.nb + 1):
            names += [f"body[{i}].theta", f"body[{i}].w"]
        names += [f"shaft[{j}].tau" for j in range(1, self.ns + 1)]
        for m in range(1, self.nm + 1):
            names += [f"mesh[{m}].{v}" for v in ("dte", "F_fwd", "F_bwd", "n_fwd", "n_bwd", "F_f1",
                                                 "F_f2", "F_b1", "F_b2", "P_loss")]
            if self.meshes[m - 1].lumped:
                names.append(f"mesh[{m}].k_mesh")
        names.append("housing.tau")
        for i in range(1, self.nb + 1):
            names += [f"body[{i}].{v}" for v in ("x", "y", "vx", "vy")]
        names += [f"mesh[{m}].delta_lat" for m in range(1, self.nm + 1)]
        for i in range(1, self.nb + 1):
            names += [f"body[{i}].Fx", f"body[{i}].Fy"]
        names += ["housing.Fx", "housing.Fy"]
        return names + ["E_kin", "E_el", "E_gate", "W_ext", "W_loss", "energy_residual"]

    def elastic_energy(self, y, cfg):
        x, xd, Th, V = self._state(y)
        U = 0.0
        for mesh, ms in zip(self.meshes, cfg.meshes):
            if not (ms.kf or ms.kb):
                continue
            k = self._mesh_kin(mesh, y, np.zeros(self.n))
            for ks, tag in ((ms.kf, "f"), (ms.kb, "b")):
                if not ks:
                    continue
                d = k[tag][0]
                U += (0.5 * mesh.k_eff(len(ks)) * d * d if mesh.lumped
                      else len(ks) * T.pair_energy(mesh, d))
        for s in self.shafts:
            U += 0.5 * s.k * (self._q(s, x) + s.twist0) ** 2
        return U + 0.5 * float(np.dot(self.kq * Th[self.nb:], Th[self.nb:]))

    def bearing_forces_lateral(self, Th, V, acc, per_mesh):
        """[body Fx, Fy ..., housing Fx, Fy] (module docstring, OUTPUTS)."""
        nb, H = self.nb, self.H
        F = np.zeros((nb + 1, 2))          # meshes' forces: planets in the carrier frame
        for mesh, (_pl, forces) in zip(self.meshes, per_mesh):
            if not forces:
                continue
            fB = mesh.force_on_B(forces)
            c = mesh.carrier
            fB_h = _rot(self._psi(c, Th)) @ fB if c is not None else fB
            for X, sgn in ((mesh.B, 1.0), (mesh.A, -1.0)):
                if X != H and self.carrier_of[X] is not None:
                    F[X] += sgn * fB
                else:
                    F[nb if X == H else X] += sgn * fB_h
        out = np.zeros((nb, 2))
        pins = np.zeros((nb, 2))
        spring = {}                        # -k q - c q' of each lateral body, in its axes
        for i in self.lat_bodies:
            k = self.qoff[i]
            sl = slice(k - nb, k - nb + 2)
            spring[i] = -(self.kq[sl] * Th[k:k + 2] + self.cq[sl] * V[k:k + 2])
        for i in range(nb):
            c = self.carrier_of[i]
            if c is None:
                continue
            r = np.array(self.planet_position(i))
            if self.is_lat[i]:
                P = self.axes[i] @ spring[i]          # the pin's force on the planet, carrier frame
                out[i] = spring[i]
            else:
                Om, al = self.sigma[c] * V[c], self.sigma[c] * acc[c]
                P = self.bodies[i].mass * (-Om * Om * r + al * _perp(r)) - F[i]
                er = r / math.hypot(r[0], r[1])
                out[i] = (float(P @ er), float(P @ _perp(er)))
            pins[c] += _rot(self._psi(c, Th)) @ P
        hous = F[nb].copy()
        for i in range(nb):
            if self.carrier_of[i] is not None:
                continue
            out[i] = spring[i] if self.is_lat[i] else -F[i] + pins[i]
            hous -= out[i]
        return [float(v) for v in out.ravel()] + [float(hous[0]), float(hous[1])]

    def outputs(self, t, y, cfg, e_gate, bearing=None, tau=None):
        nb, N = self.nb, self.n
        x, xd, Th, V = self._state(y)
        tau = self._tau_at(t) if tau is None else tau
        Q, _pl, _pext, per_mesh = self._forces(Th, V, x, xd, tau, [(ms.kf, ms.kb) for ms in cfg.meshes])
        M, h = self.mass_matrix(Th, V)
        row = [t]
        for i in range(nb):
            row += [Th[i], V[i]]
        for s in self.shafts:
            row.append(s.k * (self._q(s, x) + s.twist0) + s.d * self._q(s, xd))
        for mesh, ms, (pl, forces) in zip(self.meshes, cfg.meshes, per_mesh):
            row += self._mesh_row(mesh, ms, self._e(mesh, x) + mesh.dte0, forces, pl)
        row.append(float(Q[N]))
        for i in range(nb):
            if self.is_lat[i]:
                k = self.qoff[i]
                row += [Th[k], Th[k + 1], V[k], V[k + 1]]
            else:
                row += [0.0, 0.0, 0.0, 0.0]
        for mesh in self.meshes:
            D, _Dd, _JD = self._lat(mesh, Th, V)
            row.append(float(mesh.lat.n[1] @ D))
        needs_acc = any(self.carrier_of[i] is not None and not self.is_lat[i] for i in range(nb))
        acc = np.linalg.solve(M, Q[:N] - h) if needs_acc else None
        row += self.bearing_forces_lateral(Th, V, acc, per_mesh)
        row += [0.5 * float(V @ M @ V), self.elastic_energy(y, cfg), e_gate, y[2 * N], y[2 * N + 1]]
        return row


# --------------------------------------------------------------------------------------------
# Static states, linearization
# --------------------------------------------------------------------------------------------

def forward_config(train: LateralTrain, y):
    """The contact state with every mesh on its forward flank (its pairs gated by position),
    whatever its penetration: the lumped law is not clipped and the Johnson law is extended
    oddly through 0 inside a segment, so the forces are smooth in the positions."""
    states = []
    for mesh in train.meshes:
        k = train._mesh_kin(mesh, y, np.zeros(train.n))
        k["f"], k["b"] = (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)
        decide = train._decide_lumped if mesh.lumped else train._decide_johnson
        states.append(decide(mesh, k, False))
    return T.Config(tuple(states), np.zeros(train.n))


def static_state(train: LateralTrain, y, tau, step=1e-10, max_iter=40):
    """y with every position but the free bodies' angles moved to where every edge and lateral
    coordinate has zero acceleration at y's speeds: static balance, or relative balance in a
    train that spins or accelerates as a rigid body.  Newton on central differences, every mesh
    held on its forward flank (forward_config); the balance found must be one (RuntimeError
    otherwise).  The positions are lengths (m) except shaft twists (rad); `step` is far below
    any penetration."""
    nb, N, E = train.nb, train.n, train.E
    f = len(train.free)
    idx = np.arange(f, N)
    tau = np.asarray(tau, dtype=float)

    def resid(yy, cfg):
        a = train.accelerations(0.0, yy, cfg, tau)
        return np.concatenate([E @ a[:nb], a[nb:]])[f:]
    y = np.array(y, dtype=float)
    for _ in range(max_iter):
        cfg = forward_config(train, y)
        r = resid(y, cfg)
        Jm = np.empty((len(idx), len(idx)))
        for k, j in enumerate(idx):
            yp, ym = y.copy(), y.copy()
            yp[j] += step
            ym[j] -= step
            Jm[:, k] = (resid(yp, cfg) - resid(ym, cfg)) / (2.0 * step)
        dz = np.linalg.solve(Jm, -r)
        y[idx] += dz
        if np.max(np.abs(dz)) <= 1e-15 * max(np.max(np.abs(y[idx])), 1e-6):
            break
    else:
        raise RuntimeError(f"static_state: Newton did not converge (last step {np.max(np.abs(dz))!r})")
    got = train.classify(0.0, y, tau)
    off = [f"mesh[{mesh.m}]" for mesh, ms, want in zip(train.meshes, got.meshes, cfg.meshes)
           if not ms.on_f or ms.on_b or ms.kf != want.kf]
    if off:
        raise RuntimeError("static_state: at the balance found " + ", ".join(off) + " are not on "
                           "their forward flanks alone")
    return y


def static_start(start_values: dict, max_rounds=6) -> dict:
    """Start values at the static (or rigidly spinning/accelerating) balance under the
    constant torques body[i].tau: speeds of the rigid motion through the free bodies' w_start
    (train_ref.rigid_kernel), then static_state; its edge coordinates go into the placing
    meshes' dte_start and shafts' twist_start (placing again reproduces the angles; a loop
    mesh's penetration follows from them), its lateral coordinates into x_start, y_start.
    A carrier always starts at psi = 0 while the balance found may have it turned by ~delta/R,
    which turns the housing-frame displacements seen in its frame: solve again on the train
    so built until its start is the balance, to 1e-15 (m; rad for a shaft's twist), far below
    any penetration and above the placement's rounding (~1e-17 m): each round shrinks that
    turn by a factor ~delta/R, two rounds do it."""
    sv = dict(start_values)
    tr = LateralTrain(sv)
    w = T.rigid_kernel(tr) @ np.array([tr.bodies[i].w0 for i in tr.free])
    for i in range(tr.nb):
        sv[f"body[{i + 1}].w_start"] = float(w[i])
    for _ in range(max_rounds):
        tr = LateralTrain(sv)
        if sorted(tr.placing) != sorted(tr.indep):
            raise NotImplementedError("static_start: a loop edge is an independent coordinate")
        tau = np.array([b.tau for b in tr.bodies])
        y0 = tr.initial_state()
        y = static_state(tr, y0, tau)
        if np.max(np.abs(y - y0)) <= 1e-15:
            return sv
        f = len(tr.free)
        for r_, k in enumerate(sorted(tr.indep)):
            if k < tr.nm:
                sv[f"mesh[{k + 1}].dte_start"] = float(tr.meshes[k].dte0 + y[f + r_])
            else:
                s_ = tr.shafts[k - tr.nm]
                sv[f"shaft[{s_.j}].twist_start"] = float(s_.twist0 + y[f + r_])
        for i in tr.lat_bodies:
            k = tr.qoff[i]
            sv[f"body[{i + 1}].x_start"], sv[f"body[{i + 1}].y_start"] = float(y[k]), float(y[k + 1])
    raise RuntimeError(f"static_start: the start is not the balance after {max_rounds} rounds")


def position_jacobian(train: LateralTrain, y, tau, step=1e-9):
    """d(x'', q'')/d(x, q) at y (central differences, the contact state of y held)."""
    nb, N, E = train.nb, train.n, train.E
    cfg = train.classify(0.0, y, tau)

    def acc(yy):
        a = train.accelerations(0.0, yy, cfg, tau)
        return np.concatenate([E @ a[:nb], a[nb:]])
    Jm = np.empty((N, N))
    for j in range(N):
        yp, ym = y.copy(), y.copy()
        yp[j] += step
        ym[j] -= step
        Jm[:, j] = (acc(yp) - acc(ym)) / (2.0 * step)
    return Jm


def state_jacobian(train: LateralTrain, y, tau, step_pos=1e-9, step_vel=1e-6):
    """d(y')/dy over positions and velocities (2N x 2N) at y, the contact state held."""
    N = train.n
    cfg = train.classify(0.0, y, tau)
    t0 = 0.0
    rhs = train.make_rhs(cfg, (t0, np.asarray(tau, dtype=float), np.zeros(len(tau))))
    A = np.empty((2 * N, 2 * N))
    for j in range(2 * N):
        h = step_pos if j < N else step_vel
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        A[:, j] = (rhs(t0, yp)[:2 * N] - rhs(t0, ym)[:2 * N]) / (2.0 * h)
    return A


def natural_frequencies(train: LateralTrain, y, tau):
    """Undamped natural frequencies [Hz], ascending, from the position Jacobian at y (speeds
    and damping not included): sqrt(eig(-d acc/d pos)) / (2 pi), negative rounding clipped."""
    lam = np.linalg.eigvals(-position_jacobian(train, y, tau))
    return np.sort(np.sqrt(np.clip(lam.real, 0.0, None)) / (2.0 * math.pi))


# --------------------------------------------------------------------------------------------
# Scenes
# --------------------------------------------------------------------------------------------

def scene_model(scene):
    tr = make_train(scene.get("start_values", {}))
    taus = [b.tau for b in tr.bodies]
    if "input_file" in scene:
        inputs = T.TrainInputs.from_csv(os.path.join(os.path.dirname(scene["path"]),
                                                     scene["input_file"]), taus)
    else:
        inputs = T.TrainInputs.constant(taus)
    return tr, inputs


def run_scene(scene, rtol=None, method="DOP853", perturb_rel=0.0):
    """train_ref.run_scene for a train without a lateral body (unchanged), else LateralTrain."""
    if not has_lateral(scene.get("start_values", {})):
        return T.run_scene(scene, rtol=rtol, method=method, perturb_rel=perturb_rel)
    if rtol is None:
        rtol = float(scene.get("reference_rtol", T.REF_RTOL))
    tr, inputs = scene_model(scene)
    dw = perturb_rel * max(abs(tr.bodies[0].w0), 1.0)
    return tr.simulate(scene["stop_time"], scene["output_interval"], inputs, rtol=rtol,
                       method=method, perturb_w1=dw)
