//! Rigid contact (`contact_model = 2`, rig-and-modes.md §2): the teeth are a unilateral
//! constraint. The numbers and laws that define it live here; the mesh component (`mesh/`) holds the modes and the paper rig (`paper_rig/rigid_contact.rs`) the dynamics.
//!
//! - Locked on a flank, the wheels roll as one body and the constraint force N >= 0 is the
//!   Lagrange multiplier of d^2 delta/dt^2 = 0. Every load is linear in N (friction too, for
//!   the current sliding velocities), so N is one linear solve: `lock_force`.
//! - N is split equally between the gated pairs (the paper's §6.3 convention).
//! - An impact obeys Newton's law on the normal relative speed (`Impact`).

/// A rebound whose free flight would bring the teeth back within this time locks the contact
/// at once (no Zeno chatter of ever shorter bounces) \[s\].
pub const ZENO_FLIGHT_TIME: f64 = 1e-6;

/// Relative speed [m/s] below which a rebound is not resolved in double precision at the
/// wheel speeds w_a, w_b: a few ulp of the pitch-line speeds that make it up.
pub fn speed_resolution(r_ab: f64, r_bb: f64, w_a: f64, w_b: f64) -> f64 {
    4.0 * f64::EPSILON * (r_ab * w_a.abs() + r_bb * w_b.abs())
}

/// Newton's impact law along the line of action: the relative normal speed v_minus (> 0,
/// approaching) becomes -e v_minus through the impulse P = (1 + e) m_eff v_minus.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Impact {
    pub impulse: f64,
    pub rebound_speed: f64,
}

impl Impact {
    /// `inv_m_eff` = 1/m_eff = rAb^2/J_A + rBb^2/J_B (+ sin^2(alpha_w)/m_S with a slider).
    pub fn new(v_minus: f64, restitution: f64, inv_m_eff: f64) -> Impact {
        Impact {
            impulse: (1.0 + restitution) * v_minus / inv_m_eff,
            rebound_speed: restitution * v_minus,
        }
    }

    /// The rebound is short enough to lock: its free flight under the approach acceleration
    /// `approach_acc` returns within ZENO_FLIGHT_TIME, or it is below `resolution`.
    pub fn ends_in_lock(&self, approach_acc: f64, resolution: f64) -> bool {
        self.rebound_speed <= resolution
            || (approach_acc > 0.0 && 2.0 * self.rebound_speed / approach_acc < ZENO_FLIGHT_TIME)
    }
}

/// The constraint force that holds d^2 delta/dt^2 = a0 + a1 N at zero; `None` when the loads
/// cannot hold it (a1 >= 0: friction so large that pressing harder accelerates the teeth
/// together, Painleve's paradox).
pub fn lock_force(a0: f64, a1: f64) -> Option<f64> {
    (a1 < 0.0).then(|| -a0 / a1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn impact_law_and_energy() {
        // Two bodies reduced to the line of action: the impulse changes the relative speed by
        // P / m_eff; the kinetic energy lost is (1 - e^2) m_eff v^2 / 2.
        let (v, inv_m) = (0.3, 2.5);
        for e in [0.0, 0.7, 1.0] {
            let i = Impact::new(v, e, inv_m);
            assert!((v - i.impulse * inv_m + i.rebound_speed).abs() < 1e-15);
            let m = 1.0 / inv_m;
            let lost = 0.5 * m * v * v - 0.5 * m * i.rebound_speed * i.rebound_speed;
            assert!((lost - 0.5 * (1.0 - e * e) * m * v * v).abs() < 1e-15);
        }
    }

    #[test]
    fn zeno_threshold() {
        let i = Impact::new(1e-3, 0.5, 1.0);
        // Flight time 2 * 5e-4 / a: locks for a above 1e3 m/s^2 / 1e-6 s.
        assert!(!i.ends_in_lock(900.0, 0.0));
        assert!(i.ends_in_lock(1.1e3 / ZENO_FLIGHT_TIME, 0.0));
        assert!(
            !i.ends_in_lock(-1.0, 0.0),
            "separating acceleration: no return"
        );
        assert!(i.ends_in_lock(-1.0, 1e-3), "below the resolution");
        assert_eq!(lock_force(2.0, -4.0), Some(0.5));
        assert_eq!(lock_force(2.0, 0.0), None);
    }
}
