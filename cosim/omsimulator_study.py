"""OMSimulator in docs/cosim.md's study: the two-stage drivetrain's .ssp run by OMSimulator at the
study's communication steps, its error against the monolithic train (as the study measures the
other masters), and its distance from our own master's plain Jacobi coupling with held inputs
(cosim/drivetrain.py run_master, delay 0), which it should be: its fixed-step master solves the
algebraic loop of the direct feedthroughs at every communication point.

    OMSIMULATOR_HOME=/work/omsim/install .venv/bin/python cosim/omsimulator_study.py   # about 20 s

Writes the block between the oms-study markers of docs/omsimulator.md and prints it.
"""

import math
import re
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import drivetrain as D  # noqa: E402
import oms_run  # noqa: E402
from drivetrain_study import HS  # noqa: E402

Q3 = ["mesh1.dte", "mesh2.dte", "shaft.tau"]
DOC = HERE.parent / "docs" / "omsimulator.md"
BEGIN, END = "<!-- oms-study:begin (cosim/omsimulator_study.py writes this block) -->", "<!-- oms-study:end -->"


def _e(x):
    return "unstable" if not math.isfinite(x) else f"{x:.2g}"


def study(ssp, oms, t_stop):
    ref = D.run_monolithic(D.fmu_paths()["train"], t_stop, 1e-5)
    ranges = {q: float(np.ptp(ref[q])) for q in Q3}
    rows = []
    for h in HS:
        jac = D.run_master(h, t_stop, dt_out=h)
        e_jac = D.errors(jac, ref)
        if jac["_unstable"]:
            e_jac = {q: math.inf for q in Q3}
        try:
            run = D.run_omsimulator_ssp(ssp, h, t_stop, oms)
            e = D.errors(run, ref)
            # OMSimulator against our Jacobi master on the run's grid (both record every h)
            n = min(len(run["time"]), len(jac["time"]))
            d = {q: float(np.max(np.abs(run[q][:n] - jac[q][:n]))) for q in Q3}
            cpu, warn = run["_cpu"], run["_warnings"]
            if not all(math.isfinite(v) for v in e.values()):
                raise RuntimeError("non-finite output")
        except RuntimeError as ex:  # a blown-up run: an FMU refuses its state, OMSimulator stops
            print(f"h={h:g}: {str(ex).splitlines()[0]}", file=sys.stderr)
            e, d, cpu, warn = {q: math.inf for q in Q3}, {q: math.nan for q in Q3}, math.nan, None
        rows.append((h, e, e_jac, d, cpu, warn))
        print(f"h={h:7.0e} oms " + ", ".join(f"{q} {e[q]:.3g}" for q in Q3) + f" | jacobi "
              + ", ".join(f"{e_jac[q]:.3g}" for q in Q3) + " | |oms-jacobi| "
              + ", ".join(f"{d[q]:.3g}" for q in Q3) + f" | cpu {cpu:.2f} s, warnings {warn}", flush=True)
    return ranges, rows


def markdown(oms, ranges, rows, t_stop):
    out = [f"Run: `python cosim/omsimulator_study.py` ({date.today().isoformat()}), {oms.version()}; "
           f"scene `two-stage-firing.toml`, every FMU at rel_tol {D.REL_TOL:g}, 0 to {t_stop:g} s; errors "
           "max |co-simulation - monolithic train| on the reference's 1e-5 s grid (the run's own grid "
           "where h > 1e-5), as docs/cosim.md's study. Ranges over the run: "
           + ", ".join(f"{q} {ranges[q]:.3g}" for q in Q3) + ".", "",
           "| h [s] | OMSimulator (.ssp): dte1, dte2, tau | own master, Jacobi, held inputs: dte1, dte2, tau "
           "| max \\|OMSimulator - own Jacobi\\|: dte1, dte2, tau | OMSimulator CPU s | loop warnings |",
           "|---|---|---|---|---|---|"]
    for h, e, ej, d, cpu, warn in rows:
        out.append(f"| {h:g} | " + ", ".join(_e(e[q]) for q in Q3) + " | " + ", ".join(_e(ej[q]) for q in Q3)
                   + " | " + ", ".join("—" if math.isnan(d[q]) else f"{d[q]:.2g}" for q in Q3)
                   + f" | {'—' if math.isnan(cpu) else f'{cpu:.2f}'} | {'—' if warn is None else warn} |")
    fit = [(h, e) for h, e, *_ in rows if h <= 1e-5 and all(math.isfinite(v) for v in e.values())]
    if len(fit) >= 3:
        hs = np.log([h for h, _ in fit])
        orders = {q: float(np.polyfit(hs, np.log([e[q] for _, e in fit]), 1)[0]) for q in Q3}
        out += ["", "Observed order (least-squares slope over h = 1e-5 ... 1e-6): "
                + ", ".join(f"{q} {orders[q]:.2f}" for q in Q3) + "."]
    out.append("CPU: the OMSimulator child process (import of the .ssp, instantiation and result "
               "file included); the own master's and libcosim's are in docs/cosim.md.")
    return "\n".join(out)


def main():
    oms = oms_run.find()
    if oms is None:
        sys.exit(oms_run.MISSING)
    t_stop = 0.05
    with tempfile.TemporaryDirectory() as work:
        ssp = D.build_ssp(Path(work) / "two-stage.ssp")
        t0 = time.perf_counter()
        ranges, rows = study(ssp, oms, t_stop)
        print(f"study: {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    block = markdown(oms, ranges, rows, t_stop)
    print(block)
    text = DOC.read_text()
    if BEGIN in text and END in text:
        text = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END), lambda m: f"{BEGIN}\n{block}\n{END}", text,
                      flags=re.S)
        DOC.write_text(text)
    else:
        print(f"{DOC} has no oms-study markers: block not written", file=sys.stderr)


if __name__ == "__main__":
    main()
