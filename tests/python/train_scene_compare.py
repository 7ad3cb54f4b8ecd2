"""Runs a gear-train scene (scenes/train/<name>.toml) through the packaged SpurGearTrain FMU with
the real `fmpy simulate` CLI and compares the result with the independent reference trace
tests/reference/train/<name>.csv (tests/reference_model/train_ref.py, regenerate_train.py).

The train's counterpart of scene_compare.py (the single-mesh FMU's scenes), with the same design
and, where the two agree, the same code (imported from scene_compare):

* The command line: `fmpy simulate <fmu> --validate --start-values NAME VALUE ... --stop-time T
  --output-interval DT [--input-file scenes/train/<input_file>] --output-variables ...
  --output-file F`.  The structured names (`body[1].J`, `mesh[2].dte`) are single argv elements
  (subprocess, no shell), so their brackets need no quoting; the reproduce command printed on a
  failure is shlex.join'ed, which quotes them for a shell (unquoted, `body[1].J` is a glob
  pattern).  FMPy's CSV reader takes the input file's header names verbatim (it splits on ',' and
  strips the quotes), so the column `"body[1].tau"` drives the input `body[1].tau`.

* mode = "trace": every variable of [compare] variables, on the output grid t_k = k dt,
  max |FMU - reference| <= [compare.tolerance] <variable>; the reference's grid row, or at an
  event exactly on a grid time the closer of its two rows (scene_compare.compare_traces).

* events = true: for EVERY mesh m = 1..n_meshes, the switching times of its contact state
  (mesh[m].n_fwd, mesh[m].n_bwd), grid-resolved as in scene_compare.compare_events: at every grid
  time the FMU's sampled state of mesh m must be a state the reference's mesh m is in within the
  event tolerance (one output interval unless the scene sets [compare] event_tolerance).  The
  reference writes a row pair at every event of any mesh, so each mesh's state changes only
  across such a pair.  One check per mesh, named mesh[m].switching_time.

* mode = "statistics": train_ref.statistics() (per body and per mesh) on the FMU's output and on
  the reference trace, both over the output-grid rows, |FMU - reference| <= the bound in
  [compare.statistics].

The FMU runs with its own defaults for everything the scene does not set.  Without
--relative-tolerance FMPy passes the modelDescription's DefaultExperiment tolerance (1e-6, the
same as the rel_tol default) to fmi2SetupExperiment.  The FMU is Co-Simulation only; FMPy uses the
output interval as the communication step.  All bounds are the scene files'; none is derived from
the FMU's output.

    .venv/bin/python tests/python/train_scene_compare.py            # all train scenes, a table
    .venv/bin/python tests/python/train_scene_compare.py idler --fmu path/to/SpurGearTrain.fmu
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))
import scene_compare as S  # noqa: E402  (also puts tests/ on sys.path for reference_model)

from reference_model import lateral_ref as LR  # noqa: E402
from reference_model import train_ref as T  # noqa: E402

ROOT = S.ROOT
TRAIN_SCENES_DIR = S.SCENES_DIR / "train"
TRAIN_REF_DIR = S.REF_DIR / "train"
TRAIN_FMU = ROOT / "target" / "fmu" / "SpurGearTrain.fmu"
# The packager of the train FMU; prints the path of the FMU it wrote (last line of stdout).
PACKAGE_TRAIN = ["cargo", "run", "-q", "--release", "-p", "fmu-packaging", "--bin", "package-train"]

# units by the last component of a structured name (body[1].w -> w) or a statistic's name
_UNITS = {
    "theta": "rad", "w": "rad/s", "tau": "N.m", "dte": "m", "F_fwd": "N", "F_bwd": "N",
    "F_f1": "N", "F_f2": "N", "F_b1": "N", "F_b2": "N", "P_loss": "W", "k_mesh": "N/m",
    "tau_mesh_A": "N.m", "tau_mesh_B": "N.m", "mean_w": "rad/s", "rms_dte": "m",
    "max_dte": "m", "min_dte": "m", "switching_time": "s", "E_kin": "J", "E_el": "J",
    "E_gate": "J", "W_ext": "J", "W_loss": "J", "energy_residual": "J", "Fx": "N", "Fy": "N",
}


def unit(name):
    return _UNITS.get(name.rsplit(".", 1)[-1], "")


@dataclass
class Check(S.Check):
    """scene_compare.Check with the train's units (looked up by the name's last component)."""

    def message(self):
        u = unit(self.name)
        u = f" {u}" if u else ""
        what = {"trace": "max |FMU - reference|", "statistic": "|FMU - reference|",
                "events": "switching-time disagreement (grid-resolved)"}[self.kind]
        return (f"{self.name}: {what} = {self.error:.3g}{u} at {self.where}; bound {self.bound:.3g}{u} "
                f"({self.fraction:.3g} of it)" + (f"; {self.note}" if self.note else ""))


def _train_check(c):
    return Check(c.kind, c.name, c.error, c.bound, c.where, c.note)


def scene_names():
    return sorted(p.stem for p in TRAIN_SCENES_DIR.glob("*.toml"))


def load_scene(name):
    return T.load_scene(name)


def build_train_fmu():
    """Builds and packages the train FMU (the package-train binary); returns the path it prints."""
    out = subprocess.run(PACKAGE_TRAIN, cwd=ROOT, check=True, capture_output=True, text=True)
    path = Path(out.stdout.strip().splitlines()[-1])
    assert path.is_file(), f"package-train printed {out.stdout!r}"
    return path


def counts(scene):
    """n_bodies, n_shafts, n_meshes of a scene (its start values over the FMU's defaults)."""
    # The lateral bodies' parameters are lateral_ref's, not train_ref's.
    p = T.make_train_params(LR.split_start_values(scene.get("start_values", {}))[0])
    return p["n_bodies"], p["n_shafts"], p["n_meshes"]


def outputs(scene):
    """The outputs recorded for a scene: every active element's outputs that the reference
    trace also has, the whole train's energies, and any compared variable not among them."""
    nb, ns, nm = counts(scene)
    names = []
    for i in range(1, nb + 1):
        names += [f"body[{i}].theta", f"body[{i}].w"]
    names += [f"shaft[{j}].tau" for j in range(1, ns + 1)]
    for m in range(1, nm + 1):
        names += [f"mesh[{m}].{v}" for v in ("dte", "F_fwd", "F_bwd", "n_fwd", "n_bwd", "F_f1",
                                             "F_f2", "F_b1", "F_b2", "P_loss")]
    names += ["E_kin", "E_el", "E_gate", "W_ext", "W_loss", "energy_residual"]
    names += [v for v in scene.get("compare", {}).get("variables", []) if v not in names]
    return names


def fmpy_command(fmu, scene, output_file, rel_tol=None, solver=None):
    """The `fmpy simulate` command line of a train scene (see the module docstring). solver:
    None runs Co-Simulation; "CVode" or "Euler" runs Model Exchange with FMPy's solver."""
    cmd = [S.fmpy_executable(), "simulate", str(fmu), "--validate"]
    if solver is not None:
        cmd += ["--interface-type", "ModelExchange", "--solver", solver, "--dont-record-events"]
    sv = scene.get("start_values", {})
    if sv:
        cmd.append("--start-values")
        for name, value in sv.items():
            cmd += [name, S.format_start_value(value)]
    cmd += ["--stop-time", repr(float(scene["stop_time"])),
            "--output-interval", repr(float(scene["output_interval"]))]
    if "input_file" in scene:
        cmd += ["--input-file", str(TRAIN_SCENES_DIR / scene["input_file"])]
    if rel_tol is not None:
        cmd += ["--relative-tolerance", repr(float(rel_tol))]
    cmd += ["--output-variables", *outputs(scene), "--output-file", str(output_file)]
    return cmd


def run_fmpy(fmu, scene, workdir, rel_tol=None, solver=None):
    tag = "" if rel_tol is None else f".rtol{rel_tol:g}"
    tag += "" if solver is None else f".me-{solver}"
    out = Path(workdir) / f"train-{scene['name']}{tag}.fmu.csv"
    cmd = fmpy_command(Path(fmu).resolve(), scene, out, rel_tol, solver)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=str(workdir))
    seconds = time.perf_counter() - t0
    if proc.returncode != 0 or not out.is_file():
        raise RuntimeError(f"`{shlex.join(cmd)}` failed (exit {proc.returncode}):\n"
                           f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    names, table = S.read_csv(out)
    return names, table, seconds, cmd


def compare_traces(scene, fnames, ftab, rnames, rtab):
    return [_train_check(c) for c in S.compare_traces(scene, fnames, ftab, rnames, rtab)]


def _as_single_mesh(names, m):
    """Column names with mesh m's contact counts renamed to the single mesh's n_fwd, n_bwd."""
    ren = {f"mesh[{m}].n_fwd": "n_fwd", f"mesh[{m}].n_bwd": "n_bwd"}
    if any(n in ("n_fwd", "n_bwd") for n in names):
        raise ValueError("unexpected single-mesh column names in a train trace")
    return [ren.get(n, n) for n in names]


def compare_events(scene, fnames, ftab, rnames, rtab):
    """One grid-resolved switching-time check per mesh (scene_compare.compare_events on the
    columns mesh[m].n_fwd, mesh[m].n_bwd)."""
    checks = []
    for m in range(1, counts(scene)[2] + 1):
        (c,) = S.compare_events(scene, _as_single_mesh(fnames, m), ftab,
                                _as_single_mesh(rnames, m), rtab)
        checks.append(Check(c.kind, f"mesh[{m}].switching_time", c.error, c.bound,
                            c.where.replace("n_fwd/n_bwd", f"mesh[{m}].n_fwd/n_bwd"), c.note))
    return checks


def compare_statistics(scene, fnames, ftab, rnames, rtab):
    dt = scene["output_interval"]
    train = T.GearTrain(scene.get("start_values", {}))
    fs = T.statistics(fnames, ftab, dt, train)
    rs = T.statistics(rnames, rtab, dt, train)
    checks = []
    for stat, bound in scene["compare"]["statistics"].items():
        if stat not in rs:
            raise KeyError(f"scene {scene['name']}: [compare.statistics] {stat} is not a statistic "
                           f"of train_ref.statistics ({sorted(rs)})")
        err = abs(fs[stat] - rs[stat])
        checks.append(Check("statistic", stat, float(err), float(bound),
                            f"whole scene (FMU {fs[stat]:.9g}, reference {rs[stat]:.9g})"))
    return checks


def compare_scene(fmu, name, workdir, rel_tol=None, solver=None):
    t0 = time.perf_counter()
    scene = load_scene(name)
    mode = scene.get("mode", "trace")
    fnames, ftab, seconds, cmd = run_fmpy(fmu, scene, workdir, rel_tol, solver)
    rnames, rtab = S.read_csv(TRAIN_REF_DIR / f"{name}.csv")
    res = S.SceneResult(name, mode, fmpy_seconds=seconds, command=cmd)
    if mode == "trace":
        res.checks += compare_traces(scene, fnames, ftab, rnames, rtab)
    elif mode == "statistics":
        res.checks += compare_statistics(scene, fnames, ftab, rnames, rtab)
    else:
        raise ValueError(f"scene {name}: unknown mode {mode!r}")
    if scene.get("compare", {}).get("events", False):
        res.checks += compare_events(scene, fnames, ftab, rnames, rtab)
    res.total_seconds = time.perf_counter() - t0
    return res


def failure_message(res, what=""):
    """Every out-of-bound check, all checks, and the command to reproduce."""
    lines = [f"train scene {res.name} ({res.mode}){what}: {len(res.failures())} of "
             f"{len(res.checks)} checks out of bounds"]
    lines += ["  " + c.message() for c in res.failures()]
    lines += ["all checks:", res.report(), "reproduce: " + shlex.join(res.command)]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", help="train scene names (default: all)")
    ap.add_argument("--fmu", help=f"packaged FMU (default: build with {shlex.join(PACKAGE_TRAIN)})")
    args = ap.parse_args(argv)
    fmu = Path(args.fmu) if args.fmu else build_train_fmu()
    ok = True
    print("| scene | check | worst error | bound | error / bound | where |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        for name in args.scenes or scene_names():
            res = compare_scene(fmu, name, work)
            ok &= res.ok
            for c in res.checks:
                print(f"| {name} | {c.name} | {c.error:.3g} {unit(c.name)} | {c.bound:.3g} | "
                      f"{c.fraction:.3g}{'' if c.ok else ' FAIL'} | {c.where} |")
            print(f"<!-- {name}: fmpy simulate {res.fmpy_seconds:.2f} s -->")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
