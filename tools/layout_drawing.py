#!/usr/bin/env python3
"""The drawing of a SpurGearTrain gearbox's layout (tools/train_layout.py computes it): each gear
as its pitch, tip and base circles, carriers, centres, the lines of action with their contact
segments, tooth 0 of every gear, tags and a zoom on each mesh.

From Python: `draw_layout(params, path)`; from the shell: `tools/train_layout.py layout`.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from train_layout import CLOSE_AXES, HOUSING, MM, layout, same_gear  # noqa: E402

# --------------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------------

BODY_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2",
               "#17becf"]


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
