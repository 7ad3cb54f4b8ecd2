"""The gear-train FMU (SpurGearTrain.fmu, /work/shared/spec/gear-train.md) against its independent
reference, through FMPy as a user runs it:

* every train scene (scenes/train/*.toml) with the real `fmpy simulate` CLI vs its reference trace
  tests/reference/train/<name>.csv (tests/python/train_scene_compare.py says how each mode is
  compared; the bounds are the scene files' own, none is read off the FMU's output);
* `fmpy validate` on the FMU is clean;
* spec section 7, first check, FMU against FMU: the one-mesh train `single` is the single-mesh
  FMU's `damped` scene (SpurGearMesh.fmu with scenes/damped.toml's start values), every variable
  damped compares within damped's own bound;
* bad input (spec section 1, topology; rigid contact) gives fmi2Error at initialization with a
  logged message naming the elements; a count above capacity is refused by fmi2SetInteger.

    .venv/bin/python -m pytest -q tests/python/test_train_scenes.py
    .venv/bin/python tests/python/train_scene_compare.py      # the scene comparison as a table

A scene failure lists every check that is out of bounds: the variable, its max error, where (time,
FMU and reference values) and the bound, then all checks and the fmpy command to reproduce it.
"""

import shlex
import subprocess

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

import scene_compare as S
import train_scene_compare as TS

SCENES = TS.scene_names()
FMI2_ERROR = 3


def test_every_train_scene_has_a_reference():
    assert SCENES, f"no train scenes in {TS.TRAIN_SCENES_DIR}"
    missing = [n for n in SCENES if not (TS.TRAIN_REF_DIR / f"{n}.csv").is_file()]
    assert not missing, ("train scenes without a reference trace "
                         f"(run tests/reference_model/regenerate_train.py): {missing}")


@pytest.mark.parametrize("name", SCENES)
def test_train_scene_matches_reference(name, train_fmu_path, tmp_path):
    res = TS.compare_scene(train_fmu_path, name, tmp_path)
    assert res.checks, f"train scene {name} compares nothing"
    if not res.ok:
        pytest.fail(TS.failure_message(res), pytrace=False)


def test_fmpy_validate_is_clean(train_fmu_path):
    cmd = [S.fmpy_executable(), "validate", str(train_fmu_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0 and "No problems found" in proc.stdout, (
        f"`{shlex.join(cmd)}` exit {proc.returncode}:\n{proc.stdout[-4000:]}\n{proc.stderr[-2000:]}")


# ---- the one-mesh train is the single-mesh FMU ----------------------------------------------

# damped's compared variables and their names in the train (body 1 = wheel A, body 2 = wheel B)
SINGLE_AS_TRAIN = {"dte": "mesh[1].dte", "w_A": "body[1].w", "w_B": "body[2].w",
                   "F_fwd": "mesh[1].F_fwd", "F_f1": "mesh[1].F_f1", "F_f2": "mesh[1].F_f2",
                   "P_loss": "mesh[1].P_loss"}


def test_one_mesh_train_is_the_single_mesh_fmu(train_fmu_path, fmu_path, tmp_path):
    damped = S.G.load_scene("damped")
    single = TS.load_scene("single")
    assert (single["stop_time"], single["output_interval"]) == \
        (damped["stop_time"], damped["output_interval"])
    assert set(damped["compare"]["variables"]) == set(SINGLE_AS_TRAIN)
    bounds = damped["compare"]["tolerance"]
    sn, st, _, scmd = S.run_fmpy(fmu_path, damped, tmp_path)
    tn, tt, _, tcmd = TS.run_fmpy(train_fmu_path, single, tmp_path)
    assert len(st) == len(tt) and np.array_equal(st[:, sn.index("time")], tt[:, tn.index("time")])
    t = st[:, sn.index("time")]
    lines, n_bad = [], 0
    for var, tvar in SINGLE_AS_TRAIN.items():
        a, b = st[:, sn.index(var)], tt[:, tn.index(tvar)]
        err = np.abs(a - b)
        k = int(np.argmax(np.where(np.isnan(err), np.inf, err)))
        e, bound = float(err[k]), float(bounds[var])
        ok = e <= bound  # NaN fails
        n_bad += not ok
        u = TS.unit(tvar)
        lines.append(f"  {'ok  ' if ok else 'FAIL'} {tvar} (train) vs {var} (single mesh): max |difference| "
                     f"= {e:.3g} {u} at t = {t[k]:.6g} s (train {b[k]:.9g}, single mesh {a[k]:.9g}); "
                     f"bound {bound:.3g} {u}, damped's ({e / bound:.3g} of it)")
    if n_bad:
        pytest.fail("\n".join(
            [f"train scene `single` vs the single-mesh FMU's scene `damped`: {n_bad} of "
             f"{len(lines)} out of damped's bounds"] + lines
            + ["reproduce: " + shlex.join(scmd), "           " + shlex.join(tcmd)]), pytrace=False)


# ---- bad input --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def train_unzip_dir(train_fmu_path, tmp_path_factory):
    return fmpy.extract(str(train_fmu_path), unzipdir=str(tmp_path_factory.mktemp("SpurGearTrain")))


@pytest.fixture(scope="module")
def train_md(train_unzip_dir):
    return fmpy.read_model_description(train_unzip_dir)


def simulate(unzip_dir, md, start_values):
    """fmpy.simulate_fmu (Co-Simulation, 1 ms) with a logger that records every message the FMU
    logs, and the FMI calls; returns (exception or None, [(status, category, message)], calls)."""
    messages, calls = [], []

    def log(env, instance, status, category, message):
        messages.append((status, (category or b"").decode("utf-8", "replace"),
                         (message or b"").decode("utf-8", "replace")))

    # The logger goes into the callbacks directly: instantiate_fmu(logger=...) routes it through
    # FMPy's native logger proxy, a process-wide global that outlives this function's logger
    # and that later instances with FMPy's default callbacks call too.
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(log)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip_dir,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="train",
                    fmiCallLogger=calls.append)
    fmu.instantiate(callbacks=callbacks)
    try:
        fmpy.simulate_fmu(unzip_dir, model_description=md, fmu_instance=fmu,
                          start_values=start_values, stop_time=1e-3, output_interval=1e-3)
        return None, messages, calls
    except FMICallException as e:
        return e, messages, calls
    finally:
        fmu.freeInstance()


def test_the_default_train_initializes(train_unzip_dir, train_md):
    """The control for the bad-input cases: the defaults (two-stage reducer) run without error."""
    exc, messages, _ = simulate(train_unzip_dir, train_md, {})
    assert exc is None and not [m for m in messages if m[0] >= FMI2_ERROR], (exc, messages)


# name -> (start values, element names the error message must contain).  The defaults: 4 bodies,
# mesh 1 = 1-2, shaft 1 = 2-3, mesh 2 = 3-4; meshes 3.. join 5-6, 7-8, ...
BAD_INPUT = {
    # a fourth edge on four bodies: mesh 3 from body 4 back to body 1 closes the loop
    # mesh[1] - shaft[1] - mesh[2] - mesh[3], whose housing-fixed axes (all at centre angle 0)
    # cannot meet; every element of the loop must be named
    "cycle": ({"n_bodies": 4, "n_shafts": 1, "n_meshes": 3, "mesh[3].A": 4, "mesh[3].B": 1},
              ["mesh[3]", "mesh[1]", "mesh[2]", "shaft[1]"]),
    "disconnected-body": ({"n_bodies": 5}, ["body[5]"]),
    # 7 lies within the variable's range 1..8 (fmi2SetInteger accepts it), beyond n_bodies = 4
    "index-out-of-range": ({"mesh[2].B": 7}, ["mesh[2].B"]),
    "mesh-A-equals-B": ({"mesh[2].A": 3, "mesh[2].B": 3}, ["mesh[2]"]),
    "rigid-contact": ({"mesh[1].contact_model": 2}, ["mesh[1].contact_model"]),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_is_an_error_at_initialization(case, train_unzip_dir, train_md):
    start_values, names = BAD_INPUT[case]
    md_vars = {v.name: v for v in train_md.modelVariables}
    for name, value in start_values.items():  # every value passes the variable's own range
        v = md_vars[name]
        assert (v.min is None or float(v.min) <= value) and (v.max is None or value <= float(v.max)), \
            f"{name} = {value} outside [{v.min}, {v.max}]: the test would not reach initialization"
    exc, messages, calls = simulate(train_unzip_dir, train_md, start_values)
    assert exc is not None, f"{case}: {start_values} initialized without error; log: {messages}"
    assert exc.function in ("fmi2EnterInitializationMode", "fmi2ExitInitializationMode") \
        and exc.status == FMI2_ERROR, \
        f"{case}: {exc.function} returned {exc.status}, expected fmi2Error (3) at initialization"
    errors = [m for s, c, m in messages if s == FMI2_ERROR]
    assert errors, f"{case}: fmi2Error without a logged message (log: {messages})"
    missing = [n for n in names if not any(n in m for m in errors)]
    assert not missing, f"{case}: the error message does not name {missing}: {errors}"


def test_count_above_capacity_is_refused_by_set_integer(train_unzip_dir, train_md):
    v = {v.name: v for v in train_md.modelVariables}["n_meshes"]
    assert int(v.max) == 16, f"n_meshes max = {v.max}; the spec's capacity is 16 meshes (planetary.md section 5)"
    exc, messages, calls = simulate(train_unzip_dir, train_md, {"n_meshes": 17})
    assert exc is not None and exc.function == "fmi2SetInteger" and exc.status == FMI2_ERROR, \
        f"n_meshes = 17: {exc and (exc.function, exc.status)}; calls: {calls[-3:]}"
    errors = [m for s, c, m in messages if s == FMI2_ERROR]
    assert any("n_meshes" in m for m in errors), f"no error naming n_meshes: {messages}"
    assert not any("InitializationMode" in c for c in calls), "initialization was entered"


# ---- the comparison itself, on the reference's own grid rows (no FMU) ------------------------

def grid_as_fmu_output(name):
    """The reference's grid rows, as FMPy would write them for a perfect FMU."""
    scene = TS.load_scene(name)
    names, table = S.read_csv(TS.TRAIN_REF_DIR / f"{name}.csv")
    return scene, names, S.G.grid_rows(names, table, scene["output_interval"]), table


def test_train_comparison_of_the_reference_with_itself_is_exact():
    for name in SCENES:
        scene, names, grid, table = grid_as_fmu_output(name)
        checks = (TS.compare_traces(scene, names, grid, names, table) if scene["mode"] == "trace"
                  else TS.compare_statistics(scene, names, grid, names, table))
        if scene["compare"].get("events"):
            ev = TS.compare_events(scene, names, grid, names, table)
            assert [c.name for c in ev] == [f"mesh[{m}].switching_time"
                                            for m in range(1, TS.counts(scene)[2] + 1)]
            checks += ev
        assert all(c.error == 0.0 for c in checks), [c.message() for c in checks if c.error]


def test_train_comparison_sees_an_offset_and_a_late_switch_of_one_mesh():
    scene, names, grid, table = grid_as_fmu_output("two-stage")
    dt = scene["output_interval"]
    bound = scene["compare"]["tolerance"]["mesh[2].dte"]
    bad = grid.copy()
    k = 200
    bad[k, names.index("mesh[2].dte")] += 1.5 * bound
    by = {c.name: c for c in TS.compare_traces(scene, names, bad, names, table)}
    assert not by["mesh[2].dte"].ok and by["mesh[2].dte"].fraction == pytest.approx(1.5)
    assert f"t = {k * dt:.6g} s" in by["mesh[2].dte"].where and by["mesh[1].dte"].error == 0.0
    # mesh 2's forward count late by 3 output intervals: its check fails, mesh 1's is untouched
    late = grid.copy()
    col = names.index("mesh[2].n_fwd")
    late[3:, col] = grid[:-3, col]
    ev = {c.name: c for c in TS.compare_events(scene, names, late, names, table)}
    assert not ev["mesh[2].switching_time"].ok and \
        2 * dt < ev["mesh[2].switching_time"].error <= 3 * dt, ev["mesh[2].switching_time"].message()
    assert ev["mesh[1].switching_time"].error == 0.0
    # late by one interval: agrees to the output interval, passes
    late1 = grid.copy()
    late1[1:, col] = grid[:-1, col]
    (ev1,) = [c for c in TS.compare_events(scene, names, late1, names, table)
              if c.name == "mesh[2].switching_time"]
    assert ev1.ok and ev1.error > 0, ev1.message()
