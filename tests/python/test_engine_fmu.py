"""EngineTorque.fmu (engine-fmu/, the drive of issue 24's drivetrain) through FMPy: a valid FMI
2.0 Co-Simulation FMU whose torque is

    tau = tau_mean + tau_ripple sin(order theta + phase)

of the crank angle theta, declared as a direct feedthrough, with bad values refused and a logged
message naming the variable. Its FMI layer is fmi2_slave's stateless slave, which
test_shaft_fmu.py and shaft-fmu/tests/fmi.rs exercise call by call; this file checks what the
engine adds: its table, its law, its checks.
"""

import ctypes
import math
import re
import subprocess
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

ROOT = Path(__file__).resolve().parents[2]


def torque(mean, ripple, order, phase, theta):
    """The law, in the FMU's order of evaluation."""
    return mean + ripple * np.sin(order * theta + phase)


def test_engine_crate_tests():
    subprocess.run(["cargo", "test", "-q", "--release", "-p", "engine_torque"], cwd=ROOT, check=True,
                   capture_output=True)


def test_valid_with_feedthrough_declared_and_all_of_fmi2_exported(engine_fmu_path, tmp_path):
    assert validate_fmu(str(engine_fmu_path)) == []
    md = fmpy.read_model_description(str(engine_fmu_path))
    assert md.fmiVersion == "2.0" and md.modelExchange is None
    assert md.coSimulation.modelIdentifier == "EngineTorque"
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    byname = {v.name: v for v in md.modelVariables}
    assert [v.name for v in md.modelVariables if v.causality == "input"] == ["theta"]
    assert {n: byname[n].unit for n in ("theta", "tau_mean", "tau_ripple", "phase", "tau")} == {
        "theta": "rad", "tau_mean": "N.m", "tau_ripple": "N.m", "phase": "rad", "tau": "N.m"}
    assert byname["order"].min == "0"
    assert [o.variable.name for o in md.outputs] == ["tau"]
    assert [v.name for v in md.outputs[0].dependencies] == ["theta"]
    unzip = Path(fmpy.extract(str(engine_fmu_path), unzipdir=str(tmp_path / "engine")))
    doc = (unzip / "documentation" / "index.html").read_text()
    assert "tau = tau_mean + tau_ripple sin(order theta + phase)" in doc
    lib = ctypes.CDLL(str(unzip / "binaries" / "linux64" / "EngineTorque.so"))
    header = (Path(fmpy.__file__).parent / "c-code" / "fmi2Functions.h").read_text()
    names = sorted(set(re.findall(r"#define (fmi2\w+)\s+fmi2FullName\(", header)))
    assert len(names) == 44 and [n for n in names if not hasattr(lib, n)] == []


def test_simulate_fmu_gives_the_laws_torque(engine_fmu_path):
    """A crank turning at 150 rad/s with a small speed wobble; FMPy sets the inputs of t before
    the step from t and samples after it, so row i holds the angle of t_(i-1) and the torque of
    that angle."""
    t = np.linspace(0.0, 0.05, 51)
    sig = np.zeros(len(t), dtype=[("time", np.float64), ("theta", np.float64)])
    sig["time"], sig["theta"] = t, 150.0 * t + 0.01 * np.sin(900.0 * t)
    p = {"tau_mean": 80.0, "tau_ripple": -35.0, "order": 1.5, "phase": 0.4}
    res = fmpy.simulate_fmu(str(engine_fmu_path), stop_time=0.05, step_size=1e-3, output_interval=1e-3,
                            start_values=p, input=sig, output=["theta", "tau"])
    np.testing.assert_allclose(res["theta"][1:], sig["theta"][:-1], rtol=1e-12, atol=1e-15)
    expected = torque(p["tau_mean"], p["tau_ripple"], p["order"], p["phase"], res["theta"])
    np.testing.assert_allclose(res["tau"], expected, rtol=1e-12, atol=0)
    assert np.ptp(res["tau"]) > 60.0  # the ripple is there: most of its 70 N.m swing


@pytest.mark.parametrize("name, value, why", [
    ("order", -1.0, "order = -1: must be >= 0"),
    ("tau_mean", math.nan, "tau_mean = NaN: must be finite"),
    ("tau_ripple", math.inf, "tau_ripple = inf: must be finite"),
    ("theta", -math.inf, "theta = -inf: must be finite"),
])
def test_bad_values_are_refused_with_the_logged_message(engine_fmu_path, tmp_path, name, value, why):
    from conftest import Instance

    md = fmpy.read_model_description(str(engine_fmu_path))
    unzip = fmpy.extract(str(engine_fmu_path), unzipdir=str(tmp_path / "engine"))
    e = Instance(unzip, md, name="e", model_identifier="EngineTorque")
    try:
        e.slave.setupExperiment(startTime=0.0)
        e.slave.enterInitializationMode()
        with pytest.raises(FMICallException):  # one call: the good value and the bad one
            e.slave.setReal([e.vars["tau_mean"].valueReference, e.vars[name].valueReference], [10.0, value])
        errors = [m for st, c, m in e.messages if st == 3 and c == "logStatusError"]
        assert any(why in m and "fmi2SetReal" in m for m in errors), e.messages
        # Nothing of the refused call was applied (getters still answer in the error state).
        assert e.get("tau_mean") == 50.0
    finally:
        e.free()


def test_states_and_wrong_calls(engine_fmu_path, tmp_path):
    md = fmpy.read_model_description(str(engine_fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = fmpy.extract(str(engine_fmu_path), unzipdir=str(tmp_path / "engine"))
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier="EngineTorque", instanceName="e")
    s.instantiate()
    try:
        with pytest.raises(FMICallException):  # doStep before initialization
            s.doStep(0.0, 1e-3)
        s.reset()
        with pytest.raises(FMICallException):  # finite values, infinite torque
            s.setReal([vr["tau_mean"], vr["tau_ripple"], vr["phase"]], [1.7e308, 1.7e308, 1.5])
        s.reset()
        with pytest.raises(FMICallException):  # the output
            s.setReal([vr["tau"]], [1.0])
        s.reset()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.setReal([vr["theta"]], [math.pi / 4])  # defaults 50 + 20 sin(2 theta): the peak
        assert s.getReal([vr["tau"]]) == pytest.approx([70.0], rel=1e-15)
        s.exitInitializationMode()
        blob = s.serializeFMUstate(s.getFMUstate())
        s.doStep(0.0, 0.1)
        s.setReal([vr["theta"]], [3 * math.pi / 4])
        assert s.getReal([vr["tau"]]) == pytest.approx([30.0], rel=1e-15)
        s.setFMUstate(s.deSerializeFMUstate(blob))
        assert s.getReal([vr["tau"]]) == pytest.approx([70.0], rel=1e-15)
        s.doStep(0.0, 0.1)  # the time came back with the state
    finally:
        s.freeInstance()
