"""The binary's C interface against the FMI 2.0 standard's headers (the copies FMPy ships):

- the prototypes of our exports, generated from src/ by cbindgen (tools/exports-header.sh,
  tools/cbindgen.toml), compile together with fmi2Functions.h under gcc -Werror: C rejects a
  redeclaration with a different signature, so any mismatch fails the compilation;
- every function fmi2Functions.h declares is exported by binaries/linux64/SpurGearMesh.so;
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
FMI2_FUNCTIONS_H = C_CODE / "fmi2Functions.h"

def standard_functions():
    """Names of the functions fmi2Functions.h declares (FMI2_Export <name>TYPE <name>;)."""
    text = FMI2_FUNCTIONS_H.read_text()
    names = re.findall(r"FMI2_Export\s+(fmi2\w+)TYPE\s+(fmi2\w+)\s*;", text)
    assert all(t == n for t, n in names)
    return sorted(n for _, n in names)


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
        m = re.search(r"\b(fmi2\w+)\s*\(", decl)
        if m:
            protos[m.group(1)] = decl.strip()
    return protos


def test_generated_header_declares_every_standard_function(exports_header):
    protos = split_prototypes(exports_header)
    missing = sorted(set(standard_functions()) - set(protos))
    assert not missing, f"exports without a prototype in src/: {missing}"


def test_exports_match_the_standard_prototypes(exports_header, tmp_path):
    (tmp_path / "exports.h").write_text(exports_header)
    src = tmp_path / "abi.c"
    src.write_text(
        "#include <stddef.h>\n"
        "#include <stdint.h>\n"
        '#include "fmi2Functions.h"\n'
        '#include "exports.h"\n'
        '_Static_assert(sizeof(fmi2Type) == sizeof(int), "fmi2Type is int-sized");\n'
        '_Static_assert(sizeof(fmi2StatusKind) == sizeof(int), "fmi2StatusKind is int-sized");\n'
        '_Static_assert(sizeof(fmi2Status) == sizeof(int), "fmi2Status is int-sized (Rust repr(C) enum)");\n'
        # Take every standard function's address through the standard's function type as well.
        + "".join(f"{n}TYPE *p_{n} = {n};\n" for n in standard_functions())
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


def test_every_standard_function_is_exported(unzip_dir):
    so = Path(unzip_dir) / "binaries" / "linux64" / "SpurGearMesh.so"
    out = subprocess.run(["nm", "-D", "--defined-only", str(so)], check=True, capture_output=True, text=True).stdout
    exported = {line.split()[-1] for line in out.splitlines() if line.split() and line.split()[-2] in "TtWi"}
    missing = sorted(set(standard_functions()) - exported)
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
