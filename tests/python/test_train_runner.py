"""The in-process train runner (train-fmu/examples/run_train_scene.rs, which tools/work_precision.py
times for docs/performance.md, section "Gear trains") against the independent reference: every
train scene at the FMU's defaults (solver 1, rel_tol 1e-6) within the same bounds as the packaged
FMU through fmpy (tests/python/train_scene_compare.py: each scene's [compare.tolerance] or
[compare.statistics], and the per-mesh switching times), and with the reference's columns.
So the work-precision numbers time the same trajectory that the FMU tests check.

    .venv/bin/python -m pytest -q tests/python/test_train_runner.py

Builds the example first (`cargo build --release -p spur_gear_train --example run_train_scene`,
a no-op when it is up to date); the four runs take well under a second.
"""

import json
import subprocess

import pytest

import scene_compare as S
import train_scene_compare as TS

ROOT = TS.ROOT
RUNNER = ROOT / "target" / "release" / "examples" / "run_train_scene"
SCENES = TS.scene_names()


@pytest.fixture(scope="module")
def runner():
    subprocess.run(["cargo", "build", "-q", "--release", "-p", "spur_gear_train", "--example",
                    "run_train_scene"], cwd=ROOT, check=True)
    assert RUNNER.is_file()
    return RUNNER


def start_args(scene):
    out = []
    for k, v in scene.get("start_values", {}).items():
        if isinstance(v, bool):
            v = "true" if v else "false"
        elif isinstance(v, float):
            v = repr(v)
        out += ["--set", f"{k}={v}"]
    return out


def run(runner, scene, trace, outputs=None):
    cmd = [str(runner), "--stop-time", repr(float(scene["stop_time"])),
           "--output-interval", repr(float(scene["output_interval"])), "--reps", "1",
           "--trace", str(trace)] + start_args(scene)
    if outputs:
        cmd += ["--outputs", ",".join(outputs)]
    if "input_file" in scene:
        cmd += ["--input-file", str(TS.TRAIN_SCENES_DIR / scene["input_file"])]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.parametrize("name", SCENES)
def test_runner_matches_the_reference_at_the_defaults(runner, name, tmp_path):
    scene = TS.load_scene(name)
    # The reference's columns: the runner's defaults, and what a scene's reference carries
    # beyond them (a lumped mesh's k_mesh, the bearing forces), named.
    rnames, rtab = S.read_csv(TS.TRAIN_REF_DIR / f"{name}.csv")
    r = run(runner, scene, tmp_path / f"{name}.csv", [n for n in rnames if n != "time"])
    assert r["error"] is None, r["error"]
    # The FMU's defaults, or the scene's own rel_tol where it states one.
    rel_tol = float(scene.get("start_values", {}).get("rel_tol", 1e-6))
    assert r["method"] == "solver1" and r["rel_tol"] == rel_tol
    assert r["t_reached"] == pytest.approx(scene["stop_time"])
    fnames, ftab = S.read_csv(tmp_path / f"{name}.csv")
    if scene.get("mode", "trace") == "trace":
        assert fnames == rnames
        checks = TS.compare_traces(scene, fnames, ftab, rnames, rtab)
    else:
        checks = TS.compare_statistics(scene, fnames, ftab, rnames, rtab)
    if scene.get("compare", {}).get("events", False):
        checks += TS.compare_events(scene, fnames, ftab, rnames, rtab)
    assert checks
    bad = [c.message() for c in checks if not c.ok]
    assert not bad, f"train scene {name} through run_train_scene:\n" + "\n".join(bad)
