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

From Python: `layout(params) -> dict` here, `draw_layout(params, path)` in layout_drawing.py,
`plot_run(csv_path, out_png)` in run_plots.py.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import tomllib
import warnings
from collections import deque
from pathlib import Path

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
LATERAL_FIELDS = {"lateral", "k_x", "k_y", "c_x", "c_y", "x_start", "y_start", "vx_start",
                  "vy_start"}
BODY_FIELDS = {"J", "c", "w_start", "tau", "tau_ripple", "ripple_order", "ripple_phase",
               # planetary.md section 3: a planet's carrier, orbit angle, mass, pin errors
               "carrier", "orbit_angle", "m", "pin_error_r", "pin_error_t",
               # lateral.md section 1: a lateral body's bearing and start (not drawn)
               *LATERAL_FIELDS}
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
# metres to millimetres (messages and drawings)
MM = 1e3

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
    # The torsional reference places the gears; a lateral body's displacements come after.
    raw = {k: v for k, v in parsed["raw"].items() if k.rsplit(".", 1)[-1] not in LATERAL_FIELDS}
    try:
        tr = TR.GearTrain(raw)
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
            from layout_drawing import draw_layout

            draw_layout(params, a.out, title=a.title)
        else:
            params = load_scene(a.scene) if a.scene else {}
            for s in a.set:
                if "=" not in s:
                    ap.error(f"--set {s!r}: expected name=value")
                k, v = s.split("=", 1)
                params[k.strip()] = parse_value(v)
            from run_plots import plot_run

            plot_run(a.csv, a.out, params if (a.scene or a.set) else None)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
