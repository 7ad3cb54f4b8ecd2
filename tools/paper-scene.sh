#!/usr/bin/env bash
# Builds the FMUs (SpurGearMesh and SpurGearTrain) and runs the paper's scene through FMPy: writes out/paper-scene.csv and
# out/paper-scene.png (transmission error and contact forces), and the paper's Fig. 7, rigid
# against compliant contact force: out/fig7-rigid-vs-compliant.png, out/fig7-*.csv, out/fig7-summary.md.
# Usage: bash tools/paper-scene.sh      (the README's first command)
set -euo pipefail
cd "$(dirname "$0")/.."
py=$(bash tools/venv.sh)
fmu=$(cargo run -q -p fmu-packaging --release)
train=$(cargo run -q -p fmu-packaging --release --bin package-train)
echo "SpurGearTrain: $train" >&2
"$py" tools/paper_scene.py "$fmu" out
