//! SpurGearMesh as a rig of `rig_fmu`: the paper's two wheels (`PaperRig`) behind the generic
//! FMI instance (`rig_fmu::RigInstance`, which holds the get/set plumbing, the stepping, the
//! Model Exchange glue and the FMU state's snapshot for every rig). Here is only what is the
//! mesh's own: how the run is built from the parameters, its outputs (`outputs`), the energy
//! outputs computed when read, the inputs' interpolation (fmi2SetRealInputDerivatives) and the
//! payload of its serialized FMU states (`fmu_state`). The FMI state machine around it is
//! `fmi2_slave::Instance`.

use super::{fmu_state, outputs};
use crate::driver::simulation::Simulation;
use crate::driver::Stats;
use crate::model::mesh::LawOutOfRange;
use crate::model::paper_rig::statics::static_dte_start;
use crate::model::paper_rig::Ramp;
use crate::model::Loads;
use crate::model::{PaperRig, State};
use crate::variables::{
    Calculated, Inputs, Locals, Outputs, Params, Var, GUID, LOG_CATEGORIES, MODEL_IDENTIFIER,
};
use crate::variables::{N_EVENT_INDICATORS, STATES};
use fmi2_slave::fmu_state::{Reader, Writer};
use rig_fmu::instance::real_var;
use rig_fmu::{Rig, Run};

// The event indicators are the mesh's event functions.
const _: () = assert!(N_EVENT_INDICATORS == crate::model::contact::N_EVENTS);
const _: () = assert!(STATES.len() == crate::driver::exchange::ME_STATE.len());

pub use fmi2_slave::instance::{allowed, error, CallResult, Failure, FmiState};
pub use rig_fmu::instance::LOG_SOLVER;

rig_fmu::rig_table!(MeshTable, crate::variables);

/// The paper's rig as an FMU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshRig;

/// The model behind an FMU instance.
pub type SpurGearMesh = rig_fmu::RigInstance<MeshRig>;
/// What an FMU state holds: everything that determines how the instance continues (`extra`:
/// the inputs' interpolation, fmi2SetRealInputDerivatives; all zero: held inputs).
pub type Snapshot = rig_fmu::Snapshot<MeshRig>;

fn loads(s: &Snapshot) -> Loads {
    gear_model::table::loads(&s.params, &s.inputs)
}

fn active_ramp(s: &Snapshot) -> Option<Ramp> {
    s.extra.is_active().then_some(s.extra)
}

/// The position of an input in `Ramp` (inputs in the table's order).
fn ramp_slot(v: Var) -> Option<usize> {
    match v {
        Var::tau_A => Some(0),
        Var::tau_B => Some(1),
        Var::alpha_housing => Some(2),
        Var::a_housing_x => Some(3),
        _ => None,
    }
}

impl Rig for MeshRig {
    type Table = MeshTable;
    type Sim = Simulation;
    type Extra = Ramp;
    type Cache = ();

    const MODEL_NAME: &'static str = MODEL_IDENTIFIER;
    const LOG_CATEGORIES: &'static [&'static str] = LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = *b"SGMSTATE";
    const STATE_FORMAT_VERSION: u32 = fmu_state::FORMAT_VERSION;
    const N_EVENT_INDICATORS: usize = N_EVENT_INDICATORS;
    const EVENT_INDICATOR_VR0: u32 = crate::variables::EVENT_INDICATOR_VR0;
    const STATES: &'static [(Var, Var)] = STATES;

    fn guid() -> &'static str {
        GUID
    }

    fn rel_tol(p: &Params) -> f64 {
        p.rel_tol
    }

    fn validate(p: &Params) -> Result<(), String> {
        gear_model::table::validate(p).map_err(|e| e.message)
    }

    fn build(s: &Snapshot, rel_tol: f64, _: &()) -> Result<Simulation, String> {
        let solved = match s.params.static_start {
            true => Some(static_start(s)?),
            false => None,
        };
        let p = started_at(&s.params, solved);
        let mut sim = gear_model::table::simulation(&p, &s.inputs, s.start_time, rel_tol)
            .map_err(|e| e.message)?;
        sim.rig.static_dte = solved;
        if let Some(stop) = s.stop_time {
            sim.set_stop_time(stop);
        }
        if let Some(r) = active_ramp(s) {
            sim.set_loads(loads(s), Some(r));
        }
        Ok(sim)
    }

    fn apply_loads(s: &mut Snapshot, _: &()) {
        let (loads, ramp) = (loads(s), active_ramp(s));
        if let Some(sim) = s.sim.as_mut() {
            sim.set_loads(loads, ramp);
        }
        if let Some(ex) = s.me.as_mut() {
            ex.set_loads(loads);
        }
    }

    /// A value set for an input holds from now on until derivatives are given for it.
    fn on_set(ramp: &mut Ramp, v: Var, now: f64) {
        if let Some(k) = ramp_slot(v) {
            (ramp.t0[k], ramp.rate[k], ramp.curvature[k]) = (now, 0.0, 0.0);
        }
    }

    fn write_outputs(run: Run<'_, MeshRig>, out: &mut Outputs, _: &()) -> Result<(), String> {
        match run {
            Run::Exchange(ex) => outputs::write_exchange(ex, out),
            Run::Sim(sim) => outputs::write(sim, out),
        }
        .map_err(|e| e.to_string())
    }

    /// The energy account, computed on the first read of one of its outputs after each change.
    fn is_lazy(v: Var) -> bool {
        outputs::is_energy(v)
    }

    fn write_lazy(m: &PaperRig, y: &State, o: &mut Outputs) -> Result<(), String> {
        outputs::write_energy(m, y, o).map_err(|e| e.to_string())
    }

    fn locals(m: &PaperRig, y: &State) -> Result<Locals, LawOutOfRange> {
        outputs::locals(m, y)
    }

    fn calculated(m: &PaperRig, _: &()) -> Calculated {
        outputs::calculated(m)
    }

    fn init_warnings(sim: &Simulation) -> Vec<String> {
        sim.rig.geo.warnings.clone()
    }

    fn solver_summary(t_end: f64, s: &Stats) -> String {
        format!(
            "t = {t_end}: {} steps, {} rejected, {} rhs evaluations, {} Jacobians, {} factorizations, {} events so far",
            s.steps, s.rejected, s.rhs_evals, s.jac_evals, s.factorizations, s.events
        )
    }

    fn check_model_exchange(s: &Snapshot) -> Result<(), Failure> {
        if s.extra.is_active() {
            return Err(error(
                "input derivatives are a Co-Simulation feature; a Model Exchange master sets the inputs".into(),
            ));
        }
        Ok(())
    }

    /// Input derivatives at the current time (canInterpolateInputs): order 1 (rate) or 2
    /// (curvature) of tau_A, tau_B, alpha_housing, a_housing_x. The input is re-based to now
    /// first, so a derivative given without a new value continues from the input's current
    /// value. All are checked before any is applied.
    fn set_real_input_derivatives(
        i: &mut SpurGearMesh,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<(), Failure> {
        let now = fmi2_slave::Slave::time(i);
        let (mut inputs, mut ramp): (Inputs, Ramp) = (i.snap.inputs.clone(), i.snap.extra);
        for ((&vr, &order), &x) in vrs.iter().zip(orders).zip(values) {
            let v = real_var::<MeshRig>(vr)?;
            let name = v.info().name;
            let k = ramp_slot(v).ok_or_else(|| {
                error(format!(
                    "{name} (value reference {vr}) is not a Real input: it has no input derivative"
                ))
            })?;
            if !(order == 1 || order == 2) {
                return Err(error(format!(
                    "{name}: derivative order {order} is not supported (1 or 2)"
                )));
            }
            if !x.is_finite() {
                return Err(error(format!(
                    "{name}: derivative of order {order} = {x}: must be finite"
                )));
            }
            let u = inputs.get_real(v).expect("a Real input");
            let (u_now, rate_now) = ramp.extrapolate(k, u, now);
            inputs.set_real(v, u_now);
            ramp.t0[k] = now;
            ramp.rate[k] = rate_now;
            if order == 1 {
                ramp.rate[k] = x;
            } else {
                ramp.curvature[k] = x;
            }
        }
        i.snap.inputs = inputs;
        i.snap.extra = ramp;
        i.stale();
        let (loads, ramp) = (loads(&i.snap), active_ramp(&i.snap));
        if let Some(sim) = i.snap.sim.as_mut() {
            sim.set_loads(loads, ramp);
        }
        Ok(())
    }

    fn encode(s: &Snapshot, w: &mut Writer) {
        fmu_state::write(w, s)
    }

    fn decode(r: &mut Reader) -> Result<Snapshot, String> {
        fmu_state::read(r)
    }
}

/// The dte_start at which the start loads balance (parameter `static_start`).
fn static_start(s: &Snapshot) -> Result<f64, String> {
    let spec = gear_model::table::rig(&s.params).map_err(|e| e.message)?;
    static_dte_start(&spec, &loads(s)).map_err(|e| e.message)
}

/// The parameters with the dte_start a static start solved for, if any.
pub(crate) fn started_at(p: &Params, solved: Option<f64>) -> Params {
    Params {
        dte_start: solved.unwrap_or(p.dte_start),
        ..p.clone()
    }
}
