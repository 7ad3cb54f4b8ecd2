"""The reduced lateral model for hardware in the loop (issue 36's cost section): a 4-planet set
with every member lateral and lumped meshes (7 bodies, 21 degrees of freedom: the state past the
compact capacity), through SpurGearTrain's Co-Simulation in FMPy at rel_tol 1e-6, against real
time (the bound: at least 5 times faster), and its cost per right-hand side against the same set
torsional (no body lateral, 7 coordinates, on the compact state).

The set is scenes/train/lateral-four-planet.toml (Lin & Parker's inertias, lumped meshes whose
stiffness varies, sun at 1104 rad/s, carrier at 300 rad/s) with sun, ring and carrier on 1e8 N/m
bearings too (5 % damping, as its planets'), run from its balance (the reference's static start,
tests/reference_model/lateral_ref.py). Each figure is the
median over interleaved repetitions in one process; the run excludes FMPy's unpacking. Two
figures per set: `simulate_fmu` (FMPy's whole loop: instantiation, the start values, recording
two outputs per step) and the doStep loop alone through FMPy's FMU2Slave (as a
hardware-in-the-loop master steps an FMU: the setup excluded).

Usage: .venv/bin/python tools/bench_hil_lateral.py [--reps 7] [--stop-time 0.2] [--varying] [--sine]
Prints a Markdown table.
"""

import argparse
import math
import statistics
import sys
import time
import tomllib
from pathlib import Path

import fmpy

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tests"))
import train_layout as TL  # noqa: E402
from bench_gearbox_fmu import packaged  # noqa: E402
from reference_model import lateral_ref as LR  # noqa: E402


def scenes(varies: bool):
    sc = tomllib.loads((ROOT / "scenes/train/lateral-four-planet.toml").read_text())
    sv = dict(sc["start_values"], rel_tol=1e-6)
    for k in range(1, 9):
        sv[f"mesh[{k}].k_lumped_varies"] = varies
    for i in (1, 2, 3):
        m, k = float(sv[f"body[{i}].m"]), 1e8
        c = 0.1 * math.sqrt(k * m)
        sv.update({f"body[{i}].lateral": True, f"body[{i}].k_x": k, f"body[{i}].k_y": k,
                   f"body[{i}].c_x": c, f"body[{i}].c_y": c})
    torsional = {k: v for k, v in sv.items() if k.rsplit(".", 1)[-1] not in TL.LATERAL_FIELDS}
    return {"lateral (21 DOF)": LR.static_start(sv), "torsional (7 DOF)": LR.static_start(torsional)}


def step_loop(unzip, md, sv, stop_time, sine=False, h=1e-3):
    """Seconds of the doStep loop alone through FMPy's FMU2Slave (what a hardware-in-the-loop
    master's loop costs beyond the FMU: a ctypes call per step, nothing recorded), the
    instantiation and initialization left out. `sine`: the sun's torque moves by 10 % as a
    10 Hz sine, set before every step (a master that moves an input every step restarts the
    integrator at every step)."""
    from fmpy.fmi2 import FMU2Slave
    from fmpy.simulation import apply_start_values

    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="hil")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0, stopTime=stop_time)
    apply_start_values(fmu, md, dict(sv))
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    n = round(stop_time / h)
    vr = next(v.valueReference for v in md.modelVariables if v.name == "body[1].tau")
    tau = float(sv["body[1].tau"])
    t0 = time.perf_counter()
    for k in range(n):
        if sine:
            fmu.setReal([vr], [tau * (1.0 + 0.1 * math.sin(2.0 * math.pi * 10.0 * k * h))])
        fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
    wall = time.perf_counter() - t0
    fmu.terminate()
    fmu.freeInstance()
    return wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--stop-time", type=float, default=0.2)
    ap.add_argument("--sine", action="store_true",
                    help="the doStep loop moves the sun's torque as a 10 Hz sine (an input change per step)")
    ap.add_argument("--varying", action="store_true",
                    help="the meshes' stiffness as the scene's square wave (an event per change)")
    a = ap.parse_args(argv)
    fmu = packaged("--bin", "package-train")
    md = fmpy.read_model_description(fmu)
    unzip = fmpy.extract(fmu)
    runs = scenes(a.varying)
    times = {name: [] for name in runs}
    loops = {name: [] for name in runs}
    evals = {}
    for _ in range(a.reps):
        for name, sv in runs.items():
            loops[name].append(step_loop(unzip, md, sv, a.stop_time, a.sine))
            t0 = time.perf_counter()
            res = fmpy.simulate_fmu(unzip, model_description=md, start_values=sv,
                                    stop_time=a.stop_time, output_interval=1e-3,
                                    output=["n_rhs_evaluations", "n_steps"])
            times[name].append(time.perf_counter() - t0)
            evals[name] = (int(res["n_rhs_evaluations"][-1]), int(res["n_steps"][-1]))
    stiffness = "square wave" if a.varying else "constant"
    print(f"simulated {a.stop_time} s at 1 ms communication steps, rel_tol 1e-6, mesh stiffness "
          f"{stiffness}, median of {a.reps}" + ("; the doStep loop with the sun's torque a 10 Hz sine" if a.sine else "")
          + "\n")
    print("| set | wall [s] | faster than real time | doStep loop alone [s] | faster than real time | steps "
          "| rhs evaluations | us per rhs |")
    print("|---|---|---|---|---|---|---|---|")
    per = {}
    for name in runs:
        w, loop = statistics.median(times[name]), statistics.median(loops[name])
        n, steps = evals[name]
        per[name] = w / n
        print(f"| {name} | {w:.4f} | {a.stop_time / w:.1f}x | {loop:.4f} | {a.stop_time / loop:.1f}x | {steps} | {n} "
              f"| {1e6 * w / n:.2f} |")
    lat, tor = per.values()
    print(f"\ncost per right-hand side, lateral / torsional: {lat / tor:.2f} "
          "(the whole run's wall time per evaluation: FMPy's loop included)")


if __name__ == "__main__":
    main()
