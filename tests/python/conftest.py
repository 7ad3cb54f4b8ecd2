"""Fixtures for the FMU tests: the packaged FMU (built once per session), its extraction, the
modelDescription, and low-level FMPy instances whose log messages are captured.

The FMU is always built from the working tree (`cargo run -q -p fmu-packaging --release`), so
the tests exercise exactly the binary a user would get.
"""

import math
import subprocess
from pathlib import Path

import fmpy
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy import calloc, free

ROOT = Path(__file__).resolve().parents[2]
MODEL_IDENTIFIER = "SpurGearMesh"


def build_fmu(packager=None):
    """Builds and packages the FMU (another model's with `packager`, e.g. "package-engine");
    returns the path the packager prints."""
    out = subprocess.run(
        ["cargo", "run", "-q", "-p", "fmu-packaging", "--release"]
        + (["--bin", packager] if packager else []),
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    path = Path(out.stdout.strip().splitlines()[-1])
    assert path.is_file(), f"the packager printed {out.stdout!r}"
    return path


@pytest.fixture(scope="session")
def fmu_path():
    return build_fmu()


@pytest.fixture(scope="session")
def train_fmu_path():
    """The gear-train FMU (SpurGearTrain.fmu), built from the working tree once per session like
    fmu_path: `cargo run -q --release -p fmu-packaging --bin package-train`, which prints its path
    (train_scene_compare.build_train_fmu)."""
    import train_scene_compare

    return train_scene_compare.build_train_fmu()


@pytest.fixture(scope="session")
def engine_fmu_path():
    """EngineTorque.fmu, built from the working tree once per session."""
    return build_fmu("package-engine")


@pytest.fixture(scope="session")
def train_fmu3_path(train_fmu_path):
    """The FMI 3.0 train FMU, which package-train writes beside the FMI 2.0 one."""
    path = train_fmu_path.parent / "SpurGearTrain-fmi3.fmu"
    assert path.is_file(), path
    return path


@pytest.fixture(scope="session")
def fmu3_path(fmu_path):
    """The FMI 3.0 FMU, which the packager writes beside the FMI 2.0 one."""
    path = fmu_path.parent / "SpurGearMesh-fmi3.fmu"
    assert path.is_file(), path
    return path


@pytest.fixture(scope="session")
def model_description(fmu_path):
    return fmpy.read_model_description(str(fmu_path))


@pytest.fixture(scope="session")
def unzip_dir(fmu_path, tmp_path_factory):
    d = tmp_path_factory.mktemp("SpurGearMesh")
    return fmpy.extract(str(fmu_path), unzipdir=str(d))


@pytest.fixture(scope="session")
def variables(model_description):
    """name -> ScalarVariable."""
    return {v.name: v for v in model_description.modelVariables}


class Instance:
    """An FMU2Slave with a logger that records (status, category, message) of every log call,
    and name-based typed get/set."""

    def __init__(self, unzip_dir, md, name="inst", guid=None, logging_on=False, instantiate=True,
                 model_identifier=MODEL_IDENTIFIER):
        self.md = md
        self.vars = {v.name: v for v in md.modelVariables}
        self.messages = []
        self.slave = FMU2Slave(
            guid=md.guid if guid is None else guid,
            unzipDirectory=unzip_dir,
            modelIdentifier=model_identifier,
            instanceName=name,
        )

        def log(env, instance_name, status, category, message):
            self.messages.append(
                (
                    status,
                    (category or b"").decode("utf-8", "replace"),
                    (message or b"").decode("utf-8", "replace"),
                )
            )

        # Keep the ctypes callback objects alive as long as the instance.
        self._logger = fmi2CallbackLoggerTYPE(log)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.instantiated = False
        self.t = 0.0
        if instantiate:
            self.slave.instantiate(callbacks=self.callbacks, loggingOn=logging_on)
            self.instantiated = True

    # ---- values by name ----------------------------------------------------------------------
    def set(self, **values):
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Real":
                self.slave.setReal([v.valueReference], [float(value)])
            elif v.type == "Integer":
                self.slave.setInteger([v.valueReference], [int(value)])
            elif v.type == "Boolean":
                self.slave.setBoolean([v.valueReference], [bool(value)])
            elif v.type == "String":
                self.slave.setString([v.valueReference], [str(value)])
            else:
                raise TypeError(v.type)

    def get(self, name):
        v = self.vars[name]
        getter = {
            "Real": self.slave.getReal,
            "Integer": self.slave.getInteger,
            "Boolean": self.slave.getBoolean,
            "String": self.slave.getString,
        }[v.type]
        return getter([v.valueReference])[0]

    def get_many(self, names):
        return {n: self.get(n) for n in names}

    # ---- life cycle --------------------------------------------------------------------------
    def initialize(self, tolerance=None, stop_time=None, **values):
        """setupExperiment, set the given values in initialization mode, exit initialization."""
        self.slave.setupExperiment(tolerance=tolerance, startTime=0.0, stopTime=stop_time)
        self.slave.enterInitializationMode()
        self.set(**values)
        self.slave.exitInitializationMode()
        self.t = 0.0
        return self

    def step(self, h):
        self.slave.doStep(currentCommunicationPoint=self.t, communicationStepSize=h)
        self.t += h

    def run(self, t_end, h, names):
        """Steps to t_end with step h (an integer number of steps); returns {name: list} sampled
        after every step, with the initial values first, and 'time'."""
        n = int(round((t_end - self.t) / h))
        rec = {name: [self.get(name)] for name in names}
        times = [self.t]
        t0 = self.t
        for k in range(1, n + 1):
            self.slave.doStep(currentCommunicationPoint=self.t, communicationStepSize=h)
            # Communication points as t0 + k*h (no accumulated rounding).
            self.t = t0 + k * h
            times.append(self.t)
            for name in names:
                rec[name].append(self.get(name))
        rec["time"] = times
        return rec

    def errors(self):
        return [m for s, c, m in self.messages if s >= 3]

    def free(self):
        if self.instantiated:
            self.slave.freeInstance()
            self.instantiated = False


@pytest.fixture
def new_instance(unzip_dir, model_description):
    """Factory: new_instance(name='inst', guid=None, logging_on=False) -> Instance; all are freed
    at the end of the test."""
    made = []

    def make(name="inst", guid=None, logging_on=False):
        inst = Instance(unzip_dir, model_description, name=name, guid=guid, logging_on=logging_on)
        made.append(inst)
        return inst

    yield make
    for inst in made:
        inst.free()


@pytest.fixture
def instance(new_instance):
    """One freshly instantiated instance (not yet initialized)."""
    return new_instance()


def expect_status(call, status, *args, **kwargs):
    """Runs an FMPy call that must fail with the given fmi2Status; returns the exception."""
    with pytest.raises(FMICallException) as info:
        call(*args, **kwargs)
    assert info.value.status == status, f"{info.value.function} returned {info.value.status}, expected {status}"
    return info.value


def johnson_delta(n_per_width, rho, e_star):
    """Johnson line contact (spec §4): penetration for a given force per unit face width.
    Explicit in N, so it is an independent check of the FMU's Lambert-W inversion."""
    return n_per_width / (math.pi * e_star) * (math.log(4 * math.pi * e_star * rho / n_per_width) - 1)
