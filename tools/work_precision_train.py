#!/usr/bin/env python3
"""The gear trains' part of the work-precision benchmark (tools/work_precision.py runs it; its
docstring says what is measured): SpurGearTrain's solvers on scenes/train/*.toml through
train-fmu/examples/run_train_scene.rs, the SciPy peer tests/reference_model/train_ref.py, their
errors against tests/reference/train/<scene>.csv, and the section "Gear trains" of
docs/performance.md.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import time

import numpy as np

from work_precision import (  # noqa: E402
    FMU_SOLVERS,
    HORIZON_FRACTION,
    OUT,
    REPO,
    TARGET_DTE,
    Counting,
    G,
    T,
    cheapest_explicit,
    cost_at,
    fmt,
    grid_index,
    label_of,
    loosest_meeting,
    ok,
    read_trace,
    reps_for,
)

# --------------------------------------------------------------------------------------------
# the gear trains (SpurGearTrain, scenes/train/*.toml)
# --------------------------------------------------------------------------------------------

TRAIN_RUNNER = os.path.join(REPO, "target", "release", "examples", "run_train_scene")
TRAIN_REF_DIR = os.path.join(REPO, "tests", "reference", "train")
TRAIN_PLOT = os.path.join(REPO, "docs", "work-precision-train.png")
TRAIN_RESULTS = os.path.join(OUT, "train-results.json")
TRAIN_BEGIN = "<!-- gear trains: begin (work_precision.py --train-only rewrites this section) -->"
TRAIN_END = "<!-- gear trains: end -->"
TRAIN_LEVELS = [1e-3, 1e-5]      # the dte error levels the section reads off


def train_scene_names():
    return sorted(f[:-5] for f in os.listdir(T.TRAIN_SCENES_DIR) if f.endswith(".toml"))


class TrainReference:
    """A train scene's reference trace on its output grid (tests/reference/train/<name>.csv,
    train_ref at rtol 1e-10), its meshes' dte columns, and the compared window."""

    def __init__(self, name):
        self.name = name
        self.scene = T.load_scene(name)
        self.dt = self.scene["output_interval"]
        self.stop = self.scene["stop_time"]
        self.mode = self.scene.get("mode", "trace")
        self.names, self.table = read_trace(os.path.join(TRAIN_REF_DIR, name + ".csv"))
        self.grid = G.grid_rows(self.names, self.table, self.dt)
        self.k = grid_index(self.grid[:, 0], self.dt)
        p = T.make_train_params(self.scene.get("start_values", {}))
        self.nb, self.ns, self.nm = p["n_bodies"], p["n_shafts"], p["n_meshes"]
        self.dte_cols = [f"mesh[{m}].dte" for m in range(1, self.nm + 1)]
        self.w_cols = [f"body[{i}].w" for i in range(1, self.nb + 1)]
        self.col = {n: self.grid[:, self.names.index(n)] for n in self.dte_cols + self.w_cols}
        self.horizon = self.stop
        self.horizon_note = "whole scene"

    def set_horizon(self, horizon, note):
        self.horizon = horizon
        self.horizon_note = note

    def window(self):
        return self.grid[:, 0] <= self.horizon + 1e-12

    def dte_ranges(self):
        win = self.window()
        return [float(np.ptp(self.col[c][win])) for c in self.dte_cols]

    def dte_range(self):
        return max(self.dte_ranges())


def train_errors(ref: TrainReference, names, table):
    """Per mesh: max |dte - dte_ref| over the compared window divided by that mesh's dte range
    there; dte_rel is the worst mesh's (worst_mesh names it, dte_abs is its absolute error).
    w_rel: the largest body speed error divided by that body's largest |w|."""
    t = table[:, names.index("time")]
    k = grid_index(t, ref.dt)
    on = np.abs(t / ref.dt - k) < 1e-6
    pos = {}
    for i, kk in enumerate(k):
        if on[i] and kk not in pos:
            pos[kk] = i
    win = ref.window()
    idx_ref, idx = [], []
    for i, kk in enumerate(ref.k):
        if win[i] and kk in pos:
            idx_ref.append(i)
            idx.append(pos[kk])
    bad = {"complete": False, "dte_abs": math.inf, "dte_rel": math.inf, "w_rel": math.inf,
           "mesh_dte_rel": [math.inf] * ref.nm, "worst_mesh": None}
    if not idx or len(idx_ref) != int(win.sum()):
        return bad
    idx_ref, idx = np.array(idx_ref), np.array(idx)
    out = {"complete": True, "mesh_dte_rel": []}
    worst = (-1.0, 0, 0.0)
    for m, (c, rng) in enumerate(zip(ref.dte_cols, ref.dte_ranges()), start=1):
        d = np.abs(table[idx, names.index(c)] - ref.col[c][idx_ref])
        e = float(d.max()) if np.all(np.isfinite(d)) else math.inf
        rel = e / rng if rng > 0 else (0.0 if e == 0 else math.inf)
        out["mesh_dte_rel"].append(rel)
        if rel > worst[0]:
            worst = (rel, m, e)
    out["dte_rel"], out["worst_mesh"], out["dte_abs"] = worst
    w = 0.0
    for c in ref.w_cols:
        scale = float(np.abs(ref.col[c][win]).max())
        e = np.abs(table[idx, names.index(c)] - ref.col[c][idx_ref])
        w = max(w, float(e.max()) / scale if np.all(np.isfinite(e)) else math.inf)
    out["w_rel"] = w
    if ref.mode == "statistics":
        out["stats_within"] = train_stats_within(ref, names, table)
    return out


def train_stats_within(ref: TrainReference, names, table):
    """How many of the scene's [compare.statistics] (train_ref.statistics over the whole scene)
    are within their bounds: (within, total), or None when they cannot be computed."""
    bounds = ref.scene.get("compare", {}).get("statistics", {})
    try:
        tr = T.GearTrain(ref.scene.get("start_values", {}))
        fs = T.statistics(names, table, ref.dt, tr)
        rs = T.statistics(ref.names, ref.table, ref.dt, tr)
        within = sum(abs(fs[s] - rs[s]) <= b for s, b in bounds.items())
    except Exception:  # noqa: BLE001 (an incomplete trace)
        return None
    return [int(within), len(bounds)]


def train_self_agreement_horizon(ref: TrainReference):
    """As self_agreement_horizon for the single mesh, on every mesh's dte: the largest T over
    which train_ref with body[1].w_start perturbed by 1e-9 and train_ref at rtol 1e-12 both stay
    within HORIZON_FRACTION of the reference's running dte range, on every mesh.  Cached in
    target/work-precision/train-horizons.json against the reference file's and the scene file's
    contents (the two runs take about 45 s for rattle)."""
    import hashlib
    h = hashlib.sha256()
    for path in (os.path.join(TRAIN_REF_DIR, ref.name + ".csv"), ref.scene["path"]):
        with open(path, "rb") as f:
            h.update(f.read())
    key = f"{ref.name}:{h.hexdigest()[:16]}:{HORIZON_FRACTION:g}"
    cache_path = os.path.join(OUT, "train-horizons.json")
    cache = {}
    if os.path.exists(cache_path):
        with open(cache_path) as f:
            cache = json.load(f)
    if key in cache:
        return tuple(cache[key])
    runs = {
        "body[1].w_start perturbed by 1e-9": T.run_scene(ref.scene, rtol=1e-10, perturb_rel=1e-9),
        "rtol 1e-12": T.run_scene(ref.scene, rtol=1e-12),
    }
    horizon = ref.stop
    detail = []
    for label, r in runs.items():
        g = G.grid_rows(r.names, r.table, ref.dt)
        n = min(len(g), len(ref.grid))
        ok_all = np.ones(n, bool)
        for c in ref.dte_cols:
            d = ref.col[c][:n]
            rng = np.maximum.accumulate(d) - np.minimum.accumulate(d)
            dev = np.maximum.accumulate(np.abs(g[:n, r.names.index(c)] - d))
            ok_all &= dev <= HORIZON_FRACTION * rng
        # as self_agreement_horizon: the last grid time at which the running deviation is within
        # the fraction of the running range (both grow with T; the start, where the range is
        # still ~0, does not count against it)
        good = np.nonzero(ok_all)[0]
        h = float(ref.grid[good[-1], 0]) if len(good) else 0.0
        detail.append(f"{label}: within {HORIZON_FRACTION:g} of each mesh's range until {h:.4g} s")
        horizon = min(horizon, h)
    out = (horizon, "; ".join(detail))
    cache[key] = list(out)
    os.makedirs(OUT, exist_ok=True)
    with open(cache_path, "w") as f:
        json.dump(cache, f, indent=1)
    return out


def train_start_args(scene):
    """A scene's start values as run_train_scene's --set arguments (integers stay integers)."""
    out = []
    for k, v in scene.get("start_values", {}).items():
        if isinstance(v, bool):
            v = "true" if v else "false"
        elif isinstance(v, float):
            v = repr(v)
        out += ["--set", f"{k}={v}"]
    return out


def run_train_rust(ref: TrainReference, trace, reps, solver, rtol):
    sc = ref.scene
    cmd = [TRAIN_RUNNER, "--stop-time", repr(float(sc["stop_time"])),
           "--output-interval", repr(float(sc["output_interval"])), "--reps", str(reps),
           "--trace", trace, "--solver", str(solver), "--rtol", repr(rtol),
           "--outputs", ",".join(ref.names[1:])] + train_start_args(sc)
    if "input_file" in sc:
        cmd += ["--input-file", os.path.join(T.TRAIN_SCENES_DIR, sc["input_file"])]
    out = subprocess.run(cmd, cwd=REPO, check=True, text=True, capture_output=True).stdout
    r = json.loads(out.strip().splitlines()[-1])
    r["scene"] = "train/" + ref.name
    return r


def run_train_scipy(ref: TrainReference, rtol, counting: Counting, max_reps=3):
    cpu, wall = [], []
    res, err = None, None
    for _ in range(max_reps):
        counting.reset()
        c0, w0 = time.thread_time(), time.perf_counter()
        try:
            res = T.run_scene(ref.scene, rtol=rtol, method="DOP853")
        except Exception as e:  # noqa: BLE001
            err, res = f"{type(e).__name__}: {e}", None
            break
        cpu.append(time.thread_time() - c0)
        wall.append(time.perf_counter() - w0)
        if sum(wall) > 2.0:
            break
    out = {"method": "scipy-DOP853", "rel_tol": rtol, "reps": len(cpu), "error": err,
           "stop_time": ref.stop, "scene": "train/" + ref.name}
    if res is not None:
        out.update(counting.c)
        out["n_events"] = len(res.events)
        out["cpu_median_s"] = float(np.median(cpu))
        out["wall_median_s"] = float(np.median(wall))
        out["t_reached"] = ref.stop
    return out, res


def sweep_train_scene(ref: TrainReference, args, counting):
    tdir = os.path.join(OUT, "traces", "train", ref.name)
    os.makedirs(tdir, exist_ok=True)
    results = []

    def record(r, names=None, table=None, path=None):
        if path is not None:
            names, table = read_trace(path)
            r["trace"] = path
        if table is not None and len(table):
            r.update(train_errors(ref, names, table))
        else:
            r.update({"dte_abs": math.inf, "dte_rel": math.inf, "w_rel": math.inf,
                      "complete": False, "mesh_dte_rel": [math.inf] * ref.nm,
                      "worst_mesh": None})
        r["label"] = label_of(r)
        results.append(r)
        status = "" if not r.get("error") else f"  [{r['error'][:70]}]"
        per_mesh = " ".join(f"{x:.1e}" for x in r["mesh_dte_rel"])
        print(f"  train/{ref.name:10s} {r['method'] + ' rtol ' + format(r['rel_tol'], '.0e'):24s} "
              f"cpu {r.get('cpu_median_s') and r['cpu_median_s'] * 1e3 or float('nan'):9.2f} ms"
              f"  dte err/range per mesh {per_mesh}  w err {r['w_rel']:.2e}{status}", flush=True)

    for solver in FMU_SOLVERS:
        last = None
        for rtol in args.rtols:
            p = os.path.join(tdir, f"solver{solver}-{rtol:.0e}.csv")
            try:
                r = run_train_rust(ref, p, reps_for(last), solver, rtol)
            except subprocess.CalledProcessError as e:
                r = {"method": f"solver{solver}", "rel_tol": rtol, "scene": "train/" + ref.name,
                     "error": (e.stderr or "")[-200:] or str(e), "cpu_median_s": None}
                record(r)
                continue
            last = r["cpu_median_s"]
            record(r, path=p)
    if not args.no_scipy:
        for rtol in args.scipy_rtols:
            r, res = run_train_scipy(ref, rtol, counting)
            if res is None:
                r["cpu_median_s"] = None
                record(r)
            else:
                record(r, names=res.names, table=res.table)
    return results


def cost_cell(r, stop):
    """rtol: CPU ms per simulated second, of the cheapest run reaching a level."""
    if r is None:
        return "not reached"
    return f"{r['rel_tol']:.0e}: {r['cpu_median_s'] * 1e3 / stop:.3g}"


def train_report(info, refs, all_results, args):
    """The section "Gear trains" of docs/performance.md (between TRAIN_BEGIN and TRAIN_END)."""
    L = [TRAIN_BEGIN, ""]
    A = L.append
    A("## Gear trains\n")
    A(f"The SpurGearTrain FMU on its scenes (`scenes/train/*.toml`), against the independent "
      f"reference (`tests/reference/train/<scene>.csv`, `train_ref` at rtol 1e-10; its "
      f"self-agreement in tests/reference_model/accuracy_train.md). Generated by "
      f"`$(bash tools/venv.sh) tools/work_precision.py --train-only` (or the full run); raw "
      f"numbers in `target/work-precision/train-results.json`. Plot: "
      f"[work-precision-train.png](work-precision-train.png).\n")
    load = ", ".join(f"{x:.1f}" for x in info["load_start"])
    load_end = ", ".join(f"{x:.1f}" for x in info["load_end"])
    A(f"- Machine and tools as above: {info['cpu']}, {info['cores']} cores; {info['rustc']}, "
      f"SciPy {info.get('scipy', '?')}; commit {info['commit']}"
      f"{' with uncommitted changes in ' + ', '.join(info['dirty']) if info.get('dirty') else ''}; "
      f"{info['date']}; load average {load} at the start of the train part, {load_end} at its "
      f"end; {info['train_s'] / 60:.1f} min for the train part"
      f"{' (--quick: fewer tolerances)' if args.quick else ''}.")
    A("- FMU: `cargo run --release -p spur_gear_train --example run_train_scene -- --set "
      "name=value ... --solver S --rtol R` (train-fmu/examples/run_train_scene.rs), in-process "
      "through the FMU's own `Slave` (`SpurGearTrain`: set the start values, setup, "
      "initialization, then per communication step the inputs, `do_step`, and every output "
      "column of the reference read back), so the cost includes what fmi2DoStep does around "
      "the integration (the copy of the simulation kept for a rollback, all outputs computed "
      "after the step). The communication step is the scene's output interval; rattle's input "
      "torque is set from its CSV at every communication point. Median of 3 to 21 runs (about "
      "1 s of runs), CPU time of the thread and wall time, as for the single mesh.")
    A("- SciPy peer: `train_ref.run_scene(scene, rtol)` (solve_ivp DOP853, every mesh's events "
      "located and the integration restarted), timed in this process as for the single mesh. "
      "rtol 1e-10 is the reference itself and is not run; its error at tight tolerances is "
      "optimistic (the same method and event handling as the reference).")
    A("- Error: for every mesh m, max |mesh[m].dte - reference| on the output grid over the "
      "compared window, divided by mesh m's dte range there; the tables give the **worst mesh** "
      "(and which one it is). Speed error: the largest |body[i].w - reference| divided by that "
      "body's largest |w|, worst body.")
    for n, ref in refs.items():
        if ref.mode == "statistics":
            A(f"- {n} is chaotic (mode = statistics): point errors are compared over t ≤ "
              f"{ref.horizon:.4g} s only, where the reference agrees with itself ("
              f"{ref.horizon_note}); over the whole scene the column 'stats within bounds' counts "
              f"the scene's own statistics ([compare.statistics], train_ref.statistics) that lie "
              f"within their bounds.")
    A("- No naive fixed-step peer (RK4 xN, Euler xN) for the trains: run_scene's is written "
      "against the single mesh's `PaperRig`; a train version needs its own stepper over "
      "`Train::rhs` and `Train::handle_event`, and the single-mesh scenes already show where "
      "that kind of integrator stands.\n")

    A("**Cheapest run reaching each dte error level** (worst mesh's error / its range; per "
      "scene the cheapest tolerance of each integrator that reaches it, CPU time per simulated "
      "second; ratio = SciPy's CPU time / the cheapest FMU solver's):\n")
    hdr = []
    for e in TRAIN_LEVELS:
        hdr += [f"≤ {e:g}: solver 1", "solver 2", "solver 3", "SciPy", "SciPy / best FMU"]
    A("| scene | " + " | ".join(hdr) + " |")
    A("|---|" + "---|" * len(hdr))
    for n, res in all_results.items():
        cells = []
        for e in TRAIN_LEVELS:
            ours = [cost_at(res, f"solver {sv}", e) for sv in FMU_SOLVERS]
            sp = cost_at(res, "SciPy DOP853", e)
            stop = refs[n].stop
            cells += [cost_cell(o, stop) for o in ours]
            cells.append(cost_cell(sp, stop))
            good = [o for o in ours if o]
            if good and sp:
                b = min(good, key=lambda r: r["cpu_median_s"])
                cells.append(f"{sp['cpu_median_s'] / b['cpu_median_s']:.0f}× (solver "
                             f"{b['label'].split()[-1]})")
            else:
                cells.append("–")
        title = n + (f" (t ≤ {refs[n].horizon:.3g} s)" if refs[n].horizon < refs[n].stop else "")
        A(f"| {title} | " + " | ".join(cells) + " |")
    A("\nCell: `rtol: CPU ms per simulated second` of the cheapest measured run of that "
      "integrator reaching the level (no interpolation between tolerances); not reached: none of "
      "its measured tolerances got there.\n")
    L.extend(train_reading(refs, all_results))
    A("**Loosest rtol from which on (it and every tighter rtol measured) the worst mesh's dte "
      "stays within 0.1 % of its range**, and solver 1 at the default rtol 1e-6:\n")
    A("| scene | solver 1 | solver 2 | solver 3 | solver 1 at rtol 1e-6: worst dte err / range (mesh), CPU ms per s |")
    A("|---|---|---|---|---|")
    for n, res in all_results.items():
        cells = []
        for sv in FMU_SOLVERS:
            r = loosest_meeting(res, f"solver {sv}")
            cells.append("not reached" if r is None else
                         f"{r['rel_tol']:.0e} ({r['cpu_median_s'] * 1e3 / refs[n].stop:.3g} ms per s)")
        d = next((r for r in res if r["label"] == "solver 1" and r["rel_tol"] == 1e-6 and ok(r)), None)
        cells.append("– (not measured)" if d is None else
                     f"{d['dte_rel']:.1e} (mesh {d['worst_mesh']}), "
                     f"{d['cpu_median_s'] * 1e3 / refs[n].stop:.3g}")
        A(f"| {n} | " + " | ".join(cells) + " |")
    A("")
    A("### Per train scene\n")
    for n, res in all_results.items():
        ref = refs[n]
        A(f"#### {n}\n")
        desc = re.split(r"(?<=[a-z0-9)]{3})\. (?=[A-Z])|: ",
                        ref.scene.get("description", "").replace("\n", " "))[0].rstrip(".")
        rngs = ", ".join(f"mesh[{m}] {x:.3g} m" for m, x in enumerate(ref.dte_ranges(), start=1))
        A(f"{desc}. {plural(ref.nb, 'body', 'bodies')}, {plural(ref.ns, 'shaft')}, "
          f"{plural(ref.nm, 'mesh', 'meshes')}; stop time {ref.stop} s, "
          f"communication step {ref.dt:g} s, mode {ref.mode}; dte range {rngs} over the compared "
          f"window ({ref.horizon_note}).\n")
        stats = ref.mode == "statistics"
        A("| integrator | setting | CPU ms per sim s | wall ms per sim s | steps | rejected | RHS evals "
          "| Jacobians | LU | events | dte err / range per mesh | worst (mesh) | speed err (rel) "
          + ("| stats within bounds " if stats else "") + "| status |")
        A("|---|" + "---|" * (13 + stats))
        for r in res:
            cpu, wall = r.get("cpu_median_s"), r.get("wall_median_s")
            status = "ok" if ok(r) else (r.get("error") or "incomplete")
            status = status.replace("|", "/").replace("\n", " ")
            if len(status) > 90:
                status = status[:87] + "..."
            per_mesh = ", ".join(fmt(x, ".1e") for x in r.get("mesh_dte_rel", []))
            sw = r.get("stats_within")
            A(f"| {r['label']} | rtol {r['rel_tol']:.0e} | {fmt(cpu and 1e3 * cpu / ref.stop, '.3g')} "
              f"| {fmt(wall and 1e3 * wall / ref.stop, '.3g')} | {r.get('n_steps', '–')} "
              f"| {r.get('n_rejected_steps', '–')} | {r.get('n_rhs_evaluations', '–')} "
              f"| {r.get('n_jacobians', '–')} | {r.get('n_factorizations', '–')} "
              f"| {r.get('n_events', '–')} | {per_mesh} | {fmt(r['dte_rel'], '.2e')}"
              f"{' (' + str(r['worst_mesh']) + ')' if r.get('worst_mesh') else ''} "
              f"| {fmt(r['w_rel'])} "
              + (f"| {'–' if not sw else f'{sw[0]} of {sw[1]}'} " if stats else "")
              + f"| {status} |")
        A("")
    A("Counters: the FMU's n_steps, n_rejected_steps, n_rhs_evaluations, n_jacobians, "
      "n_factorizations, n_events after the run; SciPy's summed over its restarts (accepted "
      "steps only, so its rejected steps read –; events are its located contact events).\n")
    A(TRAIN_END)
    return "\n".join(L) + "\n"


def plural(n, one, many=None):
    return f"{n} {one if n == 1 else (many or one + 's')}"


def train_reading(refs, all_results):
    """A short reading of the train tables, every number from the runs."""
    L = ["**Reading** (generated from the runs above):\n"]
    for e in TRAIN_LEVELS:
        parts, ratios, unreached = [], [], []
        for n, res in all_results.items():
            ours = [o for o in (cost_at(res, f"solver {sv}", e) for sv in FMU_SOLVERS) if o]
            sp = cost_at(res, "SciPy DOP853", e)
            if not ours:
                unreached.append(n)
                continue
            b = min(ours, key=lambda r: r["cpu_median_s"])
            txt = (f"{n}: solver {b['label'].split()[-1]} at rtol {b['rel_tol']:.0e}, "
                   f"{b['cpu_median_s'] * 1e3 / refs[n].stop:.3g} ms per simulated s")
            if sp:
                q = sp["cpu_median_s"] / b["cpu_median_s"]
                ratios.append(q)
                txt += (f" (SciPy: rtol {sp['rel_tol']:.0e}, "
                        f"{sp['cpu_median_s'] / refs[n].stop:.3g} s per simulated s, {q:.0f}×)")
            else:
                txt += " (SciPy: no measured rtol reaches it)"
            parts.append(txt)
        line = f"- **≤ {e:g} of the dte range** (worst mesh), cheapest: " + "; ".join(parts) + "."
        if ratios:
            line += (f" Where both reach it the FMU is {min(ratios):.0f}× to {max(ratios):.0f}× "
                     f"cheaper in CPU time than SciPy.")
        if unreached:
            line += f" Not reached by any FMU solver: {', '.join(unreached)}."
        L.append(line)
    slower = []
    for n, res in all_results.items():
        a, b = cost_at(res, "solver 2", TARGET_DTE), cheapest_explicit(res, TARGET_DTE)
        if a and b:
            slower.append((a["cpu_median_s"] / b["cpu_median_s"], n))
    if slower:
        lo, hi = min(slower), max(slower)
        L.append(f"- The implicit solver 2 (BDF) takes {lo[0]:.1f}× ({lo[1]}) to {hi[0]:.1f}× "
                 f"({hi[1]}) the cheaper explicit solver's CPU time at ≤ {TARGET_DTE:g}.")
    for n, res in all_results.items():
        ref = refs[n]
        if ref.mode != "statistics":
            continue
        fmu = [r for r in res if r["label"].startswith("solver") and r.get("stats_within")]
        if fmu:
            worst = min(fmu, key=lambda r: r["stats_within"][0] / r["stats_within"][1])
            w = worst["stats_within"]
            L.append(f"- {n}: the pointwise errors cover only t ≤ {ref.horizon:.3g} s of "
                     f"{ref.stop:g} s (no longer does the reference agree with itself), before "
                     f"the rattle proper. Over the whole scene every FMU run keeps at least {w[0]} "
                     f"of its {w[1]} statistics within the scene's bounds (the fewest: "
                     f"{worst['label']} at rtol {worst['rel_tol']:.0e}).")
    L.append("")
    return L


def splice_train_section(doc_text, section):
    """The doc with its train section replaced (or appended when it has none)."""
    i, j = doc_text.find(TRAIN_BEGIN), doc_text.find(TRAIN_END)
    if i >= 0 and j > i:
        return doc_text[:i] + section.rstrip("\n") + doc_text[j + len(TRAIN_END):]
    return doc_text.rstrip("\n") + "\n\n" + section


def run_trains(names, args, counting, info):
    """The train sweep; returns (refs, results) and writes train-results.json."""
    t0 = time.perf_counter()
    info["load_start"] = os.getloadavg()
    refs = {n: TrainReference(n) for n in names}
    for n, ref in refs.items():
        if ref.mode == "statistics":
            print(f"train/{n}: self-agreement horizon of the reference ...", flush=True)
            h, note = train_self_agreement_horizon(ref)
            ref.set_horizon(h, note)
            print(f"  {note}", flush=True)
    results = {}
    for n in names:
        print(f"== train/{n}", flush=True)
        results[n] = sweep_train_scene(refs[n], args, counting)
    info["load_end"] = os.getloadavg()
    info["train_s"] = time.perf_counter() - t0
    with open(TRAIN_RESULTS, "w") as f:
        json.dump({"info": info, "results": results,
                   "horizons": {n: [r.horizon, r.horizon_note] for n, r in refs.items()}},
                  f, indent=1, default=str)
    return refs, results
