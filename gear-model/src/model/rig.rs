//! The rest of the paper's rig (rig-and-modes.md §1, §3, §4): the mesh force on B as a vector in
//! the paper frame, and the slider S that carries B's bearing along O_A O_B. The housing's motion
//! enters the equations of motion as inertial torques (`Loads::alpha_housing`, `a_housing_x`).

use super::contact::Flank;
use super::ModelError;

/// B's bearing on the slider S: a spring along O_A O_B (small displacements, spec §3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slider {
    /// Stiffness k_S \[N/m\].
    pub k: f64,
    /// Damping c_S [N s/m].
    pub c: f64,
    /// Mass m_S moving with B \[kg\].
    pub m: f64,
}

impl Slider {
    /// The slider of stiffness k, damping c and mass m; `None` when k = 0 (B's bearing is rigid).
    pub fn new(k: f64, c: f64, m: f64) -> Result<Option<Slider>, ModelError> {
        if k == 0.0 {
            return Ok(None);
        }
        if !(m > 0.0) {
            return Err(ModelError::new(format!(
                "parameter slider_mass = {m}: must be > 0 with a slider (slider_stiffness = {k})"
            )));
        }
        Ok(Some(Slider { k, c, m }))
    }

    /// Natural frequency of the slider on its spring alone \[rad/s\].
    pub fn frequency(&self) -> f64 {
        (self.k / self.m).sqrt()
    }
}

/// Force that one pair exerts on wheel B, paper frame (rig-and-modes §1): the normal force f_n
/// along the flank's line of action u = (sin a, -cos a) (forward) or u_b = (sin a, cos a)
/// (backward), and the friction force f_t across it, signed as in gear-mesh-model §4.
pub fn force_on_b(f: Flank, f_n: f64, f_t: f64, sin_a: f64, cos_a: f64) -> (f64, f64) {
    match f {
        Flank::Forward => (f_n * sin_a + f_t * cos_a, -f_n * cos_a + f_t * sin_a),
        Flank::Backward => (f_n * sin_a - f_t * cos_a, f_n * cos_a + f_t * sin_a),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// rig-and-modes §1: taken at each pair's contact point (K_B - s_B u forward, K_B' - s_B u_b
    /// backward), the moment of the pair's force about O_B is the torque table's torque on B
    /// (gear-mesh-model §4, paper frame): +F_n rBb - F_t s_B forward, -F_n rBb - F_t s_B
    /// backward; and the moment of -F about O_A at the same point is the table's torque on A.
    /// The contact points are built here from the spec's vectors, independently of force_on_b.
    #[test]
    fn moments_of_the_vector_forces_are_the_torque_table() {
        let (a, r_ab, r_bb) = (0.35f64, 0.19, 0.28);
        let d = (r_ab + r_bb) / a.cos();
        let l = d * a.sin();
        let (sin_a, cos_a) = a.sin_cos();
        for f in [Flank::Forward, Flank::Backward] {
            for (s_a, f_n, f_t) in [
                (0.06, 1000.0, 0.0),
                (0.07, 800.0, 120.0),
                (0.11, 500.0, -90.0),
            ] {
                let s_b = l - s_a;
                let (k_a, u) = match f {
                    Flank::Forward => ((r_ab * a.cos(), r_ab * a.sin()), (a.sin(), -a.cos())),
                    Flank::Backward => ((r_ab * a.cos(), -r_ab * a.sin()), (a.sin(), a.cos())),
                };
                // The contact point from A's side (K_A + s_A u) and from B's side (K_B - s_B u).
                let p = (k_a.0 + s_a * u.0, k_a.1 + s_a * u.1);
                let k_b = match f {
                    Flank::Forward => (d - r_bb * a.cos(), -r_bb * a.sin()),
                    Flank::Backward => (d - r_bb * a.cos(), r_bb * a.sin()),
                };
                let p_b = (k_b.0 - s_b * u.0, k_b.1 - s_b * u.1);
                assert!((p.0 - p_b.0).abs() < 1e-12 && (p.1 - p_b.1).abs() < 1e-12);
                let (fx, fy) = force_on_b(f, f_n, f_t, sin_a, cos_a);
                let m_b = (p.0 - d) * fy - p.1 * fx;
                let m_a = p.0 * -fy - p.1 * -fx;
                let (t_a, t_b) = match f {
                    Flank::Forward => (f_n * r_ab - f_t * s_a, f_n * r_bb - f_t * s_b),
                    Flank::Backward => (-f_n * r_ab - f_t * s_a, -f_n * r_bb - f_t * s_b),
                };
                let scale = 1e-12 * (f_n.abs() + f_t.abs());
                assert!((m_b - t_b).abs() <= scale, "{f:?} B: {m_b} vs {t_b}");
                assert!((m_a - t_a).abs() <= scale, "{f:?} A: {m_a} vs {t_a}");
            }
        }
    }
}
