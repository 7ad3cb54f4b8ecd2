#!/usr/bin/env bash
# Creates .venv (once) and installs the pinned Python tooling into it; prints the venv's python.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv >&2
fi
stamp=.venv/.requirements.stamp
if [ ! -f "$stamp" ] || ! cmp -s requirements.txt "$stamp"; then
  .venv/bin/python -m pip install --quiet --upgrade pip >&2
  .venv/bin/python -m pip install --quiet -r requirements.txt >&2
  cp requirements.txt "$stamp"
fi
echo "$PWD/.venv/bin/python"
