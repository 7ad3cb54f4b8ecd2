"""Tests of tools/train_layout.py (the gear train's layout picture and run plot), about 20 s.

    .venv/bin/python -m pytest tests/python/test_train_layout.py

The geometric facts are checked against closed forms written out here (centre distances
d = rA + rB of the paper geometry and m (zA + zB)/2 of the standard one, base radii r cos(alpha_w),
tip radii m z/2 + m (ha + x)) and against properties any correct drawing has: the line of action
touches both base circles at its ends and crosses the line of centres at the pitch point, and
each base circle, turning in its body's forward sense, moves along K_A -> K_B at its tangent
point (the forward flank of A drives B forward).  Tolerances: positions are sums of a few
products of numbers <= 1 m, so 1e-12 relative (or 1e-15 m absolute at the origin) is ~1e3
roundings.

Planetary sets (planetary.md sections 1, 3, 4; the scenes scenes/train/planetary-*.toml and
power-split.toml): planet axes at the orbit radius R (the nominal operating centre distance of
the planet's lowest-index mesh with a central member, from the involute closed form here) and the
orbit angle, pin errors moving them, the ring's circles from section 1's formulas, the internal
meshes' lines of action checked by the same tangency and forward-motion properties, the placing
walk, and the refusals.  The walk's senses and loop meshes are also cross-checked with the
independent reference's own topology code (train_ref.py).
"""

import csv
import math
import sys
from pathlib import Path

import pytest
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))

import layout_drawing as D  # noqa: E402
import run_plots as RP  # noqa: E402
import train_layout as T  # noqa: E402

REL = 1e-12
DEG = math.pi / 180.0


def close(x, y, rel=REL, abs_=1e-15):
    return abs(x - y) <= max(rel * max(abs(x), abs(y)), abs_)


def idler(angle):
    """Three bodies, body 2 the idler (B of mesh 1, A of mesh 2) with the same gear data in both:
    z = 33 (nominal 30), r = 0.3 m; bodies 1 and 3 z = 22 (nominal 20), r = 0.2 m."""
    return {"n_bodies": 3, "n_shafts": 0, "n_meshes": 2,
            "mesh[2].A": 2, "mesh[2].B": 3, "mesh[2].center_angle": angle,
            "mesh[2].zA": 33, "mesh[2].zA_nominal": 30, "mesh[2].rA": 0.3,
            "mesh[2].zB": 22, "mesh[2].zB_nominal": 20}


# paper geometry by hand (gear-mesh-model.md section 2), defaults rA = 0.2, 20/30, factor 2.8
def paper_alpha_w(zAn=20, zBn=30, factor=2.8):
    return factor * math.atan(2.0 * math.pi / (zAn * (1.0 + zBn / zAn)))


FOUR_STAGE = {  # a chain of four meshes turning in all directions, a shaft in the middle
    "n_bodies": 6, "n_shafts": 1, "n_meshes": 4,
    "shaft[1].a": 3, "shaft[1].b": 4,
    "mesh[1].A": 1, "mesh[1].B": 2, "mesh[1].center_angle": 20 * DEG,
    "mesh[2].A": 3, "mesh[2].B": 2, "mesh[2].center_angle": 200 * DEG,   # B already placed
    "mesh[3].A": 4, "mesh[3].B": 5, "mesh[3].center_angle": -75 * DEG,
    "mesh[4].A": 5, "mesh[4].B": 6, "mesh[4].center_angle": 150 * DEG,
    # mesh 4 in standard geometry with profile shifts
    "mesh[4].geometry": 2, "mesh[4].module": 0.005, "mesh[4].zA": 24, "mesh[4].zB": 37,
    "mesh[4].zA_nominal": 24, "mesh[4].zB_nominal": 37, "mesh[4].xA": 0.3, "mesh[4].xB": 0.1,
}


# ------------------------------------------------------------------------------ placement

def test_default_two_stage_reducer():
    lay = T.layout({})
    c = {i: b["center"] for i, b in lay["bodies"].items()}
    d = 0.2 + 0.2 * 30 / 20  # rA + rB, both meshes at the single-mesh defaults
    assert c[1] == (0.0, 0.0)
    assert close(c[2][0], d) and c[2][1] == 0.0
    assert c[3] == c[2]                       # shaft 1 joins bodies 2 and 3: coaxial
    assert close(c[4][0], 2 * d) and c[4][1] == 0.0
    # sigma_1 = -1, flipped across a mesh, kept across the shaft
    assert [lay["bodies"][i]["sigma"] for i in (1, 2, 3, 4)] == [-1, 1, 1, -1]
    assert lay["counts"] == {"n_bodies": 4, "n_shafts": 1, "n_meshes": 2}


def test_ninety_degrees_puts_body_2_above():
    lay = T.layout({"mesh[1].center_angle": math.pi / 2})
    c = {i: b["center"] for i, b in lay["bodies"].items()}
    assert abs(c[2][0]) < 1e-15 and close(c[2][1], 0.5)
    assert close(c[4][0], 0.5) and close(c[4][1], 0.5)   # mesh 2 still along +x from body 3


def test_mesh_placed_from_its_B_body():
    # mesh 2 names the already placed body 2 as its B: O_A = O_B - d (cos beta, sin beta)
    lay = T.layout({"n_bodies": 3, "n_shafts": 0, "mesh[2].A": 3, "mesh[2].B": 2,
                    "mesh[2].center_angle": 30 * DEG})
    c = {i: b["center"] for i, b in lay["bodies"].items()}
    assert close(c[3][0], 0.5 - 0.5 * math.cos(30 * DEG))
    assert close(c[3][1], -0.5 * math.sin(30 * DEG))
    assert [lay["bodies"][i]["sigma"] for i in (1, 2, 3)] == [-1, 1, -1]


def test_idler_senses_and_position():
    lay = T.layout(idler(60 * DEG))
    assert [lay["bodies"][i]["sigma"] for i in (1, 2, 3)] == [-1, 1, -1]
    c = {i: b["center"] for i, b in lay["bodies"].items()}
    assert close(c[3][0], 0.5 + 0.5 * 0.5) and close(c[3][1], 0.5 * math.sqrt(3) / 2)
    # 120 degrees at the idler between the two lines of centres
    assert close(math.dist(c[1], c[3]), 0.5 * math.sqrt(3))
    # the idler's gear is one gear: same tooth count, base circle, tip circle and thickness in
    # both meshes (paper geometry, equal backlash; its thickness angle s_w / r + 2 inv(alpha_w))
    g1, g2 = lay["bodies"][2]["gears"]
    aw = paper_alpha_w()
    p_b = 0.2 * math.cos(aw) * 2 * math.pi / 22
    t = (p_b - 1e-4) / (2 * math.cos(aw)) / 0.3 + 2 * (math.tan(aw) - aw)
    for g in (g1, g2):
        assert g["z"] == 33 and close(g["r_b"], 0.3 * math.cos(aw)) and close(g["t"], t)
    assert T.same_gear(g1, g2)
    assert not T.same_gear(g1, dict(g2, mount=0.01))


def test_standard_geometry_centre_distance_and_pitch_circles():
    m, zA, zB, xA, xB, a0 = 0.005, 24, 37, 0.3, 0.1, 20 * DEG
    lay = T.layout(FOUR_STAGE)
    mm = lay["meshes"][4]
    inv = lambda a: math.tan(a) - a  # noqa: E731
    aw = brentq(lambda a: inv(a) - inv(a0) - 2 * math.tan(a0) * (xA + xB) / (zA + zB), 0.1, 1.2,
                xtol=1e-16)
    d = m * (zA + zB) / 2 * math.cos(a0) / math.cos(aw)
    assert close(math.dist(mm["O_A"], mm["O_B"]), d, rel=1e-11)
    # operating pitch circles touch at the pitch point and divide d in the ratio zA : zB
    assert close(mm["r_wA"] + mm["r_wB"], d, rel=1e-11)
    assert close(mm["r_wA"] / mm["r_wB"], zA / zB)
    assert close(math.dist(mm["O_A"], mm["P"]), mm["r_wA"], rel=1e-11)
    # the contact segment ends on the tip circles m z/2 + m (ha + x)
    assert close(math.dist(mm["O_A"], mm["b"]), m * zA / 2 + m * (1.0 + xA))
    assert close(math.dist(mm["O_B"], mm["a"]), m * zB / 2 + m * (1.0 + xB))
    # without shifts the operating pitch circle is the reference circle m z / 2
    lay0 = T.layout({**FOUR_STAGE, "mesh[4].xA": 0.0, "mesh[4].xB": 0.0})
    mm0 = lay0["meshes"][4]
    assert close(mm0["r_wA"], m * zA / 2) and close(mm0["r_wB"], m * zB / 2)


def test_paper_pitch_radii():
    lay = T.layout({"mesh[2].rA": 0.1, "mesh[2].zA_nominal": 20, "mesh[2].zB_nominal": 50,
                    "mesh[2].zA": 20, "mesh[2].zB": 50, "mesh[2].alpha_factor": 3.0})
    mm = lay["meshes"][2]
    assert close(mm["r_wA"], 0.1) and close(mm["r_wB"], 0.25)
    assert close(math.dist(mm["O_A"], mm["O_B"]), 0.35)


# ------------------------------------------------------------------------------ lines of action

def line_distance(p, q, c):
    """Distance of point c from the line through p and q."""
    ux, uy = q[0] - p[0], q[1] - p[1]
    return abs(ux * (c[1] - p[1]) - uy * (c[0] - p[0])) / math.hypot(ux, uy)


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


@pytest.mark.parametrize("params", [
    {}, {"mesh[1].center_angle": math.pi / 2}, idler(60 * DEG), idler(-130 * DEG), FOUR_STAGE,
], ids=["default", "ninety", "idler60", "idler-130", "four-stage"])
def test_lines_of_action_touch_both_base_circles(params):
    lay = T.layout(params)
    assert lay["meshes"]
    for m, mm in lay["meshes"].items():
        OA, OB, KA, KB = mm["O_A"], mm["O_B"], mm["K_A"], mm["K_B"]
        rAb, rBb = mm["geometry"].rAb, mm["geometry"].rBb
        if mm["params"]["geometry"] == 1:   # base radii by hand: r cos(alpha_w)
            p = mm["params"]
            aw = paper_alpha_w(p["zA_nominal"], p["zB_nominal"], p["alpha_factor"])
            assert close(rAb, p["rA"] * math.cos(aw))
            assert close(rBb, p["rA"] * p["zB_nominal"] / p["zA_nominal"] * math.cos(aw))
        # tangent: each centre's distance from the line is its base radius, reached at K
        assert close(line_distance(KA, KB, OA), rAb), (m, line_distance(KA, KB, OA), rAb)
        assert close(line_distance(KA, KB, OB), rBb), (m, line_distance(KA, KB, OB), rBb)
        assert close(math.dist(OA, KA), rAb) and close(math.dist(OB, KB), rBb)
        u = (KB[0] - KA[0], KB[1] - KA[1])
        L = math.hypot(*u)
        dot_A = ((KA[0] - OA[0]) * u[0] + (KA[1] - OA[1]) * u[1]) / (rAb * L)
        dot_B = ((KB[0] - OB[0]) * u[0] + (KB[1] - OB[1]) * u[1]) / (rBb * L)
        assert abs(dot_A) < 1e-12 and abs(dot_B) < 1e-12
        # the internal (crossed) tangent: it cuts O_A O_B at the pitch point, which divides it
        # in the ratio rAb : rBb, and K_A, K_B lie on opposite sides of the line of centres
        d = math.dist(OA, OB)
        f = rAb / (rAb + rBb)
        P = (OA[0] + (OB[0] - OA[0]) * f, OA[1] + (OB[1] - OA[1]) * f)
        assert line_distance(KA, KB, P) <= 1e-12 * d
        assert close(math.dist(mm["P"], P), 0.0, abs_=1e-12 * d)
        ob = (OB[0] - OA[0], OB[1] - OA[1])
        side_A = cross(ob, (KA[0] - OA[0], KA[1] - OA[1]))
        side_B = cross(ob, (KB[0] - OA[0], KB[1] - OA[1]))
        assert side_A * side_B < 0
        # forward flank: each base circle turning forward moves along K_A -> K_B at its tangent
        # point (A drives B; the force on B along u turns B forward)
        assert close(cross((KA[0] - OA[0], KA[1] - OA[1]), u) / L, mm["sigma_A"] * rAb)
        assert close(cross((KB[0] - OB[0], KB[1] - OB[1]), u) / L, mm["sigma_B"] * rBb)
        assert mm["sigma_B"] == -mm["sigma_A"]
        # the contact segment lies on K_A K_B, a before b, and ends on the tip circles
        g = mm["geometry"]
        assert close(math.dist(KA, mm["a"]), g.s_a) and close(math.dist(KA, mm["b"]), g.s_b)
        assert close(math.dist(mm["a"], KB), L - g.s_a)
        assert close(math.dist(OA, mm["b"]), g.r_tipA) and close(math.dist(OB, mm["a"]), g.r_tipB)
        assert close(L, d * math.sin(g.alpha_w))


def test_paper_frame_mirror_matches_spec_angles():
    # spec section 3, sigma_A = +1: psi^m = -(psi - beta), so a paper-frame direction at angle
    # phi is the housing direction beta - phi; sigma_A = -1: psi^m = psi - beta
    O, beta, r = (0.3, -0.7), 0.9, 0.25
    for phi in (0.0, 0.35, 2.0, -1.1):
        p = (r * math.cos(phi), r * math.sin(phi))
        x, y = T.paper_to_housing(p, O, beta, +1)
        assert close(x, O[0] + r * math.cos(beta - phi))
        assert close(y, O[1] + r * math.sin(beta - phi))
        x, y = T.paper_to_housing(p, O, beta, -1)
        assert close(x, O[0] + r * math.cos(beta + phi))
        assert close(y, O[1] + r * math.sin(beta + phi))


# ------------------------------------------------------------------------------ topology

@pytest.mark.parametrize("params, pattern", [
    ({"mesh[1].B": 1}, r"mesh\[1\] joins body 1 to itself"),
    ({"shaft[1].b": 2}, r"shaft\[1\] joins body 2 to itself"),
    ({"mesh[2].B": 5}, r"mesh\[2\]\.B = 5 is not a body"),
    ({"shaft[1].a": -1}, r"shaft\[1\]\.a = -1 is not a body"),   # 0 is the housing
    ({"n_bodies": 3, "n_shafts": 0, "n_meshes": 3, "mesh[2].A": 2, "mesh[2].B": 3,
      "mesh[3].A": 3, "mesh[3].B": 1},
     r"mesh\[3\].*cycle through bodies 1, 2, 3: mesh\[1\], mesh\[2\], mesh\[3\]"),
    ({"n_bodies": 2, "n_meshes": 1, "shaft[1].a": 1, "shaft[1].b": 2},
     r"mesh\[1\].*cycle through bodies 1, 2: shaft\[1\], mesh\[1\]"),
    ({"n_shafts": 0}, r"body 3, body 4 not connected"),
    ({"n_bodies": 17}, r"n_bodies = 17 outside 1\.\.16"),   # planetary.md section 5
    ({"mesh[17].zA": 20}, r"mesh\[17\]\.zA: mesh index 17 outside 1\.\.16"),
    ({"n_shafts": 2, "n_bodies": 5, "mesh[2].B": 5}, r"shaft\[2\]\.a is not set"),
    ({"mesh[2].contact_model": 2}, r"mesh\[2\]\.contact_model = 2: rigid contact"),
    ({"mesh[1].J_A": 1.0}, r"mesh\[1\]\.J_A"),
    ({"mesh[2].zB": 34}, r"mesh\[2\]: zB/zA"),
])
def test_topology_and_parameter_errors_name_the_element(params, pattern):
    with pytest.raises(ValueError, match=pattern):
        T.layout(params)


def test_unknown_names_are_warned_about_and_ignored():
    with pytest.warns(UserWarning, match=r"mesh\[1\]\.za"):
        lay = T.layout({"mesh[1].za": 3})
    assert len(lay["meshes"]) == 2


def test_single_body_and_elements_beyond_the_counts():
    lay = T.layout({"n_bodies": 1, "n_shafts": 0, "n_meshes": 0, "mesh[3].A": 7})
    assert lay["bodies"][1]["center"] == (0.0, 0.0) and lay["meshes"] == {}


# ------------------------------------------------------------------------------ pictures and CLI

def test_draw_layout_and_cli(tmp_path):
    out = tmp_path / "layout.png"
    D.draw_layout(idler(60 * DEG), out)
    assert out.stat().st_size > 20_000
    scene = tmp_path / "idler.toml"
    scene.write_text('description = "idler"\n[start_values]\nn_bodies = 3\nn_shafts = 0\n'
                     '"mesh[2].A" = 2\n"mesh[2].B" = 3\n"mesh[2].zA" = 33\n'
                     '"mesh[2].zA_nominal" = 30\n"mesh[2].rA" = 0.3\n"mesh[2].zB" = 22\n'
                     '"mesh[2].zB_nominal" = 20\n')
    out2 = tmp_path / "cli.png"
    assert T.main(["layout", "--scene", str(scene), "--set", "mesh[2].center_angle=1.2",
                   "-o", str(out2)]) == 0
    assert out2.stat().st_size > 20_000
    assert T.load_scene(scene)["mesh[2].zA"] == 33
    assert T.main(["layout", "--set", "mesh[1].B=1", "-o", str(tmp_path / "x.png")]) == 2


def write_fmpy_csv(path, names, rows):
    """The CSV as `fmpy simulate` writes it (fmpy.util.write_csv on a structured array)."""
    import numpy as np
    from fmpy.util import write_csv
    types = [(n, np.int32 if n.endswith((".n_fwd", ".n_bwd")) else np.float64) for n in names]
    write_csv(str(path), np.array([tuple(r) for r in rows], dtype=types))


def test_plot_run_on_a_synthetic_csv(tmp_path):
    names = ["time", "mesh[1].dte", "mesh[1].F_fwd", "mesh[1].F_bwd", "mesh[1].F_f1",
             "mesh[1].F_f2", "mesh[2].dte", "mesh[2].F_fwd", "mesh[2].F_bwd", "mesh[3].dte",
             "mesh[3].F_fwd", "body[1].w", "body[2].w", "shaft[1].tau", "mesh[1].n_fwd"]
    rows = []
    for k in range(201):
        t = 1e-4 * k
        rows.append([t, 1e-6 * (1 + 0.1 * math.sin(3e3 * t)), 500 + 50 * math.sin(3e3 * t), 0.0,
                     300.0, 200 + 50 * math.sin(3e3 * t), 2e-6, 800.0, 0.0, 0.0, 0.0,
                     100 + t, 66 + t, 150.0, 2])
    path = tmp_path / "run.csv"
    write_fmpy_csv(path, names, rows)
    out = tmp_path / "run.png"
    # mesh 3 reads 0 throughout (beyond n_meshes): not shown
    assert RP.plot_run(path, out) == [1, 2]
    assert out.stat().st_size > 20_000
    assert T.main(["run", str(path), "-o", str(tmp_path / "cli-run.png")]) == 0
    cols = RP.read_run_csv(path)
    assert cols["mesh[1].F_fwd"][0] == 500.0 and len(cols["time"]) == 201

    bad = tmp_path / "bad.csv"
    with open(bad, "w", newline="") as f:
        csv.writer(f).writerows([["t", "x"], [0, 1]])
    with pytest.raises(ValueError, match="first column must be 'time'"):
        RP.plot_run(bad, tmp_path / "bad.png")
    with open(bad, "w", newline="") as f:
        csv.writer(f).writerows([["time", "y"], [0, 1]])
    with pytest.raises(ValueError, match="no non-zero"):
        RP.plot_run(bad, tmp_path / "bad.png")


# ------------------------------------------------------------------------------ planetary sets
# planetary.md sections 1, 3 and 4; the scenes' data: planetary-simple is sun 21 (x 0.5),
# planets 18 (x 0), ring 57 (x 0.5) fixed (mesh B = 0), module 2 mm, 20 deg, ha = 1.

SCENES = ROOT / "scenes" / "train"
A0 = 20 * DEG


def inv(a):
    return math.tan(a) - a


def op_distance(m, z1, z2, x1, x2, internal):
    """Nominal operating centre distance of a standard pair (planetary.md section 1 for a ring:
    inv aw = inv a0 + 2 tan a0 (xB - xA)/(zB - zA), d = m (zB - zA)/2 cos a0 / cos aw; external:
    sums in place of the differences). Returns (d, alpha_w)."""
    s = -1 if internal else 1
    aw = brentq(lambda a: inv(a) - inv(A0) - 2 * math.tan(A0) * (x2 + s * x1) / (z2 + s * z1),
                0.05, 1.2, xtol=1e-16)
    return m * (z2 + s * z1) / 2 * math.cos(A0) / math.cos(aw), aw


def simple():
    return T.load_scene(SCENES / "planetary-simple.toml")


def test_planetary_simple_planets_on_their_orbit(tmp_path):
    lay = T.layout(simple())
    R, _ = op_distance(0.002, 21, 18, 0.5, 0.0, False)      # mesh 1: sun-planet, the lowest
    R_ring, _ = op_distance(0.002, 18, 57, 0.0, 0.5, True)  # the scene's design: equal
    assert close(R, R_ring, rel=1e-9)
    carrier = lay["bodies"][2]
    assert carrier["planets"] == [3, 4, 5] and carrier["center"] == (0.0, 0.0)
    assert lay["bodies"][1]["center"] == (0.0, 0.0)          # the sun on the carrier's axis
    for i, phi in ((3, 0.0), (4, 2 * math.pi / 3), (5, 4 * math.pi / 3)):
        b = lay["bodies"][i]
        assert b["carrier"] == 2 and close(b["R"], R, rel=1e-11)
        assert close(b["center"][0], R * math.cos(phi), rel=1e-11, abs_=1e-15)
        assert close(b["center"][1], R * math.sin(phi), rel=1e-11, abs_=1e-15)
    # the ring (body 0) is on the carrier's axis in each of its meshes, and drawn once
    for m in (4, 5, 6):
        mm = lay["meshes"][m]
        assert mm["B"] == 0 and mm["internal"] and mm["carrier"] == 2
        assert mm["O_B"] == (0.0, 0.0)
        assert close(math.dist(mm["O_A"], mm["O_B"]), R, rel=1e-11)
    lay2 = D.draw_layout(simple(), tmp_path / "planetary-layout.png")
    ring = [g for g in lay2["housing_drawn"] if g["internal"]]
    assert len(ring) == 1 and ring[0]["names"] == ["mesh[4].B", "mesh[5].B", "mesh[6].B"]


def test_ring_circles_follow_the_internal_formulas():
    lay = T.layout(simple())
    m, zA, zB, xA, xB = 0.002, 18, 57, 0.0, 0.5
    d, aw = op_distance(m, zA, zB, xA, xB, True)
    (ring,) = {(g["r_w"], g["r_tip"], g["r_b"], g["r_root"]) for g in lay["housing_gears"]}
    r_w, r_tip, r_b, r_root = ring
    assert close(r_b, m * zB * math.cos(A0) / 2)              # rBb
    assert close(r_tip, m * zB / 2 - m * (1.0 - xB))          # r_Ba: the tips point inwards
    assert close(r_w, r_b / math.cos(aw), rel=1e-11)          # operating pitch circle
    assert close(r_root, m * zB / 2 + m * (1.25 + xB))
    assert r_b < r_tip < r_w < r_root                         # tip circle inside the pitch circle
    planet = lay["bodies"][3]["gears"][0]
    # pitch circles of a ring pair touch from inside: r_wB - r_wA = d
    assert close(r_w - planet["r_w"], d, rel=1e-10)
    assert close(planet["r_tip"], m * zA / 2 + m * (1.0 + xA))


@pytest.mark.parametrize("scene", ["planetary-simple", "planetary-pin-error", "power-split",
                                   "planetary-mounted"])
def test_internal_lines_of_action_in_the_carrier_frame(scene):
    """planetary.md section 1's frame (O_B at (-d, 0), rotated by beta + pi, mirrored when
    sigma_A = +1), checked by properties: the line touches both base circles at K_A and K_B on
    the SAME side of the line of centres (the external tangent of a circle inside a circle),
    the pitch point lies beyond O_A at r_wA from O_A and r_wB from O_B, the contact segment ends
    on the tip circles, and each base circle turning forward moves along u at its tangent
    point."""
    lay = T.layout(T.load_scene(SCENES / f"{scene}.toml"))
    internal = [mm for mm in lay["meshes"].values() if mm["internal"]]
    assert internal
    for mm in lay["meshes"].values():
        g = mm["geometry"]
        OA, OB, KA, KB, u, P = mm["O_A"], mm["O_B"], mm["K_A"], mm["K_B"], mm["u"], mm["P"]
        d = math.dist(OA, OB)
        assert close(d, g.d, rel=1e-9)
        assert close(math.dist(OA, KA), g.rAb) and close(math.dist(OB, KB), g.rBb)
        assert abs(line_distance(KA, KB, OA) - g.rAb) < 1e-12
        assert abs(line_distance(KA, KB, OB) - g.rBb) < 1e-12
        assert close(math.hypot(*u), 1.0)
        assert close(cross((KA[0] - OA[0], KA[1] - OA[1]), u), mm["sigma_A"] * g.rAb)
        assert close(cross((KB[0] - OB[0], KB[1] - OB[1]), u), mm["sigma_B"] * g.rBb)
        assert close(math.dist(OA, mm["b"]), g.r_tipA) and close(math.dist(OB, mm["a"]), g.r_tipB)
        assert close(math.dist(KA, KB), g.L, rel=1e-11)
        ob = (OB[0] - OA[0], OB[1] - OA[1])
        side = cross(ob, (KA[0] - OA[0], KA[1] - OA[1])) * cross(ob, (KB[0] - OA[0], KB[1] - OA[1]))
        assert line_distance(OA, OB, P) < 1e-12
        assert close(math.dist(OA, P), g.rAb / math.cos(g.alpha_w), rel=1e-11)
        assert close(math.dist(OB, P), g.rBb / math.cos(g.alpha_w), rel=1e-11)
        if mm["internal"]:
            assert side > 0                                        # same side
            assert mm["sigma_A"] == mm["sigma_B"]                  # an internal mesh keeps it
            assert close(math.dist(OB, P) - math.dist(OA, P), d, rel=1e-9)   # P beyond O_A
        else:
            assert side < 0 and mm["sigma_A"] == -mm["sigma_B"]


def test_pin_error_moves_the_planet_and_its_meshes():
    sv = T.load_scene(SCENES / "planetary-pin-error.toml")
    et = sv["body[3].pin_error_t"]
    assert et == 2e-6
    lay = T.layout(sv)
    R, _ = op_distance(0.002, 20, 22, 0.5, 0.0, False)
    c3 = lay["bodies"][3]["center"]
    assert close(c3[0], R, rel=1e-11) and close(c3[1], et)        # 2 um counter-clockwise
    m1 = lay["meshes"][1]                                         # sun (A) - planet 3 (B)
    assert close(m1["geometry"].d, math.hypot(R, et), rel=1e-12)
    assert close(m1["beta"], math.atan2(et, R), rel=1e-9)
    m4 = lay["meshes"][4]                                         # planet 3 (A) - ring (B = 0)
    assert abs(math.remainder(m4["beta"] - math.atan2(et, R) - math.pi, 2 * math.pi)) < 1e-15
    # the pin error with its sign flipped radially instead: the planet moves outwards
    lay_r = T.layout({**sv, "body[3].pin_error_t": 0.0, "body[3].pin_error_r": 1e-6})
    assert close(lay_r["bodies"][3]["center"][0], R + 1e-6, rel=1e-11)
    assert close(lay_r["meshes"][1]["geometry"].d, R + 1e-6, rel=1e-12)


def test_planetary_senses_and_walk():
    lay = T.layout(simple())
    assert lay["general"] and lay["root"] == 0                   # the housing is named
    assert [lay["bodies"][i]["sigma"] for i in (1, 2, 3, 4, 5)] == [-1, -1, 1, 1, 1]
    # queue [housing, carrier 2]: the ring meshes place the planets, planet 3 the sun
    assert lay["placed"] == [(3, "mesh[4]"), (4, "mesh[5]"), (5, "mesh[6]"), (1, "mesh[1]")]
    assert lay["loops"] == [2, 3]
    ps = T.layout(T.load_scene(SCENES / "power-split.toml"))    # no housing: from body 1
    assert ps["root"] == 1 and ps["starts"] == [1, 2] and ps["loops"] == [6, 7, 8]
    assert [ps["bodies"][i]["sigma"] for i in range(1, 8)] == [-1, -1, 1, 1, 1, 1, 1]


@pytest.mark.parametrize("scene", ["planetary-simple", "planetary-mounted", "planetary-pin-error",
                                   "planetary-two-stage", "power-split"])
def test_planetary_walk_agrees_with_the_reference(scene):
    """Cross-check with the independent reference's own topology code
    (tests/reference_model/train_ref.py): senses, loop-closing meshes, body 1's start angle."""
    from reference_model import train_ref as TR
    sv = T.load_scene(SCENES / f"{scene}.toml")
    lay = T.layout(sv)
    ref = TR.GearTrain(sv)
    assert [lay["bodies"][i]["sigma"] for i in sorted(lay["bodies"])] == list(ref.sigma)
    assert lay["loops"] == [k + 1 for k, mm in enumerate(ref.meshes) if mm.loop]
    if lay["root"] == 0:
        assert lay["psi1"] == ref.psi0[0]


@pytest.mark.parametrize("change, pattern", [
    ({"mesh[1].A": 0}, r"body 1, body 2, body 3, body 4, body 5 jammed"),   # sun and ring fixed
    ({"body[2].carrier": 3}, r"body\[2\]\.carrier = 3: body 3 is itself carried"),
    ({"mesh[2].center_angle": 0.1}, r"mesh\[2\]\.center_angle = 0\.1: a mesh in the frame of "
                                     r"carrier body 2"),
    ({"mesh[1].A": 2}, r"mesh\[1\] joins a planet to its own carrier, body 2"),
    ({"mesh[1].B": 2}, r"the axes do not close: .*body 2's axis"),   # sun-carrier: housing frame
    ({"body[3].carrier": 17}, r"body\[3\]\.carrier = 17 is not a body"),
    # planets at 0, 2, 4 rad: (21 + 57) 2 / (2 pi) is no integer (the reference's placement)
    ({"body[4].orbit_angle": 2.0, "body[5].orbit_angle": 4.0},
     r"placement .*mesh\[2\] closes a loop and cannot be assembled as placed.*assembly "
     r"condition"),
])
def test_planetary_refusals_name_the_elements(change, pattern):
    with pytest.raises(ValueError, match=pattern):
        T.layout({**simple(), **change})


def test_conflicting_senses_around_a_loop_are_refused():
    # power-split with one planet-ring mesh external: sun -> planet 4 -> ring -> planet 5 -> sun
    # flips the sense three times
    sv = {**T.load_scene(SCENES / "power-split.toml"), "mesh[5].internal": False}
    with pytest.raises(ValueError, match=r"mesh\[6\] \(bodies 5-3\) closes a cycle through "
                                         r"bodies 1, 3, 4, 5: mesh\[1\], mesh\[2\], mesh\[5\], "
                                         r"mesh\[6\], around which the forward senses conflict"):
        T.layout(sv)


def test_axes_that_do_not_close_are_refused():
    # body 6 meshes with the sun in the housing's frame (at d from its axis) and is also joined
    # by a shaft to the carrier, whose axis is the sun's: the axes cannot close
    sv = {**simple(), "n_bodies": 6, "n_shafts": 1, "n_meshes": 7,
          "shaft[1].a": 6, "shaft[1].b": 2,
          "mesh[7].A": 1, "mesh[7].B": 6, "mesh[7].geometry": 2, "mesh[7].module": 0.002,
          "mesh[7].zA": 21, "mesh[7].zB": 30, "mesh[7].zA_nominal": 21,
          "mesh[7].zB_nominal": 30}
    with pytest.raises(ValueError, match=r"the axes do not close: .* um from where"):
        T.layout(sv)


def test_torsional_mount_and_planetary_drawings(tmp_path):
    sv = T.load_scene(SCENES / "planetary-mounted.toml")
    assert sv["shaft[1].b"] == 0                                 # the ring on a torque arm
    lay = D.draw_layout(sv, tmp_path / "mounted.png")
    assert lay["bodies"][3]["center"] == (0.0, 0.0) and lay["placed"][0] == (3, "shaft[1]")
    assert (tmp_path / "mounted.png").stat().st_size > 50_000
    assert T.main(["layout", "--scene", str(SCENES / "planetary-two-stage.toml"),
                   "-o", str(tmp_path / "two.png")]) == 0


def test_load_shares_and_planetary_run_plot(tmp_path):
    lay = T.layout(simple())
    assert RP.planet_mesh_groups(lay) == {(2, 1, "sun"): [1, 2, 3], (2, 0, "ring"): [4, 5, 6]}
    names = ["time"] + [f"mesh[{m}].{f}" for m in range(1, 7) for f in ("dte", "F_fwd", "F_bwd")]
    names += ["body[1].w", "body[2].w", "housing.tau"]
    rows = []
    for k in range(101):
        t = 1e-4 * k
        f = [900.0 + 30 * math.sin(4e3 * t + 2 * p) for p in range(3)]   # three planets
        r = [t]
        for m in range(6):
            r += [1e-6, f[m % 3], 0.0]
        rows.append(r + [100.0, 26.9, 135.7])
    path = tmp_path / "run.csv"
    write_fmpy_csv(path, names, rows)
    flank, sh = RP.load_shares(RP.read_run_csv(path), [1, 2, 3])
    assert flank == "F_fwd"
    for k, row in enumerate(rows):
        mean = (row[2] + row[5] + row[8]) / 3
        assert close(sh[1][k], row[2] / mean, rel=1e-12)
        assert close(sh[1][k] + sh[2][k] + sh[3][k], 3.0, rel=1e-12)
    assert RP.plot_run(path, tmp_path / "run.png", simple()) == [1, 2, 3, 4, 5, 6]
    assert (tmp_path / "run.png").stat().st_size > 50_000
    assert T.main(["run", str(path), "--scene", str(SCENES / "planetary-simple.toml"),
                   "-o", str(tmp_path / "cli-run.png")]) == 0
