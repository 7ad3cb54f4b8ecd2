"""The two-stage drivetrain (issue 24) as a co-simulation of four FMUs, and as one FMU.

    engine (EngineTorque)  <--theta_A--  gear1 (SpurGearMesh, stage 1: 20/40)  --theta_B, w_B-->  shaft (TorsionalShaft)  <--theta_A, w_A--  gear2 (stage 2: 18/45)
    engine --tau--> gear1.tau_A     gear1.tau_B  <--tau_a--  shaft  --tau_b-->  gear2.tau_A

The physics is scenes/train/two-stage-firing.toml (the train's two-stage reducer with standard gear
data, driven by an engine): drive 50 N.m with a 20 N.m ripple at engine order 2, locked to stage
1's pinion angle (EngineTorque into gear1.tau_A; the train's body[1].tau with body[1].tau_ripple),
load -150 N.m plus drag 10/3 N.m.s/rad on stage 2's wheel (gear2.tau_B, gear2.c_load), the
intermediate shaft k = 1e5 N.m/rad,
d = 5 N.m.s/rad between stage 1's wheel and stage 2's pinion, chi = 10 s/m in both meshes, and the
quasi-static running start of that scene (rigid speed ratios, each mesh at its static penetration,
the shaft pre-twisted by its 100 N.m).

The monolithic reference is SpurGearTrain with the same four bodies, two meshes and one shaft,
placed so that each mesh's tooth pairs start where the single-mesh FMU starts its own (f1 at point
a, then wheel A turned by dte_start, gear-train.md sections 3-4):
  body[1].angle_start = X_1,          X_m = alpha_w - s_a/rAb + tA/2 - dte_start/rAb of mesh m;
  mesh[2].mount_A     = beta_2 - psi_3(0) - X_2   (body 3 turns counter-clockwise forward, so
                        mesh 2's frame is mirrored: chi_A = -(psi_3 + mount_A - beta_2) = X_2).
The single mesh starts theta_A at dte_start/rAb, theta_B at 0; the train starts all angles at 0.
So the shaft FMU's twist_start is the train's plus gear2's theta_A(0) = dte_start_2/rAb_2: its
twist theta_a - theta_b + twist_start is then the train's shaft[1].twist at every time.  Likewise
the engine's phase is the train's ripple_phase minus order * gear1's theta_A(0): its crank angle
is gear1's theta_A, which runs dte_start_1/rAb_1 ahead of the train's body[1].theta.

Functions
  system()                          every parameter of both set-ups, from the scene
  write_ssd(path)                   cosim/two-stage.ssd (generated from system(); committed)
  build_ssp(out)                    target/cosim/two-stage.ssp: the .ssd and the FMUs it uses
  run_monolithic(train_fmu, t_stop, dt_out)             the train FMU, one FMU, CS
  run_master(h, t_stop, ...)        a fixed-step master of our own (Jacobi or Gauss-Seidel,
                                    held inputs or input derivatives); it evaluates the shaft's
                                    and the engine's laws itself
  run_libcosim_ssp(ssp, h, t_stop), run_fmpy_ssp(ssp, h, t_stop)   the real masters on the .ssp
  run_omsimulator_ssp(ssp, h, t_stop)                  OMSimulator on the .ssp, if installed
Every run returns {name: array} on its output grid with "time"; the common names are
mesh1.dte, mesh2.dte, shaft.tau (the torque the shaft transmits, = train shaft[1].tau),
w1, w2, w3, w4 (body speeds, forward positive).
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
SCENE = ROOT / "scenes" / "train" / "two-stage-firing.toml"
# the same drivetrain with a constant drive: the stability sweeps run it (docs/cosim.md)
STEADY_SCENE = ROOT / "scenes" / "train" / "two-stage.toml"
SSD = ROOT / "cosim" / "two-stage.ssd"
FMU_DIR = ROOT / "target" / "fmu"
DEFAULT_SSP = ROOT / "target" / "cosim" / "two-stage.ssp"
QUANTITIES = ["mesh1.dte", "mesh2.dte", "shaft.tau", "w1", "w2", "w3", "w4"]
# the integration tolerance of every FMU in both set-ups, tighter than the default 1e-6 so that
# the coupling error dominates down to the smallest step (docs/cosim.md)
REL_TOL = 1e-9


def _scene(scene=SCENE):
    with open(scene, "rb") as f:
        return tomllib.load(f)


def system(rel_tol=REL_TOL, scene=SCENE):
    """{"train": start values of SpurGearTrain, "gear1"/"gear2"/"shaft"/"engine": FMU start values
    (inputs that are not connected included), "stop_time": the scene's}.  Derived, never typed:
    from the scene (default scenes/train/two-stage-firing.toml) and the reference model's
    geometry and placement."""
    sys.path.insert(0, str(ROOT / "tests"))
    from reference_model import train_ref as T

    sc = _scene(scene)
    sv = dict(sc["start_values"])
    sv["mesh[2].center_angle"] = float(sv.get("mesh[2].center_angle", 0.0))
    sv["body[1].angle_start"] = 0.0
    sv["rel_tol"] = rel_tol
    tr = T.GearTrain(sv)

    def X(mesh):
        g = mesh.g
        return g.alpha_w - g.s_a / g.rAb + g.tA / 2 - mesh.dte0 / g.rAb

    m1, m2 = tr.meshes
    sv["body[1].angle_start"] = X(m1)
    tr = T.GearTrain(sv)
    assert tr.sigma[2] == +1, "body 3 turns counter-clockwise forward (two meshes... one flip)"
    sv["mesh[2].mount_A"] = m2.beta - tr.psi0[2] - X(m2)
    tr = T.GearTrain(sv)
    # the check: each mesh's chi_A(0) is X_m modulo A's tooth pitch
    for m, mesh in zip((1, 2), tr.meshes):
        chi = mesh.chi_of(tr.psi0[mesh.A], mesh.mount_A)
        dz = 2 * math.pi / mesh.g.zA
        r = (chi - X(mesh)) / dz
        assert abs(r - round(r)) < 1e-9, (m, chi, X(mesh))

    def gear(m, mesh):
        a, b = m1.A if m == 1 else m2.A, m1.B if m == 1 else m2.B
        p = {k: sv[f"mesh[{m}].{k}"] for k in ("geometry", "module", "zA", "zB", "chi", "dte_start")}
        p.update({"J_A": sv[f"body[{a + 1}].J"], "J_B": sv[f"body[{b + 1}].J"],
                  "c_load": sv[f"body[{b + 1}].c"], "w_A_start": sv[f"body[{a + 1}].w_start"],
                  "w_B_start": sv[f"body[{b + 1}].w_start"], "rel_tol": rel_tol})
        assert sv[f"body[{a + 1}].c"] == 0.0, "the single mesh has no drag on A"
        return p

    g1, g2 = gear(1, m1), gear(2, m2)
    g2["tau_B"] = sv["body[4].tau"]          # the load's constant part
    assert sv["body[2].tau"] == sv["body[3].tau"] == 0.0
    assert not any(sv.get(f"body[{i}].tau_ripple") for i in (2, 3, 4)), "the engine drives body 1 only"
    shaft = {"k": sv["shaft[1].k"], "d": sv["shaft[1].d"],
             "twist_start": sv["shaft[1].twist_start"] + m2.dte0 / m2.g.rAb}
    # the drive on gear1.tau_A: the train's body[1] law on gear1's theta_A = theta_1 + theta_A(0)
    order = sv.get("body[1].ripple_order", 0.0)
    engine = {"tau_mean": sv["body[1].tau"], "tau_ripple": sv.get("body[1].tau_ripple", 0.0),
              "order": order,
              "phase": sv.get("body[1].ripple_phase", 0.0) - order * m1.dte0 / m1.g.rAb}
    return {"train": sv, "gear1": g1, "gear2": g2, "shaft": shaft, "engine": engine,
            "stop_time": sc["stop_time"], "rAb2": m2.g.rAb}


def drive(e, theta, w, alpha):
    """The engine's torque at crank angle theta (the FMU's law, in its order) and its first two
    time derivatives at speed w and acceleration alpha."""
    arg = e["order"] * theta + e["phase"]
    a, n = e["tau_ripple"], e["order"]
    return (e["tau_mean"] + a * math.sin(arg), a * n * math.cos(arg) * w,
            a * n * (math.cos(arg) * alpha - n * math.sin(arg) * w * w))


# ---- the SSP ------------------------------------------------------------------------------------

CONNECTIONS = [  # (start element, connector, end element, connector)
    ("gear1", "theta_A", "engine", "theta"), ("engine", "tau", "gear1", "tau_A"),
    ("gear1", "theta_B", "shaft", "theta_a"), ("gear1", "w_B", "shaft", "w_a"),
    ("gear2", "theta_A", "shaft", "theta_b"), ("gear2", "w_A", "shaft", "w_b"),
    ("shaft", "tau_a", "gear1", "tau_B"), ("shaft", "tau_b", "gear2", "tau_A"),
]
SOURCES = {"gear1": "SpurGearMesh.fmu", "gear2": "SpurGearMesh.fmu", "shaft": "TorsionalShaft.fmu",
           "engine": "EngineTorque.fmu"}
# connectors each component shows besides the connected ones (outputs the runs record)
EXTRA_OUTPUTS = {"gear1": ["w_A", "dte", "F_fwd"], "gear2": ["w_B", "dte", "F_fwd"], "shaft": [], "engine": []}


def _fmt(v):
    return repr(float(v))


# The .ssd's name and its system's: OMSimulator takes both as identifiers ([a-zA-Z][a-zA-Z0-9_]*)
# and refuses "two-stage" (`"two-stage" is not a valid ident`).
SSD_NAME = "two_stage"
# the communication step the .ssd proposes (libcosim's baseStepSize, OMSimulator's stepSize)
STEP = 1e-5
OMS_NS = "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"
# OMSimulator's absoluteTolerance: for its fixed-step master, the bound on the unscaled 2-norm of
# the algebraic loop's residual (KINSOL's fnormtol), in the loop's own units (N.m, rad, rad/s).
# At 1e-9 about 7 % of the steps miss it by rounding (warnings); 1e-7 is met at every step of the
# scene and sits six orders below the coupling's own torque error (docs/omsimulator.md).
LOOP_TOL = 1e-6


def oms_system_annotation(step, rel_tol, indent):
    """The lines of an ssd:Annotations for an ssd:System (after its Connections, as the SSP 1.0
    schema orders them) that OMSimulator needs: it reads the system's type only from its own
    annotation, and without one its import of an .ssp ends in `internal error`.  oms:FixedStepMaster
    makes the system weakly coupled (FMI co-simulation) with its fixed-step master "oms-ma" at
    `step`; relativeTolerance is what it passes to fmi2SetupExperiment (our FMUs take the tighter
    of it and their rel_tol), absoluteTolerance its algebraic loop's tolerance (LOOP_TOL).  Other
    tools skip annotations of types they do not know."""
    i = indent
    return [f"{i}<ssd:Annotations>",
            f'{i}  <ssc:Annotation type="org.openmodelica">',
            f"{i}    <oms:Annotations>",
            f"{i}      <oms:SimulationInformation>",
            f'{i}        <oms:FixedStepMaster description="oms-ma" stepSize="{step:g}" '
            f'absoluteTolerance="{LOOP_TOL:g}" relativeTolerance="{rel_tol:g}"/>',
            f"{i}      </oms:SimulationInformation>",
            f"{i}    </oms:Annotations>",
            f"{i}  </ssc:Annotation>",
            f"{i}</ssd:Annotations>"]


def write_ssd(path=SSD, rel_tol=REL_TOL):
    s = system(rel_tol)
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        "<!--",
        "  The two-stage drivetrain of issue 24 (generated by `python cosim/drivetrain.py ssd` from",
        "  scenes/train/two-stage-firing.toml; do not edit by hand). Four FMUs:",
        "    engine (EngineTorque): 50 N.m plus 20 N.m at engine order 2 on gear1's pinion angle theta_A;",
        "    gear1 (SpurGearMesh, stage 1, 20/40): the engine's torque on its pinion, tau_A;",
        "    shaft (TorsionalShaft, k 1e5 N.m/rad, d 5 N.m.s/rad) between gear1's wheel B and gear2's wheel A;",
        "    gear2 (SpurGearMesh, stage 2, 18/45): the load tau_B = -150 N.m and c_load = 10/3 N.m.s/rad.",
        "  Quasi-static running start. The shaft's twist_start includes gear2.theta_A(0) = dte_start/rAb",
        "  (the single mesh starts theta_A there), so the twist equals the monolithic train's; the",
        "  engine's phase is shifted by order * gear1.theta_A(0) for the same reason.",
        "  Build the .ssp with `python cosim/drivetrain.py ssp`; see docs/cosim.md.",
        f"  The names are identifiers ({SSD_NAME}: OMSimulator refuses others). The system's",
        "  org.openmodelica annotation tells OMSimulator it is a weakly coupled system with a",
        "  fixed-step master (without it its import ends in an internal error); other tools ignore",
        "  it. The com.opensimulationplatform one gives libcosim the same step (docs/omsimulator.md).",
        "-->",
        f'<ssd:SystemStructureDescription version="1.0" name="{SSD_NAME}"',
        '    xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"',
        '    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon"',
        '    xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"',
        f'    xmlns:oms="{OMS_NS}"',
        '    xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations">',
        f'  <ssd:System name="{SSD_NAME}" description="An engine driving two spur gear stages joined by a compliant shaft">',
        "    <ssd:Elements>",
    ]
    for comp in ("engine", "gear1", "shaft", "gear2"):
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
                  "            <ssd:ParameterValues>", '              <ssv:ParameterSet version="1.0" name="two-stage">',
                  "                <ssv:Parameters>"]
        for k, v in s[comp].items():
            typ = "Integer" if k in ("geometry", "zA", "zB") else "Real"
            val = str(int(v)) if typ == "Integer" else _fmt(v)
            lines.append(f'                  <ssv:Parameter name="{k}"><ssv:{typ} value="{val}"/></ssv:Parameter>')
        lines += ["                </ssv:Parameters>", "              </ssv:ParameterSet>", "            </ssd:ParameterValues>",
                  "          </ssd:ParameterBinding>", "        </ssd:ParameterBindings>", "      </ssd:Component>"]
    lines.append("    </ssd:Elements>")
    lines.append("    <ssd:Connections>")
    for a, ca, b, cb in CONNECTIONS:
        lines.append(f'      <ssd:Connection startElement="{a}" startConnector="{ca}" endElement="{b}" endConnector="{cb}"/>')
    lines += ["    </ssd:Connections>"] + oms_system_annotation(STEP, rel_tol, "    ") + [
        "  </ssd:System>",
        f'  <ssd:DefaultExperiment startTime="0.0" stopTime="{_fmt(s["stop_time"])}">',
        "    <ssd:Annotations>", '      <ssc:Annotation type="com.opensimulationplatform">',
        "        <osp:Algorithm>", f'          <osp:FixedStepAlgorithm baseStepSize="{STEP:g}"/>',
        "        </osp:Algorithm>", "      </ssc:Annotation>", "    </ssd:Annotations>",
        "  </ssd:DefaultExperiment>", "</ssd:SystemStructureDescription>", ""]
    Path(path).write_text("\n".join(lines))
    return Path(path)


def ssd_parameters(ssd=SSD):
    """{component: {name: value}} from the .ssd's ParameterBindings, Booleans included."""
    import xml.etree.ElementTree as ET

    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
          "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues"}
    out = {}
    for comp in ET.parse(ssd).getroot().iterfind("ssd:System/ssd:Elements/ssd:Component", ns):
        vals = out.setdefault(comp.get("name"), {})
        for p in comp.iterfind(".//ssv:Parameter", ns):
            for typ, conv in (("Real", float), ("Integer", int), ("Boolean", lambda x: x == "true")):
                e = p.find(f"ssv:{typ}", ns)
                if e is not None:
                    vals[p.get("name")] = conv(e.get("value"))
    return out


def fmu_paths():
    return {"gear": FMU_DIR / "SpurGearMesh.fmu", "shaft": FMU_DIR / "TorsionalShaft.fmu",
            "train": FMU_DIR / "SpurGearTrain.fmu", "engine": FMU_DIR / "EngineTorque.fmu"}


def build_ssp(out=DEFAULT_SSP, ssd=SSD):
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    f = fmu_paths()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.write(ssd, "SystemStructure.ssd")
        z.write(f["gear"], "resources/SpurGearMesh.fmu", compress_type=zipfile.ZIP_STORED)
        z.write(f["shaft"], "resources/TorsionalShaft.fmu", compress_type=zipfile.ZIP_STORED)
        z.write(f["engine"], "resources/EngineTorque.fmu", compress_type=zipfile.ZIP_STORED)
    return out


# ---- FMUs in this process ------------------------------------------------------------------------

class Slave:
    """An FMI 2.0 CS instance through FMPy's FMU2Slave, with names."""

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
            if self.types[k] == "Integer":
                self.fmu.setInteger([self.vr[k]], [int(v)])
            else:
                self.fmu.setReal([self.vr[k]], [float(v)])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def refs(self, names):
        return [self.vr[n] for n in names]

    def close(self):
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()
            shutil.rmtree(self.unzip, ignore_errors=True)


def run_monolithic(train_fmu, t_stop, dt_out, rel_tol=REL_TOL, extra=(), scene=SCENE):
    """SpurGearTrain alone, stepped at the output interval (its inputs are constant, so the
    internal integration does not see the communication points).  Returns the run and its wall
    time in "_seconds" (instantiation included)."""
    s = system(rel_tol, scene)
    t0 = _time.perf_counter()
    c0 = _time.process_time()
    tr = Slave(train_fmu, "train", {k: v for k, v in s["train"].items()})
    names = ["mesh[1].dte", "mesh[2].dte", "shaft[1].tau", "body[1].w", "body[2].w", "body[3].w", "body[4].w"]
    names += list(extra)
    refs = tr.refs(names)
    n = int(round(t_stop / dt_out))
    rec = np.empty((n + 1, len(names)))
    rec[0] = tr.fmu.getReal(refs)
    for k in range(n):
        tr.fmu.doStep(currentCommunicationPoint=k * dt_out, communicationStepSize=dt_out)
        rec[k + 1] = tr.fmu.getReal(refs)
    tr.close()
    out = {q: rec[:, i] for i, q in enumerate(QUANTITIES + list(extra))}
    out["time"] = dt_out * np.arange(n + 1)
    out["_seconds"] = _time.perf_counter() - t0
    out["_cpu"] = _time.process_time() - c0
    return out


def run_master(h, t_stop, scheme="jacobi", derivatives=0, dt_out=None, rel_tol=REL_TOL, fmus=None,
               blowup=1e7, delay=0, start="state", scene=SCENE):
    """A fixed-step master of our own on the two gear FMUs; it evaluates the two direct
    feedthroughs, the shaft's and the engine's laws, itself (the SSP runs show the FMUs give
    the same values).

    scheme="jacobi": at t_k every gear's outputs go through the shaft and the engine (direct
        feedthroughs, evaluated at once) to the gears' inputs; both gears step to t_k + h.  The order-1 coupling
        the standard masters intend (libcosim and FMPy add one step of delay: docs/cosim.md).
    scheme="gauss-seidel": gear1 steps first; the shaft torque for gear2's step is the law with
        gear1's new state (t_{k+1}) and gear2's old one (t_k), as a sequential master passes the
        newest outputs; the twist then mixes two times (an error of about k w h: docs/cosim.md).
    derivatives=1: with each torque, its time derivative through fmi2SetRealInputDerivatives
        (order 1), from the shaft law: d tau/dt = k (w_a - w_b) + d (alpha_a - alpha_b), the
        accelerations from each wheel's torque balance J alpha = tau_mesh + tau_in - c w; the
        engine's d tau/dt = A n cos(n theta + phase) w.  derivatives=2 adds the second
        derivatives, k (alpha_a - alpha_b) and the engine's (drive()).
    delay=1 (Jacobi, held inputs): the torques over [t_k, t_k+1] are the laws at t_{k-1},
        what libcosim and FMPy's simulate_ssp do with a direct-feedthrough FMU between two others
        (they read the shaft's outputs after its step, computed from the inputs set before it).
        start="state": the first two steps take the law at t_0 (libcosim); start="fmpy": the
        first step has zero torques and the second the laws at zero inputs, k twist_start and
        tau_mean + tau_ripple sin(phase) (simulate_ssp starts every connection at 0).
    scene: the drivetrain's scene (STEADY_SCENE: the constant drive).
    Records on the grid dt_out (default: max(h, 1e-4)); stops early (and sets "_unstable") when
    the shaft torque exceeds blowup.  "_seconds": wall time, "_cpu": CPU time (after system())."""
    s = system(rel_tol, scene)
    t0 = _time.perf_counter()
    c0 = _time.process_time()
    f = fmus or fmu_paths()
    g1 = Slave(f["gear"], "gear1", s["gear1"])
    g2 = Slave(f["gear"], "gear2", s["gear2"])
    k_s, d_s, tw = s["shaft"]["k"], s["shaft"]["d"], s["shaft"]["twist_start"]
    p1, p2 = s["gear1"], s["gear2"]
    names = ["theta_A", "w_A", "theta_B", "w_B", "dte", "tau_mesh_A", "tau_mesh_B"]
    r1, r2 = g1.refs(names), g2.refs(names)
    vr_tauB1, vr_tauA2, vr_tauA1 = g1.vr["tau_B"], g2.vr["tau_A"], g1.vr["tau_A"]
    e = s["engine"]
    dt_out = dt_out or max(h, 1e-4)
    every = int(round(dt_out / h))
    n = int(round(t_stop / h))
    assert abs(n * h - t_stop) < 1e-9 * t_stop and abs(every * h - dt_out) < 1e-9 * dt_out, (h, t_stop, dt_out)
    rows = []
    unstable = False

    def shaft(o1, o2):
        # o = theta_A, w_A, theta_B, w_B, dte, tau_mesh_A, tau_mesh_B; the torque and its first two
        # rates (the accelerations with this torque acting: it depends on the state alone)
        twist = o1[2] - o2[0] + tw
        dw = o1[3] - o2[1]
        tau = k_s * twist + d_s * dw
        a_a = (o1[6] - tau - p1["c_load"] * o1[3]) / p1["J_B"]     # gear1's wheel B
        a_b = (o2[5] + tau) / p2["J_A"]                              # gear2's wheel A (no drag on A)
        return tau, k_s * dw + d_s * (a_a - a_b), k_s * (a_a - a_b)

    def engine(o1):
        # the drive and its first two rates; gear1's pinion accelerates under it and its mesh torque
        tau = drive(e, o1[0], o1[1], 0.0)[0]
        return drive(e, o1[0], o1[1], (o1[5] + tau) / p1["J_A"])

    def record(t, o1, o2, tau):
        rows.append((t, o1[4], o2[4], tau, o1[1], o1[3], o2[1], o2[3]))

    try:
        o1, o2 = g1.fmu.getReal(r1), g2.fmu.getReal(r2)
        tau = k_s * (o1[2] - o2[0] + tw) + d_s * (o1[3] - o2[1])
        record(0.0, o1, o2, tau)
        if delay and (derivatives or scheme != "jacobi"):
            raise ValueError("delay=1 models the standard masters: Jacobi with held inputs")
        prev = None
        for k in range(n):
            t = k * h
            tau, dtau, ddtau = shaft(o1, o2)
            td, dtd, ddtd = engine(o1)
            if delay:
                held = prev if prev is not None else (tau, td)
                prev = (tau, td)
                if start == "fmpy" and k < 2:
                    held = (0.0, 0.0) if k == 0 else (k_s * tw, drive(e, 0.0, 0.0, 0.0)[0])
                tau, td = held
            g1.fmu.setReal([vr_tauB1, vr_tauA1], [-tau, td])
            if derivatives:
                g1.fmu.setRealInputDerivatives([vr_tauB1, vr_tauA1], [1, 1], [-dtau, dtd])
                if derivatives > 1:
                    g1.fmu.setRealInputDerivatives([vr_tauB1, vr_tauA1], [2, 2], [-ddtau, ddtd])
            g1.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            o1n = g1.fmu.getReal(r1)
            if scheme == "gauss-seidel":
                tau2, dtau2, ddtau2 = shaft(o1n, o2)
                # the torque on gear2 over [t_k, t_k+1]: its value at t_k+1 with gear1 ahead
                tau, dtau, ddtau = tau2, dtau2, ddtau2
            elif scheme != "jacobi":
                raise ValueError(scheme)
            g2.fmu.setReal([vr_tauA2], [tau])
            if derivatives:
                g2.fmu.setRealInputDerivatives([vr_tauA2], [1], [dtau])
                if derivatives > 1:
                    g2.fmu.setRealInputDerivatives([vr_tauA2], [2], [ddtau])
            g2.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            o1, o2 = o1n, g2.fmu.getReal(r2)
            if (k + 1) % every == 0:
                tau_now = k_s * (o1[2] - o2[0] + tw) + d_s * (o1[3] - o2[1])
                record((k + 1) * h, o1, o2, tau_now)
                if not abs(tau_now) < blowup:
                    unstable = True
                    break
    except Exception as e:  # an FMU refusing a state far out (a blow-up) ends the run
        if rows and abs(rows[-1][3]) > 1e3 * abs(rows[0][3]):
            unstable = True
        else:
            raise RuntimeError(f"h = {h}: {e}") from e
    finally:
        g1.close()
        g2.close()
    a = np.array(rows)
    out = {q: a[:, i + 1] for i, q in enumerate(QUANTITIES)}
    out["time"] = a[:, 0]
    out["_seconds"] = _time.perf_counter() - t0
    out["_cpu"] = _time.process_time() - c0
    out["_unstable"] = unstable
    return out


# ---- the standard masters on the .ssp ----------------------------------------------------------

RECORDED = [("gear1", "dte"), ("gear2", "dte"), ("shaft", "tau_b"), ("gear1", "w_A"), ("gear1", "w_B"),
            ("gear2", "w_A"), ("gear2", "w_B")]


def _ns(x):
    ns = int(round(x * 1e9))
    assert math.isclose(ns * 1e-9, x, rel_tol=1e-12), x
    return ns


def run_libcosim_ssp(ssp, h, t_stop):
    """libcosim loads the .ssp (parameters and connections from the .ssd) and steps it at h
    (its fixed-step algorithm: every slave steps, then outputs are copied to inputs)."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver

    t0 = _time.perf_counter()
    c0 = _time.process_time()
    n = int(round(t_stop / h))
    ex = CosimExecution.from_ssp_file(str(ssp), step_size=_ns(h))
    idx = {i.name.decode(): i.index for i in ex.slave_infos()}
    obs = CosimObserver.create_time_series(buffer_size=n + 16)
    ex.add_observer(obs)
    refs = []
    for comp, name in RECORDED:
        vr = {v.name.decode(): v.reference for v in ex.slave_variables(idx[comp])}[name]
        refs.append((idx[comp], vr))
        obs.start_time_series(idx[comp], vr, CosimVariableType.REAL)
    if not ex.simulate_until(_ns(t_stop)):
        raise RuntimeError("libcosim: the simulation failed")
    out = {}
    for q, (slave, vr) in zip(QUANTITIES, refs):
        times, steps, values = obs.time_series_real_samples(slave, vr, from_step=1, sample_count=n)
        if list(steps) != list(range(1, n + 1)):
            raise RuntimeError(f"libcosim: {q} has samples of steps {steps[:3]}..{steps[-3:]}")
        out[q] = np.array(values)
        out["time"] = np.array(times) * 1e-9
    out["_seconds"] = _time.perf_counter() - t0
    out["_cpu"] = _time.process_time() - c0
    return out


def run_omsimulator_ssp(ssp, h, t_stop, oms=None):
    """OMSimulator (cosim/oms_run.py; None when it is not installed) on the .ssp at step h: its
    fixed-step master "oms-ma" solves the algebraic loop the shaft's and the engine's direct
    feedthroughs close (KINSOL) at every communication point, so every FMU steps with the
    others' outputs at the step's start: Jacobi with held inputs, without the extra step of
    delay of libcosim and FMPy.  Records the RECORDED signals every h (the last row of each
    time: the solved loop).  "_seconds" wall, "_cpu" the child process's CPU time (import and
    instantiation included)."""
    import oms_run

    oms = oms or oms_run.find()
    if oms is None:
        return None
    import tempfile

    names = [f"{SSD_NAME}.{SSD_NAME}.{c}.{v}" for c, v in RECORDED]
    regex = "^(" + "|".join(re.escape(n) for n in names) + ")$"
    with tempfile.TemporaryDirectory() as work:
        res = oms_run.run_api(oms, ssp, t_stop, work, step=h, interval=h, signals=regex)
    n = int(round(t_stop / h))
    t = res.columns["time"]
    if len(t) != n + 1 or not np.allclose(t, h * np.arange(n + 1), rtol=0, atol=1e-9 * h):
        raise RuntimeError(f"OMSimulator wrote {len(t)} times, expected {n + 1} on a grid of {h}")
    out = {q: res.columns[name] for q, name in zip(QUANTITIES, names)}
    out["time"] = t
    out["_seconds"], out["_cpu"], out["_warnings"] = res.seconds, res.cpu, res.warnings
    return out


def run_fmpy_ssp(ssp, h, t_stop):
    """fmpy.ssp.simulation.simulate_ssp with the .ssd's parameters as its parameter_set (it does
    not read ParameterBindings).  Its rows carry the step's start time and the values at its end:
    put on t_{k+1} here."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet

    t0 = _time.perf_counter()
    c0 = _time.process_time()
    n = int(round(t_stop / h))
    ps = ParameterSet(name="two-stage")
    for comp, values in ssd_parameters().items():
        for name, value in values.items():
            p = Parameter(name=f"{comp}.{name}")
            p.type, p.value = ("Integer" if isinstance(value, int) else "Real"), value
            ps.parameters.append(p)
    rows = simulate_ssp(str(ssp), stop_time=t_stop - 0.5 * h, step_size=h, parameter_set=ps)
    if len(rows) != n:
        raise RuntimeError(f"simulate_ssp made {len(rows)} steps, expected {n}")
    out = {q: np.asarray(rows[f"{c}.{v}"], dtype=float) for q, (c, v) in zip(QUANTITIES, RECORDED)}
    out["time"] = h * np.arange(1, n + 1)
    out["_seconds"] = _time.perf_counter() - t0
    out["_cpu"] = _time.process_time() - c0
    return out


# ---- comparison -----------------------------------------------------------------------------------

def errors(run, ref, quantities=("mesh1.dte", "mesh2.dte", "shaft.tau"), t_max=None):
    """Max |run - ref| per quantity over the run's times that lie on ref's grid (and <= t_max)."""
    dt = ref["time"][1] - ref["time"][0]
    t = run["time"]
    idx = np.rint(t / dt).astype(int)
    on = np.abs(idx * dt - t) < 1e-9 * dt
    on &= idx < len(ref["time"])
    if t_max is not None:
        on &= t <= t_max * (1 + 1e-12)
    out = {}
    for q in quantities:
        d = np.abs(run[q][on] - ref[q][idx[on]])
        out[q] = float(np.max(d)) if d.size and np.all(np.isfinite(d)) else math.inf
    return out


def main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("ssd", help="write cosim/two-stage.ssd from the scene")
    b = sub.add_parser("ssp", help="zip the .ssd and target/fmu's FMUs into target/cosim/two-stage.ssp")
    b.add_argument("--out", default=str(DEFAULT_SSP))
    r = sub.add_parser("run", help="run the .ssp in libcosim, FMPy and OMSimulator (if installed) and compare with the train")
    r.add_argument("ssp", nargs="?", default=str(DEFAULT_SSP))
    r.add_argument("--step", type=float, default=1e-5)
    r.add_argument("--stop", type=float, default=0.01)
    a = ap.parse_args(argv)
    if a.cmd == "ssd":
        print(write_ssd())
    elif a.cmd == "ssp":
        print(build_ssp(a.out))
    else:
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

        log_output_level(CosimLogLevel.WARNING)
        ref = run_monolithic(fmu_paths()["train"], a.stop, 1e-5 if a.step <= 1e-5 else a.step)
        for master, fn in (("libcosim", run_libcosim_ssp), ("fmpy", run_fmpy_ssp),
                           ("omsimulator", run_omsimulator_ssp)):
            run = fn(a.ssp, a.step, a.stop)
            if run is None:
                print(f"{master}: not installed (docs/omsimulator.md)")
                continue
            e = errors(run, ref)
            print(f"{master}: h = {a.step:g} s, {run['_seconds']:.2f} s wall; max error against the train: "
                  + ", ".join(f"{q} {v:.3g}" for q, v in e.items()))


if __name__ == "__main__":
    sys.exit(main())
