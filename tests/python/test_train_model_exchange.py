"""SpurGearTrain in Model Exchange through FMPy (issue 23, point 1): the same FMUs instantiated as
fmi2ModelExchange / FMI 3.0 Model Exchange, the master (FMPy's CVode, with root finding on the
192 event indicators) integrating the 30 declared states.

- Every train scene, through the FMI 2.0 and the FMI 3.0 FMU, passes its own checks against its
  independent reference (train_scene_compare, the same bounds as Co-Simulation): in Model
  Exchange CVode sets the accuracy, at the scene's own rel_tol where it states one, else at the
  DefaultExperiment's tolerance, which is the FMU's default rel_tol too.
- FMPy's explicit Euler runs the two-stage reducer clean (no error, finite outputs) and its
  error against the Co-Simulation run falls at first order with the step.
"""

import fmpy
import numpy as np
import pytest

import train_scene_compare as TS

SCENES = TS.scene_names()


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
@pytest.mark.parametrize("name", SCENES)
def test_cvode_passes_the_scene_checks(name, version, train_fmu_path, train_fmu3_path, tmp_path):
    fmu = train_fmu_path if version == "fmi2" else train_fmu3_path
    rel_tol = TS.load_scene(name).get("start_values", {}).get("rel_tol")
    res = TS.compare_scene(fmu, name, tmp_path, rel_tol=rel_tol, solver="CVode")
    assert res.checks, f"train scene {name} compares nothing"
    if not res.ok:
        pytest.fail(TS.failure_message(res, f" (Model Exchange, {version}, CVode)"), pytrace=False)


OUT = ["mesh[1].dte", "mesh[2].dte"]
STOP, GRID = 2e-3, 1e-4


def two_stage(fmu, step=None):
    """The two-stage scene to STOP on the GRID: Co-Simulation (step None) or Model Exchange with
    FMPy's Euler, which steps at the output interval (so it records every step; the grid rows
    are picked out)."""
    sv = TS.load_scene("two-stage")["start_values"]
    kw = dict(stop_time=STOP, start_values=sv, output=OUT)
    if step is None:
        return fmpy.simulate_fmu(str(fmu), relative_tolerance=1e-10, output_interval=GRID, **kw)
    r = fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", solver="Euler", step_size=step,
                          output_interval=step, record_events=False, **kw)
    k = np.round(r["time"] / GRID)
    return r[np.abs(r["time"] / GRID - k) < 1e-6]


def test_euler_runs_clean_and_converges_at_first_order(train_fmu_path):
    """Explicit Euler is stable where h is below 2 zeta / omega of the fastest vibration (the
    meshes: omega ~ 2e4 rad/s, zeta ~ 0.1: about 1e-5 s); there the error against the
    Co-Simulation run at rel_tol 1e-10 (itself ~1e-9 of the dte range) must halve with the
    step, up to the O(h^2) terms: a ratio between 1.6 and 2.5 where first order gives 2."""
    cs = two_stage(train_fmu_path)
    errs = []
    for h in (5e-7, 2.5e-7):
        me = two_stage(train_fmu_path, h)
        assert np.allclose(me["time"], cs["time"], rtol=0, atol=1e-12)
        err = 0.0
        for name in OUT:
            assert np.all(np.isfinite(me[name])), (h, name)
            err = max(err, np.max(np.abs(me[name] - cs[name])) / np.ptp(cs[name]))
        errs.append(err)
    ratio = errs[0] / errs[1]
    assert 1.6 < ratio < 2.5, f"errors {errs}: ratio {ratio:.3g}"
