#!/usr/bin/env python3
"""The single mesh's report of the work-precision benchmark (tools/work_precision.py runs it; its
docstring says what is measured): the summary against the performance targets and the text of
docs/performance.md.
"""

from __future__ import annotations

import math

import numpy as np

from work_precision import (  # noqa: E402
    EQUAL_ERROR_LEVELS,
    EXPLICIT,
    FMU_SOLVERS,
    HORIZON_FRACTION,
    PAPER_M2_WINDOWS,
    RADAU_MIN_RTOL,
    TARGET_DTE,
    cheapest_explicit,
    cost_at,
    error_at_cost,
    errors,
    fmt,
    loosest_meeting,
    median_verdict,
    ok,
    rate_verdict,
    read_trace,
    scene_table,
    stats_table,
)

def summary(refs, all_results, tl):
    L = []
    A = L.append
    A("## Summary\n")
    A("| target | measured | verdict |")
    A("|---|---|---|")
    if tl.get("paper_m2_c_api"):
        rows = [r for r in tl["paper_m2_c_api"] if r["dte_rel"] <= TARGET_DTE]
        if rows:
            b = min(rows, key=lambda r: r["cpu"])
            d = tl.get("damped_c_api")
            extra = (f"; damped variant (whole scene, solver {d['solver']}, rtol "
                     f"{d['rel_tol']:.0e}): {0.1 / d['cpu']:.0f} per CPU s, "
                     f"{0.1 / d['wall']:.0f} per wall s") if d else ""
            v = 0.1 / b["cpu"]
            robust = loosest_meeting(all_results["paper-m2"], f"solver {b['solver']}")
            rr = robust and next((r for r in tl["paper_m2_c_api"]
                                  if r["rel_tol"] == robust["rel_tol"]
                                  and r["solver"] == b["solver"]), None)
            if rr and rr is not b:
                extra = (f"; {0.1 / rr['cpu']:.0f} per CPU s at rtol {rr['rel_tol']:.0e}, the "
                         f"loosest from which every tighter rtol also passes") + extra
            A(f"| paper-m2 ≥ 100 simulated s per s through the C API, dte within 0.1 % "
              f"(the damped variant ≥ 300) | "
              f"{v:.0f} per CPU s, {0.1 / b['wall']:.0f} per wall s (solver {b['solver']}, "
              f"rtol {b['rel_tol']:.0e}, "
              f"error {b['dte_rel']:.1e} of the range over t ≤ {refs['paper-m2'].horizon:.3g} s){extra} "
              f"| paper-m2: {rate_verdict(v, 100)}"
              + (f"; damped: {rate_verdict(0.1 / d['cpu'], 300)}" if d else "") + " |")
    ratios = []
    for n, res in all_results.items():
        ours = [cost_at(res, f"solver {sv}", TARGET_DTE) for sv in FMU_SOLVERS]
        ours = [o for o in ours if o]
        sp = cost_at(res, "SciPy DOP853", TARGET_DTE) or cost_at(res, "SciPy Radau", TARGET_DTE)
        if ours and sp:
            ratios.append((sp["cpu_median_s"] / min(o["cpu_median_s"] for o in ours), n))
    if ratios:
        ratios.sort()
        A(f"| ≥ 300× faster than the SciPy peer at equal error (dte error ≤ 0.1 % of the range) | "
          f"{ratios[0][0]:.0f}× ({ratios[0][1]}) to {ratios[-1][0]:.0f}× ({ratios[-1][1]}), median "
          f"{np.median([r for r, _ in ratios]):.0f}× over {len(ratios)} scenes | "
          f"{median_verdict(ratios)} |")
    ns = tl.get("dostep_ns")
    if ns:
        A(f"| fmi2DoStep without an event ≤ 1 µs | {ns:.0f} ns | {'met' if ns <= 1000 else 'missed'} |")
    if "stiff" in all_results:
        res = all_results["stiff"]
        cells = []
        verdict = None
        for e in (1e-2, TARGET_DTE, 1e-4):
            a, b = cost_at(res, "solver 2", e), cheapest_explicit(res, e)
            if a and b:
                q = b["cpu_median_s"] / a["cpu_median_s"]
                cells.append(f"{q:.0f}× at ≤ {e:g}")
                if e == TARGET_DTE:
                    verdict = "met" if q >= 10 else f"missed by {10 / q:.1f}×"
        A(f"| stiff scene: implicit ≥ 10× faster than explicit at equal error | {', '.join(cells)} | "
          f"{verdict or '–'} at 0.1 %{'' if not cells else '; see below'} |")
    if tl.get("backward"):
        cells, same = [], []
        for sc, b in tl["backward"].items():
            cells.append(f"{sc} {b['cpu']['all four'] / b['cpu']['forward only']:.2f}×")
            if b["trace_diff"] < 1e-9:    # the same trajectory with and without b1, b2
                same.append(min(b.get("round_ratios") or [0.0]))
        verdict = ("met on the scenes with the same trajectory (cheaper in every round)"
                   if same and min(same) > 1.0 else
                   "not in every round" if same else "–")
        A(f"| backward_contacts = false measurably cheaper | CPU time all four / forward only: "
          f"{', '.join(cells)} | {verdict}; see below |")
    A("")
    A("**Loosest rtol from which on (for it and every tighter rtol measured) dte stays within 0.1 % "
      "of its range**, and its cost:\n")
    A("| scene | solver 1 | solver 2 | solver 3 | solver 1 at rtol 1e-6 (the default): dte err / range, CPU ms per simulated s |")
    A("|---|---|---|---|---|")
    for n, res in all_results.items():
        cells = []
        for lab in (f"solver {sv}" for sv in FMU_SOLVERS):
            r = loosest_meeting(res, lab)
            cells.append("not reached" if r is None else
                         f"{r['rel_tol']:.0e} ({r['cpu_median_s'] * 1e3 / refs[n].stop:.3g} ms per s)")
        d = next((r for r in res if r["label"] == "solver 1" and r["rel_tol"] == 1e-6), None)
        cells.append("–" if d is None else
                     f"{fmt(d['dte_rel'], '.1e')}, {d['cpu_median_s'] * 1e3 / refs[n].stop:.3g}")
        A(f"| {n}{' (t ≤ %.3g s)' % refs[n].horizon if refs[n].horizon < refs[n].stop else ''} | "
          + " | ".join(cells) + " |")
    A("")
    A("**Where the time goes** (solver 1 and the SciPy peer at rtol 1e-6): cost per attempted "
      "step and per right-hand-side evaluation, everything included (event location, step-size "
      "control, outputs at every communication point):\n")
    A("| scene | solver 1: steps + rejected | rejected share | µs per attempted step | ns per RHS eval | SciPy: µs per RHS eval | ratio per RHS eval | SciPy / solver 1: RHS evals |")
    A("|---|---|---|---|---|---|---|---|")
    for n, res in all_results.items():
        a = next((r for r in res if r["label"] == "solver 1" and r["rel_tol"] == 1e-6 and ok(r)), None)
        b = next((r for r in res if r["label"].startswith("SciPy") and r["rel_tol"] == 1e-6 and ok(r)), None)
        if not a:
            continue
        att = a["n_steps"] + a["n_rejected_steps"]
        per_rhs = a["cpu_median_s"] / a["n_rhs_evaluations"]
        b = b if b and b["n_rhs_evaluations"] > 0 else None
        sp = "–" if not b else f"{b['cpu_median_s'] / b['n_rhs_evaluations'] * 1e6:.1f}"
        q = "–" if not b else f"{b['cpu_median_s'] / b['n_rhs_evaluations'] / per_rhs:.0f}×"
        qe = "–" if not b else f"{b['n_rhs_evaluations'] / a['n_rhs_evaluations']:.2f}"
        A(f"| {n} | {att} | {a['n_rejected_steps'] / att:.0%} | {a['cpu_median_s'] / att * 1e6:.2f} "
          f"| {per_rhs * 1e9:.0f} | {sp} | {q} | {qe} |")
    A("")
    return L


def report(info, refs, all_results, targets, args):
    L = []
    A = L.append
    A("# Performance: error against run time\n")
    A("Generated by `$(bash tools/venv.sh) tools/work_precision.py` (do not edit; the raw numbers "
      "are in `target/work-precision/results.json`). Plot: [work-precision.png](work-precision.png).\n")
    A("## How it was measured\n")
    load = ", ".join(f"{x:.1f}" for x in info["load_start"])
    load_end = ", ".join(f"{x:.1f}" for x in info["load_end"])
    A(f"- Machine: {info['cpu']}, {info['cores']} cores, {info['os']}; {info['rustc']}, Python "
      f"{info['python']}, NumPy {info['numpy']}, SciPy {info.get('scipy', '?')}; commit "
      f"{info['commit']}"
      f"{' with uncommitted changes in ' + ', '.join(info['dirty']) if info.get('dirty') else ''}; "
      f"{info['date']}. "
      f"Load average at the start {load}, at the end {load_end} (1, 5, 15 min): the machine was "
      f"shared with other work, so the tables give the median **CPU time of the simulating thread** "
      f"(`CLOCK_THREAD_CPUTIME_ID`; `time.thread_time()` for SciPy), which leaves out the time spent "
      f"waiting for a core, next to the median wall time. On an idle machine the two agree.")
    A(f"- Solvers (the `solver` parameter): {info['solver_doc']}.")
    A("- Rust integrators: `cargo run --release --example run_scene -- scenes/<scene>.toml --solver S "
      "--rtol R` (or `--integrator rk4|euler --substeps N`), in-process through the Rust API "
      "(`Simulation::advance` per communication step, outputs read after every step), repeated "
      "3 to 21 times (about 1 s of runs), median. The communication step is the scene's output "
      "interval; inputs are interpolated from the scene's CSV at each communication point and "
      "held over the step (after a step in the table, the new value).")
    A("- Naive fixed-step peer (RK4 xN, Euler xN): N substeps per communication step on the same "
      "right-hand side (`PaperRig::rhs`), no event location: before every substep every event "
      "function found past its zero is handled at the current state (`PaperRig::handle_event`), so "
      "contact onsets, separations and pair switches are detected up to a substep late and the "
      "right-hand side jumps inside substeps.")
    A(f"- SciPy peer: `gearmesh_ref.run_scene(scene, rtol, method)` (solve_ivp DOP853, Radau for "
      f"the solver = 2 scene, events located and restarted), timed in this process, median of up "
      f"to 3 runs (one run when it takes > 2 s). Radau below rtol {RADAU_MIN_RTOL:g} is left out "
      f"(about 15 s per run at 1e-9). rtol 1e-10 is the reference itself and is not run. Its "
      f"counters are summed over the restarts (solve_ivp reports accepted steps only, so its "
      f"rejected steps read –). Its error at tight tolerances is optimistic: it shares the "
      f"reference's method and event handling.")
    A("- Errors against `tests/reference/<scene>.csv` (gearmesh_ref at rtol 1e-10, self-agreement "
      "in tests/reference_model/accuracy.md) on the output grid: max |dte - dte_ref| (also divided "
      "by the reference's dte range over the compared window) and the max speed error "
      "max(|w_A - w_A,ref|, ...) divided by the largest |w| of the reference. The reference's own "
      "error floor is about 1e-9 of the range: points below it are not resolved.")
    A(f"- Chaotic scenes (mode = statistics): point errors are meaningful only while the "
      f"reference agrees with itself. The compared window ends where the reference perturbed by "
      f"1e-9 in w_A_start or run at a tighter tolerance departs from it by more than "
      f"{HORIZON_FRACTION:g} of the dte range (1/10 of the 0.1 % target); over the whole scene "
      f"the statistics are compared instead (table per scene).")
    for n, ref in refs.items():
        if ref.mode == "statistics":
            A(f"  - {n}: compared window t ≤ {ref.horizon:.4g} s ({ref.horizon_note}).")
    A(f"- Total run time of the command: {info['total_s'] / 60:.1f} min.\n")

    # ---- summary
    L.extend(summary(refs, all_results, targets))

    # ---- targets
    A("## Targets\n")
    tl = targets
    if "paper_m2_c_api" in tl:
        rows = tl["paper_m2_c_api"]
        A("**1. paper-m2 at ≥ 100 simulated s per wall-clock s, through the C API, with dte within "
          "0.1 % of its range.** paper-m2 is undamped and chaotic (contact loss and re-impacts "
          "after ~0.03 s), so the accuracy is assessed over the window in which the reference "
          f"agrees with itself (t ≤ {refs['paper-m2'].horizon:.4g} s); the run covers the whole "
          "0.1 s scene. In-process through fmi2Instantiate ... fmi2DoStep (communication step "
          "1e-4 s, fmi2GetReal of dte, w_A, w_B after every step), 3 rounds of 21 runs, median:\n")
        A("| solver | rtol | dte err / range (window) | steps | rejected | RHS evals | events | CPU ms | wall ms | simulated s per CPU s | per wall s |")
        A("|---|---|---|---|---|---|---|---|---|---|---|")
        for r in rows:
            A(f"| {r['solver']} | {r['rel_tol']:.0e} | {r['dte_rel']:.2e} | {r['n_steps']} | {r['n_rejected_steps']} "
              f"| {r['n_rhs_evaluations']} | {r['n_events']} | {r['cpu'] * 1e3:.2f} | {r['wall'] * 1e3:.2f} "
              f"| {0.1 / r['cpu']:.0f} | {0.1 / r['wall']:.0f} |")
        A("\nHow much of paper-m2 is compared matters: every flight phase and re-impact (from "
          "~0.015 s on) amplifies earlier errors. dte error of the explicit solvers (fraction of "
          "the range over the window) and their CPU time per run (Rust API, from the sweep), by "
          "window:\n")
        wins = sorted(set(PAPER_M2_WINDOWS + [refs["paper-m2"].horizon]))
        A("| solver | rtol | CPU ms per run | " + " | ".join(f"t ≤ {w:.4g} s" for w in wins) + " |")
        A("|---|---|---|" + "---|" * len(wins))
        ref = refs["paper-m2"]
        keep = ref.horizon, ref.horizon_note
        for r in all_results["paper-m2"]:
            if r["label"] not in EXPLICIT or not ok(r):
                continue
            names, table = read_trace(r["trace"])
            cells = []
            for w in wins:
                ref.set_horizon(w, "")
                cells.append(f"{errors(ref, names, table)['dte_rel']:.1e}")
            A(f"| {r['label'].split()[-1]} | {r['rel_tol']:.0e} | {r['cpu_median_s'] * 1e3:.2f} | "
              + " | ".join(cells) + " |")
        ref.set_horizon(*keep)
        if "damped_c_api" in tl:
            d = tl["damped_c_api"]
            others = "".join(f"; solver {o['solver']} at rtol {o['rtol']:.0e}, the loosest from "
                             f"which it passes: {0.1 / o['cpu']:.0f} per CPU s"
                             for o in d.get("others", {}).values())
            A(f"\nThe damped variant (scene `damped`, chi = 10 s/m, compared over the whole 0.1 s): "
              f"solver {d['solver']} at rtol {d['rel_tol']:.0e}, the loosest from which it keeps dte "
              f"within 0.1 % (error {d['dte_rel']:.2e} of the range), {0.1 / d['cpu']:.0f} simulated "
              f"s per CPU s ({0.1 / d['wall']:.0f} per wall s){others} (interleaved, C API).")
        A("")
    A("**2. ≥ 300× faster than the SciPy peer at equal error.** Cheapest measured run reaching each "
      "dte error level (fraction of the range), per scene; ratio = SciPy's CPU time / the FMU "
      "solver's (the best of solvers 1 to 3):\n")
    A("| scene | " + " | ".join(f"err ≤ {e:g}" for e in EQUAL_ERROR_LEVELS) + " |")
    A("|---|" + "---|" * len(EQUAL_ERROR_LEVELS))
    for n, res in all_results.items():
        cells = []
        for e in EQUAL_ERROR_LEVELS:
            ours = [cost_at(res, f"solver {sv}", e) for sv in FMU_SOLVERS]
            ours = [o for o in ours if o]
            sp = cost_at(res, "SciPy DOP853", e) or cost_at(res, "SciPy Radau", e)
            if not ours or not sp:
                cells.append("–")
                continue
            o = min(ours, key=lambda r: r["cpu_median_s"])
            cells.append(f"{sp['cpu_median_s'] / o['cpu_median_s']:.0f}× "
                         f"({o['label'].split()[-1]}@{o['rel_tol']:.0e} vs {sp['rel_tol']:.0e})")
        A(f"| {n} | " + " | ".join(cells) + " |")
    A("\nCell: speed ratio (the FMU's solver and rtol vs SciPy's rtol). – : one of the two did "
      "not reach that error level in the sweep.\n")
    ns = tl.get("dostep_ns")
    A(f"**3. fmi2DoStep with no event ≤ 1 µs:** {ns:.0f} ns median (`cargo bench --bench "
      f"throughput`: fmi2DoStep of 1e-7 s plus fmi2GetReal of dte inside a single-contact "
      f"interval of the damped paper rig, 21 × 1000 calls).\n" if ns else
      "**3. fmi2DoStep with no event ≤ 1 µs:** the benchmark did not run.\n")
    if "stiff" in all_results:
        res = all_results["stiff"]
        A("**4. stiff scene: the implicit solver ≥ 10× faster than the explicit at equal error.** "
          "Cheapest run of each reaching the error level:\n")
        A("| dte err / range ≤ | solver 2 (implicit) | the cheaper explicit (solver 1 or 3) | ratio |")
        A("|---|---|---|---|")
        for e in EQUAL_ERROR_LEVELS + [1e-6]:
            a, b = cost_at(res, "solver 2", e), cheapest_explicit(res, e)
            if a and b:
                A(f"| {e:g} | {a['cpu_median_s'] * 1e3:.2f} ms (rtol {a['rel_tol']:.0e}) "
                  f"| {b['cpu_median_s'] * 1e3:.1f} ms ({b['label']}, rtol {b['rel_tol']:.0e}) "
                  f"| {b['cpu_median_s'] / a['cpu_median_s']:.1f}× |")
            else:
                A(f"| {e:g} | {fmt(a and a['cpu_median_s'] * 1e3, '.2f')} | {fmt(b and b['cpu_median_s'] * 1e3, '.1f')} | – |")
        A("")
    if tl.get("backward"):
        A("**5. backward_contacts = false cheaper than all four objects** (the same scene, solver 1, "
          "rtol 1e-6, 7 alternating rounds of 11 runs, median of the round medians; the cost per "
          "attempted step divides by steps + rejected steps, which removes the effect of a "
          "different step sequence):\n")
        A("| scene | all four: CPU ms | forward only: CPU ms | ratio | ratio per round (min – max) | wall ms (all / fwd) | steps + rejected (all / fwd) | µs per attempted step (all / fwd) | ratio per step | max dte difference between the two runs |")
        A("|---|---|---|---|---|---|---|---|---|---|")
        for s, b in tl["backward"].items():
            ca, cb = b["cpu"]["all four"], b["cpu"]["forward only"]
            wa, wb = b["wall"]["all four"], b["wall"]["forward only"]
            ka, kb = b["counters"]["all four"], b["counters"]["forward only"]
            na = ka["n_steps"] + ka["n_rejected_steps"]
            nb = kb["n_steps"] + kb["n_rejected_steps"]
            rr = b.get("round_ratios") or [math.nan]
            A(f"| {s} | {ca * 1e3:.3f} | {cb * 1e3:.3f} | {ca / cb:.3f}× | {min(rr):.3f} – {max(rr):.3f} "
              f"| {wa * 1e3:.3f} / {wb * 1e3:.3f} "
              f"| {na} / {nb} | {ca / na * 1e6:.3f} / {cb / nb * 1e6:.3f} | {(ca / na) / (cb / nb):.3f}× "
              f"| {b['trace_diff']:.2e} m |")
        A("")

    # ---- naive peer at equal cost
    A("## The naive fixed-step peer at equal cost\n")
    A("For each scene: the error of solver 1 at rtol 1e-6 and at rtol 1e-4, and the smallest error "
      "the naive RK4 and Euler peers reach for at most the same CPU time.\n")
    A("| scene | solver 1 rtol 1e-4: CPU ms, dte err/range | RK4 at ≤ that cost | solver 1 rtol 1e-6 | RK4 at ≤ that cost | Euler at ≤ that cost |")
    A("|---|---|---|---|---|---|")
    for n, res in all_results.items():
        cells = []
        for rt, peers in ((1e-4, ("RK4 fixed",)), (1e-6, ("RK4 fixed", "Euler fixed"))):
            s1 = next((r for r in res if r["label"] == "solver 1" and r["rel_tol"] == rt and ok(r)), None)
            if not s1:
                cells += ["–"] * (1 + len(peers))
                continue
            cells.append(f"{s1['cpu_median_s'] * 1e3:.2f} ms, {s1['dte_rel']:.1e}")
            for peer in peers:
                p = error_at_cost(res, peer, s1["cpu_median_s"])
                if p is None:
                    cells.append("none that cheap")
                elif not math.isfinite(p["dte_rel"]):
                    cells.append("fails (unstable or out of the law's range) at every substep count that cheap")
                else:
                    cells.append(f"{fmt(p['dte_rel'], '.1e')} (x{p['substeps']}, "
                                 f"{p['cpu_median_s'] * 1e3:.2f} ms)")
        A(f"| {n} | " + " | ".join(cells) + " |")
    A("")

    # ---- per scene
    A("## Per scene\n")
    for n, res in all_results.items():
        ref = refs[n]
        A(f"### {n}\n")
        desc = ref.scene.get("description", "").split(".")[0].replace("\n", " ")
        A(f"{desc}. Stop time {ref.stop} s, communication step {ref.dt:g} s, mode {ref.mode}; "
          f"dte range {ref.dte_range():.3g} m over the compared window ({ref.horizon_note}).\n")
        L.extend(scene_table(res, ref))
        A("")
        if ref.mode == "statistics":
            A("Statistics over the whole scene (value and relative deviation from the reference; "
              "see tests/reference_model/accuracy.md for the reference's own spread under 1e-9 "
              "perturbations):\n")
            L.extend(stats_table(res, ref))
            A("")
    if tl.get("bench_output"):
        A("## `cargo bench --bench throughput` output\n")
        A("```")
        A(tl["bench_output"])
        A("```\n")
    return "\n".join(L) + "\n"
