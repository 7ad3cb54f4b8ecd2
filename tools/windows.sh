#!/usr/bin/env bash
# Windows binaries in every FMU (issue 25), built and tested on this Linux machine:
#   1. installs what it needs from Debian's archive when missing (as root): rustc-web, cargo-web
#      and rust-web-src (Rust 1.96 with the standard library's sources), the MinGW-w64 cross
#      gcc, wine;
#   2. cross-builds the five cdylibs (SpurGearMesh, SpurGearTrain, SpeedController,
#      TorsionalShaft, EngineTorque) for x86_64-pc-windows-gnu in one cargo invocation, with Debian's cargo and
#      rustc, std built from source with panic_unwind (-Zbuild-std, so RUSTC_BOOTSTRAP=1), into
#      target/windows (its own target directory: the shared target/ stays free);
#   3. packages every FMU with both platforms (FMU_WINDOWS_DIR, fmu-packaging/src/lib.rs):
#      binaries/win64/<id>.dll beside binaries/linux64/<id>.so (FMI 2.0) and
#      binaries/x86_64-windows/<id>.dll beside binaries/x86_64-linux/<id>.so (FMI 3.0);
#   4. tests them (tests/windows/wine_tests.py): each DLL's import table (system DLLs only) and
#      exports, then the C master tests/windows/fmi_master.c compiled with MinGW and run under
#      wine against the same master compiled with gcc on the Linux .so.
#
# Usage: bash tools/windows.sh            (build, package, test; prints the time of each part)
#        bash tools/windows.sh --no-test  (build and package only)
# Times on 2 busy cores: std and the five DLLs from scratch about 15 min, later builds reuse std;
# the wine tests about 3 min. tools/test-all.sh calls it after the Linux tests.
set -euo pipefail
cd "$(dirname "$0")/.."
test=1
[ "${1:-}" = "--no-test" ] && test=0
start=$SECONDS
phase() { echo "== [$((SECONDS - start)) s] $*"; }

# Debian's toolchain lives in /usr/bin; rustup's proxies (without the standard library's
# sources) usually come first in PATH, so Debian's cargo and rustc are named explicitly.
DEB_CARGO=/usr/bin/cargo
DEB_RUSTC=/usr/bin/rustc
RUST_SRC=/usr/lib/rustlib/src/rust/library
need=()
# The -web packages by name: bookworm's plain rustc/cargo (1.63) also live in /usr/bin and are
# too old for the pinned dependencies; rust-web-src matches rustc-web's version exactly.
for p in rustc-web cargo-web rust-web-src; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || need+=("$p")
done
[ -x "$DEB_CARGO" ] && [ -x "$DEB_RUSTC" ] && [ -d "$RUST_SRC/std" ] || need+=(rustc-web cargo-web rust-web-src)
command -v x86_64-w64-mingw32-gcc >/dev/null || need+=(gcc-mingw-w64-x86-64)
command -v x86_64-w64-mingw32-objdump >/dev/null || need+=(binutils-mingw-w64-x86-64)
command -v wine >/dev/null || need+=(wine wine64)
command -v gcc >/dev/null || need+=(gcc)
if [ ${#need[@]} -gt 0 ]; then
  if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    phase "installing ${need[*]} from Debian's archive"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      rustc-web cargo-web rust-web-src gcc-mingw-w64-x86-64 binutils-mingw-w64-x86-64 wine wine64 gcc \
      >/dev/null
  else
    echo "windows.sh: needs ${need[*]} (apt-get install as root)" >&2
    exit 1
  fi
fi
phase "toolchain: $("$DEB_RUSTC" --version), $("$DEB_CARGO" --version | cut -d' ' -f1-2), $(x86_64-w64-mingw32-gcc --version | head -n 1)"

packages=(-p spur_gear_mesh -p spur_gear_train -p speed_controller -p torsional_shaft -p engine_torque)
phase "cross build for x86_64-pc-windows-gnu, std from source (target/windows)"
RUSTC="$DEB_RUSTC" RUSTDOC=/usr/bin/rustdoc RUSTC_BOOTSTRAP=1 \
  CARGO_TARGET_X86_64_PC_WINDOWS_GNU_LINKER=x86_64-w64-mingw32-gcc \
  "$DEB_CARGO" build --locked --release --lib --target x86_64-pc-windows-gnu \
  -Zbuild-std=std,panic_unwind --target-dir target/windows "${packages[@]}"
dlls=target/windows/x86_64-pc-windows-gnu/release
ls -l "$dlls"/*.dll

# Packaged into target/windows/fmu first (others' Linux-only packaging may rewrite target/fmu
# meanwhile in a shared checkout), tested there, then copied to target/fmu.
phase "packaging every FMU with both platforms (target/windows/fmu)"
fmus=target/windows/fmu
rm -rf "$fmus"
export FMU_WINDOWS_DIR="$PWD/$dlls" FMU_OUT_DIR="$PWD/$fmus"
cargo run -q -p fmu-packaging --release >/dev/null
cargo run -q -p fmu-packaging --release --bin package-train >/dev/null
cargo run -q -p fmu-packaging --release --bin package-controller >/dev/null
cargo run -q -p fmu-packaging --release --bin package-shaft >/dev/null
cargo run -q -p fmu-packaging --release --bin package-engine >/dev/null
# A gearbox FMU: SpurGearTrain's DLL under the gearbox's name, with its file in resources/.
cargo run -q -p fmu-packaging --release --bin package-train -- --gearbox scenes/gearbox/planetary-simple.toml >/dev/null
unset FMU_WINDOWS_DIR FMU_OUT_DIR
publish() {
  mkdir -p target/fmu
  for f in "$fmus"/*.fmu; do
    cp "$f" "target/fmu/.$(basename "$f").$$" && mv "target/fmu/.$(basename "$f").$$" "target/fmu/$(basename "$f")"
  done
  phase "target/fmu: $(cd "$fmus" && echo *.fmu) with binaries for linux64/win64 (FMI 2.0), x86_64-linux/x86_64-windows (FMI 3.0)"
}
[ $test = 1 ] || { publish; phase "done (not tested)"; exit 0; }

py=$(bash tools/venv.sh)
inc=$("$py" -c 'import fmpy, os; print(os.path.join(os.path.dirname(fmpy.__file__), "c-code"))')
work=target/windows/test
rm -rf "$work"
mkdir -p "$work/stub"
phase "compiling the test master (gcc and MinGW) and the ProcessPrng stub"
gcc -std=c99 -O1 -Wall -Wextra -Werror -I"$inc" tests/windows/fmi_master.c -ldl -lm -lpthread \
  -o "$work/fmi_master"
x86_64-w64-mingw32-gcc -std=c99 -O1 -Wall -Wextra -Werror -I"$inc" tests/windows/fmi_master.c \
  -o "$work/fmi_master.exe"
x86_64-w64-mingw32-gcc -O2 -Wall -Wextra -Werror -shared -o "$work/stub/bcryptprimitives.dll" \
  tests/windows/processprng_stub.c tests/windows/processprng_stub.def -lbcrypt

# wine: its own prefix under target/windows, no desktop, no Mono or Gecko prompts; the stub
# bcryptprimitives.dll beside the master wins over wine's built-in one.
export WINEPREFIX="$PWD/target/windows/wineprefix"
export WINEDEBUG=-all
export WINEDLLOVERRIDES="mscoree,mshtml=;bcryptprimitives=n,b"
unset DISPLAY WAYLAND_DISPLAY
if [ ! -f "$WINEPREFIX/system.reg" ]; then
  phase "creating the wine prefix"
  wineboot -i >/dev/null 2>&1 || true
  wineserver -w || true
fi

phase "the wine tests (tests/windows/wine_tests.py)"
rc=0
"$py" tests/windows/wine_tests.py "$fmus" "$work" "$work/fmi_master" "$work/fmi_master.exe" "$work/stub" || rc=$?
wineserver -k 2>/dev/null || true
[ $rc = 0 ] && publish
phase "done (exit $rc)"
exit $rc
