#!/usr/bin/env python3
"""Cost of the base scenes now against an earlier commit (issue 8: with every new feature off,
the base scenes must cost what they cost before, within noise).

    .venv/bin/python tools/cost_vs_rev.py REV [--rounds 15] [--scenes damped,paper-m2,...]
        [--old-binary PATH]     (REV's run_scene already built: skips the worktree build)
        [--train]               (the gear trains: scenes/train/*.toml through run_train_scene,
                                 CPU time of the FMU's Slave, the setup included)

Builds REV's examples/run_scene in a git worktree (target/cost-vs-rev/, its own target dir), then
runs both binaries on every scene through the C API, alternating old and new in each round so
both meet the same machine state. Prints, per scene, the median wall time of each, the median of
the per-round ratios new/old, and their spread (min..max of the ratios), as a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def build(rev: str, example: str = "run_scene", package: str = "") -> Path:
    base = ROOT / "target" / "cost-vs-rev"
    tree = base / "tree"
    if tree.exists():
        subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, check=True)
    subprocess.run(["git", "worktree", "add", "--detach", str(tree), rev], cwd=ROOT, check=True,
                   stdout=subprocess.DEVNULL)
    env = {**__import__("os").environ, "CARGO_TARGET_DIR": str(base / "target")}
    pkg = ["-p", package] if package else []
    subprocess.run(["cargo", "build", "-q", "--release", *pkg, "--example", example], cwd=tree,
                   env=env, check=True)
    return base / "target" / "release" / "examples" / example


def wall(binary: Path, scene: Path) -> float:
    out = subprocess.run([str(binary), str(scene), "--api", "c", "--reps", "3"], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out.splitlines()[0])["wall_median_s"]


def train_cpu(binary: Path, scene: dict) -> float | None:
    """The median thread CPU time of 3 runs of a train scene (tools/work_precision.py's way of
    handing it to run_train_scene: the scene's start values, its input table)."""
    sys.path.insert(0, str(ROOT / "tools"))
    from work_precision_train import train_start_args  # noqa: E402
    cmd = [str(binary), "--stop-time", repr(float(scene["stop_time"])), "--output-interval",
           repr(float(scene["output_interval"])), "--reps", "3"] + train_start_args(scene)
    if "input_file" in scene:
        cmd += ["--input-file", str(ROOT / "scenes" / "train" / scene["input_file"])]
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if run.returncode != 0:
        return None
    return json.loads(run.stdout.strip().splitlines()[-1])["cpu_median_s"]


def table(names, rounds, heading, time_old, time_new) -> None:
    """The Markdown table: per scene, `rounds` alternating timings of old and new, their medians
    and the median and spread of the per-round ratios. A scene the old one cannot run (time
    None) gets a row saying so."""
    print(heading)
    print("| scene | old [ms] | new [ms] | new/old (median) | new/old (min..max) |")
    print("|---|---|---|---|---|")
    for n in names:
        if time_old(n) is None:
            print(f"| `{n}` | (fails at the old commit) | | | |", flush=True)
            continue
        o, w = [], []
        for _ in range(rounds):
            o.append(time_old(n))
            w.append(time_new(n))
        r = [x / y for x, y in zip(w, o)]
        print(f"| `{n}` | {1e3 * statistics.median(o):.3f} | {1e3 * statistics.median(w):.3f} | "
              f"{statistics.median(r):.3f} | {min(r):.2f}..{max(r):.2f} |", flush=True)


def main_train(a) -> int:
    import tomllib
    example, package = "run_train_scene", "spur_gear_train"
    subprocess.run(["cargo", "build", "-q", "--release", "-p", package, "--example", example],
                   cwd=ROOT, check=True)
    new = ROOT / "target" / "release" / "examples" / example
    old = Path(a.old_binary) if a.old_binary else build(a.rev, example, package)
    names = [s for s in a.scenes.split(",") if s] or sorted(
        p.stem for p in (ROOT / "scenes" / "train").glob("*.toml"))
    scene = {n: tomllib.loads((ROOT / "scenes" / "train" / f"{n}.toml").read_text())
             for n in names}
    table(names, a.rounds,
          f"new = working tree, old = {a.rev}; {a.rounds} rounds, each the median thread CPU "
          "time of 3 runs of the FMU's Slave (run_train_scene), old and new alternating",
          lambda n: train_cpu(old, scene[n]), lambda n: train_cpu(new, scene[n]))
    return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("rev")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--scenes", default="")
    ap.add_argument("--old-binary", default="")
    ap.add_argument("--train", action="store_true")
    a = ap.parse_args()
    if a.train:
        return main_train(a)
    subprocess.run(["cargo", "build", "-q", "--release", "--example", "run_scene"], cwd=ROOT,
                   check=True)
    new = ROOT / "target" / "release" / "examples" / "run_scene"
    old = Path(a.old_binary) if a.old_binary else build(a.rev)
    names = [s for s in a.scenes.split(",") if s] or sorted(
        p.stem for p in (ROOT / "scenes").glob("*.toml")
        if subprocess.run([str(old), str(p), "--reps", "1", "--stop-time", "1e-4"], cwd=ROOT,
                          capture_output=True).returncode == 0)
    table(names, a.rounds,
          f"new = working tree, old = {a.rev}; {a.rounds} rounds, each the median of 3 runs "
          "through the C API, old and new alternating",
          lambda n: wall(old, ROOT / "scenes" / f"{n}.toml"),
          lambda n: wall(new, ROOT / "scenes" / f"{n}.toml"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
