//! SpeedController as an `fmi2_slave::Slave`, and its exported fmi2* functions. The FMI layer
//! itself (state machine, logging, FMU states, the C functions) is the `fmi2_slave` crate,
//! shared with SpurGearMesh.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::controller::{reference, Params, Pi};
use crate::variables::{guid, Causality, Id, Type, LOG_CATEGORIES, MODEL_NAME, VARS};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::logging::LOG_EVENTS;
use fmi2_slave::{error, Boolean, Failure, Logger, Slave, Status, ValueReference};
use std::sync::OnceLock;

fmi2_slave::export_fmi2!(SpeedController);

/// The controller's own debug category: the PI update of every step.
pub const LOG_SOLVER: &str = "logSolver";

/// Everything that determines how an instance continues (also its FMU state).
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedController {
    /// Values of the parameters and the input, by value reference (outputs' slots unused).
    pub values: [f64; VARS.len()],
    pub start_time: f64,
    pub time: f64,
    /// The controller; None until the end of initialization.
    pub pi: Option<Pi>,
}

impl SpeedController {
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

fn lookup(vr: u32, ty: Type) -> Result<Id, Failure> {
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

/// A variable that may be set: a parameter or the input.
fn settable(vr: u32, ty: Type) -> Result<Id, Failure> {
    let id = lookup(vr, ty)?;
    match id.def().causality {
        Causality::Output => Err(error(format!(
            "{} is an output: it cannot be set",
            id.def().name
        ))),
        Causality::Parameter | Causality::Input => Ok(id),
    }
}

impl Slave for SpeedController {
    const MODEL_NAME: &'static str = MODEL_NAME;
    const LOG_CATEGORIES: &'static [&'static str] = LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = *b"SPCSTATE";
    const STATE_FORMAT_VERSION: u32 = 1;

    fn guid() -> &'static str {
        static GUID: OnceLock<String> = OnceLock::new();
        GUID.get_or_init(guid)
    }

    fn fresh() -> SpeedController {
        SpeedController {
            values: VARS.map(|v| v.start),
            start_time: 0.0,
            time: 0.0,
            pi: None,
        }
    }

    /// The tolerance is not used: the law is exact at the communication points.
    fn setup_experiment(
        &mut self,
        _tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<(), Failure> {
        fmi2_slave::check_experiment_times(start, stop)?;
        self.start_time = start;
        self.time = start;
        Ok(())
    }

    fn exit_initialization(&mut self) -> Result<(), Failure> {
        self.pi = Some(self.pi());
        self.time = self.start_time;
        Ok(())
    }

    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure> {
        let id = lookup(vr, Type::Real)?;
        Ok(match id.def().causality {
            Causality::Parameter | Causality::Input => self.values[vr as usize],
            Causality::Output => match id {
                Id::tau => self.pi().tau,
                Id::error => self.pi().error,
                Id::integral => self.pi().integral,
                Id::w_r => reference(&self.params(), self.start_time, self.time),
                other => unreachable!("{other:?} is a Real output"),
            },
        })
    }

    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        match lookup(vr, Type::Boolean)? {
            Id::saturated => Ok(self.pi().saturated),
            other => unreachable!("{other:?} is a Boolean output"),
        }
    }

    /// A value set after initialization acts from the next step on; the outputs keep their
    /// values until then.
    fn set_real(
        &mut self,
        vrs: &[ValueReference],
        values: &[f64],
        _running: bool,
    ) -> Result<(), Failure> {
        let mut new = self.values;
        for (&vr, &x) in vrs.iter().zip(values) {
            let d = settable(vr, Type::Real)?.def();
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
        self.values = new;
        Ok(())
    }

    /// The only Boolean variable, `saturated`, is an output.
    fn set_boolean(
        &mut self,
        vrs: &[ValueReference],
        _values: &[Boolean],
        _running: bool,
    ) -> Result<(), Failure> {
        for &vr in vrs {
            settable(vr, Type::Boolean)?;
        }
        Ok(())
    }

    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure> {
        let p = self.params();
        let w = self.values[Id::w_A as usize];
        let mut pi = self.pi();
        let was_saturated = pi.saturated;
        pi.step(&p, self.start_time, current, h, w);
        self.pi = Some(pi);
        self.time = current + h;
        if pi.saturated != was_saturated {
            log.log(
                Status::Ok,
                LOG_EVENTS,
                &format!(
                    "t = {:.12} s: saturation {} (tau = {} N.m, tau_max = {} N.m)",
                    current + h,
                    if pi.saturated { "entered" } else { "left" },
                    pi.tau,
                    p.tau_max
                ),
            );
        }
        if log.enabled(LOG_SOLVER) {
            log.log(
                Status::Ok,
                LOG_SOLVER,
                &format!(
                    "t = {current} s, h = {h} s: w_A = {w} rad/s, error = {} rad/s, integral = {} N.m, tau = {} N.m",
                    pi.error, pi.integral, pi.tau
                ),
            );
        }
        Ok(())
    }

    fn time(&self) -> f64 {
        self.time
    }

    fn encode(&self, w: &mut Writer) {
        w.fs(&self.values);
        w.f(self.start_time);
        w.f(self.time);
        w.b(self.pi.is_some());
        let pi = self.pi.unwrap_or(Pi {
            integral: 0.0,
            error: 0.0,
            tau: 0.0,
            saturated: false,
        });
        w.fs(&[pi.integral, pi.error, pi.tau]);
        w.b(pi.saturated);
    }

    fn decode(r: &mut Reader) -> Result<SpeedController, String> {
        let values = r.fs()?;
        let (start_time, time, has_pi) = (r.f()?, r.f()?, r.b()?);
        let [integral, error, tau] = r.fs()?;
        let saturated = r.b()?;
        let pi = has_pi.then_some(Pi {
            integral,
            error,
            tau,
            saturated,
        });
        Ok(SpeedController {
            values,
            start_time,
            time,
            pi,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmi2_slave::instance::{FmiState, Saved};

    #[test]
    fn serialized_state_round_trips_and_rejects_damage() {
        let mut s = SpeedController::fresh();
        s.values[Id::w_A as usize] = 12.5;
        s.exit_initialization().unwrap();
        s.pi.as_mut().unwrap().integral = 3.25;
        let saved = Saved {
            state: FmiState::StepComplete,
            slave: s,
        };
        let bytes = fmi2_slave::fmu_state::encode(&saved);
        assert_eq!(&bytes[..8], b"SPCSTATE");
        assert_eq!(
            fmi2_slave::fmu_state::decode::<SpeedController>(&bytes).unwrap(),
            saved
        );
        let mut flipped = bytes.clone();
        let k = bytes.len() - 20;
        flipped[k] ^= 1;
        let e = fmi2_slave::fmu_state::decode::<SpeedController>(&flipped).unwrap_err();
        assert!(e.contains("checksum"), "{e}");
        let e = fmi2_slave::fmu_state::decode::<SpeedController>(&bytes[..bytes.len() - 1])
            .unwrap_err();
        assert!(e.contains("length"), "{e}");
    }
}
