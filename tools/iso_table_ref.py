#!/usr/bin/env python3
"""ISO 6336-1 comparison table of the independent Python reference (contact models 1 and 3).

    .venv/bin/python tools/iso_table_ref.py                      # Markdown to stdout
    .venv/bin/python tools/iso_table_ref.py --bore 0.5 0.25 --E 2.06e11 --line-load 300

For each standard pair of tests/reference_model/tooth_structure_ref.TABLE_PAIRS: the quasi-static
mesh at the given line load (exact static balance at 12 Gauss points per contact interval of one
mesh cycle), the mean over the cycle of the secant mesh stiffness W/dte (the definition behind the
issue's numbers) and of the tangent stiffness sum dF_i/d(delta), and the peak of the single-pair
secant stiffness over the single-contact zone, all per unit face width in N/(mm um), against
ISO 6336-1 method B: c' (single) and c_gamma_alpha (mean), as the spec gives them.  Solid wheels:
bore radius = fraction * root radius (Sainsot's h_f = 1/fraction).  No factor is tuned.
"""

from __future__ import annotations

import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests"))
from reference_model import tooth_structure_ref as T  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bore", type=float, nargs="+", default=[0.5, 0.25],
                    help="bore radius as a fraction of the root radius (one table each)")
    ap.add_argument("--E", type=float, default=T.E_ISO, help="Young's modulus [Pa] (ISO: 2.06e11)")
    ap.add_argument("--nu", type=float, default=T.NU_STEEL)
    ap.add_argument("--line-load", type=float, default=300.0, help="F/b [N/mm]")
    args = ap.parse_args(argv)

    print(f"# ISO 6336-1 method B against the Python reference (line load {args.line_load:g} N/mm, "
          f"E = {args.E:.4g} Pa, nu = {args.nu:g})\n")
    print("Stiffness per unit face width in N/(mm um). Mean: mean over one mesh cycle of the secant "
          "W/dte (tangent mean in brackets) against c_gamma_alpha; peak: the single-pair secant "
          "stiffness's maximum over the single-contact zone against c'. Ratios are model/ISO.\n")
    for frac in args.bore:
        print(f"## Solid wheels, bore radius = {frac:g} x root radius (h_f = {1 / frac:g})\n")
        print("| zA/zB | m [mm] | xA/xB | eps | c' | c_ga | M1 mean/c_ga | M1 peak/c' "
              "| M3 mean [tangent] | M3 peak | **M3 mean/c_ga** | **M3 peak/c'** |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        notes = []
        r1, r3m, r3p = [], [], []
        for zA, zB, m, xA, xB in T.TABLE_PAIRS:
            r = T.table_row(zA, zB, m, xA, xB, E=args.E, nu=args.nu,
                            line_load=args.line_load * 1e3, bore_fraction=frac)
            a = r["m3_mean"] / r["c_gamma_alpha"]
            p = r["m3_peak"] / r["c_prime"]
            r3m.append(a)
            r3p.append(p)
            r1.append(r["m1_mean"] / r["c_gamma_alpha"])
            print(f"| {zA}/{zB} | {m:g} | {xA:+.2f}/{xB:+.2f} | {r['eps']:.3f} | {r['c_prime']:.2f} "
                  f"| {r['c_gamma_alpha']:.2f} | {r['m1_mean'] / r['c_gamma_alpha']:.2f} "
                  f"| {r['m1_peak'] / r['c_prime']:.2f} | {r['m3_mean']:.2f} [{r['m3_mean_tangent']:.2f}] "
                  f"| {r['m3_peak']:.2f} | **{a:.3f}** | **{p:.3f}** |")
            notes += [f"{zA}/{zB}: {w}" for w in r["warnings"]]
        print(f"\nModel 3 mean/c_ga: {min(r3m):.3f} .. {max(r3m):.3f}; peak/c': "
              f"{min(r3p):.3f} .. {max(r3p):.3f}. Model 1 mean/c_ga: {min(r1):.2f} .. {max(r1):.2f}.\n")
        for n in notes:
            print(f"- warning: {n}")
        if notes:
            print()


if __name__ == "__main__":
    main()
