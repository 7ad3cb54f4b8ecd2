"""Directional derivatives of Model Exchange (lateral.md section 5) and tools/modes.py.

    .venv/bin/python -m pytest -q tests/python/test_directional.py

The FMUs give d(unknowns)/d(knowns) . seed by central differences (fmi2-slave/src/directional.rs,
steps eps^(1/3) of each known's scale): the stated accuracy is 1e-8 of the derivative's scale.
The lumped mesh (contact_model = 4) makes the right-hand side linear in the deflections, so the
Jacobian has closed forms to check against; a Johnson mesh's tangent stiffness is the output
k_mesh (its closed form, johnson.rs).
"""

import math
import sys
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.fmi3 import FMU3Model

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))

import modes as MODES  # noqa: E402

TOL = 1e-8
K = 4e8
LUMPED = {"contact_model": 4, "k_lumped": K, "backlash": 0.0, "c_load": 0.0,
          "w_A_start": 100.0, "w_B_start": 66.66666666666667, "dte_start": 1e-6, "tau_A": 0.0}


class Model:
    """A Model Exchange instance of SpurGearMesh (FMI 2.0 or 3.0) in continuous-time mode."""

    def __init__(self, path, start, version=2):
        md = fmpy.read_model_description(path)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.types = {v.name: v.type for v in md.modelVariables}
        cls = FMU2Model if version == 2 else FMU3Model
        self.f = cls(guid=md.guid, unzipDirectory=fmpy.extract(path),
                     modelIdentifier=md.modelExchange.modelIdentifier, instanceName="dd")
        self.version = version
        self.f.instantiate()
        self.states = [d.variable.derivative.valueReference for d in md.derivatives]
        self.ders = [d.variable.valueReference for d in md.derivatives]
        if version == 2:
            self.f.setupExperiment(startTime=0.0)
            self.f.enterInitializationMode()
        else:
            self.f.enterInitializationMode(startTime=0.0)
        for k, v in start.items():
            t = self.types[k]
            if t in ("Integer", "Int32"):
                (self.f.setInteger if version == 2 else self.f.setInt32)([self.vr[k]], [int(v)])
            else:
                (self.f.setReal if version == 2 else self.f.setFloat64)([self.vr[k]], [float(v)])
        self.f.exitInitializationMode()
        (self.f.newDiscreteStates if version == 2 else self.f.updateDiscreteStates)()
        self.f.enterContinuousTimeMode()

    def real(self, name):
        return (self.f.getReal if self.version == 2 else self.f.getFloat64)([self.vr[name]])[0]

    def dd(self, unknowns, knowns, seed):
        u = [self.vr[n] if isinstance(n, str) else n for n in unknowns]
        k = [self.vr[n] if isinstance(n, str) else n for n in knowns]
        return np.array(self.f.getDirectionalDerivative(u, k, seed))


@pytest.mark.parametrize("version", [2, 3])
def test_the_lumped_mesh_jacobian_is_its_closed_form(version, fmu_path, fmu3_path):
    """Without backlash at dte > 0 the forward spring alone carries: F = k dte, so
    d(dw_A/dt)/d(dte) = -k rAb/J_A, d(d^2 dte/dt^2)/d(dte) = -k (rAb^2/J_A + rBb^2/J_B),
    dF_fwd/d(dte) = k, and the drive enters as d(d^2 dte/dt^2)/d(tau_A) = rAb/J_A; d(der(dte))/
    d(dte_rate) = 1. The model is linear there: the differences are exact but for rounding."""
    m = Model(fmu_path if version == 2 else fmu3_path, LUMPED, version)
    ra, rb, ja, jb = m.real("rAb"), m.real("rBb"), 0.4, 2.0
    cases = [
        ("der(w_A)", "dte", -K * ra / ja),
        ("der(dte_rate)", "dte", -K * (ra * ra / ja + rb * rb / jb)),
        ("F_fwd", "dte", K),
        ("der(dte_rate)", "tau_A", ra / ja),
        ("der(dte)", "dte_rate", 1.0),
        ("der(theta_A)", "w_A", 1.0),
    ]
    for unknown, known, want in cases:
        got = m.dd([unknown], [known], [1.0])[0]
        assert abs(got - want) <= TOL * abs(want), (unknown, known, got, want)
    # Linear in the seed, and a seed along two knowns is the sum.
    a = m.dd(["der(dte_rate)"], ["dte"], [2.5])[0]
    b = m.dd(["der(dte_rate)"], ["dte", "dte_rate"], [2.5, 0.0])[0]
    assert abs(a - 2.5 * cases[1][2]) <= TOL * abs(a) and a == b
    assert list(m.dd(["der(dte_rate)"], ["dte"], [0.0])) == [0.0]
    # The point is left as it was.
    assert m.real("dte") == 1e-6


def test_a_johnson_mesh_has_its_force_slope(fmu_path):
    """Johnson's law (the paper's mesh) under load: dF_fwd/d(dte) is n pairs' slope of
    b N(delta, L + delta) (Johnson's radius grows with the penetration, R = L + delta), from the
    independent reference's law (tests/reference_model) by Richardson-extrapolated central
    differences at delta/1000 and delta/2000 (error O(h^4) ~ 1e-12, rounding ~ 1e-13 of it).
    The model's k_mesh, the slope at fixed R, differs by about delta/L of it (3e-6)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from reference_model import gearmesh_ref as G
    start = {"tau_A": 100.0, "c_load": 2.0, "w_A_start": 100.0,
             "w_B_start": 66.66666666666667, "dte_start": 5.592370531367129e-07}
    m = Model(fmu_path, start)
    got = m.dd(["F_fwd"], ["dte"], [1.0])[0]
    d, L = m.real("dte"), m.real("line_of_action")
    n = m.f.getInteger([m.vr["n_fwd"]])[0]
    e_star = 1.0 / (2 * (1 - 0.3 ** 2) / 2.1e11)

    def force(x):
        return n * 0.02 * G.johnson_N(x, L + x, e_star)

    def slope(h):
        return (force(d + h) - force(d - h)) / (2 * h)

    want = (4 * slope(d / 2000) - slope(d / 1000)) / 3
    assert n >= 1 and abs(got - want) <= TOL * want, (got, want)
    k_mesh = m.real("k_mesh")
    assert abs(k_mesh - want) <= 2 * d / L * want, (k_mesh, want)


def test_bad_calls_are_refused_by_name(fmu_path, capfd):
    """A known that is neither a state nor an input (a parameter), a non-finite seed, a
    Co-Simulation instance: fmi2Error, with a message (FMPy's default logger prints it) naming
    the function and what is wrong."""
    for known, seed, what in (("chi", 1.0, "is neither a continuous state nor a real input"),
                              ("dte", float("nan"), "is nan: must be finite")):
        m = Model(fmu_path, LUMPED)
        capfd.readouterr()
        with pytest.raises(FMICallException):
            m.dd(["der(w_A)"], [known], [seed])
        log = capfd.readouterr().out
        assert "fmi2GetDirectionalDerivative" in log and what in log.lower(), log
    md = fmpy.read_model_description(fmu_path)
    s = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(fmu_path),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="cs")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    capfd.readouterr()
    with pytest.raises(FMICallException):
        s.getDirectionalDerivative([vr["F_fwd"]], [vr["dte"]], [1.0])
    assert "instantiated for Co-Simulation" in capfd.readouterr().out


def two_body(k=K):
    """A one-mesh train of lumped meshes (the paper's pair) at a static load."""
    return {"n_bodies": 2, "n_shafts": 0, "n_meshes": 1, "body[1].J": 0.4, "body[2].J": 2.0,
            "body[1].tau": 100.0, "body[2].tau": -150.0, "body[1].w_start": 100.0,
            "body[2].w_start": 66.66666666666667, "body[3].tau": 0.0, "body[4].tau": 0.0,
            "mesh[1].A": 1, "mesh[1].B": 2, "mesh[1].contact_model": 4, "mesh[1].k_lumped": k}


def test_modes_of_a_pair_and_a_chain(train_fmu_path):
    """tools/modes.py on lumped trains against the closed forms of their torsional models.

    One mesh: a rigid rotation and one mode at sqrt(k (rAb^2/J_A + rBb^2/J_B)) / (2 pi). A chain
    1-2-3 of two meshes: with dte_m = rAb_m theta_A - rBb_m theta_B and F_m = k_m dte_m, M theta''
    = -K theta gives K's eigenvalues (one 0) as the squares of the frequencies. The Jacobian's
    entries carry 1e-8 relative error at most, so do the eigenvalues: 1e-7 on the frequencies."""
    lin = MODES.linearize(train_fmu_path, two_body())
    fs = [m["f"] for m in MODES.modes(lin)]
    g = MODES_GEOMETRY(train_fmu_path, two_body())
    want = math.sqrt(K * (g[1][0] ** 2 / 0.4 + g[1][1] ** 2 / 2.0)) / (2 * math.pi)
    assert abs(fs[0]) < 1e-6 * want and abs(fs[1] - want) <= 1e-7 * want, (fs, want)

    chain = dict(two_body(), **{"n_bodies": 3, "n_meshes": 2, "body[2].tau": 0.0,
                               "body[3].J": 1.2, "body[3].w_start": 50.0,
                               "mesh[2].A": 2, "mesh[2].B": 3, "mesh[2].contact_model": 4,
                               "mesh[2].k_lumped": 2.5e8})
    g = MODES_GEOMETRY(train_fmu_path, chain)
    w_b = 100.0 * g[1][0] / g[1][1]
    chain["body[2].w_start"] = w_b
    chain["body[3].w_start"] = w_b * g[2][0] / g[2][1]
    chain["body[3].tau"] = -100.0 * g[1][1] / g[1][0] * g[2][1] / g[2][0]
    lin = MODES.linearize(train_fmu_path, chain)
    fs = sorted(m["f"] for m in MODES.modes(lin))
    (a1, b1), (a2, b2) = g[1], g[2]
    J = np.diag([0.4, 2.0, 1.2])
    stiff = np.zeros((3, 3))
    for k, (i, j), (ra, rb) in ((K, (0, 1), (a1, b1)), (2.5e8, (1, 2), (a2, b2))):
        row = np.zeros(3)
        row[i], row[j] = ra, -rb
        # dte = row . theta; the force's torques are -F rAb on A, +F rBb on B: -k row^T row.
        stiff += k * np.outer(row, row)
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(J, stiff)).real)
    want = [math.sqrt(max(x, 0.0)) / (2 * math.pi) for x in w2]
    assert abs(fs[0]) < 1e-6 * want[-1], fs
    for f, w in zip(fs[1:], want[1:]):
        assert abs(f - w) <= 1e-7 * w, (fs, want)


def MODES_GEOMETRY(fmu, start):
    """Each mesh's (rAb, rBb) as the FMU calculates them (calculated parameters)."""
    md = fmpy.read_model_description(fmu)
    names = [f"mesh[{m}].{r}" for m in range(1, int(start["n_meshes"]) + 1)
             for r in ("rAb", "rBb")]
    res = fmpy.simulate_fmu(fmu, model_description=md, start_values=start, stop_time=1e-6,
                            output_interval=1e-6, output=names)
    return {m: (float(res[f"mesh[{m}].rAb"][0]), float(res[f"mesh[{m}].rBb"][0]))
            for m in range(1, int(start["n_meshes"]) + 1)}


def test_a_gearbox_fmu_has_the_trains_jacobian(train_fmu_path, tmp_path):
    """A gearbox FMU of the same one-mesh train (its states named by the file) gives the same
    frequencies as SpurGearTrain: the same model underneath, the same differences."""
    sys.path.insert(0, str(ROOT / "tests" / "python"))
    from test_gearbox_fmu import package
    gb = tmp_path / "pair.toml"
    gb.write_text("""name = "LumpedPair"
[defaults]
contact_model = 4
k_lumped = 4e8
[[body]]
name = "pinion"
J = 0.4
tau = 100.0
w_start = 100.0
gear = { z = 22 }
[[body]]
name = "wheel"
J = 2.0
tau = -150.0
w_start = 66.66666666666667
gear = { z = 33 }
[[mesh]]
gears = ["pinion", "wheel"]
paper = { zA_nominal = 20, zB_nominal = 30, rA = 0.2, alpha_factor = 2.8 }
""")
    fmu = package(gb, tmp_path)
    md = fmpy.read_model_description(fmu)
    assert md.modelExchange is not None
    m = FMU2Model(guid=md.guid, unzipDirectory=fmpy.extract(fmu),
                  modelIdentifier=md.modelExchange.modelIdentifier, instanceName="gb")
    m.instantiate()
    m.setupExperiment(startTime=0.0)
    m.enterInitializationMode()
    m.exitInitializationMode()
    m.newDiscreteStates()
    m.enterContinuousTimeMode()
    states = [d.variable.derivative.valueReference for d in md.derivatives]
    ders = [d.variable.valueReference for d in md.derivatives]
    J = np.array([m.getDirectionalDerivative(ders, [s], [1.0]) for s in states]).T
    m.terminate()
    m.freeInstance()
    lin = MODES.linearize(train_fmu_path, two_body())
    # The gearbox's states: W_ext, W_loss, then each coordinate's value and rate.
    jt = lin["J"]
    gb_coord = J[2:, 2:]
    order = [0, 2, 1, 3]  # value1, value2, rate1, rate2 -> interleaved
    want = jt[np.ix_(order, order)]
    assert np.allclose(gb_coord, want, rtol=1e-12, atol=1e-12 * np.max(np.abs(want))), \
        (gb_coord, want)


def test_modes_of_a_pinion_on_its_bearing(train_fmu_path):
    """tools/modes.py with a lateral body (lateral.md section 5): the pair of
    test_modes_of_a_pair_and_a_chain with the pinion on a bearing (k_x, k_y), lumped mesh k.

    With q the pinion's (x, y) the forward penetration is rAb theta_A - rBb theta_B + n . q (the
    sense of each term changes no frequency: only their squares enter), n = (sin a_w, -cos a_w)
    for O_B on the x axis, so K = k g g^T + diag(0, 0, k_x, k_y) with g = (rAb, -rBb, n_x, n_y)
    over M = diag(J_A, J_B, m, m): a rigid rotation and three modes. The Jacobian is exact to
    1e-8 for a linear law, so are the frequencies to 1e-7. The modes mix rotation and
    translation: the pinion is the only central member that moves sideways."""
    kx, ky, m = 2e8, 5e7, 3.0
    sv = dict(two_body(), **{"body[1].lateral": True, "body[1].m": m, "body[1].k_x": kx,
                             "body[1].k_y": ky})
    lin = MODES.linearize(train_fmu_path, sv)
    ms = MODES.modes(lin, sv)
    md = fmpy.read_model_description(train_fmu_path)
    res = fmpy.simulate_fmu(train_fmu_path, model_description=md, start_values=sv, stop_time=1e-6,
                            output_interval=1e-6, output=["mesh[1].rAb", "mesh[1].rBb",
                                                          "mesh[1].alpha_w"])
    ra, rb, aw = (float(res[n][0]) for n in ("mesh[1].rAb", "mesh[1].rBb", "mesh[1].alpha_w"))
    g = np.array([ra, -rb, math.sin(aw), -math.cos(aw)])
    stiff = K * np.outer(g, g) + np.diag([0.0, 0.0, kx, ky])
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(np.diag([0.4, 2.0, m, m]), stiff)).real)
    want = [math.sqrt(max(x, 0.0)) / (2 * math.pi) for x in w2]
    fs = [md_["f"] for md_ in ms]
    assert len(fs) == 4 and abs(fs[0]) < 1e-6 * want[-1], fs
    for f, w in zip(fs[1:], want[1:]):
        assert abs(f - w) <= 1e-7 * w, (fs, want)
    assert {md_["kind"] for md_ in ms[1:]} == {"mixed"}, [md_["kind"] for md_ in ms]


def test_lin_parker_frequencies_and_multiplicities_through_the_fmu(train_fmu_path):
    """lateral.md section 7 through the FMU: Lin & Parker's (1999) 4-planet set with every member
    lateral (7 bodies, 21 coordinates: past the compact state, on the full one) and lumped meshes,
    linearized by the FMU's directional derivatives at the balance its static start finds, read
    by tools/modes.py.
    The 21 frequencies match the published ones to 0.1 % (the reference's own, same parameters,
    reach 0.037 %: test_lateral_ref), and the modal structure holds: a rigid rotation, 5
    rotational modes, 6 double translational ones and N - 3 = 1 copy of each of the 3 planet
    modes. The Jacobian of a linear law is exact to about 1e-8 (central differences of an affine
    map, rounding only), so a double mode's two frequencies agree to 1e-6."""
    from test_lateral_ref import LIN_PARKER_HZ, lin_parker

    sv = lin_parker()
    ms = MODES.modes(MODES.linearize(train_fmu_path, sv), sv)
    assert len(ms) == 21 and ms[0]["kind"] == "rigid rotation", [m["kind"] for m in ms]
    groups = MODES.multiplicities(ms[1:], rel=1e-6)
    want = sorted([(f, 1, "rotational") for f in LIN_PARKER_HZ["rotational"][1:]]
                  + [(f, 2, "translational") for f in LIN_PARKER_HZ["translational"]]
                  + [(f, 1, "planet") for f in LIN_PARKER_HZ["planet"]])
    assert [(n, kind) for _, n, kind in groups] == [(n, kind) for _, n, kind in want], groups
    for (f, _, _), (w, _, _) in zip(groups, want):
        assert abs(f / w - 1.0) < 1e-3, (groups, want)
