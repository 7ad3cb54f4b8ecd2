"""TorsionalShaft.fmu (shaft-fmu/, issue 24 part 1) through FMPy: a valid FMI 2.0 Co-Simulation
FMU whose outputs are the formula's torques of the inputs,

    tau_b = -tau_a = k (theta_a - theta_b + twist_start) + d (w_a - w_b),

declared as a direct feedthrough of the four inputs, and whose bad parameters are refused with a
logged message naming the variable. The FMU is built from the working tree once per session
(`cargo run -q --release -p fmu-packaging --bin package-shaft`, which prints its path).
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
from fmpy import calloc, free
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.validation import validate_fmu

ROOT = Path(__file__).resolve().parents[2]
INPUTS = ["theta_a", "w_a", "theta_b", "w_b"]


@pytest.fixture(scope="module")
def shaft_fmu():
    out = subprocess.run(
        ["cargo", "run", "-q", "--release", "-p", "fmu-packaging", "--bin", "package-shaft"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    path = Path(out.stdout.strip().splitlines()[-1])
    assert path.is_file() and path.name == "TorsionalShaft.fmu", out.stdout
    return path


def torque_b(k, d, twist, ta, wa, tb, wb):
    """The formula, in the FMU's order of evaluation."""
    return k * (ta - tb + twist) + d * (wa - wb)


def test_shaft_crate_tests():
    subprocess.run(
        ["cargo", "test", "-q", "--release", "-p", "torsional_shaft"],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )


def test_valid_with_feedthrough_declared_and_all_of_fmi2_exported(shaft_fmu, tmp_path):
    assert validate_fmu(str(shaft_fmu)) == []
    # The command line too (what the issue names).
    out = subprocess.run(
        [str(ROOT / ".venv" / "bin" / "fmpy"), "validate", str(shaft_fmu)],
        check=True,
        capture_output=True,
        text=True,
    )
    assert "No problems found" in out.stdout, out.stdout + out.stderr

    md = fmpy.read_model_description(str(shaft_fmu))
    assert md.fmiVersion == "2.0"
    assert md.coSimulation is not None and md.modelExchange is None
    assert md.coSimulation.modelIdentifier == "TorsionalShaft"
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    byname = {v.name: v for v in md.modelVariables}
    assert [v.name for v in md.modelVariables if v.causality == "input"] == INPUTS
    assert {n: byname[n].unit for n in INPUTS + ["k", "d", "twist_start", "tau_a", "tau_b"]} == {
        "theta_a": "rad", "w_a": "rad/s", "theta_b": "rad", "w_b": "rad/s",
        "k": "N.m/rad", "d": "N.m.s/rad", "twist_start": "rad", "tau_a": "N.m", "tau_b": "N.m",
    }
    assert (byname["k"].min, byname["d"].min, byname["twist_start"].min) == ("0", "0", None)
    assert all(byname[n].variability == "tunable" for n in ("k", "d", "twist_start"))
    # Each output depends on exactly the four inputs (direct feedthrough).
    assert [o.variable.name for o in md.outputs] == ["tau_a", "tau_b"]
    for o in md.outputs:
        assert [v.name for v in o.dependencies] == INPUTS

    unzip = fmpy.extract(str(shaft_fmu), unzipdir=str(tmp_path / "shaft"))
    doc = (Path(unzip) / "documentation" / "index.html").read_text()
    assert "tau_b = -tau_a = k (theta_a - theta_b + twist_start) + d (w_a - w_b)" in doc
    assert "forward positive" in doc
    lib = ctypes.CDLL(str(Path(unzip) / "binaries" / "linux64" / "TorsionalShaft.so"))
    header = (Path(fmpy.__file__).parent / "c-code" / "fmi2Functions.h").read_text()
    names = sorted(set(re.findall(r"#define (fmi2\w+)\s+fmi2FullName\(", header)))
    assert len(names) == 44
    assert [n for n in names if not hasattr(lib, n)] == []


def inputs_table():
    """Inputs on a 1 ms grid, every one changing, with both signs of each difference."""
    t = np.linspace(0.0, 0.05, 51)
    sig = np.zeros(len(t), dtype=[("time", np.float64)] + [(n, np.float64) for n in INPUTS])
    sig["time"] = t
    sig["theta_a"] = 0.02 * np.sin(300.0 * t) + 3.0 * t
    sig["w_a"] = 6.0 * np.cos(300.0 * t) + 3.0
    sig["theta_b"] = -0.01 * np.cos(170.0 * t) + 2.9 * t
    sig["w_b"] = 1.7 * np.sin(170.0 * t) + 2.9
    return sig


def test_simulate_fmu_gives_the_formulas_torques(shaft_fmu):
    k, d, twist = 4.2e4, 3.5, -1.5e-3
    sig = inputs_table()
    res = fmpy.simulate_fmu(
        str(shaft_fmu),
        stop_time=0.05,
        step_size=1e-3,
        output_interval=1e-3,
        start_values={"k": k, "d": d, "twist_start": twist},
        input=sig,
        output=INPUTS + ["tau_a", "tau_b"],
    )
    assert len(res) == 51
    # The inputs reached the FMU: what it reads back is the input table. FMPy's master sets the
    # inputs of t before initialization and before each step from t, and samples after the step
    # at t + h, so row i holds the inputs of t_(i-1) (row 0 those of t = 0); the torques in a
    # row are those of the inputs in the same row.
    for n in INPUTS:
        np.testing.assert_allclose(res[n][0], sig[n][0], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(res[n][1:], sig[n][:-1], rtol=1e-12, atol=1e-15)
    expected = torque_b(k, d, twist, res["theta_a"], res["w_a"], res["theta_b"], res["w_b"])
    assert np.all(np.abs(expected) > 1.0)  # a real test: no row is near 0
    np.testing.assert_allclose(res["tau_b"], expected, rtol=1e-12, atol=0)
    np.testing.assert_allclose(res["tau_a"], -expected, rtol=1e-12, atol=0)
    assert np.array_equal(res["tau_a"], -res["tau_b"])  # equal and opposite, exactly


def test_defaults_give_the_documented_shaft(shaft_fmu):
    """k = 1e5 N.m/rad, d = 5 N.m.s/rad, twist_start = 0 (SpurGearTrain's default shaft)."""
    sig = inputs_table()
    res = fmpy.simulate_fmu(
        str(shaft_fmu), stop_time=0.05, step_size=1e-3, input=sig, output=INPUTS + ["tau_b"]
    )
    expected = torque_b(1e5, 5.0, 0.0, res["theta_a"], res["w_a"], res["theta_b"], res["w_b"])
    np.testing.assert_allclose(res["tau_b"], expected, rtol=1e-12, atol=0)


@pytest.mark.parametrize(
    "name, value, why",
    [
        ("k", -1.0, "k = -1: must be >= 0"),
        ("d", -0.5, "d = -0.5: must be >= 0"),
        ("k", math.nan, "k = NaN: must be finite"),
        ("d", math.inf, "d = inf: must be finite"),
        ("twist_start", -math.inf, "twist_start = -inf: must be finite"),
    ],
)
def test_bad_parameter_raises_with_the_logged_message(shaft_fmu, tmp_path, name, value, why):
    """fmpy.simulate_fmu on an instance whose logger records every message. The logger is set
    in the callbacks directly, not through simulate_fmu(logger=...): FMPy's native logger
    proxy keeps the last such logger in a process-wide global, which its default callbacks
    then call too, so a test's logger freed after the test would crash a later FMPy instance."""
    messages = []

    def log(env, instance, status, category, message):
        messages.append((status, (category or b"").decode(), (message or b"").decode()))

    md = fmpy.read_model_description(str(shaft_fmu))
    unzip = fmpy.extract(str(shaft_fmu), unzipdir=str(tmp_path / "shaft"))
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(log)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier="TorsionalShaft", instanceName="s")
    fmu.instantiate(callbacks=callbacks)
    try:
        with pytest.raises(FMICallException):
            fmpy.simulate_fmu(unzip, model_description=md, fmu_instance=fmu, stop_time=0.01,
                              start_values={name: value})
    finally:
        fmu.freeInstance()
    errors = [m for s, c, m in messages if s == 3 and c == "logStatusError"]
    assert any(why in m for m in errors), messages


def test_negative_twist_and_zero_stiffness_and_damping_are_fine(shaft_fmu):
    sig = inputs_table()
    res = fmpy.simulate_fmu(
        str(shaft_fmu),
        stop_time=0.05,
        step_size=1e-3,
        start_values={"k": 0.0, "d": 0.0, "twist_start": -0.7},
        input=sig,
        output=["tau_a", "tau_b"],
    )
    assert np.all(res["tau_b"] == 0.0)


def test_bad_inputs_and_state_machine_through_fmpy(shaft_fmu, tmp_path):
    md = fmpy.read_model_description(str(shaft_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = fmpy.extract(str(shaft_fmu), unzipdir=str(tmp_path / "shaft"))
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier="TorsionalShaft", instanceName="s")
    s.instantiate()
    try:
        with pytest.raises(FMICallException):  # doStep before initialization
            s.doStep(0.0, 1e-3)
        for name in INPUTS:
            for bad in (math.nan, math.inf, -math.inf):
                s.reset()
                with pytest.raises(FMICallException):
                    s.setReal([vr[name]], [bad])
        s.reset()
        with pytest.raises(FMICallException):  # an output
            s.setReal([vr["tau_b"]], [1.0])
        s.reset()
        with pytest.raises(FMICallException):  # finite values, infinite torque
            s.setReal([vr["k"], vr["theta_a"]], [1e300, 1e300])
        s.reset()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.setReal([vr["theta_a"], vr["w_b"]], [0.001, 2.0])
        # Feedthrough in initialization mode already: 1e5 * 0.001 + 5 * (0 - 2) = 90.
        assert s.getReal([vr["tau_a"], vr["tau_b"]]) == [-90.0, 90.0]
        s.exitInitializationMode()
        state = s.getFMUstate()
        blob = s.serializeFMUstate(state)
        s.doStep(0.0, 0.1)
        s.setReal([vr["theta_b"]], [0.001])  # the outputs follow at once, without a step
        assert s.getReal([vr["tau_b"]]) == [-10.0]
        s.setFMUstate(s.deSerializeFMUstate(blob))
        assert s.getReal([vr["tau_b"], vr["theta_b"]]) == [90.0, 0.0]
        s.doStep(0.0, 0.1)  # the time came back with the state
        with pytest.raises(FMICallException):  # corrupted
            s.deSerializeFMUstate(blob[:-1] + bytes([blob[-1] ^ 1]))
        s.reset()
        set_time = s.dll.fmi2SetTime  # a Model Exchange function: fmi2Error
        set_time.argtypes, set_time.restype = [ctypes.c_void_p, ctypes.c_double], ctypes.c_int
        assert set_time(s.component, 0.0) == 3
    finally:
        s.freeInstance()
