"""Every scene (scenes/<name>.toml) through the packaged FMU with the real `fmpy simulate` CLI,
compared with the independent reference trace tests/reference/<name>.csv (issue 3, point 3).

    .venv/bin/python -m pytest -q tests/python/test_scenes.py
    .venv/bin/python tools/scene_table.py        # the same comparison as a Markdown table

How each mode is compared, and why, is in tests/python/scene_compare.py.  The bounds are the
scene files' own: max-abs errors in physical units ([compare.tolerance], each with its reason in a
comment; policy and the reference's self-agreement in tests/reference_model/accuracy.md), the
statistics bounds ([compare.statistics]) and, with events = true, one output interval for the
switching times of (n_fwd, n_bwd).  None is read off the FMU's output.

A failure lists every check that is out of bounds: the variable, its max error, where (time,
FMU and reference values) and the bound, followed by the fmpy command to reproduce it.
"""

import shlex

import pytest

import scene_compare as S

SCENES = S.scene_names()


def test_every_scene_has_a_reference():
    missing = [n for n in SCENES if not (S.REF_DIR / f"{n}.csv").is_file()]
    assert not missing, f"scenes without a reference trace (run tests/reference_model/regenerate.py): {missing}"


@pytest.mark.parametrize("name", SCENES)
def test_scene_matches_reference(name, fmu_path, tmp_path):
    res = S.compare_scene(fmu_path, name, tmp_path)
    assert res.checks, f"scene {name} compares nothing"
    if not res.ok:
        lines = [f"scene {name} ({res.mode}): {len(res.failures())} of {len(res.checks)} checks "
                 "out of bounds"]
        lines += ["  " + c.message() for c in res.failures()]
        lines += ["all checks:", res.report(), "reproduce: " + shlex.join(res.command)]
        pytest.fail("\n".join(lines), pytrace=False)


# DOP853 (solver = 3) on the explicit methods' scenes: every one at its own rel_tol and bounds.
# `stiff` is left out: it is the implicit solver's scene (solver = 2), on which an explicit
# method takes ~2e5 steps (docs/performance.md).
EXPLICIT_SCENES = [n for n in SCENES
                   if S.G.load_scene(n).get("start_values", {}).get("solver", 1) == 1]


@pytest.mark.parametrize("name", EXPLICIT_SCENES)
def test_scene_matches_reference_with_dop853(name, fmu_path, tmp_path):
    res = S.compare_scene(fmu_path, name, tmp_path, integrator=3)
    assert res.checks, f"scene {name} compares nothing"
    if not res.ok:
        lines = [f"scene {name} ({res.mode}) with solver = 3: {len(res.failures())} of "
                 f"{len(res.checks)} checks out of bounds"]
        lines += ["  " + c.message() for c in res.failures()]
        lines += ["reproduce: " + shlex.join(res.command)]
        pytest.fail("\n".join(lines), pytrace=False)


# ---- the comparison itself, on the reference's own grid rows (no FMU) ------------------------

def grid_as_fmu_output(name):
    """The reference's grid rows, as FMPy would write them for a perfect FMU."""
    scene = S.G.load_scene(name)
    names, table = S.read_csv(S.REF_DIR / f"{name}.csv")
    return scene, names, S.G.grid_rows(names, table, scene["output_interval"]), table


def test_comparison_of_the_reference_with_itself_is_exact():
    for name in SCENES:
        scene, names, grid, table = grid_as_fmu_output(name)
        checks = (S.compare_traces(scene, names, grid, names, table) if scene["mode"] == "trace"
                  else S.compare_statistics(scene, names, grid, names, table))
        if scene["compare"].get("events"):
            checks += S.compare_events(scene, names, grid, names, table)
        assert all(c.error == 0.0 for c in checks), [c.message() for c in checks if c.error]


def test_comparison_sees_an_offset_and_a_late_switch():
    scene, names, grid, table = grid_as_fmu_output("damped")
    dt = scene["output_interval"]
    bound = scene["compare"]["tolerance"]["dte"]
    bad = grid.copy()
    k = 400
    bad[k, names.index("dte")] += 1.5 * bound
    (dte,) = [c for c in S.compare_traces(scene, names, bad, names, table) if c.name == "dte"]
    assert not dte.ok and dte.fraction == pytest.approx(1.5) and f"t = {k * dt:.6g} s" in dte.where
    # delay every switch of n_fwd by 3 output intervals: more than 2 dt off, so it must fail
    late = grid.copy()
    col = names.index("n_fwd")
    late[3:, col] = grid[:-3, col]
    (ev,) = S.compare_events(scene, names, late, names, table)
    assert not ev.ok and 2 * dt < ev.error <= 3 * dt, ev.message()
    # by one interval: the switching times agree to the output interval, it must pass
    late1 = grid.copy()
    late1[1:, col] = grid[:-1, col]
    (ev1,) = S.compare_events(scene, names, late1, names, table)
    assert ev1.ok and ev1.error > 0, ev1.message()
