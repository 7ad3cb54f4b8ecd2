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

Planetary sets (/work/shared/spec/planetary.md sections 1, 3-4): the housing is body 0 (a mesh
or shaft end 0: a fixed gear, a torsional mount), `body[i].carrier` puts a planet's axis at
`body[i].orbit_angle` about its carrier's (carriers at psi = 0) at the orbit radius R (the
nominal operating centre distance of its lowest-index mesh with a central member) moved by its
pin errors, and a mesh in a carrier's frame takes its distance and direction from the positions.
Loops are allowed; the breadth-first placing walk (from the housing if named, else body 1; queue
[root, carriers]) says which mesh places which body and which close loops. A ring is drawn as an
internal gear (tip circle inside the pitch circle, its body outside, hatched when the housing
holds it), a carrier as arms to its planets' pins, an internal mesh's line of action in section
1's frame (O_B at (-d, 0), rotated by beta + pi, mirrored when sigma_A = +1). Refused as the FMU
refuses them: conflicting senses around a loop, a jammed body, axes that do not close (1 um), a
carried carrier, a planet meshing with its own carrier, ...; body 1's placed start angle and the
assembly check come from the reference's placement (tests/reference_model/train_ref.py).

    .venv/bin/python tools/train_layout.py layout [--set name=value ...] \\
        [--scene scenes/train/X.toml] -o out/train-layout.png
    .venv/bin/python tools/train_layout.py run results.csv [--scene scenes/train/X.toml] \\
        -o out/train-run.png

Quote --set arguments in the shell ('mesh[2].zA=33'): brackets are glob characters. A scene is a
TOML file with a [start_values] table of FMI names, quoted there too ("mesh[2].zA" = 33), or a
gearbox file (docs/gearbox-file.md): `--scene scenes/train/gearbox/two-stage.toml`.

`run` plots a CSV written by `fmpy simulate` (first column `time`, columns named by FMI name):
per mesh dte [um] and the flank forces, then the body speeds and the shaft torques. With the
run's scene (--scene / --set) of a planetary train: the meshes grouped per carrier (sun-planet,
planet-ring), the planets' load sharing (each mesh's F_fwd over the mean over the planets), the
speeds and housing.tau.

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

# Fixed capacity of the train FMU (planetary.md section 5; gear-train.md's 8/7/6 before it).
CAPACITY = {"body": 16, "shaft": 15, "mesh": 16}
# Counts: the train FMU's defaults (a two-stage reducer with a compliant intermediate shaft).
COUNT_DEFAULTS = {"n_bodies": 4, "n_shafts": 1, "n_meshes": 2}
COUNT_NAMES = {"body": "n_bodies", "shaft": "n_shafts", "mesh": "n_meshes"}
# Whole-train parameters that do not change the layout (accepted, not used).
TRAIN_SCALARS = {"solver", "rel_tol", "statistics", "stats_start"}
BODY_FIELDS = {"J", "c", "w_start", "tau", "tau_ripple", "ripple_order", "ripple_phase",
               # planetary.md section 3: a planet's carrier, orbit angle, mass, pin errors
               "carrier", "orbit_angle", "m", "pin_error_r", "pin_error_t"}
# + angle_start on body[1] only
SHAFT_FIELDS = {"a", "b", "k", "d", "twist_start"}
MESH_PLACEMENT = {"A", "B", "center_angle", "mount_A", "mount_B"}
# Single-mesh parameters that a train does not have (spec section 1: bodies carry inertia, drag,
# start speed and external torque; solver and tolerance belong to the whole train).
NOT_IN_TRAIN = {"J_A", "J_B", "c_load", "w_A_start", "w_B_start", "tau_A", "tau_B", "solver",
                "rel_tol", "restitution", "slider_stiffness"}
MESH_GEAR_FIELDS = set(G.DEFAULTS) - NOT_IN_TRAIN
INTEGER_FIELDS = {("shaft", "a"), ("shaft", "b"), ("mesh", "A"), ("mesh", "B"),
                  ("body", "carrier")}
# the housing (planetary.md section 3): a mesh end or shaft end 0
HOUSING = 0
# axes reached twice along housing-frame meshes, shafts and carrier ties must agree to this
CLOSE_AXES = 1e-6

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
    if kind == "body" and field in ("angle_start", "orbit_angle", "m", "pin_error_r",
                                     "pin_error_t"):
        return 0.0
    if kind == "body" and field == "carrier":
        return 0
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
    raw = {}
    for name, v in params.items():
        if name in COUNT_DEFAULTS:
            counts[name] = _as_int(name, v)
            raw[name] = counts[name]
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
        raw[name] = v
    if unknown:
        warnings.warn("not train layout parameters, ignored: " + ", ".join(sorted(unknown)),
                      stacklevel=3)
    for kind, cname in COUNT_NAMES.items():
        lo = 1 if kind == "body" else 0
        if not lo <= counts[cname] <= CAPACITY[kind]:
            raise ValueError(f"{cname} = {counts[cname]} outside {lo}..{CAPACITY[kind]}")
    return {"counts": counts, **given, "raw": raw}


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
    """[(label, kind, index, a, b)] for every shaft and mesh in use (shafts first), ends checked.
    An end 0 is the housing (planetary.md section 3)."""
    n = parsed["counts"]["n_bodies"]
    edges = []
    for kind, ends in (("shaft", ("a", "b")), ("mesh", ("A", "B"))):
        for j in range(1, parsed["counts"][COUNT_NAMES[kind]] + 1):
            label = f"{kind}[{j}]"
            e = [_as_int(f"{label}.{f}", _value(parsed, kind, j, f)) for f in ends]
            for f, i in zip(ends, e):
                if not 0 <= i <= n:
                    raise ValueError(f"{label}.{f} = {i} is not a body: indices run 1..n_bodies "
                                     f"= 1..{n}, and 0 is the housing")
            if e[0] == e[1]:
                what = "the housing" if e[0] == HOUSING else f"body {e[0]}"
                raise ValueError(f"{label} joins {what} to itself ({label}.{ends[0]} = "
                                 f"{label}.{ends[1]} = {e[0]})")
            edges.append((label, kind, j, e[0], e[1]))
    return edges


def _internal(parsed: dict, m: int) -> bool:
    return bool(parsed["mesh"].get(m, {}).get("internal", False))


def analyse(parsed: dict) -> dict:
    """The train's topology (gear-train.md section 1, planetary.md sections 3-4): raises
    ValueError, naming the elements, for what the FMU refuses on topology alone (indices, a body
    joined to itself, a carried carrier, a planet meshing with its own carrier or a planet of
    another carrier, a planet with no mesh or no central member, a nonzero center_angle in a
    carrier's frame, conflicting forward senses around a loop, a body joined to nothing).

    Returns {'edges', 'carrier_of' {planet: carrier}, 'carriers' [ascending], 'frame'
    {mesh: carrier or None}, 'sigma' {body: +-1}, 'mesh_sigma' {mesh: (sigma_A, sigma_B)},
    'root' (0 = the housing, or 1), 'housing_named', 'general'} where 'general' says whether
    planetary.md applies at all (the housing named, a carrier, or a loop); otherwise the train is
    a tree of gear-train.md."""
    n = parsed["counts"]["n_bodies"]
    edges = _edges(parsed)
    bad = []
    carrier_of = {}
    for i in range(1, n + 1):
        c = _as_int(f"body[{i}].carrier", _value(parsed, "body", i, "carrier"))
        if c == 0:
            continue
        if not 1 <= c <= n:
            bad.append(f"body[{i}].carrier = {c} is not a body: a carrier is one of 1..n_bodies "
                       f"= 1..{n} (0: the housing holds the axis)")
        elif c == i:
            bad.append(f"body[{i}].carrier = {c}: a body cannot carry itself")
        else:
            carrier_of[i] = c
    for i, c in sorted(carrier_of.items()):
        if c in carrier_of:
            bad.append(f"body[{i}].carrier = {c}: body {c} is itself carried (by body "
                       f"{carrier_of[c]}); a carrier turns about a housing-fixed axis")
    if bad:
        raise ValueError("; ".join(bad))
    frame = {}
    for label, kind, j, a, b in edges:
        if kind != "mesh":
            continue
        ca, cb = carrier_of.get(a), carrier_of.get(b)
        if ca is not None and cb is not None and ca != cb:
            bad.append(f"{label} joins body {a} (a planet of body {ca}) to body {b} (a planet of "
                       f"body {cb})")
        c = ca if ca is not None else cb
        if c is not None and c in (a, b):
            bad.append(f"{label} joins a planet to its own carrier, body {c}")
        beta = float(_value(parsed, "mesh", j, "center_angle"))
        if c is not None and beta != 0.0:
            bad.append(f"{label}.center_angle = {beta!r}: a mesh in the frame of carrier body {c} "
                       f"takes its direction from the planets' positions; center_angle must be 0")
        frame[j] = c
    for i in sorted(carrier_of):
        mine = [(j, b if a == i else a) for _l, kind, j, a, b in edges
                if kind == "mesh" and i in (a, b)]
        if not mine:
            bad.append(f"body {i} is a planet of body {carrier_of[i]} with no mesh")
        elif all(o in carrier_of for _j, o in mine):
            bad.append(f"body {i}, a planet of body {carrier_of[i]}, meshes with no central member "
                       f"(a housing-mounted body or the housing): its orbit radius is undefined")
    if bad:
        raise ValueError("; ".join(bad))

    # forward senses: an external mesh flips, an internal mesh and a shaft keep; never through
    # the housing.  An element joining two bodies already joined closes a loop: refused when
    # the senses conflict around it.
    def keeps(e):
        return e[1] == "shaft" or _internal(parsed, e[2])

    adj = {i: [] for i in range(1, n + 1)}
    for e in edges:
        label, _kind, _j, a, b = e
        if HOUSING in (a, b):
            continue
        path = _path(adj, a, b)
        if path is not None:
            flips = sum(0 if keeps(x) else 1 for x in path) % 2
            if flips != (0 if keeps(e) else 1):
                elems = sorted(path + [e], key=lambda x: (x[1] != "shaft", x[2]))
                cyc = sorted({x[3] for x in elems} | {x[4] for x in elems})
                raise ValueError(
                    f"{label} (bodies {a}-{b}) closes a cycle through bodies "
                    f"{', '.join(map(str, cyc))}: {', '.join(x[0] for x in elems)}, around which "
                    f"the forward senses conflict (an external mesh flips the sense, an internal "
                    f"mesh and a shaft keep it): the train cannot turn")
        adj[a].append((b, e))
        adj[b].append((a, e))
    sigma = {}
    for start in range(1, n + 1):           # body 1 first; an unreached part: -1 at its lowest
        if start in sigma:
            continue
        sigma[start] = -1
        q = deque([start])
        while q:
            i = q.popleft()
            for k, e in adj[i]:
                if k not in sigma:
                    sigma[k] = sigma[i] if keeps(e) else -sigma[i]
                    q.append(k)
    mesh_sigma = {}
    for _label, kind, j, a, b in edges:
        if kind != "mesh":
            continue
        keep = _internal(parsed, j)
        if a == HOUSING:        # a fixed external gear: the sense the mesh gives from B
            mesh_sigma[j] = (sigma[b] if keep else -sigma[b], sigma[b])
        elif b == HOUSING:
            mesh_sigma[j] = (sigma[a], sigma[a] if keep else -sigma[a])
        else:
            mesh_sigma[j] = (sigma[a], sigma[b])

    # connectivity over meshes, shafts and carrier ties, from the root of the placing walk
    housing_named = any(HOUSING in (e[3], e[4]) for e in edges)
    root = HOUSING if housing_named else 1
    nbr = {i: set() for i in range(0, n + 1)}
    for e in edges:
        nbr[e[3]].add(e[4])
        nbr[e[4]].add(e[3])
    for i, c in carrier_of.items():
        nbr[i].add(c)
        nbr[c].add(i)
    seen, q = {root}, deque([root])
    while q:
        i = q.popleft()
        for k in nbr[i]:
            if k not in seen:
                seen.add(k)
                q.append(k)
    lost = [i for i in range(1, n + 1) if i not in seen]
    if lost:
        inner = [e for e in edges if HOUSING not in (e[3], e[4])]
        raise ValueError(
            f"body {', body '.join(map(str, lost))} not connected to "
            f"{'the housing' if root == HOUSING else 'body 1'} by any shaft, mesh or carrier tie "
            f"({len(edges)} edges for {n} bodies; a tree needs n_bodies - 1 = {n - 1})"
            if not housing_named and not carrier_of and len(inner) < n - 1 else
            f"body {', body '.join(map(str, lost))} not connected to "
            f"{'the housing' if root == HOUSING else 'body 1'} by any shaft, mesh or carrier tie")
    has_loop = any(_path({i: [x for x in adj[i] if x[1] is not e] for i in adj}, e[3], e[4])
                   is not None for e in edges if HOUSING not in (e[3], e[4]))
    general = housing_named or bool(carrier_of) or has_loop
    return {"edges": edges, "carrier_of": carrier_of,
            "carriers": sorted(set(carrier_of.values())), "frame": frame, "sigma": sigma,
            "mesh_sigma": mesh_sigma, "root": root, "housing_named": housing_named,
            "general": general}


def check_topology(parsed: dict):
    """Raises ValueError for what the train refuses on topology alone (see analyse). Returns the
    edges."""
    return analyse(parsed)["edges"]


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


def paper_frame_points(g, internal: bool) -> dict:
    """The forward line of action in the mesh's paper frame (O_A at the origin, A turning
    clockwise forward): K_A, K_B, the contact segment ends a, b, the pitch point P, the unit
    forward direction u (from K_A towards the pitch point) and O_B.

    External pair (gear-mesh-model.md section 2): O_B = (d, 0), K_A = rAb (cos aw, sin aw),
    u = (sin aw, -cos aw), K_B = K_A + L u = O_B - rBb (cos aw, sin aw).  Internal pair
    (planetary.md section 1): O_B = (-d, 0), the same K_A and u, P = (rAb / cos aw, 0) and
    K_B = K_A - L u, at polar angle aw about O_B.  Either way a = K_A + s_a u, b = K_A + s_b u,
    P = K_A + rAb tan(aw) u."""
    aw = g.alpha_w
    ca, sa = math.cos(aw), math.sin(aw)
    u = (sa, -ca)
    K_A = (g.rAb * ca, g.rAb * sa)
    sgn = -1.0 if internal else 1.0

    def along(s):
        return (K_A[0] + s * u[0], K_A[1] + s * u[1])
    return {"O_B": (sgn * g.d, 0.0), "K_A": K_A, "K_B": along(sgn * g.L), "a": along(g.s_a),
            "b": along(g.s_b), "P": along(g.rAb * math.tan(aw)), "u": u}


def _placing_walk(parsed, topo):
    """planetary.md section 4's breadth-first walk with the agreed queue: [root, carriers
    ascending]; at each body its meshes in index order, then its shafts; when the queue runs dry
    and bodies remain, it goes on from the lowest unplaced body.  Returns (starts, placed, loops):
    the bodies the walk starts from (a free coordinate each), [(body, edge label)] in the order
    the walk places them, and the meshes that close a loop."""
    n = parsed["counts"]["n_bodies"]
    edges = topo["edges"]
    meshes = [e for e in edges if e[1] == "mesh"]
    shafts = [e for e in edges if e[1] == "shaft"]
    root = topo["root"]
    starts = ([root] if root != HOUSING else []) + [c for c in topo["carriers"] if c != root]
    done = {root, *topo["carriers"]}
    q = deque([root] + [c for c in topo["carriers"] if c != root])
    placed, placing = [], set()
    while True:
        while q:
            i = q.popleft()
            for e in meshes + shafts:
                if i not in (e[3], e[4]):
                    continue
                j = e[4] if i == e[3] else e[3]
                if j in done:
                    continue
                done.add(j)
                placed.append((j, e[0]))
                placing.add(e[0])
                q.append(j)
        rest = [i for i in range(1, n + 1) if i not in done]
        if not rest:
            break
        starts.append(rest[0])
        done.add(rest[0])
        q.append(rest[0])
    loops = [e[2] for e in meshes if e[0] not in placing]
    return starts, placed, loops


def _jammed(lay, n):
    """Bodies that no rigid rolling of the meshes (each relative to its frame, shafts absent)
    lets turn (planetary.md section 4): zero in every null vector of the rolling constraints
    rAb theta_A,rel - rBb theta_B,rel = 0, theta_rel = theta - sigma sigma_c theta_c, forward
    senses, the housing at rest."""
    import numpy as np
    rows = []
    for mm in lay["meshes"].values():
        g, c = mm["geometry"], mm["carrier"]
        row = np.zeros(n + 1)
        for X, r, sX in ((mm["A"], g.rAb, mm["sigma_A"]), (mm["B"], -g.rBb, mm["sigma_B"])):
            if X != HOUSING:
                row[X] += r
            if c is not None:
                row[c] -= r * sX * lay["bodies"][c]["sigma"]
        rows.append(row[1:])
    if not rows:
        return []
    M = np.array(rows)
    scale = np.abs(M).max()
    _u, s, vt = np.linalg.svd(M / scale)
    rank = int((s > 1e-10).sum())
    null = vt[rank:]
    return [i for i in range(1, n + 1) if null.shape[0] == 0 or np.abs(null[:, i - 1]).max() < 1e-9]


def layout(params: dict) -> dict:
    """The gearbox in the housing frame [m, rad] at t = 0 from the train FMU's parameters (FMI
    names), the carriers at psi = 0.

    Returns {'counts', 'bodies': {i: {'center', 'sigma', 'J', 'gears': [gear, ...], 'carrier'
    (0 or the carrier), 'R', 'orbit_angle', 'pin' (pin_error_r, pin_error_t), 'planets'}},
    'shafts': {j: {'a', 'b', 'k'}}, 'meshes': {m: {...}}, 'gears': [...], 'housing_gears',
    'general', 'root', 'starts', 'placed', 'loops', 'coordinates', 'psi1'} where a gear is
    {'body' (0: the housing), 'center', 'mesh', 'side' ('A'/'B'), 'internal', 'z', 'r_w', 'r_b',
    'r_tip', 'r_root', 'mount', 't'} and a mesh holds 'A', 'B', 'internal', 'carrier' (None: the
    housing's frame), 'beta' (direction O_A -> O_B), 'sigma_A', 'sigma_B', 'geometry' (the
    reference model's Geometry at the mesh's actual centre distance), the housing-frame points
    'O_A', 'O_B', 'K_A', 'K_B', 'a', 'b' (contact segment ends), 'P' (pitch point) and 'u' (unit
    direction of the forward line of action, from K_A towards the pitch point).
    """
    parsed = parse_params(params)
    counts = parsed["counts"]
    topo = analyse(parsed)
    edges = topo["edges"]
    n = counts["n_bodies"]
    carrier_of, frame, sigma = topo["carrier_of"], topo["frame"], topo["sigma"]

    def geometry(label, p):
        try:
            return G.Geometry(p)
        except G.GeometryError as e:
            raise ValueError(f"{label}: {e}") from None

    meshes = {}
    for label, kind, m, a, b in edges:
        if kind != "mesh":
            continue
        p = mesh_gear_params(parsed, m)
        meshes[m] = {
            "A": a, "B": b, "params": p, "geometry": geometry(label, p),
            "internal": bool(p.get("internal", False)), "carrier": frame[m],
            "beta": float(_value(parsed, "mesh", m, "center_angle")),
            "mount_A": float(_value(parsed, "mesh", m, "mount_A")),
            "mount_B": float(_value(parsed, "mesh", m, "mount_B")),
            "sigma_A": topo["mesh_sigma"][m][0], "sigma_B": topo["mesh_sigma"][m][1],
        }

    # planets: orbit radius R (nominal operating centre distance of the lowest-index mesh with a
    # central member) and the axis in the carrier's frame, pin errors included (section 3)
    R, pos = {}, {}
    for i in sorted(carrier_of):
        m = min(m for m, mm in meshes.items() if i in (mm["A"], mm["B"])
                and (mm["B"] if mm["A"] == i else mm["A"]) not in carrier_of)
        g0 = geometry(f"mesh[{m}]", dict(meshes[m]["params"], center_distance_error=0.0))
        R[i] = g0.d
        ph = float(_value(parsed, "body", i, "orbit_angle"))
        er = float(_value(parsed, "body", i, "pin_error_r"))
        et = float(_value(parsed, "body", i, "pin_error_t"))
        pos[i] = ((R[i] + er) * math.cos(ph) - et * math.sin(ph),
                  (R[i] + er) * math.sin(ph) + et * math.cos(ph))
    # a mesh in a carrier's frame: centre distance and direction from the positions, plus its
    # own center_distance_error (section 3; the Geometry at the actual distance, section 2)
    for m, mm in meshes.items():
        c = mm["carrier"]
        if c is None:
            continue
        A, B = mm["A"], mm["B"]
        if A in carrier_of and B in carrier_of:     # two planets: from their positions
            OA, OB = pos[A], pos[B]
            dist = math.dist(OA, OB)
            mm["beta"] = math.atan2(OB[1] - OA[1], OB[0] - OA[0])
        else:   # a planet and a central member: polar form about the planet's own ray, so
            # that without a pin error the distance is R exactly and the direction the orbit
            # angle (the reference model's form too)
            P = B if B in carrier_of else A
            er = float(_value(parsed, "body", P, "pin_error_r"))
            et = float(_value(parsed, "body", P, "pin_error_t"))
            dist = math.hypot(R[P] + er, et)
            mm["beta"] = (float(_value(parsed, "body", P, "orbit_angle"))
                          + math.atan2(et, R[P] + er) + (0.0 if P == B else math.pi))
        p = mm["params"]
        g0 = geometry(f"mesh[{m}]", dict(p, center_distance_error=0.0))
        cde = (dist - g0.d) + float(p.get("center_distance_error", 0.0))
        mm["geometry"] = geometry(f"mesh[{m}]", dict(p, center_distance_error=cde))

    # axes: body 1 at the origin; along housing-frame meshes (O_B = O_A + d (cos beta, sin
    # beta), internal pairs too), shafts (coaxial) and carrier ties (a planet at its position in
    # the carrier, a central member on the carrier's axis).  An axis reached twice must close.
    links = {i: [] for i in range(1, n + 1)}

    def link(x, y, off, label):
        links[x].append((y, off, label))
        links[y].append((x, (-off[0], -off[1]), label))
    for label, kind, j, a, b in edges:
        if HOUSING in (a, b):
            continue
        if kind == "shaft":
            link(a, b, (0.0, 0.0), label)
        elif meshes[j]["carrier"] is None:
            d, beta = meshes[j]["geometry"].d, meshes[j]["beta"]
            link(a, b, (d * math.cos(beta), d * math.sin(beta)), label)
        else:
            c = meshes[j]["carrier"]
            for X in (a, b):
                link(c, X, pos.get(X, (0.0, 0.0)), label)
    for i, c in carrier_of.items():
        link(c, i, pos[i], f"body[{i}].carrier")
    center, via = {}, {}
    for start in range(1, n + 1):
        if start in center:
            continue
        if start != 1:
            warnings.warn(f"body {start}'s axis is not tied to body 1's by any housing-frame mesh, "
                          f"shaft or carrier: drawn at the origin", stacklevel=2)
        center[start], via[start] = (0.0, 0.0), "the origin"
        q = deque([start])
        while q:
            x = q.popleft()
            for y, off, label in links[x]:
                at = (center[x][0] + off[0], center[x][1] + off[1])
                if y not in center:
                    center[y], via[y] = at, label
                    q.append(y)
                elif math.dist(at, center[y]) > CLOSE_AXES:
                    raise ValueError(
                        f"the axes do not close: {label} puts body {y}'s axis at "
                        f"({MM * at[0]:.6g}, {MM * at[1]:.6g}) mm, "
                        f"{1e6 * math.dist(at, center[y]):.4g} um from where {via[y]} put it "
                        f"({MM * center[y][0]:.6g}, {MM * center[y][1]:.6g}) mm (tolerance "
                        f"{1e6 * CLOSE_AXES:g} um)")

    gears = []
    for m, mm in meshes.items():
        g, A, B, c = mm["geometry"], mm["A"], mm["B"], mm["carrier"]
        d, beta = g.d, mm["beta"]
        if c is not None:       # a housing gear in a carrier's frame is on the carrier's axis
            O_A = center[A] if A != HOUSING else center[c]
            O_B = center[B] if B != HOUSING else center[c]
        elif A != HOUSING:
            O_A = center[A]
            O_B = center[B] if B != HOUSING else (O_A[0] + d * math.cos(beta),
                                                  O_A[1] + d * math.sin(beta))
        else:
            O_B = center[B]
            O_A = (O_B[0] - d * math.cos(beta), O_B[1] - d * math.sin(beta))
        # paper frame: the housing (carrier) frame translated to O_A, rotated by beta (beta + pi
        # for an internal pair, which puts O_B at (-d, 0)), mirrored when sigma_A = +1
        rot = beta + (math.pi if mm["internal"] else 0.0)
        sA = mm["sigma_A"]
        pts = paper_frame_points(g, mm["internal"])
        for k in ("K_A", "K_B", "a", "b", "P"):
            mm[k] = paper_to_housing(pts[k], O_A, rot, sA)
        mm["u"] = paper_to_housing(pts["u"], (0.0, 0.0), rot, sA)
        mm.update(O_A=O_A, O_B=O_B, rot=rot)
        mm["r_wA"] = g.rAb / math.cos(g.alpha_w)
        mm["r_wB"] = g.rBb / math.cos(g.alpha_w)
        p = mm["params"]
        if p["geometry"] == 1:  # paper geometry: rA given, rB = rA zB_nominal / zA_nominal
            mm["r_wA"], mm["r_wB"] = p["rA"], p["rA"] * p["zB_nominal"] / p["zA_nominal"]
            root = {"A": None, "B": None}
        else:                   # root circles of standard gears (dedendum ha + 0.25 modules)
            mod, ha = p["module"], p["addendum"]
            root = {"A": mod * g.zA / 2 - mod * (ha + 0.25 - p["xA"]),
                    "B": (mod * g.zB / 2 + mod * (ha + 0.25 + p["xB"]) if mm["internal"]
                          else mod * g.zB / 2 - mod * (ha + 0.25 - p["xB"]))}
        for side, body, O, z, r_w, r_b, r_tip, mount, t in (
                ("A", A, O_A, g.zA, mm["r_wA"], g.rAb, g.r_tipA, mm["mount_A"], g.tA),
                ("B", B, O_B, g.zB, mm["r_wB"], g.rBb, g.r_tipB, mm["mount_B"], g.tB)):
            gears.append({"body": body, "center": O, "mesh": m, "side": side,
                          "module": p.get("module") if p["geometry"] == 2 else None,
                          "internal": side == "B" and mm["internal"], "z": z, "r_w": r_w,
                          "r_b": r_b, "r_tip": r_tip, "r_root": root[side], "mount": mount,
                          "t": t})

    bodies = {}
    for i in range(1, n + 1):
        J = parsed["body"].get(i, {}).get("J")
        bodies[i] = {"center": center[i], "sigma": sigma[i], "J": J,
                     "gears": [gg for gg in gears if gg["body"] == i],
                     "carrier": carrier_of.get(i, 0), "R": R.get(i),
                     "orbit_angle": float(_value(parsed, "body", i, "orbit_angle")),
                     "pin": (float(_value(parsed, "body", i, "pin_error_r")),
                             float(_value(parsed, "body", i, "pin_error_t"))),
                     "m": float(_value(parsed, "body", i, "m")),
                     "planets": sorted(k for k, c in carrier_of.items() if c == i)}
    shafts = {}
    for _label, kind, j, a, b in edges:
        if kind == "shaft":
            shafts[j] = {"a": a, "b": b, "k": parsed["shaft"].get(j, {}).get("k")}
    lay = {"counts": counts, "bodies": bodies, "shafts": shafts, "meshes": meshes,
           "gears": gears, "housing_gears": [gg for gg in gears if gg["body"] == HOUSING],
           "angle_start": float(_value(parsed, "body", 1, "angle_start")),
           "general": topo["general"], "root": topo["root"]}
    jam = _jammed(lay, n) if topo["general"] else []
    if jam:
        raise ValueError(
            f"body {', body '.join(map(str, jam))} jammed: no rigid rolling motion of the meshes "
            f"(each relative to its frame, shafts absent) lets {'it' if len(jam) == 1 else 'them'} "
            f"turn (three external gears in a triangle, a planetary set with sun and ring both "
            f"fixed)")
    starts, placed, loops = _placing_walk(parsed, topo)
    lay.update(starts=starts, placed=placed, loops=loops)
    lay["psi1"] = lay["angle_start"]
    if topo["general"] and topo["root"] == HOUSING:
        lay["psi1"] = _reference_psi1(parsed)
    return lay


def _reference_psi1(parsed):
    """Body 1's placed start angle psi_1(0) when the walk starts from the housing, from the
    independent reference's placement (tests/reference_model/train_ref.py, which also refuses a
    set that cannot be assembled: a loop-closing mesh more than 1 % of its base pitch into its
    teeth, with the assembly condition)."""
    from reference_model import train_ref as TR
    try:
        tr = TR.GearTrain(dict(parsed["raw"]))
    except ValueError as e:
        raise ValueError(f"placement (the reference model's): {e}") from None
    return float(tr.psi0[0])


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
    """Per body the distinct gears to draw (an idler's gear named by two meshes is one gear; a
    housing gear named by several meshes, such as a fixed ring, is one gear when it also sits on
    the same axis), and the coaxial groups (bodies joined by shafts, and a carrier with its
    central members, share a centre)."""
    def distinct(gears, housing):
        drawn = []
        for gg in gears:
            name = f"mesh[{gg['mesh']}].{gg['side']}"
            twin = next((d for d in drawn if same_gear(d, gg) and
                         (not housing or math.dist(d["center"], gg["center"]) <= CLOSE_AXES)),
                        None)
            if twin is not None:
                twin["names"].append(name)
            else:
                drawn.append(dict(gg, names=[name]))
        return drawn
    for b in lay["bodies"].values():
        b["drawn"] = distinct(b["gears"], False)
    lay["housing_drawn"] = distinct(lay["housing_gears"], True)
    groups = {}
    for i, b in lay["bodies"].items():
        groups.setdefault((round(b["center"][0], 9), round(b["center"][1], 9)), []).append(i)
    lay["groups"] = list(groups.values())


HOUSING_COLOR = "0.35"


def _all_drawn(lay):
    """(body, gear) for every distinct gear, the housing's (body 0) included."""
    out = [(i, gg) for i, b in lay["bodies"].items() for gg in b["drawn"]]
    return out + [(HOUSING, gg) for gg in lay.get("housing_drawn", [])]


def _outer_radius(gg):
    """The radius a gear reaches: its tip circle, or a ring's rim (root circle + 2.5 modules)."""
    if gg["internal"] and gg["r_root"] is not None:
        return gg["r_root"] + 2.5 * gg["module"]
    return gg["r_tip"]


def _draw_gears(ax, lay, tags):
    """Operating pitch circle strong; tip circle dashed and base circle dotted, lighter.  A ring
    (internal gear, B of an internal mesh) has its tips inside its pitch circle and its body
    outside: an annulus from its root circle outwards, hatched when the housing holds it (body
    0); a fixed external gear (body 0) is hatched inside its base circle."""
    from matplotlib.patches import Circle, Wedge
    for i, gg in _all_drawn(lay):
        col = HOUSING_COLOR if i == HOUSING else _color(i)
        c = gg["center"]
        _circle(ax, c, gg["r_w"], color=col, lw=2.0)
        _circle(ax, c, gg["r_tip"], color=col, lw=0.9, ls="--", alpha=0.55)
        _circle(ax, c, gg["r_b"], color=col, lw=0.9, ls=":", alpha=0.55)
        if gg["internal"] and gg["r_root"] is not None:
            r0, r1 = gg["r_root"], _outer_radius(gg)
            _circle(ax, c, r0, color=col, lw=0.9, alpha=0.8)
            ax.add_patch(Wedge((MM * c[0], MM * c[1]), MM * r1, 0, 360, width=MM * (r1 - r0),
                               fc=col, alpha=0.10 if i != HOUSING else 0.06, ec="none"))
            if i == HOUSING:
                ax.add_patch(Wedge((MM * c[0], MM * c[1]), MM * r1, 0, 360,
                                   width=MM * (r1 - r0), fill=False, hatch="////", ec=col,
                                   lw=0.0, alpha=0.7))
            _circle(ax, c, r1, color=col, lw=1.2)
        elif i == HOUSING:
            ax.add_patch(Circle((MM * c[0], MM * c[1]), MM * 0.6 * gg["r_b"], fill=False,
                                hatch="////", ec=col, lw=0.8))
        if tags:  # tooth count on the pitch circle, away from the body's meshes
            ang = _free_angle(lay, c, gg)
            ax.text(MM * (c[0] + gg["r_w"] * math.cos(ang)),
                    MM * (c[1] + gg["r_w"] * math.sin(ang)),
                    f"z={gg['z']}" + (" ring" if gg["internal"] else ""),
                    color=col, fontsize=7.5, ha="center", va="center", fontweight="bold",
                    bbox=dict(fc="white", ec=col, lw=0.6, alpha=0.9, pad=1.2), zorder=6)


def _draw_carriers(ax, lay):
    """Each carrier's arm: a line from its axis to each of its planets' axes (at psi_c = 0 the
    planets sit at their orbit angles), and a ring round each pin."""
    for c, b in lay["bodies"].items():
        if not b["planets"]:
            continue
        col = _color(c)
        O = b["center"]
        for i in b["planets"]:
            P = lay["bodies"][i]["center"]
            ax.plot([MM * O[0], MM * P[0]], [MM * O[1], MM * P[1]], color=col, lw=5.0,
                    alpha=0.35, solid_capstyle="round", zorder=3)
            ax.plot(MM * P[0], MM * P[1], "o", ms=8, mfc="white", mec=col, mew=2.0, zorder=5)


def _role(lay, i):
    b = lay["bodies"][i]
    if b["planets"]:
        return "carrier"
    if b["carrier"]:
        return "planet"
    return ""


def _draw_centres(ax, lay):
    """Centres, shaft symbols, torsional mounts, forward-sense arrows and body tags."""
    bodies = lay["bodies"]
    for members in lay["groups"]:
        c = bodies[members[0]]["center"]
        radii = [gg["r_b"] for i in members for gg in bodies[i]["gears"]
                 if not gg["internal"]]
        radii += [0.5 * math.dist(c, bodies[p]["center"]) for i in members
                  for p in bodies[i]["planets"]]
        rmin = min(radii, default=0.05)
        group_shafts = [(j, s) for j, s in lay["shafts"].items()
                        if s["a"] in members or s["b"] in members]
        if any(s["a"] in members and s["b"] in members for _j, s in group_shafts):
            ax.plot(MM * c[0], MM * c[1], "o", ms=11, mfc="white", mec="0.3", mew=2.0, zorder=5)
        for k, (j, s) in enumerate(group_shafts):
            mount = HOUSING in (s["a"], s["b"])
            if mount:
                ax.plot(MM * c[0], MM * c[1], "s", ms=11, mfc="white", mec=HOUSING_COLOR,
                        mew=2.0, zorder=5)
            a_txt = "housing" if s["a"] == HOUSING else f"body {s['a']}"
            b_txt = "housing" if s["b"] == HOUSING else f"body {s['b']}"
            txt = (f"shaft[{j}]: {a_txt} - {b_txt}" + (" (torsional mount)" if mount else "")
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
            role = _role(lay, i)
            ax.annotate(f"body {i}" + (f" ({role})" if role == "carrier" else ""),
                        (MM * c[0], MM * (c[1] - rmin * 0.5)),
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
    """Tooth 0 of body 1's gears: its symmetry axis at psi_1(0) + mount (gear-train.md section
    3); psi_1(0) is body[1].angle_start, or where the placing walk from the housing puts body 1
    (planetary.md section 4)."""
    if 1 not in lay["bodies"]:
        return
    c = lay["bodies"][1]["center"]
    for gg in lay["bodies"][1]["drawn"]:
        ang = lay["psi1"] + gg["mount"]
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


def _end(x):
    return "housing" if x == HOUSING else f"body {x}"


def _mesh_role(lay, m):
    if m in lay.get("loops", []):
        return "closes a loop"
    for i, lbl in lay.get("placed", []):
        if lbl == f"mesh[{m}]":
            return f"places body {i}"
    return ""


def _mesh_tag_text(m, mm, lay=None):
    g = mm["geometry"]
    frame = ("" if mm.get("carrier") is None
             else f", in carrier body {mm['carrier']}'s frame")
    kind = "internal" if mm.get("internal") else (
        "paper" if mm["params"]["geometry"] == 1 else "standard")
    role = _mesh_role(lay, m) if lay is not None and lay.get("general") else ""
    deg = round(math.degrees(math.remainder(mm["beta"], 2 * math.pi)), 9) + 0.0
    angle = (f"center_angle = {deg:.4g} deg" if mm.get("carrier") is None
             else f"direction {deg:.4g} deg")
    return (f"mesh[{m}]: A = {_end(mm['A'])}, B = {_end(mm['B'])}{frame}\n"
            f"{kind} geometry, z {g.zA}:{g.zB}, eps = {g.eps:.3f}\n"
            f"d = {MM * g.d:.6g} mm, {angle}" + (f"\n{role}" if role else ""))


def _zoom_meshes(lay, limit=6):
    """The meshes zoomed on below the layout: all of them up to `limit`; otherwise those of each
    carrier's first planet and those in the housing's frame."""
    ms = sorted(lay["meshes"])
    if len(ms) <= limit:
        return ms
    first = {b["planets"][0] for b in lay["bodies"].values() if b["planets"]}
    pick = [m for m in ms if lay["meshes"][m]["carrier"] is None
            or first & {lay["meshes"][m]["A"], lay["meshes"][m]["B"]}]
    return pick[:max(limit, 8)]


def draw_layout(params: dict, path, title: str | None = None):
    """Draws the layout of `params` (FMI names) to `path` (PNG): the whole gearbox, and below it
    one zoom per mesh on its line of action (for more than six meshes: those of each carrier's
    first planet and those in the housing's frame). Returns the layout dict."""
    lay = layout(params)
    _prepare(lay)
    bodies, meshes = lay["bodies"], lay["meshes"]
    planetary = lay["general"]

    xs, ys = [], []
    for _i, gg in _all_drawn(lay):
        c, r = gg["center"], _outer_radius(gg)
        xs += [c[0] - r, c[0] + r]
        ys += [c[1] - r, c[1] + r]
    if not xs:
        xs, ys = [-0.1, 0.1], [-0.1, 0.1]
    ext = max(max(xs) - min(xs), max(ys) - min(ys))

    # mesh tags: beside the pitch point with a leader to it; in a tree outside every tip circle
    # with the mesh's data, in a planetary train short (the data are in the legend)
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
        if planetary:
            h = 0.045 * ext
            tags[m] = (P[0] + h * nrm[0], P[1] + h * nrm[1])
            continue
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
    legend_w = 5.6 if planetary else 4.6
    main_h = min(max(3.5, main_w * (h + 2 * pad) / (w + 2 * pad)), 11.0)
    zooms = _zoom_meshes(lay)
    nz = len(zooms)
    zoom_h = 3.0 if nz else 0.0
    if planetary:   # room for the legend (the bodies' and the meshes' lines, 6.5 pt)
        lines = sum(2 + len(b["drawn"]) + (1 if b["carrier"] or b["planets"] else 0)
                    + (1 if any(b["pin"]) else 0) for b in bodies.values())
        lines += 3 * len(meshes) + 16
        main_h = max(main_h, 0.118 * lines - zoom_h)
    fig = plt.figure(figsize=(main_w + legend_w, main_h + zoom_h + 1.0))
    fh = fig.get_figheight()
    # main view on top (the legend to its right), the zoom row below across the whole width
    gs = fig.add_gridspec(1, 1, left=0.06, right=main_w / (main_w + legend_w),
                          top=1 - 0.45 / fh,
                          bottom=(zoom_h + 0.95) / fh if nz else 0.6 / fh)
    gz = fig.add_gridspec(1, max(nz, 4), left=0.05, right=0.98, top=(zoom_h + 0.1) / fh,
                          bottom=0.35 / fh, wspace=0.35) if nz else None
    ax = fig.add_subplot(gs[0, 0])

    _draw_gears(ax, lay, tags=True)
    _draw_carriers(ax, lay)
    _draw_centres(ax, lay)
    _draw_lines_of_action(ax, lay, names=False)
    _draw_tooth0(ax, lay, label=True)
    for m, mm in meshes.items():
        if planetary:
            txt = f"mesh[{m}]" + (" (loop)" if m in lay["loops"] else "")
            box = dict(fc="#fff6dd", ec=CONTACT, lw=0.6, alpha=0.85, pad=1.2)
            fs = 6.5
        else:
            txt = _mesh_tag_text(m, mm)
            box = dict(fc="#fff6dd", ec=CONTACT, lw=0.8, alpha=0.92, pad=2.5)
            fs = 7.5
        ax.annotate(txt, xy=(MM * mm["P"][0], MM * mm["P"][1]),
                    xytext=(MM * tags[m][0], MM * tags[m][1]), fontsize=fs, ha="center",
                    va="center", color="0.1", bbox=box,
                    arrowprops=dict(arrowstyle="-", color=CONTACT, lw=0.8, shrinkA=0,
                                    shrinkB=3), zorder=10)
    ax.set_aspect("equal")
    ax.set_xlim(MM * (min(xs) - pad), MM * (max(xs) + pad))
    ax.set_ylim(MM * (min(ys) - pad), MM * (max(ys) + pad))
    ax.set_xlabel("x [mm] (housing frame, body 1 at the origin"
                  + (", carriers at psi = 0)" if planetary else ")"))
    ax.set_ylabel("y [mm]")
    ax.grid(True, lw=0.3, alpha=0.5)
    counts = lay["counts"]
    nb, ns, nm = counts["n_bodies"], counts["n_shafts"], counts["n_meshes"]
    extra = ""
    if planetary:
        nc = sum(1 for b in bodies.values() if b["planets"])
        npl = sum(1 for b in bodies.values() if b["carrier"])
        nl = len(lay["loops"])
        extra = (f" ({nc} carrier{'' if nc == 1 else 's'}, {npl} planet{'' if npl == 1 else 's'})"
                 f"; {nl} mesh{'' if nl == 1 else 'es'} close{'s' if nl == 1 else ''} a loop"
                 + ("; the walk starts at the housing" if lay["root"] == HOUSING else ""))
    ax.set_title(title or f"SpurGearTrain layout: {nb} bod{'y' if nb == 1 else 'ies'}, "
                          f"{ns} shaft{'' if ns == 1 else 's'}, {nm} mesh{'' if nm == 1 else 'es'}"
                          + extra, fontsize=10 if planetary else None)

    # zooms: the line of action with the contact segment
    for k, m in enumerate(zooms):
        mm = meshes[m]
        az = fig.add_subplot(gz[0, k])
        _draw_gears(az, lay, tags=False)
        _draw_lines_of_action(az, lay, names=True, fs=8)
        _draw_tooth0(az, lay, label=False)
        g = mm["geometry"]
        # centred on K_A K_B with the contact segment: for a ring the pitch point and the
        # segment lie beyond K_A, on the far side from K_B (planetary.md section 1)
        span = [mm[k] for k in ("K_A", "K_B", "a", "b", "P")]
        lo = min(range(5), key=lambda k: (span[k][0] - mm["K_B"][0]) * mm["u"][0]
                 + (span[k][1] - mm["K_B"][1]) * mm["u"][1])
        hi = max(range(5), key=lambda k: (span[k][0] - mm["K_B"][0]) * mm["u"][0]
                 + (span[k][1] - mm["K_B"][1]) * mm["u"][1])
        cx = 0.5 * (span[lo][0] + span[hi][0])
        cy = 0.5 * (span[lo][1] + span[hi][1])
        half = 0.62 * math.dist(span[lo], span[hi])
        az.set_xlim(MM * (cx - half), MM * (cx + half))
        az.set_ylim(MM * (cy - half), MM * (cy + half))
        az.set_aspect("equal")
        az.grid(True, lw=0.3, alpha=0.5)
        az.tick_params(labelsize=7)
        sa, sb = ("CW" if mm["sigma_A"] < 0 else "CCW"), ("CW" if mm["sigma_B"] < 0 else "CCW")
        az.set_title((f"mesh[{m}], internal ring\n" if mm["internal"] else
                      f"mesh[{m}] (zoom on the line of action)\n")
                     + f"A = {_end(mm['A'])} ({sa}), B = {_end(mm['B'])} ({sb})\n"
                     f"L = {MM * g.L:.4g} mm, a-b = {MM * (g.s_b - g.s_a):.4g} mm",
                     fontsize=7.5)

    from matplotlib.patches import Patch
    handles = []
    for i, b in bodies.items():
        J = f"J = {_fmt(b['J'])} kg.m2" if b["J"] is not None else "J: FMU default"
        sense = "CCW" if b["sigma"] > 0 else "CW"
        gear_txt = "\n  ".join(f"z={gg['z']}{' ring' if gg['internal'] else ''}: "
                               + " = ".join(gg["names"]) for gg in b["drawn"])
        role = ""
        if b["planets"]:
            role = f"\n  carrier of bodies {', '.join(map(str, b['planets']))}"
        elif b["carrier"]:
            role = (f"\n  planet of body {b['carrier']}: orbit angle "
                    f"{math.degrees(b['orbit_angle']):.4g} deg, R = {MM * b['R']:.6g} mm"
                    + (f", m = {_fmt(b['m'])} kg" if b["m"] else ""))
            if any(b["pin"]):
                role += (f"\n  pin error r {1e6 * b['pin'][0]:g} um, "
                         f"t {1e6 * b['pin'][1]:g} um")
        handles.append(Line2D([], [], color=_color(i), lw=2.0,
                              label=f"body {i} ({J}), forward {sense} (sigma {b['sigma']:+d})"
                                    + role + (f"\n  {gear_txt}" if gear_txt else "")))
    if lay["housing_drawn"]:
        gear_txt = "\n  ".join(f"z={gg['z']}{' ring' if gg['internal'] else ''}: "
                               + " = ".join(gg["names"]) for gg in lay["housing_drawn"])
        handles.append(Patch(fc="white", ec=HOUSING_COLOR, hatch="////",
                             label=f"the housing (body 0), fixed\n  {gear_txt}"))
    handles += [
        Line2D([], [], color="0.3", lw=2.0, label="operating pitch circle"),
        Line2D([], [], color="0.3", lw=0.9, ls="--", alpha=0.6,
               label="tip circle" + (" (a ring's inside its pitch circle)"
                                     if any(gg["internal"] for _i, gg in _all_drawn(lay))
                                     else "")),
        Line2D([], [], color="0.3", lw=0.9, ls=":", alpha=0.6, label="base circle"),
        Line2D([], [], color="k", lw=1.0, marker="o", ms=3.5,
               label="forward line of action K_A K_B\n(tangent to both base circles)"),
        Line2D([], [], color=CONTACT, lw=4.0, label="contact segment a-b\n(arrow: force on B)"),
        Line2D([], [], color="k", marker="x", ms=5, ls="none", label="pitch point P"),
        Line2D([], [], color="0.2", lw=1.0, ls="-.", marker="D", ms=5,
               label=f"tooth 0 axis of body 1\n(psi_1(0) + mount, psi_1(0) = "
                     f"{lay['psi1']:.6g} rad"
                     + (", placed from the housing)" if lay["root"] == HOUSING and planetary
                        else ")")),
        Line2D([], [], color="0.4", lw=1.4, marker=r"$\circlearrowleft$", ms=10, ls="none",
               label="forward sense"),
        Line2D([], [], color="0.55", lw=0.6, ls=(0, (8, 4)), label="line of centres"),
    ]
    if any(b["planets"] for b in bodies.values()):
        handles.append(Line2D([], [], color="0.5", lw=5.0, alpha=0.35, marker="o", ms=8,
                              mfc="white", mec="0.5", label="carrier arm to a planet's pin"))
    if any(HOUSING not in (s["a"], s["b"]) for s in lay["shafts"].values()):
        handles.append(Line2D([], [], marker="o", ms=10, mfc="white", mec="0.3", mew=2.0,
                              ls="none", label="shaft (coaxial bodies)"))
    if any(HOUSING in (s["a"], s["b"]) for s in lay["shafts"].values()):
        handles.append(Line2D([], [], marker="s", ms=10, mfc="white", mec=HOUSING_COLOR,
                              mew=2.0, ls="none", label="shaft to the housing (torsional mount)"))
    if planetary:
        for m, mm in meshes.items():
            handles.append(Line2D([], [], color=CONTACT, lw=0.0,
                                  label=_mesh_tag_text(m, mm, lay).replace("\n", "; ", 1)
                                  .replace("\n", "\n  ")))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              fontsize=6.5 if planetary else 8, frameon=False)
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
        if all(math.hypot(x - gg["center"][0], y - gg["center"][1]) > gg["r_tip"] + margin
               for gg in lay["gears"] if not gg["internal"]):
            return h
        h += 0.25 * margin
    return h


def _free_angle(lay, c, gear):
    """A direction from the centre c away from the lines of centres of the meshes there, for a
    tag."""
    dirs = []
    for mm in lay["meshes"].values():   # towards each pitch point of a gear on this axis
        if min(math.dist(mm["O_A"], c), math.dist(mm["O_B"], c)) <= CLOSE_AXES:
            dirs.append(math.atan2(mm["P"][1] - c[1], mm["P"][0] - c[0]))
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
    "mesh[2].zA" = 33), or SpurGearTrain's start values for a gearbox file (a top-level `name`,
    docs/gearbox-file.md), from the Rust mapping the tests check (tools/scene_to_ssp.py)."""
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    if "start_values" not in scene and "name" in scene:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from scene_to_ssp import gearbox_start_values
        return gearbox_start_values(path)
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
    rp.add_argument("--scene", help="the run's scene TOML: with a planetary train, groups the "
                    "meshes and adds the planets' load sharing")
    rp.add_argument("--set", action="append", default=[], metavar="name=value",
                    help="FMI parameter of the run (after the scene's), repeatable")
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
            params = load_scene(a.scene) if a.scene else {}
            for s in a.set:
                if "=" not in s:
                    ap.error(f"--set {s!r}: expected name=value")
                k, v = s.split("=", 1)
                params[k.strip()] = parse_value(v)
            plot_run(a.csv, a.out, params if (a.scene or a.set) else None)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
