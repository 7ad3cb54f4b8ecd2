"""Builds target/cosim/speed-loop.ssp: cosim/SystemStructure.ssd with the two FMUs it names
(resources/SpurGearMesh.fmu and resources/SpeedController.fmu).

    python cosim/build_ssp.py              # packages both FMUs with cargo first
    python cosim/build_ssp.py --no-build   # uses target/fmu/*.fmu as they are

Prints the path of the .ssp. The FMUs are built from the working tree, so the .ssp is not
committed; only the .ssd and this script are.
"""

import argparse
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SSD = ROOT / "cosim" / "SystemStructure.ssd"
DEFAULT_OUT = ROOT / "target" / "cosim" / "speed-loop.ssp"


def _packaged(cmd):
    """Runs a packager that prints the .fmu path on its last line; returns that path."""
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
    path = Path(out.stdout.strip().splitlines()[-1])
    if not path.is_file():
        raise RuntimeError(f"{' '.join(cmd)} printed {out.stdout!r}, not an FMU path")
    return path


def build_gear_fmu():
    return _packaged(["cargo", "run", "-q", "-p", "fmu-packaging", "--release"])


def build_controller_fmu():
    return _packaged(
        ["cargo", "run", "-q", "--release", "-p", "fmu-packaging", "--bin", "package-controller"]
    )


def build_ssp(gear_fmu, controller_fmu, out=DEFAULT_OUT):
    """Zips the .ssd and the two FMUs into `out`; returns its path."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.write(SSD, "SystemStructure.ssd")
        # FMUs are zips already: store them.
        z.write(gear_fmu, "resources/SpurGearMesh.fmu", compress_type=zipfile.ZIP_STORED)
        z.write(controller_fmu, "resources/SpeedController.fmu", compress_type=zipfile.ZIP_STORED)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-build", action="store_true", help="use target/fmu/*.fmu without running cargo")
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="where to write the .ssp")
    args = ap.parse_args(argv)
    if args.no_build:
        gear = ROOT / "target" / "fmu" / "SpurGearMesh.fmu"
        controller = ROOT / "target" / "fmu" / "SpeedController.fmu"
    else:
        gear, controller = build_gear_fmu(), build_controller_fmu()
    print(build_ssp(gear, controller, args.out))


if __name__ == "__main__":
    sys.exit(main())
