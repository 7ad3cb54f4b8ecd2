"""The hybrid power-split device co-simulated from three FMUs (issue 31 point 6;
docs/power-split.md): cosim/power-split.ssd, SpurGearTrain (scenes/train/power-split.toml's planetary
set, the vehicle on the ring) with EngineTorque on the carrier and SpeedController holding the sun.

1. The .ssd is the scene: the train's parameter set is the scene's start values (the two connected
   torque inputs at their values at t = 0), the names are identifiers, the system carries
   OMSimulator's org.openmodelica fixed-step annotation, it is valid SSP 1.0, and the committed file
   is what `python cosim/power_split.py ssd` writes.
2. The .ssp runs in libcosim and in FMPy's simulate_ssp, and each is our own master's Jacobi
   coupling with the engine's torque one step late (FMPy: with its zero start) to rounding, so the
   torques each master's train held over every step are known.
3. The power balance closes at every communication point: the engine's work (its law, in closed
   form along the carrier's angle) = the generator's work + the change of kinetic and elastic
   energy + the meshes' losses + the road drag's work - the gate energy, within the bound
   balance() derives from the step (the held ripple torque: A n W^2 h^2 (d + 1/2) per step, d the
   master's delay; FMPy's zero first step; the road term; the integration tolerance).  With the
   engine's work as the train received it, the residual has no coupling error: it is bounded by the
   road and integration terms alone (a generator torque one step out of place would break that).
4. The Willis relation z_s w_s - z_r w_r - (z_s + z_r) w_c = 0 (forward senses: sun and carrier
   -1, ring +1) holds within the meshes' compliance at every communication point: its residual R
   equals 2 (dte_rate[n] + dte_rate[n + 4]) / (m cos alpha0) for each planet n to rounding, so
   |R| <= (2 / (m cos alpha0)) min_n (|dte_rate[n]| + |dte_rate[n + 4]|).
5. OMSimulator (skipped when it is not installed, as in CI): the .ssp runs without a warning, its
   stepping loop is the engine's feedthrough (train and engine), it is our own master with the loop solved at the communication points (delay 0) to the rounding of its
   12-digit result file, and 3. and 4. hold there.
Each run: h = 1e-4 s, 0 to 0.1 s (about 1 s of CPU per master).
"""

import re
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "cosim"))

import oms_run  # noqa: E402
import power_split as P  # noqa: E402

H, T = P.STEP, P.STOP
OMS = oms_run.find()


@pytest.fixture(scope="module")
def fmus(train_fmu_path, engine_fmu_path):
    from conftest import build_fmu

    controller = build_fmu("package-controller")
    assert train_fmu_path.parent == engine_fmu_path.parent == controller.parent == P.FMU_DIR
    return P.fmu_paths()


@pytest.fixture(scope="module")
def ssp(fmus, tmp_path_factory):
    return P.build_ssp(tmp_path_factory.mktemp("ssp") / "power-split.ssp")


@pytest.fixture(autouse=True, scope="module")
def _quiet_libcosim():
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.WARNING)


@pytest.fixture(scope="module")
def runs(ssp):
    return {"own": P.run_master(H, T, delay=0), "own_delayed": P.run_master(H, T, delay=1),
            "own_fmpy": P.run_master(H, T, delay=1, start="fmpy"),
            "libcosim": P.run_libcosim_ssp(ssp, H, T), "fmpy": P.run_fmpy_ssp(ssp, H, T)}


# master: (delay of the engine's torque, FMPy's zero first step)
SCHEMES = {"own": (0, False), "libcosim": (1, False), "fmpy": (1, True)}


def test_the_ssd_is_the_scene_and_what_omsimulator_imports(fmus, tmp_path):
    import xml.etree.ElementTree as ET

    import fmpy.ssp
    from lxml import etree

    schema = etree.XMLSchema(etree.parse(str(Path(fmpy.ssp.__file__).parent / "schema" / "SystemStructureDescription.xsd")))
    assert schema.validate(etree.parse(str(P.SSD))), schema.error_log
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
          "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon", "oms": P.D.OMS_NS}
    root = ET.parse(P.SSD).getroot()
    system = root.find("ssd:System", ns)
    ident = re.compile(r"^[a-zA-Z][a-zA-Z0-9_]*$")
    names = [root.get("name"), system.get("name")] + [c.get("name") for c in system.iterfind("ssd:Elements/ssd:Component", ns)]
    assert all(ident.match(n) for n in names), names
    master = system.find("ssd:Annotations/ssc:Annotation[@type='org.openmodelica']/oms:Annotations/"
                         "oms:SimulationInformation/oms:FixedStepMaster", ns)
    assert master is not None and float(master.get("stepSize")) == P.STEP
    # the train's parameter set is the scene's start values, the connected inputs at t = 0
    with open(P.SCENE, "rb") as f:
        scene = tomllib.load(f)["start_values"]
    params = P.ssd_parameters()
    train = params["train"]
    for k, v in scene.items():
        if k in ("body[1].tau", "body[2].tau"):
            continue
        assert train[k] == v, k
    assert set(train) == set(scene) | {"rel_tol"}
    assert train["body[2].tau"] == params["engine"]["tau_mean"] == scene["body[2].tau"]
    assert train["body[1].tau"] == 0.0 and params["generator"]["w_ref"] == params["generator"]["w_A"] == scene["body[1].w_start"]
    P.write_ssd(tmp_path / "power-split.ssd")
    assert (tmp_path / "power-split.ssd").read_text() == P.SSD.read_text(), \
        "regenerate with `python cosim/power_split.py ssd`"


def _same(a, b, rel=10 * P.REL_TOL):
    """The same scheme in two masters: the same calls, at communication times that may differ
    by rounding (t = k h against a sum of steps), so each run lies within the train's
    integration error of the exact coupled solution: local errors of rel_tol relative to the
    state, accumulated over a run of damped vibrations, allowed ten times. The earlier bound of
    1e-10 lay below rel_tol = 1e-9 and held only while both runs rounded alike."""
    for q in ["body[1].w", "body[2].w", "body[3].w", "body[1].theta", "body[2].theta", "mesh[1].dte",
              "mesh[5].dte", "E_kin", "W_loss", "held.sun", "held.carrier"]:
        scale = float(np.max(np.abs(a[q])))
        err = float(np.max(np.abs(a[q] - b[q])))
        assert err <= rel * scale, f"{q}: differs by {err:.3g} (scale {scale:.3g})"


def test_libcosim_is_jacobi_with_the_engine_one_step_late(runs):
    _same(runs["libcosim"], runs["own_delayed"])


def test_fmpy_is_jacobi_with_the_engine_one_step_late_and_a_zero_start(runs):
    r = runs["fmpy"]
    assert r["held.sun"][0] == r["held.carrier"][0] == 0.0
    assert r["held.sun"][1] == P.TAU_MAX      # its generator sampled w = 0 in the first step
    _same(r, runs["own_fmpy"])


@pytest.mark.parametrize("master", list(SCHEMES))
def test_the_power_balance_closes_within_the_bound_derived_from_the_step(runs, master):
    delay, zero = SCHEMES[master]
    b = P.balance(runs[master], H, delay, zero)
    assert np.all(np.abs(b["r_held"]) <= b["bound_held"]), float(np.max(np.abs(b["r_held"])))
    assert np.all(np.abs(b["r"]) <= b["bound"]), float(np.max(np.abs(b["r"]) / b["bound"]))
    assert np.all(np.abs(b["coupling"]) <= b["bound_coupling"] + 1e-9)
    # the terms are what the scene makes them: the engine's mean torque over the carrier's angle,
    # the road taking most of it
    assert b["W_engine"][-1] == pytest.approx(100.0 * (runs[master]["body[2].theta"][-1]), rel=1e-2)
    assert 0.5 * b["W_engine"][-1] < b["W_road"][-1] < b["W_engine"][-1]


@pytest.mark.parametrize("master", list(SCHEMES))
def test_willis_holds_within_the_meshes_compliance_at_every_point(runs, master):
    w = P.willis(runs[master])
    assert np.all(w["defect"] <= 1e-13 * w["size"]), float(np.max(w["defect"] / w["size"]))
    assert np.all(np.abs(w["R"]) <= w["bound"])
    # the set turns as the scene says: R is small against its terms
    assert np.max(np.abs(w["R"]) / w["size"]) < 1e-2


@pytest.mark.skipif(OMS is None, reason=oms_run.MISSING)
def test_omsimulator_runs_the_ssp_as_jacobi_with_the_loop_solved(runs, ssp):
    r = P.run_omsimulator_ssp(ssp, H, T, OMS)
    assert r["_warnings"] == 0, r["_log"][-3000:]
    # two loops: at initialization with the generator (its initial torque depends on its input),
    # then, for the steps, the engine's feedthrough between it and the train
    loops = re.findall(r"Alg\. loop \(size (\d+)/\d+\)\s*\n((?:\s+\S+\n)+)", r["_log"])
    assert loops, r["_log"][-3000:]
    assert {line.strip().rsplit(".", 1)[-1] for line in loops[-1][1].splitlines()} == {"train", "engine"}
    own = runs["own"]
    for q in ["body[1].w", "body[2].w", "body[3].w", "mesh[1].dte", "E_kin", "held.sun", "held.carrier"]:
        scale = float(np.max(np.abs(own[q])))
        assert float(np.max(np.abs(r[q] - own[q]))) <= 1e-9 * scale, q
    b = P.balance(r, H, 0, False)
    assert np.all(np.abs(b["r"]) <= b["bound"])
    # its 12 digits: the held balance's residual is rounding of E_kin (7e4 J) at 1e-11 and more
    assert np.all(np.abs(b["r_held"]) <= b["bound_held"])
    w = P.willis(r, P.OMS_ROUNDING)
    assert np.all(w["defect"] <= P.OMS_ROUNDING * w["size"])
    assert np.all(np.abs(w["R"]) <= w["bound"])
