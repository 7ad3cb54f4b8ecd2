"""SpurGearTrain as an FMI 3.0 FMU (SpurGearTrain-fmi3.fmu, the same binary as the
FMI 2.0 FMU with the FMI 3.0 description of the same table): it validates, runs a scene to the
same numbers bit for bit as the FMI 2.0 FMU (one model behind both interfaces, the same steps),
and refuses a broken train with an error naming the body."""

import fmpy
import numpy as np
import pytest
from fmpy.validation import validate_fmu

OUTPUTS = ["mesh[1].dte", "mesh[2].dte", "mesh[1].F_fwd", "shaft[1].tau", "body[4].w", "E_el"]


def test_the_fmi3_description_validates(train_fmu3_path):
    assert validate_fmu(str(train_fmu3_path)) == []
    md = fmpy.read_model_description(str(train_fmu3_path))
    assert md.fmiVersion == "3.0" and md.coSimulation is not None and md.modelExchange is not None
    assert md.variableNamingConvention == "structured"


def test_fmi3_runs_the_default_train_as_fmi2_does(train_fmu_path, train_fmu3_path):
    runs = [
        fmpy.simulate_fmu(str(p), stop_time=0.02, output_interval=1e-4, output=OUTPUTS)
        for p in (train_fmu_path, train_fmu3_path)
    ]
    assert len(runs[0]) == len(runs[1]) == 201
    for name in OUTPUTS:
        assert np.array_equal(runs[0][name], runs[1][name]), name
    assert np.all(np.isfinite(runs[1]["mesh[1].dte"]))


def test_fmi3_refuses_a_body_joined_to_nothing(train_fmu3_path):
    messages = []

    def logger(*args):
        messages.append(" ".join(str(a) for a in args))

    with pytest.raises(Exception):
        fmpy.simulate_fmu(str(train_fmu3_path), stop_time=1e-3, start_values={"n_bodies": 5},
                          debug_logging=True, logger=logger)
    assert any("body[5]" in m for m in messages), messages
