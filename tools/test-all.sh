#!/usr/bin/env bash
# Runs every test: Rust unit and integration tests, then the packaged FMU through FMPy (pytest).
# Usage: bash tools/test-all.sh        (the README's test command; .ci/run calls it)
set -euo pipefail
cd "$(dirname "$0")/.."
py=$(bash tools/venv.sh)
echo "== cargo test (release: the integration tests simulate real scenes)"
cargo test --workspace --release
echo "== the diffsol peer benchmark compiles (docs/integrators.md; its own workspace)"
cargo check -q --all-targets --manifest-path benches/diffsol-peer/Cargo.toml --target-dir target/diffsol-peer
echo "== the API documentation builds without warnings (units in brackets are not links)"
RUSTDOCFLAGS="-D warnings" cargo doc -q --workspace --no-deps
echo "== package the FMUs"
cargo run -q -p fmu-packaging --release
cargo run -q -p fmu-packaging --release --bin package-train
echo "== memcheck of the C API (valgrind)"
bash tools/reliability.sh
echo "== FMU tests through FMPy"
"$py" -m pytest -q tests/python
echo "== Windows binaries: cross build, every FMU packaged with both platforms, wine tests (tools/windows.sh)"
bash tools/windows.sh
