//! EngineTorque as a stateless `fmi2_slave` FMU (`fmi2_slave::algebraic`, shared with
//! TorsionalShaft), and its exported fmi2* functions.
//!
//! The torque is computed from the crank angle and the parameters set last whenever it is read
//! (a direct feedthrough, declared in ModelStructure); fmi2DoStep only advances the time.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::engine::torque;
use crate::variables::Var;
use fmi2_slave::algebraic::Law;
use fmi2_slave::ValueReference;

fmi2_slave::algebraic_fmu!(Engine, EngineTorque);

impl Engine {
    /// The torque at the current crank angle.
    pub fn tau(&self) -> f64 {
        let p = &self.params;
        torque(
            p.tau_mean,
            p.tau_ripple,
            p.order,
            p.phase,
            self.inputs.theta,
        )
    }
}

impl Law for Engine {
    const STATE_MAGIC: [u8; 8] = *b"ENGSTATE";

    fn output(&self, vr: ValueReference) -> Option<f64> {
        match Var::from_vr(vr)? {
            Var::tau => Some(self.tau()),
            _ => None,
        }
    }

    /// A torque that overflows (tau_mean and tau_ripple near the largest double).
    fn check(&self) -> Option<String> {
        let t = self.tau();
        if t.is_finite() {
            return None;
        }
        let p = &self.params;
        Some(format!(
            "the torque tau_mean + tau_ripple sin(order theta + phase) = {t} is not finite \
             (tau_mean = {}, tau_ripple = {}, order = {}, phase = {}, theta = {})",
            p.tau_mean, p.tau_ripple, p.order, p.phase, self.inputs.theta
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmi2_slave::instance::{FmiState, Saved};
    use fmi2_slave::Slave;

    #[test]
    fn outputs_follow_the_latest_values_and_bad_ones_are_refused_whole() {
        let mut e = EngineTorque::fresh();
        let vr = |n: &str| Var::from_name(n).unwrap().info().vr;
        e.set_real(&[vr("theta")], &[std::f64::consts::PI / 4.0], true)
            .unwrap();
        assert!((e.get_real(vr("tau")).unwrap() - 70.0).abs() < 1e-12);
        // One bad value refuses the whole call, with the variable named.
        let err = e
            .set_real(&[vr("tau_mean"), vr("order")], &[10.0, -1.0], true)
            .unwrap_err();
        assert!(format!("{err:?}").contains("order = -1"), "{err:?}");
        assert_eq!(e.law.params.tau_mean, 50.0);
        let err = e.set_real(&[vr("theta")], &[f64::NAN], true).unwrap_err();
        assert!(format!("{err:?}").contains("theta = NaN"), "{err:?}");
        let err = e
            .set_real(
                &[vr("tau_mean"), vr("tau_ripple"), vr("phase")],
                &[1.7e308, 1.7e308, 1.5],
                true,
            )
            .unwrap_err();
        assert!(format!("{err:?}").contains("not finite"), "{err:?}");
        let err = e.set_real(&[vr("tau")], &[1.0], true).unwrap_err();
        assert!(format!("{err:?}").contains("tau is an output"), "{err:?}");
    }

    #[test]
    fn serialized_state_round_trips_and_refuses_a_bad_value() {
        let mut s = EngineTorque::fresh();
        s.law.inputs.theta = 12.5;
        s.law.params.phase = -0.3;
        s.time = 0.25;
        let saved = Saved {
            state: FmiState::StepComplete,
            slave: s.clone(),
        };
        let bytes = fmi2_slave::fmu_state::encode(&saved);
        assert_eq!(&bytes[..8], b"ENGSTATE");
        assert_eq!(
            fmi2_slave::fmu_state::decode::<EngineTorque>(&bytes, &EngineTorque::fresh()).unwrap(),
            saved
        );
        s.law.params.order = f64::INFINITY;
        let bytes = fmi2_slave::fmu_state::encode(&Saved {
            state: FmiState::StepComplete,
            slave: s,
        });
        let e = fmi2_slave::fmu_state::decode::<EngineTorque>(&bytes, &EngineTorque::fresh())
            .unwrap_err();
        assert!(e.contains("order"), "{e}");
    }
}
