"""Runs a scene (scenes/<name>.toml) through the packaged FMU with the real `fmpy simulate` CLI
and compares the result with the independent reference trace tests/reference/<name>.csv.

Shared by tests/python/test_scenes.py (the CI check) and tools/scene_table.py (the README table),
so both report the same numbers.

What is compared (issue 3, point 3):

* mode = "trace": every variable in [compare] variables, on the output grid t_k = k * output_interval,
  max |FMU - reference| <= [compare.tolerance] <variable> (physical units; each bound's reason is a
  comment in the scene file).  The reference repeats a row at each event (before, after).  On the
  grid we take the reference's grid row.  If an event of the reference falls exactly on a grid time
  (the rigid scenes release their lock at the input steps t = 0.03 and 0.06 s), both its rows are
  candidates and the closer one counts: FMI 2.0 does not say whether a Co-Simulation FMU reports
  the state just before or just after an event that ends a communication step, and FMPy records
  whatever the FMU returns after fmi2DoStep.

* events = true: the switching times of the contact state (n_fwd, n_bwd).  A Co-Simulation master
  only sees the FMU at communication points, so the FMU's switching times are known only to the
  output interval dt.  The check: at every grid time t_k the FMU's sampled state (n_fwd, n_bwd) must
  be a state the reference is in at some time within the event tolerance of t_k (default: one
  output interval; a scene may set [compare] event_tolerance in seconds).  The metric is
  d = max_k min{|t - t_k| : reference state at t == FMU state at t_k}, 0 where they agree.
  If the FMU switches at t_f and the reference at t_r, every grid time between them shows a
  mismatch whose d is at most its distance to t_r; so d <= |t_f - t_r|, and for an isolated
  switch (no other switch of the reference within |t_f - t_r|) d >= |t_f - t_r| - dt.  The check
  therefore passes every switch that is off by <= dt, and fails an isolated switch that is off by
  > 2 dt, as well as a missing or an extra contact state, as soon as it covers a grid time more
  than dt away from every time at which the reference is in the FMU's state.  Bounces shorter than dt (e.g. paper-m1's ~60 ns
  loss of contact every mesh cycle) are invisible in any Co-Simulation output; the trace comparison
  of the forces catches their consequences.  The number of state changes between consecutive grid
  rows on both sides is reported for information.

* mode = "statistics": gearmesh_ref.statistics() on the FMU's output and on the reference trace
  (the same function, over the output-grid rows on both sides), |FMU - reference| <= the bound in
  [compare.statistics].

The FMU runs with its own defaults for everything the scene does not set (rel_tol = 1e-6; FMPy
passes no tolerance to fmi2SetupExperiment unless --relative-tolerance is given).  For a
Co-Simulation FMU FMPy uses the output interval as the communication step (--step-size is only for
Model Exchange solvers), so output_interval is the communication step.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
SCENES_DIR = ROOT / "scenes"
REF_DIR = ROOT / "tests" / "reference"
sys.path.insert(0, str(ROOT / "tests"))

from reference_model import gearmesh_ref as G  # noqa: E402

# Everything the FMU's outputs have in common with the reference trace (all of it is cheap to
# record; the statistics need theta_A, n_fwd, n_bwd besides the compared variables).
OUTPUTS = [n for n in G.OUTPUT_NAMES if n != "time"] + G.BEARING_OUTPUT_NAMES
UNITS = {
    "theta_A": "rad", "theta_B": "rad", "w_A": "rad/s", "w_B": "rad/s", "dte": "m",
    "F_f1": "N", "F_f2": "N", "F_b1": "N", "F_b2": "N", "F_fwd": "N", "F_bwd": "N",
    "n_fwd": "", "n_bwd": "", "tau_mesh_A": "N.m", "tau_mesh_B": "N.m", "P_loss": "W",
    "F_B_x": "N", "F_B_y": "N", "k_mesh": "N/m", "load_share": "",
    "mean_w_A": "rad/s", "mean_w_B": "rad/s", "mean_w_A_over_w_B": "", "rms_dte": "m",
    "max_dte": "m", "min_dte": "m", "impacts_per_mesh_cycle": "",
    "flank_switches_per_mesh_cycle": "", "switching_time": "s",
}
GRID_EPS = 1e-9  # |t/dt - k| below this: t is the grid time k*dt


def scene_names():
    return sorted(p.stem for p in SCENES_DIR.glob("*.toml"))


def fmpy_executable():
    """The venv's `fmpy` entry point (next to the running interpreter), else the one on PATH."""
    exe = Path(sys.executable).parent / "fmpy"
    if exe.is_file():
        return str(exe)
    found = shutil.which("fmpy")
    if found is None:
        raise RuntimeError("no `fmpy` command found (run `bash tools/venv.sh`)")
    return found


def format_start_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        # String parameter (e.g. pitch_errors_A = "1.2e-07, -3e-08, ..."): one argv element,
        # passed to fmi2SetString unchanged (subprocess does not split it; fmpy's CLI converts a
        # String variable's value with str()).  argparse would take a value that starts with
        # '-' and contains no space for an option; a leading space keeps it a value (the list
        # is parsed with surrounding whitespace allowed, as in "1e-07, 2e-07").
        if value.startswith("-") and " " not in value:
            return " " + value
        return value
    x = float(value)
    text = repr(x)  # shortest repr that round-trips: no precision lost
    if x < 0 and "e" in text:
        # argparse takes '-5e-05' for an option (its negative-number pattern has no
        # exponent); the same shortest digits written positionally stay a value.
        import numpy as np
        text = np.format_float_positional(x, unique=True, trim="-")
        assert float(text) == x
    return text


def fmpy_command(fmu, scene, output_file, rel_tol=None, solver=None):
    """The `fmpy simulate` command line of a scene.  rel_tol: passed as --relative-tolerance
    (fmi2SetupExperiment's tolerance, which overrides the FMU's rel_tol); None = the FMU's
    default, as in CI.  solver: None runs Co-Simulation (FMPy's default for this FMU); "CVode"
    or "Euler" runs Model Exchange with FMPy's solver of that name."""
    cmd = [fmpy_executable(), "simulate", str(fmu), "--validate"]
    if solver is not None:
        cmd += ["--interface-type", "ModelExchange", "--solver", solver, "--dont-record-events"]
    sv = scene.get("start_values", {})
    if sv:
        cmd.append("--start-values")
        for name, value in sv.items():
            cmd += [name, format_start_value(value)]
    cmd += ["--stop-time", repr(float(scene["stop_time"])),
            "--output-interval", repr(float(scene["output_interval"]))]
    if "input_file" in scene:
        cmd += ["--input-file", str(SCENES_DIR / scene["input_file"])]
    if rel_tol is not None:
        cmd += ["--relative-tolerance", repr(float(rel_tol))]
    # compared variables that are not in the common list (k_mesh, load_share of the per-pair
    # mesh) are requested too
    extra = [v for v in scene.get("compare", {}).get("variables", []) if v not in OUTPUTS]
    cmd += ["--output-variables", *OUTPUTS, *extra, "--output-file", str(output_file)]
    return cmd


@dataclass
class Check:
    kind: str           # "trace", "events" or "statistic"
    name: str           # variable or statistic name
    error: float
    bound: float
    where: str = ""     # e.g. "t = 0.0421 s (FMU 1.2e-06, reference 1.19e-06)"
    note: str = ""

    @property
    def fraction(self):
        return self.error / self.bound if self.bound > 0 else (0.0 if self.error == 0 else math.inf)

    @property
    def ok(self):
        return self.error <= self.bound  # NaN fails

    def message(self):
        u = UNITS.get(self.name, "")
        u = f" {u}" if u else ""
        what = {"trace": "max |FMU - reference|", "statistic": "|FMU - reference|",
                "events": "switching-time disagreement (grid-resolved)"}[self.kind]
        return (f"{self.name}: {what} = {self.error:.3g}{u} at {self.where}; bound {self.bound:.3g}{u} "
                f"({self.fraction:.3g} of it)" + (f"; {self.note}" if self.note else ""))


@dataclass
class SceneResult:
    name: str
    mode: str
    checks: list = field(default_factory=list)
    fmpy_seconds: float = 0.0
    total_seconds: float = 0.0
    command: list = field(default_factory=list)

    @property
    def ok(self):
        return all(c.ok for c in self.checks)

    def failures(self):
        return [c for c in self.checks if not c.ok]

    def report(self):
        lines = [f"scene {self.name} ({self.mode}), fmpy simulate {self.fmpy_seconds:.2f} s"]
        lines += [("  FAIL " if not c.ok else "  ok   ") + c.message() for c in self.checks]
        return "\n".join(lines)


def read_csv(path):
    names, table = G.read_table_csv(str(path))
    return names, table


def run_fmpy(fmu, scene, workdir, rel_tol=None, solver=None):
    tag = "" if rel_tol is None else f".rtol{rel_tol:g}"
    tag += "" if solver is None else f".me-{solver}"
    out = Path(workdir) / f"{scene['name']}{tag}.fmu.csv"
    cmd = fmpy_command(Path(fmu).resolve(), scene, out, rel_tol, solver)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=str(workdir))
    seconds = time.perf_counter() - t0
    if proc.returncode != 0 or not out.is_file():
        raise RuntimeError(f"`{' '.join(cmd)}` failed (exit {proc.returncode}):\n"
                           f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    names, table = read_csv(out)
    return names, table, seconds, cmd


def grid_index(t, dt):
    """Grid indices of the times t that lie on the output grid (-1 elsewhere)."""
    k = np.round(t / dt)
    return np.where(np.abs(t / dt - k) < GRID_EPS, k, -1).astype(int)


def reference_candidates(names, table, dt, n_grid):
    """For every grid index k the reference rows at t_k: its grid row, or both rows of an event
    that lies exactly on t_k."""
    k = grid_index(table[:, names.index("time")], dt)
    cands = [[] for _ in range(n_grid + 1)]
    for i, kk in enumerate(k):
        if 0 <= kk <= n_grid:
            cands[kk].append(i)
    missing = [kk for kk, c in enumerate(cands) if not c]
    if missing:
        raise ValueError(f"reference has no row at grid times {missing[:5]} ...")
    return cands


def fmt_t(t):
    return f"t = {t:.6g} s"


def compare_traces(scene, fnames, ftab, rnames, rtab):
    dt = scene["output_interval"]
    ft = ftab[:, fnames.index("time")]
    fk = grid_index(ft, dt)
    n_grid = int(round(scene["stop_time"] / dt))
    if np.any(fk < 0) or len(ft) != n_grid + 1 or np.any(fk != np.arange(n_grid + 1)):
        raise ValueError(f"FMPy's output is not the grid 0, dt, ..., stop_time "
                         f"({len(ft)} rows, expected {n_grid + 1})")
    cands = reference_candidates(rnames, rtab, dt, n_grid)
    tols = scene.get("compare", {}).get("tolerance", {})
    checks = []
    for var in scene["compare"]["variables"]:
        if var not in tols:
            raise KeyError(f"scene {scene['name']}: no [compare.tolerance] {var}")
        fv = ftab[:, fnames.index(var)]
        rcol = rtab[:, rnames.index(var)]
        err = np.empty(n_grid + 1)
        rbest = np.empty(n_grid + 1)
        for k, rows in enumerate(cands):
            e = [abs(fv[k] - rcol[i]) for i in rows]
            j = int(np.argmin(e))
            err[k], rbest[k] = e[j], rcol[rows[j]]
        if np.any(np.isnan(err)):
            k = int(np.argmax(np.isnan(err)))
            checks.append(Check("trace", var, math.nan, tols[var], fmt_t(k * dt), "NaN in the FMU output"))
            continue
        k = int(np.argmax(err))
        checks.append(Check("trace", var, float(err[k]), float(tols[var]),
                            f"{fmt_t(ft[k])} (FMU {fv[k]:.9g}, reference {rbest[k]:.9g})"))
    return checks


def reference_state_segments(rnames, rtab):
    """The reference's contact state (n_fwd, n_bwd) as closed segments [t0, t1] -> state, with a
    breakpoint at every event row pair that changes the state."""
    t = rtab[:, rnames.index("time")]
    nf = np.rint(rtab[:, rnames.index("n_fwd")]).astype(int)
    nb = np.rint(rtab[:, rnames.index("n_bwd")]).astype(int)
    segs = []
    t0, state = -math.inf, (nf[0], nb[0])
    for i in range(1, len(t)):
        s = (nf[i], nb[i])
        if s != state:
            if t[i] != t[i - 1]:
                raise ValueError(f"reference state changes between rows at t = {t[i - 1]} and {t[i]} "
                                 "without an event row pair")
            segs.append((t0, t[i], state))
            t0, state = t[i], s
    segs.append((t0, math.inf, state))  # holds to the end (FMPy's last time may differ by an ulp)
    return segs


def compare_events(scene, fnames, ftab, rnames, rtab):
    dt = scene["output_interval"]
    bound = float(scene.get("compare", {}).get("event_tolerance", dt))
    segs = reference_state_segments(rnames, rtab)
    a = np.array([s[0] for s in segs])
    b = np.array([s[1] for s in segs])
    st = [s[2] for s in segs]
    ft = ftab[:, fnames.index("time")]
    fnf = np.rint(ftab[:, fnames.index("n_fwd")]).astype(int)
    fnb = np.rint(ftab[:, fnames.index("n_bwd")]).astype(int)
    by_state = {}
    for i, s in enumerate(st):
        by_state.setdefault(s, []).append(i)
    dist = np.empty(len(ft))
    for k, tk in enumerate(ft):
        idx = by_state.get((fnf[k], fnb[k]))
        if not idx:
            dist[k] = math.inf
            continue
        dist[k] = float(np.min(np.maximum(0.0, np.maximum(a[idx] - tk, tk - b[idx]))))
    k = int(np.argmax(dist))
    # the reference's state at t_k (the segment holding it; the later one at an exact event)
    j = int(np.searchsorted(a, ft[k], side="right") - 1)
    n_ref_switch = len(segs) - 1
    # state changes between consecutive grid rows, both sides
    rk = [st[int(np.searchsorted(a, tk, side="right") - 1)] for tk in ft]
    r_grid_changes = sum(1 for x, y in zip(rk, rk[1:]) if x != y)
    f_grid_changes = int(np.sum((fnf[1:] != fnf[:-1]) | (fnb[1:] != fnb[:-1])))
    where = (f"{fmt_t(ft[k])} (FMU n_fwd/n_bwd {fnf[k]}/{fnb[k]}, reference {st[j][0]}/{st[j][1]})"
             if dist[k] > 0 else "all grid times")
    note = (f"{n_ref_switch} switches in the reference; changes between grid rows: "
            f"FMU {f_grid_changes}, reference {r_grid_changes}; "
            f"{int(np.sum(dist > 0))} grid times differ")
    return [Check("events", "switching_time", float(dist[k]), bound, where, note)]


def compare_statistics(scene, fnames, ftab, rnames, rtab):
    dt = scene["output_interval"]
    zA = G.GearMesh(scene.get("start_values", {})).g.zA
    fs = G.statistics(fnames, ftab, dt, zA)
    rs = G.statistics(rnames, rtab, dt, zA)
    checks = []
    for stat, bound in scene["compare"]["statistics"].items():
        err = abs(fs[stat] - rs[stat])
        checks.append(Check("statistic", stat, float(err), float(bound),
                            f"whole scene (FMU {fs[stat]:.9g}, reference {rs[stat]:.9g})"))
    return checks


def compare_scene(fmu, name, workdir, rel_tol=None, integrator=None):
    """integrator: the FMU's `solver` parameter instead of the scene's (None: the scene's)."""
    t0 = time.perf_counter()
    scene = G.load_scene(name)
    if integrator is not None:
        scene = {**scene, "name": f"{name}.solver{integrator}",
                 "start_values": {**scene.get("start_values", {}), "solver": integrator}}
    mode = scene.get("mode", "trace")
    fnames, ftab, seconds, cmd = run_fmpy(fmu, scene, workdir, rel_tol)
    rnames, rtab = read_csv(REF_DIR / f"{name}.csv")
    res = SceneResult(name, mode, fmpy_seconds=seconds, command=cmd)
    if mode == "trace":
        res.checks += compare_traces(scene, fnames, ftab, rnames, rtab)
    elif mode == "statistics":
        res.checks += compare_statistics(scene, fnames, ftab, rnames, rtab)
    else:
        raise ValueError(f"scene {name}: unknown mode {mode!r}")
    if scene.get("compare", {}).get("events", False):
        res.checks += compare_events(scene, fnames, ftab, rnames, rtab)
    res.total_seconds = time.perf_counter() - t0
    return res
