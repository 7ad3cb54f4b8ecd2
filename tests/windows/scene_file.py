"""The plain scene file tests/windows/fmi_master.c reads (its header comment has the format),
from a scene (scenes/<name>.toml) and an FMU's modelDescription.xml: start values and inputs by
value reference and type, the outputs to write, nx and nz for Model Exchange.
"""

import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration")


def variables(md_xml):
    """{name: (value reference, type)}, the number of states and of event indicators."""
    md = ET.fromstring(md_xml)
    out = {}
    for v in md.iter("ScalarVariable"):
        ty = next(c.tag for c in v if c.tag in TYPES)
        out[v.get("name")] = (int(v.get("valueReference")), ty)
    nx = len(md.findall("ModelStructure/Derivatives/Unknown"))
    nz = int(md.get("numberOfEventIndicators", "0"))
    return out, nx, nz


def load_scene(path):
    path = Path(path)
    with open(path, "rb") as fh:
        scene = tomllib.load(fh)
    rows = []
    if "input_file" in scene:
        lines = (path.parent / scene["input_file"]).read_text().splitlines()
        cols = [c.strip('"') for c in lines[0].split(",")]
        rows = [cols] + [[float(x) for x in ln.split(",")] for ln in lines[1:] if ln.strip()]
    return scene, rows


def scene_text(md_xml, scene=None, rows=(), outputs=None, start=None, stop_time=None,
               output_interval=None, me_step=None):
    """The scene file's text. `start` overrides or adds start values (name: value)."""
    vars_, nx, nz = variables(md_xml)
    scene = scene or {}
    starts = dict(scene.get("start_values", {}))
    starts.update(start or {})
    outputs = outputs or scene.get("compare", {}).get("variables")
    lines = [
        f"stop_time {stop_time if stop_time is not None else scene['stop_time']!r}",
        f"output_interval {output_interval if output_interval is not None else scene['output_interval']!r}",
        f"nx {nx}",
        f"nz {nz}",
    ]
    if me_step is not None:
        lines.append(f"me_step {me_step!r}")
    for name, value in starts.items():
        vr, ty = vars_[name]
        if ty == "Real":
            lines.append(f"real {vr} {float(value)!r}")
        elif ty in ("Integer", "Enumeration"):
            lines.append(f"integer {vr} {int(value)}")
        elif ty == "Boolean":
            lines.append(f"boolean {vr} {int(bool(value))}")
        else:
            lines.append(f"string {vr} {value}")
    if rows:
        cols = rows[0][1:]
        for c in cols:
            vr, ty = vars_[c]
            assert ty == "Real", c
            lines.append(f"input {vr}")
        for r in rows[1:]:
            lines.append("row " + " ".join(repr(float(x)) for x in r))
    for name in outputs:
        lines.append(f"output {vars_[name][0]} {name}")
    return "\n".join(lines) + "\n"
