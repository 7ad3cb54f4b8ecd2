//! The FMI instance of a gear rig, written once for every rig: `RigInstance<R>` is the
//! `fmi2_slave::Slave` of SpurGearMesh (the paper's two wheels) and of SpurGearTrain, and of
//! any further rig. It holds the parameters and inputs, the experiment, the run (the driver's
//! Co-Simulation run, or Model Exchange's `Exchange`) and the outputs computed on demand, and
//! does the get/set plumbing, the stepping, the Model Exchange glue and the FMU state's
//! snapshot. A rig (`Rig`) declares its variable table (`table::Table`, from the generated
//! module by `rig_table!`) and its model: how to build the run from the parameters, how to read
//! the outputs, and the payload of its serialized FMU states.
//!
//! Three layers stay apart: the model (gear_model::model) and the driver
//! (gear_model::driver: `RigSim` here is what the instance needs of a driver's run) know no
//! FMI; fmi2_slave knows no gear model; this crate joins them.

pub mod instance;
pub mod table;

pub use instance::{RigInstance, Run, Snapshot};
pub use table::{Info, Kind, Role, Table, Values};

use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::{error, Failure};
use gear_model::driver::exchange::{Exchange, ExchangeRig};
use gear_model::driver::simulation::Simulation;
use gear_model::driver::train_simulation::TrainSimulation;
use gear_model::driver::{DriverError, Stats, System};
use gear_model::model::mesh::{EventReport, LawOutOfRange};
use gear_model::model::train::Train;
use gear_model::model::PaperRig;

/// The model's state type.
pub type State<R> = <<<R as Rig>::Sim as RigSim>::Model as System>::State;
/// The model of a rig.
pub type Model<R> = <<R as Rig>::Sim as RigSim>::Model;
/// The table's types of a rig.
pub type Var<R> = <<R as Rig>::Table as Table>::Var;
pub type Params<R> = <<R as Rig>::Table as Table>::Params;
pub type Inputs<R> = <<R as Rig>::Table as Table>::Inputs;
pub type Outputs<R> = <<R as Rig>::Table as Table>::Outputs;
pub type Calculated<R> = <<R as Rig>::Table as Table>::Calculated;
pub type Locals<R> = <<R as Rig>::Table as Table>::Locals;

/// What the instance needs of a driver's Co-Simulation run of a rig's model.
pub trait RigSim: Clone + std::fmt::Debug + PartialEq {
    type Model: ExchangeRig + Clone + std::fmt::Debug + PartialEq;
    fn model(&self) -> &Self::Model;
    fn model_mut(&mut self) -> &mut Self::Model;
    fn into_model(self) -> Self::Model;
    fn time(&self) -> f64;
    /// Moves the time back to t (a step that failed inside the last internal step).
    fn set_time(&mut self, t: f64);
    fn state(&self) -> <Self::Model as System>::State;
    fn stats(&self) -> &Stats;
    fn needs_work(&self, t_end: f64) -> bool;
    fn advance(
        &mut self,
        t_end: f64,
        log: &mut dyn FnMut(f64, &EventReport),
    ) -> Result<(), DriverError<LawOutOfRange>>;
    fn make_restart_point_if_needed(&mut self);
    /// Whether the model describes its events in words (the log's logEvents).
    fn describe_events(model: &mut Self::Model, on: bool);
}

impl RigSim for Simulation {
    type Model = PaperRig;
    fn model(&self) -> &PaperRig {
        &self.rig
    }
    fn model_mut(&mut self) -> &mut PaperRig {
        &mut self.rig
    }
    fn into_model(self) -> PaperRig {
        self.into_rig().0
    }
    fn time(&self) -> f64 {
        Simulation::time(self)
    }
    fn set_time(&mut self, t: f64) {
        Simulation::set_time(self, t)
    }
    fn state(&self) -> gear_model::model::State {
        self.driver.state()
    }
    fn stats(&self) -> &Stats {
        &self.driver.stats
    }
    fn needs_work(&self, t_end: f64) -> bool {
        Simulation::needs_work(self, t_end)
    }
    fn advance(
        &mut self,
        t_end: f64,
        log: &mut dyn FnMut(f64, &EventReport),
    ) -> Result<(), DriverError<LawOutOfRange>> {
        Simulation::advance(self, t_end, log)
    }
    fn make_restart_point_if_needed(&mut self) {
        Simulation::make_restart_point_if_needed(self)
    }
    fn describe_events(model: &mut PaperRig, on: bool) {
        model.mesh.describe_events = on;
    }
}

impl RigSim for TrainSimulation {
    type Model = Train;
    fn model(&self) -> &Train {
        self.train()
    }
    fn model_mut(&mut self) -> &mut Train {
        self.train_mut()
    }
    fn into_model(self) -> Train {
        self.into_train()
    }
    fn time(&self) -> f64 {
        TrainSimulation::time(self)
    }
    fn set_time(&mut self, t: f64) {
        TrainSimulation::set_time(self, t)
    }
    fn state(&self) -> gear_model::model::train::State {
        TrainSimulation::state(self)
    }
    fn stats(&self) -> &Stats {
        TrainSimulation::stats(self)
    }
    fn needs_work(&self, t_end: f64) -> bool {
        TrainSimulation::needs_work(self, t_end)
    }
    fn advance(
        &mut self,
        t_end: f64,
        log: &mut dyn FnMut(f64, &EventReport),
    ) -> Result<(), DriverError<LawOutOfRange>> {
        TrainSimulation::advance(self, t_end, log)
    }
    fn make_restart_point_if_needed(&mut self) {
        TrainSimulation::make_restart_point_if_needed(self)
    }
    fn describe_events(model: &mut Train, on: bool) {
        for m in &mut model.meshes {
            m.describe_events = on;
        }
    }
}

/// A rig as an FMU: its table, its model, and what only it knows. Everything else is
/// `RigInstance`'s.
pub trait Rig: Clone + std::fmt::Debug + PartialEq + Sized + 'static {
    type Table: Table;
    /// The driver's run of the model.
    type Sim: RigSim;
    /// What the snapshot holds beyond the parameters, inputs, experiment and run (saved between
    /// the tolerance and the run; `()` saves nothing).
    type Extra: Clone + std::fmt::Debug + PartialEq + Default;
    /// What an instance derives once from the table (not saved).
    type Cache: Clone + std::fmt::Debug + Default;

    const MODEL_NAME: &'static str;
    const LOG_CATEGORIES: &'static [&'static str];
    const STATE_MAGIC: [u8; 8];
    const STATE_FORMAT_VERSION: u32;
    const N_EVENT_INDICATORS: usize;
    const EVENT_INDICATOR_VR0: u32;
    /// The model's states and their derivatives, as (state, derivative) locals: what
    /// directional derivatives read.
    const STATES: &'static [(Var<Self>, Var<Self>)];
    /// How many of them modelDescription.xml declares, the first: what a master integrates.
    const N_DECLARED_STATES: usize = Self::STATES.len();
    /// What to do instead when a model has more states in use than that (an error's advice).
    const MORE_STATES_ADVICE: &'static str = "";
    fn guid() -> &'static str;

    /// The rig's own relative tolerance (a master's tolerance can only tighten it).
    fn rel_tol(p: &Params<Self>) -> f64;
    /// Checks the parameters as a whole (after a set of parameters).
    fn validate(p: &Params<Self>) -> Result<(), String>;
    /// The same after a set of the `changed` parameters, the table valid before it: a rig
    /// whose checks are per parameter checks only what the set can have changed.
    fn validate_changed(p: &Params<Self>, _changed: &[Var<Self>]) -> Result<(), String> {
        Self::validate(p)
    }
    /// The run from the snapshot's parameters, inputs and experiment, at rel_tol.
    fn build(s: &Snapshot<Self>, rel_tol: f64, cache: &Self::Cache) -> Result<Self::Sim, String>;
    /// New inputs or tunable parameters after initialization: the run takes them.
    fn apply_loads(s: &mut Snapshot<Self>, cache: &Self::Cache);
    /// A variable was set (before the parameters are checked): `extra` may follow it.
    fn on_set(_extra: &mut Self::Extra, _v: Var<Self>, _now: f64) {}
    /// The outputs at the run's current point (the lazy ones need not be written).
    fn write_outputs(
        run: Run<'_, Self>,
        out: &mut Outputs<Self>,
        cache: &Self::Cache,
    ) -> Result<(), String>;
    /// The first output that is NaN or infinite after `write_outputs`, with its name. A rig
    /// that writes only the outputs in use checks only those.
    fn first_non_finite(out: &Outputs<Self>, _cache: &Self::Cache) -> Option<(&'static str, f64)> {
        out.first_non_finite()
    }
    /// Outputs computed only when read (`write_lazy`).
    fn is_lazy(_v: Var<Self>) -> bool {
        false
    }
    fn write_lazy(
        _m: &Model<Self>,
        _y: &State<Self>,
        _o: &mut Outputs<Self>,
    ) -> Result<(), String> {
        Ok(())
    }
    /// The locals (Model Exchange's states and derivatives) at state y.
    fn locals(m: &Model<Self>, y: &State<Self>) -> Result<Locals<Self>, LawOutOfRange>;
    fn calculated(m: &Model<Self>, cache: &Self::Cache) -> Calculated<Self>;
    /// What is valid but unusual in the run just built.
    fn init_warnings(_sim: &Self::Sim) -> Vec<String> {
        Vec::new()
    }
    /// The logSolver line after a step to t_end.
    fn solver_summary(t_end: f64, s: &Stats) -> String;
    /// Refuses what Model Exchange cannot continue (before its run starts).
    fn check_model_exchange(_s: &Snapshot<Self>) -> Result<(), Failure> {
        Ok(())
    }
    /// fmi2SetRealInputDerivatives, for a rig that interpolates its inputs.
    fn set_real_input_derivatives(
        _i: &mut RigInstance<Self>,
        _vrs: &[u32],
        _orders: &[i32],
        _values: &[f64],
    ) -> Result<(), Failure> {
        Err(error(
            "canInterpolateInputs is false: input derivatives are not supported".into(),
        ))
    }
    /// The payload of a serialized FMU state, and back (checked).
    fn encode(s: &Snapshot<Self>, w: &mut Writer);
    fn decode(r: &mut Reader) -> Result<Snapshot<Self>, String>;
}

/// The Model Exchange run of a rig.
pub type ExchangeOf<R> = Exchange<Model<R>>;
