//! One FMU instance: the FMI 2.0 Co-Simulation state machine, parameter and input handling,
//! and stepping. Every exported function goes through `Instance::call`, which checks the
//! state in one place; a failing call leaves the values the instance had before it.

use super::logging::{Category, Logger};
use super::Status;
use crate::driver::simulation::Simulation;
use crate::driver::DriverError;
use crate::model::geometry;
use crate::model::Loads;
use crate::variables::{Causality, Inputs, Outputs, Params, Var, VarType, Variability};
use std::collections::HashSet;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FmiState {
    Instantiated = 1,
    InitializationMode = 2,
    StepComplete = 4,
    StepFailed = 8,
    Terminated = 16,
    Error = 32,
}

impl FmiState {
    pub fn from_bits(b: u64) -> Option<FmiState> {
        use FmiState::*;
        [
            Instantiated,
            InitializationMode,
            StepComplete,
            StepFailed,
            Terminated,
            Error,
        ]
        .into_iter()
        .find(|s| *s as u64 == b)
    }
}

/// Sets of states in which a function may be called (FMI 2.0 standard, section 4.2.4).
pub mod allowed {
    use super::FmiState::*;
    pub const INST: u32 = Instantiated as u32;
    pub const INIT: u32 = InitializationMode as u32;
    pub const DONE: u32 = StepComplete as u32;
    pub const FAIL: u32 = StepFailed as u32;
    pub const TERM: u32 = Terminated as u32;
    pub const ERR: u32 = Error as u32;
    pub const ANY: u32 = INST | INIT | DONE | FAIL | TERM | ERR;
    pub const GET: u32 = INIT | DONE | FAIL | TERM | ERR;
    pub const SET: u32 = INST | INIT | DONE;
    pub const STATUS: u32 = DONE | FAIL | TERM | ERR;
}

/// What an FMU state holds: everything that determines how the instance continues.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    pub state: FmiState,
    pub params: Params,
    pub inputs: Inputs,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub sim: Option<Simulation>,
}

pub struct Instance {
    pub(crate) magic: u64,
    pub log: Logger,
    pub snap: Snapshot,
    /// Outputs at the current time, computed on demand.
    outputs: Option<Outputs>,
    /// FMU states handed out by this instance (owned here, freed by fmi2FreeFMUstate or at free).
    pub(crate) fmu_states: HashSet<usize>,
}

pub const MAGIC: u64 = 0x5350_5552_4745_4152; // "SPURGEAR"

/// A function's failure: the status to return and the message to log.
pub struct Failure {
    pub status: Status,
    pub message: String,
}

pub type CallResult = Result<Status, Failure>;

pub fn error(message: String) -> Failure {
    Failure {
        status: Status::Error,
        message,
    }
}

impl Snapshot {
    pub fn fresh() -> Snapshot {
        Snapshot {
            state: FmiState::Instantiated,
            params: Params::default(),
            inputs: Inputs::default(),
            start_time: 0.0,
            stop_time: None,
            tolerance: None,
            sim: None,
        }
    }
}

impl Instance {
    pub fn new(log: Logger) -> Instance {
        Instance {
            magic: MAGIC,
            log,
            snap: Snapshot::fresh(),
            outputs: None,
            fmu_states: HashSet::new(),
        }
    }

    /// Runs one FMI function: checks the state, catches panics, logs failures.
    pub fn call(
        &mut self,
        func: &str,
        states: u32,
        body: impl FnOnce(&mut Instance) -> CallResult,
    ) -> Status {
        if states & self.snap.state as u32 == 0 {
            self.log.log(
                Status::Error,
                Category::Error,
                &format!("{func}: not allowed in state {:?}", self.snap.state),
            );
            return Status::Error;
        }
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| body(self)));
        let failure = match result {
            Ok(Ok(status)) => return status,
            Ok(Err(f)) => f,
            Err(_) => {
                error("internal error (panic caught at the C boundary); reset the instance".into())
            }
        };
        self.log.log(
            failure.status,
            Category::for_status(failure.status),
            &format!("{func}: {}", failure.message),
        );
        match failure.status {
            Status::Error | Status::Fatal => self.snap.state = FmiState::Error,
            Status::Discard => self.snap.state = FmiState::StepFailed,
            _ => {}
        }
        failure.status
    }

    fn tolerance(&self) -> f64 {
        self.snap.tolerance.unwrap_or(self.snap.params.rel_tol)
    }

    fn loads(&self) -> Loads {
        let (p, i) = (&self.snap.params, &self.snap.inputs);
        Loads {
            tau_a: i.tau_A,
            tau_b: i.tau_B,
            c_load: p.c_load,
            chi: p.chi,
            mu: p.mu,
            v_reg: p.v_reg,
        }
    }

    /// Builds the simulation from the parameters (at the end of initialization, or earlier when
    /// a master reads calculated values in initialization mode).
    fn build(&mut self) -> Result<&mut Simulation, Failure> {
        if self.snap.sim.is_none() {
            let s = &self.snap;
            let mut sim = Simulation::new(&s.params, &s.inputs, s.start_time, self.tolerance())
                .map_err(|e| error(e.message))?;
            if let Some(stop) = s.stop_time {
                sim.driver.t_stop = stop;
            }
            self.snap.sim = Some(sim);
            self.outputs = None;
        }
        Ok(self.snap.sim.as_mut().expect("just built"))
    }

    pub fn outputs(&mut self) -> Result<Outputs, Failure> {
        if let Some(o) = &self.outputs {
            return Ok(o.clone());
        }
        let o = self.build()?.outputs().map_err(|e| error(e.to_string()))?;
        self.outputs = Some(o.clone());
        Ok(o)
    }

    pub fn setup_experiment(
        &mut self,
        tol: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> CallResult {
        if let Some(t) = tol {
            if !(t >= 1e-14 && t <= 0.1) {
                return Err(error(format!("tolerance = {t}: must lie in [1e-14, 0.1]")));
            }
        }
        if !start.is_finite() {
            return Err(error(format!("startTime = {start}: must be finite")));
        }
        if let Some(s) = stop {
            if !(s >= start) || !s.is_finite() {
                return Err(error(format!(
                    "stopTime = {s}: must be finite and not before startTime = {start}"
                )));
            }
        }
        self.snap.tolerance = tol;
        self.snap.start_time = start;
        self.snap.stop_time = stop;
        self.snap.sim = None;
        self.outputs = None;
        Ok(Status::Ok)
    }

    pub fn exit_initialization(&mut self) -> CallResult {
        self.build()?;
        self.outputs()?;
        self.snap.state = FmiState::StepComplete;
        Ok(Status::Ok)
    }

    pub fn reset(&mut self) {
        self.snap = Snapshot::fresh();
        self.outputs = None;
    }

    pub fn restore(&mut self, s: &Snapshot) {
        self.snap = s.clone();
        self.outputs = None;
    }

    fn lookup(&self, vr: u32, ty: VarType) -> Result<Var, Failure> {
        let v = Var::from_vr(vr).ok_or_else(|| error(format!("unknown value reference {vr}")))?;
        let info = v.info();
        if info.ty != ty {
            return Err(error(format!(
                "{} (value reference {vr}) is {:?}, not {ty:?}",
                info.name, info.ty
            )));
        }
        Ok(v)
    }

    pub fn get_real(&mut self, vr: u32) -> Result<f64, Failure> {
        let v = self.lookup(vr, VarType::Real)?;
        self.value(
            v,
            |p| p.get_real(v),
            |i| i.get_real(v),
            |o| o.get_real(v),
            |c| c.get_real(v),
        )
    }

    pub fn get_integer(&mut self, vr: u32) -> Result<i32, Failure> {
        let v = self.lookup(vr, VarType::Integer)?;
        self.value(
            v,
            |p| p.get_integer(v),
            |i| i.get_integer(v),
            |o| o.get_integer(v),
            |c| c.get_integer(v),
        )
    }

    pub fn get_boolean(&mut self, vr: u32) -> Result<bool, Failure> {
        let v = self.lookup(vr, VarType::Boolean)?;
        self.value(
            v,
            |p| p.get_boolean(v),
            |i| i.get_boolean(v),
            |o| o.get_boolean(v),
            |c| c.get_boolean(v),
        )
    }

    fn value<T>(
        &mut self,
        v: Var,
        param: impl Fn(&Params) -> Option<T>,
        input: impl Fn(&Inputs) -> Option<T>,
        output: impl Fn(&Outputs) -> Option<T>,
        calc: impl Fn(&crate::variables::Calculated) -> Option<T>,
    ) -> Result<T, Failure> {
        let got = match v.info().causality {
            Causality::Parameter => param(&self.snap.params),
            Causality::Input => input(&self.snap.inputs),
            Causality::Output => output(&self.outputs()?),
            Causality::CalculatedParameter => calc(&self.build()?.mesh.calculated()),
        };
        Ok(got.expect("the generated table gives every variable a getter of its type"))
    }

    /// Checks that a variable may be set now to the value shown (for the message).
    fn settable(&self, v: Var, shown: &dyn std::fmt::Display) -> Result<(), Failure> {
        let info = v.info();
        let running = self.snap.state == FmiState::StepComplete;
        match (info.causality, info.variability) {
            (Causality::Output | Causality::CalculatedParameter, _) => Err(error(format!(
                "{} = {shown}: {} is a {:?}, it cannot be set",
                info.name, info.name, info.causality
            ))),
            (Causality::Parameter, Variability::Fixed) if running => Err(error(format!(
                "{} = {shown}: {} is a fixed parameter, it cannot be set after initialization",
                info.name, info.name
            ))),
            _ => Ok(()),
        }
    }

    /// Sets several variables at once: all are checked before any is applied.
    pub fn set_many<T: Copy + std::fmt::Display>(
        &mut self,
        ty: VarType,
        vrs: &[u32],
        values: &[T],
        check: impl Fn(T) -> bool,
        apply: impl Fn(&mut Params, &mut Inputs, Var, T),
    ) -> CallResult {
        let (mut params, mut inputs) = (self.snap.params.clone(), self.snap.inputs.clone());
        for (&vr, &x) in vrs.iter().zip(values) {
            let v = self.lookup(vr, ty)?;
            self.settable(v, &x)?;
            if !check(x) {
                return Err(error(format!(
                    "{} = {x}: the value must be finite",
                    v.info().name
                )));
            }
            apply(&mut params, &mut inputs, v, x);
        }
        geometry::validate(&params).map_err(|e| error(e.message))?;
        self.snap.params = params;
        self.snap.inputs = inputs;
        self.outputs = None;
        match self.snap.state {
            FmiState::StepComplete => {
                let loads = self.loads();
                if let Some(sim) = self.snap.sim.as_mut() {
                    sim.set_loads(loads);
                }
            }
            // Before the end of initialization the simulation is rebuilt from the parameters.
            _ => self.snap.sim = None,
        }
        Ok(Status::Ok)
    }

    pub fn do_step(&mut self, current: f64, h: f64) -> CallResult {
        let t = self
            .snap
            .sim
            .as_ref()
            .map_or(self.snap.start_time, |s| s.time());
        if !current.is_finite() || !h.is_finite() {
            return Err(error(format!("currentCommunicationPoint = {current}, communicationStepSize = {h}: must be finite")));
        }
        if !(h > 0.0) {
            return Err(error(format!(
                "communicationStepSize = {h}: must be positive"
            )));
        }
        // Masters accumulate time in floating point; a nanosecond-scale mismatch is rounding.
        if (current - t).abs() > 1e-9 * t.abs().max(1.0) {
            return Err(error(format!(
                "currentCommunicationPoint = {current} does not match the FMU's time {t}"
            )));
        }
        let t_end = current + h;
        if let Some(stop) = self.snap.stop_time {
            if t_end > stop * (1.0 + 1e-12) + 1e-12 {
                return Err(error(format!(
                    "step to {t_end} goes past the stopTime {stop} of fmi2SetupExperiment"
                )));
            }
        }
        let debug_events = self.log.enabled(Category::Events);
        let sim = self.snap.sim.as_mut().expect("initialized in StepComplete");
        let before = sim.clone();
        let mut events = Vec::new();
        let result = sim.advance(t_end, &mut |te, r| {
            if debug_events {
                events.push(format!("t = {te:.12} s: {}", r.what));
            }
        });
        for e in &events {
            self.log.log(Status::Ok, Category::Events, e);
        }
        self.outputs = None;
        let failure = match result {
            Ok(()) => match self.outputs() {
                Ok(o) if outputs_finite(&o) => None,
                Ok(_) => Some(error(format!(
                    "the step to {t_end} gave a non-finite output; state kept at t = {t}"
                ))),
                Err(f) => Some(f),
            },
            Err(e @ DriverError::Law { .. }) => Some(error(format!("{e}; state kept at t = {t}"))),
            Err(e) => Some(Failure {
                status: Status::Discard,
                message: format!("{e}; state kept at t = {t}"),
            }),
        };
        if let Some(f) = failure {
            self.snap.sim = Some(before);
            self.outputs = None;
            return Err(f);
        }
        if self.log.enabled(Category::Solver) {
            let s = &self.snap.sim.as_ref().expect("stepped").driver.stats;
            self.log.log(
                Status::Ok,
                Category::Solver,
                &format!(
                    "t = {t_end}: {} steps, {} rejected, {} rhs evaluations, {} Jacobians, {} factorizations, {} events so far",
                    s.steps, s.rejected, s.rhs_evals, s.jac_evals, s.factorizations, s.events
                ),
            );
        }
        Ok(Status::Ok)
    }

    pub fn time(&self) -> f64 {
        self.snap
            .sim
            .as_ref()
            .map_or(self.snap.start_time, |s| s.time())
    }
}

fn outputs_finite(o: &Outputs) -> bool {
    crate::variables::VARIABLES
        .iter()
        .filter_map(|info| o.get_real(info.var))
        .all(f64::is_finite)
}
