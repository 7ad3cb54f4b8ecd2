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
