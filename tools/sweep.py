#!/usr/bin/env python3
"""Parameter sweeps of SpurGearMesh on a Dask cluster: one FMU run per grid point, the FMU's own
statistics outputs per point, one parquet table.

Usage (a speed-load map of the damped paper rig):
    .venv/bin/python tools/sweep.py --scene scenes/damped.toml --hold-speed \\
        --vary w_A_start=50:900:40 --vary tau_A=25:400:16 --stop-time 0.2 --stats-start 0.1 \\
        --out out/speed-load.parquet --plot out/speed-load.png [--workers 2 | --scheduler tcp://host:8786]

    --scene FILE        scene TOML (scenes/*.toml); its [start_values] are the base point, its
                        stop_time the run length (--stop-time overrides)
    --vary NAME=A:B:N   N values from A to B (numpy.linspace), or NAME=v1,v2,...; repeatable, the
                        grid is the product of all --vary. NAME is a parameter or an input.
    --hold-speed        speed-load maps: w_A_start is the held speed of A. Each point gets
                        w_B_start = w_A_start zA/zB and c_load = tau_A (zB/zA)^2 / w_A_start, the
                        viscous load whose steady state is that speed (see docs/studies.md)
    --stats-start T     the FMU's statistics accumulate over t >= T (skip the start transient)
    --workers N         embedded LocalCluster of N worker processes (default: one per core)
    --scheduler ADDR    use a running Dask cluster instead (tcp://host:8786)
    --out FILE.parquet  results; a re-run with the same --out skips the points already ok
    --plot FILE.png     heat maps (two or more varied names) or lines (one) of the statistics
    --fmu PATH          default target/fmu/SpurGearMesh.fmu

Every point runs the packaged FMU through FMPy's FMU2Slave in a worker process: one
communication step to stats_start, then --comm-steps large ones (the statistics are exact along
the FMU's internal steps, so the communication grid does not matter); the FMU's `statistics`
switch is set on. Its row holds the varied values, every statistics output, n_steps and
n_events, w_A at stats_start and at the end, w_B at the end, wall_time (the point in the
worker), fmu_time (its fmi2DoStep calls), status (ok / error / timeout / lost), error and worker.
A failed point is a row, never the end of the sweep. --timeout (s per point, default 300) is
checked between communication steps; --batch sets the points per Dask task.

The FMU travels as bytes through the cluster (the result of one task, which the scheduler
recomputes if its worker dies; each worker fetches it once from a peer) and each worker process
unpacks it once into its local directory. Worker-side code is pickled by value, so remote
workers need only the same Python version with fmpy and dask, not this file.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import itertools
import json
import math
import os
import socket
import sys
import tempfile
import threading
import time
import tomllib
import types
import zipfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FMU = ROOT / "target" / "fmu" / "SpurGearMesh.fmu"

# The FMU's statistics outputs (issue 11): the columns every sweep reports.
STATS = ("dte_mean", "dte_rms", "dte_min", "dte_max", "F_max", "t_separated", "t_backward")
# Integer outputs recorded per point: the FMU's own work.
COUNTERS = ("n_steps", "n_events")
# Speeds recorded per point: w_A at stats_start and at the end tell whether the speed was held
# (and give A's torque balance over the statistics window), w_B at the end.
SPEEDS = ("w_A_stats_start", "w_A_end", "w_B_end")
META_KEY = b"spurgear.sweep"
STATUS_OK = "ok"


# ---------------------------------------------------------------------------------------------
# Worker side. Everything a task needs is passed in or cached in a module registered in
# sys.modules, because these functions are pickled by value and lose their own globals per task.
# ---------------------------------------------------------------------------------------------

def _worker_cache():
    """Per-process cache that survives tasks: unpacked FMUs, and per-thread FMU2Slave objects."""
    cache = sys.modules.get("_spurgear_sweep_cache")
    if cache is None:
        cache = types.ModuleType("_spurgear_sweep_cache")
        cache.lock = threading.Lock()
        cache.fmus = {}  # digest -> (unzipdir, model description)
        cache.local = threading.local()
        sys.modules[cache.__name__] = cache
    return cache


def _scratch_dir():
    """The Dask worker's local directory (removed with the worker), else the system temp dir."""
    try:
        from distributed import get_worker

        return get_worker().local_directory
    except (ImportError, ValueError):
        return tempfile.gettempdir()


def _unpacked_fmu(fmu_bytes, digest):
    """Unzips the FMU once per process; returns (unzipdir, model description)."""
    import fmpy

    cache = _worker_cache()
    with cache.lock:
        if digest not in cache.fmus:
            d = tempfile.mkdtemp(prefix=f"SpurGearMesh-{digest[:12]}-", dir=_scratch_dir())
            with zipfile.ZipFile(io.BytesIO(fmu_bytes)) as z:
                z.extractall(d)
            md = fmpy.read_model_description(d)
            cache.fmus[digest] = (d, md)
        return cache.fmus[digest]


class _Runner:
    """One FMU2Slave per thread and FMU: the shared library stays loaded, and each point gets a
    fresh instance (instantiate/free cost ~30 us, a library load ~1 ms)."""

    def __init__(self, unzipdir, md):
        from fmpy.fmi2 import (
            FMU2Slave,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )
        from fmpy import calloc, free

        self.vars = {v.name: v for v in md.modelVariables}
        self.slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="sweep",
        )
        self.messages = []

        def log(env, name, status, category, message):
            self.messages.append((message or b"").decode("utf-8", "replace"))

        # ctypes callbacks must outlive every instance made with them.
        self._logger = fmi2CallbackLoggerTYPE(log)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)

    def set(self, values):
        for name, value in values.items():
            v = self.vars[name]
            if v.type == "Real":
                self.slave.setReal([v.valueReference], [float(value)])
            elif v.type == "Integer":
                self.slave.setInteger([v.valueReference], [int(value)])
            elif v.type == "Boolean":
                self.slave.setBoolean([v.valueReference], [bool(value)])
            else:
                raise TypeError(f"{name}: type {v.type} cannot be set")

    def get(self, name):
        v = self.vars[name]
        get = {"Real": self.slave.getReal, "Integer": self.slave.getInteger}[v.type]
        return get([v.valueReference])[0]

    def start(self, start_values, stop_time):
        """A fresh instance, initialized with the start values."""
        self.messages.clear()
        self.slave.instantiate(callbacks=self.callbacks, loggingOn=False)
        try:
            self.slave.setupExperiment(startTime=0.0, stopTime=stop_time)
            self.slave.enterInitializationMode()
            self.set(start_values)
            self.slave.exitInitializationMode()
        except BaseException:
            self.free()
            raise

    def step(self, t, h):
        """One fmi2DoStep; returns its wall time."""
        s = time.perf_counter()
        self.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        return time.perf_counter() - s

    def free(self):
        # Without fmpy's freeLibrary: the next point reuses the loaded library.
        self.slave.fmi2FreeInstance(self.slave.component)

    def run(self, start_values, stop_time, n_comm, timeout, outputs):
        """One point in a fresh instance: one step to stats_start, n_comm steps over the
        statistics window. Returns (outputs at the end, w_A at stats_start and at the end,
        fmu_time). Raises TimeoutError between steps once `timeout` s have passed."""
        t0 = time.perf_counter()
        t_stats = float(start_values.get("stats_start", 0.0))
        grid = ([0.0] if t_stats > 0.0 else []) + list(np.linspace(t_stats, stop_time, n_comm + 1))
        self.start(start_values, stop_time)
        try:
            fmu_time = 0.0
            values = {"w_A_stats_start": self.get("w_A")}
            for t, t_next in zip(grid[:-1], grid[1:]):
                if time.perf_counter() - t0 > timeout:
                    raise TimeoutError(f"timeout {timeout:g} s at t = {t:g} s")
                fmu_time += self.step(t, t_next - t)
                if t_next == t_stats:
                    values["w_A_stats_start"] = self.get("w_A")
            values.update({n: self.get(n) for n in outputs}, w_A_end=self.get("w_A"), w_B_end=self.get("w_B"))
            return values, fmu_time
        finally:
            self.free()

    def failure_text(self, exc):
        log = " | ".join(m for m in self.messages if m)
        return f"{type(exc).__name__}: {exc}" + (f" | FMU: {log}" if log else "")


def runner_of(fmu_bytes, digest):
    """This thread's runner of the FMU (for tasks of other tools, too)."""
    cache = _worker_cache()
    runners = getattr(cache.local, "runners", None)
    if runners is None:
        runners = cache.local.runners = {}
    if digest not in runners:
        runners[digest] = _Runner(*_unpacked_fmu(fmu_bytes, digest))
    return runners[digest]


def fmu_blob(fmu_bytes):
    """Worker task holding the FMU's bytes: a result the scheduler can recompute when the worker
    holding it dies (scattered data would be lost with it). Workers fetch it from a peer once."""
    return fmu_bytes


def run_batch(fmu_bytes, digest, points, stop_time, n_comm, timeout, outputs):
    """Worker task: runs each point {"key": {...}, "start": {...}}; returns one row per point.
    Any exception of a point becomes its row (status error/timeout)."""
    where = f"{socket.gethostname()}:{os.getpid()}"
    rows = []
    for p in points:
        row = dict(p["key"], status=STATUS_OK, error="", worker=where)
        t0 = time.perf_counter()
        runner = None
        try:
            runner = runner_of(fmu_bytes, digest)
            values, fmu_time = runner.run(p["start"], stop_time, n_comm, timeout, outputs)
            row.update(values, fmu_time=fmu_time)
        except TimeoutError as exc:
            row.update(status="timeout", error=str(exc))
        except Exception as exc:  # an FMU error or anything else: the row says what
            row.update(status="error", error=runner.failure_text(exc) if runner else repr(exc))
        row["wall_time"] = time.perf_counter() - t0
        rows.append(row)
    return rows


# ---------------------------------------------------------------------------------------------
# Client side: grid, cluster, resume, table.
# ---------------------------------------------------------------------------------------------

def parse_vary(spec):
    """'NAME=A:B:N' (linspace) or 'NAME=v1,v2,...' -> (name, list of floats)."""
    name, sep, rhs = spec.partition("=")
    if not sep or not name or not rhs:
        raise ValueError(f"--vary {spec!r}: expected NAME=START:STOP:N or NAME=v1,v2,...")
    if ":" in rhs:
        parts = rhs.split(":")
        if len(parts) != 3:
            raise ValueError(f"--vary {spec!r}: expected START:STOP:N")
        n = int(parts[2])
        if n < 1:
            raise ValueError(f"--vary {spec!r}: N must be >= 1")
        values = np.linspace(float(parts[0]), float(parts[1]), n).tolist()
    else:
        values = [float(v) for v in rhs.split(",")]
    return name.strip(), values


def typed(var, value):
    """A value cast to the variable's FMI type (Integer must be whole)."""
    if var.type == "Integer":
        if float(value) != round(float(value)):
            raise ValueError(f"{var.name} is Integer, got {value}")
        return int(round(float(value)))
    if var.type == "Boolean":
        return bool(value)
    return float(value)


def load_scene(path):
    """A scene TOML -> (start_values, stop_time). Time-varying inputs are refused: a sweep runs
    a few long steps with constant inputs."""
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    if "input_file" in scene:
        raise ValueError(f"{path}: scenes with time-varying inputs ({scene['input_file']}) cannot be swept")
    return dict(scene.get("start_values", {})), float(scene["stop_time"])


def model_variables(fmu_path):
    import fmpy

    md = fmpy.read_model_description(str(fmu_path))
    return {v.name: v for v in md.modelVariables}


def check_variables(variables, varied, stats):
    """Errors early, on the client: unknown or unsettable names, missing statistics outputs."""
    missing = [n for n in stats if n not in variables or variables[n].causality != "output"]
    if missing:
        raise SystemExit(
            f"the FMU has no statistics output(s) {', '.join(missing)}: rebuild it "
            "(cargo run -q -p fmu-packaging --release) from a tree that has them"
        )
    for name in varied:
        v = variables.get(name)
        if v is None:
            raise SystemExit(f"--vary {name}: the FMU has no variable {name!r}")
        if v.causality not in ("parameter", "input"):
            raise SystemExit(f"--vary {name}: {name} is a {v.causality}, not a parameter or input")


def speed_hold(start, variables):
    """w_A_start is the held speed: rigid-rolling w_B_start and the viscous load whose steady
    state is that speed (c_load w_B = tau_A zB/zA, without friction losses)."""
    zA = start.get("zA", variables["zA"].start)
    zB = start.get("zB", variables["zB"].start)
    ratio = float(zB) / float(zA)
    w = float(start.get("w_A_start", 0.0))
    if w <= 0.0:
        raise SystemExit("--hold-speed needs w_A_start > 0 (in the scene or a --vary)")
    # Steady state at w: c_load w_B = (mesh torque on B) + tau_B = tau_A zB/zA + tau_B.
    tau = float(start.get("tau_A", 0.0)) + float(start.get("tau_B", 0.0)) / ratio
    if tau <= 0.0:
        raise SystemExit("--hold-speed needs a forward drive: tau_A + tau_B zA/zB > 0")
    return dict(start, w_B_start=w / ratio, c_load=tau * ratio * ratio / w)


def grid_points(varies, base, variables, hold_speed=False):
    """The product of all --vary values -> list of {"key": varied values, "start": start values}."""
    names = [n for n, _ in varies]
    points = []
    for combo in itertools.product(*[vals for _, vals in varies]):
        key = {n: typed(variables[n], v) for n, v in zip(names, combo)}
        start = dict(base, **key)
        if hold_speed:
            start = speed_hold(start, variables)
        points.append({"key": key, "start": start})
    return points


def key_of(row, names):
    return tuple(row[n] for n in names)


def read_previous(out, meta, replace_other=False):
    """Rows of an earlier sweep into the same file, or None. A different base (scene, stop time,
    statistics start, FMU, varied names) is refused, as its rows are not the same experiment; or,
    with replace_other (a cache, as in dynamic_factor.py), ignored and overwritten."""
    import pyarrow.parquet as pq

    if not Path(out).exists():
        return None
    table = pq.read_table(out)
    old = json.loads((table.schema.metadata or {}).get(META_KEY, b"{}"))
    diff = sorted(k for k in meta if old.get(k) != meta[k])
    if diff and replace_other:
        print(f"{out}: a different {', '.join(diff)}; running every point again", file=sys.stderr)
        return None
    if diff:
        raise SystemExit(f"{out} holds a sweep with a different {', '.join(diff)}; use another --out")
    return table.to_pandas()


def write_table(out, rows, names, meta):
    """Rows -> parquet (sorted by the varied values), atomically: a crash leaves the old file."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    df = pd.DataFrame(rows)
    for c in COUNTERS:
        if c in df:  # counts stay integers; a failed point's is missing, not NaN
            df[c] = df[c].astype("Int64")
    if len(df):
        df = df.sort_values(names, kind="stable").reset_index(drop=True)
    table = pa.Table.from_pandas(df, preserve_index=False)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}), META_KEY: json.dumps(meta)})
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    tmp = f"{out}.tmp-{os.getpid()}"
    pq.write_table(table, tmp)
    os.replace(tmp, out)


def row_template(names, outputs):
    """The columns of every row, so a failed point has NaN statistics, not missing columns."""
    cols = dict.fromkeys(names)
    cols.update(dict.fromkeys(outputs, math.nan))
    cols.update(dict.fromkeys(SPEEDS, math.nan))
    cols.update(fmu_time=math.nan, wall_time=math.nan, status="", error="", worker="")
    return cols


def batches(points, size):
    return [points[i : i + size] for i in range(0, len(points), size)]


def auto_batch(n_points, n_workers):
    """Points per task: enough tasks for load balance (8 per worker), few enough that the
    scheduler's per-task cost (~1 ms) stays small next to the points (~2-20 ms each)."""
    return max(1, min(64, math.ceil(n_points / (8 * max(1, n_workers)))))


def make_client(workers, scheduler):
    """A Client of the given cluster, or of an embedded LocalCluster of worker processes."""
    from distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler)
    cluster = LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=40,
    )
    return Client(cluster)


def pickle_by_value():
    """Imported as a module (tests, other tools), the task functions would be pickled by
    reference and a remote worker would need this file; by value it needs only fmpy."""
    import cloudpickle

    mod = sys.modules[__name__]
    if __name__ != "__main__":
        cloudpickle.register_pickle_by_value(mod)


def ship_fmu(client, fmu_bytes):
    """The FMU as a cluster future (one task result, fetched once per worker) and its digest."""
    pickle_by_value()
    digest = hashlib.sha256(fmu_bytes).hexdigest()
    return client.submit(fmu_blob, fmu_bytes, key=f"SpurGearMesh.fmu-{digest}"), digest


def run_points(client, fmu_bytes, points, stop_time, n_comm=4, timeout=300.0, outputs=STATS + COUNTERS,
               batch=None, on_rows=None, progress=True):
    """Runs points on the cluster; returns one row per point. A task that dies with its worker
    (crash, KilledWorker) is split and retried point by point, and a point lost again is retried
    alone, one at a time at the end (a crashing neighbour in the same worker takes down whatever
    is queued there); a point lost even then is a row with status 'lost'. on_rows(rows) is called
    as results arrive (checkpoints)."""
    from distributed import as_completed
    from tqdm import tqdm

    fmu_future, digest = ship_fmu(client, fmu_bytes)
    n_workers = max(1, len(client.scheduler_info(n_workers=-1)["workers"]))
    size = batch or auto_batch(len(points), n_workers)
    pending, rows, lost = {}, [], []
    bar = tqdm(total=len(points), unit="pt", disable=not progress, file=sys.stderr, smoothing=0.1)

    def submit(chunk):
        f = client.submit(run_batch, fmu_future, digest, chunk, stop_time, n_comm, timeout,
                          list(outputs), pure=False)
        pending[f] = chunk
        return f

    def accept(got):
        rows.extend(got)
        bar.update(len(got))
        if on_rows:
            on_rows(got)

    queue = as_completed([submit(c) for c in batches(points, size)])
    for f in queue:
        chunk = pending.pop(f)
        try:
            accept(f.result())
        except Exception:  # the task, not a point, failed: worker died, unpicklable, ...
            if len(chunk) > 1:
                for p in chunk:
                    queue.add(submit([p]))
            else:
                lost.append(chunk[0])
    for p in lost:
        f = submit([p])
        try:
            accept(f.result())
        except Exception as exc:
            accept([dict(p["key"], status="lost", error=f"{type(exc).__name__}: {exc}")])
        pending.pop(f, None)
    bar.close()
    return rows


def summary(rows, elapsed, n_workers):
    """One line: throughput and how much of a point is the FMU's own stepping."""
    ok = [r for r in rows if r.get("status") == STATUS_OK]
    fmu = sum(r["fmu_time"] for r in ok)
    wall = sum(r["wall_time"] for r in ok)
    n = len(rows)
    rate = n / elapsed if elapsed > 0 else math.nan
    per_point = elapsed * n_workers / n if n else math.nan
    fmu_pp = fmu / len(ok) if ok else math.nan
    head = f"{n} points ({len(ok)} ok) in {elapsed:.2f} s with {n_workers} worker(s): {rate:.1f} points/s"
    if not ok:
        return head
    return (
        f"{head}; per point {1e3 * per_point:.2f} ms of worker time, of it fmi2DoStep {1e3 * fmu_pp:.2f} ms, "
        f"the rest of the task {1e3 * (wall - fmu) / max(1, len(ok)):.2f} ms, "
        f"cluster overhead {1e3 * (per_point - wall / max(1, len(ok))):.2f} ms"
    )


def sweep(points, names, out, meta, client, fmu_bytes, stop_time, n_comm, timeout, batch=None,
          outputs=STATS + COUNTERS, progress=True, checkpoint_every=10.0, replace_other=False):
    """Runs the points of the grid not yet ok in `out`, keeps the rows already there, and writes
    the union to `out`. Returns (table rows, rows computed now, elapsed seconds)."""
    prev = read_previous(out, meta, replace_other)
    kept = {}
    if prev is not None:
        for r in prev.to_dict("records"):
            kept[key_of(r, names)] = r
    todo = [p for p in points if kept.get(key_of(p["key"], names), {}).get("status") != STATUS_OK]
    template = row_template(names, outputs)
    done = {}
    last = [time.monotonic()]

    def table():
        merged = dict(kept)
        merged.update(done)
        return [dict(template, **r) for r in merged.values()]

    def checkpoint(rows):
        for r in rows:
            done[key_of(r, names)] = r
        if time.monotonic() - last[0] > checkpoint_every:
            write_table(out, table(), names, meta)
            last[0] = time.monotonic()

    if len(todo) < len(points):
        print(f"{out}: {len(points) - len(todo)} of {len(points)} points already ok, skipped", file=sys.stderr)
    t0 = time.perf_counter()
    try:
        new = run_points(client, fmu_bytes, todo, stop_time, n_comm, timeout, outputs, batch, checkpoint,
                         progress) if todo else []
    except KeyboardInterrupt:
        write_table(out, table(), names, meta)  # keep what is done; a re-run goes on from there
        raise
    elapsed = time.perf_counter() - t0
    rows = table()
    write_table(out, rows, names, meta)
    return rows, new, elapsed


# ---------------------------------------------------------------------------------------------
# Plot
# ---------------------------------------------------------------------------------------------

PLOTTED = {
    "F_max": ("F_max [N]", lambda d: d["F_max"]),
    "dte_pp": ("dte_max - dte_min [um]", lambda d: 1e6 * (d["dte_max"] - d["dte_min"])),
    "separated": ("t_separated / measured time", None),  # needs the statistics window
}


def plot(df, names, path, window=None, title=""):
    """Heat maps of F_max, the dte peak-to-peak and the separated fraction over the first two
    varied names that take more than one value (the maximum over any further ones), or lines
    over one; failed points are blank. window: the statistics' duration (stop - stats_start)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dims = [n for n in names if df[n].nunique() > 1] or names[:1]
    ok = df["status"] == STATUS_OK
    panels = [(k, lab, f) for k, (lab, f) in PLOTTED.items() if f is not None or window]
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False)
    for ax, (key, label, f) in zip(axes[0], panels):
        values = f(df) if f else df["t_separated"] / window
        d = df.assign(v=values.where(ok))
        if len(dims) == 1:
            x = d.sort_values(dims[0])
            ax.plot(x[dims[0]], x["v"], "o-", ms=3)
            ax.set_xlabel(dims[0])
            ax.set_ylabel(label)
        else:
            grid = d.pivot_table(index=dims[1], columns=dims[0], values="v", aggfunc="max", dropna=False)
            xs, ys = grid.columns.to_numpy(float), grid.index.to_numpy(float)
            m = ax.pcolormesh(_edges(xs), _edges(ys), grid.to_numpy(float), shading="flat", cmap="viridis")
            fig.colorbar(m, ax=ax, label=label)
            ax.set_xlabel(dims[0])
            ax.set_ylabel(dims[1])
            more = f"\n(max over {', '.join(dims[2:])})" if len(dims) > 2 else ""
            ax.set_title(key + more)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _edges(centres):
    """Cell edges around sorted centres (midpoints; the outer cells mirrored)."""
    c = np.asarray(centres, float)
    if len(c) == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[2 * c[0] - mid[0]], mid, [2 * c[-1] - mid[-1]]])


# ---------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------

def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", required=True, help="scene TOML; its start_values are the base point")
    ap.add_argument("--vary", action="append", default=[], metavar="NAME=START:STOP:N|v1,v2,..")
    ap.add_argument("--hold-speed", action="store_true",
                    help="w_A_start is a held speed: set w_B_start and c_load from it and tau_A")
    ap.add_argument("--stats-start", type=float, default=None, metavar="T")
    ap.add_argument("--stop-time", type=float, default=None, help="default: the scene's stop_time")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS")
    ap.add_argument("--out", required=True, metavar="FILE.parquet")
    ap.add_argument("--plot", default=None, metavar="FILE.png")
    ap.add_argument("--fmu", default=str(DEFAULT_FMU))
    ap.add_argument("--comm-steps", type=int, default=4, help="communication steps per point")
    ap.add_argument("--timeout", type=float, default=300.0,
                    help="seconds per point, checked between communication steps")
    ap.add_argument("--batch", type=int, default=None, help="points per Dask task (default: automatic)")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    if not args.vary:
        ap.error("give at least one --vary")
    return args


def setup(args):
    """Arguments -> (points, varied names, base start values, stop time, metadata, FMU bytes)."""
    fmu_bytes = Path(args.fmu).read_bytes()
    variables = model_variables(args.fmu)
    varies = [parse_vary(s) for s in args.vary]
    names = [n for n, _ in varies]
    if len(set(names)) != len(names):
        raise SystemExit("each name may be varied once")
    check_variables(variables, names + (["stats_start"] if args.stats_start is not None else []), STATS)
    base, stop_time = load_scene(args.scene)
    if args.stop_time is not None:
        stop_time = args.stop_time
    if "statistics" in variables:  # the switch that makes the FMU accumulate them
        base["statistics"] = True
    if args.stats_start is not None:
        if not 0.0 <= args.stats_start < stop_time:
            raise SystemExit(f"--stats-start must lie in [0, stop time {stop_time:g})")
        base["stats_start"] = args.stats_start
    for n in base:
        if n not in variables:
            raise SystemExit(f"{args.scene}: the FMU has no variable {n!r}")
    points = grid_points(varies, base, variables, args.hold_speed)
    meta = {
        "scene": Path(args.scene).name,
        "base": base,
        "stop_time": stop_time,
        "hold_speed": bool(args.hold_speed),
        "varied": names,
        "fmu_sha256": hashlib.sha256(fmu_bytes).hexdigest(),
    }
    return points, names, stop_time, meta, fmu_bytes


def main(argv=None):
    args = parse_args(argv)
    points, names, stop_time, meta, fmu_bytes = setup(args)
    client = make_client(args.workers, args.scheduler)
    try:
        n_workers = len(client.scheduler_info(n_workers=-1)["workers"])
        rows, new, elapsed = sweep(points, names, args.out, meta, client, fmu_bytes, stop_time,
                                   args.comm_steps, args.timeout, args.batch, progress=not args.no_progress)
    except KeyboardInterrupt:
        print(f"interrupted: the points done are in {args.out}; the same command goes on", file=sys.stderr)
        return 130
    finally:
        client.close()
        if client.cluster is not None and not args.scheduler:
            client.cluster.close()
    if new:
        print(summary(new, elapsed, n_workers), file=sys.stderr)
    bad = [r for r in new if r["status"] != STATUS_OK]
    for r in bad[:10]:
        print(f"  {r['status']}: {key_of(r, names)}: {r['error']}", file=sys.stderr)
    print(f"{args.out}: {len(rows)} rows, {len(bad)} failed now", file=sys.stderr)
    if args.plot:
        import pandas as pd

        window = stop_time - meta["base"].get("stats_start", 0.0)
        plot(pd.read_parquet(args.out), names, args.plot, window, title=Path(args.scene).stem)
        print(f"{args.plot}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
