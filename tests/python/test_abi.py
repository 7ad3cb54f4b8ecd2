"""The binary's C interface against the FMI 2.0 and 3.0 standards' headers (the copies FMPy ships):

- the prototypes of our exports, generated from src/ by cbindgen (tools/exports-header.sh,
  tools/cbindgen.toml), compile together with fmi2Functions.h and fmi3Functions.h under
  gcc -Werror: C rejects a
  redeclaration with a different signature, so any mismatch fails the compilation;
- every function fmi2Functions.h declares is exported by binaries/linux64/SpurGearMesh.so, and
  every one fmi3Functions.h declares by the FMI 3.0 FMU's binaries/x86_64-linux/SpurGearMesh.so;
- the binary needs only the C runtime.
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

import fmpy
import pytest

from conftest import ROOT

C_CODE = Path(fmpy.__file__).parent / "c-code"


def standard_functions(version=2):
    """Names of the functions fmi<version>Functions.h declares (FMIx_Export <name>TYPE <name>;)."""
    text = (C_CODE / f"fmi{version}Functions.h").read_text()
    names = re.findall(rf"FMI{version}_Export\s+(fmi{version}\w+)TYPE\s+(fmi{version}\w+)\s*;", text)
    assert names and all(t == n for t, n in names)
    return sorted(n for _, n in names)


ALL_STANDARD = standard_functions(2) + standard_functions(3)


@pytest.fixture(scope="module")
def exports_header(tmp_path_factory):
    out = tmp_path_factory.mktemp("abi") / "spurgearmesh_exports.h"
    subprocess.run(
        ["bash", str(ROOT / "tools" / "exports-header.sh"), str(out)],
        cwd=ROOT,
        check=True,
        timeout=900,  # a first run installs cbindgen
    )
    return out.read_text()


def split_prototypes(header):
    """{function name: prototype text} of the generated header."""
    protos = {}
    for decl in header.split(";"):
        m = re.search(r"\b(fmi[23]\w+)\s*\(", decl)
        if m:
            protos[m.group(1)] = decl.strip()
    return protos


def test_generated_header_declares_every_standard_function(exports_header):
    protos = split_prototypes(exports_header)
    missing = sorted(set(ALL_STANDARD) - set(protos))
    assert not missing, f"exports without a prototype in src/: {missing}"


def test_exports_match_the_standard_prototypes(exports_header, tmp_path):
    (tmp_path / "exports.h").write_text(exports_header)
    src = tmp_path / "abi.c"
    src.write_text(
        "#include <stddef.h>\n"
        "#include <stdint.h>\n"
        '#include "fmi2Functions.h"\n'
        '#include "fmi3Functions.h"\n'
        '#include "exports.h"\n'
        '_Static_assert(sizeof(fmi2Type) == sizeof(int), "fmi2Type is int-sized");\n'
        '_Static_assert(sizeof(fmi2StatusKind) == sizeof(int), "fmi2StatusKind is int-sized");\n'
        '_Static_assert(sizeof(fmi2Status) == sizeof(int), "fmi2Status is int-sized (Rust repr(C) enum)");\n'
        '_Static_assert(sizeof(fmi3Status) == sizeof(int), "fmi3Status is int-sized (the same Rust enum)");\n'
        '_Static_assert(sizeof(fmi3DependencyKind) == sizeof(int), "fmi3DependencyKind is int-sized");\n'
        '_Static_assert(sizeof(fmi3IntervalQualifier) == sizeof(int), "fmi3IntervalQualifier is int-sized");\n'
        # Take every standard function's address through the standard's function type as well.
        + "".join(f"{n}TYPE *p_{n} = {n};\n" for n in ALL_STANDARD)
    )
    gcc = shutil.which("gcc")
    assert gcc, "gcc is needed"
    res = subprocess.run(
        [gcc, "-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c", "-o", os.devnull,
         "-I", str(C_CODE), "-I", str(tmp_path), str(src)],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr


def test_every_standard_function_is_exported(unzip_dir, fmu3_path, tmp_path):
    """Of FMI 2.0 by the FMI 2.0 FMU's binary, and of FMI 3.0 by the FMI 3.0 FMU's (the same)."""
    unzip3 = Path(fmpy.extract(str(fmu3_path), unzipdir=str(tmp_path / "fmu3")))
    for so, version in [(Path(unzip_dir) / "binaries" / "linux64" / "SpurGearMesh.so", 2),
                        (unzip3 / "binaries" / "x86_64-linux" / "SpurGearMesh.so", 3)]:
        out = subprocess.run(["nm", "-D", "--defined-only", str(so)], check=True,
                             capture_output=True, text=True).stdout
        exported = {line.split()[-1] for line in out.splitlines()
                    if line.split() and line.split()[-2] in "TtWi"}
        missing = sorted(set(standard_functions(version)) - exported)
        assert not missing, f"not exported: {missing}"


def test_binary_needs_only_the_c_runtime(unzip_dir):
    so = Path(unzip_dir) / "binaries" / "linux64" / "SpurGearMesh.so"
    out = subprocess.run(["readelf", "-d", str(so)], check=True, capture_output=True, text=True).stdout
    needed = set(re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", out))
    # libc, libm and libgcc_s (unwinding) as any Rust cdylib; ld-linux-x86-64.so.2 because
    # Rust's thread-locals in a shared object resolve through the dynamic loader's
    # __tls_get_addr (the global-dynamic TLS model).
    allowed = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "ld-linux-x86-64.so.2"}
    assert needed and needed <= allowed, f"unexpected dependencies: {sorted(needed - allowed)}"
    assert "libc.so.6" in needed
