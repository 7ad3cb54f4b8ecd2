"""tools/scene_to_ssp.py: a train scene as an SSP 1.0 package (the SpurGearTrain FMU, an .ssv
with every start value, an .ssd with one component) that FMPy, libcosim and OMSimulator load as
they are (docs/omsimulator.md).

1. The package is SSP 1.0: FMPy's reader validates its .ssd and .ssv against the standard's
   schemas; its names are identifiers where OMSimulator needs them; the .ssv holds every start
   value of the scene, typed as the FMU declares it, and nothing else.
2. FMPy's simulate_ssp of the package, with the package's own parameter set
   (scene_to_ssp.fmpy_parameter_set), is the FMU run with the scene's start values at the same
   communication steps: equal to rounding to fmpy.simulate_fmu with the scene's start values and
   set_stop_time=False.  simulate_ssp tells the FMU no stop time; the CLI `fmpy simulate` does
   (fmi2SetupExperiment's stopTime), which the FMU's integrator uses, so the CLI's run differs
   at the integration tolerance: it is held to the scene's own comparison bounds
   ([compare.tolerance], 0.1 % of each variable's range), the bounds its test holds the FMU to
   against the reference model.  Rounding: simulate_ssp sums its time (t += h), the others take
   t_k = k h; a communication point a few ulps away moves the adaptive integrator's steps, which
   shows at 1e-12 of a variable's size here (bound 1e-9).
3. libcosim loads the package (the .ssv through the component's ParameterBinding) and runs it:
   the same values to rounding.
4. OMSimulator, when installed (OMSIMULATOR_HOME or OMSimulator on PATH; CI does not build it,
   so there it skips), runs the package from its command line: the same values to rounding (its
   CSV has 12 digits).  It passes the FMU's DefaultExperiment tolerance (the annotation's
   relativeTolerance) and no stop time to fmi2SetupExperiment.
"""

import re
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "cosim"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import oms_run as OMS  # noqa: E402
import scene_to_ssp as X  # noqa: E402
import train_scene_compare as C  # noqa: E402

SCENES = ["two-stage", "internal"]  # internal: a Boolean parameter and an internal mesh
ROUNDING = 1e-9  # relative to each variable's largest magnitude over the run


@pytest.fixture(scope="module", params=SCENES)
def case(request, train_fmu_path, tmp_path_factory):
    scene = C.load_scene(request.param)
    ssp = X.scene_to_ssp(scene, tmp_path_factory.mktemp("ssp") / f"{scene['name']}.ssp", train_fmu_path)
    return scene, ssp, train_fmu_path


def _reference(fmu, scene, set_stop_time):
    """fmpy.simulate_fmu with the scene's start values: {name: array} on t_k = k h, k >= 1."""
    import fmpy

    h, t = float(scene["output_interval"]), float(scene["stop_time"])
    names = [n for n in C.outputs(scene)]
    res = fmpy.simulate_fmu(str(fmu), start_values=dict(scene["start_values"]), stop_time=t,
                            output_interval=h, output=names, set_stop_time=set_stop_time)
    n = int(round(t / h))
    assert len(res) == n + 1 and np.allclose(res["time"], h * np.arange(n + 1), rtol=0, atol=1e-12)
    return {q: np.asarray(res[q], dtype=float)[1:] for q in names}


ENERGIES = ["E_kin", "E_el", "E_gate", "W_ext", "W_loss"]


def _scale(q, ref):
    """A variable's size: its largest magnitude; for energy_residual (a small difference of the
    energies) the largest energy's, whose rounding it carries."""
    names = [e for e in ENERGIES if e in ref] if q == "energy_residual" else [q]
    return max(float(np.max(np.abs(ref[n]))) for n in names)


def _assert_same(run, ref, what, bound=None):
    """max |run - ref| <= ROUNDING * its size (_scale), or the absolute `bound[q]` where given."""
    bad = []
    for q, r in ref.items():
        if q not in run:
            continue
        d = float(np.max(np.abs(np.asarray(run[q], dtype=float) - r)))
        lim = bound[q] if bound is not None else ROUNDING * max(_scale(q, ref), 1e-300)
        if not d <= lim:
            bad.append(f"{q}: {d:.3g} > {lim:.3g}")
    missing = sorted(set(ref) - set(run))
    assert not missing, f"{what}: the run lacks {missing}"
    assert not bad, f"{what} differs: " + "; ".join(bad)


def test_the_package_is_ssp_1_0_with_every_start_value(case):
    from fmpy.ssp.ssd import read_ssd

    scene, ssp, fmu = case
    with zipfile.ZipFile(ssp) as z:
        assert sorted(z.namelist()) == sorted(["SystemStructure.ssd", f"resources/{scene['name']}.ssv",
                                               "resources/SpurGearTrain.fmu"])
        assert z.read("resources/SpurGearTrain.fmu") == Path(fmu).read_bytes()
    ssd = read_ssd(str(ssp))  # validates the .ssd and the .ssv it binds against SSP 1.0's schemas
    ident = re.compile(r"^[a-zA-Z][a-zA-Z0-9_]*$")  # OMSimulator's ComRef::isValidIdent
    assert ident.match(ssd.name) and ident.match(ssd.system.name), (ssd.name, ssd.system.name)
    (comp,) = ssd.system.elements
    assert comp.name == X.COMPONENT and comp.source == "resources/SpurGearTrain.fmu"
    assert all(c.kind == "output" for c in comp.connectors), "an unconnected input would be set to 0 by simulate_ssp"
    (binding,) = comp.parameterBindings
    (values,) = binding.parameterValues
    got = {p.name: (p.type, p.value) for p in values.parameters}
    import fmpy

    types = {v.name: v.type for v in fmpy.read_model_description(str(fmu)).modelVariables}
    sv = scene["start_values"]
    assert set(got) == set(sv)
    for name, value in sv.items():
        typ, text = got[name]
        assert typ == types[name], name
        back = {"Real": float, "Integer": int, "Boolean": lambda s: s == "true"}[typ](text)
        assert back == value, f"{name}: {text} in the .ssv, {value!r} in the scene"


def test_fmpy_simulate_ssp_is_the_scene(case):
    from fmpy.ssp.simulation import simulate_ssp

    scene, ssp, fmu = case
    h, t = float(scene["output_interval"]), float(scene["stop_time"])
    rows = simulate_ssp(str(ssp), stop_time=t - 0.5 * h, step_size=h, parameter_set=X.fmpy_parameter_set(ssp))
    assert len(rows) == int(round(t / h))
    # a row holds the step's start time and the values at its end
    run = {n[len(X.COMPONENT) + 1:]: rows[n] for n in rows.dtype.names if n.startswith(X.COMPONENT + ".")}
    _assert_same(run, _reference(fmu, scene, set_stop_time=False), "simulate_ssp against simulate_fmu")
    # the CLI `fmpy simulate` (with the stop time): within the scene's own bounds
    with tempfile.TemporaryDirectory() as work:
        names, table, _, _ = C.run_fmpy(fmu, scene, work)
    cli = {q: table[1:, i] for i, q in enumerate(names) if q in scene["compare"]["tolerance"]}
    _assert_same(run, cli, "simulate_ssp against `fmpy simulate`", bound=scene["compare"]["tolerance"])


def test_libcosim_loads_and_runs_the_package(case):
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    scene, ssp, fmu = case
    h, t = float(scene["output_interval"]), float(scene["stop_time"])
    ns = int(round(h * 1e9))
    n = int(round(t / h))
    ex = CosimExecution.from_ssp_file(str(ssp), step_size=ns)
    (info,) = ex.slave_infos()
    assert info.name.decode() == X.COMPONENT
    variables = {v.name.decode(): v for v in ex.slave_variables(info.index)}
    obs = CosimObserver.create_time_series(buffer_size=n + 16)
    ex.add_observer(obs)
    names = [q for q in C.outputs(scene) if variables[q].type == CosimVariableType.REAL.value]
    for q in names:
        obs.start_time_series(info.index, variables[q].reference, CosimVariableType.REAL)
    assert ex.simulate_until(n * ns)
    run = {}
    for q in names:
        times, steps, values = obs.time_series_real_samples(info.index, variables[q].reference,
                                                             from_step=1, sample_count=n)
        assert list(steps) == list(range(1, n + 1)), q
        run[q] = np.array(values)
    ref = _reference(fmu, scene, set_stop_time=False)
    _assert_same(run, {q: ref[q] for q in names}, "libcosim against simulate_fmu")


@pytest.mark.skipif(OMS.find() is None, reason=OMS.MISSING)
def test_omsimulator_runs_the_package(case, tmp_path):
    oms = OMS.find()
    scene, ssp, fmu = case
    h, t = float(scene["output_interval"]), float(scene["stop_time"])
    # the command a user types: OMSimulator --stopTime=T --resultFile=F x.ssp
    res = OMS.run_cli(oms, ssp, t, tmp_path)
    name = X.ident(scene["name"])
    run = {q: v[1:] for q, v in res.component(f"{name}.{name}.{X.COMPONENT}.").items()}
    n = int(round(t / h))
    assert np.allclose(res.columns["time"], h * np.arange(n + 1), rtol=0, atol=1e-9 * h)
    assert res.warnings == 0, res.log[-2000:]
    # OMSimulator's fmi2SetupExperiment sets no stop time (and the FMU's default tolerance)
    _assert_same(run, _reference(fmu, scene, set_stop_time=False), "OMSimulator against simulate_fmu")
