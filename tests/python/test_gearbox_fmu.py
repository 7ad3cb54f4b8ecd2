"""The FMU of a gearbox (gearbox-file.md §2) through FMPy: `package-train --gearbox FILE`
writes NAME.fmu and NAME-fmi3.fmu, which FMPy validates and runs in both interfaces with the
file's values as start values; the run equals SpurGearTrain's given the scene's values; its
default outputs are the gearbox's own; a missing or damaged gearbox file in its resources fails
the instantiation with a message.
"""

import math
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))

import scene_to_ssp as X  # noqa: E402

SCENES = ["two-stage", "planetary-simple", "lateral-pair"]


def package(path, out_dir):
    """Packages the gearbox file at `path` into `out_dir`; returns the FMI 2.0 FMU's path."""
    import os

    env = dict(os.environ, FMU_OUT_DIR=str(out_dir))
    r = subprocess.run(["cargo", "run", "-q", "--release", "-p", "fmu-packaging", "--bin", "package-train",
                        "--", "--gearbox", str(path)], cwd=ROOT, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    fmu = Path(r.stdout.strip().splitlines()[-1])
    assert fmu.is_file() and fmu.with_name(fmu.stem + "-fmi3.fmu").is_file()
    return fmu


@pytest.fixture(scope="module")
def gearbox_fmus(tmp_path_factory, train_fmu_path):
    out = tmp_path_factory.mktemp("gearbox-fmus")
    return {name: package(ROOT / "scenes" / "train" / "gearbox" / f"{name}.toml", out) for name in SCENES}


def outputs(md):
    return [v.name for v in md.modelVariables if v.causality == "output"]


@pytest.mark.parametrize("name", SCENES)
def test_the_gearbox_fmu_validates_and_declares_only_its_elements(name, gearbox_fmus):
    import fmpy
    from fmpy.validation import validate_fmu

    for fmu in (gearbox_fmus[name], gearbox_fmus[name].with_name(gearbox_fmus[name].stem + "-fmi3.fmu")):
        assert validate_fmu(str(fmu)) == [], fmu
    md = fmpy.read_model_description(str(gearbox_fmus[name]))
    names = [v.name for v in md.modelVariables]
    assert not any(n.startswith(("body[", "mesh[", "shaft[", "n_bodies")) for n in names), names
    g = X.load_scene(str(ROOT / "scenes" / "train" / "gearbox" / f"{name}.toml"))
    nb = g["start_values"]["n_bodies"]
    nm = g["start_values"]["n_meshes"]
    lateral = sum(bool(g["start_values"].get(f"body[{i}].lateral", False)) for i in range(1, nb + 1))
    # Model Exchange: exactly this gearbox's states (a rotation per body, two translations per
    # lateral body, each with its rate) and event indicators.
    assert len(md.derivatives) == 2 + 2 * (nb + 2 * lateral)
    # (NAME.dx, NAME.dy: NAME.x is an inline gear's profile shift.)
    assert sum(n.endswith((".dx", ".dy")) for n in outputs(md)) == 2 * lateral
    assert md.numberOfEventIndicators == 32 * nm
    assert sum(n.endswith(".w") for n in outputs(md)) == nb
    assert sum(n.endswith(".dte") for n in outputs(md)) == nm
    with zipfile.ZipFile(gearbox_fmus[name]) as z:
        files = z.namelist()
        assert "resources/gearbox.toml" in files and "documentation/layout.svg" in files
        doc = z.read("documentation/index.html").decode()
        assert "layout.svg" in doc and all(n in doc for n in outputs(md))


@pytest.mark.parametrize("name", SCENES)
def test_the_gearbox_fmu_runs_as_spur_gear_train(name, gearbox_fmus, train_fmu_path):
    """The same traces as SpurGearTrain given the scene's values, to 1e-12 of each range (the
    same model with the same values: in fact to the bit), in Co-Simulation and Model Exchange."""
    import fmpy

    scene = X.load_scene(name)
    sv = scene["start_values"]
    h, t = float(scene["output_interval"]), float(scene["stop_time"])
    md = fmpy.read_model_description(str(gearbox_fmus[name]))
    own = outputs(md)
    # The gearbox names its bodies and meshes in the file's order, which is the train's.
    pairs = []
    for suffix, kind in ((".w", "body"), (".theta", "body"), (".dte", "mesh"), (".F_fwd", "mesh")):
        mine = [n for n in own if n.endswith(suffix)]
        pairs += [(n, f"{kind}[{i + 1}]{suffix}") for i, n in enumerate(mine)]
    bodies = [n[:-2] for n in own if n.endswith(".w")]
    pairs += [(n, f"body[{bodies.index(n[:-3]) + 1}].{n[-1]}") for n in own if n.endswith((".dx", ".dy"))]
    pairs.append(("housing.tau", "housing.tau"))
    # Co-Simulation: the FMU's own integrator on the same model and values, to rounding.
    # Model Exchange: FMPy's CVode integrates this gearbox's n states here and SpurGearTrain's
    # 34 there (the unused ones constant), which changes its error norm and so its steps: the
    # traces agree to the integration error. CVode's weighted RMS norm averages over all
    # states, so SpurGearTrain's unused ones loosen its effective local tolerance by
    # sqrt(34 / n) (at most 1.8 for the 10 states of lateral-pair); with the usual margin of 100
    # of global over local error the bound is 100 rtol sqrt(34 / n) of each range, on the output
    # grid (event rows differ).
    n_train = len(fmpy.read_model_description(str(train_fmu_path)).derivatives)
    me_bound = 100 * 1e-6 * math.sqrt(n_train / len(md.derivatives))
    for fmi_type, stop, bound in (("CoSimulation", t, 1e-12), ("ModelExchange", min(t, 0.01), me_bound)):
        a = fmpy.simulate_fmu(str(gearbox_fmus[name]), stop_time=stop, output_interval=h, fmi_type=fmi_type,
                              relative_tolerance=1e-6)
        b = fmpy.simulate_fmu(str(train_fmu_path), stop_time=stop, output_interval=h, start_values=sv,
                              output=[q for _, q in pairs], fmi_type=fmi_type, relative_tolerance=1e-6)
        a, b = (r[_on_grid(r["time"], h)] for r in (a, b))
        assert len(a) == len(b) > 10 and np.array_equal(a["time"], b["time"])
        for mine, theirs in pairs:
            span = max(np.ptp(b[theirs]), np.max(np.abs(b[theirs])), 1e-300)
            err = np.max(np.abs(a[mine] - b[theirs]))
            assert err <= bound * span, f"{name} {fmi_type} {mine} vs {theirs}: {err:.3g} of {span:.3g}"


def _on_grid(t, h):
    """The rows at the output grid's points, each once (FMPy adds rows at events)."""
    k = np.round(t / h)
    grid = np.abs(t - k * h) <= 1e-9 * h
    first = np.concatenate(([True], np.diff(t) > 0))
    return grid & first


def test_default_outputs_are_the_gearbox_own(gearbox_fmus):
    """`fmpy simulate` with no output list records the gearbox's outputs only (per body theta
    and w, per mesh dte, F_fwd, F_bwd, F and the contact counts, per shaft tau, housing.tau and
    the energy residual), not every local SpurGearTrain can show."""
    import fmpy

    md = fmpy.read_model_description(str(gearbox_fmus["planetary-simple"]))
    r = fmpy.simulate_fmu(str(gearbox_fmus["planetary-simple"]), stop_time=0.002)
    assert set(r.dtype.names) == {"time", *outputs(md)}
    assert len(outputs(md)) < 60 < len(md.modelVariables)
    f = [n for n in outputs(md) if n.endswith(".F")]
    assert len(f) == 6
    for n in f:
        mesh = n[:-2]
        assert np.array_equal(r[n], r[f"{mesh}.F_fwd"] + r[f"{mesh}.F_bwd"]), n


def _instantiate_errors(fmu, unzipped):
    """Instantiates the unzipped `fmu` through FMPy (conftest's Instance, which records the log);
    returns the logged errors, or None when it instantiated."""
    import fmpy
    from conftest import Instance

    md = fmpy.read_model_description(str(fmu))
    inst = Instance(str(unzipped), md, model_identifier=md.coSimulation.modelIdentifier, instantiate=False)
    try:
        inst.slave.instantiate(callbacks=inst.callbacks, loggingOn=True)
    except Exception:
        return [m for _, _, m in inst.messages] or ["instantiate failed, nothing logged"]
    inst.instantiated = True
    inst.free()
    return None


def test_a_missing_or_damaged_gearbox_file_is_refused(gearbox_fmus, tmp_path):
    fmu = gearbox_fmus["two-stage"]
    ok = tmp_path / "ok"
    shutil.unpack_archive(fmu, ok, "zip")
    assert _instantiate_errors(fmu, ok) is None
    missing = tmp_path / "missing"
    shutil.unpack_archive(fmu, missing, "zip")
    (missing / "resources" / "gearbox.toml").unlink()
    errors = _instantiate_errors(fmu, missing)
    assert errors and any("gearbox.toml" in e and "cannot be read" in e for e in errors), errors
    damaged = tmp_path / "damaged"
    shutil.unpack_archive(fmu, damaged, "zip")
    p = damaged / "resources" / "gearbox.toml"
    p.write_text(p.read_text().replace("J = 0.004", "J = 0.004\nmass = 2.0"))
    errors = _instantiate_errors(fmu, damaged)
    assert errors and any("unknown field `mass`" in e for e in errors), errors


def test_libcosim_runs_a_gearbox_fmu(gearbox_fmus):
    """libcosim loads the gearbox FMU itself (it unzips it and passes its resources), and its run
    is FMPy's to rounding: the same FMU at the same communication steps."""
    import fmpy
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    fmu = gearbox_fmus["planetary-simple"]
    h, n = 1e-4, 200
    ns = int(round(h * 1e9))
    ex = CosimExecution.from_step_size(step_size=ns)
    index = ex.add_local_slave(CosimLocalSlave(fmu_path=str(fmu), instance_name="gearbox"))
    variables = {v.name.decode(): v for v in ex.slave_variables(index)}
    own = outputs(fmpy.read_model_description(str(fmu)))
    names = [n for n in own if n.endswith(".w")][:2] + [n for n in own if n.endswith((".dte", ".F"))][:2]
    names.append("housing.tau")
    obs = CosimObserver.create_time_series(buffer_size=n + 16)
    ex.add_observer(obs)
    for q in names:
        obs.start_time_series(index, variables[q].reference, CosimVariableType.REAL)
    assert ex.simulate_until(n * ns)
    ref = fmpy.simulate_fmu(str(fmu), stop_time=n * h, output_interval=h, output=names, set_stop_time=False)
    for q in names:
        _, steps, values = obs.time_series_real_samples(index, variables[q].reference, from_step=1, sample_count=n)
        assert list(steps) == list(range(1, n + 1)), q
        span = max(np.ptp(ref[q]), np.max(np.abs(ref[q])))
        err = np.max(np.abs(np.array(values) - ref[q][1:n + 1]))
        assert err <= 1e-12 * span, f"{q}: {err:.3g} of {span:.3g}"


def test_the_spec_example_packages_and_runs(tmp_path):
    """gearbox-file.md §1's example (scenes/gearbox/nrel-stage1.toml) as an FMU: the generator is
    speed-driven (input `generator.w_in`, output `generator.tau_drive`, no `w_start`), the
    static start is on, and FMPy runs it. Over the planetary stage's mesh period 2 pi / (z_ring
    w_c) the drive holds T_c w_c / w_gen in the mean, to 1 % (the closed form without friction;
    train-fmu/tests/gearbox.rs checks the same run's forces and Willis ratio in detail). A new
    speed is held from the communication point it is set at. In Model Exchange the drive's rate
    is the input, not a state (2 + 2 n_bodies - 1 states), and FMPy's CVode follows the
    Co-Simulation run to the integration error (1e-4 of each range, as for every gearbox)."""
    import fmpy
    from fmpy.validation import validate_fmu

    fmu = package(ROOT / "scenes" / "gearbox" / "nrel-stage1.toml", tmp_path)
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["generator.w_in"].causality == "input"
    assert float(by_name["generator.w_in"].start) == pytest.approx(18.75, rel=1e-12)
    assert by_name["generator.tau_drive"].causality == "output"
    assert "generator.w_start" not in by_name and "hss.tau_drive" not in by_name and "hss.w_in" not in by_name
    t_c, w_c, w_gen = 4.1667e6, 1.2, 18.75
    period = 2 * np.pi / (56 * w_c)
    h = period / 200
    signal = np.array([(0.0, w_gen), (period, w_gen), (period, 19.0), (period + 20 * h, 19.0)],
                      dtype=[("time", float), ("generator.w_in", float)])
    r = fmpy.simulate_fmu(str(fmu), stop_time=period + 10 * h, output_interval=h, input=signal,
                          output=["generator.w", "generator.tau_drive", "stage1.carrier.w"])
    first = r["time"] <= period * (1 + 1e-9)
    # Held to the rounding of the map from the coordinates to the bodies (a few ulp).
    assert np.max(np.abs(r["generator.w"][first] - w_gen)) <= 1e-13 * w_gen
    mean = np.mean(r["generator.tau_drive"][first][1:])
    assert abs(mean / (-t_c * w_c / w_gen) - 1) <= 0.01, mean
    assert abs(r["generator.w"][-1] - 19.0) <= 1e-13 * 19.0
    # Model Exchange: the generator's coordinate (the first) has no rate state.
    n_bodies = sum(1 for v in md.modelVariables if v.name.endswith(".J"))
    states = [d.variable.name for d in md.derivatives]
    assert len(states) == 2 + 2 * n_bodies - 1 and "der(coordinate[1].rate)" not in states, states
    outs = ["generator.w", "stage1.carrier.w", "stage1.sun.w"]
    cs, me = (fmpy.simulate_fmu(str(fmu), stop_time=period, output_interval=h, output=outs, fmi_type=t,
                                relative_tolerance=1e-6) for t in ("CoSimulation", "ModelExchange"))
    cs, me = (x[_on_grid(x["time"], h)] for x in (cs, me))
    assert len(cs) == len(me) > 100 and np.array_equal(cs["time"], me["time"])
    assert np.max(np.abs(me["generator.w"] - w_gen)) <= 1e-13 * w_gen
    for n in outs[1:]:
        span = max(np.ptp(cs[n]), np.max(np.abs(cs[n])))
        assert np.max(np.abs(me[n] - cs[n])) <= 1e-4 * span, n


def test_damping_ratio_shows_chi_as_a_calculated_parameter(tmp_path):
    """A mesh with `damping_ratio` declares its chi as a calculated parameter (no start value),
    which FMPy validates in FMI 2.0 and 3.0 and reads after initialization; a mesh with `chi`
    keeps it a tunable parameter."""
    import fmpy
    from fmpy.validation import validate_fmu

    text = (ROOT / "scenes" / "train" / "gearbox" / "two-stage.toml").read_text()
    path = tmp_path / "two-stage-ratio.toml"
    path.write_text(text.replace("center_angle = 0.6\n", "center_angle = 0.6\ndamping_ratio = 0.05\n"))
    fmu = package(path, tmp_path)
    for f in (fmu, fmu.with_name(fmu.stem + "-fmi3.fmu")):
        assert validate_fmu(str(f)) == [], f
    md = fmpy.read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    chi = by_name["pinion2_output.chi"]
    assert chi.causality == "calculatedParameter" and chi.start is None
    assert by_name["motor_wheel1.chi"].causality == "parameter"
    r = fmpy.simulate_fmu(str(fmu), stop_time=1e-3, output=["pinion2_output.chi"])
    assert np.all(r["pinion2_output.chi"] > 0)
