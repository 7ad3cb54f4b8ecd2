#!/usr/bin/env python3
"""Regenerate the reference traces tests/reference/<scene>.csv and the accuracy report.

    .venv/bin/python tests/reference_model/regenerate.py                 # all scenes
    .venv/bin/python tests/reference_model/regenerate.py paper-m2 damped # some scenes
    .venv/bin/python tests/reference_model/regenerate.py --no-accuracy   # traces only
    .venv/bin/python tests/reference_model/regenerate.py --suggest       # print tolerance policy values

The reference is gearmesh_ref at rtol 1e-10 (DOP853; Radau when the scene sets solver = 2).  A
scene whose reference is not converged at 1e-10 (second-tolerance difference above 1/10 of a
compared tolerance, while the 1e-9 perturbation passes: an accuracy, not a conditioning problem)
may set a tighter `reference_rtol` (top-level key of its TOML; the FMU is not affected).
The accuracy report (tests/reference_model/accuracy.md, written when all scenes are run) shows
the reference's agreement with itself:
  * the same scene at a second tolerance (rtol 1e-12 for DOP853, 1e-9 for Radau, whose cost
    grows steeply below 1e-10; with reference_rtol: 1/100 of it, at least 1e-13, for DOP853),
  * the same scene with w_A_start perturbed by 1e-9 relative (1e-9 rad/s when w_A_start = 0),
  * for mode = "statistics": an ensemble of perturbations k * 1e-6 (k = 1..12; the scale of the
    FMU's own integration error) and the spread of every statistic.
A trace scene must be converged (second-tolerance difference <= 1/10 of every compared
tolerance) and well-conditioned (the perturbation's effect <= 1/10 of the tolerance, or not
growing beyond 10x its size over the first 1 % of the horizon and within the tolerance), else
it is not fit for point-by-point comparison (the script says so and exits with status 1).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from multiprocessing import Pool

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from reference_model import gearmesh_ref as G  # noqa: E402

REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
REF_DIR = os.path.join(REPO, "tests", "reference")
REF_RTOL = G.REF_RTOL
CHECK_RTOL = {"DOP853": 1e-12, "Radau": 1e-9}
PERTURB = 1e-9
# Statistics scenes are chaotic: a valid solution is any trajectory on the attractor. The FMU's
# integration error at its default rel_tol (1e-6) perturbs its trajectory by about that much all
# along, so the ensemble that sets their bounds is perturbed at that scale (k * 1e-6), not at
# 1e-9, which leaves the trajectories correlated and understates the spread.
ENSEMBLE_PERTURB = 1e-6
N_ENSEMBLE = 12
STAT_NAMES = ["mean_w_A", "mean_w_B", "mean_w_A_over_w_B", "rms_dte", "max_dte", "min_dte",
              "impacts_per_mesh_cycle", "flank_switches_per_mesh_cycle"]


def all_scene_names():
    return sorted(f[:-5] for f in os.listdir(G.SCENES_DIR) if f.endswith(".toml"))


def method_for(scene):
    return "Radau" if scene.get("start_values", {}).get("solver", 1) == 2 else "DOP853"


def check_rtol(scene, method):
    """The second tolerance: CHECK_RTOL, or for a scene with its own reference_rtol 1/100 of it
    (DOP853, at least 1e-13: tighter stalls near double precision)."""
    ref = G.scene_reference_rtol(scene)
    if ref == REF_RTOL or method != "DOP853":
        return CHECK_RTOL[method]
    return max(ref / 100.0, 1e-13)


def run_job(job):
    name, variant, k = job
    scene = G.load_scene(name)
    method = method_for(scene)
    rtol = check_rtol(scene, method) if variant == "tol" else G.scene_reference_rtol(scene)
    pert = {"pert": PERTURB * k, "ens": ENSEMBLE_PERTURB * k}.get(variant, 0.0)
    t0 = time.time()
    res = G.run_scene(scene, rtol=rtol, method=method, perturb_rel=pert)
    dt = time.time() - t0
    zA = G.GearMesh(scene.get("start_values", {})).g.zA
    stats = G.statistics(res.names, res.table, scene["output_interval"], zA)
    return {"name": name, "variant": variant, "k": k, "table": res.table, "names": res.names,
            "events": res.events, "seconds": dt, "stats": stats, "method": method,
            "rtol": rtol, "n_restarts": res.n_restarts, "n_missed": res.n_missed,
            "n_hidden": res.n_hidden}


def grid_map(names, table, dt):
    rows = G.grid_rows(names, table, dt)
    return {int(round(r[0] / dt)): r for r in rows}


def max_diff(a, b, names, var, dt, early=False):
    """Largest |a - b| of var over the grid rows (early: over the first 1 %, >= 5 rows)."""
    ga, gb = grid_map(names, a, dt), grid_map(names, b, dt)
    i = names.index(var)
    keys = sorted(set(ga) & set(gb))
    if early:
        keys = keys[:max(5, len(keys) // 100)]
    return max(abs(ga[k][i] - gb[k][i]) for k in keys)


def round_up(x, digits=1):
    if x <= 0 or not math.isfinite(x):
        return x
    e = math.floor(math.log10(x)) - (digits - 1)
    return math.ceil(x / 10 ** e - 1e-9) * 10 ** e


def suggested_trace_tol(names, table, var, dt):
    """Policy: 0.1 % of the variable's range over the scene, but not below 1e-5 of its largest
    magnitude (ten times the error of a solver at the FMU's default rel_tol 1e-6); rounded up
    to two digits."""
    rows = G.grid_rows(names, table, dt)
    col = rows[:, names.index(var)]
    return round_up(max(1e-3 * (col.max() - col.min()), 1e-5 * np.abs(col).max()), 2)


def suggested_stat_tol(stat, ref, devs, cycles):
    """Policy: 2x the largest deviation from the reference over the ensemble (perturbed runs
    and the second-tolerance run), at least 0.1 % of the value (1e-5 for the speed ratio), and
    for the per-mesh-cycle counts at least two counts' worth (a contact shorter than one output
    interval may or may not show on the grid); rounded up to two digits."""
    spread = 2.0 * max(devs)
    if stat.endswith("per_mesh_cycle"):
        floor = 2.0 / cycles if cycles > 0 else 0.0
    elif stat == "mean_w_A_over_w_B":
        floor = 1e-5
    elif stat in ("mean_w_A", "mean_w_B"):
        floor = 1e-5 * abs(ref)
    else:
        floor = 1e-3 * abs(ref)
    return round_up(max(spread, floor), 2)


def event_time_diff(ea, eb):
    if len(ea) != len(eb):
        return None
    return max((abs(x[0] - y[0]) for x, y in zip(ea, eb)), default=0.0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", help="scene names (default: all)")
    ap.add_argument("--no-accuracy", action="store_true", help="only regenerate the traces")
    ap.add_argument("--suggest", action="store_true", help="print policy tolerances for the TOMLs")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--report", default=os.path.join(HERE, "accuracy.md"))
    args = ap.parse_args(argv)
    names = args.scenes or all_scene_names()
    scenes = {n: G.load_scene(n) for n in names}
    jobs = []
    for n in names:
        jobs.append((n, "ref", 0))
        if args.no_accuracy:
            continue
        jobs.append((n, "tol", 0))
        jobs.append((n, "pert", 1))
        if scenes[n].get("mode") == "statistics":
            jobs.extend((n, "ens", k) for k in range(2, N_ENSEMBLE + 1))
    # longest first (Radau scenes) for load balance
    jobs.sort(key=lambda j: 0 if method_for(scenes[j[0]]) == "Radau" else 1)
    t_start = time.time()
    with Pool(args.jobs) as pool:
        results = pool.map(run_job, jobs, chunksize=1)
    wall = time.time() - t_start
    by = {}
    for r in results:
        by.setdefault(r["name"], []).append(r)
    os.makedirs(REF_DIR, exist_ok=True)
    lines = []
    ok_all = True
    for n in names:
        sc = scenes[n]
        rs = by[n]
        ref = next(r for r in rs if r["variant"] == "ref")
        path = os.path.join(REF_DIR, n + ".csv")
        G.write_table_csv(path, ref["names"], ref["table"])
        size = os.path.getsize(path)
        print(f"{n}: {len(ref['table'])} rows, {size / 1e3:.0f} kB, {ref['seconds']:.1f} s, "
              f"{len(ref['events'])} events, {ref['n_restarts']} restarts "
              f"({ref['method']}, rtol {ref['rtol']:g})")
        if args.no_accuracy:
            continue
        tol = next(r for r in rs if r["variant"] == "tol")
        pert = [r for r in rs if r["variant"] in ("pert", "ens")]
        dt = sc["output_interval"]
        mode = sc.get("mode", "trace")
        own = f", reference rtol {ref['rtol']:g}" if ref["rtol"] != REF_RTOL else ""
        lines.append(f"### {n}  ({mode}, {ref['method']}{own}, stop {sc['stop_time']} s, "
                     f"output {dt:g} s)\n")
        lines.append(f"reference {ref['seconds']:.1f} s, {len(ref['events'])} contact events, "
                     f"{ref['n_restarts']} integrator restarts; second tolerance rtol "
                     f"{tol['rtol']:g}: {len(tol['events'])} events"
                     + (f", max event-time difference {event_time_diff(ref['events'], tol['events']):.2g} s"
                        if event_time_diff(ref['events'], tol['events']) is not None else
                        " (event count differs)")
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
                # well-conditioned: the reference is converged (rtol diff <= tol/10) and the
                # effect of the 1e-9 perturbation is either small (<= tol/10) or does not grow
                # (<= 10x what it is in the first 1 % of the horizon, i.e. the direct response
                # to the perturbed initial speed, not a divergence)
                good = d_tol <= 0.1 * tv and (d_pert <= 0.1 * tv or (growth <= 10 and d_pert <= tv))
                flag = "" if good else "  **NOT WELL-CONDITIONED**"
                if not good:
                    ok_all = False
                lines.append(f"| {var} | {col.max() - col.min():.4g} | {tv:.3g} | {d_tol:.2g} | "
                             f"{d_early:.2g} | {d_pert:.2g} | {d_tol / tv:.2g} | {d_pert / tv:.2g} | "
                             f"{growth:.3g}{flag} |")
                if args.suggest:
                    print(f"   {var}: suggested tolerance {suggested_trace_tol(ref['names'], ref['table'], var, dt):.3g}")
        else:
            stols = cmp.get("statistics", {})
            lines.append(f"| statistic | reference | tolerance | diff rtol | max diff over {len(pert)} perturbed | worst / tolerance |")
            lines.append("|---|---|---|---|---|---|")
            thA = G.grid_rows(ref["names"], ref["table"], dt)[:, ref["names"].index("theta_A")]
            zA = G.GearMesh(sc.get("start_values", {})).g.zA
            cycles = zA * abs(thA[-1] - thA[0]) / (2 * math.pi)
            for st in STAT_NAMES:
                if st not in stols and not args.suggest:
                    continue
                v0 = ref["stats"][st]
                d_tol = abs(tol["stats"][st] - v0)
                devs = [abs(r["stats"][st] - v0) for r in pert] + [d_tol]
                tv = stols.get(st, float("nan"))
                worst = max(devs)
                ratio = worst / tv if tv == tv else float("nan")
                if ratio > 1.0:
                    ok_all = False
                lines.append(f"| {st} | {v0:.6g} | {tv:.3g} | {d_tol:.2g} | {max(devs[:-1]):.2g} | {ratio:.2g} |")
                if args.suggest:
                    print(f"   {st}: ref {v0:.8g}, suggested tolerance "
                          f"{suggested_stat_tol(st, v0, devs, cycles):.3g} (max dev {worst:.3g})")
        lines.append("")
    if not args.no_accuracy:
        total_ref = sum(r["seconds"] for r in results if r["variant"] == "ref")
        total = sum(r["seconds"] for r in results)
        head = [
            "# Accuracy of the Python reference (generated by regenerate.py, do not edit)\n",
            f"Reference: gearmesh_ref, rtol {REF_RTOL:g} (DOP853; Radau for solver = 2 scenes), "
            "events located and the integration restarted at every one (a scene with "
            "reference_rtol: that rtol, shown in its section).  ",
            "Each scene is run again at a second tolerance and with w_A_start perturbed by 1e-9 "
            "(relative; absolute rad/s if it is 0); statistics scenes with an ensemble of "
            f"perturbations k*1e-6, k = 1..{N_ENSEMBLE} (the scale of the FMU's own integration error).  Differences are the largest over the "
            "output-grid rows.  A trace scene is accepted (well-conditioned) when for every "
            "compared variable the second-tolerance difference is at most 1/10 of its "
            "tolerance and the perturbed difference is either at most 1/10 of it or does not "
            "grow (at most 10x its value over the first 1 % of the horizon, where it is the "
            "direct response to the perturbed start speed) and stays within the tolerance; a "
            "statistics scene when every statistic's ensemble spread is within its tolerance.\n",
            f"Run time: reference traces {total_ref:.0f} s of CPU, all runs {total:.0f} s of CPU, "
            f"{wall:.0f} s wall on {args.jobs} processes.\n",
        ]
        text = "\n".join(head) + "\n" + "\n".join(lines) + "\n"
        if set(names) == set(all_scene_names()):
            with open(args.report, "w") as f:
                f.write(text)
            print(f"wrote {args.report}")
        else:
            print(text)
        print("ALL SCENES WITHIN THEIR SELF-AGREEMENT CRITERIA" if ok_all else
              "SOME SCENES FAIL THEIR SELF-AGREEMENT CRITERIA")
    print(f"wall time {wall:.0f} s")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
