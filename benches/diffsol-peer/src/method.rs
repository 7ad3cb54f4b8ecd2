//! The interface between the diffsol wrapper and the event loop (from the scratch probe that
//! first tried diffsol; the wrapper in `diffsol_method.rs` implements it).

/// The model as a method sees it: a right-hand side that is smooth between events (the modes are
/// frozen inside the model object; the loop changes them only between restarts).
pub trait Rhs {
    fn dim(&self) -> usize;
    /// dy = f(t, y). An Err means "state outside the model's range": the method must reject/shrink
    /// the step.
    #[allow(clippy::result_unit_err)]
    fn eval(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), ()>;
}

#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    pub steps: u64,
    pub rejected: u64,
    pub rhs_evals: u64,
    pub jac_evals: u64,
    pub factorizations: u64,
}

pub trait Method {
    /// Start afresh at (t, y): after an event, after an input change, or at the first step.
    fn restart(&mut self, rhs: &dyn Rhs, t: f64, y: &[f64]);
    /// One accepted internal step, never past t_limit. Returns the new time.
    fn step(&mut self, rhs: &dyn Rhs, t_limit: f64) -> Result<f64, String>;
    fn t(&self) -> f64;
    fn t_prev(&self) -> f64;
    fn y(&self) -> &[f64];
    /// Dense output anywhere in [t_prev, t].
    fn interpolate(&self, t: f64, out: &mut [f64]);
    fn stats(&self) -> Stats;
}
