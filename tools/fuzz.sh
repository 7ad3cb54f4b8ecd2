#!/usr/bin/env bash
# Issue 5, fuzzing: a longer campaign of the FMI call-sequence fuzzer (tests/fmi_fuzz.rs) than
# the bounded pass of CI, from a random seed (printed; FMI_FUZZ_SEED=<n> replays it).
# A failure is shrunk to a minimal call sequence, printed, and its seed appended to
# tests/fmi_fuzz.proptest-regressions (commit that file; add the sequence to corpus() if it
# deserves a name).
#
# Usage: bash tools/fuzz.sh [seconds] [relaxed]   (default 600 s; instances restored from hostile
# blobs are held to every invariant; "relaxed" sets FMI_FUZZ_STRICT=0 to check them only for
# crashes, panics, hangs, the state machine and logging)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
[ "${2:-}" = relaxed ] && export FMI_FUZZ_STRICT=0
FMI_FUZZ_CASES=100000000 FMI_FUZZ_SECONDS=$seconds FMI_FUZZ_SEED=${FMI_FUZZ_SEED:-random} \
  cargo test --release --test fmi_fuzz -- random_call_sequences --nocapture
