//! The control law, free of FMI: a PI speed controller sampled at the communication points.
//!
//! At `fmi2DoStep(t_k, h)` the controller samples the error `e_k = r(t_k) - w_A(t_k)` (the input
//! the master set before the step), integrates it held over the step,
//! `I_{k+1} = I_k + ki h e_k`, and sets its output for the next step to
//! `tau_{k+1} = sat(kp e_k + I_{k+1})`. The output never depends on the input set after the step,
//! so every master that exchanges values at communication points (Jacobi: step all, then
//! connect) produces the same sequence. As h -> 0 it tends to the continuous PI law
//! `tau = kp e + ki \int e dt`.
//!
//! Anti-windup by conditional integration: when the candidate output is beyond `tau_max` in the
//! direction the error pushes, the integral keeps its value.

/// The parameters, as the variable table names them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    pub w_ref: f64,
    pub t_ramp: f64,
    pub w_step: f64,
    pub t_step: f64,
    pub kp: f64,
    pub ki: f64,
    pub tau_max: f64,
}

/// The reference speed r(t): a ramp from 0 at `t0` to `w_ref` in `t_ramp`, plus a step
/// `w_step` from `t_step` on.
pub fn reference(p: &Params, t0: f64, t: f64) -> f64 {
    let ramp = if p.t_ramp > 0.0 {
        ((t - t0) / p.t_ramp).clamp(0.0, 1.0)
    } else {
        1.0
    };
    // The step is taken at t_step within the rounding of a master's accumulated time.
    let step = if t >= p.t_step - 1e-9 * p.t_step.abs().max(1.0) {
        p.w_step
    } else {
        0.0
    };
    p.w_ref * ramp + step
}

/// The controller's state and the outputs of the last update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pi {
    pub integral: f64,
    pub error: f64,
    pub tau: f64,
    pub saturated: bool,
}

impl Pi {
    /// The state at the start time: zero integral, output from the current error.
    pub fn initial(p: &Params, t0: f64, w: f64) -> Pi {
        let error = reference(p, t0, t0) - w;
        let (tau, saturated) = saturate(p.kp * error, p.tau_max);
        Pi {
            integral: 0.0,
            error,
            tau,
            saturated,
        }
    }

    /// One sampled update over [t, t + h] with the measured speed w at t.
    pub fn step(&mut self, p: &Params, t0: f64, t: f64, h: f64, w: f64) {
        let e = reference(p, t0, t) - w;
        let mut integral = self.integral + p.ki * h * e;
        let v = p.kp * e + integral;
        if (v > p.tau_max && e > 0.0) || (v < -p.tau_max && e < 0.0) {
            integral = self.integral;
        }
        let (tau, saturated) = saturate(p.kp * e + integral, p.tau_max);
        *self = Pi {
            integral,
            error: e,
            tau,
            saturated,
        };
    }
}

fn saturate(v: f64, max: f64) -> (f64, bool) {
    (v.clamp(-max, max), v.abs() > max)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Params {
        Params {
            w_ref: 100.0,
            t_ramp: 0.1,
            w_step: 20.0,
            t_step: 0.2,
            kp: 10.0,
            ki: 100.0,
            tau_max: 50.0,
        }
    }

    #[test]
    fn reference_ramps_then_steps() {
        let p = params();
        assert_eq!(reference(&p, 0.0, 0.0), 0.0);
        assert!((reference(&p, 0.0, 0.05) - 50.0).abs() < 1e-12);
        assert_eq!(reference(&p, 0.0, 0.15), 100.0);
        assert_eq!(reference(&p, 0.0, 0.2), 120.0);
        let step_only = Params { t_ramp: 0.0, ..p };
        assert_eq!(reference(&step_only, 0.0, 0.0), 100.0);
    }

    #[test]
    fn integrates_the_held_error_and_saturates_without_windup() {
        let p = Params {
            t_ramp: 0.0,
            w_step: 0.0,
            ..params()
        };
        let mut pi = Pi::initial(&p, 0.0, 99.0);
        assert_eq!((pi.error, pi.tau, pi.integral), (1.0, 10.0, 0.0));
        pi.step(&p, 0.0, 0.0, 0.01, 99.0);
        assert!((pi.integral - 1.0).abs() < 1e-12);
        assert!((pi.tau - 11.0).abs() < 1e-12);
        // A large error saturates the output and freezes the integral.
        pi.step(&p, 0.0, 0.01, 0.01, 0.0);
        assert!(pi.saturated);
        assert_eq!(pi.tau, 50.0);
        assert!((pi.integral - 1.0).abs() < 1e-12);
        // Back inside the limits the integral moves again.
        pi.step(&p, 0.0, 0.02, 0.01, 100.5);
        assert!(!pi.saturated);
        assert!((pi.integral - 0.5).abs() < 1e-12);
        assert!((pi.tau - (-5.0 + 0.5)).abs() < 1e-12);
    }
}
