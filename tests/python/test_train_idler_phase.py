"""Idler phasing (gear-train.md section 7) on the gear-train FMU itself: the closed form
train_ref.idler_switch_phase against the switches the FMU makes.

    .venv/bin/python -m pytest tests/python/test_train_idler_phase.py

The FMU is conftest's train_fmu_path (packaged from the working tree once per session).

The scene is scenes/train/idler.toml (body 1 drives the idler, body 2, which drives body 3) with
mesh 2's centre line turned to each of IDLER_BETAS, started at train_ref.quasi_static_start.  The
FMU (Co-Simulation, fmpy.simulate_fmu) runs STOP_TIME (about six mesh periods of the idler) on an
output grid of OUTPUT_INTERVAL at rel_tol REL_TOL.

SWITCH (idler_switch_phase's docstring): a forward pair entering the gate at point a, i.e. the
entering object's s_A - delta crossing s_a upward (s_A = mesh[m].s_f1 or s_f2, delta = mesh[m].dte,
the penetration shared by all pairs).  The FMU's own switch is the rise of mesh[m].n_fwd from 1 to
2; test_switches_are_gate_entries_at_point_a checks that every rise of n_fwd while in contact is
such an entry (not a re-contact after a separation, not a window event) and that every such entry
while in contact is a rise.  PHASE = (idler angle at the switch of mesh 2 following a switch of
mesh 1 - idler angle at that switch of mesh 1) / (2 pi / z_idler): body[2].theta, exact in angle
(no steady-speed assumption), compared with idler_switch_phase(sv, delta2 = mesh 2's dte at its
switch).

Every bound is derived below from the output grid, the integrator's tolerance or rounding; none is
read off a run.
"""

import math
import os
import sys

import fmpy
import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests"))

from reference_model import train_ref as T  # noqa: E402

IDLER_BETAS = (1.0, 2.3, 3.9)      # mesh[2].center_angle [rad]; the phases are 0.91, 0.33, 0.22
STOP_TIME = 0.02                   # about 6.4 mesh periods of the idler (2 pi/(31 x 64.5) = 3.1 ms)
OUTPUT_INTERVAL = 1e-6             # the grid: 64.5e-6 rad of idler angle = 3.2e-4 of dz per step
REL_TOL = 1e-9
MIN_CHECKED = 5                    # switch pairs checked per angle (about 6 fit in STOP_TIME)

OUTPUTS = ["body[2].theta"] + [
    f"mesh[{m}].{v}" for m in (1, 2)
    for v in ("n_fwd", "s_f1", "s_f2", "dte", "s_a", "base_pitch", "rAb", "rBb", "contact_ratio",
              "contact_objects_per_flank")]


# ------------------------------------------------------------------------------ the runs
@pytest.fixture(scope="module")
def train_unzip_dir(train_fmu_path, tmp_path_factory):
    return fmpy.extract(str(train_fmu_path),
                        unzipdir=str(tmp_path_factory.mktemp("SpurGearTrainIdler")))


@pytest.fixture(scope="module")
def train_md(train_unzip_dir):
    return fmpy.read_model_description(train_unzip_dir)


@pytest.fixture(scope="module", params=IDLER_BETAS, ids=lambda b: f"beta2={b}")
def idler_fmu_run(request, train_unzip_dir, train_md):
    sv = dict(T.load_scene("idler")["start_values"])
    sv["mesh[2].center_angle"] = request.param
    sv = T.quasi_static_start(sv)
    res = fmpy.simulate_fmu(train_unzip_dir, model_description=train_md,
                            start_values={**sv, "rel_tol": REL_TOL}, stop_time=STOP_TIME,
                            output_interval=OUTPUT_INTERVAL, output=OUTPUTS)
    return sv, Run(res)


class Run:
    """The FMU's output on the grid, with the switches of each mesh located on it."""

    def __init__(self, res):
        self.t = np.asarray(res["time"], dtype=float)
        self.theta = np.asarray(res["body[2].theta"], dtype=float)
        self.col = {name: np.asarray(res[name], dtype=float) for name in OUTPUTS}
        self.const = {name: float(self.col[name][0]) for name in OUTPUTS
                      if name.split(".")[1] in ("s_a", "base_pitch", "rAb", "rBb", "contact_ratio",
                                                "contact_objects_per_flank")}

    def n_fwd(self, m):
        return self.col[f"mesh[{m}].n_fwd"].astype(int)

    def gate_margins(self, m):
        """s_A - delta - s_a of objects f1 and f2 of mesh m (>= 0: inside the gate past point a)."""
        d, sa = self.col[f"mesh[{m}].dte"], self.const[f"mesh[{m}].s_a"]
        return [self.col[f"mesh[{m}].s_{o}"] - d - sa for o in ("f1", "f2")]

    def geometric_entries(self, m):
        """Rows k such that an object's s_A - delta crosses s_a upward in (t[k-1], t[k]], with
        (k, object index) - contact or not.  A window event moves an object by m_c p_b, so a
        step of more than half a base pitch is a jump, not a crossing."""
        pb = self.const[f"mesh[{m}].base_pitch"]
        out = []
        for j, g in enumerate(self.gate_margins(m)):
            k = np.nonzero((g[:-1] < 0.0) & (g[1:] >= 0.0) & (np.abs(np.diff(g)) < 0.5 * pb))[0]
            out += [(int(kk) + 1, j) for kk in k]
        return sorted(out)

    def contact_rises(self, m):
        """Rows k where n_fwd rises while the flank is in contact (n_fwd[k-1] >= 1)."""
        n = self.n_fwd(m)
        return [int(k) + 1 for k in np.nonzero((n[1:] > n[:-1]) & (n[:-1] >= 1))[0]]

    def fmu_switches(self, m):
        """The FMU's switches of mesh m (rises of n_fwd in contact), each with the geometric
        entry it belongs to (row within +-1: the FMU locates its gate event on its own dense
        output, the grid rows come from the same trajectory, so the two can straddle a grid time
        only when the event is within a rounding distance of it)."""
        geo = self.geometric_entries(m)
        out = []
        for k in self.contact_rises(m):
            match = [(kg, j) for kg, j in geo if abs(kg - k) <= 1]
            out.append((k, match[0] if match else None))
        return out


def next_mesh2_switch(run, k1):
    """The FMU switch of mesh 2 that follows the mesh-1 switch at row k1: the next geometric entry
    of mesh 2 (contact or not), and the FMU's switch at it, or None when mesh 2 was separated
    there (no rise of n_fwd: the FMU's switch is not observable, the pair is skipped)."""
    geo = [(kg, j) for kg, j in run.geometric_entries(2) if kg >= k1]
    if not geo:
        return None, None
    kg, j = geo[0]
    for k, match in run.fmu_switches(2):
        if match == (kg, j):
            return (kg, j), k
    return (kg, j), None


def dz_of(sv):
    return 2.0 * math.pi / sv["mesh[1].zB"]


def wrapped(x):
    """x mod 1 in [-0.5, 0.5): phases are defined mod 1."""
    return (x + 0.5) % 1.0 - 0.5


# ------------------------------------------------------------------------------ the checks
def test_scene_is_in_the_closed_forms_range(idler_fmu_run):
    """idler_switch_phase holds for m_c = ceil(eps) (contacts_per_flank = 0) and 1 < eps < 2,
    for an idler turning forward; the FMU's calculated parameters say so."""
    sv, run = idler_fmu_run
    for m in (1, 2):
        eps = run.const[f"mesh[{m}].contact_ratio"]
        assert 1.0 < eps < 2.0, (m, eps)
        assert run.const[f"mesh[{m}].contact_objects_per_flank"] == 2.0
    assert np.all(np.diff(run.theta) > 0.0)      # the idler turns forward at every step
    assert sv["mesh[1].zB"] == sv["mesh[2].zA"]


def test_switches_are_gate_entries_at_point_a(idler_fmu_run):
    """The FMU's n_fwd rises (in contact) are exactly the pairs entering at point a: every rise
    from >= 1 is by one pair, from 1 to 2, at a geometric entry (row within +-1, see
    Run.fmu_switches); every geometric entry with the flank in contact on the rows around it
    (n_fwd >= 1 from k-2 to k+1) is such a rise.  And one entry per mesh period: consecutive
    geometric entries of a mesh are one tooth of the idler apart, dz within two grid steps of
    idler angle (each entry located to one step), plus for mesh 2 the shift by its penetration:
    its entry condition s_A - delta = s_a moves by d delta/rAb2 in idler angle when delta changes
    between the two entries (taken on the rows, plus its change over each bracketing step)."""
    sv, run = idler_fmu_run
    dz = dz_of(sv)
    for m in (1, 2):
        n = run.n_fwd(m)
        sw = run.fmu_switches(m)
        assert len(sw) >= MIN_CHECKED, (m, len(sw))
        for k, match in sw:
            assert (n[k - 1], n[k]) == (1, 2), (m, run.t[k], n[k - 1], n[k])
            assert match is not None, (m, run.t[k], "n_fwd rose away from point a")
        rises = {k for k, _ in sw}
        geo = run.geometric_entries(m)
        for kg, _j in geo:
            if kg >= 2 and kg + 1 < len(n) and n[kg - 2:kg + 2].min() >= 1:
                assert rises & {kg - 1, kg, kg + 1}, (m, run.t[kg], "entry at a without a rise")
        steps = np.diff(run.theta)
        d = run.col[f"mesh[{m}].dte"]
        for (ka, _), (kb, _) in zip(geo, geo[1:]):
            gap = run.theta[kb] - run.theta[ka]
            bound = steps[ka - 1] + steps[kb - 1]
            if m == 2:
                bound += (abs(d[kb] - d[ka]) + abs(d[ka] - d[ka - 1]) + abs(d[kb] - d[kb - 1])) \
                    / run.const["mesh[2].rAb"]
            assert abs(gap - dz) <= bound, (m, run.t[ka], gap, dz, bound)


def grid_phase_checks(sv, run):
    """(t1, phase on the grid, closed form, bound) for each switch of mesh 1 and the next of
    mesh 2; see test_idler_phase_on_the_output_grid for the bound."""
    dz = dz_of(sv)
    pb2 = run.const["mesh[2].base_pitch"]
    dte2 = run.col["mesh[2].dte"]
    th = run.theta
    # Allowance for the FMU's event location: it finds each gate event to a few ulp on its dense
    # output, whose angle error is bounded by the error control, rel_tol relative on angles of at
    # most 2 pi here (the idler turns 1.3 rad, body 1 2 rad); in phase rel_tol 2 pi/dz, 3e-8.
    integ = REL_TOL * 2.0 * math.pi / dz
    out = []
    for k1, _ in run.fmu_switches(1):
        _geo2, k2 = next_mesh2_switch(run, k1)
        if k2 is None:
            continue
        mid1 = 0.5 * (th[k1 - 1] + th[k1])
        mid2 = 0.5 * (th[k2 - 1] + th[k2])
        ph = (mid2 - mid1) / dz
        want = T.idler_switch_phase(sv, delta2=0.5 * (dte2[k2 - 1] + dte2[k2]))
        bound = ((th[k1] - th[k1 - 1]) + (th[k2] - th[k2 - 1])) / (2.0 * dz) \
            + abs(dte2[k2] - dte2[k2 - 1]) / (2.0 * pb2) + integ
        out.append((run.t[k1], ph, want, bound))
    return out


def test_idler_phase_on_the_output_grid(idler_fmu_run):
    """The closed form against the FMU's switches located on the output grid.

    Each switch lies between the two grid rows where n_fwd rises, so its idler angle lies in
    [theta[k-1], theta[k]] (theta increases); the midpoint is off by at most half that step, and
    the phase (theta2 - theta1)/dz by at most (step1 + step2)/(2 dz): 64.5 rad/s x 1e-6 s / 0.2027
    rad = 3.2e-4 of a period.  The closed form takes mesh 2's penetration at its switch; dte2 is
    taken at the midpoint of the two rows, off by at most half its change over the step (dte is
    C1 - its second derivative jumps at events but stays bounded - so within one step it stays
    within its two end values up to h^2/8 max|dte''| ~ 1e-12 m), and the phase moves by
    delta2/p_b2 (idler_switch_phase's docstring): |d dte2|/(2 p_b2).  Plus the event-location
    allowance of grid_phase_checks (3e-8).  The integrator's error in the trajectory does not
    enter otherwise: both switch conditions are geometric functions of the idler's angle (and of
    mesh 2's dte), which the FMU outputs from the same state.  The bound (~3.2e-4) is 150 times
    below the 0.05 of a period that a wrong term of the closed form would move (the thickness term
    alone is ~0.4 of a period)."""
    sv, run = idler_fmu_run
    checks = grid_phase_checks(sv, run)
    assert len(checks) >= MIN_CHECKED, len(checks)
    for t1, ph, want, bound in checks:
        assert bound < 1e-3                      # the argument's size: a fine grid, resolved
        assert -bound <= ph < 1.0 + bound, (t1, ph)   # the NEXT switch of mesh 2
        assert abs(wrapped(ph - want)) <= bound, (t1, ph, want, bound)


def test_idler_phase_refined_by_the_contact_coordinates(idler_fmu_run):
    """The same switches, their idler angles refined exactly: s_A - delta of an object is linear
    in the idler's angle (involutes roll on the base circles: mesh 1, idler = B, s_B = s_A - delta
    moves by rBb1 per radian of the idler; mesh 2, idler = A, s_A moves by rAb2 per radian), so the
    angle where the entering object's s_A - delta equals s_a is theta[k] - margin[k]/r_b, with
    mesh 2's delta held at dte2[k] - and the closed form is taken at delta2 = dte2[k], the same
    condition.  Only rounding remains: angles of at most 2 pi and lengths of at most 0.05 m through
    a few dozen operations, ~1e-14 rad or 1e-17 m, below 1e-13 of a period; bound 1e-10."""
    sv, run = idler_fmu_run
    dz = dz_of(sv)
    th = run.theta
    dte2 = run.col["mesh[2].dte"]
    m1_margins, m2_margins = run.gate_margins(1), run.gate_margins(2)
    rB1, rA2 = run.const["mesh[1].rBb"], run.const["mesh[2].rAb"]
    checked = 0
    for k1, (kg1, j1) in run.fmu_switches(1):
        geo2, k2 = next_mesh2_switch(run, k1)
        if k2 is None:
            continue
        kg2, j2 = geo2
        theta1 = th[kg1] - m1_margins[j1][kg1] / rB1
        theta2 = th[kg2] - m2_margins[j2][kg2] / rA2
        ph = (theta2 - theta1) / dz
        want = T.idler_switch_phase(sv, delta2=dte2[kg2])
        assert abs(wrapped(ph - want)) <= 1e-10, (run.t[kg1], ph, want)
        checked += 1
    assert checked >= MIN_CHECKED, checked
