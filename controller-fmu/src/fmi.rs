//! SpeedController as an `fmi2_slave::Slave`, and its exported fmi2* functions. The FMI layer
//! itself (state machine, logging, FMU states, the C functions) is the `fmi2_slave` crate,
//! shared with SpurGearMesh.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::controller::{self, reference, Pi};
use crate::variables::{
    Causality, Inputs, Params, Var, VarType, GUID, LOG_CATEGORIES, MODEL_NAME, VARIABLES,
};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::logging::LOG_EVENTS;
use fmi2_slave::{error, Boolean, Failure, Logger, Slave, Status, ValueReference};

fmi2_slave::export_fmi2!(SpeedController);

/// The controller's own debug category: the PI update of every step.
pub const LOG_SOLVER: &str = "logSolver";

/// Everything that determines how an instance continues (also its FMU state).
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedController {
    pub params: Params,
    pub inputs: Inputs,
    pub start_time: f64,
    pub time: f64,
    /// The controller; None until the end of initialization.
    pub pi: Option<Pi>,
}

impl SpeedController {
    /// The law's parameters.
    pub fn params(&self) -> controller::Params {
        let p = &self.params;
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
            .unwrap_or_else(|| Pi::initial(&self.params(), self.start_time, self.inputs.w_A))
    }
}

fn lookup(vr: u32, ty: VarType) -> Result<Var, Failure> {
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

/// A variable that may be set: a parameter or the input.
fn settable(vr: u32, ty: VarType) -> Result<Var, Failure> {
    let v = lookup(vr, ty)?;
    match v.info().causality {
        Causality::Parameter | Causality::Input => Ok(v),
        _ => Err(error(format!(
            "{} is an output: it cannot be set",
            v.info().name
        ))),
    }
}

/// The Real parameters and inputs in the table's order (the FMU state's payload).
fn settable_reals() -> impl Iterator<Item = Var> {
    VARIABLES
        .iter()
        .filter(|v| v.ty == VarType::Real)
        .filter(|v| matches!(v.causality, Causality::Parameter | Causality::Input))
        .map(|v| v.var)
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
            params: Params::default(),
            inputs: Inputs::default(),
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
        let v = lookup(vr, VarType::Real)?;
        if let Some(x) = self.params.get_real(v).or(self.inputs.get_real(v)) {
            return Ok(x);
        }
        Ok(match v {
            Var::tau => self.pi().tau,
            Var::error => self.pi().error,
            Var::integral => self.pi().integral,
            Var::w_r => reference(&self.params(), self.start_time, self.time),
            other => unreachable!("{other:?} is a Real output"),
        })
    }

    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        match lookup(vr, VarType::Boolean)? {
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
        let (mut params, mut inputs) = (self.params.clone(), self.inputs.clone());
        for (&vr, &x) in vrs.iter().zip(values) {
            let v = settable(vr, VarType::Real)?;
            let info = v.info();
            if !x.is_finite() {
                return Err(error(format!("{} = {x}: must be finite", info.name)));
            }
            if let Some(why) = info.range.violation(x) {
                return Err(error(format!("{} = {x}: {why}", info.name)));
            }
            let _ = params.set_real(v, x) || inputs.set_real(v, x);
        }
        (self.params, self.inputs) = (params, inputs);
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
            settable(vr, VarType::Boolean)?;
        }
        Ok(())
    }

    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure> {
        let p = self.params();
        let w = self.inputs.w_A;
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
        for v in settable_reals() {
            w.f(self
                .params
                .get_real(v)
                .or(self.inputs.get_real(v))
                .expect("a Real"));
        }
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
        let (mut params, mut inputs) = (Params::default(), Inputs::default());
        for v in settable_reals() {
            let x = r.f()?;
            let _ = params.set_real(v, x) || inputs.set_real(v, x);
        }
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
            params,
            inputs,
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
        s.inputs.w_A = 12.5;
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
