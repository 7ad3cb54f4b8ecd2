#!/usr/bin/env bash
# Generates the C prototypes of the FMU's exported fmi2* functions from the source with cbindgen
# (config: tools/cbindgen.toml) and writes them to the given file. Installs the pinned cbindgen
# with `cargo install --locked` when it is missing (once, ~3-4 min).
# Usage: bash tools/exports-header.sh <out.h>       (tests/python/test_abi.py calls it)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: exports-header.sh <out.h>}
version=0.29.4
cbindgen=$(command -v cbindgen || echo "${CARGO_HOME:-$HOME/.cargo}/bin/cbindgen")
if ! "$cbindgen" --version 2>/dev/null | grep -qx "cbindgen $version"; then
  echo "installing cbindgen $version" >&2
  cargo install cbindgen --locked --version "$version" >&2
  cbindgen="${CARGO_HOME:-$HOME/.cargo}/bin/cbindgen"
fi
# The exports come from a macro (fmi2_slave::export_fmi2!), so cbindgen expands the crate
# (rustc -Zunpretty=expanded); RUSTC_BOOTSTRAP=1 lets the stable toolchain do that.
# Its "Can't find <alias>" warnings are expected: the aliases are renamed to the standard's
# types, whose definitions come from fmi2Functions.h.
RUSTC_BOOTSTRAP=1 "$cbindgen" --quiet --config tools/cbindgen.toml --crate spur_gear_mesh --output "$out"
