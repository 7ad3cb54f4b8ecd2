#!/usr/bin/env python3
"""The loaded static transmission error and mesh stiffness over two mesh cycles (issue 9,
point 4), contact models 1 and 3, each without and with tip relief: runs `examples/static_te.rs`
(exact static balance at each wheel position, no dynamics) and writes the CSV and a plot. The
relief is the parameters' (--set tip_relief_A=... ) or the example's textbook long relief.

    .venv/bin/python tools/static_te.py [--torque 100] [--out docs/static-te] [-- --set name=value ...]
"""

import argparse
import csv
import io
import subprocess
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--torque", type=float, default=100.0, help="torque on A [N.m]")
    ap.add_argument("--out", default=str(ROOT / "docs" / "static-te"), help="path without extension")
    ap.add_argument("rest", nargs="*", help="passed on to the example (e.g. --set xA=0.2)")
    a = ap.parse_args(argv)
    text = subprocess.run(
        ["cargo", "run", "-q", "--release", "--example", "static_te", "--",
         "--torque", str(a.torque), *a.rest],
        cwd=ROOT, check=True, capture_output=True, text=True)
    relief_note = text.stderr.strip().splitlines()[-1] if text.stderr.strip() else ""
    text = text.stdout
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".csv").write_text(text)
    rows = list(csv.DictReader(io.StringIO(text)))
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for cm, label, color in (("1", "model 1 (Johnson, contact only)", "C0"),
                             ("3", "model 3 (tooth structure + Weber)", "C1")):
        for relief, style in (("0", "-"), ("1", "--")):
            r = [x for x in rows if x["contact_model"] == cm and x["tip_relief"] == relief]
            th = [float(x["theta_A"]) for x in r]
            te = [1e6 * float(x["static_te"]) for x in r]
            ptp = max(te) - min(te)
            name = f"{label}, {'tip relief' if relief == '1' else 'no relief'} (p-p {ptp:.2f} um)"
            ax1.plot(th, te, style, color=color, label=name)
            ax2.plot(th, [1e-9 * float(x["k_mesh"]) for x in r], style, color=color, label=name)
    ax1.set_ylabel("loaded static TE [um]")
    ax2.set_ylabel("k_mesh [kN/um]")
    ax2.set_xlabel("theta_A [rad] (two mesh cycles)")
    ax1.set_title(f"Static transmission error at tau_A = {a.torque:g} N.m, exact static balance\n"
                  + relief_note, fontsize=10)
    handles, labels = ax1.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", fontsize=8, ncol=2)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    fig.savefig(out.with_suffix(".png"), dpi=110)
    print(out.with_suffix(".csv"), out.with_suffix(".png"))


if __name__ == "__main__":
    main()
