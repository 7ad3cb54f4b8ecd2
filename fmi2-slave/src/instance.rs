//! One FMU instance: the FMI 2.0 state machine around a model (`Slave`), for Co-Simulation or
//! Model Exchange. Every
//! exported function goes through `Instance::call`, which checks the state in one place,
//! catches panics, and logs a failure and turns it into a state change.

use crate::{Logger, Slave, Status};
use std::collections::HashSet;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FmiState {
    Instantiated = 1,
    InitializationMode = 2,
    StepComplete = 4,
    StepFailed = 8,
    Terminated = 16,
    Error = 32,
    /// Model Exchange only.
    EventMode = 64,
    ContinuousTimeMode = 128,
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
            EventMode,
            ContinuousTimeMode,
        ]
        .into_iter()
        .find(|s| *s as u64 == b)
    }
}

/// Sets of states in which a function may be called (FMI 2.0 standard, sections 3.2.3 and
/// 4.2.4).
pub mod allowed {
    use super::FmiState::*;
    pub const INST: u32 = Instantiated as u32;
    pub const INIT: u32 = InitializationMode as u32;
    pub const DONE: u32 = StepComplete as u32;
    pub const FAIL: u32 = StepFailed as u32;
    pub const TERM: u32 = Terminated as u32;
    pub const ERR: u32 = Error as u32;
    pub const EVENT: u32 = EventMode as u32;
    pub const CONT: u32 = ContinuousTimeMode as u32;
    pub const ANY: u32 = INST | INIT | DONE | FAIL | TERM | ERR | EVENT | CONT;
    pub const GET: u32 = INIT | DONE | FAIL | TERM | ERR | EVENT | CONT;
    pub const SET: u32 = INST | INIT | DONE | EVENT | CONT;
    /// After initialization: only tunable parameters and inputs may change.
    pub const RUNNING: u32 = DONE | EVENT | CONT;
    pub const STATUS: u32 = DONE | FAIL | TERM | ERR;
    /// Model Exchange's getters of states, derivatives, event indicators and nominals.
    pub const ME_GET: u32 = INIT | EVENT | CONT | TERM | ERR;
}

/// A function's failure: the status to return and the message to log.
#[derive(Debug)]
pub struct Failure {
    pub status: Status,
    pub message: String,
}

pub type CallResult = Result<Status, Failure>;

/// The FMI 3.0 function that does what an FMI 2.0 function does, for messages: the bodies
/// are shared, and name their FMI 2.0 function.
pub fn fmi3_name(fmi2: &str) -> std::borrow::Cow<'_, str> {
    let special = [
        ("fmi2GetReal", "fmi3GetFloat64"),
        ("fmi2SetReal", "fmi3SetFloat64"),
        ("fmi2GetInteger", "fmi3GetInt32"),
        ("fmi2SetInteger", "fmi3SetInt32"),
        ("fmi2GetDerivatives", "fmi3GetContinuousStateDerivatives"),
        ("fmi2NewDiscreteStates", "fmi3UpdateDiscreteStates"),
        ("fmi2DeSerializeFMUstate", "fmi3DeserializeFMUState"),
    ];
    if let Some((_, n)) = special.iter().find(|(a, _)| *a == fmi2) {
        return (*n).into();
    }
    match fmi2.strip_prefix("fmi2") {
        Some(rest) => format!("fmi3{}", rest.replace("FMUstate", "FMUState")).into(),
        None => fmi2.into(),
    }
}

/// The FMI 3.0 name of an argument that FMI 2.0 names `fmi2` (messages only).
pub fn fmi3_arg(fmi2: &'static str) -> &'static str {
    match fmi2 {
        "vr" => "valueReferences",
        "value" => "values",
        "nx" => "nContinuousStates",
        "x" => "continuousStates",
        "ni" => "nEventIndicators",
        other => other,
    }
}

pub fn error(message: String) -> Failure {
    Failure {
        status: Status::Error,
        message,
    }
}

/// An FMU state: the FMI state and the model.
#[derive(Clone, Debug, PartialEq)]
pub struct Saved<S> {
    pub state: FmiState,
    pub slave: S,
}

pub struct Instance<S: Slave> {
    pub(crate) magic: u64,
    pub log: Logger,
    pub state: FmiState,
    /// Instantiated for Model Exchange (else Co-Simulation).
    pub model_exchange: bool,
    /// Called through FMI 3.0's functions: messages name those (`fmi3_name`).
    pub fmi3: bool,
    pub slave: S,
    /// FMU states handed out by this instance (owned here, freed by fmi2FreeFMUstate or at free).
    pub(crate) fmu_states: HashSet<usize>,
    /// The strings of the last fmi2GetString: the master may read them until its next call.
    pub(crate) strings: Vec<std::ffi::CString>,
    /// A step the time resolves only coarsely has been reported (once per instance, until
    /// fmi2Reset): `ffi::do_step`.
    pub(crate) coarse_step_reported: bool,
}

/// Marks a live instance: a component pointer to anything else (or to a freed instance) is rejected.
pub(crate) const MAGIC: u64 = 0x464d_4932_534c_4156; // "FMI2SLAV"

impl<S: Slave> Instance<S> {
    pub fn new(log: Logger, model_exchange: bool, slave: S) -> Instance<S> {
        Instance {
            magic: MAGIC,
            log,
            state: FmiState::Instantiated,
            model_exchange,
            fmi3: false,
            slave,
            fmu_states: HashSet::new(),
            strings: Vec::new(),
            coarse_step_reported: false,
        }
    }

    /// Runs one FMI function: checks the state, catches panics, logs failures.
    pub fn call(
        &mut self,
        func: &str,
        states: u32,
        body: impl FnOnce(&mut Instance<S>) -> CallResult,
    ) -> Status {
        if states & self.state as u32 == 0 {
            let func = self.name(func);
            self.log.log_status(
                Status::Error,
                &format!("{func}: not allowed in state {:?}", self.state),
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
        let func = self.name(func);
        self.log
            .log_status(failure.status, &format!("{func}: {}", failure.message));
        match failure.status {
            Status::Error | Status::Fatal => self.state = FmiState::Error,
            Status::Discard => self.state = FmiState::StepFailed,
            _ => {}
        }
        failure.status
    }

    /// The function's name as the master called it (messages only, so off the hot path).
    #[cold]
    pub(crate) fn name<'a>(&self, func: &'a str) -> std::borrow::Cow<'a, str> {
        if self.fmi3 {
            fmi3_name(func)
        } else {
            func.into()
        }
    }

    /// An argument's name as the master's standard names it (for messages).
    pub fn arg(&self, fmi2: &'static str) -> &'static str {
        if self.fmi3 {
            fmi3_arg(fmi2)
        } else {
            fmi2
        }
    }

    pub fn reset(&mut self) {
        self.state = FmiState::Instantiated;
        self.slave.reset_model();
        self.coarse_step_reported = false;
    }

    pub fn save(&mut self) -> Saved<S> {
        self.slave.prepare_save();
        Saved {
            state: self.state,
            slave: self.slave.clone(),
        }
    }

    pub fn restore(&mut self, s: &Saved<S>) -> Result<(), Failure> {
        self.fits(s.state)?;
        self.state = s.state;
        self.slave = s.slave.clone();
        Ok(())
    }

    /// An FMU state of the other interface (a Co-Simulation step state in a Model Exchange
    /// instance, or the reverse) cannot be continued here.
    pub fn fits(&self, state: FmiState) -> Result<(), Failure> {
        use FmiState::*;
        let (ours, other) = if self.model_exchange {
            ("Model Exchange", matches!(state, StepComplete | StepFailed))
        } else {
            (
                "Co-Simulation",
                matches!(state, EventMode | ContinuousTimeMode),
            )
        };
        if other {
            return Err(error(format!(
                "the FMU state was saved in {state:?}, which a {ours} instance does not have"
            )));
        }
        Ok(())
    }
}
