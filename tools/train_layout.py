#!/usr/bin/env python3
"""See a SpurGearTrain gearbox: its layout in the housing frame, and the traces of a run.

The layout follows /work/shared/spec/gear-train.md from the train FMU's own parameters (FMI
names of spec section 6; missing names take the FMU's defaults): bodies placed by walking the
tree from body 1 at the origin (a mesh puts its other body at its centre distance d in the
direction `center_angle` of O_A -> O_B; a shaft joins two coaxial bodies), forward senses
(sigma_1 = -1, flipped across a mesh, kept across a shaft), each gear as its operating pitch
circle with its tip and base circles, and each mesh's forward line of action K_A K_B with the
contact segment a-b, computed in the mesh's paper frame (gear-mesh-model.md section 2, through
the reference model's `Geometry`) and mapped back to the housing frame (spec section 3).

    .venv/bin/python tools/train_layout.py layout [--set name=value ...] \\
        [--scene scenes/train/X.toml] -o out/train-layout.png
    .venv/bin/python tools/train_layout.py run results.csv -o out/train-run.png

Quote --set arguments in the shell ('mesh[2].zA=33'): brackets are glob characters. A scene is a
TOML file with a [start_values] table of FMI names, quoted there too ("mesh[2].zA" = 33).

`run` plots a CSV written by `fmpy simulate` (first column `time`, columns named by FMI name):
per mesh dte [um] and the flank forces, then the body speeds and the shaft torques.

From Python: `layout(params) -> dict`, `draw_layout(params, path)`, `plot_run(csv_path, out_png)`.
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import sys
import tomllib
import warnings
from collections import deque
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from reference_model import gearmesh_ref as G  # noqa: E402

# Fixed capacity of the train FMU (spec section 1 and 6).
CAPACITY = {"body": 8, "shaft": 7, "mesh": 6}
# Counts: the train FMU's defaults (a two-stage reducer with a compliant intermediate shaft).
COUNT_DEFAULTS = {"n_bodies": 4, "n_shafts": 1, "n_meshes": 2}
COUNT_NAMES = {"body": "n_bodies", "shaft": "n_shafts", "mesh": "n_meshes"}
# Whole-train parameters that do not change the layout (accepted, not used).
TRAIN_SCALARS = {"solver", "rel_tol", "statistics", "stats_start"}
BODY_FIELDS = {"J", "c", "w_start", "tau"}        # + angle_start on body[1] only
SHAFT_FIELDS = {"a", "b", "k", "d", "twist_start"}
MESH_PLACEMENT = {"A", "B", "center_angle", "mount_A", "mount_B"}
# Single-mesh parameters that a train does not have (spec section 1: bodies carry inertia, drag,
# start speed and external torque; solver and tolerance belong to the whole train).
NOT_IN_TRAIN = {"J_A", "J_B", "c_load", "w_A_start", "w_B_start", "tau_A", "tau_B", "solver",
                "rel_tol", "restitution"}
MESH_GEAR_FIELDS = set(G.DEFAULTS) - NOT_IN_TRAIN
INTEGER_FIELDS = {("shaft", "a"), ("shaft", "b"), ("mesh", "A"), ("mesh", "B")}

NAME_RE = re.compile(r"^(body|shaft|mesh)\[(\d+)\]\.(\w+)$")


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------

def _element_default(kind: str, idx: int, field: str):
    """The FMU's start value of an element parameter, or None if the spec does not fix one."""
    if kind == "mesh":
        if field == "A":
            return 2 * idx - 1
        if field == "B":
            return 2 * idx
        if field in ("center_angle", "mount_A", "mount_B"):
            return 0.0
        if field in MESH_GEAR_FIELDS:
            return G.DEFAULTS[field]
    if kind == "shaft" and idx == 1 and field in ("a", "b"):
        return {"a": 2, "b": 3}[field]
    if kind == "body" and field == "angle_start":
        return 0.0
    return None


def _as_int(name: str, v) -> int:
    if isinstance(v, bool) or int(v) != v:
        raise ValueError(f"{name} must be an integer, got {v!r}")
    return int(v)


def parse_params(params: dict) -> dict:
    """Checks the FMI names; returns {'counts': {...}, 'body': {i: {field: v}}, 'shaft': ...,
    'mesh': ...} with only the names given. Names the train does not know are warned about and
    ignored; malformed element names raise ValueError."""
    counts = dict(COUNT_DEFAULTS)
    given = {"body": {}, "shaft": {}, "mesh": {}}
    unknown = []
    for name, v in params.items():
        if name in COUNT_DEFAULTS:
            counts[name] = _as_int(name, v)
            continue
        if name in TRAIN_SCALARS:
            continue
        mt = NAME_RE.match(name)
        if not mt:
            unknown.append(name)
            continue
        kind, idx, field = mt.group(1), int(mt.group(2)), mt.group(3)
        if not 1 <= idx <= CAPACITY[kind]:
            raise ValueError(f"{name}: {kind} index {idx} outside 1..{CAPACITY[kind]} "
                             f"(the train's capacity)")
        known = {"body": BODY_FIELDS | ({"angle_start"} if idx == 1 else set()),
                 "shaft": SHAFT_FIELDS,
                 "mesh": MESH_PLACEMENT | MESH_GEAR_FIELDS}[kind]
        if field not in known:
            if kind == "mesh" and field in NOT_IN_TRAIN:
                raise ValueError(f"{name}: the single mesh's {field!r} is not a train parameter "
                                 f"(gear-train.md section 1: bodies carry inertia, drag, start "
                                 f"speed and torque; solver and rel_tol belong to the train)")
            unknown.append(name)
            continue
        if (kind, field) in INTEGER_FIELDS:
            v = _as_int(name, v)
        given[kind].setdefault(idx, {})[field] = v
    if unknown:
        warnings.warn("not train layout parameters, ignored: " + ", ".join(sorted(unknown)),
                      stacklevel=3)
    for kind, cname in COUNT_NAMES.items():
        lo = 1 if kind == "body" else 0
        if not lo <= counts[cname] <= CAPACITY[kind]:
            raise ValueError(f"{cname} = {counts[cname]} outside {lo}..{CAPACITY[kind]}")
    return {"counts": counts, **given}


def _value(parsed: dict, kind: str, idx: int, field: str):
    v = parsed[kind].get(idx, {}).get(field)
    if v is None:
        v = _element_default(kind, idx, field)
    if v is None:
        raise ValueError(f"{kind}[{idx}].{field} is not set and the train has no agreed default "
                         f"for it; set it")
    return v


def mesh_gear_params(parsed: dict, m: int) -> dict:
    """The single-mesh start values of mesh m (its `mesh[m].<name>`, defaults otherwise)."""
    given = {k: v for k, v in parsed["mesh"].get(m, {}).items() if k in MESH_GEAR_FIELDS}
    if given.get("contact_model") == 2:
        raise ValueError(f"mesh[{m}].contact_model = 2: rigid contact is not available in a train "
                         f"(gear-train.md section 1); use 1 or 3")
    try:
        return G.make_params(given)
    except (KeyError, TypeError) as e:
        raise ValueError(f"mesh[{m}]: {e}") from None


# --------------------------------------------------------------------------------------------
# Topology
# --------------------------------------------------------------------------------------------

def _edges(parsed: dict):
    """[(label, kind, index, a, b)] for every shaft and mesh in use, ends checked."""
    n = parsed["counts"]["n_bodies"]
    edges = []
    for kind, ends in (("shaft", ("a", "b")), ("mesh", ("A", "B"))):
        for j in range(1, parsed["counts"][COUNT_NAMES[kind]] + 1):
            label = f"{kind}[{j}]"
            e = [_as_int(f"{label}.{f}", _value(parsed, kind, j, f)) for f in ends]
            for f, i in zip(ends, e):
                if not 1 <= i <= n:
                    raise ValueError(f"{label}.{f} = {i} is not a body: indices run 1..n_bodies "
                                     f"= 1..{n}")
            if e[0] == e[1]:
                raise ValueError(f"{label} joins body {e[0]} to itself ({label}.{ends[0]} = "
                                 f"{label}.{ends[1]} = {e[0]})")
            edges.append((label, kind, j, e[0], e[1]))
    return edges


def check_topology(parsed: dict):
    """Raises ValueError unless the shafts and meshes form a tree on the bodies (spec section 1).
    Returns the edges."""
    n = parsed["counts"]["n_bodies"]
    edges = _edges(parsed)
    adj = {i: [] for i in range(1, n + 1)}
    for e in edges:
        label, _kind, _j, a, b = e
        # a path a ~> b through the edges so far means this edge closes a cycle
        path = _path(adj, a, b)
        if path is not None:
            elems = sorted(path + [e], key=lambda x: (x[1] != "shaft", x[2]))
            cyc_bodies = sorted({x[3] for x in elems} | {x[4] for x in elems})
            raise ValueError(
                f"{label} (bodies {a}-{b}) closes a cycle through bodies "
                f"{', '.join(map(str, cyc_bodies))}: {', '.join(x[0] for x in elems)} "
                f"(the bodies, shafts and meshes must form a tree; cycles of meshes are planetary "
                f"sets, out of scope)")
        adj[a].append((b, e))
        adj[b].append((a, e))
    seen = _reachable(adj, 1)
    lost = [i for i in range(1, n + 1) if i not in seen]
    if lost:
        raise ValueError(
            f"body {', body '.join(map(str, lost))} not connected to body 1 by any shaft or mesh "
            f"({len(edges)} edges for {n} bodies; a tree needs n_bodies - 1 = {n - 1})")
    return edges


def _path(adj, a, b):
    """The edges on the path a ~> b, or None."""
    prev = {a: None}
    q = deque([a])
    while q:
        i = q.popleft()
        if i == b:
            edges = []
            while prev[i] is not None:
                i, e = prev[i]
                edges.append(e)
            return edges[::-1]
        for k, e in adj[i]:
            if k not in prev:
                prev[k] = (i, e)
                q.append(k)
    return None


def _reachable(adj, start):
    seen = {start}
    q = deque([start])
    while q:
        i = q.popleft()
        for k, _e in adj[i]:
            if k not in seen:
                seen.add(k)
                q.append(k)
    return seen


# --------------------------------------------------------------------------------------------
# Layout
# --------------------------------------------------------------------------------------------

def paper_to_housing(p, O_A, beta, sigma_A):
    """Housing coordinates of a point p of a mesh's paper frame (spec section 3: the paper frame
    is the housing frame translated to O_A, rotated by beta and mirrored y -> -y when
    sigma_A = +1), i.e.  P = O_A + R(beta) diag(1, -sigma_A) p."""
    x, y = p[0], -sigma_A * p[1]
    c, s = math.cos(beta), math.sin(beta)
    return (O_A[0] + c * x - s * y, O_A[1] + s * x + c * y)


def layout(params: dict) -> dict:
    """The gearbox in the housing frame [m, rad] from the train FMU's parameters (FMI names).

    Returns {'counts', 'bodies': {i: {'center', 'sigma', 'J', 'gears': [gear, ...]}},
    'shafts': {j: {'a', 'b', 'k'}}, 'meshes': {m: {...}}, 'gears': [...]} where a gear is
    {'body', 'mesh', 'side' ('A'/'B'), 'z', 'r_w', 'r_b', 'r_tip', 'mount', 't'} and a mesh holds
    'A', 'B', 'beta', 'sigma_A', 'geometry' (the reference model's Geometry), the housing-frame
    points 'O_A', 'O_B', 'K_A', 'K_B', 'a', 'b' (contact segment ends), 'P' (pitch point) and
    'u' (unit direction K_A -> K_B of the forward line of action).
    """
    parsed = parse_params(params)
    counts = parsed["counts"]
    edges = check_topology(parsed)
    n = counts["n_bodies"]

    meshes = {}
    for label, kind, m, a, b in edges:
        if kind != "mesh":
            continue
        p = mesh_gear_params(parsed, m)
        try:
            g = G.Geometry(p)
        except G.GeometryError as e:
            raise ValueError(f"{label}: {e}") from None
        if p["geometry"] == 1:  # paper geometry: rA given, rB = rA zB_nominal / zA_nominal
            r_wA = p["rA"]
            r_wB = p["rA"] * p["zB_nominal"] / p["zA_nominal"]
        else:                   # standard: operating pitch radius r_w = r_b / cos(alpha_w)
            r_wA = g.rAb / math.cos(g.alpha_w)
            r_wB = g.rBb / math.cos(g.alpha_w)
        meshes[m] = {
            "A": a, "B": b, "geometry": g, "params": p,
            "beta": float(_value(parsed, "mesh", m, "center_angle")),
            "mount_A": float(_value(parsed, "mesh", m, "mount_A")),
            "mount_B": float(_value(parsed, "mesh", m, "mount_B")),
            "r_wA": r_wA, "r_wB": r_wB,
        }

    # walk the tree from body 1 at the origin
    center = {1: (0.0, 0.0)}
    sigma = {1: -1}
    adj = {i: [] for i in range(1, n + 1)}
    for e in edges:
        adj[e[3]].append(e)
        adj[e[4]].append(e)
    q = deque([1])
    while q:
        i = q.popleft()
        for _label, kind, j, a, b in adj[i]:
            other = b if i == a else a
            if other in center:
                continue
            if kind == "shaft":
                center[other] = center[i]
                sigma[other] = sigma[i]
            else:
                mm = meshes[j]
                d, beta = mm["geometry"].d, mm["beta"]
                step = (d * math.cos(beta), d * math.sin(beta))
                sgn = 1.0 if i == a else -1.0      # O_B = O_A + d (cos beta, sin beta)
                center[other] = (center[i][0] + sgn * step[0], center[i][1] + sgn * step[1])
                sigma[other] = -sigma[i]
            q.append(other)

    gears = []
    for m, mm in meshes.items():
        g = mm["geometry"]
        sA = sigma[mm["A"]]
        O_A, O_B = center[mm["A"]], center[mm["B"]]
        aw, beta = g.alpha_w, mm["beta"]
        # paper frame (gear-mesh-model.md section 2): O_A = 0, O_B = (d, 0), A turns clockwise;
        # the forward line of action touches A's base circle at K_A = rAb (cos aw, sin aw) and
        # B's at K_B = O_B - rBb (cos aw, sin aw), direction u = (sin aw, -cos aw), and
        # K_B = K_A + L u because rAb + rBb = d cos aw.  The contact segment runs from
        # a = K_A + s_a u to b = K_A + s_b u; the pitch point P = K_A + rAb tan(aw) u.
        ca, sa = math.cos(aw), math.sin(aw)
        u = (sa, -ca)
        K_A = (g.rAb * ca, g.rAb * sa)
        pts = {
            "K_A": K_A,
            "K_B": (g.d - g.rBb * ca, -g.rBb * sa),
            "a": (K_A[0] + g.s_a * u[0], K_A[1] + g.s_a * u[1]),
            "b": (K_A[0] + g.s_b * u[0], K_A[1] + g.s_b * u[1]),
            "P": (K_A[0] + g.rAb * math.tan(aw) * u[0], K_A[1] + g.rAb * math.tan(aw) * u[1]),
        }
        for k, v in pts.items():
            mm[k] = paper_to_housing(v, O_A, beta, sA)
        # a direction maps without the translation
        ux, uy = paper_to_housing(u, (0.0, 0.0), beta, sA)
        mm.update(O_A=O_A, O_B=O_B, sigma_A=sA, sigma_B=sigma[mm["B"]], u=(ux, uy))
        for side, body, z, r_w, r_b, r_tip, mount, t in (
                ("A", mm["A"], g.zA, mm["r_wA"], g.rAb, g.r_tipA, mm["mount_A"], g.tA),
                ("B", mm["B"], g.zB, mm["r_wB"], g.rBb, g.r_tipB, mm["mount_B"], g.tB)):
            gears.append({"body": body, "mesh": m, "side": side, "z": z, "r_w": r_w, "r_b": r_b,
                          "r_tip": r_tip, "mount": mount, "t": t})

    bodies = {}
    for i in range(1, n + 1):
        J = parsed["body"].get(i, {}).get("J")
        bodies[i] = {"center": center[i], "sigma": sigma[i], "J": J,
                     "gears": [gg for gg in gears if gg["body"] == i]}
    shafts = {}
    for _label, kind, j, a, b in edges:
        if kind == "shaft":
            shafts[j] = {"a": a, "b": b, "k": parsed["shaft"].get(j, {}).get("k")}
    return {"counts": counts, "bodies": bodies, "shafts": shafts, "meshes": meshes,
            "gears": gears, "angle_start": float(_value(parsed, "body", 1, "angle_start"))}


def same_gear(g1: dict, g2: dict, rel=1e-12) -> bool:
    """Two gears of one body that are one physical gear (an idler named by two meshes with the
    same tooth data, mount and thickness, spec section 4)."""
    def close(x, y):
        return abs(x - y) <= rel * max(abs(x), abs(y), 1e-300)
    return (g1["z"] == g2["z"] and close(g1["r_b"], g2["r_b"]) and close(g1["r_tip"], g2["r_tip"])
            and close(g1["t"], g2["t"]) and abs(g1["mount"] - g2["mount"]) <= 1e-12)


# --------------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------------

BODY_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2",
               "#17becf"]
MM = 1e3


def _circle(ax, c, r, **kw):
    ax.add_patch(plt.Circle((MM * c[0], MM * c[1]), MM * r, fill=False, **kw))


def _sense_arrow(ax, c, r, sigma, color):
    """A 270 degree arc around c at radius r [m] ending in an arrowhead in the sense sigma."""
    th0 = math.radians(135.0)
    n = 60
    ths = [th0 + sigma * math.radians(270.0) * k / n for k in range(n + 1)]
    xs = [MM * (c[0] + r * math.cos(t)) for t in ths]
    ys = [MM * (c[1] + r * math.sin(t)) for t in ths]
    ax.plot(xs[:-3], ys[:-3], color=color, lw=1.4)
    ax.annotate("", xy=(xs[-1], ys[-1]), xytext=(xs[-4], ys[-4]),
                arrowprops=dict(arrowstyle="-|>", color=color, lw=1.4, mutation_scale=14))


def _fmt(v):
    return f"{v:g}"


def _color(i):
    return BODY_COLORS[(i - 1) % len(BODY_COLORS)]


CONTACT = "#e6a100"


def _prepare(lay):
    """Per body the distinct gears to draw (an idler's gear named by two meshes is one gear),
    and the coaxial groups (bodies joined by shafts share a centre)."""
    for b in lay["bodies"].values():
        drawn = []
        for gg in b["gears"]:
            name = f"mesh[{gg['mesh']}].{gg['side']}"
            twin = next((d for d in drawn if same_gear(d, gg)), None)
            if twin is not None:
                twin["names"].append(name)
            else:
                drawn.append(dict(gg, names=[name]))
        b["drawn"] = drawn
    groups = {}
    for i, b in lay["bodies"].items():
        groups.setdefault((round(b["center"][0], 12), round(b["center"][1], 12)), []).append(i)
    lay["groups"] = list(groups.values())


def _draw_gears(ax, lay, tags):
    """Operating pitch circle strong; tip circle dashed and base circle dotted, lighter."""
    for i, b in lay["bodies"].items():
        col = _color(i)
        for gg in b["drawn"]:
            _circle(ax, b["center"], gg["r_w"], color=col, lw=2.0)
            _circle(ax, b["center"], gg["r_tip"], color=col, lw=0.9, ls="--", alpha=0.55)
            _circle(ax, b["center"], gg["r_b"], color=col, lw=0.9, ls=":", alpha=0.55)
            if tags:  # tooth count on the pitch circle, away from the body's meshes
                ang = _free_angle(lay, i, gg)
                ax.text(MM * (b["center"][0] + gg["r_w"] * math.cos(ang)),
                        MM * (b["center"][1] + gg["r_w"] * math.sin(ang)), f"z={gg['z']}",
                        color=col, fontsize=7.5, ha="center", va="center", fontweight="bold",
                        bbox=dict(fc="white", ec=col, lw=0.6, alpha=0.9, pad=1.2), zorder=6)


def _draw_centres(ax, lay):
    """Centres, shaft symbols, forward-sense arrows and body tags."""
    bodies = lay["bodies"]
    for members in lay["groups"]:
        c = bodies[members[0]]["center"]
        rmin = min((gg["r_b"] for i in members for gg in bodies[i]["gears"]), default=0.05)
        if len(members) > 1:
            ax.plot(MM * c[0], MM * c[1], "o", ms=11, mfc="white", mec="0.3", mew=2.0, zorder=5)
            for k, (j, s) in enumerate((j, s) for j, s in lay["shafts"].items()
                                       if s["a"] in members):
                txt = (f"shaft[{j}]: body {s['a']} - body {s['b']}"
                       + (f", k = {_fmt(s['k'])} N.m/rad" if s["k"] is not None else ""))
                ax.annotate(txt, (MM * c[0], MM * (c[1] + rmin * 0.62)),
                            textcoords="offset points", xytext=(0, 12 * k), color="0.25",
                            fontsize=8, ha="center", va="bottom", zorder=6,
                            bbox=dict(fc="white", ec="none", alpha=0.75, pad=1.0))
        ax.plot(MM * c[0], MM * c[1], "+", ms=9, color="k", zorder=6)
        for k, i in enumerate(members):
            col = _color(i)
            _sense_arrow(ax, c, rmin * (0.28 + 0.16 * k), bodies[i]["sigma"], col)
            # short tag below the centre (the details are in the legend), stacked if coaxial
            ax.annotate(f"body {i}", (MM * c[0], MM * (c[1] - rmin * 0.5)),
                        textcoords="offset points", xytext=(0, -13 * k), color=col, fontsize=9,
                        ha="center", va="top", fontweight="bold", zorder=6,
                        bbox=dict(fc="white", ec="none", alpha=0.75, pad=0.8))


def _draw_lines_of_action(ax, lay, names, fs=7.5):
    """Each mesh's forward line of action K_A K_B, its contact segment a-b (thick) with an
    arrow for the direction of the forward force on B, the pitch point (x) and the line of
    centres (thin dashed)."""
    for mm in lay["meshes"].values():
        g = mm["geometry"]
        KA, KB, a, b, P, u = mm["K_A"], mm["K_B"], mm["a"], mm["b"], mm["P"], mm["u"]
        ax.plot([MM * mm["O_A"][0], MM * mm["O_B"][0]], [MM * mm["O_A"][1], MM * mm["O_B"][1]],
                color="0.55", lw=0.6, ls=(0, (8, 4)), zorder=1)
        ax.plot([MM * KA[0], MM * KB[0]], [MM * KA[1], MM * KB[1]], "-", color="k", lw=1.0,
                zorder=7)
        ax.plot([MM * KA[0], MM * KB[0]], [MM * KA[1], MM * KB[1]], "o", color="k", ms=3.5,
                zorder=7)
        ax.plot([MM * a[0], MM * b[0]], [MM * a[1], MM * b[1]], "-", color=CONTACT, lw=4.0,
                solid_capstyle="butt", zorder=8)
        tip = (b[0] + 0.3 * g.p_b * u[0], b[1] + 0.3 * g.p_b * u[1])
        ax.annotate("", xy=(MM * tip[0], MM * tip[1]), xytext=(MM * b[0], MM * b[1]),
                    arrowprops=dict(arrowstyle="-|>", color=CONTACT, lw=2.0), zorder=8)
        ax.plot(MM * P[0], MM * P[1], "x", color="k", ms=5, zorder=9)
        if names:  # K_A, K_B on one side of the line, a, b, P on the other
            nx, ny = -u[1], u[0]
            for name, pt, side, col, fw in (("K_A", KA, 1, "0.2", "normal"),
                                            ("K_B", KB, 1, "0.2", "normal"),
                                            ("P", P, 1, "0.2", "normal"),
                                            ("a", a, -1, "#a06f00", "bold"),
                                            ("b", b, -1, "#a06f00", "bold")):
                ax.annotate(name, (MM * pt[0], MM * pt[1]), textcoords="offset points",
                            xytext=(9 * side * nx, 9 * side * ny), fontsize=fs, color=col,
                            fontweight=fw, ha="center", va="center", zorder=9)


def _draw_tooth0(ax, lay, label):
    """Tooth 0 of body 1's gears: its symmetry axis at psi_1(0) + mount (spec section 3)."""
    if 1 not in lay["bodies"]:
        return
    c = lay["bodies"][1]["center"]
    for gg in lay["bodies"][1]["drawn"]:
        ang = lay["angle_start"] + gg["mount"]
        ca, sa = math.cos(ang), math.sin(ang)
        ax.plot([MM * c[0], MM * (c[0] + gg["r_tip"] * ca)],
                [MM * c[1], MM * (c[1] + gg["r_tip"] * sa)], color="0.2", lw=1.0, ls="-.",
                zorder=4)
        ax.plot(MM * (c[0] + gg["r_tip"] * ca), MM * (c[1] + gg["r_tip"] * sa), "D",
                color="0.2", ms=5, zorder=8)
        if label:
            rot = math.degrees(math.atan2(sa, ca))
            if ca < 0:
                rot += 180.0
            ax.annotate("tooth 0", (MM * (c[0] + 0.55 * gg["r_w"] * ca),
                                    MM * (c[1] + 0.55 * gg["r_w"] * sa)),
                        textcoords="offset points", xytext=(-3 * sa, 3 * ca), fontsize=7,
                        color="0.2", rotation=rot, rotation_mode="anchor", ha="center",
                        va="bottom", zorder=8)


def _mesh_tag_text(m, mm):
    g = mm["geometry"]
    return (f"mesh[{m}]: A = body {mm['A']}, B = body {mm['B']}\n"
            f"{'paper' if mm['params']['geometry'] == 1 else 'standard'} geometry, "
            f"z {g.zA}:{g.zB}, eps = {g.eps:.3f}\n"
            f"d = {MM * g.d:.6g} mm, center_angle = {math.degrees(mm['beta']):.4g} deg")


def draw_layout(params: dict, path, title: str | None = None):
    """Draws the layout of `params` (FMI names) to `path` (PNG): the whole gearbox, and below it
    one zoom per mesh on its line of action. Returns the layout dict."""
    lay = layout(params)
    _prepare(lay)
    bodies, meshes = lay["bodies"], lay["meshes"]

    xs, ys = [], []
    for gg in lay["gears"]:
        c = bodies[gg["body"]]["center"]
        xs += [c[0] - gg["r_tip"], c[0] + gg["r_tip"]]
        ys += [c[1] - gg["r_tip"], c[1] + gg["r_tip"]]
    if not xs:
        xs, ys = [-0.1, 0.1], [-0.1, 0.1]
    ext = max(max(xs) - min(xs), max(ys) - min(ys))

    # mesh tags: beside the pitch point, outside every tip circle, with a leader to it
    tags = {}
    for m, mm in meshes.items():
        P = mm["P"]
        # along the backward line of action (the forward one mirrored about the line of
        # centres, 2 alpha_w away from it), on the side needing the shorter leader
        e = ((mm["O_B"][0] - mm["O_A"][0]) / mm["geometry"].d,
             (mm["O_B"][1] - mm["O_A"][1]) / mm["geometry"].d)
        u = mm["u"]
        ue = u[0] * e[0] + u[1] * e[1]
        nrm = (2 * ue * e[0] - u[0], 2 * ue * e[1] - u[1])
        if nrm[1] < 0 or (nrm[1] == 0 and nrm[0] > 0):
            nrm = (-nrm[0], -nrm[1])   # "up" first
        h_up = _tag_distance(lay, P, nrm, 0.07 * ext)
        h_dn = _tag_distance(lay, P, (-nrm[0], -nrm[1]), 0.07 * ext)
        if h_dn < h_up - 1e-9 or (abs(h_dn - h_up) <= 1e-9 and m % 2 == 0):
            nrm, h_up = (-nrm[0], -nrm[1]), h_dn
        tags[m] = (P[0] + h_up * nrm[0], P[1] + h_up * nrm[1])
        xs += [tags[m][0] - 0.13 * ext, tags[m][0] + 0.13 * ext]   # the tag's box, roughly
        ys += [tags[m][1] - 0.05 * ext, tags[m][1] + 0.05 * ext]
    w, h = max(xs) - min(xs), max(ys) - min(ys)
    pad = 0.05 * max(w, h)

    main_w = 10.0
    main_h = min(max(3.5, main_w * (h + 2 * pad) / (w + 2 * pad)), 11.0)
    nz = len(meshes)
    zoom_h = 3.0 if nz else 0.0
    fig = plt.figure(figsize=(main_w + 4.6, main_h + zoom_h + 1.0))
    fh = fig.get_figheight()
    # main view on top (the legend to its right), the zoom row below across the whole width
    gs = fig.add_gridspec(1, 1, left=0.06, right=main_w / (main_w + 4.6), top=1 - 0.45 / fh,
                          bottom=(zoom_h + 0.95) / fh if nz else 0.6 / fh)
    gz = fig.add_gridspec(1, max(nz, 4), left=0.05, right=0.98, top=(zoom_h + 0.1) / fh,
                          bottom=0.35 / fh, wspace=0.35) if nz else None
    ax = fig.add_subplot(gs[0, 0])

    _draw_gears(ax, lay, tags=True)
    _draw_centres(ax, lay)
    _draw_lines_of_action(ax, lay, names=False)
    _draw_tooth0(ax, lay, label=True)
    for m, mm in meshes.items():
        ax.annotate(_mesh_tag_text(m, mm), xy=(MM * mm["P"][0], MM * mm["P"][1]),
                    xytext=(MM * tags[m][0], MM * tags[m][1]), fontsize=7.5, ha="center",
                    va="center", color="0.1",
                    bbox=dict(fc="#fff6dd", ec=CONTACT, lw=0.8, alpha=0.92, pad=2.5),
                    arrowprops=dict(arrowstyle="-", color=CONTACT, lw=0.8, shrinkA=0,
                                    shrinkB=3), zorder=10)
    ax.set_aspect("equal")
    ax.set_xlim(MM * (min(xs) - pad), MM * (max(xs) + pad))
    ax.set_ylim(MM * (min(ys) - pad), MM * (max(ys) + pad))
    ax.set_xlabel("x [mm] (housing frame, body 1 at the origin)")
    ax.set_ylabel("y [mm]")
    ax.grid(True, lw=0.3, alpha=0.5)
    counts = lay["counts"]
    nb, ns, nm = counts["n_bodies"], counts["n_shafts"], counts["n_meshes"]
    ax.set_title(title or f"SpurGearTrain layout: {nb} bod{'y' if nb == 1 else 'ies'}, "
                          f"{ns} shaft{'' if ns == 1 else 's'}, {nm} mesh{'' if nm == 1 else 'es'}")

    # one zoom per mesh: the line of action with the contact segment
    for k, (m, mm) in enumerate(meshes.items()):
        az = fig.add_subplot(gz[0, k])
        _draw_gears(az, lay, tags=False)
        _draw_lines_of_action(az, lay, names=True, fs=8)
        _draw_tooth0(az, lay, label=False)
        g = mm["geometry"]
        cx = 0.5 * (mm["K_A"][0] + mm["K_B"][0])
        cy = 0.5 * (mm["K_A"][1] + mm["K_B"][1])
        half = 0.62 * g.L
        az.set_xlim(MM * (cx - half), MM * (cx + half))
        az.set_ylim(MM * (cy - half), MM * (cy + half))
        az.set_aspect("equal")
        az.grid(True, lw=0.3, alpha=0.5)
        az.tick_params(labelsize=7)
        sa, sb = ("CW" if mm["sigma_A"] < 0 else "CCW"), ("CW" if mm["sigma_B"] < 0 else "CCW")
        az.set_title(f"mesh[{m}] (zoom on the line of action)\nA = body {mm['A']} ({sa}), "
                     f"B = body {mm['B']} ({sb})\nL = {MM * g.L:.4g} mm, "
                     f"a-b = {MM * (g.s_b - g.s_a):.4g} mm", fontsize=7.5)

    handles = []
    for i, b in bodies.items():
        J = f"J = {_fmt(b['J'])} kg.m2" if b["J"] is not None else "J: FMU default"
        sense = "CCW" if b["sigma"] > 0 else "CW"
        gear_txt = "\n  ".join(f"z={gg['z']}: " + " = ".join(gg["names"]) for gg in b["drawn"])
        handles.append(Line2D([], [], color=_color(i), lw=2.0,
                              label=f"body {i} ({J}), forward {sense} (sigma {b['sigma']:+d})"
                                    + (f"\n  {gear_txt}" if gear_txt else "")))
    handles += [
        Line2D([], [], color="0.3", lw=2.0, label="operating pitch circle"),
        Line2D([], [], color="0.3", lw=0.9, ls="--", alpha=0.6, label="tip circle"),
        Line2D([], [], color="0.3", lw=0.9, ls=":", alpha=0.6, label="base circle"),
        Line2D([], [], color="k", lw=1.0, marker="o", ms=3.5,
               label="forward line of action K_A K_B\n(tangent to both base circles)"),
        Line2D([], [], color=CONTACT, lw=4.0, label="contact segment a-b\n(arrow: force on B)"),
        Line2D([], [], color="k", marker="x", ms=5, ls="none", label="pitch point P"),
        Line2D([], [], color="0.2", lw=1.0, ls="-.", marker="D", ms=5,
               label=f"tooth 0 axis of body 1\n(psi_1(0) + mount, psi_1(0) = "
                     f"{lay['angle_start']:g} rad)"),
        Line2D([], [], color="0.4", lw=1.4, marker=r"$\circlearrowleft$", ms=10, ls="none",
               label="forward sense"),
        Line2D([], [], color="0.55", lw=0.6, ls=(0, (8, 4)), label="line of centres"),
    ]
    if lay["shafts"]:
        handles.append(Line2D([], [], marker="o", ms=10, mfc="white", mec="0.3", mew=2.0,
                              ls="none", label="shaft (coaxial bodies)"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              frameon=False)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return lay


def _tag_distance(lay, P, nrm, margin):
    """Smallest distance along nrm from P at which a point is outside every tip circle by
    margin (and at least 3 margins from P)."""
    h = 3.0 * margin
    for _ in range(400):
        x, y = P[0] + h * nrm[0], P[1] + h * nrm[1]
        if all(math.hypot(x - lay["bodies"][gg["body"]]["center"][0],
                          y - lay["bodies"][gg["body"]]["center"][1]) > gg["r_tip"] + margin
               for gg in lay["gears"]):
            return h
        h += 0.25 * margin
    return h


def _free_angle(lay, i, gear):
    """A direction from body i's centre away from all its meshes' lines of centres, for a tag."""
    c = lay["bodies"][i]["center"]
    dirs = []
    for mm in lay["meshes"].values():
        for end, other in (("A", "O_B"), ("B", "O_A")):
            if mm[end] == i:
                o = mm[other]
                dirs.append(math.atan2(o[1] - c[1], o[0] - c[0]))
    best, best_gap = -math.pi / 2 - 0.6, -1.0
    for k in range(72):
        th = -math.pi / 2 - 0.6 + 2 * math.pi * k / 72
        gap = min((abs(math.remainder(th - d, 2 * math.pi)) for d in dirs), default=math.pi)
        gap -= 0.01 * abs(math.remainder(th + math.pi / 2 + 0.6, 2 * math.pi))  # prefer low left
        if gap > best_gap:
            best, best_gap = th, gap
    return best


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


def plot_run(csv_path, out_png):
    """One row per mesh (dte [um]; F_fwd, F_bwd and the per-pair forces present [N]) and a
    last row with the body speeds and shaft torques when present. Elements whose columns are all
    zero (beyond n_*, spec section 6) are left out. Returns the mesh indices plotted."""
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


# --------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------

def parse_value(s: str):
    """A --set value: integer, float, true/false, or else the string itself."""
    t = s.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    try:
        return int(t)
    except ValueError:
        pass
    try:
        return float(t)
    except ValueError:
        return t


def _flatten(d, prefix=""):
    out = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, name + "."))
        else:
            out[name] = v
    return out


def load_scene(path) -> dict:
    """The [start_values] of a scene TOML (structured names must be quoted keys there:
    "mesh[2].zA" = 33)."""
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    if "start_values" not in scene:
        raise ValueError(f"{path}: no [start_values] table")
    return _flatten(scene["start_values"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    lp = sub.add_parser("layout", help="draw the gearbox")
    lp.add_argument("--scene", help="scene TOML whose [start_values] set the parameters")
    lp.add_argument("--set", action="append", default=[], metavar="name=value",
                    help="FMI parameter (after the scene's), repeatable: --set mesh[1].zA=22")
    lp.add_argument("--title", help="figure title (default: the counts)")
    lp.add_argument("-o", "--out", default=str(ROOT / "out" / "train-layout.png"))
    rp = sub.add_parser("run", help="plot a run's CSV (fmpy simulate)")
    rp.add_argument("csv")
    rp.add_argument("-o", "--out", default=str(ROOT / "out" / "train-run.png"))
    a = ap.parse_args(argv)
    try:
        if a.cmd == "layout":
            params = load_scene(a.scene) if a.scene else {}
            for s in a.set:
                if "=" not in s:
                    ap.error(f"--set {s!r}: expected name=value")
                k, v = s.split("=", 1)
                params[k.strip()] = parse_value(v)
            draw_layout(params, a.out, title=a.title)
        else:
            plot_run(a.csv, a.out)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
