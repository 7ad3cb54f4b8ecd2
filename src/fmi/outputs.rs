//! The FMU's outputs and calculated parameters, assembled from the model's readout and the
//! driver's counters: the one place that maps model quantities onto variable-table names.

use crate::driver::exchange::{Exchange, ME_STATE};
use crate::driver::simulation::Simulation;
use crate::driver::Stats;
use crate::model::mesh::LawOutOfRange;
use crate::model::paper_rig::{Energy, Readout, DDTE, NY, V_S};
use crate::model::statistics::Summary;
use crate::model::{PaperRig, State};
use crate::variables::{Calculated, Locals, Outputs, Var, STATES};

/// A counter as an FMI Integer, saturating at 2^31 - 1.
fn saturate(n: u64) -> i32 {
    n.min(i32::MAX as u64) as i32
}

/// The outputs at the simulation's current time.
pub fn outputs(sim: &Simulation) -> Result<Outputs, LawOutOfRange> {
    let mut o = Outputs::default();
    write(sim, &mut o)?;
    write_energy(&sim.rig, &sim.driver.state(), &mut o)?;
    Ok(o)
}

/// Writes the outputs at the simulation's current time into `o` (the FMU reads them after
/// every communication step; in place saves two copies of the struct), all but the energy
/// account (`write_energy`).
pub fn write(sim: &Simulation, o: &mut Outputs) -> Result<(), LawOutOfRange> {
    let r = sim.rig.readout(&sim.driver.state())?;
    let summary = sim.statistics().map(|s| s.summary()).unwrap_or_default();
    assemble(&r, &summary, &sim.driver.stats, o);
    Ok(())
}

/// `write` for Model Exchange: at the state the master set, with the statistics up to its
/// last completed step and its counts of steps and evaluations.
pub fn write_exchange(ex: &Exchange, o: &mut Outputs) -> Result<(), LawOutOfRange> {
    let r = ex.rig.readout(&ex.y)?;
    let summary = ex
        .rig
        .stats
        .as_ref()
        .map(|s| s.summary())
        .unwrap_or_default();
    assemble(&r, &summary, &ex.stats, o);
    Ok(())
}

/// The outputs that `write` leaves out: they cost a law evaluation per flank (the elastic
/// energy), so the FMU computes them when a master reads one (`is_energy`).
pub fn write_energy(mesh: &PaperRig, y: &State, o: &mut Outputs) -> Result<(), LawOutOfRange> {
    let e: Energy = mesh.energy(y)?;
    o.E_kin = e.e_kin;
    o.E_el = e.e_el;
    o.energy_residual = e.residual;
    Ok(())
}

/// The locals at state y: the states that are not outputs, and every state's derivative (a
/// right-hand-side evaluation, so only when a master reads one).
pub fn locals(mesh: &PaperRig, y: &State) -> Result<Locals, LawOutOfRange> {
    let mut dy = [0.0; NY];
    mesh.rhs(y, &mut dy)?;
    let mut l = Locals {
        dte_rate: y[DDTE],
        v_slider: y[V_S],
        ..Locals::default()
    };
    for (k, &(_, der)) in STATES.iter().enumerate() {
        l.set_real(der, dy[ME_STATE[k]]);
    }
    Ok(l)
}

/// The outputs `write_energy` computes.
pub fn is_energy(v: Var) -> bool {
    matches!(v, Var::E_kin | Var::E_el | Var::energy_residual)
}

/// The outputs of a readout, with the run's statistics and the integrator's counters.
#[inline]
pub fn assemble(r: &Readout, run: &Summary, st: &Stats, o: &mut Outputs) {
    // Field by field: a struct literal here was built aside and copied.
    o.theta_A = r.theta_a;
    o.theta_B = r.theta_b;
    o.w_A = r.w_a;
    o.w_B = r.w_b;
    o.dte = r.dte;
    o.P_loss = r.p_loss;
    o.W_ext = r.w_ext;
    o.W_loss = r.w_loss;
    o.E_gate = r.e_gate;
    o.n_events = saturate(r.n_events);
    o.n_impacts = saturate(r.n_impacts);
    o.x_slider = r.x_slider;
    o.set_mesh(&r.mesh, run);
    o.n_steps = saturate(st.steps);
    o.n_rejected_steps = saturate(st.rejected);
    o.n_rhs_evaluations = saturate(st.rhs_evals);
    o.n_jacobians = saturate(st.jac_evals);
    o.n_factorizations = saturate(st.factorizations);
}

/// The calculated parameters: the pair's geometry.
pub fn calculated(mesh: &PaperRig) -> Calculated {
    Calculated::of_geometry(&mesh.geo)
}
