"""The checks of planetary.md section 6 on the gear-train FMU (SpurGearTrain.fmu) through FMPy.

    .venv/bin/python -m pytest -q tests/python/test_planetary_checks.py
    PLANETARY_TRAIN_FMU=target/fmu/SpurGearTrain.fmu .venv/bin/python -m pytest -q ...  # no build

The FMU is conftest's train_fmu_path (packaged from the working tree once per session), or the
file PLANETARY_TRAIN_FMU names.  Every run is fmpy.simulate_fmu (Co-Simulation) with start values.

The sets (module 2 mm, 20 deg, width 20 mm, backlash 50 um, chi 20 s/m, mu = 0; body 1 the sun
driven by T_s = 50 N.m, body 2 the carrier loaded by the drag c = T_s (1 + z_r/z_s)/w_c that
balances it at the Willis speed of w_s = 100 rad/s, bodies 3.. the planets (J 1e-4, m 0.3 kg),
the ring fixed: meshes 1..N sun-planet (A = sun), N+1..2N planet-ring (A = planet, B = 0,
internal)); every start is train_ref.quasi_static_start (speeds and penetrations of the static
loads, so no large start transient):
  IN_PHASE   21/18/57, x = 0.5/0/0.5, three planets at 2 pi/3: z_s/N = 7 (in phase);
  OUT_PHASE  20/19/58, same shifts, three planets at 2 pi/3: z_s/N = 20/3 (out of phase);
  UNEQUAL    21/18/57 with four planets at 2 pi (0, 17, 41, 60)/78 (unequal spacing).
Both tooth sets have z_s + z_p = 39 and z_r - z_p = 39 with equal shift sums, so every pair runs at
the same alpha_w and centre distance (R = 39.92 mm); (z_s + z_r)/N = 26 (assembly); contact
ratios 1.44/1.72 (21/18/57) and 1.43/1.71 (20/19/58), checked below from the FMU's calculated
parameters.

Recurring bounds (each test says which it uses):
* FORCE ENVELOPE: a damped mesh started at its static load keeps 0 <= F <= F_cap = 2 F0 (dynamic
  factor below 2; F0 = T_s/(N r_s) the equal share; with a pin error one planet may take the
  whole T_s/r_s, so F_cap = 2 T_s/r_s); asserted on the trace wherever a bound relies on it.
* QUADRATURE: the time mean of a mesh force over a window of length T_w by the trapezoid rule on
  the output grid (step h).  A force jumps at pair switches (by at most the flank's force, <= 2 F0);
  each interval holding a jump errs by at most |jump| h / 2 <= F_cap h / 2 (F_cap the FORCE
  ENVELOPE); between jumps the force oscillates at most at the mesh's natural frequency w_n (from
  its tangent stiffness k_mesh and the two gears' mobility r_bA^2/J_A + r_bB^2/J_B, at most that
  of the stiffest state seen) with amplitude <= F_cap, so |F''| <= F_cap w_n^2 and the rule errs
  by at most T_w h^2 |F''|/12.  Mean error <= (n_jumps F_cap h/2 + T_w h^2 F_cap w_n^2/12)/T_w.
* INTEGRATION: rel_tol = 1e-9; the body angles and speeds (error-controlled, relative) carry a
  global error of order rel_tol, allowed as 1000 rel_tol of the quantity.
"""

import math
import os
import sys
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy import calloc, free
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from reference_model import train_ref as T  # noqa: E402

FMI2_ERROR = 3
REL_TOL = 1e-9
MODULE, ALPHA0, WIDTH, BACKLASH, CHI = 0.002, math.radians(20.0), 0.02, 5e-5, 20.0
T_SUN, W_SUN = 50.0, 100.0
J_SUN, J_CARRIER, J_PLANET, M_PLANET = 2e-3, 0.05, 1e-4, 0.3
SHIFTS = (0.5, 0.0, 0.5)                      # x_sun, x_planet, x_ring
EQUAL3 = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)
UNEQUAL4 = tuple(2 * math.pi * k / 78 for k in (0, 17, 41, 60))


# ------------------------------------------------------------------------------ the FMU
@pytest.fixture(scope="module")
def fmu_dir(request, tmp_path_factory):
    path = os.environ.get("PLANETARY_TRAIN_FMU")
    path = Path(path) if path else request.getfixturevalue("train_fmu_path")
    return fmpy.extract(str(path), unzipdir=str(tmp_path_factory.mktemp("SpurGearTrainPlanetary")))


@pytest.fixture(scope="module")
def md(fmu_dir):
    return fmpy.read_model_description(fmu_dir)


def pair(zA, zB, xA, xB, internal):
    p = {"geometry": 2, "module": MODULE, "zA": zA, "zB": zB, "xA": xA, "xB": xB, "width": WIDTH,
         "backlash": BACKLASH, "chi": CHI, "mu": 0.0}
    if internal:
        p["internal"] = True
    return p


def simple_set(zs, zp, zr, angles, pin_t=None):
    """Start values of a simple set (module docstring), at train_ref.quasi_static_start."""
    N = len(angles)
    xs, xp, xr = SHIFTS
    wc = W_SUN * zs / (zs + zr)
    sv = {"n_bodies": 2 + N, "n_shafts": 0, "n_meshes": 2 * N,
          "body[1].J": J_SUN, "body[1].c": 0.0, "body[1].tau": T_SUN, "body[1].w_start": W_SUN,
          "body[2].J": J_CARRIER, "body[2].c": T_SUN * (1 + zr / zs) / wc, "body[2].tau": 0.0,
          "body[2].w_start": wc}
    for n, a in enumerate(angles):
        i = 3 + n
        sv.update({f"body[{i}].J": J_PLANET, f"body[{i}].m": M_PLANET, f"body[{i}].c": 0.0,
                   f"body[{i}].carrier": 2, f"body[{i}].orbit_angle": a, f"body[{i}].tau": 0.0})
        if pin_t and n in pin_t:
            sv[f"body[{i}].pin_error_t"] = pin_t[n]
        for m, A, B, p in ((1 + n, 1, i, pair(zs, zp, xs, xp, False)),
                           (1 + N + n, i, 0, pair(zp, zr, xp, xr, True))):
            sv[f"mesh[{m}].A"], sv[f"mesh[{m}].B"] = A, B
            sv.update({f"mesh[{m}].{k}": v for k, v in p.items()})
    return T.quasi_static_start(sv)


CONSTS = ("rAb", "rBb", "alpha_w", "s_a", "line_of_action", "base_pitch", "contact_ratio",
          "contact_objects_per_flank", "center_distance")


class Run:
    """One FMU run: its outputs as arrays, the set's data."""

    def __init__(self, fmu_dir, md, zs, zp, zr, angles, stop, dt, pin_t=None, extra=()):
        self.zs, self.zp, self.zr, self.angles = zs, zp, zr, angles
        self.N = N = len(angles)
        self.sv = simple_set(zs, zp, zr, angles, pin_t)
        self.tr = T.GearTrain(self.sv)          # the reference's geometry (static penetrations)
        names = ["E_kin", "E_gate", "W_loss", "energy_residual", "housing.tau"]
        names += [f"body[{i}].{v}" for i in range(1, N + 3) for v in ("theta", "w", "Fx", "Fy")]
        names += ["housing.Fx", "housing.Fy"]
        names += [f"mesh[{m}].{v}" for m in range(1, 2 * N + 1)
                  for v in ("dte", "F_fwd", "F_bwd", "n_fwd", "s_f1", "s_f2", "k_mesh") + CONSTS]
        names += list(extra)
        res = fmpy.simulate_fmu(fmu_dir, model_description=md,
                                start_values={**self.sv, "rel_tol": REL_TOL}, stop_time=stop,
                                output_interval=dt, output=names)
        self.dt = dt
        self.t = np.asarray(res["time"], dtype=float)
        self.c = {n: np.asarray(res[n], dtype=float) for n in names}
        self.k = {f"mesh[{m}].{v}": float(self.c[f"mesh[{m}].{v}"][0])
                  for m in range(1, 2 * N + 1) for v in CONSTS}
        self.rs, self.rp = self.k["mesh[1].rAb"], self.k["mesh[1].rBb"]
        self.rr = self.k[f"mesh[{N + 1}].rBb"]
        self.F0 = T_SUN / (N * self.rs)                 # static force of each sun-planet mesh
        # FORCE ENVELOPE: twice the static force; with a pin error one planet may carry it all
        self.cap = 2 * (N if pin_t else 1) * self.F0

    def __getitem__(self, name):
        return self.c[name]

    def window(self, t_from, period):
        """Rows k0..k1 spanning the largest whole number of `period`s from t_from on the grid."""
        k0 = int(np.searchsorted(self.t, t_from - 1e-12))
        n = math.floor((self.t[-1] - self.t[k0]) / period + 1e-9)
        k1 = k0 + int(round(n * period / self.dt))
        return k0, min(k1, len(self.t) - 1), n

    def mesh_period(self):
        """Nominal mesh period from the start speeds: 2 pi / (z_s (w_s - w_c))."""
        return 2 * math.pi / (self.zs * (self.sv["body[1].w_start"] - self.sv["body[2].w_start"]))

    def omega_n(self, m, JA, JB):
        mob = self.k[f"mesh[{m}].rAb"] ** 2 / JA + self.k[f"mesh[{m}].rBb"] ** 2 / JB
        return math.sqrt(np.max(self[f"mesh[{m}].k_mesh"]) * mob)

    def quadrature_bound(self, m, k0, k1, JA, JB):
        """QUADRATURE (module docstring) for mesh m's mean force over rows k0..k1."""
        n = self[f"mesh[{m}].n_fwd"][k0:k1 + 1]
        jumps = int(np.count_nonzero(np.diff(n)))
        Tw = self.t[k1] - self.t[k0]
        wn = self.omega_n(m, JA, JB)
        return (jumps * self.cap * self.dt / 2 + Tw * self.dt ** 2 * self.cap * wn ** 2 / 12) / Tw

    def mean(self, name, k0, k1):
        return np.trapezoid(self[name][k0:k1 + 1], self.t[k0:k1 + 1]) / (self.t[k1] - self.t[k0])


@pytest.fixture(scope="module")
def in_phase(fmu_dir, md):
    return Run(fmu_dir, md, 21, 18, 57, EQUAL3, stop=0.03, dt=2e-6)


@pytest.fixture(scope="module")
def pin(fmu_dir, md):
    return Run(fmu_dir, md, 21, 18, 57, EQUAL3, stop=0.03, dt=2e-6, pin_t={0: 2e-6})


@pytest.fixture(scope="module")
def out_phase(fmu_dir, md):
    return Run(fmu_dir, md, 20, 19, 58, EQUAL3, stop=0.015, dt=2e-6)


@pytest.fixture(scope="module")
def unequal(fmu_dir, md):
    return Run(fmu_dir, md, 21, 18, 57, UNEQUAL4, stop=0.015, dt=2e-6)


def force_envelope(run, k0=0):
    """FORCE ENVELOPE: every mesh's forward force in [0, run.cap] and no backward contact."""
    for m in range(1, 2 * run.N + 1):
        F = run[f"mesh[{m}].F_fwd"][k0:]
        assert F.min() >= 0.0 and F.max() <= run.cap, (m, F.min(), F.max(), run.cap)
        assert np.all(run[f"mesh[{m}].F_bwd"][k0:] == 0.0), m


def test_the_sets_are_valid(in_phase, out_phase, unequal):
    """The sets are what the module docstring says: every pair at one centre distance, contact
    ratio in (1, 2) (so m_c = 2 and one switch of each kind per mesh period), the loop-closing
    meshes started within 1 % of p_b of their siblings' static penetration (the assembly
    condition holds), and the FMU's base radii are m z cos(alpha_0)/2."""
    for run in (in_phase, out_phase, unequal):
        for m in range(1, 2 * run.N + 1):
            assert 1.0 < run.k[f"mesh[{m}].contact_ratio"] < 2.0
            assert run.k[f"mesh[{m}].contact_objects_per_flank"] == 2.0
        for r, z in ((run.rs, run.zs), (run.rp, run.zp), (run.rr, run.zr)):
            assert r == pytest.approx(MODULE * z * math.cos(ALPHA0) / 2, rel=1e-14)
        d0 = run["mesh[1].dte"][0]
        for m in range(2, run.N + 1):
            assert abs(run[f"mesh[{m}].dte"][0] - d0) < 0.01 * run.k["mesh[1].base_pitch"]


# ------------------------------------------------------------------------------ 1. Willis
def test_willis_angle_identity(in_phase):
    """planetary.md sections 1 and 3, exactly: for each planet, with e = dte - dte(0), the sun
    mesh's e_s = r_s (theta_s - theta_c) - r_p theta_p,rel and the ring mesh's e_r = r_p
    theta_p,rel - r_r theta_c (ring fixed: its angle relative to the carrier is theta_c, both
    planets' base radii are m z_p cos(alpha_0)/2), so e_s + e_r = r_s theta_s - (r_s + r_r)
    theta_c.  Rounding only: angles of at most 3 rad carry ~1e-15 rad, times 0.06 m; the
    coordinates keep dte to ~1e-16 m (gear-train.md section 5): bound 1e-12 m."""
    run = in_phase
    ths, thc = run["body[1].theta"], run["body[2].theta"]
    want = run.rs * ths - (run.rs + run.rr) * thc
    for n in range(1, run.N + 1):
        es = run[f"mesh[{n}].dte"] - run[f"mesh[{n}].dte"][0]
        er = run[f"mesh[{run.N + n}].dte"] - run[f"mesh[{run.N + n}].dte"][0]
        assert np.max(np.abs(es + er - want)) < 1e-12, n


def test_willis_mean_speed_ratio(in_phase):
    """planetary.md section 6, Willis: mean w_c / w_s = z_s / (z_s + z_r).

    Over a window of whole mesh periods (from 5 ms on), mean w_c / mean w_s = d theta_c /
    d theta_s, and by the identity above
        d theta_c / d theta_s = r_s/(r_s + r_r) - d(e_s + e_r) / ((r_s + r_r) d theta_s),
    r_s/(r_s + r_r) = z_s/(z_s + z_r).  A priori bound: each dte stays within [0, delta_1(2 F0)]
    (FORCE ENVELOPE: forward contact, one pair carrying at most 2 F0), so |d(e_s + e_r)| <=
    delta_1s(2 F0) + delta_1r(2 F0) (train_ref.static_delta, the Johnson law).  The bound is
    ~1e-4 of the ratio; one tooth more on the ring changes it by 1.3 %."""
    run = in_phase
    force_envelope(run)
    k0, k1, n = run.window(0.005, run.mesh_period())
    assert n >= 5
    ths, thc = run["body[1].theta"], run["body[2].theta"]
    ratio = (thc[k1] - thc[k0]) / (ths[k1] - ths[k0])
    ds = T.static_delta(run.tr.meshes[0], 2 * run.F0, 1)
    dr = T.static_delta(run.tr.meshes[run.N], 2 * run.F0, 1)
    for m, d in ((1, ds), (run.N + 1, dr)):
        dte = run[f"mesh[{m}].dte"]
        assert dte.min() >= 0.0 and dte.max() <= d, (m, dte.min(), dte.max(), d)
    bound = (ds + dr) / ((run.rs + run.rr) * (ths[k1] - ths[k0]))
    want = run.zs / (run.zs + run.zr)
    assert bound < 1e-3 * want
    assert abs(ratio - want) <= bound, (ratio, want, bound)


# ------------------------------------------------------------------------------ 2. torques
def inertial_terms(run, k0, k1):
    """The carrier identity (test_carrier_torque) and the whole set's angular momentum change
    between rows k0 and k1: (J_s dw_s (1 + z_r/z_s) + J_c' dw_c + sum J_p dw_p (r_r - r_p)/r_p,
    dH) with J_c' = J_c + sum m R^2 and H = -J_s w_s - J_c' w_c + sum J_p w_p (absolute,
    counter-clockwise: sun and carrier turn clockwise forward, the planets counter-clockwise)."""
    N = run.N
    R = run.k["mesh[1].center_distance"]          # the orbit radius (planetary.md section 3)
    Jc = J_CARRIER + N * M_PLANET * R ** 2
    d = {i: run[f"body[{i}].w"][k1] - run[f"body[{i}].w"][k0] for i in range(1, N + 3)}
    kk = 1 + run.zr / run.zs
    carrier = (J_SUN * d[1] * kk + Jc * d[2]
               + sum(J_PLANET * d[i] * (run.rr - run.rp) / run.rp for i in range(3, N + 3)))
    dH = -J_SUN * d[1] - Jc * d[2] + sum(J_PLANET * d[i] for i in range(3, N + 3))
    return carrier, dH


def test_carrier_torque(in_phase):
    """planetary.md section 6, torques: at steady speed the carrier's torque is the sun's times
    1 + z_r/z_s.  The carrier's load is its drag c w_c; its window mean is c d theta_c / dt
    (exact, no quadrature).

    Identity (mu = 0, no planet drag; forward senses, sun and carrier -1, planets +1): sun J_s
    w_s' = T_s - r_s sum F_s; planet J_p w_p' = r_p (F_s - F_r); carrier (J_c + sum m R^2) w_c' =
    -c w_c + sum [F_s (r_s + r_p) + F_r (r_r - r_p)] (it takes minus the sum of each mesh's
    torques).  Eliminating the forces,
        c <w_c> = T_s (1 + z_r/z_s) - [J_s dw_s (1 + z_r/z_s) + J_c' dw_c
                                      + sum J_p dw_p (r_r - r_p)/r_p] / dt
    over any window.  Steady speed: over whole mesh periods of the periodic state the bracket is
    small; asserted below 1 % of the torque.  Bound: INTEGRATION on the angle and the speeds
    (1000 rel_tol of c theta_c(end)/dt and of each term's scale J w / dt)."""
    run = in_phase
    k0, k1, n = run.window(0.005, run.mesh_period())
    dt = run.t[k1] - run.t[k0]
    c = run.sv["body[2].c"]
    thc = run["body[2].theta"]
    Tc = c * (thc[k1] - thc[k0]) / dt
    want = T_SUN * (1 + run.zr / run.zs)
    carrier, _dH = inertial_terms(run, k0, k1)
    assert abs(carrier / dt) < 0.01 * want, "not at steady speed"
    R = run.k["mesh[1].center_distance"]
    w = {i: np.max(np.abs(run[f"body[{i}].w"])) for i in range(1, run.N + 3)}
    scale = (c * abs(thc[k1]) + J_SUN * w[1] * (1 + run.zr / run.zs)
             + (J_CARRIER + run.N * M_PLANET * R ** 2) * w[2]
             + sum(J_PLANET * w[i] * (run.rr - run.rp) / run.rp for i in range(3, run.N + 3)))
    bound = 1000 * REL_TOL * scale / dt
    assert abs(Tc - (want - carrier / dt)) <= bound, (Tc, want, carrier / dt, bound)


def test_housing_torque(in_phase):
    """planetary.md section 6: housing.tau balances the sun's and the carrier's torques.

    (a) Exactly, at every output time: housing.tau is the torque of the ring meshes on body 0,
        counter-clockwise positive; the ring's forward sense is +1 and each mesh pushes it
        forward with F r_r (mu = 0): housing.tau = r_r sum F_fwd(ring meshes).  Rounding: 1e-12
        relative.
    (b) Angular momentum of the whole set about the central axis (planetary.md section 3: the
        torsional model has no other coupling): dH/dt = -T_s + c w_c - housing.tau (absolute:
        the sun's drive is clockwise, the carrier's drag counter-clockwise), so over a window
        <housing.tau> = c d theta_c/dt - T_s - dH/dt; and with the carrier identity <housing.tau>
        -> T_s z_r / z_s at steady speed.  <housing.tau> by the trapezoid rule: N times QUADRATURE
        of a ring mesh times r_r (F_cap = 2 F0, w_n of the ring mesh: planet J_p against the
        fixed ring)."""
    run = in_phase
    N = run.N
    h = run["housing.tau"]
    ring = run.rr * sum(run[f"mesh[{m}].F_fwd"] for m in range(N + 1, 2 * N + 1))
    assert np.max(np.abs(h - ring)) <= 1e-12 * np.max(np.abs(h)), np.max(np.abs(h - ring))
    force_envelope(run)
    k0, k1, n = run.window(0.005, run.mesh_period())
    dt = run.t[k1] - run.t[k0]
    c = run.sv["body[2].c"]
    thc = run["body[2].theta"]
    carrier, dH = inertial_terms(run, k0, k1)
    quad = run.rr * sum(run.quadrature_bound(m, k0, k1, J_PLANET, math.inf)
                        for m in range(N + 1, 2 * N + 1))
    mean_h = run.mean("housing.tau", k0, k1)
    balance = c * (thc[k1] - thc[k0]) / dt - T_SUN - dH / dt
    integ = 1000 * REL_TOL * (c * thc[k1]) / dt
    assert abs(mean_h - balance) <= quad + integ, (mean_h, balance, quad)
    want = T_SUN * run.zr / run.zs
    assert quad < 0.01 * want
    assert abs(mean_h - want) <= quad + integ + abs(carrier / dt) + abs(dH / dt), \
        (mean_h, want, quad, carrier / dt, dH / dt)


def test_bearing_forces(in_phase, out_phase):
    """lateral.md section 7, bearing forces, through the FMU's outputs body[i].Fx/Fy, housing.Fx/Fy.

    (a) A rigidly held sun among equally spaced identical planets in phase (z_s/N = 7): its
        bearing force is zero at every instant, and so are the carrier's and the housing's (the
        ring's mesh forces and the planets' centripetal forces cancel by symmetry too).  The
        N meshes of a kind are the same equations integrated as different coordinates: each
        deflection is held to INTEGRATION (1000 rel_tol), so the forces cancel to 1e-6 F0.
    (b) Out of phase (z_s/N = 20/3): the mesh harmonics with (l z_s +- 1)/N an integer drive
        the sun laterally (Parker 2000), so its bearing force is not zero: at least 1 % of F0
        (the phase-shifted meshes' forces differ by a good part of F0 at the switches).
    (c) Each planet's pin holds it on its orbit against its two meshes: the tangential force
        (the carrier's frame) carries the two meshes' tangential load, about 2 F0 cos(alpha_w)
        pushing the carrier forward; bounded loosely by the FORCE ENVELOPE: between 0 and
        2 F_cap."""
    for run, in_phase_set in ((in_phase, True), (out_phase, False)):
        force_envelope(run)
        sun = np.hypot(run["body[1].Fx"], run["body[1].Fy"])
        if in_phase_set:
            tol = 1000 * REL_TOL * run.F0
            for name in ("body[1]", "body[2]", "housing"):
                f = np.hypot(run[f"{name}.Fx"], run[f"{name}.Fy"])
                assert np.max(f) <= tol, (name, np.max(f), tol)
        else:
            assert np.max(sun) >= 0.01 * run.F0, (np.max(sun), run.F0)
        for i in range(3, run.N + 3):
            ft = np.abs(run[f"body[{i}].Fy"])
            assert np.min(ft) > 0.0 and np.max(ft) <= 2 * run.cap, (i, np.min(ft), np.max(ft))


# ------------------------------------------------------------------------------ 3. load sharing
def sun_mesh_means(run, k0, k1):
    means = [run.mean(f"mesh[{m}].F_fwd", k0, k1) for m in range(1, run.N + 1)]
    bounds = [run.quadrature_bound(m, k0, k1, J_SUN, J_PLANET)
              for m in range(1, run.N + 1)]
    return means, bounds


def test_load_sharing_equal_planets(in_phase):
    """planetary.md section 6, load sharing: N identical, equally spaced planets without errors:
    every sun-planet mesh's mean normal force is T_s/(N r_s) (r_s = mesh[m].rAb, the FMU's
    calculated parameter).  Bound: QUADRATURE (w_n of the sun-planet pair), plus the sun's
    angular momentum change J_s dw_s/(N r_s dt) (sun identity of test_carrier_torque: r_s sum F_s
    = T_s - J_s w_s'; equal planets share it equally)."""
    run = in_phase
    force_envelope(run)
    k0, k1, n = run.window(0.005, run.mesh_period())
    dt = run.t[k1] - run.t[k0]
    means, bounds = sun_mesh_means(run, k0, k1)
    inert = J_SUN * abs(run["body[1].w"][k1] - run["body[1].w"][k0]) / (run.N * run.rs * dt)
    for m, (F, b) in enumerate(zip(means, bounds), 1):
        assert b < 0.01 * run.F0
        assert abs(F - run.F0) <= b + inert, (m, F, run.F0, b, inert)


def test_load_sharing_with_a_pin_error(pin):
    """planetary.md section 6: a tangential pin error on one planet (planet 1, +2 um,
    counter-clockwise) changes its share; the sum over the planets stays T_s/r_s.

    Direction: the carrier's forward sense is clockwise, so the error moves planet 1 backwards;
    both its meshes push it forwards (sun and ring forces on the planet both point forward), so
    both close by e_t cos(alpha_w): its loop is 2 e_t cos(alpha_w) = 3.7 um tighter, about the
    static penetration (1.4 um per mesh): its share rises, by more than its QUADRATURE bound.
    Sum: the sun identity r_s sum F_s = T_s - J_s w_s' (as in test_load_sharing_equal_planets),
    bound the sum of the QUADRATURE bounds plus J_s dw_s/(r_s dt)."""
    run = pin
    force_envelope(run)
    k0, k1, n = run.window(0.005, run.mesh_period())
    dt = run.t[k1] - run.t[k0]
    means, bounds = sun_mesh_means(run, k0, k1)
    inert = J_SUN * abs(run["body[1].w"][k1] - run["body[1].w"][k0]) / (run.rs * dt)
    assert abs(sum(means) - T_SUN / run.rs) <= sum(bounds) + inert, (means, bounds, inert)
    assert means[0] > run.F0 + bounds[0], (means, run.F0, bounds)
    assert max(means[1:]) < run.F0 - max(bounds[1:]), (means, run.F0, bounds)


# ------------------------------------------------------------------------------ 4. mesh phasing
def entries(run, m):
    """Geometric gate entries of mesh m on the grid: rows k where an object's s_A - delta - s_a
    crosses 0 upward in (t[k-1], t[k]] (a window jump moves an object by m_c p_b; a step of more
    than half a base pitch is such a jump, not a crossing)."""
    pb, sa = run.k[f"mesh[{m}].base_pitch"], run.k[f"mesh[{m}].s_a"]
    d = run[f"mesh[{m}].dte"]
    out = []
    for o in ("f1", "f2"):
        g = run[f"mesh[{m}].s_{o}"] - d - sa
        k = np.nonzero((g[:-1] < 0.0) & (g[1:] >= 0.0) & (np.abs(np.diff(g)) < 0.5 * pb))[0]
        out += [int(kk) + 1 for kk in k]
    return sorted(out)


def switches_are_entries(run, m):
    """The FMU's pair switches of mesh m (n_fwd rising while in contact) are its geometric
    entries (row within +-1, the idler test's argument), one per entry."""
    n = run[f"mesh[{m}].n_fwd"].astype(int)
    rises = [int(k) + 1 for k in np.nonzero((n[1:] > n[:-1]) & (n[:-1] >= 1))[0]]
    geo = entries(run, m)
    assert len(rises) == len(geo) and len(geo) >= 3, (m, rises, geo)
    for k in rises:
        assert (n[k - 1], n[k]) == (1, 2), (m, run.t[k])
        assert min(abs(k - kg) for kg in geo) <= 1, (m, run.t[k])
    return geo


def frac(x):
    return x - math.floor(x)


def wrapped(x):
    return (x + 0.5) % 1.0 - 0.5


def mid(a, k):
    return 0.5 * (a[k - 1] + a[k])


def phase_pairs(ks1, ks2):
    """(k1, k2): each entry of stream 1 with the next entry of stream 2 (k2 >= k1)."""
    out = []
    for k1 in ks1:
        later = [k for k in ks2 if k >= k1]
        if later:
            out.append((k1, later[0]))
    return out


def planet_rel_theta(run, n):
    """Planet n's forward angle relative to the carrier: theta_p - sigma_p sigma_c theta_c =
    theta_p + theta_c (sigma_p = +1, sigma_c = -1)."""
    return run[f"body[{n + 2}].theta"] + run["body[2].theta"]


def thickness(z, x, jn, rb):
    """Base tooth thickness angle of an external gear (gear-train.md section 3, standard)."""
    inv = math.tan(ALPHA0) - ALPHA0
    return (math.pi / 2 + 2 * x * math.tan(ALPHA0)) * 2 / z + 2 * inv - jn / (2 * rb)


def sun_ring_phase(run, n, delta_r):
    """docs/planetary-phasing.md section 3 (mounts 0)."""
    ms, mr = n, run.N + n
    k = run.k
    rp = k[f"mesh[{ms}].rBb"]
    assert rp == k[f"mesh[{mr}].rAb"]
    tps = thickness(run.zp, SHIFTS[1], BACKLASH, rp)
    tpr = thickness(run.zp, SHIFTS[1], BACKLASH, rp)
    arg = ((k[f"mesh[{ms}].line_of_action"] - k[f"mesh[{ms}].s_a"]) / rp
           + (k[f"mesh[{mr}].s_a"] + delta_r) / rp
           - k[f"mesh[{ms}].alpha_w"] - k[f"mesh[{mr}].alpha_w"] - (tps + tpr) / 2 - math.pi)
    return frac(run.zp * arg / (2 * math.pi))


def step_bound(angle, ks, dz):
    """Each switch lies between rows k-1 and k, its angle within half the step of the midpoint
    (the angles increase monotonically: forward relative drive)."""
    return sum(angle[k] - angle[k - 1] for k in ks) / (2 * dz)


PHASE_SETS = ["in_phase", "out_phase", "unequal"]


@pytest.mark.parametrize("name", PHASE_SETS)
def test_mesh_phasing_between_planets(name, request):
    """planetary.md section 6, mesh phasing (docs/planetary-phasing.md sections 1 and 2): the
    sun-planet switches of planet n follow planet 1's by frac(sigma_s z_s (psi_n - psi_1)/(2 pi)
    + (delta_n - delta_1)/p_b) of a period (sigma_s = -1), measured in the sun's angle relative to
    the carrier (theta_s - theta_c, dz_s per period), and the ring-planet switches by
    frac(-sigma_s z_r (psi_n - psi_1)/(2 pi)), measured in theta_c (the ring's angle relative
    to the carrier; dz_r per period).  The sets: 21/18/57 (phase 0 at 2 pi/3), 20/19/58 (1/3,
    2/3), 21/18/57 at 2 pi (17, 41, 60)/78 (0.423, 0.962, 0.846): apart from the in-phase set's
    0, every phase differs from its sign-flipped value by at least 0.07.

    Bound (the idler test's): each switch is located to the grid step bracketing it, the angle
    at the midpoint of the two rows is off by at most half the step; delta at a switch is taken
    at the same midpoint, off by at most half its change over the step (dte is C1: h^2/8
    max|dte''| ~ 1e-13 m beyond that), which moves the closed form by that over p_b."""
    run = request.getfixturevalue(name)
    force_envelope(run)
    N = run.N
    dzs, dzr = 2 * math.pi / run.zs, 2 * math.pi / run.zr
    ths_rel = run["body[1].theta"] - run["body[2].theta"]
    thc = run["body[2].theta"]
    assert np.all(np.diff(ths_rel) > 0) and np.all(np.diff(thc) > 0)
    pbs = run.k["mesh[1].base_pitch"]
    sun = {n: switches_are_entries(run, n) for n in range(1, N + 1)}
    ring = {n: switches_are_entries(run, N + n) for n in range(1, N + 1)}
    checked = 0
    for n in range(2, N + 1):
        dpsi = run.angles[n - 1] - run.angles[0]
        d1, dn = run["mesh[1].dte"], run[f"mesh[{n}].dte"]
        for k1, kn in phase_pairs(sun[1], sun[n]):
            ph = (mid(ths_rel, kn) - mid(ths_rel, k1)) / dzs
            want = frac(-run.zs * dpsi / (2 * math.pi) + (mid(dn, kn) - mid(d1, k1)) / pbs)
            bound = step_bound(ths_rel, (k1, kn), dzs) + \
                (abs(dn[kn] - dn[kn - 1]) + abs(d1[k1] - d1[k1 - 1])) / (2 * pbs)
            assert bound < 2e-3
            assert abs(wrapped(ph - want)) <= bound, ("sun", n, run.t[k1], ph, want, bound)
            checked += 1
        for k1, kn in phase_pairs(ring[1], ring[n]):
            ph = (mid(thc, kn) - mid(thc, k1)) / dzr
            want = frac(run.zr * dpsi / (2 * math.pi))
            bound = step_bound(thc, (k1, kn), dzr)
            assert abs(wrapped(ph - want)) <= bound, ("ring", n, run.t[k1], ph, want, bound)
            checked += 1
    assert checked >= 4 * (N - 1)


@pytest.mark.parametrize("name", PHASE_SETS)
def test_mesh_phasing_sun_ring_of_one_planet(name, request):
    """planetary.md section 6, the sun-ring phase of one planet (docs/planetary-phasing.md
    section 3): from a switch of planet n's sun mesh to the next of its ring mesh, in the
    planet's angle relative to the carrier (dz_p per period), against the closed form with the
    ring mesh's penetration at its switch.  The same for every planet (no orbit angle in it);
    0.975 for 21/18/57, 0.464 for 20/19/58 (the tooth count and the thickness decide).  Bound as
    in test_mesh_phasing_between_planets."""
    run = request.getfixturevalue(name)
    N = run.N
    dzp = 2 * math.pi / run.zp
    pbr = run.k[f"mesh[{N + 1}].base_pitch"]
    checked = 0
    for n in range(1, N + 1):
        th = planet_rel_theta(run, n)
        assert np.all(np.diff(th) > 0)
        dr = run[f"mesh[{N + n}].dte"]
        ks = switches_are_entries(run, n)
        kr = switches_are_entries(run, N + n)
        for k1, k2 in phase_pairs(ks, kr):
            ph = (mid(th, k2) - mid(th, k1)) / dzp
            want = sun_ring_phase(run, n, mid(dr, k2))
            bound = step_bound(th, (k1, k2), dzp) + abs(dr[k2] - dr[k2 - 1]) / (2 * pbr)
            assert bound < 2e-3
            assert abs(wrapped(ph - want)) <= bound, (n, run.t[k1], ph, want, bound)
            checked += 1
    assert checked >= 2 * N


# ------------------------------------------------------------------------------ 5. excitation
def hann_amplitude(t, x, w, h):
    """Amplitude of harmonic h of x at the fundamental w, Hann window over the whole span."""
    win = 0.5 - 0.5 * np.cos(2 * np.pi * (t - t[0]) / (t[-1] - t[0]))
    x = x - np.sum(win * x) / np.sum(win)
    return 2 * abs(np.sum(win * x * np.exp(-1j * h * w * t))) / np.sum(win)


@pytest.fixture(scope="module")
def ripple_runs(fmu_dir, md):
    return {z: Run(fmu_dir, md, *z, EQUAL3, stop=0.08, dt=1e-5, extra=())
            for z in ((21, 18, 57), (20, 19, 58))}


def test_phasing_cancels_the_first_harmonic(ripple_runs):
    """planetary.md section 6 (Seager 1975; Parker 2000): three equally spaced planets with
    z_s/N = 20/3 not an integer: the sun's speed ripple at the first mesh harmonic is at least
    100 times smaller than in the in-phase set (21/18/57, z_s/N = 7) at the same load.  Both sets
    keep the assembly condition (26 teeth per spacing), the same centre distance and pressure
    angle, contact ratios in (1, 2) (test_the_sets_are_valid).

    Measured with a Hann window over the largest whole number of mesh periods from 40 ms on to
    80 ms (9 periods), the period measured: 2 pi/(z_s <w_s - w_c>), the mean relative speed from
    the angles (the relative angle advances dz_s per period exactly).  The start transient has
    decayed: the quasi-static start leaves only the mesh vibration, which Hunt-Crossley damping
    removes at the rate chi delta w_n^2/2 (w_n ~ 5e4 rad/s, delta ~ 1.4 um: ~4e4 1/s, a time
    constant below 0.1 ms), and the rigid mode starts at its equilibrium; 40 ms are ten mesh
    periods.  The out-of-phase set's third harmonic (the first it does excite) is asserted to be
    of the in-phase set's order (at least 0.1 of its first harmonic), so the ratio is not that of
    two noises."""
    amps = {}
    for z, run in ripple_runs.items():
        thr = run["body[1].theta"] - run["body[2].theta"]
        k0 = int(np.searchsorted(run.t, 0.04))
        wrel = (thr[-1] - thr[k0]) / (run.t[-1] - run.t[k0])
        Tm = 2 * math.pi / (run.zs * wrel)
        M = math.floor((run.t[-1] - run.t[k0]) / Tm)
        ks = int(np.searchsorted(run.t, run.t[-1] - M * Tm))
        t, x = run.t[ks:], run["body[1].w"][ks:]
        amps[z] = [hann_amplitude(t, x, 2 * math.pi / Tm, h) for h in (1, 2, 3)]
    a_in, a_out = amps[(21, 18, 57)], amps[(20, 19, 58)]
    assert a_out[2] >= 0.1 * a_in[0], (a_in, a_out)
    assert a_out[0] * 100 <= a_in[0], (a_in, a_out)


# ------------------------------------------------------------------------------ 6. energy
@pytest.mark.parametrize("rel_tol", [1e-9, 1e-10])
@pytest.mark.parametrize("zset", [(21, 18, 57), (20, 19, 58)], ids=["in-phase", "out-of-phase"])
def test_energy_residual(rel_tol, zset, fmu_dir, md):
    """planetary.md section 6, energy: E_kin + E_el + W_loss - W_ext - E_gate is conserved (the
    housing does no work; E_kin with the carriers' orbital inertia).  Bound rel_tol x max E_kin
    over 10 ms (test_train_ref.test_energy_residual's argument, which train_ref meets on these
    sets): the integrator keeps each step's error below rel_tol relative to the state, the
    vibrations are resolved, so the speeds' global relative error stays of order rel_tol and the
    energy (quadratic in them) and the works drift by ~rel_tol E_kin.  At two tolerances: a
    residual that does not shrink with the tolerance is no integration error.  The bound lies
    two orders below the gate energy, so a bookkeeping error of a pair entering loaded shows."""
    sv = simple_set(*zset, EQUAL3)
    res = fmpy.simulate_fmu(fmu_dir, model_description=md, start_values={**sv, "rel_tol": rel_tol},
                            stop_time=0.01, output_interval=1e-4,
                            output=["energy_residual", "E_kin", "E_gate", "W_loss"])
    bound = rel_tol * np.max(res["E_kin"])
    assert np.max(np.abs(res["E_gate"])) > 1e2 * bound
    assert res["W_loss"][-1] > 1e2 * bound
    resid = np.max(np.abs(res["energy_residual"]))
    assert resid <= bound, f"max |energy_residual| = {resid:.3g} J > {bound:.3g} J"


# ------------------------------------------------------------------------------ 7. bad input
def simulate_logged(unzip_dir, md, start_values):
    """test_train_scenes.simulate: simulate_fmu with a logger in the callbacks; returns
    (exception or None, [(status, category, message)])."""
    messages = []

    def log(env, instance, status, category, message):
        messages.append((status, (category or b"").decode("utf-8", "replace"),
                         (message or b"").decode("utf-8", "replace")))

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(log)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip_dir,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="planetary")
    fmu.instantiate(callbacks=callbacks)
    try:
        fmpy.simulate_fmu(unzip_dir, model_description=md, fmu_instance=fmu,
                          start_values=start_values, stop_time=1e-3, output_interval=1e-3)
        return None, messages
    except FMICallException as e:
        return e, messages
    finally:
        fmu.freeInstance()


def simple_scene():
    return dict(T.load_scene("planetary-simple")["start_values"])


def external(m, z):
    return {f"mesh[{m}].{k}": v for k, v in pair(z, z, 0.0, 0.0, False).items()}


# name -> (base, changes, texts the error message must contain).  planetary-simple: body 1 sun,
# 2 carrier, 3-5 planets; meshes 1-3 sun-planet, 4-6 planet-ring (B = 0).
BAD_INPUT = {
    "not-assembling": (simple_scene, {"body[4].orbit_angle": 2 * math.pi / 3 + 0.05},
                       ["mesh[2]", "body[4]", "(z_sun + z_ring) (psi_n - psi_1) / (2 pi)",
                        "integer"]),
    # body 6 in the housing, placed beside the sun by mesh 7 (centre angle 2.5), meshing with
    # planet 3 (mesh 8): not coaxial with the carrier
    "planet-meshes-a-non-coaxial-gear": (simple_scene, {
        "n_bodies": 6, "n_meshes": 8, "body[6].J": 1e-3, "mesh[7].A": 1, "mesh[7].B": 6,
        "mesh[7].center_angle": 2.5, "mesh[8].A": 6, "mesh[8].B": 3,
        **{f"mesh[{m}].{k}": v for m in (7, 8) for k, v in pair(21, 18, 0.5, 0.0, False).items()}},
        ["mesh[8]", "body[6]", "coaxial"]),
    # the carrier (with an output gear, mesh 7 to body 6) carried by the sun
    "carried-carrier": (simple_scene, {"body[2].carrier": 1, "n_bodies": 6, "n_meshes": 7,
                                       "body[6].J": 1e-3, "mesh[7].A": 2, "mesh[7].B": 6,
                                       **external(7, 20)},
                        ["body[2]", "body[1]", "carried"]),
    # three equal external gears on an equilateral triangle (the axes close)
    "jammed-triangle": (dict, {"n_bodies": 3, "n_meshes": 3, "n_shafts": 0,
                               "mesh[1].A": 1, "mesh[1].B": 2, "mesh[2].A": 2, "mesh[2].B": 3,
                               "mesh[3].A": 3, "mesh[3].B": 1, "mesh[1].center_angle": 0.0,
                               "mesh[2].center_angle": 2 * math.pi / 3,
                               "mesh[3].center_angle": 4 * math.pi / 3,
                               **external(1, 20), **external(2, 20), **external(3, 20)},
                        ["mesh[1]", "mesh[2]", "mesh[3]", "body[1]", "body[2]", "body[3]"]),
    # planet 3 between a fixed sun (mesh 1, A = 0) and the fixed ring
    "jammed-sun-and-ring-fixed": (simple_scene, {"mesh[1].A": 0},
                                  ["mesh[1]", "mesh[4]", "body[3]"]),
    # the ring freed (body 6) and tied to the sun by a shaft: sun and ring turn opposite ways
    # forward (external, then internal mesh), a shaft keeps the sense
    "conflicting-senses": (simple_scene, {"n_bodies": 6, "n_shafts": 1, "body[6].J": 1e-2,
                                          "mesh[4].B": 6, "mesh[5].B": 6, "mesh[6].B": 6,
                                          "shaft[1].a": 1, "shaft[1].b": 6, "shaft[1].k": 1e4},
                           ["mesh[4]", "body[6]", "conflict"]),
    "center-angle-in-a-carrier-frame": (simple_scene, {"mesh[2].center_angle": 0.3},
                                        ["mesh[2]", "center_angle"]),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_is_an_error_at_initialization(case, fmu_dir, md):
    """planetary.md sections 3-4: refused at initialization with fmi2Error and a logged message
    naming the elements (and, for a set that cannot be assembled, the assembly condition)."""
    base, changes, texts = BAD_INPUT[case]
    sv = {**base(), **changes}
    exc, messages = simulate_logged(fmu_dir, md, sv)
    assert exc is not None, f"{case}: initialized without error; log: {messages}"
    assert exc.function in ("fmi2EnterInitializationMode", "fmi2ExitInitializationMode") \
        and exc.status == FMI2_ERROR, (case, exc.function, exc.status)
    errors = [m for s, c, m in messages if s == FMI2_ERROR]
    assert errors, f"{case}: fmi2Error without a logged message ({messages})"
    missing = [x for x in texts if not any(x in m for m in errors)]
    assert not missing, f"{case}: the error message lacks {missing}: {errors}"


@pytest.mark.parametrize("name,value", [("n_bodies", 17), ("n_shafts", 16), ("n_meshes", 17)])
def test_counts_above_capacity(name, value, fmu_dir, md):
    """planetary.md section 5: capacity 16 bodies, 15 shafts, 16 meshes; one more is refused
    with fmi2Error (by fmi2SetInteger, the variable's max) and a message naming the count."""
    v = {v.name: v for v in md.modelVariables}[name]
    assert int(v.max) == value - 1
    exc, messages = simulate_logged(fmu_dir, md, {**simple_scene(), name: value})
    assert exc is not None and exc.status == FMI2_ERROR, (name, exc)
    errors = [m for s, c, m in messages if s == FMI2_ERROR]
    assert any(name in m for m in errors), (name, messages)
