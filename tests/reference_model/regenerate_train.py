#!/usr/bin/env python3
"""Regenerate the gear-train reference traces tests/reference/train/<scene>.csv and their
accuracy report (tests/reference_model/accuracy_train.md), from scenes/train/*.toml.

    .venv/bin/python tests/reference_model/regenerate_train.py                # all train scenes
    .venv/bin/python tests/reference_model/regenerate_train.py idler single   # some scenes
    .venv/bin/python tests/reference_model/regenerate_train.py --no-accuracy  # traces only
    .venv/bin/python tests/reference_model/regenerate_train.py --suggest      # policy tolerances

Same policy as regenerate.py (the single-mesh scenes), applied to train_ref:
  * the reference is train_ref at rtol 1e-10 (DOP853; a scene may set reference_rtol);
  * self-agreement: the scene again at rtol 1e-12, and with body[1].w_start perturbed by 1e-9
    relative (1e-9 rad/s when it is 0); statistics scenes also with an ensemble k * 1e-6,
    k = 2..12 (the scale of an FMU's own integration error at rel_tol 1e-6);
  * a trace scene is accepted when for every compared variable the second-tolerance
    difference is <= 1/10 of its tolerance and the perturbation's effect is <= 1/10 of it or
    does not grow (<= 10x its first-1 % value) and stays within it; a statistics scene when
    every statistic's ensemble spread is within its tolerance;
  * suggested tolerances: trace 0.1 % of the variable's range, at least 1e-5 of its largest
    magnitude (regenerate.suggested_trace_tol); statistics 2x the ensemble spread with the
    floors of suggested_stat_tol below.
A statistics scene's CSV keeps only the columns its statistics (train_ref.statistics) and its
compared variables need, to keep the file small; a trace scene's keeps every output.
Runs on one process by default: the machine is shared (--jobs N for more).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from multiprocessing import Pool

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from reference_model import gearmesh_ref as G  # noqa: E402
from reference_model import lateral_ref as LR  # noqa: E402
from reference_model import train_ref as T  # noqa: E402
from reference_model.regenerate import (  # noqa: E402
    event_time_diff, max_diff, round_up, suggested_trace_tol)

REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
REF_DIR = os.path.join(REPO, "tests", "reference", "train")
CHECK_RTOL = 1e-12
PERTURB = 1e-9
ENSEMBLE_PERTURB = 1e-6
N_ENSEMBLE = 12


def all_scene_names():
    return sorted(f[:-5] for f in os.listdir(T.TRAIN_SCENES_DIR) if f.endswith(".toml"))


def check_rtol(scene):
    ref = float(scene.get("reference_rtol", T.REF_RTOL))
    return CHECK_RTOL if ref == T.REF_RTOL else max(ref / 100.0, 1e-13)


def run_job(job):
    name, variant, k = job
    scene = T.load_scene(name)
    rtol = check_rtol(scene) if variant == "tol" else float(scene.get("reference_rtol", T.REF_RTOL))
    pert = {"pert": PERTURB * k, "ens": ENSEMBLE_PERTURB * k}.get(variant, 0.0)
    t0 = time.time()
    res = LR.run_scene(scene, rtol=rtol, perturb_rel=pert)   # train_ref's unless a body is lateral
    dt = time.time() - t0
    stats = T.statistics(res.names, res.table, scene["output_interval"], res.train)
    ev = [(e[0],) for e in res.events]
    return {"name": name, "variant": variant, "k": k, "table": res.table, "names": res.names,
            "events": ev, "seconds": dt, "stats": stats, "rtol": rtol,
            "n_restarts": res.n_restarts, "n_missed": res.n_missed, "n_hidden": res.n_hidden}


def stored_columns(scene, names):
    """Indices of the columns written to the reference CSV (see the module docstring)."""
    if scene.get("mode", "trace") != "statistics":
        return list(range(len(names)))
    keep = set(scene.get("compare", {}).get("variables", []))
    for n in names:
        if n == "time" or n.endswith((".theta", ".w", ".dte", ".n_fwd", ".n_bwd")):
            keep.add(n)
    return [i for i, n in enumerate(names) if n in keep]


def suggested_stat_tol(stat, ref, devs, cycles, n_rows):
    """2x the largest deviation over the ensemble and the second-tolerance run, at least:
    1e-5 relative for mean speeds and speed ratios, two counts' worth for per-mesh-cycle counts
    (a contact shorter than one output interval may or may not show on the grid), two grid
    rows' worth for time fractions, 0.1 % for the dte statistics; rounded up to two digits."""
    spread = 2.0 * max(devs)
    if stat.endswith("per_mesh_cycle"):
        floor = 2.0 / cycles if cycles > 0 else 0.0
    elif stat.endswith("fraction"):
        floor = 2.0 / n_rows
    elif stat.endswith("mean_w") or stat.endswith("mean_ratio"):
        floor = 1e-5 * abs(ref)
    else:
        floor = 1e-3 * abs(ref)
    return round_up(max(spread, floor), 2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", help="scene names (default: all in scenes/train)")
    ap.add_argument("--no-accuracy", action="store_true", help="only regenerate the traces")
    ap.add_argument("--suggest", action="store_true", help="print policy tolerances")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--report", default=os.path.join(HERE, "accuracy_train.md"))
    args = ap.parse_args(argv)
    names = args.scenes or all_scene_names()
    scenes = {n: T.load_scene(n) for n in names}
    jobs = []
    for n in names:
        jobs.append((n, "ref", 0))
        if args.no_accuracy:
            continue
        jobs += [(n, "tol", 0), (n, "pert", 1)]
        if scenes[n].get("mode") == "statistics":
            jobs += [(n, "ens", k) for k in range(2, N_ENSEMBLE + 1)]
    t_start = time.time()
    if args.jobs > 1:
        with Pool(args.jobs) as pool:
            results = pool.map(run_job, jobs, chunksize=1)
    else:
        results = [run_job(j) for j in jobs]
    wall = time.time() - t_start
    by = {}
    for r in results:
        by.setdefault(r["name"], []).append(r)
    os.makedirs(REF_DIR, exist_ok=True)
    lines, ok_all = [], True
    for n in names:
        sc, rs = scenes[n], by[n]
        ref = next(r for r in rs if r["variant"] == "ref")
        path = os.path.join(REF_DIR, n + ".csv")
        cols = stored_columns(sc, ref["names"])
        T.write_table_csv(path, [ref["names"][i] for i in cols], ref["table"][:, cols])
        print(f"{n}: {len(ref['table'])} rows, {os.path.getsize(path) / 1e3:.0f} kB, "
              f"{ref['seconds']:.1f} s, {len(ref['events'])} events, {ref['n_restarts']} restarts")
        if args.no_accuracy:
            continue
        tol = next(r for r in rs if r["variant"] == "tol")
        pert = [r for r in rs if r["variant"] in ("pert", "ens")]
        dt = sc["output_interval"]
        mode = sc.get("mode", "trace")
        etd = event_time_diff(ref["events"], tol["events"])
        lines.append(f"### {n}  ({mode}, rtol {ref['rtol']:g}, stop {sc['stop_time']} s, "
                     f"output {dt:g} s)\n")
        lines.append(f"reference {ref['seconds']:.1f} s, {len(ref['events'])} contact events, "
                     f"{ref['n_restarts']} integrator restarts; second tolerance rtol "
                     f"{tol['rtol']:g}: {len(tol['events'])} events"
                     + (f", max event-time difference {etd:.2g} s" if etd is not None
                        else " (event count differs)")
                     + f"; missed/hidden state changes: {ref['n_missed']}/{ref['n_hidden']}\n")
        cmp = sc.get("compare", {})
        if mode == "trace":
            tols = cmp.get("tolerance", {})
            lines.append("| variable | range | tolerance | max diff rtol | perturbed: first 1 % | "
                         "perturbed: max | rtol diff / tol | perturbed / tol | growth |")
            lines.append("|---|---|---|---|---|---|---|---|---|")
            for var in cmp.get("variables", []):
                rows = G.grid_rows(ref["names"], ref["table"], dt)
                col = rows[:, ref["names"].index(var)]
                d_tol = max_diff(ref["table"], tol["table"], ref["names"], var, dt)
                d_pert = max_diff(ref["table"], pert[0]["table"], ref["names"], var, dt)
                d_early = max_diff(ref["table"], pert[0]["table"], ref["names"], var, dt, early=True)
                tv = tols.get(var, float("nan"))
                growth = d_pert / d_early if d_early > 0 else (1.0 if d_pert == 0 else float("inf"))
                good = d_tol <= 0.1 * tv and (d_pert <= 0.1 * tv or (growth <= 10 and d_pert <= tv))
                if not good:
                    ok_all = False
                lines.append(f"| {var} | {np.ptp(col):.4g} | {tv:.3g} | {d_tol:.2g} | {d_early:.2g} | "
                             f"{d_pert:.2g} | {d_tol / tv:.2g} | {d_pert / tv:.2g} | {growth:.3g}"
                             + ("" if good else "  **NOT WELL-CONDITIONED**") + " |")
                if args.suggest:
                    print(f"   {var}: suggested tolerance "
                          f"{suggested_trace_tol(ref['names'], ref['table'], var, dt):.3g} "
                          f"(range {np.ptp(col):.4g}, max |.| {np.max(np.abs(col)):.4g})")
        else:
            stols = cmp.get("statistics", {})
            lines.append(f"| statistic | reference | tolerance | diff rtol | max diff over "
                         f"{len(pert)} perturbed | worst / tolerance |")
            lines.append("|---|---|---|---|---|---|")
            tr = T.GearTrain(sc.get("start_values", {}))
            n_rows = len(G.grid_rows(ref["names"], ref["table"], dt))
            for st, v0 in ref["stats"].items():
                if st not in stols and not args.suggest:
                    continue
                d_tol = abs(tol["stats"][st] - v0)
                devs = [abs(r["stats"][st] - v0) for r in pert] + [d_tol]
                tv = stols.get(st, float("nan"))
                ratio = max(devs) / tv if tv == tv else float("nan")
                if ratio > 1.0:
                    ok_all = False
                lines.append(f"| {st} | {v0:.6g} | {tv:.3g} | {d_tol:.2g} | {max(devs[:-1]):.2g} "
                             f"| {ratio:.2g} |")
                if args.suggest:
                    m = int(st[5]) if st.startswith("mesh[") else None
                    cyc = (T.mesh_cycles(ref["names"], ref["table"], dt, tr, m) if m else 0.0)
                    print(f"   {st}: ref {v0:.8g}, suggested tolerance "
                          f"{suggested_stat_tol(st, v0, devs, cyc, n_rows):.3g} "
                          f"(max dev {max(devs):.3g})")
        lines.append("")
    if not args.no_accuracy:
        total_ref = sum(r["seconds"] for r in results if r["variant"] == "ref")
        total = sum(r["seconds"] for r in results)
        head = [
            "# Accuracy of the gear-train reference (generated by regenerate_train.py, do not edit)\n",
            f"Reference: train_ref, rtol {T.REF_RTOL:g} (DOP853), events located and the "
            "integration restarted at every one.  Each scene is run again at rtol "
            f"{CHECK_RTOL:g} and with body[1].w_start perturbed by {PERTURB:g} (relative); "
            f"statistics scenes with an ensemble of perturbations k*{ENSEMBLE_PERTURB:g}, "
            f"k = 2..{N_ENSEMBLE}.  Differences are the largest over the output-grid rows; the "
            "acceptance rule is regenerate.py's (see its docstring).\n",
            f"Run time: reference traces {total_ref:.0f} s of CPU, all runs {total:.0f} s of CPU, "
            f"{wall:.0f} s wall on {args.jobs} process(es).\n",
        ]
        text = "\n".join(head) + "\n" + "\n".join(lines) + "\n"
        if set(names) == set(all_scene_names()):
            with open(args.report, "w") as f:
                f.write(text)
            print(f"wrote {args.report}")
        else:
            print(text)
        print("ALL TRAIN SCENES WITHIN THEIR SELF-AGREEMENT CRITERIA" if ok_all else
              "SOME TRAIN SCENES FAIL THEIR SELF-AGREEMENT CRITERIA")
    print(f"wall time {wall:.0f} s")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
