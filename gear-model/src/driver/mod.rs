//! The integration driver: advances a `System` to a communication point with an adaptive,
//! error-controlled method and locates every event on the method's dense output, so the
//! right-hand side is smooth inside each internal step (modes change only at located events).
//!
//! Internal steps are independent of the communication steps: a step may reach past the
//! communication point, and the next `advance` continues it as long as the inputs did not change.
//!
//! Nothing here knows the gear: a `System` brings its own state, event and error types, and
//! `simulation.rs` connects the mesh (tests/driver_toys.rs drives an oscillator and a ball).

pub mod bdf;
mod copy;
pub mod dop853;
pub mod dopri5;
pub mod exchange;
mod locate;
pub mod simulation;
pub mod stability;
pub mod train_simulation;
pub mod wide;

pub use locate::MarginCache;
use locate::Scratch;
use serde::{Deserialize, Serialize};
pub use stability::Stability;
use std::fmt::Debug;
use std::ops::{Index, IndexMut};

/// A fixed-size vector of reals: a system's state, or the values of its event functions.
pub trait Vector:
    Copy + Debug + PartialEq + Index<usize, Output = f64> + IndexMut<usize> + 'static
{
    const LEN: usize;
    fn zeros() -> Self;
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    fn as_slice(&self) -> &[f64];
    fn as_mut_slice(&mut self) -> &mut [f64];
}

impl<const N: usize> Vector for [f64; N] {
    const LEN: usize = N;
    fn zeros() -> Self {
        [0.0; N]
    }
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self {
        std::array::from_fn(f)
    }
    fn as_slice(&self) -> &[f64] {
        self
    }
    fn as_mut_slice(&mut self) -> &mut [f64] {
        self
    }
}

/// What a system says about an event it handled.
pub trait EventOutcome {
    /// The event left the right-hand side as it was (only bookkeeping changed): the step stays
    /// valid and the driver continues it without a restart.
    fn smooth(&self) -> bool;
}

/// What the driver needs of a model: its state, its event functions and its error are the
/// model's own types.
pub trait System {
    type State: Vector;
    /// Why the right-hand side cannot be evaluated (a law out of its range).
    type Error: std::error::Error + Clone + PartialEq + 'static;
    type Report: EventOutcome;
    fn rhs(&self, y: &Self::State, dy: &mut Self::State) -> Result<(), Self::Error>;
    /// The number of event functions: the margins' length. Only the functions a model can
    /// trigger count (its contacts that can engage), so the rest cost nothing per step.
    fn n_events(&self) -> usize;
    /// Signed distance of every event function to its crossing: >= 0 until it crosses.
    /// `out` is `n_events()` long.
    fn event_margins(&self, y: &Self::State, out: &mut [f64]);
    /// The margins at y and their time derivatives with state rate dy (NaN where unknown).
    fn event_margins_and_rates(
        &self,
        y: &Self::State,
        dy: &Self::State,
        margins: &mut [f64],
        rates: &mut [f64],
    );
    fn margin(&self, i: usize, y: &Self::State) -> f64;
    /// Applies event i at y; the event may change y (an impact changes speeds).
    fn handle_event(&mut self, i: usize, y: &mut Self::State) -> Result<Self::Report, Self::Error>;
    /// Checks an accepted state against limits the right-hand side does not see.
    fn check_state(&self, y: &Self::State) -> Result<(), Self::Error>;
    /// Largest step that cannot step over a whole event cycle (e.g. a tooth pitch), and for an
    /// explicit method (`stability`: what its stability region allows, `Stability`) keeps
    /// oscillations of angular frequency omega within it.
    fn max_step(&self, y: &Self::State, stability: Option<Stability>) -> f64;
    /// The number of state components in use, a prefix of the state.
    fn dim(&self) -> usize;
    /// Takes in the piece [t0, t1] of a step between events, on which `y` is the dense output
    /// and the modes hold (the run's statistics). Systems that keep none ignore it.
    fn observe(
        &mut self,
        _t0: f64,
        _t1: f64,
        _y: &dyn Fn(f64) -> Self::State,
    ) -> Result<(), Self::Error> {
        Ok(())
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    pub steps: u64,
    pub rejected: u64,
    pub rhs_evals: u64,
    pub jac_evals: u64,
    pub factorizations: u64,
    pub events: u64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tolerance<Y> {
    pub rtol: f64,
    /// Absolute tolerance of each component; 0: not under error control.
    pub atol: Y,
}

/// Why a method could not take its step (the driver adds the context).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError<E> {
    #[error(transparent)]
    Law(E),
    #[error("at t = {t} s the step fell to {h} s without meeting the tolerance")]
    StepTooSmall { t: f64, h: f64 },
    /// The implicit solver (diffsol) failed otherwise.
    #[error("at t = {t} s the implicit solver failed: {message}")]
    Solver { t: f64, message: String },
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DriverError<E> {
    /// The contact law left its range at time t.
    #[error("at t = {t} s: {err}")]
    Law { t: f64, err: E },
    #[error("at t = {t} s the integrator's step fell to {h} s without meeting the tolerance")]
    StepTooSmall { t: f64, h: f64 },
    #[error("at t = {t} s the implicit solver failed: {message}")]
    Solver { t: f64, message: String },
    /// The work cap of one communication step was reached (e.g. chattering contacts).
    #[error(
        "at t = {t} s the communication step needed more than {steps} internal steps or {events} events \
         (the work cap per step); reduce the communication step or check the scene"
    )]
    TooMuchWork { t: f64, steps: u64, events: u64 },
}

/// Time t in a driver that integrates in time since `origin`. A zero keeps the origin's sign,
/// so that origin + since(origin, origin) is the origin bit for bit (a start time of -0).
pub fn since(t: f64, origin: f64) -> f64 {
    let x = t - origin;
    if x == 0.0 {
        0.0f64.copysign(origin)
    } else {
        x
    }
}

impl<E> DriverError<E> {
    /// The same error with its time moved by `origin` (a driver integrating in time since
    /// `origin` reports the FMU's time).
    pub fn shifted(self, origin: f64) -> DriverError<E> {
        match self {
            DriverError::Law { t, err } => DriverError::Law { t: t + origin, err },
            DriverError::StepTooSmall { t, h } => DriverError::StepTooSmall { t: t + origin, h },
            DriverError::Solver { t, message } => DriverError::Solver {
                t: t + origin,
                message,
            },
            DriverError::TooMuchWork { t, steps, events } => DriverError::TooMuchWork {
                t: t + origin,
                steps,
                events,
            },
        }
    }
}

/// Weighted RMS norm over the controlled components (those with an absolute tolerance).
pub fn error_norm<Y: Vector>(e: &Y, y0: &Y, y1: &Y, tol: &Tolerance<Y>) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for i in (0..Y::LEN).filter(|&i| tol.atol[i] > 0.0) {
        let sk = tol.atol[i] + tol.rtol * y0[i].abs().max(y1[i].abs());
        let r = e[i] / sk;
        sum += r * r;
        n += 1;
    }
    (sum / n as f64).sqrt()
}

/// Smallest meaningful step at time t: below it t + h == t in floating point, or nearly.
pub fn min_step(t: f64) -> f64 {
    16.0 * f64::EPSILON * t.abs().max(1e-3)
}

/// Hairer's starting step estimate (Solving ODEs I, II.4) for a method of the given order.
pub fn initial_step<S: System>(
    sys: &S,
    y: &S::State,
    f0: &S::State,
    order: i32,
    stability: Stability,
    tol: &Tolerance<S::State>,
    stats: &mut Stats,
) -> Result<f64, StepError<S::Error>> {
    let zero = S::State::zeros();
    let d0 = error_norm(y, &zero, &zero, tol);
    let d1 = error_norm(f0, &zero, &zero, tol);
    let h0 = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    };
    let h0 = h0.min(sys.max_step(y, Some(stability)));
    let y1 = S::State::from_fn(|i| y[i] + h0 * f0[i]);
    let mut f1 = S::State::zeros();
    sys.rhs(&y1, &mut f1).map_err(StepError::Law)?;
    stats.rhs_evals += 1;
    let df = S::State::from_fn(|i| f1[i] - f0[i]);
    let d2 = error_norm(&df, &zero, &zero, tol) / h0;
    let h1 = if d1.max(d2) <= 1e-15 {
        (h0 * 1e-3).max(1e-6)
    } else {
        (0.01 / d1.max(d2)).powf(1.0 / (order as f64 + 1.0))
    };
    Ok((100.0 * h0).min(h1).min(sys.max_step(y, Some(stability))))
}

/// The integration methods, chosen by the `solver` parameter: the hand-written Dormand-Prince
/// pairs of orders 5 and 8 and diffsol's BDF (docs/integrators.md has the measurements behind
/// the choices).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "S::State: Serialize",
    deserialize = "S::State: Deserialize<'de>"
))]
pub enum Method<S: System> {
    Dopri5(dopri5::Dopri5<S::State>),
    Bdf(bdf::Bdf<S>),
    /// Boxed: inline it would make every method as large as its 8th-order dense output, and
    /// `fmi2DoStep` copies the method before each step (to undo a failed one).
    Dop853(Box<dop853::Dop853<S::State>>),
}

/// What the driver reads of a method: its last step and the dense output over it.
pub trait DenseOutput<Y> {
    /// The time the method has integrated to, and the start of its last step.
    fn t(&self) -> f64;
    fn t_prev(&self) -> f64;
    fn y(&self) -> &Y;
    /// The step size it will try next.
    fn h(&self) -> f64;
    /// The state's rate at the end of the last step (at a restart: at the restart point).
    fn rate_at_end(&self) -> Y;
    /// The dense output and its rate at time t inside the last step.
    fn interpolate(&self, t: f64) -> Y;
    fn derivative(&self, t: f64) -> Y;
    /// For an explicit method, what its stability region allows a step on an oscillation
    /// (`System::max_step`); None for an implicit one.
    fn stability(&self) -> Option<Stability>;
}

/// How the driver steps a method on a system.
pub trait Stepper<S: System>: DenseOutput<S::State> {
    /// Starts at (t, y), with a step-size hint (else the method's own estimate).
    fn restart(
        &mut self,
        sys: &S,
        t: f64,
        y: &S::State,
        h: Option<f64>,
        tol: &Tolerance<S::State>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>>;
    /// One accepted step of at most h_max.
    fn step(
        &mut self,
        sys: &S,
        h_max: f64,
        tol: &Tolerance<S::State>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>>;
}

/// The traits of an explicit Runge-Kutta method with its own `restart`, `step`, `interpolate`
/// and `derivative`, and `t`, `t_prev`, `h`, `y` and `k1` (the rate at the step's end), with the
/// reach of its stability region on the imaginary axis.
macro_rules! explicit_method {
    ($method:ty, $stability:expr) => {
        impl<Y: Vector> DenseOutput<Y> for $method {
            fn t(&self) -> f64 {
                self.t
            }
            fn t_prev(&self) -> f64 {
                self.t_prev
            }
            fn y(&self) -> &Y {
                &self.y
            }
            fn h(&self) -> f64 {
                self.h
            }
            fn rate_at_end(&self) -> Y {
                self.k1
            }
            fn interpolate(&self, t: f64) -> Y {
                <$method>::interpolate(self, t)
            }
            fn derivative(&self, t: f64) -> Y {
                <$method>::derivative(self, t)
            }
            fn stability(&self) -> Option<Stability> {
                Some($stability)
            }
        }

        impl<S: System<State = Y>, Y: Vector> Stepper<S> for $method {
            fn restart(
                &mut self,
                sys: &S,
                t: f64,
                y: &Y,
                h: Option<f64>,
                tol: &Tolerance<Y>,
                stats: &mut Stats,
            ) -> Result<(), StepError<S::Error>> {
                <$method>::restart(self, sys, t, y, h, tol, stats)
            }
            fn step(
                &mut self,
                sys: &S,
                h_max: f64,
                tol: &Tolerance<Y>,
                stats: &mut Stats,
            ) -> Result<(), StepError<S::Error>> {
                <$method>::step(self, sys, h_max, tol, stats)
            }
        }
    };
}

explicit_method!(dopri5::Dopri5<Y>, dopri5::STABILITY);
explicit_method!(dop853::Dop853<Y>, dop853::STABILITY);

/// What an explicit method needs at a restart from y: the rate there, and the first step (the
/// hint, else Hairer's estimate for the method's order and stability limit).
pub(crate) fn explicit_start<S: System>(
    sys: &S,
    y: &S::State,
    h_hint: Option<f64>,
    order: i32,
    stability: Stability,
    tol: &Tolerance<S::State>,
    stats: &mut Stats,
) -> Result<(S::State, f64), StepError<S::Error>> {
    let mut f = S::State::zeros();
    sys.rhs(y, &mut f).map_err(StepError::Law)?;
    stats.rhs_evals += 1;
    let h = match h_hint {
        Some(h) => h,
        None => initial_step(sys, y, &f, order, stability, tol, stats)?,
    };
    Ok((f, h))
}

impl<S: System + Clone + 'static> DenseOutput<S::State> for bdf::Bdf<S> {
    fn t(&self) -> f64 {
        self.t
    }
    fn t_prev(&self) -> f64 {
        self.t_prev
    }
    fn y(&self) -> &S::State {
        &self.y
    }
    fn h(&self) -> f64 {
        self.h
    }
    fn rate_at_end(&self) -> S::State {
        bdf::Bdf::rate_at_end(self)
    }
    fn interpolate(&self, t: f64) -> S::State {
        bdf::Bdf::interpolate(self, t)
    }
    /// diffsol has no derivative of its interpolant: a central difference inside the step.
    fn derivative(&self, t: f64) -> S::State {
        let (t0, t1) = (self.t_prev, self.t);
        let d = 1e-4 * (t1 - t0);
        let (a, b) = ((t - d).max(t0), (t + d).min(t1));
        let (ya, yb) = (self.interpolate(a), self.interpolate(b));
        S::State::from_fn(|i| (yb[i] - ya[i]) / (b - a))
    }
    fn stability(&self) -> Option<Stability> {
        None
    }
}

impl<S: System + Clone + 'static> Stepper<S> for bdf::Bdf<S> {
    fn restart(
        &mut self,
        sys: &S,
        t: f64,
        y: &S::State,
        h: Option<f64>,
        tol: &Tolerance<S::State>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>> {
        bdf::Bdf::restart(self, sys, t, y, h, tol, stats)
    }
    fn step(
        &mut self,
        sys: &S,
        h_max: f64,
        _tol: &Tolerance<S::State>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>> {
        bdf::Bdf::step(self, sys, h_max, stats)
    }
}

impl<S: System + Clone + 'static> Method<S> {
    pub fn from_solver(solver: i32) -> Method<S> {
        match solver {
            2 => Method::Bdf(bdf::Bdf::new()),
            3 => Method::Dop853(Box::default()),
            _ => Method::Dopri5(dopri5::Dopri5::new()),
        }
    }

    /// The one place that tells the methods apart.
    fn dense(&self) -> &dyn DenseOutput<S::State> {
        match self {
            Method::Dopri5(m) => m,
            Method::Bdf(m) => m,
            Method::Dop853(m) => &**m,
        }
    }

    fn stepper(&mut self) -> &mut dyn Stepper<S> {
        match self {
            Method::Dopri5(m) => m,
            Method::Bdf(m) => m,
            Method::Dop853(m) => &mut **m,
        }
    }

    fn stability(&self) -> Option<Stability> {
        self.dense().stability()
    }

    fn t(&self) -> f64 {
        self.dense().t()
    }

    fn t_prev(&self) -> f64 {
        self.dense().t_prev()
    }

    fn y(&self) -> &S::State {
        self.dense().y()
    }

    fn h(&self) -> f64 {
        self.dense().h()
    }

    fn rate_at_end(&self) -> S::State {
        self.dense().rate_at_end()
    }

    fn derivative(&self, t: f64) -> S::State {
        self.dense().derivative(t)
    }

    fn interpolate(&self, t: f64) -> S::State {
        if t == self.t() {
            return *self.y();
        }
        self.dense().interpolate(t)
    }

    fn restart(
        &mut self,
        sys: &S,
        t: f64,
        y: &S::State,
        h: Option<f64>,
        tol: &Tolerance<S::State>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>> {
        self.stepper().restart(sys, t, y, h, tol, stats)
    }

    fn step(
        &mut self,
        sys: &S,
        h_max: f64,
        tol: &Tolerance<S::State>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>> {
        self.stepper().step(sys, h_max, tol, stats)
    }
}

/// How many accepted steps a computed step limit serves (see `Driver::step_limit`).
const STEP_LIMIT_AGE: u64 = 8;

/// An event found inside the method's current step, not yet handled.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PendingEvent {
    pub t: f64,
    pub index: usize,
}

/// Work cap per `advance`; past it the step ends with `TooMuchWork`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorkCap {
    pub steps: u64,
    pub events: u64,
}

impl Default for WorkCap {
    fn default() -> Self {
        // About a second of work at worst: a master asking for more in one step gets fmi2Discard
        // and can retry with shorter communication steps.
        WorkCap {
            steps: 1_000_000,
            events: 200_000,
        }
    }
}

#[derive(Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "S::State: Serialize",
    deserialize = "S::State: Deserialize<'de>"
))]
pub struct Driver<S: System> {
    pub method: Method<S>,
    pub tol: Tolerance<S::State>,
    /// The FMU's time; the method may have stepped beyond it.
    pub t: f64,
    /// The method's step must be redone from `t` (inputs changed, or not started).
    pub needs_restart: bool,
    pub pending: Option<PendingEvent>,
    pub stats: Stats,
    pub cap: WorkCap,
    /// Never step past this time (the experiment's stop time, if any).
    pub t_stop: f64,
    pub y_start: S::State,
    /// `System::max_step` as last computed: it costs a contact-law evaluation, and the limits it
    /// holds (stiffness, contact speed) change slowly, so it is renewed at restarts and every
    /// `STEP_LIMIT_AGE` accepted steps. NaN: not computed yet.
    pub(crate) step_limit: f64,
    pub(crate) start: MarginCache,
    #[serde(skip)]
    scratch: Scratch,
    /// A cap on the internal step (tests force small steps with it); infinite by default.
    pub max_step: f64,
    /// `System::observe` has seen the dense output up to this time.
    pub observed: f64,
    /// Events of the current step are searched from here: its start, or the last event after
    /// which the step continued (`EventReport::smooth`).
    pub search_from: f64,
}

impl<S: System + Clone + 'static> Driver<S> {
    pub fn new(method: Method<S>, tol: Tolerance<S::State>, t0: f64, y0: S::State) -> Driver<S> {
        Driver {
            method,
            tol,
            t: t0,
            needs_restart: true,
            pending: None,
            stats: Stats::default(),
            cap: WorkCap::default(),
            t_stop: f64::INFINITY,
            y_start: y0,
            step_limit: f64::NAN,
            start: MarginCache::default(),
            scratch: Scratch::default(),
            max_step: f64::INFINITY,
            observed: t0,
            search_from: t0,
        }
    }

    /// The state at the FMU's current time.
    pub fn state(&self) -> S::State {
        if self.needs_restart {
            self.y_start
        } else {
            self.method.interpolate(self.t)
        }
    }

    /// The time the method has integrated to (it may lie past the FMU's time).
    pub fn method_time(&self) -> f64 {
        self.method.t()
    }

    /// Hands the dense output from the last observation up to t (inside the current step) to
    /// the system.
    pub fn observe_to(&mut self, sys: &mut S, t: f64) -> Result<(), DriverError<S::Error>> {
        if !self.needs_restart && t > self.observed {
            let method = &self.method;
            sys.observe(self.observed, t, &|x| method.interpolate(x))
                .map_err(|err| DriverError::Law { t, err })?;
        }
        self.observed = self.observed.max(t);
        Ok(())
    }

    /// The right-hand side changes from the current time on (new inputs or tunables). The
    /// system has observed the dense output up to here (`observe_to`).
    pub fn invalidate(&mut self) {
        debug_assert!(self.needs_restart || self.observed >= self.t);
        if !self.needs_restart {
            self.y_start = self.state();
            self.needs_restart = true;
        }
    }

    /// Advances to t_end, handling every event on the way. `log` receives each event.
    pub fn advance(
        &mut self,
        sys: &mut S,
        t_end: f64,
        log: &mut dyn FnMut(f64, &S::Report),
    ) -> Result<(), DriverError<S::Error>> {
        let (steps0, events0) = (self.stats.steps + self.stats.rejected, self.stats.events);
        if self.needs_restart {
            let h = if self.method.h() > 0.0 {
                Some(self.method.h())
            } else {
                None
            };
            let y = self.y_start;
            self.restart(sys, self.t, &y, h)?;
        }
        loop {
            if let Some(ev) = self.pending {
                if ev.t > t_end {
                    self.t = t_end;
                    return Ok(());
                }
                self.pending = None;
                self.observe_to(sys, ev.t)?;
                let y_event = self.method.interpolate(ev.t);
                let mut y = y_event;
                let report = sys
                    .handle_event(ev.index, &mut y)
                    .map_err(|err| DriverError::Law { t: ev.t, err })?;
                self.stats.events += 1;
                log(ev.t, &report);
                self.t = ev.t;
                if report.smooth() && y == y_event {
                    // The step is still a step of the same right-hand side: search the rest of
                    // it for the next event under the new modes.
                    self.search_from = ev.t;
                    self.start.clear();
                    self.locate_and_check(sys)?;
                    continue;
                }
                let h = self.method.h();
                self.restart(sys, ev.t, &y, Some(h))?;
                continue;
            }
            if self.method.t() >= t_end {
                self.t = t_end;
                return Ok(());
            }
            let work = self.stats.steps + self.stats.rejected - steps0;
            if work > self.cap.steps || self.stats.events - events0 > self.cap.events {
                return Err(DriverError::TooMuchWork {
                    t: self.method.t(),
                    steps: self.cap.steps,
                    events: self.cap.events,
                });
            }
            self.observe_to(sys, self.method.t())?;
            if self.step_limit.is_nan() || self.stats.steps.is_multiple_of(STEP_LIMIT_AGE) {
                self.step_limit = sys.max_step(self.method.y(), self.method.stability());
            }
            let h_max = self
                .step_limit
                .min(self.max_step)
                .min(self.t_stop - self.method.t());
            let h_max = if h_max > 0.0 { h_max } else { f64::INFINITY };
            self.method
                .step(sys, h_max, &self.tol, &mut self.stats)
                .map_err(|e| self.step_error(e))?;
            self.search_from = self.method.t_prev();
            self.locate_and_check(sys)?;
        }
    }

    /// Finds the first event from `search_from` in the last step, and checks the state there.
    fn locate_and_check(&mut self, sys: &S) -> Result<(), DriverError<S::Error>> {
        self.pending = self.locate(sys);
        // A step may overshoot past an event into states the modes before it never reach:
        // the limits hold up to the first event.
        let (t, y) = match self.pending {
            Some(e) => (e.t, self.method.interpolate(e.t)),
            None => (self.method.t(), *self.method.y()),
        };
        sys.check_state(&y)
            .map_err(|err| DriverError::Law { t, err })
    }

    fn restart(
        &mut self,
        sys: &S,
        t: f64,
        y: &S::State,
        h: Option<f64>,
    ) -> Result<(), DriverError<S::Error>> {
        self.method
            .restart(sys, t, y, h, &self.tol, &mut self.stats)
            .map_err(|e| self.step_error(e))?;
        self.needs_restart = false;
        self.pending = None;
        self.observed = t;
        self.search_from = t;
        self.y_start = *y;
        self.step_limit = f64::NAN;
        self.start.clear();
        Ok(())
    }

    fn step_error(&self, e: StepError<S::Error>) -> DriverError<S::Error> {
        match e {
            StepError::Law(err) => DriverError::Law {
                t: self.method.t(),
                err,
            },
            StepError::StepTooSmall { t, h } => DriverError::StepTooSmall { t, h },
            StepError::Solver { t, message } => DriverError::Solver { t, message },
        }
    }
}
