"""What a gearbox FMU costs (gearbox-file.md §3, issue 37's cost section), through FMPy, each
figure the median of interleaved repetitions in one process (a noisy machine slows both sides of
a ratio alike):

1. default outputs: `simulate_fmu(NAME.fmu)` recording the gearbox's own outputs, against the same
   run recording four outputs (the spec's bound: 1.3 times);
2. one pair, all-in: the gearbox FMU of scenes/train/gearbox/single.toml against SpurGearMesh on
   the same pair (scenes/damped.toml), at 1 ms communication steps (bound: 1.1 times); and the
   same split in two: FMPy's unpacking of the FMU alone, and the run from the unpacked FMU;
3. Model Exchange: FMPy's CVode on the gearbox FMU against the same on SpurGearTrain with the
   scene's values, both at rtol 1e-6 (their difference is the integration error's: reported).

Usage: .venv/bin/python tools/bench_gearbox_fmu.py [--reps 7]   (packages what it needs; a few
minutes). Prints a Markdown table.
"""

import argparse
import statistics
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))


def packaged(*args):
    r = subprocess.run(["cargo", "run", "-q", "--release", "-p", "fmu-packaging", *args], cwd=ROOT,
                       capture_output=True, text=True, check=True)
    return r.stdout.strip().splitlines()[-1]


def timed(runs, reps):
    """Median seconds of each run, the runs interleaved `reps` times."""
    times = [[] for _ in runs]
    for _ in range(reps):
        for k, run in enumerate(runs):
            t = time.perf_counter()
            run()
            times[k].append(time.perf_counter() - t)
    return [statistics.median(t) for t in times]


def main(argv=None):
    import fmpy

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=7)
    a = ap.parse_args(argv)
    mesh = packaged("--bin", "package-fmu")
    train = packaged("--bin", "package-train")
    gb = {n: packaged("--bin", "package-train", "--", "--gearbox", str(ROOT / f"scenes/train/gearbox/{n}.toml"))
          for n in ("two-stage", "planetary-simple", "single")}
    rows = []

    # 1. Default outputs against four.
    for name in ("two-stage", "planetary-simple"):
        fmu = gb[name]
        md = fmpy.read_model_description(fmu)
        outs = [v.name for v in md.modelVariables if v.causality == "output"]
        four = [n for n in outs if n.endswith(".w")][:2] + [n for n in outs if n.endswith(".dte")][:2]
        stop = 0.05
        t_all, t_four = timed([lambda: fmpy.simulate_fmu(fmu, stop_time=stop, output_interval=1e-4),
                               lambda: fmpy.simulate_fmu(fmu, stop_time=stop, output_interval=1e-4, output=four)],
                              a.reps)
        rows.append((f"{name}: default outputs ({len(outs)}) / four", t_all, t_four, 1.3))

    # 2. One pair: the gearbox FMU of `single` against SpurGearMesh on damped.toml, 1 ms steps.
    damped = tomllib.load(open(ROOT / "scenes/damped.toml", "rb"))["start_values"]
    stop = 0.1
    t_gb, t_mesh = timed([lambda: fmpy.simulate_fmu(gb["single"], stop_time=stop, output_interval=1e-3),
                          lambda: fmpy.simulate_fmu(mesh, stop_time=stop, output_interval=1e-3, start_values=damped)],
                         a.reps)
    rows.append(("one pair: gearbox FMU (single) / SpurGearMesh (damped), 1 ms steps", t_gb, t_mesh, 1.1))
    # Where the difference is: FMPy unzips the FMU on every simulate_fmu call.
    import shutil
    unpacked = {k: fmpy.extract(f) for k, f in (("gb", gb["single"]), ("mesh", mesh))}
    md = {k: fmpy.read_model_description(f) for k, f in (("gb", gb["single"]), ("mesh", mesh))}
    t_gb, t_mesh = timed([lambda: shutil.rmtree(fmpy.extract(gb["single"])),
                          lambda: shutil.rmtree(fmpy.extract(mesh))], a.reps)
    rows.append(("one pair: unpacking the FMU alone (fmpy.extract)", t_gb, t_mesh, None))
    t_gb, t_mesh = timed([lambda: fmpy.simulate_fmu(unpacked["gb"], stop_time=stop, output_interval=1e-3,
                                                    model_description=md["gb"]),
                          lambda: fmpy.simulate_fmu(unpacked["mesh"], stop_time=stop, output_interval=1e-3,
                                                    start_values=damped, model_description=md["mesh"])],
                         a.reps)
    rows.append(("one pair: the run from the unpacked FMU, 1 ms steps", t_gb, t_mesh, 1.1))

    # 3. Model Exchange, CVode at rtol 1e-6: the gearbox FMU against SpurGearTrain.
    import scene_to_ssp as X

    for name in ("two-stage", "planetary-simple"):
        sv = X.load_scene(name)["start_values"]
        stop = 0.01
        md = fmpy.read_model_description(gb[name])
        dte = [v.name for v in md.modelVariables if v.causality == "output" and v.name.endswith(".dte")][0]
        res = {}

        def me(key, fmu, **kw):
            res[key] = fmpy.simulate_fmu(fmu, stop_time=stop, output_interval=1e-4, fmi_type="ModelExchange",
                                         relative_tolerance=1e-6, **kw)

        t_gb, t_train = timed([lambda: me("gb", gb[name], output=[dte]),
                               lambda: me("train", train, start_values=sv, output=["mesh[1].dte"])], max(3, a.reps // 2))
        grid = np.linspace(0, stop, 101)
        diff = np.max(np.abs(np.interp(grid, res["gb"]["time"], res["gb"][dte])
                             - np.interp(grid, res["train"]["time"], res["train"]["mesh[1].dte"])))
        span = np.ptp(res["train"]["mesh[1].dte"])
        rows.append((f"{name}: Model Exchange (CVode) gearbox FMU / SpurGearTrain; dte differs by {diff / span:.1e} of its range",
                     t_gb, t_train, None))

    print("| run | median [ms] | peer [ms] | ratio | bound |")
    print("|---|---|---|---|---|")
    for what, x, y, bound in rows:
        print(f"| {what} | {1e3 * x:.1f} | {1e3 * y:.1f} | {x / y:.2f} | {bound if bound else '(reported)'} |")


if __name__ == "__main__":
    main()
