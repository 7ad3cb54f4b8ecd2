"""Tests of tools/train_layout.py (the gear train's layout picture and run plot), fast (a few s).

    .venv/bin/python -m pytest tests/python/test_train_layout.py

The geometric facts are checked against closed forms written out here (centre distances
d = rA + rB of the paper geometry and m (zA + zB)/2 of the standard one, base radii r cos(alpha_w),
tip radii m z/2 + m (ha + x)) and against properties any correct drawing has: the line of action
touches both base circles at its ends and crosses the line of centres at the pitch point, and
each base circle, turning in its body's forward sense, moves along K_A -> K_B at its tangent
point (the forward flank of A drives B forward).  Tolerances: positions are sums of a few
products of numbers <= 1 m, so 1e-12 relative (or 1e-15 m absolute at the origin) is ~1e3
roundings.
"""

import csv
import math
import sys
from pathlib import Path

import pytest
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))

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
    ({"shaft[1].a": 0}, r"shaft\[1\]\.a = 0 is not a body"),
    ({"n_bodies": 3, "n_shafts": 0, "n_meshes": 3, "mesh[2].A": 2, "mesh[2].B": 3,
      "mesh[3].A": 3, "mesh[3].B": 1},
     r"mesh\[3\].*cycle through bodies 1, 2, 3: mesh\[1\], mesh\[2\], mesh\[3\]"),
    ({"n_bodies": 2, "n_meshes": 1, "shaft[1].a": 1, "shaft[1].b": 2},
     r"mesh\[1\].*cycle through bodies 1, 2: shaft\[1\], mesh\[1\]"),
    ({"n_shafts": 0}, r"body 3, body 4 not connected"),
    ({"n_bodies": 9}, r"n_bodies = 9 outside 1\.\.8"),
    ({"mesh[7].zA": 20}, r"mesh\[7\]\.zA: mesh index 7 outside 1\.\.6"),
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
    T.draw_layout(idler(60 * DEG), out)
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
    assert T.plot_run(path, out) == [1, 2]
    assert out.stat().st_size > 20_000
    assert T.main(["run", str(path), "-o", str(tmp_path / "cli-run.png")]) == 0
    cols = T.read_run_csv(path)
    assert cols["mesh[1].F_fwd"][0] == 500.0 and len(cols["time"]) == 201

    bad = tmp_path / "bad.csv"
    with open(bad, "w", newline="") as f:
        csv.writer(f).writerows([["t", "x"], [0, 1]])
    with pytest.raises(ValueError, match="first column must be 'time'"):
        T.plot_run(bad, tmp_path / "bad.png")
    with open(bad, "w", newline="") as f:
        csv.writer(f).writerows([["time", "y"], [0, 1]])
    with pytest.raises(ValueError, match="no non-zero"):
        T.plot_run(bad, tmp_path / "bad.png")
