//! TorsionalShaft as an `fmi2_slave::Slave`, and its exported fmi2* functions. The FMI layer
//! itself (state machine, logging, FMU states, the C functions, the panic guard) is the
//! `fmi2_slave` crate, shared with SpurGearMesh and SpeedController.
//!
//! The shaft is massless: `tau_a` and `tau_b` are computed from the inputs and parameters set
//! last whenever they are read (a direct feedthrough, declared in ModelStructure), and
//! fmi2DoStep only advances the time. A master that sets the inputs at a communication point
//! and then reads the outputs gets the torques of those inputs.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::shaft::torque_b;
use crate::variables::{
    Causality, Inputs, Params, Var, VarType, GUID, LOG_CATEGORIES, MODEL_NAME, VARIABLES,
};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::{error, Boolean, Failure, Logger, Slave, ValueReference};

fmi2_slave::export_fmi2!(TorsionalShaft);

/// Everything that determines how an instance continues (also its FMU state).
#[derive(Clone, Debug, PartialEq)]
pub struct TorsionalShaft {
    pub params: Params,
    pub inputs: Inputs,
    pub start_time: f64,
    pub time: f64,
}

/// The torque on end b of these parameters and inputs.
pub fn tau_b(p: &Params, i: &Inputs) -> f64 {
    torque_b(p.k, p.d, p.twist_start, i.theta_a, i.w_a, i.theta_b, i.w_b)
}

/// Why these values cannot be the shaft's: a value that is not finite or outside its range
/// (named), or a torque that overflows. None if they can.
fn violation(p: &Params, i: &Inputs) -> Option<String> {
    for v in settable_reals() {
        let info = v.info();
        let x = p.get_real(v).or(i.get_real(v)).expect("a Real");
        if !x.is_finite() {
            return Some(format!("{} = {x}: must be finite", info.name));
        }
        if let Some(why) = info.range.violation(x) {
            return Some(format!("{} = {x}: {why}", info.name));
        }
    }
    let t = tau_b(p, i);
    if !t.is_finite() {
        return Some(format!(
            "the torque k (theta_a - theta_b + twist_start) + d (w_a - w_b) = {t} is not finite \
             (k = {}, d = {}, twist_start = {}, theta_a = {}, w_a = {}, theta_b = {}, w_b = {})",
            p.k, p.d, p.twist_start, i.theta_a, i.w_a, i.theta_b, i.w_b
        ));
    }
    None
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

/// A variable that may be set: a parameter or an input.
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

impl Slave for TorsionalShaft {
    const MODEL_NAME: &'static str = MODEL_NAME;
    const LOG_CATEGORIES: &'static [&'static str] = LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = *b"TSHSTATE";
    const STATE_FORMAT_VERSION: u32 = 1;

    fn guid() -> &'static str {
        GUID
    }

    fn fresh() -> TorsionalShaft {
        TorsionalShaft {
            params: Params::default(),
            inputs: Inputs::default(),
            start_time: 0.0,
            time: 0.0,
        }
    }

    /// The tolerance is not used: the law is algebraic.
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
        self.time = self.start_time;
        Ok(())
    }

    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure> {
        let v = lookup(vr, VarType::Real)?;
        if let Some(x) = self.params.get_real(v).or(self.inputs.get_real(v)) {
            return Ok(x);
        }
        let t = tau_b(&self.params, &self.inputs);
        Ok(match v {
            Var::tau_b => t,
            Var::tau_a => -t,
            other => unreachable!("{other:?} is a Real output"),
        })
    }

    /// All or none: the values are applied only if each is finite and in its range and the
    /// torque of the new parameters and inputs is finite. Every parameter is tunable, and every
    /// value acts at once: the outputs are read from the latest values.
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
        if let Some(why) = violation(&params, &inputs) {
            return Err(error(why));
        }
        (self.params, self.inputs) = (params, inputs);
        Ok(())
    }

    /// The shaft has no Boolean variables; setting none is fine.
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

    /// Nothing to integrate: the step keeps the time.
    fn do_step(&mut self, current: f64, h: f64, _log: &Logger) -> Result<(), Failure> {
        self.time = current + h;
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
    }

    /// What `encode` wrote, checked as fmi2SetReal checks it: a state cannot bring in a value
    /// that fmi2SetReal would refuse.
    fn decode(r: &mut Reader) -> Result<TorsionalShaft, String> {
        let (mut params, mut inputs) = (Params::default(), Inputs::default());
        for v in settable_reals() {
            let x = r.f()?;
            let _ = params.set_real(v, x) || inputs.set_real(v, x);
        }
        let (start_time, time) = (r.f()?, r.f()?);
        if let Some(why) = violation(&params, &inputs) {
            return Err(why);
        }
        if !(start_time.is_finite() && time.is_finite() && time >= start_time) {
            return Err(format!(
                "start time {start_time} s and time {time} s: must be finite, in this order"
            ));
        }
        Ok(TorsionalShaft {
            params,
            inputs,
            start_time,
            time,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmi2_slave::instance::{FmiState, Saved};

    #[test]
    fn serialized_state_round_trips_and_rejects_damage() {
        let mut s = TorsionalShaft::fresh();
        s.inputs.theta_a = 0.125;
        s.inputs.w_b = -3.5;
        s.params.twist_start = -0.01;
        s.time = 0.5;
        let saved = Saved {
            state: FmiState::StepComplete,
            slave: s,
        };
        let bytes = fmi2_slave::fmu_state::encode(&saved);
        assert_eq!(&bytes[..8], b"TSHSTATE");
        assert_eq!(
            fmi2_slave::fmu_state::decode::<TorsionalShaft>(&bytes).unwrap(),
            saved
        );
        let mut flipped = bytes.clone();
        let k = bytes.len() - 20;
        flipped[k] ^= 1;
        let e = fmi2_slave::fmu_state::decode::<TorsionalShaft>(&flipped).unwrap_err();
        assert!(e.contains("checksum"), "{e}");
        let e =
            fmi2_slave::fmu_state::decode::<TorsionalShaft>(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(e.contains("length"), "{e}");
    }

    #[test]
    fn a_state_with_a_bad_value_is_refused() {
        for (name, bad) in [("k", -1.0), ("d", f64::NAN), ("w_a", f64::INFINITY)] {
            let mut s = TorsionalShaft::fresh();
            let v = Var::from_name(name).unwrap();
            let _ = s.params.set_real(v, bad) || s.inputs.set_real(v, bad);
            let saved = Saved {
                state: FmiState::StepComplete,
                slave: s,
            };
            let bytes = fmi2_slave::fmu_state::encode(&saved);
            let e = fmi2_slave::fmu_state::decode::<TorsionalShaft>(&bytes).unwrap_err();
            assert!(e.contains(name), "{e}");
        }
    }
}
