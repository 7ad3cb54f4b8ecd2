#!/usr/bin/env python3
"""Writes the planetary scenes scenes/train/planetary-*.toml, power-split.toml and
lumped-planetary.toml: gear data chosen to pass every refusal of planetary.md sections 1-4
(checked here), start values from train_ref.quasi_static_start (a running start at the static
loads), and the scenes' texts.

    .venv/bin/python tests/reference_model/make_planetary_scenes.py            # all of them
    .venv/bin/python tests/reference_model/make_planetary_scenes.py --check    # design checks only

Gear data (module 2 mm, 20 deg, addendum 1, face width 20 mm, backlash 50 um, every scene):
shifts x_sun = 0.5, x_planet = 0, x_ring = 0.5, so that x_sun + x_planet = x_ring - x_planet
and z_sun + 2 z_planet = z_ring: the sun-planet and the planet-ring pair have the same operating
pressure angle and the SAME nominal operating centre distance, so the planet-ring mesh, which
operates at the distance the planet positions give (the sun-planet distance R, planetary.md
section 3), runs at its own nominal geometry (center_distance_error 0 exactly).  The positive
sun and ring shifts keep every pair clear of the refusals:
  * the ring's tip clear of the planet's root: s_a > 0 and the rack-cutter rule (the contact on
    the planet stays on the involute its ISO 53 rack generates), with x_planet = 0 (a planet
    shift raises the rack's form start faster than it moves the ring's tip);
  * tip and trochoid interference of the planet's tip corners in the ring (design_checks:
    the corners followed over a whole pass, clearance > 0);
  * contact ratios within [1, 2]; top lands > 0; the external pair's contact inside [0, L] and
    both gears' contact above their rack-generated form circles;
  * the assembly condition (z_sun + z_ring) k / N an integer for N equally spaced planets;
  * adjacent planets' tip circles clear of each other.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from reference_model import gearmesh_ref as G  # noqa: E402
from reference_model import train_ref as T  # noqa: E402

MODULE, A0, WIDTH, BACKLASH, CHI = 0.002, math.radians(20.0), 0.02, 5e-5, 20.0
X_SUN, X_PLANET, X_RING = 0.5, 0.0, 0.5
H_RACK = 1.25 - 0.38 * (1.0 - math.sin(A0))       # ISO 53 rack: straight flank's depth


def form_start(z, x):
    """Roll distance from the base circle's tangent point where a rack cutter's straight flank
    starts generating the involute (gearmesh_ref.Geometry._check_pinion_form)."""
    return MODULE * (z / 2 * math.sin(A0) - (H_RACK - x) / math.sin(A0))


def ring_corner_clearance(g, xB):
    """Smallest clearance [m] of the planet's two tip corners against the ring's teeth over a
    whole pass, rigid rolling at the operating pitch circles, tooth centred in its space (each
    flank j_n/2 away): the corner at radius rho from the ring's axis must lie inside a ring space,
    whose half-angle at rho is (eB - 2 inv(alpha_rho))/2.  Negative = interference."""
    zA, zB, d = g.zA, g.zB, g.d
    gam = (g.tA - 2.0 * G.involute(math.acos(g.rAb / g.r_tipA))) / 2.0
    dz = 2.0 * math.pi / zB
    span = min(math.pi * zA / (zB - zA), 40.0 * math.pi)
    best = math.inf
    N = 40000
    for i in range(-N, N + 1):
        phB = i / N * span
        phA = phB * zB / zA
        for sgn in (1.0, -1.0):
            a = phA + sgn * gam
            X, Y = d + g.r_tipA * math.cos(a), g.r_tipA * math.sin(a)
            rho = math.hypot(X, Y)
            if rho <= g.r_tipB:
                continue
            th = (math.atan2(Y, X) - phB + dz / 2) % dz - dz / 2
            e = g.eB - 2.0 * G.involute(math.acos(g.rBb / rho))
            best = min(best, (e / 2 - abs(th)) * rho)
    root_clear = MODULE * zB / 2 + MODULE * (1.25 + xB) - (d + g.r_tipA)
    return best, root_clear


def design_checks(zs, zp, zr, n_planets, verbose=True):
    """Every refusal of planetary.md sections 1-4 for one simple set; returns the geometries."""
    assert zs + 2 * zp == zr and X_SUN + X_PLANET == X_RING - X_PLANET
    ext = G.Geometry(G.make_params(dict(geometry=2, module=MODULE, zA=zs, zB=zp, xA=X_SUN,
                                        xB=X_PLANET, width=WIDTH, backlash=BACKLASH)))
    inn = G.Geometry(G.make_params(dict(geometry=2, internal=True, module=MODULE, zA=zp, zB=zr,
                                        xA=X_PLANET, xB=X_RING, width=WIDTH, backlash=BACKLASH)))
    assert ext.d == inn.d, (ext.d, inn.d)
    assert 1.0 <= ext.eps <= 2.0 and 1.0 <= inn.eps <= 2.0
    assert ext.s_a > form_start(zs, X_SUN) and ext.L - ext.s_b > form_start(zp, X_PLANET)
    assert inn.s_a > form_start(zp, X_PLANET)
    for g in (ext,):
        for t, r, rb in ((g.tA, g.r_tipA, g.rAb), (g.tB, g.r_tipB, g.rBb)):
            assert t - 2.0 * G.involute(math.acos(rb / r)) > 0.0
    corner, root = ring_corner_clearance(inn, X_RING)
    assert corner > 0.0 and root > 0.0, (corner, root)
    assert (zs + zr) % n_planets == 0, "assembly condition"
    gap = 2.0 * ext.d * math.sin(math.pi / n_planets) - 2.0 * ext.r_tipB
    assert gap > 0.0, gap
    if verbose:
        print(f"{zs}/{zp}/{zr}, N = {n_planets}: R = {ext.d * 1e3:.4f} mm, alpha_w = "
              f"{math.degrees(ext.alpha_w):.4f} deg; sun-planet eps {ext.eps:.4f}, s_a "
              f"{ext.s_a * 1e3:.3f} mm; planet-ring eps {inn.eps:.4f}, s_a {inn.s_a * 1e3:.3f} mm "
              f"(form start {form_start(zp, X_PLANET) * 1e3:.3f} mm), corner clearance "
              f"{corner * 1e6:.1f} um, root clearance {root * 1e3:.3f} mm; planets' tip gap "
              f"{gap * 1e3:.2f} mm")
    return ext, inn


def mesh(m, A, B, zA, zB, xA, xB, internal=False):
    sv = {f"mesh[{m}].A": A, f"mesh[{m}].B": B, f"mesh[{m}].geometry": 2,
          f"mesh[{m}].module": MODULE, f"mesh[{m}].zA": zA, f"mesh[{m}].zB": zB,
          f"mesh[{m}].xA": xA, f"mesh[{m}].xB": xB, f"mesh[{m}].width": WIDTH,
          f"mesh[{m}].backlash": BACKLASH, f"mesh[{m}].chi": CHI}
    if internal:
        sv[f"mesh[{m}].internal"] = True
    return sv


def simple_set(sv, m0, sun, carrier, ring, planets, zs, zp, zr, J_p, m_p, c_p=0.0):
    """Meshes m0+1..m0+N sun-planet (sun = A), m0+N+1..m0+2N planet-ring (ring = B, may be 0);
    planets equally spaced from orbit angle 0."""
    N = len(planets)
    for k, p in enumerate(planets):
        sv.update({f"body[{p}].J": J_p, f"body[{p}].m": m_p, f"body[{p}].c": c_p,
                   f"body[{p}].carrier": carrier, f"body[{p}].orbit_angle": 2 * math.pi * k / N,
                   f"body[{p}].tau": 0.0})
        sv.update(mesh(m0 + 1 + k, sun, p, zs, zp, X_SUN, X_PLANET))
        sv.update(mesh(m0 + N + 1 + k, p, ring, zp, zr, X_PLANET, X_RING, internal=True))
    return m0 + 2 * N


def scene_simple():
    zs, zp, zr = 21, 18, 57
    design_checks(zs, zp, zr, 3)
    Ts, ws = 50.0, 100.0
    wc = ws * zs / (zs + zr)
    Tc = Ts * (zs + zr) / zs
    sv = {"n_bodies": 5, "n_shafts": 0, "n_meshes": 6,
          "body[1].J": 2e-3, "body[1].c": 0.0, "body[1].tau": Ts, "body[1].w_start": ws,
          "body[2].J": 0.05, "body[2].c": Tc / wc, "body[2].tau": 0.0, "body[2].w_start": wc}
    simple_set(sv, 0, 1, 2, 0, [3, 4, 5], zs, zp, zr, 1e-4, 0.3)
    desc = f"""A simple planetary set (planetary.md sections 3-4): body 1 the sun (21 teeth, J 2e-3, \
driven by 50 N.m at 100 rad/s), body 2 the carrier (J 0.05 plus the planets' orbital inertia 3 x 0.3 kg \
x R^2) loaded by a drag of {Tc / wc:.6g} N.m.s/rad, which absorbs the set's {Tc:.6g} N.m (50 x 78/21) at \
the Willis speed 100 x 21/78 = {wc:.6g} rad/s; bodies 3-5 three planets (18 teeth, J 1e-4, m 0.3 kg) at \
orbit angles 0, 2 pi/3, 4 pi/3, and the ring (57 teeth) fixed in the housing: meshes 4-6 have B = 0. \
Meshes 1-3 sun-planet (external, A = sun), 4-6 planet-ring (internal, A = planet). Module 2 mm, \
x_sun = 0.5, x_planet = 0, x_ring = 0.5: both pairs at alpha_w = 23.371 deg and R = 39.9235 mm \
(sun-planet eps 1.439, planet-ring eps 1.722). Assembly: (21 + 57)/3 = 26. Senses: sun -1, planets +1, \
the carrier -1 (reached by no mesh: sigma = -1 at its own index). Placement from the housing: the ring \
meshes place the planets, mesh 1 the sun; meshes 2 and 3 close loops. chi = 20 s/m; running start at \
the static loads (train_ref.quasi_static_start)."""
    return "planetary-simple", sv, desc, 0.04, 4e-5, dict(
        variables=["body[1].w", "body[2].w", "body[3].w", "mesh[1].dte", "mesh[2].dte", "mesh[4].dte",
                   "mesh[1].F_fwd", "mesh[2].F_fwd", "mesh[3].F_fwd", "mesh[4].F_fwd",
                   "housing.tau"])


def scene_mounted():
    zs, zp, zr = 24, 20, 64
    design_checks(zs, zp, zr, 4)
    Ts, ws = 40.0, 150.0
    wc = ws * zs / (zs + zr)
    Tc = Ts * (zs + zr) / zs
    k_arm = 2e5
    sv = {"n_bodies": 7, "n_shafts": 1, "n_meshes": 8,
          "body[1].J": 2e-3, "body[1].c": 0.0, "body[1].tau": Ts, "body[1].w_start": ws,
          "body[2].J": 0.06, "body[2].c": Tc / wc, "body[2].tau": 0.0, "body[2].w_start": wc,
          "body[3].J": 0.05, "body[3].c": 0.0, "body[3].tau": 0.0, "body[3].w_start": 0.0,
          "shaft[1].a": 3, "shaft[1].b": 0, "shaft[1].k": k_arm, "shaft[1].d": 20.0}
    simple_set(sv, 0, 1, 2, 3, [4, 5, 6, 7], zs, zp, zr, 8e-5, 0.25, c_p=1e-4)
    desc = f"""A planetary set whose ring floats on a torque arm (planetary.md section 3: a shaft \
to the housing is a torsional mount): body 1 the sun (24 teeth, J 2e-3, 40 N.m at 150 rad/s), body 2 the \
carrier (J 0.06 plus orbital inertia 4 x 0.25 kg x R^2, drag {Tc / wc:.6g} N.m.s/rad: {Tc:.6g} N.m = 40 x \
88/24 at the Willis speed {wc:.6g} rad/s), body 3 the ring (64 teeth, J 0.05) held by shaft 1 (a = 3, \
b = 0: k = 2e5 N.m/rad, d = 20 N.m.s/rad, about 10 % of critical on the ring), bodies 4-7 four planets \
(20 teeth, J 8e-5, m 0.25 kg, bearing drag 1e-4 N.m.s/rad on their speed relative to the carrier) at \
orbit angles k pi/2. Meshes 1-4 sun-planet, 5-8 planet-ring (internal, B = 3). Module 2 mm, x_sun 0.5, \
x_planet 0, x_ring 0.5: alpha_w = 23.040 deg, R = 44.9306 mm, sun-planet eps 1.473, planet-ring eps \
1.737. Assembly: (24 + 64)/4 = 22. The torque arm carries the ring's reaction 40 x 64/24 = 106.7 N.m \
(twist 0.53 mrad), which housing.tau shows. Placement from the housing: the shaft places the ring, the \
ring meshes the planets, mesh 1 the sun; meshes 2-4 close loops. chi = 20 s/m; running start at the \
static loads (train_ref.quasi_static_start)."""
    return "planetary-mounted", sv, desc, 0.03, 3e-5, dict(
        variables=["body[1].w", "body[2].w", "body[3].w", "shaft[1].tau", "mesh[1].dte", "mesh[3].dte",
                   "mesh[5].dte", "mesh[1].F_fwd", "mesh[2].F_fwd", "mesh[5].F_fwd", "housing.tau"])


def scene_pin_error():
    zs, zp, zr = 20, 22, 64
    design_checks(zs, zp, zr, 3)
    Ts, ws = 50.0, 120.0
    wc = ws * zs / (zs + zr)
    Tc = Ts * (zs + zr) / zs
    sv = {"n_bodies": 5, "n_shafts": 0, "n_meshes": 6,
          "body[1].J": 2e-3, "body[1].c": 0.0, "body[1].tau": Ts, "body[1].w_start": ws,
          "body[2].J": 0.05, "body[2].c": Tc / wc, "body[2].tau": 0.0, "body[2].w_start": wc}
    simple_set(sv, 0, 1, 2, 0, [3, 4, 5], zs, zp, zr, 1.2e-4, 0.3)
    sv["body[3].pin_error_t"] = 2e-6
    desc = f"""Unequal load sharing from a planet pin error (planetary.md sections 3 and 6): the simple \
set of planetary-simple with 20/22/64 teeth (R = 42.9280 mm, alpha_w = 23.164 deg, sun-planet eps 1.450, \
planet-ring eps 1.747; assembly (20 + 64)/3 = 28), sun 50 N.m at 120 rad/s, carrier drag \
{Tc / wc:.6g} N.m.s/rad ({Tc:.6g} N.m at {wc:.6g} rad/s), planets J 1.2e-4, m 0.3 kg, ring fixed \
(B = 0). Planet 1 (body 3) sits 2 um ahead of its place along its orbit (pin_error_t = 2e-6 m, \
counter-clockwise in the carrier): its sun mesh and ring mesh lie at the distance and direction its \
position gives (the distances change by et^2/(2R) = 5e-11 m, the directions by et/R = 47 urad), which \
shifts the loop penetrations of planets 2 and 3 by about 1.6 et (et cos(alpha_w) in each of planet 1's \
two meshes, shared out by the placement), against a static penetration of about 4 um per mesh: planet 1 \
carries 57 % of the sun's torque at the start, planets 2 and 3 17 % and 26 % (their meshes are out of \
phase, 20/3 teeth per planet spacing); the sum over the planets stays T_sun/rb_sun. (At 20 um the \
shift, 32 um, exceeds the static penetration many times: planet 1 carries everything and planets 2 and \
3 float in their backlash.) The sun is on a fixed axis (no floating). chi = \
20 s/m; running start at the static loads the compliant set shares (train_ref.quasi_static_start)."""
    return "planetary-pin-error", sv, desc, 0.04, 4e-5, dict(
        variables=["body[1].w", "body[2].w", "mesh[1].dte", "mesh[2].dte", "mesh[3].dte",
                   "mesh[1].F_fwd", "mesh[2].F_fwd", "mesh[3].F_fwd", "mesh[4].F_fwd", "housing.tau"])


def scene_two_stage():
    z1, z2 = (21, 18, 57), (20, 22, 64)
    design_checks(*z1, 3)
    design_checks(*z2, 3)
    Ts, ws = 30.0, 150.0
    i1, i2 = (z1[0] + z1[2]) / z1[0], (z2[0] + z2[2]) / z2[0]
    wc2 = ws / (i1 * i2)
    Tc2 = Ts * i1 * i2
    sv = {"n_bodies": 10, "n_shafts": 1, "n_meshes": 12,
          "body[1].J": 2e-3, "body[1].c": 0.0, "body[1].tau": Ts, "body[1].w_start": ws,
          "body[2].J": 0.02, "body[2].c": 0.0, "body[2].tau": 0.0,
          "body[6].J": 3e-3, "body[6].c": 0.0, "body[6].tau": 0.0,
          "body[7].J": 0.1, "body[7].c": Tc2 / wc2, "body[7].tau": 0.0,
          "shaft[1].a": 2, "shaft[1].b": 6, "shaft[1].k": 5e4, "shaft[1].d": 10.0}
    simple_set(sv, 0, 1, 2, 0, [3, 4, 5], *z1, 1e-4, 0.3)
    simple_set(sv, 6, 6, 7, 0, [8, 9, 10], *z2, 1.2e-4, 0.3)
    desc = f"""Two planetary stages in series (planetary.md sections 3-4): stage 1 (meshes 1-6) \
is planetary-simple's 21/18/57 set: body 1 the sun (J 2e-3, 30 N.m at 150 rad/s), body 2 the carrier \
(J 0.02), bodies 3-5 the planets, ring fixed (B = 0). Its carrier drives stage 2's sun, body 6 (J 3e-3), \
through shaft 1 (a = 2, b = 6: k = 5e4 N.m/rad, d = 10 N.m.s/rad). Stage 2 (meshes 7-12) is \
planetary-pin-error's 20/22/64 set without the error: body 7 its carrier (J 0.1, the output, drag \
{Tc2 / wc2:.6g} N.m.s/rad: {Tc2:.6g} N.m = 30 x (78/21) x (84/20) at {wc2:.6g} rad/s), bodies 8-10 \
its planets, ring fixed. Overall ratio 15.6. Senses: sun 1 -1, planets +1; carrier 1, shaft and sun 2 \
-1 (their part's lowest index, body 2), stage-2 planets +1, carrier 2 -1. Placement from the housing \
(queue: housing, carriers 2 and 7): the fixed rings place all six planets, carrier 2's shaft places sun 2, \
planet 3 places sun 1. Stage 2's sun is placed by the shaft, so all its three meshes close loops, and \
one of them is independent of the placement (it ties carrier 7, which starts at 0): the set assembles \
only with sun 2's teeth where the planets need them. mesh[7..9].mount_A (sun 2's tooth 0 on its body) \
is therefore solved together with the static loads (train_ref.quasi_static_start, mount_groups). \
chi = 20 s/m."""
    return "planetary-two-stage", sv, desc, 0.03, 3e-5, dict(
        variables=["body[1].w", "body[2].w", "body[6].w", "body[7].w", "shaft[1].tau", "mesh[1].dte",
                   "mesh[7].dte", "mesh[1].F_fwd", "mesh[7].F_fwd", "mesh[8].F_fwd", "housing.tau"]), \
        [[f"mesh[{m}].mount_A" for m in (7, 8, 9)]]


def scene_power_split():
    zs, zp, zr = 30, 24, 78
    design_checks(zs, zp, zr, 4)
    Te, wc, ws = 100.0, 200.0, 300.0
    # rigid kinematics in forward terms (sun and carrier sigma = -1, ring +1):
    # w_sun = (1 + zr/zs) w_c + (zr/zs) w_r
    wr = (ws - (1 + zr / zs) * wc) / (zr / zs)
    Tg = -Te * zs / (zs + zr)             # the generator's reaction (forward torque on the sun)
    Tr = Te * zr / (zs + zr)              # what reaches the ring, forward positive
    c_road = Tr / (-wr)                   # road drag -c w_r absorbs it at w_r < 0
    sv = {"n_bodies": 7, "n_shafts": 0, "n_meshes": 8,
          "body[1].J": 0.02, "body[1].c": 0.0, "body[1].tau": Tg, "body[1].w_start": ws,
          "body[2].J": 0.2, "body[2].c": 0.0, "body[2].tau": Te, "body[2].w_start": wc,
          "body[3].J": 5.0, "body[3].c": c_road, "body[3].tau": 0.0, "body[3].w_start": wr}
    simple_set(sv, 0, 1, 2, 3, [4, 5, 6, 7], zs, zp, zr, 1.5e-4, 0.35)
    desc = f"""A hybrid car's power-split device (planetary.md sections 3-4; no housing-fixed gear, \
no element names body 0): body 1 the sun on the generator MG1 (30 teeth, J 0.02), body 2 the carrier \
on the engine (J 0.2 plus orbital inertia 4 x 0.35 kg x R^2), body 3 the ring (78 teeth) carrying the \
vehicle's inertia reflected to it (J 5) and a linear road drag, bodies 4-7 four planets (24 teeth, J \
1.5e-4, m 0.35 kg) at orbit angles k pi/2. Meshes 1-4 sun-planet, 5-8 planet-ring (internal, B = 3). \
Module 2 mm, x_sun 0.5, x_planet 0, x_ring 0.5: R = 54.9415 mm, alpha_w = 22.543 deg, sun-planet eps \
1.529, planet-ring eps 1.763; assembly (30 + 78)/4 = 27. Forward senses: body 1 (sun) -1, the planets \
+1, the ring +1 (the internal mesh keeps the sense), the carrier -1 (reached by no mesh or shaft). \
Two degrees of freedom; the sun and the carrier are the free bodies. Engine 100 N.m forward on the \
carrier at 200 rad/s; the generator holds the sun at 300 rad/s forward (turning the same way as the \
engine) with its reaction {Tg:.6g} N.m = -100 x 30/108 (a brake: it generates); the ring then turns at \
w_r = (300 - 3.6 x 200)/2.6 = {wr:.6g} rad/s in its forward sense, i.e. the same way as the engine \
physically, and receives {Tr:.6g} N.m = 100 x 78/108, which the road drag {c_road:.6g} N.m.s/rad \
absorbs. The generator's brake makes the planets push the sun forward: every mesh carries on its \
BACKWARD flanks (F_bwd; dte near -backlash). Placement from body 1 (no housing named; the carrier at 0): the sun places the planets, \
planet 4 places the ring, meshes 6-8 close loops. chi = 20 s/m; running start at the static loads \
(train_ref.quasi_static_start)."""
    return "power-split", sv, desc, 0.03, 3e-5, dict(
        variables=["body[1].w", "body[2].w", "body[3].w", "body[4].w", "mesh[1].dte", "mesh[2].dte",
                   "mesh[5].dte", "mesh[1].F_bwd", "mesh[2].F_bwd", "mesh[5].F_bwd", "mesh[6].F_bwd"])


# the lumped mesh (lateral.md section 4) on planetary-simple's set
K_LUMPED, C_LUMPED = 1e9, 1800.0


def scene_lumped_planetary():
    name, sv, _desc, stop, dt, _cmp = scene_simple()
    J_s, J_p = sv["body[1].J"], sv["body[3].J"]
    ext = G.Geometry(G.make_params(dict(geometry=2, module=MODULE, zA=21, zB=18, xA=X_SUN,
                                        xB=X_PLANET, width=WIDTH, backlash=BACKLASH)))
    inn = G.Geometry(G.make_params(dict(geometry=2, internal=True, module=MODULE, zA=18, zB=57,
                                        xA=X_PLANET, xB=X_RING, width=WIDTH, backlash=BACKLASH)))
    m_sp = 1.0 / (ext.rAb ** 2 / J_s + ext.rBb ** 2 / J_p)
    m_pr = J_p / inn.rAb ** 2
    z_sp = C_LUMPED / (2.0 * math.sqrt(K_LUMPED * m_sp))
    z_pr = C_LUMPED / (2.0 * math.sqrt(K_LUMPED * m_pr))
    for m in range(1, 7):
        del sv[f"mesh[{m}].chi"]                # ignored by the lumped mesh
        sv[f"mesh[{m}].contact_model"] = 4
        sv[f"mesh[{m}].k_lumped"] = K_LUMPED
        sv[f"mesh[{m}].c_lumped"] = C_LUMPED
    sv["mesh[1].k_lumped_varies"] = True
    desc = f"""planetary-simple's set (21/18/57, three planets, ring fixed, sun 50 N.m at 100 rad/s, \
carrier drag absorbing 185.714 N.m at the Willis speed 26.9231 rad/s; its description gives the gear \
data) with every mesh the lumped mesh (contact_model = 4, lateral.md section 4), torsional only: one \
linear spring-damper along each flank's line of action, no friction, chi ignored. \
k_lumped = {K_LUMPED:.3g} N/m on all six meshes, of the order of the set's Johnson mesh stiffness \
(at planetary-simple's static load one pair's tangent stiffness is 6.47e8 N/m; times the contact \
ratios 1.439 (sun-planet) and 1.722 (planet-ring): 9.3e8 and 1.11e9 N/m). c_lumped = {C_LUMPED:g} N.s/m \
on all six: {100 * z_sp:.1f} % of critical damping of a sun-planet mesh alone \
(m_eq = 1/(rb_sun^2/J_sun + rb_planet^2/J_planet) = {m_sp:.4f} kg, critical 2 sqrt(k m_eq) = \
{2 * math.sqrt(K_LUMPED * m_sp):.4g} N.s/m) and {100 * z_pr:.1f} % of a planet-ring mesh (the ring \
fixed: m_eq = J_planet/rb_planet^2 = {m_pr:.4f} kg). Mesh 1 (sun - planet 1) alone has \
k_lumped_varies = true: its stiffness is the square wave k_lumped n/eps, 6.95e8 N/m with one pair \
on the contact segment, 1.39e9 N/m with two, switching (events) at the sun-planet tooth frequency \
21 x (100 - 26.92)/(2 pi) = 244 Hz; the other five springs are constant, so planet 1's share of the \
sun's torque oscillates against planets 2 and 3 (whose meshes stay in phase with each other). \
Running start at the static loads the compliant set shares (train_ref.quasi_static_start)."""
    return "lumped-planetary", sv, desc, stop, dt, dict(
        variables=["body[1].w", "body[2].w", "body[3].w", "body[4].w", "mesh[1].dte", "mesh[2].dte",
                   "mesh[4].dte", "mesh[1].F_fwd", "mesh[2].F_fwd", "mesh[3].F_fwd", "mesh[4].F_fwd",
                   "mesh[1].F_f1", "mesh[1].k_mesh", "mesh[1].P_loss", "housing.tau"])


def scene_bearings():
    """planetary-pin-error's set, made to load every term of the bearing forces (lateral.md
    section 6): friction on every mesh, a carrier drag that absorbs only half the set's torque
    at the start (the set accelerates), planets with mass; twice pin-error's sun torque, so that
    planets 2 and 3 stay in contact throughout (at 50 N.m, with part of the torque spent on
    accelerating the sun, the 2 um error unloads them once per mesh cycle)."""
    zs, zp, zr = 20, 22, 64
    design_checks(zs, zp, zr, 3)
    Ts, ws, mu, m_p = 100.0, 120.0, 0.05, 0.3
    wc = ws * zs / (zs + zr)
    Tc = Ts * (zs + zr) / zs
    c_c = 0.5 * Tc / wc
    sv = {"n_bodies": 5, "n_shafts": 0, "n_meshes": 6,
          "body[1].J": 2e-3, "body[1].c": 0.0, "body[1].tau": Ts, "body[1].w_start": ws,
          "body[2].J": 0.05, "body[2].c": c_c, "body[2].tau": 0.0, "body[2].w_start": wc}
    simple_set(sv, 0, 1, 2, 0, [3, 4, 5], zs, zp, zr, 1.2e-4, m_p)
    for m in range(1, 7):
        sv[f"mesh[{m}].mu"] = mu
    sv["body[3].pin_error_t"] = 2e-6
    # the rigid set's inertia referred to the carrier, for the description
    R = T.GearTrain(sv).R[2]
    i_s, i_p = (zs + zr) / zs, (zr - zp) / zp      # |w_sun / w_c|, |w_planet / w_c| (ring fixed)
    J_eff = sv["body[2].J"] + 3 * m_p * R ** 2 + 2e-3 * i_s ** 2 + 3 * 1.2e-4 * i_p ** 2
    alpha0 = (Tc - c_c * wc) / J_eff
    tau_c = J_eff / c_c
    desc = f"""Bearing forces of a torsional planetary set (lateral.md section 6: body[i].Fx, \
body[i].Fy, housing.Fx, housing.Fy, every centre held where planetary.md section 3 puts it): \
planetary-pin-error's set (20/22/64, module 2 mm, R = {R * 1e3:.4f} mm, three planets J 1.2e-4, \
m {m_p:g} kg, ring fixed, B = 0; planet 1, body 3, 2 um ahead along its orbit), with friction \
mu = {mu:g} on all six meshes (v_reg 0.01 m/s: the friction forces lie along the flanks' \
tangents, nearly radial at a planet, and flip at every pitch point) and a carrier that \
ACCELERATES: the sun's {Ts:g} N.m at {ws:g} rad/s against a carrier drag of {c_c:.6g} N.m.s/rad, \
which absorbs only half the set's {Tc:.6g} N.m at the Willis speed {wc:.6g} rad/s. The rigid \
set's inertia referred to the carrier is {J_eff:.4f} kg.m^2 (carrier 0.05, orbital 3 x 0.3 R^2, \
sun 2e-3 x 4.2^2, planets' spin 3 x 1.2e-4 x 1.91^2), so the carrier starts at {alpha0:.0f} \
rad/s^2 and tends to twice its start speed with a time constant of {tau_c * 1e3:.0f} ms (the \
reference ends at 54.3 rad/s, the sun at 227.5). What each term contributes (from the \
reference trace): a planet's pin carries its two meshes' normal forces times cos(alpha_w) \
tangentially (2.9-7.0 kN on planet 1), friction's nearly radial forces (planet 1's radial force \
swings between -520 and +1130 N as they flip), the centripetal force m R Omega^2 inwards \
({m_p * R * wc ** 2:.1f} N at the start, 37.9 N at the end) and m R alpha tangentially \
({m_p * R * alpha0:.0f} N at the start); the pin error shares the load unequally (planet 1 \
carries 38-78 % of the sun's torque over a mesh cycle, 45 % at the start) and the planets' \
meshes are out of phase (20/3 teeth per planet spacing), so the sun's bearing carries a net \
force of 0.36-3.3 kN and the carrier's a force that turns with it; every mesh stays in contact \
(at 50 N.m, with part of the torque spent on the sun's acceleration, the 2 um error unloaded \
planets 2 and 3 once per mesh cycle). The housing takes the rest, -sum m_n a_n, which only the \
pin error leaves nonzero: m et (Omega^2 e_t + alpha e_r) at planet 1, 1.5 mN at the start \
(mostly the carrier's acceleration), up to 2.0 mN. chi = 20 s/m; running start at the static \
loads in the accelerating set (train_ref.quasi_static_start)."""
    return "planetary-bearings", sv, desc, 0.03, 3e-5, dict(
        variables=["body[1].w", "body[2].w", "body[3].w", "mesh[1].dte", "mesh[2].dte",
                   "mesh[1].F_fwd", "mesh[2].F_fwd", "mesh[3].F_fwd", "mesh[4].F_fwd",
                   "mesh[1].P_loss", "housing.tau"]
        + [f"body[{i}].F{c}" for i in range(1, 6) for c in "xy"] + ["housing.Fx", "housing.Fy"])


SCENES = [scene_simple, scene_mounted, scene_pin_error, scene_two_stage, scene_power_split,
          scene_lumped_planetary, scene_bearings]


def fmt(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    return repr(float(v))


def write_scene(name, sv, desc, stop, dt, cmp, tolerances=None):
    path = os.path.join(T.TRAIN_SCENES_DIR, name + ".toml")
    lines = [f'description = """{desc}"""', f"stop_time = {stop!r}", f"output_interval = {dt!r}",
             'mode = "trace"', "", "[start_values]"]
    for k, v in sv.items():
        key = f'"{k}"' if "[" in k else k
        lines.append(f"{key} = {fmt(v)}")
    lines += ["", "[compare]", "variables = [" + ", ".join(f'"{v}"' for v in cmp["variables"]) + "]",
              "events = true", "", "[compare.tolerance]"]
    lines += tolerances or [f'"{v}" = 0.0   # set by regenerate_train.py --suggest'
                            for v in cmp["variables"]]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


def existing_tolerances(name):
    """Keep the [compare.tolerance] block of an existing scene file (it is derived from the
    reference by the policy, regenerate_train.py --suggest, after the trace exists)."""
    path = os.path.join(T.TRAIN_SCENES_DIR, name + ".toml")
    if not os.path.exists(path):
        return None
    txt = open(path).read().split("[compare.tolerance]\n", 1)
    if len(txt) < 2:
        return None
    lines = txt[1].rstrip("\n").split("\n")
    return lines if not any("= 0.0   # set by" in ln for ln in lines) else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="design checks only")
    ap.add_argument("scenes", nargs="*")
    args = ap.parse_args(argv)
    for make in SCENES:
        out = make()
        name, sv, desc, stop, dt, cmp = out[:6]
        groups = out[6] if len(out) > 6 else ()
        if args.scenes and name not in args.scenes:
            continue
        if args.check:
            continue
        full = {k: v for k, v in sv.items()}
        qs = T.quasi_static_start(full, mount_groups=groups)
        for k in list(qs):
            if k not in sv and k in T.DEFAULTS and qs[k] != T.DEFAULTS[k]:
                sv[k] = qs[k]
            elif k in sv:
                sv[k] = qs[k]
        path = write_scene(name, sv, desc, stop, dt, cmp, existing_tolerances(name))
        print("wrote", path)


if __name__ == "__main__":
    main()
