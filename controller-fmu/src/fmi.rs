//! SpeedController as an `fmi2_slave::Slave`, and its exported fmi2* functions. The FMI layer
//! itself (state machine, logging, FMU states, the C functions) is the `fmi2_slave` crate,
//! shared with SpurGearMesh; the parameters and inputs with their checks are
//! `fmi2_slave::algebraic`'s table, shared with TorsionalShaft and EngineTorque.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::controller::{self, reference, Pi};
use crate::variables::{Var, GUID, LOG_CATEGORIES, MODEL_NAME};
use fmi2_slave::algebraic::{self, decode_reals, encode_reals, lookup, set_reals};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::logging::LOG_EVENTS;
use fmi2_slave::{Boolean, Failure, Logger, Slave, Status, ValueReference};

fmi2_slave::export_fmi2!(SpeedController);
fmi2_slave::values_table!(Values);

/// No condition on the values together: each is checked on its own.
fn no_check(_: &Values) -> Option<String> {
    None
}

/// The controller's own debug category: the PI update of every step.
pub const LOG_SOLVER: &str = "logSolver";

/// Everything that determines how an instance continues (also its FMU state).
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedController {
    /// The parameters and inputs.
    pub values: Values,
    pub start_time: f64,
    pub time: f64,
    /// The controller; None until the end of initialization.
    pub pi: Option<Pi>,
}

impl SpeedController {
    /// The law's parameters.
    pub fn params(&self) -> controller::Params {
        let p = &self.values.params;
        controller::Params {
            w_ref: p.w_ref,
            t_ramp: p.t_ramp,
            w_step: p.w_step,
            t_step: p.t_step,
            kp: p.kp,
            ki: p.ki,
            tau_max: p.tau_max,
        }
    }

    /// The controller now: after initialization its state, before it the state it would
    /// start from with the current input.
    fn pi(&self) -> Pi {
        self.pi
            .unwrap_or_else(|| Pi::initial(&self.params(), self.start_time, self.values.inputs.w_A))
    }
}

impl Slave for SpeedController {
    const MODEL_NAME: &'static str = MODEL_NAME;
    const LOG_CATEGORIES: &'static [&'static str] = LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = *b"SPCSTATE";
    const STATE_FORMAT_VERSION: u32 = 2;

    fn guid() -> &'static str {
        GUID
    }

    fn fresh() -> SpeedController {
        SpeedController {
            values: Values::default(),
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
        lookup::<Values>(vr, "Real")?;
        if let Some(x) = algebraic::Table::settable_real(&self.values, vr) {
            return Ok(x);
        }
        Ok(match Var::from_vr(vr).expect("a table variable") {
            Var::tau => self.pi().tau,
            Var::error => self.pi().error,
            Var::integral => self.pi().integral,
            Var::w_r => reference(&self.params(), self.start_time, self.time),
            other => unreachable!("{other:?} is a Real output"),
        })
    }

    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        lookup::<Values>(vr, "Boolean")?;
        match Var::from_vr(vr).expect("a table variable") {
            Var::saturated => Ok(self.pi().saturated),
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
        self.values = set_reals(&self.values, vrs, values, no_check)?;
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
            algebraic::settable::<Values>(vr, "Boolean")?;
        }
        Ok(())
    }

    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure> {
        let p = self.params();
        let w = self.values.inputs.w_A;
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
        encode_reals(&self.values, w);
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

    /// What `encode` wrote; the parameters and inputs are checked as fmi2SetReal checks them.
    fn decode(r: &mut Reader) -> Result<SpeedController, String> {
        let values = decode_reals(r, no_check)?;
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
        s.values.inputs.w_A = 12.5;
        s.exit_initialization().unwrap();
        s.pi.as_mut().unwrap().integral = 3.25;
        let saved = Saved {
            state: FmiState::StepComplete,
            slave: s,
        };
        let bytes = fmi2_slave::fmu_state::encode(&saved);
        assert_eq!(&bytes[..8], b"SPCSTATE");
        assert_eq!(
            fmi2_slave::fmu_state::decode::<SpeedController>(&bytes, &SpeedController::fresh())
                .unwrap(),
            saved
        );
        let mut flipped = bytes.clone();
        let k = bytes.len() - 20;
        flipped[k] ^= 1;
        let e =
            fmi2_slave::fmu_state::decode::<SpeedController>(&flipped, &SpeedController::fresh())
                .unwrap_err();
        assert!(e.contains("checksum"), "{e}");
        let e = fmi2_slave::fmu_state::decode::<SpeedController>(
            &bytes[..bytes.len() - 1],
            &SpeedController::fresh(),
        )
        .unwrap_err();
        assert!(e.contains("length"), "{e}");
    }

    #[test]
    fn a_state_with_a_bad_value_is_refused() {
        let mut s = SpeedController::fresh();
        s.values.params.kp = f64::NAN;
        let bytes = fmi2_slave::fmu_state::encode(&Saved {
            state: FmiState::StepComplete,
            slave: s,
        });
        let e = fmi2_slave::fmu_state::decode::<SpeedController>(&bytes, &SpeedController::fresh())
            .unwrap_err();
        assert!(e.contains("kp = NaN"), "{e}");
    }
}
