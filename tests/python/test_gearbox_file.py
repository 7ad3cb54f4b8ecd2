"""Gearbox files (gearbox-file.md) through the packaged SpurGearTrain FMU.

tools/scene_to_ssp.py packages a gearbox file as it packages a scene: its start values come
from the same Rust mapping the cargo tests hold to every scene (train-fmu/tests/gearbox.rs,
bit for bit). Here the two packages of one scene, from the scene and from its gearbox file,
are run through FMPy's simulate_ssp, each with its own parameter set: the FMU starts from the
same values (each variable's effective start: the .ssv's value or the FMU's default), so the
runs agree exactly, sample for sample.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import scene_to_ssp as X  # noqa: E402

# a tree with a shaft, and a planetary set with its fixed ring and loops
SCENES = ["two-stage", "planetary-simple"]


def _effective_starts(fmu, parameter_set):
    """Every parameter and input's start as the FMU will hold it: the set's value, else the
    FMU's declared start."""
    import fmpy

    md = fmpy.read_model_description(str(fmu))
    conv = {"Real": float, "Integer": int, "Boolean": lambda s: str(s).lower() in ("true", "1")}
    starts = {v.name: conv[v.type](v.start) for v in md.modelVariables
              if v.start is not None and v.type in conv and v.causality in ("parameter", "input")}
    for p in parameter_set.parameters:
        starts[p.name[len(X.COMPONENT) + 1:]] = p.value
    return starts


@pytest.mark.parametrize("name", SCENES)
def test_a_gearbox_file_packages_and_runs_as_its_scene(name, train_fmu_path, tmp_path):
    from fmpy.ssp.simulation import simulate_ssp

    scene = X.load_scene(name)
    gearbox = X.load_scene(str(ROOT / "scenes" / "train" / "gearbox" / f"{name}.toml"))
    assert gearbox["stop_time"] == scene["stop_time"] and gearbox["output_interval"] == scene["output_interval"]
    a = X.scene_to_ssp(scene, tmp_path / "scene.ssp", train_fmu_path)
    b = X.scene_to_ssp(gearbox, tmp_path / "gearbox.ssp", train_fmu_path)
    pa, pb = X.fmpy_parameter_set(a), X.fmpy_parameter_set(b)
    assert _effective_starts(train_fmu_path, pa) == _effective_starts(train_fmu_path, pb)
    h, t = float(scene["output_interval"]), float(scene["stop_time"])
    runs = [simulate_ssp(str(p), stop_time=t - 0.5 * h, step_size=h, parameter_set=s)
            for p, s in ((a, pa), (b, pb))]
    shared = [n for n in runs[0].dtype.names if n in runs[1].dtype.names and n != "time"]
    assert any(n.endswith(".dte") for n in shared), shared
    for n in shared:
        assert np.array_equal(runs[0][n], runs[1][n]), n


def test_a_refused_gearbox_file_says_why(tmp_path):
    bad = tmp_path / "bad.toml"
    text = (ROOT / "scenes" / "train" / "gearbox" / "two-stage.toml").read_text()
    bad.write_text(text.replace("J = 0.004", "J = 0.004\nmass = 2.0"))
    with pytest.raises(ValueError, match=r"body wheel1: unknown field `mass`.*\(line \d+\)"):
        X.load_scene(str(bad))


def test_train_layout_draws_a_gearbox_file(tmp_path):
    import train_layout

    out = tmp_path / "layout.png"
    train_layout.main(["layout", "--scene", str(ROOT / "scenes" / "train" / "gearbox" / "planetary-simple.toml"),
                       "-o", str(out)])
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("name", ["two-stage", "planetary-simple"])
def test_static_start_through_the_fmu(name, train_fmu_path):
    """SpurGearTrain's static_start through FMPy: the scene without its hand-written running
    start (every dte_start and twist_start left out) and static_start = true runs as the scene
    does, within the scene's own comparison bounds ([compare.tolerance], 0.1 % of each range):
    the static start finds the scene's start deflections to 1e-9 (train-fmu/tests/gearbox.rs)."""
    import fmpy

    scene = X.load_scene(name)
    sv = scene["start_values"]
    static = {k: v for k, v in sv.items() if not k.endswith((".dte_start", ".twist_start"))}
    static["static_start"] = True
    assert len(static) < len(sv) + 1, "the scene writes its running start out"
    tol = scene["compare"]["tolerance"]
    h, t = float(scene["output_interval"]), float(scene["stop_time"])
    runs = [fmpy.simulate_fmu(str(train_fmu_path), stop_time=t, output_interval=h, start_values=v,
                              output=list(tol)) for v in (sv, static)]
    for q, bound in tol.items():
        err = np.max(np.abs(runs[0][q] - runs[1][q]))
        assert err <= bound, f"{name} {q}: {err:.3g} > {bound}"


def _all_lateral_four_planets():
    """scenes/train/lateral-four-planet.toml with sun, ring and carrier lateral too (21
    coordinates, each on a 1e8 N/m bearing damped at 5 % of critical), at its speeds."""
    import math
    import tomllib

    sv = tomllib.loads((ROOT / "scenes/train/lateral-four-planet.toml").read_text())["start_values"]
    for i in (1, 2, 3):
        m, k = float(sv[f"body[{i}].m"]), 1e8
        c = 0.1 * math.sqrt(k * m)
        sv.update({f"body[{i}].lateral": True, f"body[{i}].k_x": k, f"body[{i}].k_y": k,
                   f"body[{i}].c_x": c, f"body[{i}].c_y": c})
    return sv


@pytest.mark.parametrize("name", ["lin-parker", "all-lateral-four-planet"])
def test_static_start_of_lateral_sets_as_the_reference(name, train_fmu_path):
    """The FMU's static start on two sets with every member lateral, against the independent
    reference's (lateral_ref.static_start): Lin & Parker's set at rest under 1 N.m (backlash 0,
    deflections of ~15 nm, where the loops' closing meshes are resolved to the rounding of the
    bodies' positions, 1e-9 of a deflection) and the 4-planet set at 1104 rad/s (centrifugal
    loads). The static start accepts a balance whose accelerations are below 1e-6 of the
    elastic terms once its steps stall at rounding (statics.rs NOISE_TOL), so the deflections
    and displacements agree within 1e-6 of the largest mesh deflection."""
    from test_lateral_ref import lin_parker

    sv = lin_parker() if name == "lin-parker" else _all_lateral_four_planets()
    _static_start_as_the_reference(_without_start(sv), train_fmu_path, name)


def _without_start(sv):
    """Start values without their written-out deflections, twists and lateral displacements."""
    return {k: v for k, v in sv.items() if not k.endswith(("dte_start", "twist_start", "x_start", "y_start"))}


def _static_start_as_the_reference(sv, fmu, label):
    """The FMU's static start from `sv` against lateral_ref.static_start's: every mesh dte and
    body x, y at t = 0 within 1e-6 of the largest mesh deflection."""
    import fmpy
    from reference_model import lateral_ref

    ref = lateral_ref.static_start(sv)
    n, nm = int(sv["n_bodies"]), int(sv["n_meshes"])
    out = [f"mesh[{m}].dte" for m in range(1, nm + 1)]
    out += [f"body[{i}].{c}" for i in range(1, n + 1) for c in "xy"]
    runs = [fmpy.simulate_fmu(str(fmu), stop_time=1e-5, output_interval=1e-5, output=out,
                              start_values=v) for v in ({**sv, "static_start": True}, ref)]
    scale = max(abs(runs[1][f"mesh[{m}].dte"][0]) for m in range(1, nm + 1))
    for q in out:
        err = abs(runs[0][q][0] - runs[1][q][0])
        assert err <= 1e-6 * scale, f"{label} {q}: {runs[0][q][0]:.12g} vs {runs[1][q][0]:.12g} (scale {scale:.3g})"


@pytest.mark.parametrize("e", [0.0, 1e-6, 2e-6, 5e-6, 10e-6, 20e-6, -5e-6])
def test_static_start_balances_a_floating_sun_whatever_its_pin_error(e, train_fmu_path):
    """The static start of scenes/train/lateral-floating-sun.toml (a sun with no bearing, held
    by its three meshes) with planet 1's tangential pin error e, against the independent
    reference's balance (lateral_ref.static_start). The error moves the sun's loop-closing
    meshes by as much as their deflections (~2 um): Newton from its guess found the sun on one
    mesh and refused 2 and 10 um as singular, found no balance at 20 um, and none at a negative
    e, whose balance has mesh[1]'s dte below 0, loaded through the sun's displacement alone
    (statics.rs: the balance followed from the set without pin errors, each mesh kept on its
    flank by its whole penetration). The bound is the previous test's: the static start
    accepts accelerations below 1e-10 of the elastic terms, or 1e-6 once its steps stall at
    rounding (statics.rs NOISE_TOL), so the deflections and the sun's displacement agree
    within 1e-6 of the largest mesh deflection."""
    sv = {**_without_start(X.load_scene("lateral-floating-sun")["start_values"]), "body[3].pin_error_t": e}
    _static_start_as_the_reference(sv, train_fmu_path, f"e = {e:g}")
