"""The Windows binaries of the packaged FMUs (issue 25), tested on Linux (tools/windows.sh):

1. every FMU carries binaries/win64/<id>.dll (FMI 2.0) or binaries/x86_64-windows/<id>.dll
   (FMI 3.0) beside its Linux .so, and the DLL is the same file in both SpurGearMesh FMUs;
2. each DLL imports only Windows system DLLs (its PE import table, read with objdump) and
   exports every function of the standard's fmi2Functions.h (and fmi3Functions.h where the FMU
   has an FMI 3.0 version);
3. tests/windows/fmi_master.c, compiled with MinGW and run under wine, loads each DLL with
   LoadLibrary; the same source compiled with gcc loads the Linux .so natively. Co-Simulation
   runs of the scenes, Model Exchange with fixed-step RK4, FMU states (and blobs carried between
   the two binaries), two instances in two threads and the bad-input cases. The scenes run on
   the DLL twice, with the x87 control word of MinGW's main thread (64-bit precision) and with
   Windows' default (53-bit, FMI_MASTER_X87=53): MinGW's exp/pow/log/sin/cos/atan2 in the DLL
   run on the x87 unit. The CSVs of the DLL
   must match the .so's within the bound explained in docs/platforms.md ("How close Windows is to Linux, and why"): at most
   twice the solution's own error, estimated per scene as the .so's deviation from a run at a
   100 times tighter rel_tol (floor: 1e-9 of the variable's largest magnitude), and never more
   than the scene's compare tolerance against the independent reference.

Usage: python tests/windows/wine_tests.py <fmu dir> <work dir> <master_linux> <master.exe> <stub dir>
Prints a table of the measured differences; exits 1 on any failure.
"""

import csv
import os
import re
import shutil
import subprocess
import sys
import threading
import time
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from scene_file import load_scene, scene_text, variables  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
OBJDUMP = "x86_64-w64-mingw32-objdump"

# The Windows system DLLs the DLLs import (Rust std's own imports; msvcrt is the C runtime every
# Windows since XP ships, api-ms-win-core-synch-l1-2-0 the API set of WaitOnAddress, Windows 8
# and later, bcryptprimitives' ProcessPrng Windows 10 and later). No libgcc_s, libwinpthread or
# libstdc++ DLL: MinGW's runtime is linked statically. Anything else fails.
ALLOWED_IMPORTS = {
    "kernel32.dll", "msvcrt.dll", "ntdll.dll", "bcryptprimitives.dll", "userenv.dll",
    "ws2_32.dll", "api-ms-win-core-synch-l1-2-0.dll",
}

# (FMU file, model identifier, FMI 2.0 folder or FMI 3.0 folder)
FMUS = [
    ("SpurGearMesh.fmu", "SpurGearMesh", 2),
    ("SpurGearMesh-fmi3.fmu", "SpurGearMesh", 3),
    ("SpurGearTrain.fmu", "SpurGearTrain", 2),
    ("SpurGearTrain-fmi3.fmu", "SpurGearTrain", 3),
    ("SpeedController.fmu", "SpeedController", 2),
    ("TorsionalShaft.fmu", "TorsionalShaft", 2),
    ("EngineTorque.fmu", "EngineTorque", 2),
    # A gearbox FMU (package-train --gearbox): SpurGearTrain's binary under the gearbox's name.
    ("PlanetarySimple.fmu", "PlanetarySimple", 2),
    ("PlanetarySimple-fmi3.fmu", "PlanetarySimple", 3),
]
FOLDERS = {2: ("linux64", "win64"), 3: ("x86_64-linux", "x86_64-windows")}

# The single mesh's scenes run in Co-Simulation on both binaries.
SCENES = ["damped", "friction", "high-speed", "reversal", "rigid-reversal-bounce", "runout-pitch", "stiff"]

failures = []


def fail(msg):
    print("FAIL:", msg, flush=True)
    failures.append(msg)


def fmpy_headers():
    import fmpy
    return Path(fmpy.__file__).parent / "c-code"


def standard_functions(version):
    text = (fmpy_headers() / f"fmi{version}Functions.h").read_text()
    return sorted(set(re.findall(rf"FMI{version}_Export\s+\w+TYPE\s+(fmi{version}\w+)\s*;", text)))


def pe_tables(dll):
    """(imported DLL names, exported function names) of a PE file."""
    out = subprocess.run([OBJDUMP, "-p", str(dll)], check=True, capture_output=True, text=True).stdout
    imports = set(re.findall(r"DLL Name: (\S+)", out))
    m = re.search(r"\[Ordinal/Name Pointer\] Table\n(.*?)(?:\n\n|\Z)", out, re.S)
    exports = set(re.findall(r"\]\s+(\w+)\s*$", m.group(1), re.M)) if m else set()
    return imports, exports


def check_packages(fmu_dir, work):
    """Points 1 and 2: layout, imports, exports. Returns {model id: (so, dll, md xml)}."""
    binaries = {}
    for fmu, mid, version in FMUS:
        path = fmu_dir / fmu
        if not path.exists():
            fail(f"{fmu} was not built")
            continue
        z = zipfile.ZipFile(path)
        names = set(z.namelist())
        lin, win = FOLDERS[version]
        so, dll = f"binaries/{lin}/{mid}.so", f"binaries/{win}/{mid}.dll"
        for n in (so, dll, "modelDescription.xml"):
            if n not in names:
                fail(f"{fmu}: no {n}")
        if dll not in names:
            continue
        md = z.read("modelDescription.xml").decode()
        if f'modelIdentifier="{mid}"' not in md:
            fail(f"{fmu}: modelIdentifier is not {mid}")
        out = work / fmu.replace(".fmu", "")
        z.extractall(out)
        imports, exports = pe_tables(out / dll)
        bad = sorted(i for i in imports if i.lower() not in ALLOWED_IMPORTS)
        if bad:
            fail(f"{fmu}: {dll} imports non-system DLLs {bad}")
        missing = sorted(set(standard_functions(version)) - exports)
        if missing:
            fail(f"{fmu}: {dll} does not export {missing}")
        print(f"{fmu}: {dll} ({(out / dll).stat().st_size // 1024} KiB) imports {sorted(imports)}; "
              f"exports all {len(standard_functions(version))} fmi{version} functions", flush=True)
        if version == 2:
            binaries[mid] = (out / so, out / dll, md)
    # The FMI 2.0 and 3.0 FMUs carry the same DLL.
    for mid in ("SpurGearMesh", "SpurGearTrain"):
        a = work / f"{mid}" / f"binaries/win64/{mid}.dll"
        b = work / f"{mid}-fmi3" / f"binaries/x86_64-windows/{mid}.dll"
        if a.exists() and b.exists() and a.read_bytes() != b.read_bytes():
            fail(f"{mid}: the FMI 2.0 and 3.0 FMUs carry different DLLs")
    # A gearbox FMU carries SpurGearTrain's DLL, byte for byte.
    a = work / "SpurGearTrain" / "binaries/win64/SpurGearTrain.dll"
    b = work / "PlanetarySimple" / "binaries/win64/PlanetarySimple.dll"
    if a.exists() and b.exists() and a.read_bytes() != b.read_bytes():
        fail("PlanetarySimple.fmu: its DLL is not SpurGearTrain's")
    return binaries


class Runner:
    def __init__(self, work, master_linux, master_exe, stub_dir):
        self.work = work
        self.linux = master_linux
        self.wine_dir = work / "wine-run"
        self.wine_dir.mkdir(exist_ok=True)
        shutil.copy(master_exe, self.wine_dir / "fmi_master.exe")
        for f in Path(stub_dir).glob("*.dll"):
            shutil.copy(f, self.wine_dir / f.name)
        self.times = {"linux": 0.0, "wine": 0.0}
        self.lock = threading.Lock()

    def run(self, platform, lib, guid, *args, check=True, x87=None, resources=None):
        """Runs the master; file arguments are plain names in the work directory. x87="53": the
        master sets the x87 control word of Windows' threads and MSVC programs (0x27f).
        resources: the FMU's resources directory, passed to fmi2Instantiate as a file URI (under
        wine through drive Z:, which maps /)."""
        t0 = time.time()
        env = dict(os.environ)
        if x87:
            env["FMI_MASTER_X87"] = x87
        if resources:
            uri = Path(resources).resolve().as_uri()
            env["FMI_MASTER_RESOURCES"] = uri if platform == "linux" else uri.replace("file:///", "file:///Z:/", 1)
        if platform == "linux":
            cmd = [str(self.linux), str(lib), guid, *args]
            cwd = self.work
        else:
            name = Path(lib).name
            with self.lock:
                if not (self.wine_dir / name).exists():
                    shutil.copy(lib, self.wine_dir / name)
            cmd = ["wine", "fmi_master.exe", name, guid, *args]
            cwd = self.wine_dir
        res = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=1800, env=env)
        self.times[platform] += time.time() - t0
        if check and res.returncode != 0:
            fail(f"{platform} {' '.join(args)}: exit {res.returncode}\n{res.stderr[-3000:]}")
        return res

    def path(self, platform, name):
        return (self.work if platform == "linux" else self.wine_dir) / name

    def write(self, name, text):
        for d in (self.work, self.wine_dir):
            (d / name).write_text(text)


def read_csv(path):
    with open(path) as fh:
        rows = list(csv.reader(fh))
    head = rows[0]
    cols = list(zip(*[[float(x) for x in r] for r in rows[1:]]))
    return head, cols


def diff(a, b):
    """Per column: (max |a - b|, largest magnitude of a); the time columns must agree exactly."""
    ha, ca = read_csv(a)
    hb, cb = read_csv(b)
    assert ha == hb, (ha, hb)
    if len(ca[0]) != len(cb[0]):
        return None
    out = {}
    for name, x, y in zip(ha, ca, cb):
        out[name] = (max(abs(p - q) for p, q in zip(x, y)), max(abs(p) for p in x))
    return out


def scene_tests(r, so, dll, md, guid):
    rows_out = []
    jobs = []
    for name in SCENES:
        scene, rows = load_scene(ROOT / "scenes" / f"{name}.toml")
        r.write(f"{name}.txt", scene_text(md, scene, rows))
        rel_tol = scene.get("start_values", {}).get("rel_tol", 1e-6)
        tight = {"rel_tol": rel_tol / 100}
        r.write(f"{name}-tight.txt", scene_text(md, scene, rows, start=tight))
        jobs.append((name, scene, rel_tol))

    def one(job):
        name, _, _ = job
        r.run("linux", so, guid, "cs", f"{name}.txt", f"{name}-linux.csv")
        r.run("linux", so, guid, "cs", f"{name}-tight.txt", f"{name}-tight.csv")
        r.run("wine", dll, guid, "cs", f"{name}.txt", f"{name}-windows.csv")
        r.run("wine", dll, guid, "cs", f"{name}.txt", f"{name}-windows53.csv", x87="53")

    with ThreadPoolExecutor(2) as pool:
        list(pool.map(one, jobs))
    for name, scene, rel_tol in jobs:
        tol = scene.get("compare", {}).get("tolerance", {})
        lin, win, win53, tgt = (r.path(p, f"{name}-{s}.csv") for p, s in
                                (("linux", "linux"), ("wine", "windows"), ("wine", "windows53"),
                                 ("linux", "tight")))
        if not all(p.exists() for p in (lin, win, win53, tgt)):
            fail(f"{name}: a run did not write its CSV")
            continue
        d, d53, e = diff(lin, win), diff(lin, win53), diff(lin, tgt)
        if d is None or d53 is None or e is None:
            fail(f"{name}: the runs have different lengths")
            continue
        for var in list(d)[1:]:
            scale = d[var][1]
            emax = e[var][0]
            bound = max(2 * emax, 1e-9 * scale)
            hard = tol.get(var)
            for x87, dd in (("64", d), ("53", d53)):
                dmax = dd[var][0]
                ok = dmax <= bound and (hard is None or dmax <= hard)
                if not ok:
                    fail(f"{name}: {var} differs by {dmax:.3g} with x87 precision {x87} "
                         f"(bound {bound:.3g}, scene tolerance {hard})")
            rows_out.append((name, rel_tol, var, d[var][0], d53[var][0], scale, emax, bound, hard))
    print(f"\n{'scene':22} {'rel_tol':>7} {'var':10} {'|win-lin|':>10} {'x87 53':>10} {'/scale':>8} "
          f"{'own error':>10} {'bound':>9} {'scene tol':>9}")
    for name, rt, var, dm, dm53, scale, emax, bound, hard in rows_out:
        worst = max(dm, dm53)
        print(f"{name:22} {rt:7.0e} {var:10} {dm:10.3g} {dm53:10.3g} {worst / scale if scale else 0:8.2g} "
              f"{emax:10.3g} {bound:9.3g} {hard if hard is not None else '-':>9} "
              f"{'' if worst <= bound and (hard is None or worst <= hard) else 'FAIL'}")
    print("\nper scene: largest |win - lin| / own error (x87 64-bit, 53-bit); largest / magnitude")
    for name in dict.fromkeys(row[0] for row in rows_out):
        rs = [row for row in rows_out if row[0] == name]
        q = [max((row[c] / row[6] if row[6] else 0.0) for row in rs) for c in (3, 4)]
        m = max(max(row[3], row[4]) / row[5] if row[5] else 0.0 for row in rs)
        print(f"  {name:22} {q[0]:9.2g} {q[1]:9.2g} {m:9.2g}")
    for col, label in ((3, "x87 64-bit (MinGW master's main thread)"), (4, "x87 53-bit (Windows' default)")):
        same = sorted({row[0] for row in rows_out} - {row[0] for row in rows_out if row[col] != 0})
        print(f"bit-identical to the Linux binary, {label}: {same or 'none'}")
    print(flush=True)


def me_states_threads_errors(r, so, dll, md, guid):
    scene, _ = load_scene(ROOT / "scenes" / "damped.toml")
    # Model Exchange: 20 ms of the damped paper scene with RK4 at 1e-6 s (stable: below
    # 2.8/omega of the mesh vibration; docs/interface.md says explicit steps near 1e-6 s).
    r.write("me.txt", scene_text(md, scene, stop_time=0.02, me_step=1e-6))
    r.write("states.txt", scene_text(md, scene, stop_time=0.02))
    r.write("threads.txt", scene_text(md, scene, stop_time=0.05))

    def linux_side():
        r.run("linux", so, guid, "me", "me.txt", "me-linux.csv")
        r.run("linux", so, guid, "states", "states.txt", "linux.blob")
        r.run("linux", so, guid, "threads", "threads.txt")
        r.run("linux", so, guid, "errors")

    def wine_side():
        r.run("wine", dll, guid, "me", "me.txt", "me-windows.csv")
        r.run("wine", dll, guid, "me", "me.txt", "me-windows53.csv", x87="53")
        r.run("wine", dll, guid, "states", "states.txt", "windows.blob")
        res = r.run("wine", dll, guid, "threads", "threads.txt")
        print("wine:", res.stderr.strip().splitlines()[0] if res.stderr.strip() else "", flush=True)
        res = r.run("wine", dll, guid, "errors")
        print("wine:", res.stderr.strip().splitlines()[0] if res.stderr.strip() else "", flush=True)

    with ThreadPoolExecutor(2) as pool:
        for fut in [pool.submit(linux_side), pool.submit(wine_side)]:
            fut.result()
    for csv_name, label in (("me-windows.csv", "x87 64-bit"), ("me-windows53.csv", "x87 53-bit")):
        d = diff(r.path("linux", "me-linux.csv"), r.path("wine", csv_name))
        if d is None:
            fail(f"Model Exchange ({label}): different lengths")
            continue
        worst = max((dm / sc if sc else 0.0) for dm, sc in list(d.values())[1:])
        print(f"Model Exchange (RK4, 1e-6 s, 20 ms; {label}): max |win - lin| / magnitude = {worst:.3g}: "
              + ", ".join(f"{k} {v[0]:.3g}" for k, v in list(d.items())[1:]), flush=True)
        if worst > 1e-9:
            fail(f"Model Exchange ({label}): the DLL's trajectory differs by {worst:.3g} of the magnitude")
    # Blobs across the binaries: the Linux state continued by the DLL and the other way round.
    shutil.copy(r.path("linux", "linux.blob"), r.path("wine", "linux.blob"))
    shutil.copy(r.path("wine", "windows.blob"), r.path("linux", "windows.blob"))
    r.run("linux", so, guid, "blob", "states.txt", "linux.blob", "blob-ll.csv")
    r.run("wine", dll, guid, "blob", "states.txt", "linux.blob", "blob-lw.csv")
    r.run("linux", so, guid, "blob", "states.txt", "windows.blob", "blob-wl.csv")
    for a, b, what in [(r.path("linux", "blob-ll.csv"), r.path("wine", "blob-lw.csv"),
                        "the Linux state continued by the DLL"),
                       (r.path("linux", "blob-ll.csv"), r.path("linux", "blob-wl.csv"),
                        "the DLL's state continued by the .so")]:
        d = diff(a, b)
        if d is None:
            fail(f"{what}: different lengths")
            continue
        worst = max((dm / sc if sc else 0.0) for dm, sc in list(d.values())[1:])
        print(f"FMU state blob, {what}: max difference / magnitude {worst:.3g}", flush=True)
        if worst > 1e-9:
            fail(f"{what}: differs by {worst:.3g}")


def other_fmus(r, binaries, work):
    """The train, a gearbox FMU (its file read from its resources), the controller, the shaft and
    the engine: a default run on both binaries."""
    cases = {
        "SpurGearTrain": (dict(stop_time=0.02, output_interval=1e-4),
                          ["mesh[1].dte", "mesh[2].dte", "body[4].w", "shaft[1].tau"], {}),
        "PlanetarySimple": (dict(stop_time=0.02, output_interval=1e-4), None, {}),
        "TorsionalShaft": (dict(stop_time=0.01, output_interval=1e-3), ["tau_a", "tau_b"],
                           {"theta_a": 0.01, "w_a": 2.0, "theta_b": -0.002, "w_b": 1.0}),
        "SpeedController": (dict(stop_time=0.05, output_interval=1e-3), None, {}),
        "EngineTorque": (dict(stop_time=0.01, output_interval=1e-3), ["tau"], {"theta": 0.3}),
    }
    for mid, (times, outputs, starts) in cases.items():
        if mid not in binaries:
            continue
        so, dll, md = binaries[mid]
        guid = re.search(r'guid="([^"]+)"', md).group(1)
        if outputs is None:  # every Real output
            types, _, _ = variables(md)
            outputs = [n for n in re.findall(r'name="([^"]+)"[^>]*causality="output"', md)
                       if types[n][1] == "Real"]
        r.write(f"{mid}.txt", scene_text(md, {}, outputs=outputs, start=starts, **times))
        # check_packages unpacked each FMU into the work directory: a gearbox FMU's file is there.
        resources = work / mid / "resources"
        resources = resources if resources.is_dir() else None
        r.run("linux", so, guid, "cs", f"{mid}.txt", f"{mid}-linux.csv", resources=resources)
        r.run("wine", dll, guid, "cs", f"{mid}.txt", f"{mid}-windows.csv", resources=resources)
        d = diff(r.path("linux", f"{mid}-linux.csv"), r.path("wine", f"{mid}-windows.csv"))
        if d is None:
            fail(f"{mid}: different lengths")
            continue
        worst = max((dm / sc if sc else 0.0) for dm, sc in list(d.values())[1:])
        print(f"{mid}: DLL under wine against the .so, {len(outputs)} outputs: max difference / magnitude "
              f"{worst:.3g}", flush=True)
        if worst > 1e-9:
            fail(f"{mid}: the DLL differs by {worst:.3g} of the magnitude")


def main():
    fmu_dir, work, master_linux, master_exe, stub_dir = (Path(a).resolve() for a in sys.argv[1:6])
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    binaries = check_packages(fmu_dir, work)
    r = Runner(work, master_linux, master_exe, stub_dir)
    if "SpurGearMesh" in binaries:
        so, dll, md = binaries["SpurGearMesh"]
        guid = re.search(r'guid="([^"]+)"', md).group(1)
        # The master's value references for the bad-input cases (tests/windows/fmi_master.c).
        want = {"geometry": 1, "zA": 4, "zB": 5, "J_A": 18, "chi": 21, "solver": 30, "tau_A": 40,
                "w_A": 52, "dte": 54, "s_b": 85, "pitch_errors_A": 119, "pitch_errors_B": 120,
                "w_A_start": 27, "w_B_start": 28}
        got = {k: int(m.group(1)) for k in want
               if (m := re.search(rf'name="{re.escape(k)}" valueReference="(\d+)"', md))}
        if got != want:
            fail(f"tests/windows/fmi_master.c: value references changed: {want} vs {got}")
        scene_tests(r, so, dll, md, guid)
        me_states_threads_errors(r, so, dll, md, guid)
    other_fmus(r, binaries, work)
    print(f"\nwine_tests: {time.time() - t0:.0f} s (master run times: Linux {r.times['linux']:.0f} s, "
          f"wine {r.times['wine']:.0f} s), {len(failures)} failures", flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
