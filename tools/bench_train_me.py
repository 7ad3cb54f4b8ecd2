#!/usr/bin/env python3
"""FMPy's Model Exchange (CVode) on two builds of SpurGearTrain, scene by scene: what a master's
integrator pays for the states a build declares (docs/lateral.md, Capacity).

    .venv/bin/python tools/bench_train_me.py OLD.fmu [NEW.fmu] [--scenes single,planetary-simple]
        [--reps 5] [--stop-time 0.02]

NEW defaults to target/fmu/SpurGearTrain.fmu. Each scene runs with its start values for
--stop-time at rtol 1e-6, old and new alternating in each repetition so both meet the same
machine state. Prints, per scene, the declared states of each, the median wall times, their
ratio new/old and the largest difference of mesh[1].dte on a common grid (of its range).
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import fmpy
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))

import train_scene_compare as TS  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new", nargs="?", default=str(ROOT / "target" / "fmu" / "SpurGearTrain.fmu"))
    ap.add_argument("--scenes", default="single,planetary-simple")
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--stop-time", type=float, default=0.02)
    a = ap.parse_args(argv)
    fmus = [a.old, a.new]
    # Read and unpacked once: the runs time FMPy's instance and its integration only.
    mds = [fmpy.read_model_description(f) for f in fmus]
    n_states = [len(md.derivatives) for md in mds]
    dirs = [fmpy.extract(f) for f in fmus]
    print("| scene | states old / new | old [ms] | new [ms] | new / old | dte differs (of range) |")
    print("|---|---|---|---|---|---|")
    for name in a.scenes.split(","):
        sv = TS.load_scene(name)["start_values"]
        times, runs = [[], []], [None, None]
        for _ in range(a.reps):
            for k, d in enumerate(dirs):
                t0 = time.perf_counter()
                runs[k] = fmpy.simulate_fmu(d, model_description=mds[k], fmi_type="ModelExchange",
                                            stop_time=a.stop_time,
                                            relative_tolerance=1e-6, output_interval=1e-4,
                                            start_values=sv, output=["mesh[1].dte"])
                times[k].append(time.perf_counter() - t0)
        grid = np.linspace(0.0, a.stop_time, 201)
        old, new = (np.interp(grid, r["time"], r["mesh[1].dte"]) for r in runs)
        diff = np.max(np.abs(new - old)) / max(np.ptp(old), 1e-300)
        t_old, t_new = (statistics.median(t) for t in times)
        print(f"| {name} | {n_states[0]} / {n_states[1]} | {1e3 * t_old:.1f} | {1e3 * t_new:.1f} "
              f"| {t_new / t_old:.2f} | {diff:.1e} |")


if __name__ == "__main__":
    main()
