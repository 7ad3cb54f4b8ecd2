"""The hybrid power-split device (scenes/train/power-split.toml) co-simulated from three FMUs
(issue 31 point 6; docs/power-split.md).

    engine (EngineTorque)     <--body[2].theta--  train (SpurGearTrain: the planetary set and the vehicle)
    engine --tau--> train.body[2].tau              train --body[1].w--> generator (SpeedController)
                                                   generator --tau--> train.body[1].tau

- train: the scene's planetary set as one SpurGearTrain, with the scene's start values as its
  parameter set: body 1 the sun (generator MG1), body 2 the carrier (engine), body 3 the ring,
  which carries the vehicle's reflected inertia (J 5) and the road drag (c 0.44709 N.m.s/rad)
  as the body's own drag, bodies 4-7 the planets.  The two torque inputs body[1].tau and
  body[2].tau come from the other FMUs.
- engine: EngineTorque on the carrier, tau = 100 + 20 sin(2 theta) N.m (a four-cylinder's
  firing ripple at engine order 2 on the scene's 100 N.m), theta the carrier's body[2].theta.
- generator: SpeedController on the sun: a PI law on the sun's speed with set point 300 rad/s
  (the scene's), kp = KP, ki = KI, |tau| <= TAU_MAX.  It samples w at the start of a step and
  changes its torque only in fmi2DoStep (no feedthrough).  It starts with a zero integral, so
  its first torque is 0 where the scene's static reaction is -27.78 N.m: the integral builds
  that reaction up over the first tens of milliseconds (the start transient).

Functions
  system()                       every component's parameters, from the scene
  write_ssd(path)                cosim/power-split.ssd (committed; generated)
  build_ssp(out)                 target/cosim/power-split.ssp (the .ssd and the three FMUs)
  run_master(h, t_stop, delay=, start=)   our own Jacobi master in this process (FMPy's FMU2Slave)
  run_libcosim_ssp, run_fmpy_ssp, run_omsimulator_ssp    the .ssp in each master
  balance(run, h, delay, first_step_zero)   the power balance and its bound (docs/power-split.md)
  willis(run)                    the Willis residual at every communication point and its bound
Every run returns {name: array}: "time" (n+1 communication points t_k = k h, t_0 = 0), the
train's outputs RECORDED (their names), and "held.sun", "held.carrier" (n values: the torque
the train held over [t_k, t_k+1]), "engine.tau" where the master shows it.

    python cosim/power_split.py ssd                # writes cosim/power-split.ssd
    python cosim/power_split.py ssp                # target/cosim/power-split.ssp
    python cosim/power_split.py run [--step 1e-4 --stop 0.1]   # every master, balance and Willis
    python cosim/power_split.py study              # docs/power-split.md's table (h = 2e-4, 1e-4, 5e-5 s)
"""

import math
import re
import shutil
import sys
import time as _time
import tomllib
import zipfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "cosim"))
import drivetrain as D  # noqa: E402  (oms_system_annotation, ssd_parameters, _fmt, _ns)

SCENE = ROOT / "scenes" / "train" / "power-split.toml"
SSD = ROOT / "cosim" / "power-split.ssd"
DEFAULT_SSP = ROOT / "target" / "cosim" / "power-split.ssp"
FMU_DIR = ROOT / "target" / "fmu"
SSD_NAME = "power_split"
STEP = 1e-4          # the communication step the .ssd proposes [s]
STOP = 0.1           # its stop time [s]
REL_TOL = 1e-9       # the train's integration tolerance
DYN = 100.0          # a bound on the ring meshes' dynamic factor (balance(): the road term's bound)
# the engine on the carrier: the scene's 100 N.m plus a firing ripple locked to the carrier angle
TAU_RIPPLE, ORDER, PHASE = 20.0, 2.0, 0.0
# the generator's PI law.  J_eff, the inertia the sun's torque sees with the carrier's torque
# given (the ring's J reflected through the set), is 0.0357 kg.m2 (j_eff()); kp = 10 gives the
# loop a time constant J_eff/kp = 3.6 ms and ki = 1000 a damping ratio kp/(2 sqrt(J_eff ki)) = 0.84.
# The sampled loop with its step of delay needs kp h / J_eff << 1: 0.028 at h = 1e-4 s.
KP, KI, TAU_MAX = 10.0, 1000.0, 200.0
SOURCES = {"train": "SpurGearTrain.fmu", "engine": "EngineTorque.fmu", "generator": "SpeedController.fmu"}
CONNECTIONS = [  # (start element, connector, end element, connector)
    ("train", "body[2].theta", "engine", "theta"), ("engine", "tau", "train", "body[2].tau"),
    ("train", "body[1].w", "generator", "w_A"), ("generator", "tau", "train", "body[1].tau"),
]
# the train's outputs every run records (besides the connected ones)
RECORDED = (["body[1].theta", "body[1].w", "body[2].theta", "body[2].w", "body[3].theta", "body[3].w"]
            + [f"body[{i}].w" for i in range(4, 8)]
            + ["E_kin", "E_el", "W_ext", "W_loss", "E_gate", "energy_residual"]
            + [f"mesh[{m}].dte" for m in range(1, 9)] + [f"mesh[{m}].F_bwd" for m in range(5, 9)])
# mesh[m].dte_rate is a local of the train; the .ssd shows it as an output connector (FMPy,
# libcosim and OMSimulator read it like an output) for the Willis check
DTE_RATES = [f"mesh[{m}].dte_rate" for m in range(1, 9)]
EXTRA_OUTPUTS = {"train": [n for n in RECORDED + DTE_RATES if n not in ("body[2].theta", "body[1].w")],
                 "engine": [], "generator": ["error", "integral"]}


def _scene():
    with open(SCENE, "rb") as f:
        return tomllib.load(f)


def system(rel_tol=REL_TOL):
    """{"train": its parameter set (the scene's start values, the inputs at the values they take
    at t = 0 in the co-simulation), "engine", "generator", "stop_time"}, from the scene."""
    sc = _scene()
    sv = dict(sc["start_values"])
    z_s, z_r = sv["mesh[1].zA"], sv["mesh[5].zB"]
    assert (sv["mesh[1].A"], sv["mesh[5].B"], sv["body[4].carrier"]) == (1, 3, 2), "sun 1, ring 3, carrier 2"
    tau_e, w_s = sv["body[2].tau"], sv["body[1].w_start"]
    # the scene's static reaction of the generator: tau_e z_s / (z_s + z_r), a brake
    assert math.isclose(sv["body[1].tau"], -tau_e * z_s / (z_s + z_r), rel_tol=1e-12)
    sv["rel_tol"] = rel_tol
    engine = {"tau_mean": tau_e, "tau_ripple": TAU_RIPPLE, "order": ORDER, "phase": PHASE}
    generator = {"w_ref": w_s, "t_ramp": 0.0, "kp": KP, "ki": KI, "tau_max": TAU_MAX,
                 "w_A": w_s}     # its input's start: the sun's speed, so its first torque is 0
    # the train's inputs at t = 0 are what the other two put out then (a master that does not
    # pass values at initialization starts with these)
    sv["body[1].tau"] = 0.0
    sv["body[2].tau"] = tau_e + TAU_RIPPLE * math.sin(PHASE)
    return {"train": sv, "engine": engine, "generator": generator, "stop_time": STOP,
            "z_s": z_s, "z_r": z_r}


def j_eff(sv=None):
    """The inertia the sun's torque sees when the carrier's torque is given: the 2x2 mass matrix
    of (w_sun, w_carrier), the ring w_r = (z_s w_s - (z_s + z_r) w_c)/z_r in forward senses,
    planets and orbital inertia included, reduced to the sun: M_ss - M_sc^2 / M_cc."""
    sv = sv or _scene()["start_values"]
    z_s, z_r, z_p = sv["mesh[1].zA"], sv["mesh[5].zB"], sv["mesh[1].zB"]
    m = sv["mesh[1].module"]
    R = m * (z_s + z_p) / 2      # nominal; the set's R is 54.94 mm with the shifts (2 % more)
    Js, Jc, Jr = sv["body[1].J"], sv["body[2].J"], sv["body[3].J"]
    planets = [i for i in range(4, 8)]
    Jc += sum(sv[f"body[{i}].m"] for i in planets) * R * R
    # planet spin relative to the carrier: rb_s (w_s - w_c) = rb_p u_p  (mesh 1, rigid)
    a, b = z_s / z_r, -(z_s + z_r) / z_r                 # w_r = a w_s + b w_c
    ps, pc = z_s / z_p, -z_s / z_p - 1.0                 # w_p = ps w_s + pc w_c (forward, absolute)
    Jp = sum(sv[f"body[{i}].J"] for i in planets)
    M = np.array([[Js + Jr * a * a + Jp * ps * ps, Jr * a * b + Jp * ps * pc],
                  [Jr * a * b + Jp * ps * pc, Jc + Jr * b * b + Jp * pc * pc]])
    return M[0, 0] - M[0, 1] ** 2 / M[1, 1]


# ---- the SSP ---------------------------------------------------------------------------------------

def _param_line(name, value, typ):
    if typ == "Boolean":
        v = "true" if value else "false"
    elif typ == "Integer":
        v = str(int(value))
    else:
        v = D._fmt(value)
    return f'                  <ssv:Parameter name="{name}"><ssv:{typ} value="{v}"/></ssv:Parameter>'


def _types(fmu):
    import fmpy

    return {v.name: v.type for v in fmpy.read_model_description(str(fmu)).modelVariables}


def write_ssd(path=SSD, rel_tol=REL_TOL):
    s = system(rel_tol)
    types = {c: _types(FMU_DIR / SOURCES[c]) for c in SOURCES}
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        "<!--",
        "  The hybrid power-split device of scenes/train/power-split.toml co-simulated from three FMUs",
        "  (generated by `python cosim/power_split.py ssd`; do not edit by hand; docs/power-split.md):",
        "    train (SpurGearTrain): the planetary set with the scene's parameters: body 1 the sun",
        "      (generator), body 2 the carrier (engine), body 3 the ring with the vehicle's reflected",
        "      inertia and the road drag as its drag, bodies 4-7 the planets;",
        f"    engine (EngineTorque): {s['engine']['tau_mean']:g} N.m plus {TAU_RIPPLE:g} N.m at engine order"
        f" {ORDER:g} on the carrier's angle body[2].theta, into body[2].tau;",
        f"    generator (SpeedController): PI on the sun's speed body[1].w, set point {s['generator']['w_ref']:g}"
        f" rad/s, kp {KP:g}, ki {KI:g},",
        f"      |tau| <= {TAU_MAX:g} N.m, into body[1].tau.",
        "  Names are identifiers and the system carries OMSimulator's org.openmodelica annotation (a",
        "  weakly coupled system with its fixed-step master), as cosim/two-stage.ssd does.",
        "-->",
        f'<ssd:SystemStructureDescription version="1.0" name="{SSD_NAME}"',
        '    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"',
        '    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"',
        '    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"',
        f'    xmlns:oms="{D.OMS_NS}"',
        '    xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations">',
        f'  <ssd:System name="{SSD_NAME}" description="A hybrid power-split device: engine on the carrier, '
        'speed-controlled generator on the sun, vehicle on the ring">',
        "    <ssd:Elements>",
    ]
    for comp in ("train", "engine", "generator"):
        lines.append(f'      <ssd:Component name="{comp}" type="application/x-fmu-sharedlibrary" '
                     f'source="resources/{SOURCES[comp]}">')
        lines.append("        <ssd:Connectors>")
        ins = [c[3] for c in CONNECTIONS if c[2] == comp]
        outs = [c[1] for c in CONNECTIONS if c[0] == comp] + EXTRA_OUTPUTS[comp]
        for n in ins:
            lines.append(f'          <ssd:Connector name="{n}" kind="input"><ssc:Real/></ssd:Connector>')
        for n in outs:
            lines.append(f'          <ssd:Connector name="{n}" kind="output"><ssc:Real/></ssd:Connector>')
        lines += ["        </ssd:Connectors>", "        <ssd:ParameterBindings>", "          <ssd:ParameterBinding>",
                  "            <ssd:ParameterValues>", f'              <ssv:ParameterSet version="1.0" name="{SSD_NAME}">',
                  "                <ssv:Parameters>"]
        for k, v in s[comp].items():
            lines.append(_param_line(k, v, types[comp][k]))
        lines += ["                </ssv:Parameters>", "              </ssv:ParameterSet>", "            </ssd:ParameterValues>",
                  "          </ssd:ParameterBinding>", "        </ssd:ParameterBindings>", "      </ssd:Component>"]
    lines.append("    </ssd:Elements>")
    lines.append("    <ssd:Connections>")
    for a, ca, b, cb in CONNECTIONS:
        lines.append(f'      <ssd:Connection startElement="{a}" startConnector="{ca}" endElement="{b}" endConnector="{cb}"/>')
    lines += ["    </ssd:Connections>"] + D.oms_system_annotation(STEP, rel_tol, "    ") + [
        "  </ssd:System>",
        f'  <ssd:DefaultExperiment startTime="0.0" stopTime="{D._fmt(s["stop_time"])}">',
        "    <ssd:Annotations>", '      <ssc:Annotation type="com.opensimulationplatform">',
        "        <osp:Algorithm>", f'          <osp:FixedStepAlgorithm baseStepSize="{STEP:g}"/>',
        "        </osp:Algorithm>", "      </ssc:Annotation>", "    </ssd:Annotations>",
        "  </ssd:DefaultExperiment>", "</ssd:SystemStructureDescription>", ""]
    Path(path).write_text("\n".join(lines))
    return Path(path)


def ssd_parameters(ssd=SSD):
    """{component: {name: value}} from the .ssd's ParameterBindings (drivetrain's reader)."""
    return D.ssd_parameters(ssd)


def fmu_paths():
    return {c: FMU_DIR / f for c, f in SOURCES.items()}


def build_ssp(out=DEFAULT_SSP, ssd=SSD):
    """Zips the .ssd (as SystemStructure.ssd) and the three FMUs of target/fmu into `out`."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.write(ssd, "SystemStructure.ssd")
        for f in sorted(set(SOURCES.values())):
            z.write(FMU_DIR / f, f"resources/{f}", compress_type=zipfile.ZIP_STORED)
    return out


# ---- our own master ---------------------------------------------------------------------------------

class Slave(D.Slave):
    """drivetrain.Slave with Boolean start values (the ring meshes' `internal`)."""

    def __init__(self, fmu, name, start):
        import fmpy
        from fmpy.fmi2 import FMU2Slave

        md = fmpy.read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.types = {v.name: v.type for v in md.modelVariables}
        self.unzip = fmpy.extract(str(fmu))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=self.unzip,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        for k, v in start.items():
            t = self.types[k]
            if t == "Integer":
                self.fmu.setInteger([self.vr[k]], [int(v)])
            elif t == "Boolean":
                self.fmu.setBoolean([self.vr[k]], [bool(v)])
            else:
                self.fmu.setReal([self.vr[k]], [float(v)])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()


def run_master(h, t_stop, delay=0, start="state", rel_tol=REL_TOL, fmus=None):
    """A fixed-step Jacobi master of our own on the three FMUs (held inputs).  At t_k the train
    takes the generator's torque of t_k (computed in its last step from the sun's speed at
    t_{k-1}: it has no feedthrough) and the engine's torque: with delay=0 the engine's law at
    theta(t_k) (the loop solved at the communication point, as OMSimulator does), with delay=1 its
    output read after its own step, the law at theta(t_{k-1}) (libcosim, FMPy).  start="fmpy":
    FMPy's simulate_ssp, which starts every connection at 0: the first step runs with zero
    torques, and the generator's first step samples w = 0 (its torque then saturates)."""
    s = system(rel_tol)
    f = fmus or fmu_paths()
    c0 = _time.process_time()
    tr = Slave(f["train"], "train", s["train"])
    en = Slave(f["engine"], "engine", s["engine"])
    ge = Slave(f["generator"], "generator", s["generator"])
    names = RECORDED + DTE_RATES
    refs = tr.refs(names)
    i_th2, i_w1 = names.index("body[2].theta"), names.index("body[1].w")
    vr_t1, vr_t2 = tr.vr["body[1].tau"], tr.vr["body[2].tau"]
    vr_th, (vr_te,) = en.vr["theta"], en.refs(["tau"])
    vr_w, (vr_tg,) = ge.vr["w_A"], ge.refs(["tau"])
    n = int(round(t_stop / h))
    rec = np.empty((n + 1, len(names)))
    held = np.empty((n, 2))
    eng = np.empty(n + 1)
    try:
        o = tr.fmu.getReal(refs)
        rec[0] = o
        en.fmu.setReal([vr_th], [o[i_th2]])
        te_prev = en.fmu.getReal([vr_te])[0]
        eng[0] = te_prev
        tg = ge.fmu.getReal([vr_tg])[0]
        for k in range(n):
            t = k * h
            en.fmu.setReal([vr_th], [o[i_th2] if not (start == "fmpy" and k == 0) else 0.0])
            te_now = en.fmu.getReal([vr_te])[0]
            te = te_now if delay == 0 else te_prev
            ts = tg
            if start == "fmpy" and k == 0:
                te = ts = 0.0
            held[k] = ts, te
            tr.fmu.setReal([vr_t1, vr_t2], [ts, te])
            ge.fmu.setReal([vr_w], [0.0 if (start == "fmpy" and k == 0) else o[i_w1]])
            tr.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            en.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            ge.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            te_prev = te_now
            tg = ge.fmu.getReal([vr_tg])[0]
            o = tr.fmu.getReal(refs)
            rec[k + 1] = o
            eng[k + 1] = te_now
    finally:
        for sl in (tr, en, ge):
            sl.close()
    out = {q: rec[:, i] for i, q in enumerate(names)}
    out["time"] = h * np.arange(n + 1)
    out["held.sun"], out["held.carrier"] = held[:, 0], held[:, 1]
    out["_cpu"] = _time.process_time() - c0
    return out


# ---- the standard masters on the .ssp ---------------------------------------------------------------

def run_libcosim_ssp(ssp, h, t_stop):
    """libcosim (libcosimpy) on the .ssp: it applies the .ssd's ParameterBindings; its
    fixed-step algorithm steps every FMU, then copies outputs to inputs, so the train holds over
    [t_k, t_k+1] the torques the engine and the generator showed at t_k (the engine's computed
    in its step from theta(t_{k-1})).  Observed: the train's RECORDED outputs and dte rates, the
    engine's and the generator's tau."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver

    c0 = _time.process_time()
    n = int(round(t_stop / h))
    ex = CosimExecution.from_ssp_file(str(ssp), step_size=D._ns(h))
    idx = {i.name.decode(): i.index for i in ex.slave_infos()}
    obs = CosimObserver.create_time_series(buffer_size=n + 16)
    ex.add_observer(obs)
    series = [("train", q) for q in RECORDED + DTE_RATES] + [("engine", "tau"), ("generator", "tau")]
    refs = []
    for comp, name in series:
        vr = {v.name.decode(): v.reference for v in ex.slave_variables(idx[comp])}[name]
        refs.append((idx[comp], vr))
        obs.start_time_series(idx[comp], vr, CosimVariableType.REAL)
    if not ex.simulate_until(D._ns(t_stop)):
        raise RuntimeError("libcosim: the simulation failed")
    out = {}
    for (comp, name), (slave, vr) in zip(series, refs):
        # sample k is the value at t_k (step 0: after initialization).  libcosimpy returns one
        # sample less than asked when asked from step 0: step 0 comes from a request for two
        t0, s0, v0 = (x[:1] for x in obs.time_series_real_samples(slave, vr, from_step=0, sample_count=2))
        times, steps, values = obs.time_series_real_samples(slave, vr, from_step=1, sample_count=n)
        if list(s0) + list(steps) != list(range(0, n + 1)):
            raise RuntimeError(f"libcosim: {name} has samples of steps {steps[:3]}..{steps[-3:]}")
        out[name if comp == "train" else f"{comp}.{name}"] = np.array(list(v0) + list(values))
        out["time"] = np.array(list(t0) + list(times)) * 1e-9
    out["held.sun"] = out["generator.tau"][:-1]
    out["held.carrier"] = out["engine.tau"][:-1]
    out["_cpu"] = _time.process_time() - c0
    return out


def run_fmpy_ssp(ssp, h, t_stop):
    """fmpy.ssp.simulation.simulate_ssp with the .ssd's parameters as its parameter_set (it does
    not read ParameterBindings).  A row is stamped with its step's start t_k and holds the values
    after the step and the connections: outputs at t_{k+1}, and the inputs the train holds over
    [t_{k+1}, t_{k+2}]; every connection starts at 0, so the first step holds zero torques.  The
    values at t = 0 are the train's start (from our own master's initialization: simulate_ssp
    records none)."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet

    c0 = _time.process_time()
    n = int(round(t_stop / h))
    ps = ParameterSet(name=SSD_NAME)
    for comp, values in ssd_parameters().items():
        for name, value in values.items():
            p = Parameter(name=f"{comp}.{name}")
            # FMPy's set_value takes Booleans as value != 0.0
            p.type = "Boolean" if isinstance(value, bool) else "Integer" if isinstance(value, int) else "Real"
            p.value = (1.0 if value else 0.0) if isinstance(value, bool) else value
            ps.parameters.append(p)
    rows = simulate_ssp(str(ssp), stop_time=t_stop - 0.5 * h, step_size=h, parameter_set=ps)
    if len(rows) != n:
        raise RuntimeError(f"simulate_ssp made {len(rows)} steps, expected {n}")
    first = _initial_values()
    out = {}
    for q in RECORDED + DTE_RATES:
        out[q] = np.concatenate([[first[q]], np.asarray(rows[f"train.{q}"], dtype=float)])
    out["time"] = h * np.arange(n + 1)
    out["held.sun"] = np.concatenate([[0.0], np.asarray(rows["train.body[1].tau"], dtype=float)[:-1]])
    out["held.carrier"] = np.concatenate([[0.0], np.asarray(rows["train.body[2].tau"], dtype=float)[:-1]])
    out["_cpu"] = _time.process_time() - c0
    return out


def _initial_values():
    s = system()
    tr = Slave(fmu_paths()["train"], "train", s["train"])
    try:
        return dict(zip(RECORDED + DTE_RATES, tr.fmu.getReal(tr.refs(RECORDED + DTE_RATES))))
    finally:
        tr.close()


def run_omsimulator_ssp(ssp, h, t_stop, oms=None):
    """OMSimulator (cosim/oms_run.py; None when it is not installed) on the .ssp at step h.  Its
    fixed-step master solves the loop train -> engine -> train (the engine is a direct
    feedthrough) at every communication point, so the train holds over [t_k, t_k+1] the engine's
    law at theta(t_k): run_master's delay=0.  Records every h; the train's inputs are read from
    its result (the last row of each time, the solved loop)."""
    import oms_run

    oms = oms or oms_run.find()
    if oms is None:
        return None
    import tempfile

    p = f"{SSD_NAME}.{SSD_NAME}."
    names = [p + "train." + q for q in RECORDED + DTE_RATES + ["body[1].tau", "body[2].tau"]]
    regex = "^(" + "|".join(re.escape(n) for n in names) + ")$"
    with tempfile.TemporaryDirectory() as work:
        res = oms_run.run_api(oms, ssp, t_stop, work, step=h, interval=h, signals=regex)
    n = int(round(t_stop / h))
    t = res.columns["time"]
    if len(t) != n + 1 or not np.allclose(t, h * np.arange(n + 1), rtol=0, atol=1e-9 * h):
        raise RuntimeError(f"OMSimulator wrote {len(t)} times, expected {n + 1} on a grid of {h}")
    out = {q: res.columns[p + "train." + q] for q in RECORDED + DTE_RATES if p + "train." + q in res.columns}
    out["time"] = t
    out["held.sun"] = res.columns[p + "train.body[1].tau"][:-1]
    out["held.carrier"] = res.columns[p + "train.body[2].tau"][:-1]
    out["_cpu"], out["_warnings"], out["_log"] = res.cpu, res.warnings, res.log
    return out


# ---- the checks ---------------------------------------------------------------------------------------

def gear_data():
    """Base radii and the ring's drag and inertia, from the scene through the reference model's
    geometry (the FMU's rAb/rBb are the same closed forms)."""
    sv = _scene()["start_values"]
    m, z_s, z_r = sv["mesh[1].module"], sv["mesh[1].zA"], sv["mesh[5].zB"]
    alpha0 = math.radians(sv.get("mesh[1].pressure_angle", 20.0))
    return {"z_s": z_s, "z_r": z_r, "m": m, "alpha0": alpha0,
            "rb_s": m * z_s * math.cos(alpha0) / 2, "rb_r": m * z_r * math.cos(alpha0) / 2,
            "c_r": sv["body[3].c"], "J_r": sv["body[3].J"]}


def balance(run, h, delay, first_step_zero=False, rel_tol=REL_TOL):
    """The power balance at every communication point t_k (all in J, since t = 0):

        W_engine = W_generator + dE + W_loss + W_road - E_gate + r

    W_engine   the engine's work by its law along the carrier's angle, in closed form:
               tau_m dtheta - (A/n) [cos(n theta + phase)] (no quadrature);
    W_generator the work the generator takes out: -sum_j tau_held,j (theta_s(t_j+1) - theta_s(t_j)),
               exact, as its torque is held over each step;
    dE         E_kin + E_el - their values at 0 (the train's outputs; the vehicle is the ring);
    W_loss     the meshes' losses (train), E_gate the elastic energy pairs bring into the gate;
    W_road     the road drag's work, c int w_r^2 dt, from the ring's mean speed over each step,
               wbar = (theta_r(t_j+1) - theta_r(t_j))/h, exact: int w^2 = wbar^2 h + int (w - wbar)^2.

    Bound on |r| (derived; nothing read off r):
      coupling: the train holds over [t_j, t_j+1] the engine's law at t_{j-d} (d = delay).  The
        mean torque does not change; the ripple's rate is at most A n |w_c|, so the held torque
        errs by at most A n W (t - t_{j-d}) and its work by A n W^2 h^2 (d + 1/2) per step,
        W = 1.01 max |w_c(t_k)| (the carrier's speed changes by < 1 % within a step);  FMPy's
        first step holds 0 instead of the law: (tau_m + A) W h more;
      road: the left-out c int (w - wbar)^2 lies in [0, c h (alpha h)^2] per step, with the ring's
        acceleration |alpha_r| <= (DYN tau_ring + c max|w_r|) / J_r, tau_ring the ring's static
        torque tau_e z_r / (z_s + z_r) and DYN = 100 a dynamic factor no spur mesh of this set
        reaches (checked at the points; the largest, FMPy's start kick, is about 10);
      integration: the train's states carry relative errors of about rel_tol: 10 rel_tol times
        the energies that flow (E_kin(0) + |W_engine| + |W_generator| + W_road).
    Also returned: "held", the same balance with the engine's work as the train received it
    (sum of the held torque times the carrier's angle increment), whose residual carries no
    coupling error: bounded by the road and integration terms alone; and "coupling", the
    coupling's share, W_engine - W_engine_held, exact from the points."""
    g = gear_data()
    th_c, th_s, w_c, w_r = run["body[2].theta"], run["body[1].theta"], run["body[2].w"], run["body[3].w"]
    tau_m, A, n_o, ph = system()["engine"]["tau_mean"], TAU_RIPPLE, ORDER, PHASE
    W_eng = tau_m * (th_c - th_c[0]) - (A / n_o) * (np.cos(n_o * th_c + ph) - math.cos(n_o * th_c[0] + ph))
    dth_s, dth_c = np.diff(th_s), np.diff(th_c)
    W_gen = -np.concatenate([[0.0], np.cumsum(run["held.sun"] * dth_s)])
    W_eng_held = np.concatenate([[0.0], np.cumsum(run["held.carrier"] * dth_c)])
    wbar = np.diff(run["body[3].theta"]) / h
    W_road = np.concatenate([[0.0], np.cumsum(g["c_r"] * wbar * wbar * h)])
    dE = run["E_kin"] - run["E_kin"][0] + run["E_el"] - run["E_el"][0]
    rest = dE + run["W_loss"] + W_road - run["E_gate"]
    r = W_eng - W_gen - rest
    r_held = W_eng_held - W_gen - rest
    steps = np.arange(len(th_c))
    W = 1.01 * float(np.max(np.abs(w_c)))
    b_coup = A * n_o * W * W * h * h * (delay + 0.5) * steps
    if first_step_zero:
        b_coup = b_coup + (tau_m + A) * W * h * (steps > 0)
    tau_ring = tau_m * g["z_r"] / (g["z_s"] + g["z_r"])
    F_static = tau_ring / (4 * g["rb_r"])
    F_pts = max(float(np.max(np.abs(run[f"mesh[{m}].F_bwd"]))) for m in range(5, 9))
    assert F_pts <= DYN * F_static, f"a ring mesh carries {F_pts:.4g} N > {DYN} x static {F_static:.4g} N"
    alpha_r = (DYN * tau_ring + g["c_r"] * float(np.max(np.abs(w_r)))) / g["J_r"]
    b_road = g["c_r"] * h * (alpha_r * h) ** 2 * steps
    b_int = 10 * rel_tol * (run["E_kin"][0] + np.abs(W_eng) + np.abs(W_gen) + W_road)
    return {"time": run["time"], "W_engine": W_eng, "W_engine_held": W_eng_held, "W_generator": W_gen,
            "dE": dE, "W_loss": run["W_loss"], "W_road": W_road, "E_gate": run["E_gate"],
            "r": r, "bound": b_coup + b_road + b_int, "r_held": r_held, "bound_held": b_road + b_int,
            "coupling": W_eng - W_eng_held, "bound_coupling": b_coup}


def willis(run, rounding=1e-13):
    """The Willis relation in the train's forward senses (sun -1, carrier -1, ring +1: the ring
    turns as the sun physically when the carrier is held, so its term changes sign against the
    physical z_s w_s + z_r w_r = (z_s + z_r) w_c):

        R = z_s w_s - z_r w_r - (z_s + z_r) w_c      [teeth rad/s]

    For planet n (sun mesh n, ring mesh n + 4), dte rates relative to the carrier: sun mesh
    rb_s (w_s - w_c) - rb_p u_n, ring mesh rb_p u_n - rb_r (w_r + w_c) (u_n the planet's forward
    speed relative to the carrier; rb_p cancels), and rb = m z cos(alpha0)/2 for every gear, so

        R = 2 (dte_rate[n] + dte_rate[n + 4]) / (m cos alpha0)     for every n = 1..4,

    and |R| <= (2 / (m cos alpha0)) min_n (|dte_rate[n]| + |dte_rate[n + 4]|): a rigid set has
    R = 0; the meshes' compliance (their dte rates) is all that R can be.  Returns R, the bound
    (plus `rounding` times the terms' size: 1e-13 for values in double precision, 2e-11 for
    OMSimulator's 12-digit result file) and, when the dte rates are in the run, the identity's
    largest defect over the planets."""
    g = gear_data()
    ws, wc, wr = run["body[1].w"], run["body[2].w"], run["body[3].w"]
    R = g["z_s"] * ws - g["z_r"] * wr - (g["z_s"] + g["z_r"]) * wc
    size = g["z_s"] * np.abs(ws) + g["z_r"] * np.abs(wr) + (g["z_s"] + g["z_r"]) * np.abs(wc)
    k = 2.0 / (g["m"] * math.cos(g["alpha0"]))
    out = {"time": run["time"], "R": R, "size": size}
    if "mesh[1].dte_rate" in run:
        per = [k * (run[f"mesh[{n}].dte_rate"] + run[f"mesh[{n + 4}].dte_rate"]) for n in range(1, 5)]
        mags = [k * (np.abs(run[f"mesh[{n}].dte_rate"]) + np.abs(run[f"mesh[{n + 4}].dte_rate"])) for n in range(1, 5)]
        out["defect"] = np.max([np.abs(R - p) for p in per], axis=0)
        out["bound"] = np.min(mags, axis=0) + rounding * size
    return out


OMS_ROUNDING = 2e-11  # OMSimulator's CSV: 12 significant digits


def summary(run, h, delay, first_step_zero=False, rounding=1e-13):
    b = balance(run, h, delay, first_step_zero)
    w = willis(run, rounding)
    s = {"W_engine": b["W_engine"][-1], "W_generator": b["W_generator"][-1], "dE": b["dE"][-1],
         "W_loss": b["W_loss"][-1], "W_road": b["W_road"][-1], "E_gate": b["E_gate"][-1],
         "max|r|": float(np.max(np.abs(b["r"]))), "bound": float(b["bound"][-1]),
         "max|r_held|": float(np.max(np.abs(b["r_held"]))), "bound_held": float(b["bound_held"][-1]),
         "coupling": float(b["coupling"][-1]),
         "max|R|": float(np.max(np.abs(w["R"]))), "R/size": float(np.max(np.abs(w["R"]) / w["size"]))}
    if "defect" in w:
        s["willis_defect/size"] = float(np.max(w["defect"] / w["size"]))
        s["willis_ok"] = bool(np.all(np.abs(w["R"]) <= w["bound"]))
    s["balance_ok"] = bool(np.all(np.abs(b["r"]) <= b["bound"]))
    s["balance_held_ok"] = bool(np.all(np.abs(b["r_held"]) <= b["bound_held"]))
    return s


MASTERS = (  # name, runner(ssp, h, t), delay, FMPy's zero start, rounding of its values
    ("own master (Jacobi, loop solved)", lambda ssp, h, t: run_master(h, t), 0, False, 1e-13),
    ("libcosim", run_libcosim_ssp, 1, False, 1e-13),
    ("FMPy simulate_ssp", run_fmpy_ssp, 1, True, 1e-13),
    ("OMSimulator", run_omsimulator_ssp, 0, False, OMS_ROUNDING),
)


def study(ssp=DEFAULT_SSP, steps=(2e-4, 1e-4, 5e-5), t_stop=STOP):
    """The table of docs/power-split.md: per master and step, the balance's terms and residuals
    against their bounds, and the Willis residual against its bound."""
    lines = ["| master | h [s] | W_engine | W_generator | dE | W_road | W_loss - E_gate | "
             "max abs r (bound) | max abs r_held (bound) | coupling share | max abs R (R / size) | "
             "Willis: identity defect / size, max abs R / bound | CPU s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, fn, delay, zero, rounding in MASTERS:
        for h in steps:
            run = fn(ssp, h, t_stop)
            if run is None:
                lines.append(f"| {name} | not installed | | | | | | | | | | | |")
                break
            b, w = balance(run, h, delay, zero), willis(run, rounding)
            lines.append(
                f"| {name} | {h:g} | {b['W_engine'][-1]:.2f} | {b['W_generator'][-1]:.2f} | {b['dE'][-1]:.3f} | "
                f"{b['W_road'][-1]:.2f} | {b['W_loss'][-1] - b['E_gate'][-1]:.2e} | "
                f"{np.max(np.abs(b['r'])):.3g} ({b['bound'][-1]:.3g}) | "
                f"{np.max(np.abs(b['r_held'])):.2g} ({b['bound_held'][-1]:.2g}) | {b['coupling'][-1]:.3g} | "
                f"{np.max(np.abs(w['R'])):.3g} ({np.max(np.abs(w['R']) / w['size']):.2g}) | "
                f"{np.max(w['defect'] / w['size']):.1e}, {np.max(np.abs(w['R']) / w['bound']):.3f} | "
                f"{run['_cpu']:.2f} |")
    return "\n".join(lines)


def main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("ssd", help="write cosim/power-split.ssd from the scene")
    b = sub.add_parser("ssp", help="zip the .ssd and target/fmu's FMUs into target/cosim/power-split.ssp")
    b.add_argument("--out", default=str(DEFAULT_SSP))
    r = sub.add_parser("run", help="run the .ssp in libcosim, FMPy and OMSimulator (if installed): balance and Willis")
    r.add_argument("ssp", nargs="?", default=str(DEFAULT_SSP))
    r.add_argument("--step", type=float, default=STEP)
    r.add_argument("--stop", type=float, default=STOP)
    sub.add_parser("study", help="docs/power-split.md's table: every master at h = 2e-4, 1e-4, 5e-5 s")
    a = ap.parse_args(argv)
    if a.cmd == "ssd":
        print(write_ssd())
    elif a.cmd == "ssp":
        print(build_ssp(a.out))
    elif a.cmd == "study":
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

        log_output_level(CosimLogLevel.WARNING)
        print(study())
    else:
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

        log_output_level(CosimLogLevel.WARNING)
        for master, fn, delay, zero, rounding in MASTERS:
            run = fn(a.ssp, a.step, a.stop)
            if run is None:
                print(f"{master}: not installed (docs/omsimulator.md)")
                continue
            s = summary(run, a.step, delay, zero, rounding)
            print(f"{master}: h = {a.step:g} s, 0 to {a.stop:g} s, CPU {run['_cpu']:.2f} s")
            print("  " + ", ".join(f"{k} {v:.6g}" if isinstance(v, float) else f"{k} {v}" for k, v in s.items()))


if __name__ == "__main__":
    sys.exit(main())
