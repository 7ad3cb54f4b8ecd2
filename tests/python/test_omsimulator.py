"""The two-stage drivetrain's .ssp in OMSimulator (docs/omsimulator.md).

1. Without OMSimulator (as in CI): cosim/two-stage.ssd is what OMSimulator 2.1 needs to import
   it. Its .ssd and system names are identifiers (OMSimulator: `"two-stage" is not a valid
   ident`), and the system carries OMSimulator's org.openmodelica annotation with a fixed-step
   master (without it the import ends in `internal error`), while staying valid SSP 1.0 (the
   standard's schema, as FMPy ships it). The committed file is what `drivetrain.py ssd` writes.
2. With OMSimulator (OMSIMULATOR_HOME or OMSimulator on PATH; CI does not build it, so these
   skip there): the command docs/cosim.md gives a user, `OMSimulator --stopTime=...
   --stepSize=... --resultFile=... two-stage.ssp`, runs without an error or a warning; OMSimulator
   finds the algebraic loop the shaft's and the engine's direct feedthroughs close, with all four
   FMUs in it; the first shaft torque is k twist_start = 100 N.m; and the run is our own master's
   Jacobi coupling with held inputs and no extra delay (cosim/drivetrain.py run_master, delay 0)
   to the rounding of OMSimulator's 12-digit CSV (bound 1e-9 of each quantity's largest
   magnitude; measured 5e-11 for dte and 1e-11 for the torque at h = 1e-5 s).
"""

import re
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "cosim"))

import drivetrain as D  # noqa: E402
import oms_run  # noqa: E402

H, T = 1e-5, 0.01


def test_the_ssd_is_what_omsimulator_imports_and_still_ssp_1_0(tmp_path):
    import xml.etree.ElementTree as ET

    from lxml import etree
    import fmpy.ssp

    schema = etree.XMLSchema(etree.parse(str(Path(fmpy.ssp.__file__).parent / "schema" / "SystemStructureDescription.xsd")))
    assert schema.validate(etree.parse(str(D.SSD))), schema.error_log
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
          "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon", "oms": D.OMS_NS}
    root = ET.parse(D.SSD).getroot()
    system = root.find("ssd:System", ns)
    ident = re.compile(r"^[a-zA-Z][a-zA-Z0-9_]*$")  # OMSimulator's ComRef::isValidIdent
    assert ident.match(root.get("name")) and ident.match(system.get("name"))
    ann = system.find("ssd:Annotations/ssc:Annotation[@type='org.openmodelica']", ns)
    master = ann.find("oms:Annotations/oms:SimulationInformation/oms:FixedStepMaster", ns)
    assert master is not None and master.get("description") == "oms-ma"
    assert float(master.get("stepSize")) == D.STEP
    assert float(master.get("relativeTolerance")) == D.REL_TOL
    # the committed file is the generator's
    D.write_ssd(tmp_path / "two-stage.ssd")
    assert (tmp_path / "two-stage.ssd").read_text() == D.SSD.read_text(), \
        "regenerate with `python cosim/drivetrain.py ssd`"


OMS = oms_run.find()
# a mark, not a fixture's skip: it is decided before the session's fixtures package the FMUs
needs_oms = pytest.mark.skipif(OMS is None, reason=oms_run.MISSING)


@pytest.fixture(scope="module")
def fmus(fmu_path, train_fmu_path):
    from test_cosim_drivetrain import _package

    _package("--bin", "package-shaft")
    _package("--bin", "package-engine")
    return D.fmu_paths()


@needs_oms
def test_omsimulator_runs_the_ssp_and_is_jacobi_without_delay(fmus, tmp_path):
    ssp = D.build_ssp(tmp_path / "two-stage.ssp")
    res = oms_run.run_cli(OMS, ssp, T, tmp_path / "run", step=H)
    assert res.warnings == 0, res.log[-3000:]
    # the loop: all four FMUs (the gears declare no dependencies, so their outputs count as
    # depending on every input)
    m = re.search(r"Alg\. loop \(size (\d+)/\d+\)\s*\n((?:\s+\S+\n)+)", res.log)
    assert m, res.log[-3000:]
    members = {line.strip().rsplit(".", 1)[-1] for line in m.group(2).splitlines()}
    assert members == {"engine", "gear1", "gear2", "shaft"} and int(m.group(1)) == len(D.CONNECTIONS)
    p = f"{D.SSD_NAME}.{D.SSD_NAME}."
    col = res.columns
    n = int(round(T / H))
    assert np.allclose(col["time"], H * np.arange(n + 1), rtol=0, atol=1e-9 * H)
    assert col[p + "shaft.tau_b"][0] == pytest.approx(100.0, rel=1e-12)
    own = D.run_master(H, T, dt_out=H)
    for q, name in zip(D.QUANTITIES, [f"{c}.{v}" for c, v in D.RECORDED]):
        ref = own[q]
        err = float(np.max(np.abs(col[p + name] - ref)))
        assert err <= 1e-9 * float(np.max(np.abs(ref))), f"{q}: OMSimulator differs from Jacobi by {err:.3g}"
