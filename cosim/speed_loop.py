"""The speed loop of cosim/SystemStructure.ssd run in real masters and in one process.

    controller.tau -> gear.tau_A,   gear.w_A -> controller.w_A

Masters (each returns a dict of NumPy arrays on the grid t_k = k h, k = 1..N, with 'time'):
  run_libcosim(gear_fmu, controller_fmu, params, h, t_stop)  libcosimpy's API: slaves, initial
                                                              values, connections, observer
  run_libcosim_ssp(ssp, h, t_stop)                            libcosim loading the .ssp itself
  run_fmpy_ssp(ssp, h, t_stop)                                fmpy.ssp.simulation.simulate_ssp

In one process, with the gear FMU through FMPy's low-level API and the PI law in Python:
  run_in_process(gear_fmu, params, h, t_stop, coupling="jacobi")  the masters' exact coupling
  run_in_process(gear_fmu, params, h, t_stop, coupling="direct")  the PI law evaluated at
      every (small) step without delay: as h -> 0 the continuous loop, the reference.

The coupling both masters use (Jacobi: all FMUs step from t_k to t_{k+1}, then outputs go to
inputs) and the controller's sampled law give, with e_k = r(t_k) - w_A(t_k),
    I_{k+1} = I_k + ki h e_k,   tau_{k+1} = sat(kp e_k + I_{k+1}),
and the gear holds tau_A = tau_k on [t_k, t_{k+1}): the torque lags the continuous law
tau_c = kp e + ki int e by 1 to 2 steps. See tests/python/test_cosim.py for the error bound.
"""

import math
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SSD = ROOT / "cosim" / "SystemStructure.ssd"
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
}
# What every run records: (component, variable).
RECORDED = [("gear", "w_A"), ("gear", "w_B"), ("gear", "dte"), ("controller", "tau"), ("controller", "integral")]


# ---- the system description -------------------------------------------------------------------


def ssd_parameters(ssd=SSD):
    """{component: {parameter: value}} from the inline ParameterBindings of the .ssd."""
    root = ET.parse(ssd).getroot()
    out = {}
    for comp in root.iterfind("ssd:System/ssd:Elements/ssd:Component", NS):
        values = out.setdefault(comp.get("name"), {})
        for p in comp.iterfind(".//ssv:ParameterSet/ssv:Parameters/ssv:Parameter", NS):
            real = p.find("ssv:Real", NS)
            if real is None:
                raise ValueError(f"{comp.get('name')}.{p.get('name')}: only Real parameters are used")
            values[p.get("name")] = float(real.get("value"))
    return out


def _grid(h, t_stop):
    n = int(round(t_stop / h))
    if not math.isclose(n * h, t_stop, rel_tol=1e-12):
        raise ValueError(f"t_stop = {t_stop} is not a multiple of h = {h}")
    return n


# ---- libcosim ---------------------------------------------------------------------------------


def _libcosim_series(execution, index_of, n, start):
    """Attaches a time-series observer, runs to n steps, returns the samples of steps 1..n."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimObserver import CosimObserver

    observer = CosimObserver.create_time_series(buffer_size=n + 16)
    if not execution.add_observer(observer):
        raise RuntimeError("libcosim: adding the observer failed")
    refs = {}
    for comp, name in RECORDED:
        slave = index_of[comp]
        vr = {v.name.decode(): v.reference for v in execution.slave_variables(slave)}[name]
        refs[comp, name] = (slave, vr)
        observer.start_time_series(slave, vr, CosimVariableType.REAL)
    start()
    out = {}
    for (comp, name), (slave, vr) in refs.items():
        # from_step=1: libcosimpy trims the sample arrays at step number 0.
        times, steps, values = observer.time_series_real_samples(slave, vr, from_step=1, sample_count=n)
        if list(steps) != list(range(1, n + 1)):
            raise RuntimeError(f"libcosim: {comp}.{name} has samples of steps {steps[:3]}..{steps[-3:]}")
        out[f"{comp}.{name}"] = np.array(values)
        out["time"] = np.array(times) * 1e-9
    return out


def _nanoseconds(x):
    ns = int(round(x * 1e9))
    if not math.isclose(ns * 1e-9, x, rel_tol=1e-12):
        raise ValueError(f"{x} s is not a whole number of nanoseconds (libcosim's time unit)")
    return ns


def run_libcosim(gear_fmu, controller_fmu, params, h, t_stop):
    """The loop built with libcosimpy's API: two local slaves, initial values from `params`
    ({component: {name: value}}), two real connections, a fixed step h."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimSlave import CosimLocalSlave

    n = _grid(h, t_stop)
    execution = CosimExecution.from_step_size(_nanoseconds(h))
    slaves = {
        "gear": CosimLocalSlave(fmu_path=str(gear_fmu), instance_name="gear"),
        "controller": CosimLocalSlave(fmu_path=str(controller_fmu), instance_name="controller"),
    }
    index_of = {name: execution.add_local_slave(s) for name, s in slaves.items()}
    if min(index_of.values()) < 0:
        raise RuntimeError(f"libcosim: adding the slaves failed: {index_of}")
    vrs = {
        comp: {v.name.decode(): v.reference for v in execution.slave_variables(i)} for comp, i in index_of.items()
    }
    for comp, values in params.items():
        for name, value in values.items():
            if not execution.real_initial_value(index_of[comp], vrs[comp][name], float(value)):
                raise RuntimeError(f"libcosim: setting {comp}.{name} failed")
    for (src, out), (dst, inp) in [(("controller", "tau"), ("gear", "tau_A")), (("gear", "w_A"), ("controller", "w_A"))]:
        status = execution.connect_real_variables(index_of[src], vrs[src][out], index_of[dst], vrs[dst][inp])
        if status != 0:
            raise RuntimeError(f"libcosim: connecting {src}.{out} -> {dst}.{inp} failed")

    def start():
        if not execution.simulate_until(_nanoseconds(t_stop)):
            raise RuntimeError("libcosim: the simulation failed")

    result = _libcosim_series(execution, index_of, n, start)
    result["_keep"] = (execution, slaves)  # the slaves must outlive the execution's use of them
    return result


def run_libcosim_ssp(ssp, h, t_stop):
    """The loop as libcosim loads it from the .ssp (parameters and connections from the .ssd)."""
    from libcosimpy.CosimExecution import CosimExecution

    n = _grid(h, t_stop)
    execution = CosimExecution.from_ssp_file(str(ssp), step_size=_nanoseconds(h))
    index_of = {info.name.decode(): info.index for info in execution.slave_infos()}

    def start():
        if not execution.simulate_until(_nanoseconds(t_stop)):
            raise RuntimeError("libcosim: the simulation failed")

    result = _libcosim_series(execution, index_of, n, start)
    result["_keep"] = execution
    return result


def libcosim_parameters(ssp, h=1e-4):
    """The parameter values libcosim applied from the .ssp, read back through an observer after
    one step: {component: {name: value}} for the names in the .ssd. (libcosim only logs a
    warning for a parameter it cannot apply.)"""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver

    execution = CosimExecution.from_ssp_file(str(ssp), step_size=_nanoseconds(h))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    execution.step(1)
    wanted = ssd_parameters()
    got = {}
    for info in execution.slave_infos():
        comp = info.name.decode()
        vrs = {v.name.decode(): v.reference for v in execution.slave_variables(info.index)}
        names = list(wanted[comp])
        values = observer.last_real_values(info.index, [vrs[n] for n in names])
        got[comp] = dict(zip(names, values))
    return got


# ---- FMPy SSP ---------------------------------------------------------------------------------


def run_fmpy_ssp(ssp, h, t_stop):
    """fmpy.ssp.simulation.simulate_ssp. It ignores the .ssd's ParameterBindings, so they are
    passed as its parameter_set (names 'component.variable'). It starts every connection at 0
    and records each row at the start time of the step with the values at its end: the rows
    are put on the grid t_{k+1} here."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet

    n = _grid(h, t_stop)
    parameter_set = ParameterSet(name="speed-loop")
    for comp, values in ssd_parameters().items():
        for name, value in values.items():
            p = Parameter(name=f"{comp}.{name}")
            p.type, p.value = "Real", value
            parameter_set.parameters.append(p)
    # A stop time half a step early: simulate_ssp accumulates time += h and runs while
    # time < stop_time, so the number of steps does not depend on the rounding of that sum.
    rows = simulate_ssp(str(ssp), stop_time=t_stop - 0.5 * h, step_size=h, parameter_set=parameter_set)
    if len(rows) != n:
        raise RuntimeError(f"simulate_ssp made {len(rows)} steps, expected {n}")
    out = {f"{c}.{v}": np.asarray(rows[f"{c}.{v}"], dtype=float) for c, v in RECORDED}
    out["time"] = h * np.arange(1, n + 1)
    return out


# ---- one process ------------------------------------------------------------------------------


def reference_speed(p, t):
    """r(t): ramp from 0 to w_ref in t_ramp, plus w_step from t_step on (SpeedController's
    w_r; the step is taken within 1e-9 s of t_step, like the FMU)."""
    ramp = min(max(t / p["t_ramp"], 0.0), 1.0) if p["t_ramp"] > 0 else 1.0
    return p["w_ref"] * ramp + (p["w_step"] if t >= p["t_step"] - 1e-9 * max(abs(p["t_step"]), 1.0) else 0.0)


def run_in_process(gear_fmu, params, h, t_stop, coupling="jacobi", record_every=1):
    """The loop in one process: the gear FMU through FMPy's FMU2Slave, the PI law in Python.

    coupling="jacobi": exactly what the masters do: the controller samples w_A(t_k), and its
        output tau_{k+1} = sat(kp e_k + I_{k+1}) reaches the gear one step later.
    coupling="direct": at each step tau_k = sat(kp e_k + I_k) drives the gear on [t_k, t_{k+1})
        at once (sample and hold without the extra delay); with a small h this is the
        continuous loop, the reference of the coupling error.

    Returns arrays on t_k = k h for k = record_every, 2 record_every, ..., N."""
    import fmpy
    from fmpy.fmi2 import FMU2Slave

    n = _grid(h, t_stop)
    md = fmpy.read_model_description(str(gear_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = fmpy.extract(str(gear_fmu))
    gear = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                     instanceName="gear")
    pc = params["controller"]
    kp, ki, tau_max = pc["kp"], pc["ki"], pc["tau_max"]

    def sat(v):
        return min(max(v, -tau_max), tau_max)

    try:
        gear.instantiate()
        gear.setupExperiment(startTime=0.0)
        names = list(params["gear"])
        gear.setReal([vr[k] for k in names], [params["gear"][k] for k in names])
        gear.enterInitializationMode()
        gear.exitInitializationMode()
        out_vrs = [vr["w_A"], vr["w_B"], vr["dte"]]
        w = gear.getReal([vr["w_A"]])[0]
        integral = 0.0
        tau = sat(kp * (reference_speed(pc, 0.0) - w))  # the controller's output at t = 0
        rec = {k: [] for k in ["time"] + [f"{c}.{v}" for c, v in RECORDED]}
        for k in range(n):
            t = k * h
            e = reference_speed(pc, t) - w
            if coupling == "direct":
                tau = sat(kp * e + integral)
            gear.setReal([vr["tau_A"]], [tau])
            gear.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            # The controller's update over the same step (conditional integration).
            cand = integral + ki * h * e
            v = kp * e + cand
            if not ((v > tau_max and e > 0) or (v < -tau_max and e < 0)):
                integral = cand
            if coupling == "jacobi":
                tau = sat(kp * e + integral)
            elif coupling != "direct":
                raise ValueError(coupling)
            w_a, w_b, dte = gear.getReal(out_vrs)
            w = w_a
            if (k + 1) % record_every == 0:
                rec["time"].append((k + 1) * h)
                rec["gear.w_A"].append(w_a)
                rec["gear.w_B"].append(w_b)
                rec["gear.dte"].append(dte)
                rec["controller.tau"].append(tau)
                rec["controller.integral"].append(integral)
        gear.terminate()
    finally:
        gear.freeInstance()
        shutil.rmtree(unzip, ignore_errors=True)
    return {k: np.array(v) for k, v in rec.items()}


def main():
    """Runs the .ssp built by cosim/build_ssp.py in both masters; writes one CSV per master
    next to it and prints how far apart they are."""
    import argparse

    ap = argparse.ArgumentParser(description="Run the speed loop in libcosim and in FMPy")
    ap.add_argument("ssp", nargs="?", default=str(ROOT / "target" / "cosim" / "speed-loop.ssp"))
    ap.add_argument("--step", type=float, default=1e-4, help="communication step [s]")
    ap.add_argument("--stop", type=float, default=0.3, help="stop time [s]")
    args = ap.parse_args()
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.WARNING)
    ssp = Path(args.ssp)
    runs = {
        "libcosim": run_libcosim_ssp(ssp, args.step, args.stop),
        "fmpy": run_fmpy_ssp(ssp, args.step, args.stop),
    }
    cols = ["time"] + [f"{c}.{v}" for c, v in RECORDED]
    for master, run in runs.items():
        path = ssp.with_name(f"{ssp.stem}-{master}.csv")
        np.savetxt(path, np.column_stack([run[c] for c in cols]), delimiter=",",
                   header=",".join(f'"{c}"' for c in cols), comments="", fmt="%.12g")
        print(f"{master}: w_A({args.stop}) = {run['gear.w_A'][-1]:.6f} rad/s -> {path}")
    diff = np.max(np.abs(runs["libcosim"]["gear.w_A"] - runs["fmpy"]["gear.w_A"]))
    print(f"max |w_A,libcosim - w_A,fmpy| = {diff:.3g} rad/s")


if __name__ == "__main__":
    main()
