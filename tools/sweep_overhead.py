#!/usr/bin/env python3
"""What one sweep point costs on top of the FMU's own stepping, for the ways FMPy can run it.

Usage: .venv/bin/python tools/sweep_overhead.py [--fmu target/fmu/SpurGearMesh.fmu] [--repeats 30]

The point: scenes/damped.toml with the statistics on, 0.2 s in 4 communication steps after
stats_start = 0.1 s (as in docs/studies.md). Prints the median wall time per point of
1. fmpy.simulate_fmu on the .fmu (unzips and parses modelDescription.xml every call);
2. fmpy.simulate_fmu on an unzipped directory with a parsed model description;
3. tools/sweep.py's runner: one FMU2Slave kept per worker thread, the library loaded once, a
   fresh instance per point;
and, for 3, the time inside fmi2DoStep. Single process, no cluster.
"""

import argparse
import hashlib
import statistics
import sys
import tempfile
import time
from pathlib import Path

import fmpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import sweep as S  # noqa: E402


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--fmu", default=str(S.DEFAULT_FMU))
    ap.add_argument("--repeats", type=int, default=30)
    args = ap.parse_args()
    start, _ = S.load_scene(S.ROOT / "scenes" / "damped.toml")
    start.update(statistics=True, stats_start=0.1)
    stop, n = 0.2, 4
    outputs = list(S.STATS)
    md = fmpy.read_model_description(args.fmu)
    unzipped = fmpy.extract(args.fmu, unzipdir=tempfile.mkdtemp(prefix="SpurGearMesh-"))
    data = Path(args.fmu).read_bytes()
    runner = S.runner_of(data, hashlib.sha256(data).hexdigest())
    fmu_times = []

    def via_runner():
        _, fmu_time = runner.run(start, stop, n, 1e9, outputs)
        fmu_times.append(fmu_time)

    cases = {
        "simulate_fmu(.fmu)": lambda: fmpy.simulate_fmu(
            args.fmu, stop_time=stop, output_interval=stop / n, start_values=start, output=outputs),
        "simulate_fmu(unzipped, md)": lambda: fmpy.simulate_fmu(
            unzipped, model_description=md, stop_time=stop, output_interval=stop / n,
            start_values=start, output=outputs),
        "sweep runner (FMU2Slave kept)": via_runner,
    }
    for name, fn in cases.items():
        fn()  # warm: page cache, first library load
        fmu_times.clear()
        t = median_time(fn, args.repeats)
        extra = f", fmi2DoStep {1e3 * statistics.median(fmu_times):.2f} ms" if fmu_times else ""
        print(f"{name:32s} {1e3 * t:7.2f} ms per point{extra}")


if __name__ == "__main__":
    main()
