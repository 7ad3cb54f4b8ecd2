"""Runs an .ssp in OMSimulator, when it is installed, and reads its result (docs/omsimulator.md).

OMSimulator is found through OMSIMULATOR_HOME (its install prefix: bin/OMSimulator,
lib/x86_64-linux-gnu/libOMSimulator.so and the Python package beside it) or as `OMSimulator` on
PATH. No package registry has it and CI does not build it (docs/omsimulator.md records the
build from source), so callers skip with MISSING when find() returns None.

    find()                             the install, or None
    run_cli(oms, ssp, stop, workdir)   the command a user types: OMSimulator --stopTime=...
                                       --resultFile=... x.ssp (every signal, at every step)
    run_api(oms, ssp, stop, workdir, step=, interval=, signals=)
                                       the same through OMSimulator's Python API in a child
                                       process, with the communication step, the logging
                                       interval and a filter on the recorded signals (the CLI
                                       writes every signal of every FMU at every step)

Both return a Result: columns {full name: array} (e.g. "two_stage.two_stage.shaft.tau_b"), one
row per time. In a system with an algebraic loop OMSimulator writes two rows at each
communication point, the outputs before and after it solved the loop; the last row of each time
is kept (the solved one).  Its CSV carries 12 significant digits.
"""

from __future__ import annotations

import csv
import os
import re
import resource
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MISSING = ("OMSimulator is not installed: set OMSIMULATOR_HOME to its install prefix (bin/OMSimulator) "
           "or put OMSimulator on PATH; docs/omsimulator.md records how it was built here. "
           "CI does not build it.")


@dataclass
class Install:
    home: Path  # the prefix: bin/OMSimulator, lib/x86_64-linux-gnu/

    @property
    def exe(self):
        return self.home / "bin" / "OMSimulator"

    @property
    def pylib(self):
        return self.home / "lib" / "x86_64-linux-gnu"

    def version(self):
        out = subprocess.run([str(self.exe), "--version"], capture_output=True, text=True, check=True)
        return out.stdout.strip()


@dataclass
class Result:
    columns: dict
    log: str
    warnings: int
    seconds: float  # wall
    cpu: float  # the child's CPU time
    command: list = field(default_factory=list)

    def component(self, prefix):
        """{signal: array} of the columns under `prefix` ("model.system.component."), the
        prefix stripped."""
        return {k[len(prefix):]: v for k, v in self.columns.items() if k.startswith(prefix)}


def find():
    home = os.environ.get("OMSIMULATOR_HOME")
    if home and (Path(home) / "bin" / "OMSimulator").is_file():
        return Install(Path(home))
    exe = shutil.which("OMSimulator")
    if exe:
        return Install(Path(exe).resolve().parents[1])
    return None


def read_csv(path):
    """{name: array}, one row per time: the last row written for each time."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = [n.strip() for n in rows[0]]
    data = np.array([[float(x) for x in r] for r in rows[1:] if r], dtype=float)
    t = data[:, 0]
    last = np.append(t[1:] != t[:-1], True)  # the last row of each run of equal times
    return {n: data[last, i] for i, n in enumerate(names)}


def _summary(log):
    """(errors, warnings): OMSimulator's closing count lines `info: N warnings`, `info: N errors`
    (printed only when there was one), else the count of its `error:` and `warning:` lines."""
    w = re.findall(r"info:\s+(\d+) warnings", log)
    e = re.findall(r"info:\s+(\d+) errors", log)
    errors = int(e[-1]) if e else len(re.findall(r"^error:", log, flags=re.M))
    warnings = int(w[-1]) if w else len(re.findall(r"^warning:", log, flags=re.M))
    return errors, warnings


def _child(cmd, workdir, env=None):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    log = proc.stdout + proc.stderr
    errors, warnings = _summary(log)
    if proc.returncode != 0 or errors != 0:
        shown = [c for c in cmd if c != _API_SCRIPT]  # not the driver script's text
        raise RuntimeError(f"OMSimulator failed (exit {proc.returncode}, errors {errors}): {shown}\n{log[-3000:]}")
    return log, warnings, seconds, cpu


def run_cli(oms, ssp, stop_time, workdir, step=None):
    """`OMSimulator --stopTime=T [--stepSize=h] --resultFile=result.csv ssp` in `workdir` (it
    unpacks the .ssp there)."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    out = workdir / "result.csv"
    cmd = [str(oms.exe), f"--stopTime={stop_time!r}", f"--resultFile={out.name}", str(Path(ssp).resolve())]
    if step is not None:
        cmd.insert(2, f"--stepSize={step!r}")
    log, warnings, seconds, cpu = _child(cmd, workdir)
    return Result(read_csv(out), log, warnings, seconds, cpu, cmd)


_API_SCRIPT = r"""
import sys
from OMSimulator import OMSimulator
ssp, stop, step, interval, regex, result = sys.argv[1:7]
oms = OMSimulator()
def ok(what, status):
    if status not in (oms.status_ok, oms.status_warning):
        sys.exit(f"OMSimulator API: {what} returned {status}")
model, status = oms.importFile(ssp)
ok("importFile", status)
if step != "-":
    ok("setFixedStepSize", oms.setFixedStepSize(model + "." + model, float(step)))
ok("setStopTime", oms.setStopTime(model, float(stop)))
if interval != "-":
    ok("setLoggingInterval", oms.setLoggingInterval(model, float(interval)))
if regex != "-":
    ok("removeSignalsFromResults", oms.removeSignalsFromResults(model, ".*"))
    ok("addSignalsToResults", oms.addSignalsToResults(model, regex))
ok("setResultFile", oms.setResultFile(model, result))
ok("instantiate", oms.instantiate(model))
ok("initialize", oms.initialize(model))
ok("simulate", oms.simulate(model))
ok("terminate", oms.terminate(model))
ok("delete", oms.delete(model))
"""


def run_api(oms, ssp, stop_time, workdir, step=None, interval=None, signals=None):
    """The .ssp through OMSimulator's Python API in a child process (the .ssd's system is named
    like the .ssd, as ours are). step: the fixed-step master's communication step (default the
    .ssd's); interval: the logging interval (default every step); signals: a regex of the full
    names to record (default all)."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    out = workdir / "result.csv"
    env = dict(os.environ)
    env["PYTHONPATH"] = str(oms.pylib) + os.pathsep + env.get("PYTHONPATH", "")
    env["LD_LIBRARY_PATH"] = str(oms.pylib) + os.pathsep + env.get("LD_LIBRARY_PATH", "")
    dash = lambda x: "-" if x is None else repr(float(x)) if not isinstance(x, str) else x  # noqa: E731
    cmd = [sys.executable, "-c", _API_SCRIPT, str(Path(ssp).resolve()), repr(float(stop_time)), dash(step),
           dash(interval), dash(signals), out.name]
    log, warnings, seconds, cpu = _child(cmd, workdir, env)
    return Result(read_csv(out), log, warnings or 0, seconds, cpu, cmd)
