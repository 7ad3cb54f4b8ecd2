#!/usr/bin/env bash
# Issue 5, long runs: the running paper scene for many communication steps of 1e-4 s through the
# C API, every output read after every step. Checks that the contact coordinates s_f1, s_f2,
# s_b1, s_b2 stay inside their windows [s_b - 2 p_b, s_b], that every output stays finite, and
# that the resident set size, the time per step and the integrator's work per simulated second
# stay flat (first tenth against last tenth); prints the numbers.
#
# Usage: bash tools/long-run.sh [steps]     (default 10000000 = 1000 s simulated, ~30 s)
# CI runs the same test with 1e6 steps (100 s simulated, ~3 s) inside `cargo test --release`.
set -euo pipefail
cd "$(dirname "$0")/.."
FMI_LONG_STEPS=${1:-10000000} cargo test --release --test fmi_reliability -- \
  --exact long_run_of_the_paper_scene_has_no_drift --nocapture
