//! TorsionalShaft as a stateless `fmi2_slave` FMU, and its exported fmi2* functions. The FMI
//! layer itself (state machine, logging, FMU states, the C functions, the panic guard) is the
//! `fmi2_slave` crate, shared with SpurGearMesh and SpeedController; the stateless slave
//! (`fmi2_slave::algebraic`) with EngineTorque.
//!
//! The shaft is massless: `tau_a` and `tau_b` are computed from the inputs and parameters set
//! last whenever they are read (a direct feedthrough, declared in ModelStructure), and
//! fmi2DoStep only advances the time. A master that sets the inputs at a communication point
//! and then reads the outputs gets the torques of those inputs.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::shaft::torque_b;
use crate::variables::Var;
use fmi2_slave::algebraic::Law;
use fmi2_slave::ValueReference;

fmi2_slave::algebraic_fmu!(Shaft, TorsionalShaft);

impl Shaft {
    /// The torque on end b of these parameters and inputs.
    pub fn tau_b(&self) -> f64 {
        let (p, i) = (&self.params, &self.inputs);
        torque_b(p.k, p.d, p.twist_start, i.theta_a, i.w_a, i.theta_b, i.w_b)
    }
}

impl Law for Shaft {
    const STATE_MAGIC: [u8; 8] = *b"TSHSTATE";

    fn output(&self, vr: ValueReference) -> Option<f64> {
        match Var::from_vr(vr)? {
            Var::tau_b => Some(self.tau_b()),
            Var::tau_a => Some(-self.tau_b()),
            _ => None,
        }
    }

    /// A torque that overflows.
    fn check(&self) -> Option<String> {
        let t = self.tau_b();
        if t.is_finite() {
            return None;
        }
        let (p, i) = (&self.params, &self.inputs);
        Some(format!(
            "the torque k (theta_a - theta_b + twist_start) + d (w_a - w_b) = {t} is not finite \
             (k = {}, d = {}, twist_start = {}, theta_a = {}, w_a = {}, theta_b = {}, w_b = {})",
            p.k, p.d, p.twist_start, i.theta_a, i.w_a, i.theta_b, i.w_b
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmi2_slave::instance::{FmiState, Saved};
    use fmi2_slave::Slave;

    #[test]
    fn serialized_state_round_trips_and_rejects_damage() {
        let mut s = TorsionalShaft::fresh();
        s.law.inputs.theta_a = 0.125;
        s.law.inputs.w_b = -3.5;
        s.law.params.twist_start = -0.01;
        s.time = 0.5;
        let saved = Saved {
            state: FmiState::StepComplete,
            slave: s,
        };
        let bytes = fmi2_slave::fmu_state::encode(&saved);
        assert_eq!(&bytes[..8], b"TSHSTATE");
        assert_eq!(
            fmi2_slave::fmu_state::decode::<TorsionalShaft>(&bytes, &TorsionalShaft::fresh())
                .unwrap(),
            saved
        );
        let mut flipped = bytes.clone();
        let k = bytes.len() - 20;
        flipped[k] ^= 1;
        let e = fmi2_slave::fmu_state::decode::<TorsionalShaft>(&flipped, &TorsionalShaft::fresh())
            .unwrap_err();
        assert!(e.contains("checksum"), "{e}");
        let e = fmi2_slave::fmu_state::decode::<TorsionalShaft>(
            &bytes[..bytes.len() - 1],
            &TorsionalShaft::fresh(),
        )
        .unwrap_err();
        assert!(e.contains("length"), "{e}");
    }

    #[test]
    fn a_state_with_a_bad_value_is_refused() {
        for (name, bad) in [("k", -1.0), ("d", f64::NAN), ("w_a", f64::INFINITY)] {
            let mut s = TorsionalShaft::fresh();
            let v = Var::from_name(name).unwrap();
            let _ = s.law.params.set_real(v, bad) || s.law.inputs.set_real(v, bad);
            let saved = Saved {
                state: FmiState::StepComplete,
                slave: s,
            };
            let bytes = fmi2_slave::fmu_state::encode(&saved);
            let e =
                fmi2_slave::fmu_state::decode::<TorsionalShaft>(&bytes, &TorsionalShaft::fresh())
                    .unwrap_err();
            assert!(e.contains(name), "{e}");
        }
    }
}
