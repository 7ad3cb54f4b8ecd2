#!/usr/bin/env bash
# Issue 5, memory: runs a full simulation through the C API of the packaged FMU's binary under
# valgrind (memcheck) and fails on any memory error or any definite or indirect leak.
# The program is tests/c/fmi_memcheck.c, compiled against the standard's headers (FMPy's copy in
# .venv) and loading binaries/linux64/SpurGearMesh.so from the .fmu with dlopen.
#
# Usage: bash tools/reliability.sh [steps]      (default 20000 communication steps of 1e-4 s; ~20 s)
# SpurGearTrain then runs steps/4 steps of two instances (tests/c/train_memcheck.c) the same way,
# with a planetary set, then again with a 4-planet set whose every member is lateral,
# and a gearbox FMU (package-train --gearbox) steps/4 steps, its missing and damaged gearbox file
# refused (tests/c/gearbox_memcheck.c).
# Called by tools/test-all.sh after packaging. Needs gcc and valgrind (installed with apt-get
# if missing and possible).
set -euo pipefail
cd "$(dirname "$0")/.."
steps=${1:-20000}

py=$(bash tools/venv.sh)
echo "== package the FMU"
fmu=$(cargo run -q -p fmu-packaging --release | tail -n 1)
[ -f "$fmu" ] || { echo "reliability.sh: the packager printed '$fmu'" >&2; exit 1; }

if ! command -v valgrind >/dev/null || ! command -v gcc >/dev/null; then
  if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
    echo "== installing valgrind and gcc"
    apt-get update -qq && apt-get install -y -qq valgrind gcc >/dev/null
  else
    echo "reliability.sh: valgrind and gcc are needed (apt-get install valgrind gcc)" >&2
    exit 1
  fi
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# GUID and value references from the packaged modelDescription.xml; the program's value
# references must be the table's (tests/c/fmi_memcheck.c, enum at the top).
guid=$("$py" - "$fmu" "$work" <<'EOF'
import sys, zipfile, xml.etree.ElementTree as ET
fmu, work = sys.argv[1], sys.argv[2]
z = zipfile.ZipFile(fmu)
z.extract("binaries/linux64/SpurGearMesh.so", work)
md = ET.fromstring(z.read("modelDescription.xml"))
vr = {v.get("name"): int(v.get("valueReference")) for v in md.iter("ScalarVariable")}
expected = dict(chi=21, c_load=24, w_A_start=27, w_B_start=28, tau_A=40, w_A=52, w_B=53, dte=54,
                s_f1=66, s_f2=67, s_b1=68, s_b2=69, s_b=85, base_pitch=89,
                geometry=1, zA=4, zB=5, module=8, xB=11, width=13, J_A=18, J_B=19,
                backlash=20, mu=22, internal=48)
wrong = {k: (v, vr.get(k)) for k, v in expected.items() if vr.get(k) != v}
if wrong:
    sys.exit(f"tests/c/fmi_memcheck.c: value references changed (expected, actual): {wrong}")
print(md.get("guid"))
EOF
)
inc=$("$py" -c 'import fmpy, os; print(os.path.join(os.path.dirname(fmpy.__file__), "c-code"))')
so="$work/binaries/linux64/SpurGearMesh.so"

echo "== compile tests/c/fmi_memcheck.c"
gcc -std=c99 -g -O1 -Wall -Wextra -Werror -I"$inc" tests/c/fmi_memcheck.c -ldl -lm -o "$work/fmi_memcheck"

echo "== $steps steps natively"
"$work/fmi_memcheck" "$so" "$guid" "$steps"

echo "== $steps steps under valgrind (memcheck)"
valgrind --quiet --error-exitcode=1 --leak-check=full --show-leak-kinds=definite,indirect \
  --errors-for-leak-kinds=definite,indirect --track-origins=yes \
  "$work/fmi_memcheck" "$so" "$guid" "$steps"
echo "== valgrind: no memory errors, no definite or indirect leaks"

echo "== SpurGearTrain: package, compile tests/c/train_memcheck.c"
train=$(cargo run -q -p fmu-packaging --release --bin package-train | tail -n 1)
[ -f "$train" ] || { echo "reliability.sh: package-train printed '$train'" >&2; exit 1; }
args=$("$py" - "$train" "$work" <<'EOF'
import math, sys, tomllib, zipfile, xml.etree.ElementTree as ET
fmu, work = sys.argv[1], sys.argv[2]
z = zipfile.ZipFile(fmu)
z.extract("binaries/linux64/SpurGearTrain.so", work)
md = ET.fromstring(z.read("modelDescription.xml"))
vr = {v.get("name"): v.get("valueReference") for v in md.iter("ScalarVariable")}
kind = {v.get("name"): next(iter(v)).tag[0] for v in md.iter("ScalarVariable")}
sys.path.insert(0, "tools")
from bench_hil_lateral import scenes  # noqa: E402


def planetary(scene, name):
    """A set's start values for the C program (R|I|B vr value), and the last planet moved a
    third of a tooth of the sun along its orbit (refused: off the assembly condition)."""
    with open(f"{work}/{name}.txt", "w") as f:
        for key, x in scene.items():
            f.write(f"{kind[key]} {vr[key]} {float(x)!r}\n")
    last = max(k for k in scene if k.endswith(".orbit_angle"))
    skew = scene[last] + 2 * math.pi / scene["mesh[1].zA"] / 3
    return [f"{work}/{name}.txt", vr["mesh[2].dte"], vr[last], repr(skew)]


simple = tomllib.load(open("scenes/train/planetary-simple.toml", "rb"))["start_values"]
# Every member of a 4-planet set lateral (21 coordinates: the full state), sun at 1104 rad/s.
lateral = scenes(False)["lateral (21 DOF)"]
print(md.get("guid"), vr["mesh[1].dte"], vr["body[4].tau"], vr["n_bodies"],
      *planetary(simple, "planetary"), *planetary(lateral, "lateral"))
EOF
)
gcc -std=c99 -g -O1 -Wall -Wextra -Werror -I"$inc" tests/c/train_memcheck.c -ldl -lm -o "$work/train_memcheck"
# shellcheck disable=SC2086
set -- $args
tso="$work/binaries/linux64/SpurGearTrain.so"
tsteps=$((steps / 4))
echo "== SpurGearTrain: $tsteps steps natively"
for set in "$5 $6 $7 $8" "$9 ${10} ${11} ${12}"; do
  # shellcheck disable=SC2086
  "$work/train_memcheck" "$tso" "$1" "$tsteps" "$2" "$3" "$4" $set
done
for set in "$5 $6 $7 $8" "$9 ${10} ${11} ${12}"; do
  echo "== SpurGearTrain: $tsteps steps under valgrind (memcheck), the set of ${set%% *}"
  # shellcheck disable=SC2086
  valgrind --quiet --error-exitcode=1 --leak-check=full --show-leak-kinds=definite,indirect \
    --errors-for-leak-kinds=definite,indirect --track-origins=yes \
    "$work/train_memcheck" "$tso" "$1" "$tsteps" "$2" "$3" "$4" $set
done
echo "== valgrind (SpurGearTrain): no memory errors, no definite or indirect leaks"

echo "== a gearbox FMU: package scenes/gearbox/planetary-simple.toml, compile tests/c/gearbox_memcheck.c"
gb=$(FMU_OUT_DIR="$work/fmu" cargo run -q -p fmu-packaging --release --bin package-train -- \
  --gearbox scenes/gearbox/planetary-simple.toml | tail -n 1)
[ -f "$gb" ] || { echo "reliability.sh: package-train --gearbox printed '$gb'" >&2; exit 1; }
mkdir -p "$work/gb" "$work/missing" "$work/damaged"
args=$("$py" - "$gb" "$work" <<'EOF'
import sys, zipfile, xml.etree.ElementTree as ET
fmu, work = sys.argv[1], sys.argv[2]
z = zipfile.ZipFile(fmu)
z.extractall(f"{work}/gb")
md = ET.fromstring(z.read("modelDescription.xml"))
vr = {v.get("name"): v.get("valueReference") for v in md.iter("ScalarVariable")}
text = z.read("resources/gearbox.toml").decode()
assert "J = 0.002" in text
open(f"{work}/damaged/gearbox.toml", "w").write(text.replace("J = 0.002", "J = -0.002"))
print(md.get("guid"), md.find("CoSimulation").get("modelIdentifier"), vr["set.sun.w"], vr["set.planet1.E"])
EOF
)
# shellcheck disable=SC2086
set -- $args
gcc -std=c99 -g -O1 -Wall -Wextra -Werror -I"$inc" tests/c/gearbox_memcheck.c -ldl -lm -o "$work/gearbox_memcheck"
gargs=("$work/gb/binaries/linux64/$2.so" "$1" "$tsteps" "file://$work/gb/resources"
  "file://$work/missing" "file://$work/damaged" "$3" "$4")
echo "== the gearbox FMU: $tsteps steps natively"
"$work/gearbox_memcheck" "${gargs[@]}"
echo "== the gearbox FMU: $tsteps steps under valgrind (memcheck), missing and damaged files included"
valgrind --quiet --error-exitcode=1 --leak-check=full --show-leak-kinds=definite,indirect \
  --errors-for-leak-kinds=definite,indirect --track-origins=yes "$work/gearbox_memcheck" "${gargs[@]}"
echo "== valgrind (gearbox FMU): no memory errors, no definite or indirect leaks"
