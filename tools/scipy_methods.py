#!/usr/bin/env python3
"""The SciPy reference's solve_ivp methods side by side: right-hand-side evaluations, accepted
steps and the dte error against the scene's reference trace, per scene, method and rtol, counted
and measured as tools/work_precision.py does. It estimates what a method would gain before one
writes it in Rust (docs/integrators.md, "DOP853 for tight tolerances").

    $(bash tools/venv.sh) tools/scipy_methods.py --scenes paper-m1,paper-m2 \\
        --methods RK45,DOP853 --rtols 1e-6,1e-7,1e-8 --no-output-cap

--no-output-cap lifts the reference's cap of one output interval on solve_ivp's step (it keeps
the cap of 1/8 base pitch that guards its event search); without it a method of high order
cannot take its longer steps.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import work_precision as W  # noqa: E402

# The compared windows of the chaotic scenes (docs/performance.md, "How it was measured").
HORIZON = {"paper-m2": 0.0211, "rattle": 0.0295}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="paper-m1,paper-m2,damped,reversal")
    ap.add_argument("--methods", default="RK45,DOP853")
    ap.add_argument("--rtols", default="1e-5,1e-6,1e-7,1e-8,1e-9")
    ap.add_argument("--no-output-cap", action="store_true")
    args = ap.parse_args()
    W.patch_brentq()
    counting = W.Counting()
    W.G.solve_ivp = counting
    for name in args.scenes.split(","):
        ref = W.Reference(name)
        if name in HORIZON:
            ref.set_horizon(HORIZON[name], "")
        for method in args.methods.split(","):
            for rtol in map(float, args.rtols.split(",")):
                counting.reset()
                res = W.G.run_scene(ref.scene, rtol=rtol, method=method,
                                    output_step_cap=not args.no_output_cap)
                err = W.errors(ref, res.names, res.table)["dte_rel"]
                print(json.dumps({"scene": name, "method": method, "rtol": rtol,
                                  "output_step_cap": not args.no_output_cap,
                                  "evaluations": counting.c["n_rhs_evaluations"],
                                  "steps": counting.c["n_steps"], "dte_err_over_range": err}),
                      flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
