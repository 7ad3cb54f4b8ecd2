#!/usr/bin/env python3
"""docs/lateral-lin-parker.png: scenes/train/lateral-lin-parker.toml (Lin & Parker's set with
lumped meshes, every member lateral) through SpurGearTrain.fmu with the `fmpy simulate` command
the scene tests run (tests/python/train_scene_compare.py), drawn over its independent reference
trace (tests/reference/train/lateral-lin-parker.csv, lateral_ref at rtol 1e-10).

    .venv/bin/python tools/lateral_scene_plot.py [--fmu target/fmu/SpurGearTrain.fmu] [--out PNG]

Five panels: the central members' centres after the lateral blow at t = 0 (the translational
modes), the mesh forces of planet 1 after the torque step at 1 ms, planet 1's centre on its pin
(radial, tangential) and its pin's force, the sun's bearing force and the housing's.  Each panel's title gives the
largest difference between the FMU and the reference over the output grid.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests" / "python"), str(ROOT / "tests")]
import train_scene_compare as TS  # noqa: E402
from reference_model import gearmesh_ref as G  # noqa: E402

SCENE = "lateral-lin-parker"
PANELS = [
    ("centres of the central members, x [um]", [("body[1].x", "sun", 1e6), ("body[2].x", "ring", 1e6),
                                                ("body[3].x", "carrier", 1e6)]),
    ("planet 1's meshes [kN]", [("mesh[1].F_fwd", "sun-planet", 1e-3), ("mesh[5].F_fwd", "planet-ring", 1e-3)]),
    ("planet 1 on its pin [um]", [("body[4].x", "radial", 1e6), ("body[4].y", "tangential", 1e6)]),
    ("planet 1's pin force [kN]", [("body[4].Fx", "radial", 1e-3), ("body[4].Fy", "tangential", 1e-3)]),
    ("the sun's bearing and the housing [N]", [("body[1].Fx", "sun bearing, x", 1.0),
                                               ("housing.Fx", "housing, x", 1.0), ("housing.Fy", "housing, y", 1.0)]),
]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmu", default=str(ROOT / "target" / "fmu" / "SpurGearTrain.fmu"))
    ap.add_argument("--out", default=str(ROOT / "docs" / "lateral-lin-parker.png"))
    args = ap.parse_args(argv)
    scene = TS.load_scene(SCENE)
    with tempfile.TemporaryDirectory() as work:
        fnames, ftab, seconds, _ = TS.run_fmpy(args.fmu, scene, work)
    rnames, rtab = G.read_table_csv(str(TS.TRAIN_REF_DIR / f"{SCENE}.csv"))
    dt = scene["output_interval"]
    f_rows, r_rows = (G.grid_rows(n, t, dt) for n, t in ((fnames, ftab), (rnames, rtab)))
    fig, axes = plt.subplots(len(PANELS), 1, figsize=(9, 13), sharex=True)
    for ax, (title, lines) in zip(axes, PANELS):
        worst = []
        for var, label, scale in lines:
            f = f_rows[:, fnames.index(var)]
            r = r_rows[:, rnames.index(var)]
            t_ms = 1e3 * f_rows[:, 0]
            line, = ax.plot(t_ms, scale * f, lw=1.0, label=label)
            ax.plot(1e3 * r_rows[:, 0], scale * r, "--", lw=0.8, color="k", alpha=0.5)
            worst.append(f"{label} {np.max(np.abs(f - r)) / max(np.ptp(r), 1e-300):.1e}")
        ax.set_title(f"{title}  (FMU - reference, of the range: {', '.join(worst)})", fontsize=9)
        ax.axvline(1.0, color="0.6", lw=0.6)
        ax.legend(fontsize=8, loc="upper right")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t [ms]   (solid: the FMU through fmpy simulate; dashed: the reference)")
    fig.suptitle("Lin & Parker's set, every member lateral, lumped meshes: a lateral blow on the sun "
                 "at 0, a torque step at 1 ms", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out} (fmpy simulate {seconds:.2f} s)")


if __name__ == "__main__":
    main()
