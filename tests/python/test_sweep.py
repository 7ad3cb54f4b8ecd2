"""tools/sweep.py end to end on a Dask LocalCluster of 2 worker processes (issue 11).

A 3 x 2 grid over the damped paper scene (scenes/damped.toml): tau_A in {50, 100, 200} N.m and
backlash in {-1e-4, 1e-4} m, statistics from t = 0.05 s to the scene's stop time 0.1 s, run through
sweep.main with --scheduler pointing at the test's cluster. The negative backlash is invalid, so
half of the points must come back as rows with the FMU's error, and the other half as physics.

The physical checks and why they hold (T = 0.1 - 0.05 s, the statistics window):
- dte_min <= dte_mean <= dte_max and dte_rms >= |dte_mean|: a mean lies between the extremes,
  and by Cauchy-Schwarz the RMS bounds the mean's magnitude. Both hold exactly for the FMU's
  discrete versions too (positive Gauss weights; the extremes are sought over the Gauss nodes
  among other points), so only rounding of the sums is allowed: 1e-9 of the largest |dte|
  (~1e6 internal pieces times 1e-16).
- 0 <= t_separated, t_backward and t_separated + t_backward <= T: disjoint parts of the window
  (no flank carrying, the backward flank carrying); rounding of sums of times, 1e-12 s.
- F_max >= (tau_A - J_A (w_A(end) - w_A(stats_start)) / T) / rAb: with mu = 0 A's torque balance
  J_A dw_A/dt = tau_A - rAb (F_fwd - F_bwd) makes the right side the window's mean of
  F_fwd - F_bwd, and F_max, the peak of F_fwd + F_bwd, is at least that mean. The balance holds
  for the exact solution; the numerical speeds carry the integrator's error, bounded here by
  100 rel_tol |w_A| each (rel_tol = 1e-6, the FMU's default; 100x for the global error), which
  enters through the J_A / (T rAb) factor.
"""

import math
import sys
from pathlib import Path

import fmpy
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
import sweep as S  # noqa: E402

SCENE = ROOT / "scenes" / "damped.toml"
STATS_START = 0.05
STOP = 0.1
WINDOW = STOP - STATS_START
TAUS = (50.0, 100.0, 200.0)
BACKLASHES = (-1e-4, 1e-4)
REL_TOL = 1e-6


@pytest.fixture(scope="module")
def cluster():
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=40) as c:
        yield c


def sweep_args(fmu_path, cluster, out, taus=TAUS, stats_start=STATS_START):
    return [
        "--scene", str(SCENE),
        "--vary", "tau_A=" + ",".join(f"{t:g}" for t in taus),
        "--vary", "backlash=" + ",".join(f"{b:g}" for b in BACKLASHES),
        "--stats-start", str(stats_start),
        "--scheduler", cluster.scheduler_address,
        "--fmu", str(fmu_path),
        "--out", str(out),
        "--no-progress",
    ]


@pytest.fixture(scope="module")
def first_run(fmu_path, cluster, tmp_path_factory):
    """The grid, run once: (parquet path, table, plot path)."""
    d = tmp_path_factory.mktemp("sweep")
    out, png = d / "grid.parquet", d / "grid.png"
    assert S.main(sweep_args(fmu_path, cluster, out) + ["--plot", str(png)]) == 0
    return out, pd.read_parquet(out), png


@pytest.fixture(scope="module")
def rig(fmu_path):
    """rAb (a calculated parameter) and J_A of the scene, from the FMU."""
    md = {v.name: v for v in fmpy.read_model_description(str(fmu_path)).modelVariables}
    base, _ = S.load_scene(SCENE)
    r = fmpy.simulate_fmu(str(fmu_path), stop_time=1e-9, output_interval=1e-9, output=["rAb"],
                          start_values=base)
    assert float(base.get("mu", 0.0)) == 0.0, "the force bound assumes no friction"
    assert float(base.get("tau_B", 0.0)) == 0.0, "the force bound assumes no torque on B's side of A"
    return {"rAb": float(r["rAb"][0]), "J_A": float(base.get("J_A", float(md["J_A"].start)))}


def test_one_row_per_grid_point_with_the_statistics_columns(first_run):
    _, df, png = first_run
    assert len(df) == len(TAUS) * len(BACKLASHES)
    assert set(zip(df["tau_A"], df["backlash"])) == {(t, b) for t in TAUS for b in BACKLASHES}
    for col in S.STATS + ("wall_time", "status", "error"):
        assert col in df.columns, col
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_valid_points_give_physical_statistics(first_run, rig):
    _, df, _ = first_run
    ok = df[df["backlash"] > 0]
    assert (ok["status"] == "ok").all(), ok[["status", "error"]]
    for _, r in ok.iterrows():
        assert all(math.isfinite(r[c]) for c in S.STATS), r
        eps = 1e-9 * max(abs(r["dte_min"]), abs(r["dte_max"]))
        assert r["dte_min"] - eps <= r["dte_mean"] <= r["dte_max"] + eps
        assert r["dte_rms"] >= abs(r["dte_mean"]) - eps
        assert r["dte_max"] > 0.0  # the drive is carried, so the forward flank is pressed
        for t in ("t_separated", "t_backward"):
            assert 0.0 <= r[t] <= WINDOW + 1e-12
        assert r["t_separated"] + r["t_backward"] <= WINDOW + 1e-12
        dw = r["w_A_end"] - r["w_A_stats_start"]
        mean_force = (r["tau_A"] - rig["J_A"] * dw / WINDOW) / rig["rAb"]
        slack = rig["J_A"] * 2 * 100 * REL_TOL * abs(r["w_A_end"]) / (WINDOW * rig["rAb"])
        assert r["F_max"] >= mean_force - slack, (r["F_max"], mean_force)


def test_an_invalid_parameter_is_a_row_with_its_error(first_run):
    _, df, _ = first_run
    bad = df[df["backlash"] < 0]
    assert len(bad) == len(TAUS)
    assert (bad["status"] == "error").all()
    assert bad["error"].str.contains("backlash").all(), bad["error"].tolist()
    assert bad[list(S.STATS)].isna().all().all()


def test_a_rerun_skips_done_points_and_keeps_their_rows(first_run, fmu_path, cluster, capsys, tmp_path):
    out, before, _ = first_run
    again = tmp_path / "again.parquet"
    again.write_bytes(out.read_bytes())
    taus = TAUS + (300.0,)  # one more torque: only its points and the failed ones run
    capsys.readouterr()
    assert S.main(sweep_args(fmu_path, cluster, again, taus=taus)) == 0
    assert f"{len(TAUS)} of {len(taus) * len(BACKLASHES)} points already ok, skipped" in capsys.readouterr().err
    after = pd.read_parquet(again)
    assert len(after) == len(taus) * len(BACKLASHES)
    key = ["tau_A", "backlash"]
    kept = before[before["status"] == "ok"].merge(after, on=key, suffixes=("", "_again"))
    assert len(kept) == len(TAUS)
    # Bit-identical rows, wall time and worker included: they were not run again.
    for col in S.STATS + ("wall_time", "worker"):
        assert (kept[col] == kept[col + "_again"]).all(), col
    new = after[after["tau_A"] == 300.0]
    assert list(new.sort_values("backlash")["status"]) == ["error", "ok"]


def test_a_different_base_is_refused(first_run, fmu_path, cluster, tmp_path):
    out, _, _ = first_run
    other = tmp_path / "other.parquet"
    other.write_bytes(out.read_bytes())
    with pytest.raises(SystemExit, match="different"):
        S.main(sweep_args(fmu_path, cluster, other, stats_start=0.06))
