//! One FMU instance: the FMI 2.0 Co-Simulation state machine, values and stepping. Every
//! exported function goes through `Instance::call`, which checks the state in one place; a
//! failing call leaves the values the instance had before it.

use super::logging::{Category, Logger};
use super::Status;
use crate::controller::{reference, Params, Pi};
use crate::variables::{Causality, Id, Type, VARS};
use std::collections::HashSet;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FmiState {
    Instantiated = 1,
    InitializationMode = 2,
    StepComplete = 4,
    Terminated = 16,
    Error = 32,
}

/// Sets of states in which a function may be called (FMI 2.0 standard, section 4.2.4). The
/// controller never fails a step, so it has no stepFailed state.
pub mod allowed {
    use super::FmiState::*;
    pub const INST: u32 = Instantiated as u32;
    pub const INIT: u32 = InitializationMode as u32;
    pub const DONE: u32 = StepComplete as u32;
    pub const TERM: u32 = Terminated as u32;
    pub const ERR: u32 = Error as u32;
    pub const ANY: u32 = INST | INIT | DONE | TERM | ERR;
    pub const GET: u32 = INIT | DONE | TERM | ERR;
    pub const SET: u32 = INST | INIT | DONE;
    pub const STATUS: u32 = DONE | TERM | ERR;
}

/// Everything that determines how an instance continues (also the FMU state).
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    pub state: FmiState,
    /// Values of the parameters and the input, by value reference (outputs' slots unused).
    pub values: [f64; VARS.len()],
    pub start_time: f64,
    pub time: f64,
    /// The controller; None until the end of initialization.
    pub pi: Option<Pi>,
}

impl Snapshot {
    pub fn fresh() -> Snapshot {
        Snapshot {
            state: FmiState::Instantiated,
            values: VARS.map(|v| v.start),
            start_time: 0.0,
            time: 0.0,
            pi: None,
        }
    }

    pub fn params(&self) -> Params {
        let v = |id: Id| self.values[id as usize];
        Params {
            w_ref: v(Id::w_ref),
            t_ramp: v(Id::t_ramp),
            w_step: v(Id::w_step),
            t_step: v(Id::t_step),
            kp: v(Id::kp),
            ki: v(Id::ki),
            tau_max: v(Id::tau_max),
        }
    }

    /// The controller now: after initialization its state, before it the state it would
    /// start from with the current input.
    fn pi(&self) -> Pi {
        self.pi.unwrap_or_else(|| {
            Pi::initial(
                &self.params(),
                self.start_time,
                self.values[Id::w_A as usize],
            )
        })
    }
}

pub struct Instance {
    pub(crate) magic: u64,
    pub log: Logger,
    pub snap: Snapshot,
    /// FMU states handed out by this instance (owned here, freed by fmi2FreeFMUstate or at free).
    pub(crate) fmu_states: HashSet<usize>,
}

pub const MAGIC: u64 = 0x5350_4545_4443_544c; // "SPEEDCTL"

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

impl Instance {
    pub fn new(log: Logger) -> Instance {
        Instance {
            magic: MAGIC,
            log,
            snap: Snapshot::fresh(),
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
        if matches!(failure.status, Status::Error | Status::Fatal) {
            self.snap.state = FmiState::Error;
        }
        failure.status
    }

    pub fn setup_experiment(&mut self, start: f64, stop: Option<f64>) -> CallResult {
        if !start.is_finite() {
            return Err(error(format!("startTime = {start}: must be finite")));
        }
        if let Some(s) = stop {
            if !(s >= start && s.is_finite()) {
                return Err(error(format!(
                    "stopTime = {s}: must be finite and not before startTime = {start}"
                )));
            }
        }
        self.snap.start_time = start;
        self.snap.time = start;
        Ok(Status::Ok)
    }

    pub fn exit_initialization(&mut self) -> CallResult {
        let pi = self.snap.pi();
        self.snap.pi = Some(pi);
        self.snap.time = self.snap.start_time;
        self.snap.state = FmiState::StepComplete;
        Ok(Status::Ok)
    }

    pub fn reset(&mut self) {
        self.snap = Snapshot::fresh();
    }

    fn lookup(&self, vr: u32, ty: Type) -> Result<Id, Failure> {
        let id = Id::from_vr(vr).ok_or_else(|| error(format!("unknown value reference {vr}")))?;
        if id.def().ty != ty {
            return Err(error(format!(
                "{} (value reference {vr}) is {:?}, not {ty:?}",
                id.def().name,
                id.def().ty
            )));
        }
        Ok(id)
    }

    pub fn get_real(&self, vr: u32) -> Result<f64, Failure> {
        let id = self.lookup(vr, Type::Real)?;
        let s = &self.snap;
        Ok(match id.def().causality {
            Causality::Parameter | Causality::Input => s.values[vr as usize],
            Causality::Output => match id {
                Id::tau => s.pi().tau,
                Id::error => s.pi().error,
                Id::integral => s.pi().integral,
                Id::w_r => reference(&s.params(), s.start_time, s.time),
                other => unreachable!("{other:?} is a Real output"),
            },
        })
    }

    pub fn get_boolean(&self, vr: u32) -> Result<bool, Failure> {
        match self.lookup(vr, Type::Boolean)? {
            Id::saturated => Ok(self.snap.pi().saturated),
            other => unreachable!("{other:?} is a Boolean output"),
        }
    }

    /// Sets several reals at once: all are checked before any is applied. A value set after
    /// initialization acts from the next step on; the outputs keep their values until then.
    pub fn set_reals(&mut self, vrs: &[u32], values: &[f64]) -> CallResult {
        let mut new = self.snap.values;
        for (&vr, &x) in vrs.iter().zip(values) {
            let id = self.lookup(vr, Type::Real)?;
            let d = id.def();
            if d.causality == Causality::Output {
                return Err(error(format!("{} is an output: it cannot be set", d.name)));
            }
            let admissible = x.is_finite()
                && match d.lower {
                    Some((lo, true)) => x >= lo,
                    Some((lo, false)) => x > lo,
                    None => true,
                };
            if !admissible {
                let bound = match d.lower {
                    Some((lo, true)) => format!(" and >= {lo}"),
                    Some((lo, false)) => format!(" and > {lo}"),
                    None => String::new(),
                };
                return Err(error(format!("{} = {x}: must be finite{bound}", d.name)));
            }
            new[vr as usize] = x;
        }
        self.snap.values = new;
        Ok(Status::Ok)
    }

    pub fn do_step(&mut self, current: f64, h: f64) -> CallResult {
        let t = self.snap.time;
        if !(current.is_finite() && h.is_finite() && h > 0.0) {
            return Err(error(format!(
                "currentCommunicationPoint = {current}, communicationStepSize = {h}: \
                 must be finite, the step positive"
            )));
        }
        // Masters accumulate time in floating point; a nanosecond-scale mismatch is rounding.
        if (current - t).abs() > 1e-9 * t.abs().max(1.0) {
            return Err(error(format!(
                "currentCommunicationPoint = {current} does not match the FMU's time {t}"
            )));
        }
        let p = self.snap.params();
        let w = self.snap.values[Id::w_A as usize];
        let mut pi = self.snap.pi();
        let was_saturated = pi.saturated;
        pi.step(&p, self.snap.start_time, current, h, w);
        self.snap.pi = Some(pi);
        self.snap.time = current + h;
        if pi.saturated != was_saturated {
            self.log.log(
                Status::Ok,
                Category::Events,
                &format!(
                    "t = {:.12} s: saturation {} (tau = {} N.m, tau_max = {} N.m)",
                    current + h,
                    if pi.saturated { "entered" } else { "left" },
                    pi.tau,
                    p.tau_max
                ),
            );
        }
        if self.log.enabled(Category::Solver) {
            self.log.log(
                Status::Ok,
                Category::Solver,
                &format!(
                    "t = {current} s, h = {h} s: w_A = {w} rad/s, error = {} rad/s, integral = {} N.m, tau = {} N.m",
                    pi.error, pi.integral, pi.tau
                ),
            );
        }
        Ok(Status::Ok)
    }
}
