#!/usr/bin/env python3
"""Work and accuracy now against an earlier commit, at equal rtol: right-hand-side evaluations
(deterministic, unlike wall time) and the dte error against the scene's reference trace, per
scene and rtol. What an integrator change bought (docs/integrators.md, issue 12).

    $(bash tools/venv.sh) tools/evals_vs_rev.py REV [--scenes damped,paper-m2] [--rtols 1e-4,1e-6]

REV's examples/run_scene is built as in tools/cost_vs_rev.py. Errors are max |dte - dte_ref|
over the output grid divided by the reference's dte range, over the window tools/work_precision.py
compares (chaotic scenes: the reference's self-agreement horizon, as docs/performance.md gives it).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cost_vs_rev  # noqa: E402
import work_precision as W  # noqa: E402

# The compared windows of the chaotic scenes (docs/performance.md, "How it was measured").
HORIZON = {"paper-m2": 0.0211, "rattle": 0.0295}
SCENES = ("damped,friction,high-speed,paper-m1,paper-m2,paper-m2-rest,rattle,reversal,"
          "runout-pitch,structure-relief,zero-backlash")


def run(binary, ref, rtol, trace):
    out = subprocess.run([str(binary), W.scene_path(ref.name), "--api", "rust", "--reps", "1",
                          "--rtol", str(rtol), "--trace", trace, "--outputs", "all"],
                         capture_output=True, text=True, check=True).stdout
    counters = json.loads(out.strip().splitlines()[-1])
    return counters["n_rhs_evaluations"], W.errors(ref, *W.read_trace(trace))["dte_rel"]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("rev")
    ap.add_argument("--scenes", default=SCENES)
    ap.add_argument("--rtols", default="1e-3,1e-4,1e-5,1e-6,1e-7,1e-8")
    a = ap.parse_args()
    subprocess.run(["cargo", "build", "-q", "--release", "--example", "run_scene"],
                   cwd=cost_vs_rev.ROOT, check=True)
    new = cost_vs_rev.ROOT / "target" / "release" / "examples" / "run_scene"
    old = cost_vs_rev.build(a.rev)
    print(f"new = working tree, old = {a.rev}; solver 1, Rust API")
    print("| scene | rtol | old: evals | old: dte err / range | new: evals | new: dte err / range "
          "| evals new/old |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        trace = os.path.join(tmp, "trace.csv")
        for name in a.scenes.split(","):
            ref = W.Reference(name)
            if name in HORIZON:
                ref.set_horizon(HORIZON[name], "")
            for rtol in (float(r) for r in a.rtols.split(",")):
                (n_old, e_old), (n_new, e_new) = (run(b, ref, rtol, trace) for b in (old, new))
                print(f"| `{name}` | {rtol:.0e} | {n_old} | {e_old:.2e} | {n_new} | {e_new:.2e} "
                      f"| {n_new / n_old:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
