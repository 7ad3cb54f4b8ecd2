"""Test vectors of contact model 3's compliance from the independent Python reference
(tooth_structure_ref.py), for the Rust transcription (src/model/tooth_structure.rs, test
`matches_the_python_reference`): per standard pair and contact position, each wheel's
structural compliance and ln C.

Regenerate: .venv/bin/python tests/reference_model/tooth_structure_vectors.py
(writes tests/reference/tooth_structure.csv).
"""

import csv
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import tooth_structure_ref as ts  # noqa: E402

# (zA, zB, module [m], xA, xB): root circle below and above the base circle, shifts of both signs.
PAIRS = [(20, 30, 4e-3, 0.0, 0.0), (17, 60, 2e-3, 0.5, -0.3), (40, 100, 8e-3, -0.2, 0.4),
         (25, 25, 3e-3, 0.3, 0.3)]
FRACTIONS = [0.0, 0.25, 0.5, 0.75, 1.0]


def main():
    out = HERE.parent / "reference" / "tooth_structure.csv"
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["zA", "zB", "module", "xA", "xB", "width", "E", "nu", "L", "s_A",
                    "compliance_A", "compliance_B", "ln_C"])
        for zA, zB, m, xA, xB in PAIRS:
            p = ts.standard_pair(zA, zB, m, xA, xB)
            for q in FRACTIONS:
                s_A = p.s_a + q * (p.s_b - p.s_a)
                cA = ts.tooth_compliance(p.A, s_A, p.b)["total"]
                cB = ts.tooth_compliance(p.B, p.L - s_A, p.b)["total"]
                w.writerow([zA, zB, repr(m), repr(xA), repr(xB), repr(p.b), repr(p.A.E), repr(p.A.nu),
                            repr(p.L), repr(s_A), repr(cA), repr(cB), repr(ts.ln_C(p, s_A))])
    print(out)


if __name__ == "__main__":
    main()
