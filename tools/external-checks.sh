#!/usr/bin/env bash
# Run the packaged FMU through two independent FMI importers, in both the
# Model Exchange and the Co-Simulation interface:
#
#   * FMU Compliance Checker  (env FMUCHECK = path to fmuCheck.linux64)
#   * OMSimulator             (env OMSIMULATOR_HOME = install prefix, uses bin/OMSimulator)
#
# Neither tool can be installed from a package registry, so this is not part
# of CI; a missing tool is reported as "skipped" and is not a failure.
# How to build them: docs/external-checks.md
#
# usage: bash tools/external-checks.sh [path/to/SpurGearMesh.fmu]
#        (any of the project's FMI 2.0 FMUs: each interface it declares is checked)
#
# Exit status: 0 = every available tool passed (or none was available),
#              1 = a tool failed or reported warnings/errors,
#              2 = usage error (e.g. the FMU does not exist).
set -euo pipefail

STOP_TIME=0.01
STEP=1e-5       # fmuCheck: forward-Euler step (ME) / communication step (CS)
# ME and CS must give the same final dynamic transmission error to this
# relative tolerance; they use different integrators, so not bit-for-bit.
DTE_RTOL=${DTE_RTOL:-1e-3}

REPO_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
FMU=${1:-$REPO_ROOT/target/fmu/SpurGearMesh.fmu}

# --- which tools are there? -------------------------------------------------
have_fmucheck=0
have_oms=0
if [[ -n ${FMUCHECK:-} && -x ${FMUCHECK} ]]; then
  have_fmucheck=1
else
  echo "skipped: fmuCheck not found (set FMUCHECK to the fmuCheck.linux64 binary); see docs/external-checks.md"
fi
if [[ -n ${OMSIMULATOR_HOME:-} && -x ${OMSIMULATOR_HOME}/bin/OMSimulator ]]; then
  have_oms=1
else
  echo "skipped: OMSimulator not found (set OMSIMULATOR_HOME to its install prefix); see docs/external-checks.md"
fi
if (( !have_fmucheck && !have_oms )); then
  exit 0
fi

if [[ ! -f $FMU ]]; then
  echo "error: FMU not found: $FMU (package it first)" >&2
  exit 2
fi
FMU=$(cd "$(dirname "$FMU")" && pwd)/$(basename "$FMU")
echo "FMU: $FMU"

WORK=$(mktemp -d "${TMPDIR:-/tmp}/external-checks.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# Print a file (or stdin) indented, so tool output stands apart from ours.
show() { sed 's/^/    | /' "${1:--}"; }

# --- FMU Compliance Checker -------------------------------------------------
# fmuCheck writes its log (including the final summary) to the -e file and the
# simulation result to -o. Its exit code is 0 even when the summary counts
# warnings, so the counts are checked separately.
run_fmucheck() {
  local kind=$1
  local log=$WORK/fmucheck_$kind.log out=$WORK/fmucheck_$kind.csv
  echo
  echo "== fmuCheck -k $kind -h $STEP -s $STOP_TIME"
  local rc=0
  "$FMUCHECK" -k "$kind" -h "$STEP" -s "$STOP_TIME" -t "$WORK" \
    -e "$log" -o "$out" "$FMU" >"$WORK/fmucheck_$kind.stdout" 2>&1 || rc=$?
  # The summary is the last few lines of the log; show just that part.
  sed -n '/FMU check summary/,$p' "$log" | show
  if (( rc != 0 )); then
    fail "fmuCheck -k $kind exited with status $rc"
    # No summary when it stops early: show its error lines instead.
    grep -Ei '^\[(WARNING|ERROR|FATAL)\]' "$log" | show || true
    show "$WORK/fmucheck_$kind.stdout"
    return
  fi
  # Summary lines look like "<n> warning(s) and error(s)", "<n> Warning(s)",
  # "<n> Error(s)". A missing summary means the checker stopped early.
  local counts
  counts=$(grep -Eio '^[[:space:]]*[0-9]+ (warning\(s\) and error\(s\)|warning\(s\)|error\(s\))' "$log" \
           | awk '{print $1}' || true)
  if [[ -z $counts ]]; then
    fail "fmuCheck -k $kind: no summary in its log"
  elif grep -qv '^0$' <<<"$counts"; then
    fail "fmuCheck -k $kind reported warnings or errors"
    grep -Ei '^\[(WARNING|ERROR|FATAL)\]' "$log" | show || true
  else
    echo "ok: fmuCheck -k $kind"
  fi
}

# --- OMSimulator ------------------------------------------------------------
# OMSimulator prefixes every message with its severity ("info:", "warning:",
# "error:"), and at exit prints "info: <n> warnings / <n> errors" if there
# were any. A normal run prints only info lines, some of which name variables
# such as pitch_errors_A; so "error"/"warning" is matched as a whole word
# only, which does not hit identifiers like that.
run_oms() {
  local mode=$1
  local log=$WORK/oms_$mode.log result=$WORK/oms_$mode.csv
  echo
  echo "== OMSimulator --mode=$mode --stopTime=$STOP_TIME"
  local rc=0
  # OMSimulator unpacks the FMU into its working directory (its --tempDir
  # option did not take effect in our build), so run it inside $WORK.
  (cd "$WORK" && "$OMSIMULATOR_HOME/bin/OMSimulator" --mode="$mode" \
     --stopTime="$STOP_TIME" --resultFile="$result" "$FMU") >"$log" 2>&1 || rc=$?
  show "$log"
  if (( rc != 0 )); then
    fail "OMSimulator --mode=$mode exited with status $rc"
  elif grep -Eiwq '(error|warning)s?' "$log"; then
    fail "OMSimulator --mode=$mode printed an error or warning"
  elif [[ ! -s $result ]]; then
    fail "OMSimulator --mode=$mode wrote no result file"
  else
    echo "ok: OMSimulator --mode=$mode"
  fi
}

# Final value of column "dte" in an OMSimulator result CSV (quoted header,
# ", "-separated values).
final_dte() {
  awk -F', *' '
    NR == 1 { for (i = 1; i <= NF; i++) { gsub(/"/, "", $i); if ($i == "dte") col = i } next }
    NF > 1  { last = $col }
    END     { if (!col) exit 1; print last }' "$1"
}

# The interfaces the FMU declares (the shaft and the controller are Co-Simulation only).
kinds=()
md=$(unzip -p "$FMU" modelDescription.xml)
grep -q '<ModelExchange' <<<"$md" && kinds+=(me)
grep -q '<CoSimulation' <<<"$md" && kinds+=(cs)

if (( have_fmucheck )); then
  for kind in "${kinds[@]}"; do
    run_fmucheck "$kind"
  done
fi

if (( have_oms )); then
  run_oms me
  run_oms cs
  # Same model, same stop time: the two interfaces should agree on the
  # physics. Different integrators (CVODE in OMSimulator for ME, the FMU's own
  # solver for CS) mean a small difference is expected.
  if [[ -s $WORK/oms_me.csv && -s $WORK/oms_cs.csv ]]; then
    echo
    echo "== final dte at t = $STOP_TIME s (OMSimulator result files)"
    dte_me=$(final_dte "$WORK/oms_me.csv") || dte_me=""
    dte_cs=$(final_dte "$WORK/oms_cs.csv") || dte_cs=""
    echo "    ME: ${dte_me:-<no dte column>}"
    echo "    CS: ${dte_cs:-<no dte column>}"
    if [[ -z $dte_me || -z $dte_cs ]]; then
      fail "could not read dte from the OMSimulator results"
    elif awk -v a="$dte_me" -v b="$dte_cs" -v tol="$DTE_RTOL" 'BEGIN {
           d = a - b; if (d < 0) d = -d
           m = (a < 0 ? -a : a); if ((b < 0 ? -b : b) > m) m = (b < 0 ? -b : b)
           r = (m > 0 ? d / m : 0)
           printf "    relative difference: %.3g (tolerance %g)\n", r, tol
           exit !(r <= tol) }'; then
      echo "ok: ME and CS agree"
    else
      fail "ME and CS final dte differ by more than $DTE_RTOL (relative)"
    fi
  fi
fi

echo
if (( failures )); then
  echo "external checks: $failures failure(s)"
  exit 1
fi
echo "external checks: all passed"
