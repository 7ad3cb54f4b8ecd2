"""The FMI 3.0 FMU, target/fmu/SpurGearMesh-fmi3.fmu (issue 10, point 4): the same binary and
variable table as the FMI 2.0 FMU, with an FMI 3.0 modelDescription.

- `fmpy validate` finds no problem, and the variables are the FMI 2.0 FMU's (names, value
  references, causality, variability), plus what FMI 3.0 declares as variables: `time` and the
  event indicators.
- Every scene runs unchanged through FMPy's FMI 3.0 Co-Simulation and passes its comparison with
  the reference (scene_compare, the same bounds as test_scenes.py).
- Model Exchange through FMI 3.0: tests/python/test_model_exchange.py runs its CVode scenes on
  both FMUs.
- The FMI 3.0 functions answer bad calls with fmi3Error and a message naming the fmi3 function
  and its arguments by their FMI 3.0 names.
"""

import ctypes
import shlex

import fmpy
import numpy as np
import pytest
from fmpy.fmi3 import FMU3Model, FMU3Slave, fmi3Float64, fmi3ValueReference
from fmpy.validation import validate_fmu

import scene_compare as S


@pytest.fixture(scope="module")
def md3(fmu3_path):
    return fmpy.read_model_description(str(fmu3_path))


@pytest.fixture(scope="module")
def unzip3(fmu3_path, tmp_path_factory):
    """Extracted once: overwriting a loaded binary would crash the process."""
    return fmpy.extract(str(fmu3_path), unzipdir=str(tmp_path_factory.mktemp("fmu3")))


def test_fmpy_validate_is_clean(fmu3_path):
    assert validate_fmu(str(fmu3_path)) == []


def test_the_variables_are_the_fmi2_ones(md3, model_description):
    v2 = {v.name: v for v in model_description.modelVariables}
    v3 = {v.name: v for v in md3.modelVariables}
    extra = set(v3) - set(v2)
    assert set(v2) <= set(v3)
    indicators = [u.variable.name for u in md3.eventIndicators]
    assert extra == {"time"} | set(indicators)
    assert len(indicators) == model_description.numberOfEventIndicators == 32
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
    for name, a in v2.items():
        b = v3[name]
        assert (b.valueReference, b.causality, b.variability, b.type) == (
            a.valueReference, a.causality, a.variability, types[a.type]), name
        assert b.start == a.start, name
    # The same continuous states in the same order.
    assert [u.variable.name for u in md3.derivatives] == [
        u.variable.name for u in model_description.derivatives]
    assert v3["time"].causality == "independent" and v3["time"].valueReference == 0


@pytest.mark.parametrize("name", S.scene_names())
def test_scene_through_fmi3(name, fmu3_path, tmp_path):
    res = S.compare_scene(fmu3_path, name, tmp_path)
    assert res.checks, f"scene {name} compares nothing"
    if not res.ok:
        lines = [f"scene {name} through FMI 3.0: {len(res.failures())} checks out of bounds"]
        lines += ["  " + c.message() for c in res.failures()]
        lines += ["reproduce: " + shlex.join(res.command)]
        pytest.fail("\n".join(lines), pytrace=False)


class Logged:
    """An FMI 3.0 instance whose log messages are recorded as (status, category, message)."""

    def __init__(self, unzip, md3, cls=FMU3Slave):
        self.messages = []
        self.fmu = cls(guid=md3.guid, unzipDirectory=unzip,
                       modelIdentifier=md3.coSimulation.modelIdentifier, instanceName="f3")

        def log(env, status, category, message):
            self.messages.append((status, category.decode(), message.decode()))

        self.fmu.instantiate(loggingOn=True, logMessage=log)
        self.vr = {v.name: v.valueReference for v in md3.modelVariables}

    def errors(self, prefix):
        return [m for s, c, m in self.messages if s == 3 and m.startswith(prefix)]


def test_time_and_event_indicators_read_as_variables(unzip3, md3):
    f = Logged(unzip3, md3, cls=FMU3Model)
    sv = S.G.load_scene("damped")["start_values"]
    f.fmu.enterInitializationMode(startTime=0.0)
    for k, x in sv.items():
        f.fmu.setFloat64([f.vr[k]], [x])
    f.fmu.exitInitializationMode()
    f.fmu.updateDiscreteStates()
    f.fmu.enterContinuousTimeMode()
    f.fmu.setTime(2e-6)
    z = (fmi3Float64 * 32)()
    f.fmu.getEventIndicators(z, 32)
    vrs = [u.variable.valueReference for u in md3.eventIndicators]
    assert f.fmu.getFloat64(vrs) == list(z)
    assert f.fmu.getFloat64([0]) == [2e-6]
    n = ctypes.c_size_t()
    f.fmu.fmi3GetNumberOfContinuousStates(f.fmu.component, ctypes.byref(n))
    assert n.value == len(md3.derivatives) == 8
    f.fmu.terminate()
    f.fmu.freeInstance()


def test_bad_calls_name_the_fmi3_function(unzip3, md3):
    f = Logged(unzip3, md3)
    f.fmu.enterInitializationMode(startTime=0.0)
    f.fmu.exitInitializationMode()
    fmu = f.fmu
    vr = (fmi3ValueReference * 1)(f.vr["dte"])
    out = (fmi3Float64 * 2)()
    # Raw calls: FMPy's wrappers raise on fmi3Error; the status and the message are the point.
    lib = fmu.dll
    assert lib.fmi3GetFloat64(fmu.component, vr, 1, out, 2) == 3
    assert any("nValues = 2 for nValueReferences = 1" in m for m in f.errors("fmi3GetFloat64"))
    f = Logged(unzip3, md3)
    f.fmu.enterInitializationMode(startTime=0.0)
    lib = f.fmu.dll
    t = (fmi3ValueReference * 1)(0)
    x = (fmi3Float64 * 1)(1.0)
    assert lib.fmi3SetFloat64(f.fmu.component, t, 1, x, 1) == 3
    assert any("time (value reference 0) is the independent variable" in m
               for m in f.errors("fmi3SetFloat64"))
    f = Logged(unzip3, md3)
    f.fmu.enterInitializationMode(startTime=0.0)
    f.fmu.exitInitializationMode()
    lib = f.fmu.dll
    assert lib.fmi3EnterStepMode(f.fmu.component) == 3
    assert any("hasEventMode is false" in m for m in f.errors("fmi3EnterStepMode"))
    # A bad parameter names the fmi3 function, the variable and the value.
    f = Logged(unzip3, md3)
    mu = (fmi3ValueReference * 1)(f.vr["mu"])
    bad = (fmi3Float64 * 1)(-1.0)
    assert lib.fmi3SetFloat64(f.fmu.component, mu, 1, bad, 1) == 3
    assert any("mu" in m and "-1" in m for m in f.errors("fmi3SetFloat64")), f.messages


def test_bad_arguments_have_their_fmi3_names(unzip3, md3):
    """The bodies are shared with FMI 2.0; an FMI 3.0 master reads FMI 3.0's argument names."""

    def continuous_time():
        """A fresh Model Exchange instance in Continuous-Time Mode, and its library."""
        f = Logged(unzip3, md3, cls=FMU3Model)
        f.fmu.enterInitializationMode(startTime=0.0)
        f.fmu.exitInitializationMode()
        f.fmu.updateDiscreteStates()
        f.fmu.enterContinuousTimeMode()
        return f, f.fmu.dll

    f, lib = continuous_time()
    x = (fmi3Float64 * 9)(*([0.0] * 9))
    assert lib.fmi3SetContinuousStates(f.fmu.component, x, 9) == 3
    assert any("nContinuousStates = 9: the FMU has 8" in m
               for m in f.errors("fmi3SetContinuousStates")), f.messages
    f, lib = continuous_time()
    x = (fmi3Float64 * 8)(*([float("nan")] + [0.0] * 7))
    assert lib.fmi3SetContinuousStates(f.fmu.component, x, 8) == 3
    assert any("continuousStates[0] = NaN" in m
               for m in f.errors("fmi3SetContinuousStates")), f.messages
    f, lib = continuous_time()
    z = (fmi3Float64 * 3)()
    assert lib.fmi3GetEventIndicators(f.fmu.component, z, 3) == 3
    assert any("nEventIndicators = 3: the FMU has 32" in m
               for m in f.errors("fmi3GetEventIndicators")), f.messages
    f = Logged(unzip3, md3)
    f.fmu.enterInitializationMode(startTime=0.0)
    out = (fmi3Float64 * 1)()
    assert f.fmu.dll.fmi3GetFloat64(f.fmu.component, None, 1, out, 1) == 3
    assert any(m.startswith("fmi3GetFloat64: valueReferences: null pointer")
               for m in f.errors("fmi3GetFloat64")), f.messages


def test_co_simulation_equals_fmi2_bit_for_bit(fmu_path, fmu3_path):
    sv = S.G.load_scene("damped")["start_values"]
    kw = dict(stop_time=0.02, output_interval=1e-4, start_values=sv, output=["dte", "w_A", "F_fwd"])
    a = fmpy.simulate_fmu(str(fmu_path), **kw)
    b = fmpy.simulate_fmu(str(fmu3_path), **kw)
    for v in ("dte", "w_A", "F_fwd"):
        assert np.array_equal(a[v], b[v]), v
