"""Turns a gear-train scene (scenes/train/<name>.toml) into an SSP 1.0 package, so that a user
loads the scene into a co-simulation tool instead of typing its start values on a command line.

    .venv/bin/python tools/scene_to_ssp.py two-stage                  # target/ssp/two-stage.ssp
    .venv/bin/python tools/scene_to_ssp.py scenes/train/internal.toml --out internal.ssp
    .venv/bin/python tools/scene_to_ssp.py two-stage --fmu path/to/SpurGearTrain.fmu
    .venv/bin/python tools/scene_to_ssp.py scenes/train/gearbox/planetary-simple.toml  # a gearbox file

The FMU defaults to target/fmu/SpurGearTrain.fmu (build it with
`cargo run -q --release -p fmu-packaging --bin package-train`). The package holds:

    SystemStructure.ssd          one system, one component `train` (the FMU), every output of the
                                 scene's active bodies, shafts and meshes and the train's energies
                                 as output connectors, the parameter binding below, the scene's
                                 stop time and output interval as the default experiment
    resources/SpurGearTrain.fmu  the FMU as given (stored, not recompressed)
    resources/<name>.ssv         SSP 1.0 ParameterValues: every start value of the scene's
                                 [start_values], typed as the FMU declares it (Real, Integer,
                                 Boolean); the constant input torques body[i].tau included

The names are identifiers where OMSimulator needs them (the .ssd's and the system's: the scene's
name with '-' as '_'). The system carries OMSimulator's org.openmodelica annotation (a weakly
coupled system with a fixed-step master at the output interval; docs/omsimulator.md) and the
Open Simulation Platform's algorithm annotation (libcosim's step); every tool ignores the other's.
The communication step is the scene's output interval, as `fmpy simulate` uses it for a
Co-Simulation FMU. No tolerance is imposed: OMSimulator passes the FMU's DefaultExperiment
tolerance (what `fmpy simulate` passes too), the others none, and the FMU's own rel_tol (a start
value) rules unless a passed tolerance is tighter.

How each tool loads it (docs/omsimulator.md):
  libcosim      CosimExecution.from_ssp_file("two-stage.ssp", step_size=h_ns): it applies the
                component's ParameterBindings itself, the .ssv included.
  OMSimulator   OMSimulator --stopTime=0.05 --resultFile=two-stage.csv two-stage.ssp
                (or its Python API: importFile, simulate); it applies the .ssv itself.
  FMPy          fmpy.ssp.simulation.simulate_ssp does not apply ParameterBindings (FMPy 0.3.32):
                hand it the package's own parameter set, read from the package by FMPy's reader:
                    from scene_to_ssp import fmpy_parameter_set
                    simulate_ssp(ssp, stop_time=T, step_size=h, parameter_set=fmpy_parameter_set(ssp))

A scene with an input_file (time-varying torques, e.g. rattle) has no SSP 1.0 form here: the
package would hold only the torques' start values, so the tool refuses it.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

ROOT = Path(__file__).resolve().parents[1]
SCENES_DIR = ROOT / "scenes" / "train"
DEFAULT_FMU = ROOT / "target" / "fmu" / "SpurGearTrain.fmu"
OUT_DIR = ROOT / "target" / "ssp"
COMPONENT = "train"
OMS_NS = "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"
NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
      "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
      "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations"}
# the train's whole-train outputs (not indexed by a body, shaft or mesh)
_ELEMENT = re.compile(r"^(body|shaft|mesh)\[(\d+)\]\.")


def gearbox_start_values(path):
    """SpurGearTrain's start values for a gearbox file (gearbox-file.md), from the Rust mapping
    that the tests check against every scene (train-fmu/src/gearbox.rs); a refused file raises
    ValueError with the refusal, which names the file's elements and lines."""
    cmd = ["cargo", "run", "-q", "--release", "-p", "spur_gear_train", "--bin", "gearbox-start-values",
           "--", str(Path(path).resolve()), "--json"]
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        raise ValueError(r.stderr.strip() or f"{' '.join(cmd)} failed")
    return json.loads(r.stdout)


def load_scene(scene):
    """A scene by name (scenes/train/<name>.toml) or by path; with "name" and "path" added. A
    gearbox file (a top-level `name` and no [start_values]) is a scene too: its start values
    are the file's, its run the scene's it stands for (scenes/train/gearbox/NAME.toml is
    scenes/train/NAME.toml) or the FMU's default experiment (0.1 s, 1e-4 s)."""
    path = Path(scene)
    if path.suffix != ".toml":
        path = SCENES_DIR / f"{scene}.toml"
    with open(path, "rb") as f:
        sc = tomllib.load(f)
    if "start_values" not in sc and "name" in sc:
        beside = path.parent.parent / path.name
        run = {"stop_time": 0.1, "output_interval": 1e-4}
        if path.parent.name == "gearbox" and beside.is_file():
            with open(beside, "rb") as f:
                run.update({k: v for k, v in tomllib.load(f).items() if k in run or k == "input_file"})
        gearbox = sc
        sc = {**run, "description": gearbox.get("description", ""), "start_values": gearbox_start_values(path)}
        sc["name"], sc["path"] = gearbox["name"], str(path)
        return sc
    sc["name"], sc["path"] = path.stem, str(path)
    return sc


def ident(name):
    """An identifier OMSimulator accepts ([a-zA-Z][a-zA-Z0-9_]*) from a scene name."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return s if s[:1].isalpha() else "s_" + s


def _xml_value(typ, value):
    if typ == "Real":
        return repr(float(value))
    if typ == "Integer":
        if float(value) != int(value):
            raise ValueError(f"{value!r} is not an integer")
        return str(int(value))
    if typ == "Boolean":
        if not isinstance(value, bool) and value not in (0, 1):
            raise ValueError(f"{value!r} is not a Boolean")
        return "true" if value else "false"
    if typ == "String":
        return str(value)
    raise ValueError(f"type {typ} has no SSV form here")


def _variables(fmu):
    import fmpy

    md = fmpy.read_model_description(str(fmu), validate=False)
    return md, {v.name: v for v in md.modelVariables}


def parameter_values(scene, variables):
    """[(name, type, xml value)] of every start value of the scene, typed as the FMU declares it."""
    out = []
    for name, value in scene.get("start_values", {}).items():
        v = variables.get(name)
        if v is None:
            raise KeyError(f"scene {scene['name']}: {name} is not a variable of the FMU")
        if v.causality not in ("parameter", "input"):
            raise ValueError(f"scene {scene['name']}: {name} is a {v.causality}, not a parameter or input")
        out.append((name, v.type, _xml_value(v.type, value)))
    return out


def output_connectors(scene, variables):
    """[(name, type)]: every output of the scene's active bodies, shafts and meshes (their counts:
    the scene's start values over the FMU's defaults) and every whole-train output."""
    sv = scene.get("start_values", {})
    counts = {}
    for elem, n in (("body", "n_bodies"), ("shaft", "n_shafts"), ("mesh", "n_meshes")):
        counts[elem] = int(sv.get(n, variables[n].start))
    out = []
    for v in variables.values():
        if v.causality != "output":
            continue
        m = _ELEMENT.match(v.name)
        if m and int(m.group(2)) > counts[m.group(1)]:
            continue
        out.append((v.name, v.type))
    return out


def ssv_text(scene, params):
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f"<!-- The start values of scenes/train/{scene['name']}.toml (tools/scene_to_ssp.py). -->",
             f'<ssv:ParameterSet version="1.0" name={quoteattr(scene["name"])}',
             f'    xmlns:ssc="{NS["ssc"]}"', f'    xmlns:ssv="{NS["ssv"]}">', "  <ssv:Parameters>"]
    for name, typ, value in params:
        lines.append(f"    <ssv:Parameter name={quoteattr(name)}><ssv:{typ} value={quoteattr(value)}/></ssv:Parameter>")
    lines += ["  </ssv:Parameters>", "</ssv:ParameterSet>", ""]
    return "\n".join(lines)


def ssd_text(scene, fmu_name, ssv_name, outputs, step, tolerance):
    name = ident(scene["name"])
    desc = " ".join(scene.get("description", "").split())
    g = f"{step!r}"
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f"<!-- scenes/train/{scene['name']}.toml as an SSP package (tools/scene_to_ssp.py; docs/omsimulator.md). -->",
        f'<ssd:SystemStructureDescription version="1.0" name="{name}"',
        f'    xmlns:ssd="{NS["ssd"]}"', f'    xmlns:ssc="{NS["ssc"]}"', f'    xmlns:ssv="{NS["ssv"]}"',
        f'    xmlns:oms="{OMS_NS}"', f'    xmlns:osp="{NS["osp"]}">',
        f"  <ssd:System name=\"{name}\" description={quoteattr(desc[:2000])}>",
        "    <ssd:Elements>",
        f'      <ssd:Component name="{COMPONENT}" type="application/x-fmu-sharedlibrary" source="resources/{fmu_name}">',
        "        <ssd:Connectors>"]
    for n, typ in outputs:
        lines.append(f"          <ssd:Connector name={quoteattr(n)} kind=\"output\"><ssc:{typ}/></ssd:Connector>")
    lines += [
        "        </ssd:Connectors>",
        "        <ssd:ParameterBindings>",
        f'          <ssd:ParameterBinding source="resources/{ssv_name}"/>',
        "        </ssd:ParameterBindings>",
        "      </ssd:Component>",
        "    </ssd:Elements>",
        "    <ssd:Annotations>",
        '      <ssc:Annotation type="org.openmodelica">',
        "        <oms:Annotations>",
        "          <oms:SimulationInformation>",
        f'            <oms:FixedStepMaster description="oms-ma" stepSize="{g}" '
        f'absoluteTolerance="{tolerance!r}" relativeTolerance="{tolerance!r}"/>',
        "          </oms:SimulationInformation>",
        "        </oms:Annotations>",
        "      </ssc:Annotation>",
        "    </ssd:Annotations>",
        "  </ssd:System>",
        f'  <ssd:DefaultExperiment startTime="0.0" stopTime="{float(scene["stop_time"])!r}">',
        "    <ssd:Annotations>",
        '      <ssc:Annotation type="com.opensimulationplatform">',
        f'        <osp:Algorithm><osp:FixedStepAlgorithm baseStepSize="{g}"/></osp:Algorithm>',
        "      </ssc:Annotation>",
        "    </ssd:Annotations>",
        "  </ssd:DefaultExperiment>",
        "</ssd:SystemStructureDescription>", ""]
    return "\n".join(lines)


def scene_to_ssp(scene, out=None, fmu=DEFAULT_FMU):
    """Writes the SSP package of `scene` (a name, a path, or a loaded scene) to `out` (default
    target/ssp/<name>.ssp); returns its path."""
    sc = scene if isinstance(scene, dict) else load_scene(scene)
    if "input_file" in sc:
        raise ValueError(f"scene {sc['name']} drives the train from {sc['input_file']} (time-varying "
                         "torques): an SSP package of its start values alone would not be that scene")
    fmu = Path(fmu)
    if not fmu.is_file():
        raise FileNotFoundError(f"{fmu}: build it with `cargo run -q --release -p fmu-packaging --bin package-train`")
    md, variables = _variables(fmu)
    if md.coSimulation is None:
        raise ValueError(f"{fmu} has no Co-Simulation interface")
    step = float(sc["output_interval"])
    tolerance = float(md.defaultExperiment.tolerance) if md.defaultExperiment and md.defaultExperiment.tolerance else 1e-6
    ssv_name = f"{sc['name']}.ssv"
    ssd = ssd_text(sc, fmu.name, ssv_name, output_connectors(sc, variables), step, tolerance)
    ssv = ssv_text(sc, parameter_values(sc, variables))
    out = Path(out) if out else OUT_DIR / f"{sc['name']}.ssp"
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", ssd)
        z.writestr(f"resources/{ssv_name}", ssv)
        z.write(fmu, f"resources/{fmu.name}", compress_type=zipfile.ZIP_STORED)
    return out


def fmpy_parameter_set(ssp):
    """FMPy's ParameterSet for simulate_ssp from the package's own ParameterBindings, read with
    FMPy's reader (fmpy.ssp.ssd.read_ssd, which validates the .ssd and the .ssv against the SSP
    1.0 schemas): names prefixed with their component ("train.body[1].J"), values typed
    (FMPy's reader keeps them as strings, and its set_value takes any string as Boolean true)."""
    from fmpy.ssp.ssd import Parameter, ParameterSet, read_ssd

    conv = {"Real": float, "Integer": int, "Boolean": lambda s: s.strip().lower() in ("true", "1")}
    ssd = read_ssd(str(ssp))
    ps = ParameterSet(name=ssd.name)
    for comp in ssd.system.elements:
        for binding in getattr(comp, "parameterBindings", []):
            for values in binding.parameterValues:
                for p in values.parameters:
                    if p.type not in conv:
                        raise ValueError(f"{comp.name}.{p.name}: FMPy's simulate_ssp cannot set a {p.type}")
                    q = Parameter(name=f"{comp.name}.{p.name}")
                    q.type, q.value = p.type, conv[p.type](p.value)
                    ps.parameters.append(q)
    return ps


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="a train scene's name (scenes/train/<name>.toml) or path, or a gearbox file")
    ap.add_argument("--fmu", default=str(DEFAULT_FMU), help="the SpurGearTrain FMU to package")
    ap.add_argument("--out", help="where to write the .ssp (default target/ssp/<name>.ssp)")
    a = ap.parse_args(argv)
    print(scene_to_ssp(a.scene, a.out, a.fmu))
    return 0


if __name__ == "__main__":
    sys.exit(main())
