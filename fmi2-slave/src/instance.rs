//! One FMU instance: the FMI 2.0 Co-Simulation state machine around a model (`Slave`). Every
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

/// A function's failure: the status to return and the message to log.
#[derive(Debug)]
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
    pub slave: S,
    /// FMU states handed out by this instance (owned here, freed by fmi2FreeFMUstate or at free).
    pub(crate) fmu_states: HashSet<usize>,
    /// The strings of the last fmi2GetString: the master may read them until its next call.
    pub(crate) strings: Vec<std::ffi::CString>,
}

/// Marks a live instance: a component pointer to anything else (or to a freed instance) is rejected.
pub(crate) const MAGIC: u64 = 0x464d_4932_534c_4156; // "FMI2SLAV"

impl<S: Slave> Instance<S> {
    pub fn new(log: Logger) -> Instance<S> {
        Instance {
            magic: MAGIC,
            log,
            state: FmiState::Instantiated,
            slave: S::fresh(),
            fmu_states: HashSet::new(),
            strings: Vec::new(),
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
        self.log
            .log_status(failure.status, &format!("{func}: {}", failure.message));
        match failure.status {
            Status::Error | Status::Fatal => self.state = FmiState::Error,
            Status::Discard => self.state = FmiState::StepFailed,
            _ => {}
        }
        failure.status
    }

    pub fn reset(&mut self) {
        self.state = FmiState::Instantiated;
        self.slave = S::fresh();
    }

    pub fn save(&mut self) -> Saved<S> {
        self.slave.prepare_save();
        Saved {
            state: self.state,
            slave: self.slave.clone(),
        }
    }

    pub fn restore(&mut self, s: &Saved<S>) {
        self.state = s.state;
        self.slave = s.slave.clone();
    }
}
