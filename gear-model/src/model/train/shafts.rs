//! The shafts' twists and torques (gear-train.md §1).

use super::*;

impl Train {
    /// Shaft j's twist theta_a - theta_b + twist_start and its rate at y.
    pub(super) fn shaft_state<const N: usize>(
        &self,
        j: usize,
        y: &[f64],
        b: Option<&Bodies<N>>,
    ) -> (f64, f64) {
        let c = &*self.cfg;
        match c.coords.shaft[j] {
            Source::Coord(k) => (y[coord_index(k)], y[coord_index(k) + 1]),
            _ => {
                let (a, e) = c.shaft_ends[j];
                let own;
                let b = match b {
                    Some(b) => b,
                    None => {
                        own = self.bodies_in::<N>(y);
                        &own
                    }
                };
                (
                    b.theta[a] - b.theta[e] + c.spec.shafts[j].twist_start,
                    b.w[a] - b.w[e],
                )
            }
        }
    }

    /// Shaft j's transmitted torque at y (gear-train.md §1).
    pub fn shaft_torque(&self, j: usize, y: &[f64]) -> f64 {
        let sh = &self.cfg.spec.shafts[j];
        let (q, dq) = self.shaft_state::<SLOTS>(j, y, None);
        sh.k * q + sh.d * dq
    }

    /// Shaft j's twist theta_a - theta_b + twist_start at y.
    pub fn shaft_twist(&self, j: usize, y: &[f64]) -> f64 {
        self.shaft_state::<SLOTS>(j, y, None).0
    }

    /// Shaft j's twist rate w_a - w_b at y.
    pub fn shaft_twist_rate(&self, j: usize, y: &[f64]) -> f64 {
        self.shaft_state::<SLOTS>(j, y, None).1
    }
}
