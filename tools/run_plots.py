#!/usr/bin/env python3
"""The traces of a SpurGearTrain run (a CSV written by `fmpy simulate`): per mesh dte and the
flank forces, the body speeds and shaft torques; for a planetary train the meshes per carrier,
the planets' load sharing, the speeds and housing.tau.

From Python: `plot_run(csv_path, out_png, params)`; from the shell: `tools/train_layout.py run`.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from layout_drawing import BODY_COLORS, HOUSING_COLOR, _color, _end  # noqa: E402
from train_layout import HOUSING, NAME_RE, layout  # noqa: E402

# --------------------------------------------------------------------------------------------
# Run traces
# --------------------------------------------------------------------------------------------

def read_run_csv(path) -> dict:
    """{name: [float]} from a CSV written by fmpy (quoted header, first column time)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError(f"{path}: empty CSV")
    names = [n.strip().strip('"') for n in rows[0]]
    if names[0] != "time":
        raise ValueError(f"{path}: the first column must be 'time', got {names[0]!r}")

    def num(s):
        s = s.strip()
        if s in ("True", "true"):
            return 1.0
        if s in ("False", "false"):
            return 0.0
        return float(s)

    cols = {n: [] for n in names}
    for r in rows[1:]:
        if not r:
            continue
        for n, s in zip(names, r):
            cols[n].append(num(s))
    return cols


def _indexed(cols, kind, field):
    out = {}
    for name in cols:
        mt = NAME_RE.match(name)
        if mt and mt.group(1) == kind and mt.group(3) == field:
            out[int(mt.group(2))] = cols[name]
    return dict(sorted(out.items()))


def _all_zero(v):
    return all(x == 0.0 for x in v)


def planet_mesh_groups(lay) -> dict:
    """The planets' meshes of a layout, grouped for load sharing: {(carrier, central member,
    'sun' or 'ring'): [mesh, ...]} for every mesh in a carrier's frame between a planet and a
    central member (a housing-mounted body or the housing, 0); 'ring' when the mesh is internal.
    Groups of one mesh are left out."""
    groups = {}
    for m, mm in sorted(lay["meshes"].items()):
        c = mm["carrier"]
        if c is None:
            continue
        ends = [x for x in (mm["A"], mm["B"]) if x == HOUSING or not lay["bodies"][x]["carrier"]]
        if len(ends) != 1:
            continue            # planet-planet
        kind = "ring" if mm["internal"] else "sun"
        groups.setdefault((c, ends[0], kind), []).append(m)
    return {k: v for k, v in groups.items() if len(v) > 1}


def load_shares(cols, meshes):
    """Each mesh's force over the mean over `meshes` at every row: (flank, {m: [share]}), the
    flank ('F_fwd' or 'F_bwd') the one carrying the larger mean force over the run (a mean of 0
    gives NaN)."""
    fwd = {m: cols.get(f"mesh[{m}].F_fwd") for m in meshes}
    bwd = {m: cols.get(f"mesh[{m}].F_bwd") for m in meshes}
    if any(v is None for v in fwd.values()):
        raise ValueError("load sharing needs every mesh[m].F_fwd of "
                         + ", ".join(f"mesh[{m}]" for m in meshes))
    use, flank = fwd, "F_fwd"
    if all(v is not None for v in bwd.values()):
        sf = sum(abs(x) for v in fwd.values() for x in v)
        sb = sum(abs(x) for v in bwd.values() for x in v)
        if sb > sf:
            use, flank = bwd, "F_bwd"
    n = len(next(iter(use.values())))
    shares = {m: [] for m in meshes}
    for k in range(n):
        mean = sum(use[m][k] for m in meshes) / len(meshes)
        for m in meshes:
            shares[m].append(use[m][k] / mean if mean != 0.0 else float("nan"))
    return flank, shares


def plot_run(csv_path, out_png, params: dict | None = None):
    """One row per mesh (dte [um]; F_fwd, F_bwd and the per-pair forces present [N]) and a
    last row with the body speeds and shaft torques when present. Elements whose columns are all
    zero (beyond n_*, spec section 6) are left out. Returns the mesh indices plotted.

    With `params` (the run's FMI start values) of a planetary train (planetary.md): one row per
    group of meshes (each carrier's sun-planet meshes, its planet-ring meshes, the rest), every
    mesh's dte on the left and its F_fwd (solid) and F_bwd (dashed) on the right; a row with the
    planets' load sharing (each sun-planet, and each planet-ring, mesh's force over the mean over
    the planets, see load_shares); and a last row with the body speeds and housing.tau with the
    shaft torques."""
    if params is not None:
        lay = layout(params)
        if lay["general"]:
            return _plot_planetary_run(csv_path, out_png, lay)
    cols = read_run_csv(csv_path)
    t = cols["time"]
    dte = _indexed(cols, "mesh", "dte")
    force_fields = ["F_fwd", "F_bwd", "F_f1", "F_f2", "F_b1", "F_b2"]
    forces = {f: _indexed(cols, "mesh", f) for f in force_fields}
    mesh_ids = sorted(set(dte) | {m for f in force_fields for m in forces[f]})
    mesh_ids = [m for m in mesh_ids
                if not (_all_zero(dte.get(m, [0.0]))
                        and all(_all_zero(forces[f].get(m, [0.0])) for f in force_fields))]
    speeds = {i: v for i, v in _indexed(cols, "body", "w").items() if not _all_zero(v)}
    torques = {j: v for j, v in _indexed(cols, "shaft", "tau").items() if not _all_zero(v)}
    if not mesh_ids and not speeds and not torques:
        raise ValueError(f"{csv_path}: no non-zero mesh[m].dte / F_*, body[i].w or shaft[j].tau "
                         f"columns (got {', '.join(list(cols)[:8])}...)")
    extra = 1 if (speeds or torques) else 0
    nrows = len(mesh_ids) + extra
    fig, axes = plt.subplots(nrows, 2, figsize=(12, 2.6 * nrows + 0.6), sharex=True,
                             squeeze=False)
    for row, m in enumerate(mesh_ids):
        a1, a2 = axes[row]
        if m in dte:
            a1.plot(t, [1e6 * x for x in dte[m]], color="C0", lw=1.0)
        a1.set_ylabel(f"mesh[{m}].dte [um]")
        if m in dte and min(dte[m]) <= 0.0 <= max(dte[m]):   # contact lost: show the zero
            a1.axhline(0.0, color="0.6", lw=0.6)
        for f, style in zip(force_fields, [dict(color="C3", lw=1.4), dict(color="C2", lw=1.4),
                                           dict(color="C1", lw=0.8, ls="--"),
                                           dict(color="C4", lw=0.8, ls="--"),
                                           dict(color="C5", lw=0.8, ls=":"),
                                           dict(color="C6", lw=0.8, ls=":")]):
            v = forces[f].get(m)
            if v is None or (f not in ("F_fwd", "F_bwd") and _all_zero(v)):
                continue
            a2.plot(t, v, label=f, **style)
        a2.set_ylabel(f"mesh[{m}] force [N]")
        if a2.lines:
            a2.legend(fontsize=7, ncol=3, loc="best")
    if extra:
        a1, a2 = axes[-1]
        for i, v in speeds.items():
            a1.plot(t, v, lw=1.0, color=BODY_COLORS[(i - 1) % len(BODY_COLORS)],
                    label=f"body[{i}].w")
        a1.set_ylabel("speed [rad/s]\n(forward positive)")
        if speeds:
            a1.legend(fontsize=7, ncol=2, loc="best")
        for j, v in torques.items():
            a2.plot(t, v, lw=1.0, label=f"shaft[{j}].tau")
        a2.set_ylabel("shaft torque [N.m]")
        if torques:
            a2.legend(fontsize=7, loc="best")
    for ax in axes.flat:
        ax.grid(True, lw=0.3, alpha=0.5)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    fig.suptitle(f"SpurGearTrain run: {Path(csv_path).name}", fontsize=10)
    fig.tight_layout()
    Path(out_png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=110)
    plt.close(fig)
    return mesh_ids


_OVERLAP_LW = [2.4, 1.5, 0.8, 0.5]


def _plot_planetary_run(csv_path, out_png, lay):
    cols = read_run_csv(csv_path)
    t = cols["time"]
    dte = _indexed(cols, "mesh", "dte")
    fwd, bwd = _indexed(cols, "mesh", "F_fwd"), _indexed(cols, "mesh", "F_bwd")
    shared = planet_mesh_groups(lay)
    rows, seen = [], set()
    for (c, central, kind), ms in shared.items():
        rows.append((f"carrier body {c}: {kind}-planet meshes ({_end(central)})", ms))
        seen |= set(ms)
    rest = [m for m in sorted(lay["meshes"]) if m not in seen]
    if rest:
        rows.append(("other meshes", rest))
    rows = [(name, [m for m in ms if m in dte or m in fwd]) for name, ms in rows]
    rows = [(name, ms) for name, ms in rows if ms]
    speeds = {i: v for i, v in _indexed(cols, "body", "w").items() if not _all_zero(v)}
    torques = {j: v for j, v in _indexed(cols, "shaft", "tau").items() if not _all_zero(v)}
    housing = cols.get("housing.tau")
    if not rows and not speeds:
        raise ValueError(f"{csv_path}: no mesh[m].dte / F_fwd or body[i].w columns of this train")
    share_row = 1 if shared else 0
    nrows = len(rows) + share_row + 1
    fig, axes = plt.subplots(nrows, 2, figsize=(13, 2.7 * nrows + 0.7), sharex=True,
                             squeeze=False)
    plotted = []
    for r, (name, ms) in enumerate(rows):
        a1, a2 = axes[r]
        for k, m in enumerate(ms):
            # decreasing widths: planets in phase draw the same curve, and all stay visible
            col, lw = f"C{k % 10}", _OVERLAP_LW[k % len(_OVERLAP_LW)]
            if m in dte:
                a1.plot(t, [1e6 * x for x in dte[m]], color=col, lw=lw, label=f"mesh[{m}]")
            if m in fwd:
                a2.plot(t, fwd[m], color=col, lw=lw, label=f"mesh[{m}].F_fwd")
            if m in bwd and not _all_zero(bwd[m]):
                a2.plot(t, bwd[m], color=col, lw=lw, ls="--", label=f"mesh[{m}].F_bwd")
            plotted.append(m)
        a1.set_ylabel("dte [um]")
        a1.set_title(name, fontsize=9, loc="left")
        a2.set_ylabel("force [N]")
        for a in (a1, a2):
            if a.lines:
                a.legend(fontsize=7, ncol=3, loc="best")
    if share_row:
        a1, a2 = axes[len(rows)]
        for a, kind in ((a1, "sun"), (a2, "ring")):
            groups = [(k, ms) for k, ms in shared.items() if k[2] == kind]
            for (c, central, _kind), ms in groups:
                if not all(f"mesh[{m}].F_fwd" in cols for m in ms):
                    continue
                flank, sh = load_shares(cols, ms)
                for k, m in enumerate(ms):
                    planet = (lay["meshes"][m]["A"] if lay["meshes"][m]["B"] == central
                              else lay["meshes"][m]["B"])
                    a.plot(t, sh[m], lw=_OVERLAP_LW[k % len(_OVERLAP_LW)], color=f"C{k % 10}",
                           label=f"body {planet}: mesh[{m}].{flank} / mean")
            a.axhline(1.0, color="0.5", lw=0.6)
            vals = [y for ln in a.lines for y in ln.get_ydata() if math.isfinite(y)]
            a.set_ylim(min([0.9] + vals) - 0.02, max([1.1] + vals) + 0.02)   # not 1 +- 1e-10
            a.ticklabel_format(axis="y", useOffset=False)
            a.set_ylabel(f"{kind}-planet load share")
            a.set_title(f"planets' load sharing, {kind}-planet meshes (1 = equal shares)",
                        fontsize=9, loc="left")
            if a.lines[:-1] if a.lines else False:
                a.legend(fontsize=7, ncol=2, loc="best")
    a1, a2 = axes[-1]
    for i, v in speeds.items():
        a1.plot(t, v, lw=1.0, color=_color(i), label=f"body[{i}].w")
    a1.set_ylabel("speed [rad/s]\n(forward positive)")
    if speeds:
        a1.legend(fontsize=7, ncol=3, loc="best")
    if housing is not None:
        a2.plot(t, housing, lw=1.2, color=HOUSING_COLOR, label="housing.tau")
    for j, v in torques.items():
        a2.plot(t, v, lw=1.0, label=f"shaft[{j}].tau")
    a2.set_ylabel("torque [N.m]")
    if a2.lines:
        a2.legend(fontsize=7, loc="best")
    for ax in axes.flat:
        ax.grid(True, lw=0.3, alpha=0.5)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    fig.suptitle(f"SpurGearTrain run: {Path(csv_path).name}", fontsize=10)
    fig.tight_layout()
    Path(out_png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=110)
    plt.close(fig)
    return plotted
