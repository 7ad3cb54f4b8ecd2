#!/usr/bin/env bash
# Builds the FMU and runs the paper's scene through FMPy: writes out/paper-scene.csv and
# out/paper-scene.png (transmission error and contact forces).
# Usage: bash tools/paper-scene.sh      (the README's first command)
set -euo pipefail
cd "$(dirname "$0")/.."
py=$(bash tools/venv.sh)
fmu=$(cargo run -q -p fmu-packaging --release)
"$py" tools/paper_scene.py "$fmu" out
