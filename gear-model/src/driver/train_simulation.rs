//! The gear train and its driver together (what the train FMU steps), and the train as the
//! driver's `System` at two capacities: the same event location as the single mesh, over every
//! mesh's events.

use super::exchange::ExchangeRig;
use super::{Driver, DriverError, Method, Stats, System, Tolerance};
use crate::model::contact::EventFn;
use crate::model::mesh::{EventReport, LawOutOfRange};
use crate::model::statistics::Statistics;
use crate::model::train::{CompactState, State, Train, TrainLoads, TrainSpec, NY_COMPACT};
use crate::model::ModelError;
use std::ops::DerefMut;

/// The train with states of `NY_COMPACT` reals: a train whose coordinates fit (every train
/// without lateral bodies) steps on it, so that the integrator's stages and the copy that
/// undoes a failed communication step cost what its coordinates need, not the full capacity
/// (docs/lateral.md, "Capacity").
#[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Compact(pub Train);

impl Clone for Compact {
    fn clone(&self) -> Self {
        Compact(self.0.clone())
    }
    fn clone_from(&mut self, src: &Self) {
        self.0.clone_from(&src.0)
    }
}

/// What the driver's run needs of a train at one capacity.
pub trait TrainSystem:
    System<Error = LawOutOfRange, Report = EventReport, State: DerefMut<Target = [f64]>>
    + Clone
    + std::fmt::Debug
    + PartialEq
    + 'static
{
    fn train(&self) -> &Train;
    fn train_mut(&mut self) -> &mut Train;
    fn into_train(self) -> Train;
    /// A full-capacity state at this capacity (its components past `dim` are 0).
    fn narrow(y: &State) -> Self::State;
    fn widen(y: &Self::State) -> State;
}

impl TrainSystem for Train {
    fn train(&self) -> &Train {
        self
    }
    fn train_mut(&mut self) -> &mut Train {
        self
    }
    fn into_train(self) -> Train {
        self
    }
    fn narrow(y: &State) -> State {
        *y
    }
    fn widen(y: &State) -> State {
        *y
    }
}

impl TrainSystem for Compact {
    fn train(&self) -> &Train {
        &self.0
    }
    fn train_mut(&mut self) -> &mut Train {
        &mut self.0
    }
    fn into_train(self) -> Train {
        self.0
    }
    fn narrow(y: &State) -> CompactState {
        y.resized()
    }
    fn widen(y: &CompactState) -> State {
        y.resized()
    }
}

/// The train as the driver's `System`, at each capacity: the model reads states as slices.
macro_rules! train_as_system {
    ($sys:ty, $state:ty) => {
        impl System for $sys {
            type State = $state;
            type Error = LawOutOfRange;
            type Report = EventReport;
            fn rhs(&self, y: &$state, dy: &mut $state) -> Result<(), LawOutOfRange> {
                self.train().rhs(y, dy)
            }
            fn event_margins(&self, y: &$state, out: &mut [f64]) {
                self.train().event_margins(y, out)
            }
            fn event_margins_and_rates(
                &self,
                y: &$state,
                dy: &$state,
                margins: &mut [f64],
                rates: &mut [f64],
            ) {
                self.train().event_margins_and_rates(y, dy, margins, rates)
            }
            fn margin(&self, i: usize, y: &$state) -> f64 {
                self.train().margin(i, y)
            }
            fn n_events(&self) -> usize {
                self.train().n_event_fns()
            }
            fn check_state(&self, y: &$state) -> Result<(), LawOutOfRange> {
                self.train().check_state(y)
            }
            fn handle_event(
                &mut self,
                i: usize,
                y: &mut $state,
            ) -> Result<EventReport, LawOutOfRange> {
                self.train_mut().handle_event(i, y)
            }
            fn max_step(&self, y: &$state, stability: Option<super::Stability>) -> f64 {
                self.train().max_step(y, stability)
            }
            fn dim(&self) -> usize {
                self.train().dim()
            }
            fn observe(
                &mut self,
                t0: f64,
                t1: f64,
                y: &dyn Fn(f64) -> $state,
            ) -> Result<(), LawOutOfRange> {
                self.train_mut().observe(t0, t1, y)
            }
        }
    };
}

train_as_system!(Train, State);
train_as_system!(Compact, CompactState);

/// The driver's tolerances for the train at rel_tol (`Train::abs_tol`).
pub fn tolerance<S: TrainSystem>(train: &Train, rtol: f64) -> Tolerance<S::State> {
    Tolerance {
        rtol,
        atol: S::narrow(&train.abs_tol(rtol)),
    }
}

/// The gear train and its driver at one capacity.
#[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(bound(
    serialize = "S: serde::Serialize, S::State: serde::Serialize",
    deserialize = "S: serde::Deserialize<'de>, S::State: serde::Deserialize<'de>"
))]
pub struct TrainRun<S: TrainSystem> {
    pub train: S,
    /// Integrates in time since `origin` (see `Simulation::driver`).
    pub driver: Driver<S>,
    /// The experiment's start time \[s\]: the driver's time 0.
    pub origin: f64,
}

impl<S: TrainSystem> Clone for TrainRun<S> {
    /// As `Simulation::clone`: a BDF driver clones into a restart point, with the statistics
    /// up to now. Inlined into the caller's slot (as `Driver::clone`): a call would add a copy.
    #[inline(always)]
    fn clone(&self) -> Self {
        let d = &self.driver;
        let restart_point = matches!(d.method, Method::Bdf(_)) && !d.needs_restart;
        let mut train = self.train.clone();
        let mut driver = self.driver.clone();
        if restart_point && train.train().stats.is_some() && d.t > d.observed {
            train.train_mut().stats = self.statistics();
            driver.observed = driver.t;
        }
        TrainRun {
            train,
            driver,
            origin: self.origin,
        }
    }

    /// In place, keeping the buffers (`fmi2DoStep`'s backup); a BDF run as `clone`.
    fn clone_from(&mut self, src: &Self) {
        if matches!(src.driver.method, Method::Bdf(_)) {
            *self = src.clone();
            return;
        }
        self.train.clone_from(&src.train);
        self.driver.clone_from(&src.driver);
        self.origin = src.origin;
    }
}

impl<S: TrainSystem> TrainRun<S> {
    /// The train from y0 at this capacity (`TrainSimulation::new` chooses it).
    pub fn new(train: Train, y0: &State, solver: i32, t0: f64, rel_tol: f64) -> Self
    where
        S: From<Train>,
    {
        let tol = tolerance::<S>(&train, rel_tol);
        let y0 = S::narrow(y0);
        let driver = Driver::new(Method::from_solver(solver), tol, super::since(t0, t0), y0);
        TrainRun {
            train: S::from(train),
            driver,
            origin: t0,
        }
    }

    pub fn time(&self) -> f64 {
        self.origin + self.driver.t
    }

    pub fn set_time(&mut self, t: f64) {
        self.driver.t = super::since(t, self.origin);
    }

    pub fn set_stop_time(&mut self, t: f64) {
        self.driver.t_stop = t - self.origin;
    }

    pub fn into_train(self) -> Train {
        let mut train = self.train.into_train();
        for s in train.stats.iter_mut().flatten() {
            s.start += self.origin;
        }
        train
    }

    pub fn set_loads(&mut self, loads: TrainLoads) {
        if loads != self.train.train().loads {
            self.observe_to_now();
            self.driver.invalidate();
            let mut y = self.driver.state();
            self.train.train_mut().set_loads(loads, &mut y);
            self.driver.y_start = y;
            self.driver.tol = tolerance::<S>(self.train.train(), self.driver.tol.rtol);
        }
    }

    pub fn make_restart_point_if_needed(&mut self) {
        if matches!(self.driver.method, Method::Bdf(_)) {
            self.observe_to_now();
            self.driver.invalidate();
        }
    }

    fn observe_to_now(&mut self) {
        let t = self.driver.t;
        if self.driver.observe_to(&mut self.train, t).is_err() {
            if let Some(all) = self.train.train_mut().stats.as_mut() {
                all.iter_mut().for_each(Statistics::poison);
            }
        }
    }

    pub fn statistics(&self) -> Option<Vec<Statistics>> {
        let train = self.train.train();
        let mut all = train.stats.clone()?;
        let d = &self.driver;
        if !d.needs_restart && d.t > d.observed {
            let y = |x| d.method.interpolate(x);
            for (m, s) in all.iter_mut().enumerate() {
                if train.add_statistics(m, s, d.observed, d.t, &y).is_err() {
                    s.poison();
                }
            }
        }
        Some(all)
    }

    pub fn needs_work(&self, t_end: f64) -> bool {
        let (d, t_end) = (&self.driver, t_end - self.origin);
        d.needs_restart || d.pending.is_some_and(|e| e.t <= t_end) || d.method_time() < t_end
    }

    pub fn advance(
        &mut self,
        t_end: f64,
        log: &mut dyn FnMut(f64, &EventReport),
    ) -> Result<(), DriverError<LawOutOfRange>> {
        let origin = self.origin;
        self.driver
            .advance(&mut self.train, super::since(t_end, origin), &mut |t, r| {
                log(origin + t, r)
            })
            .map_err(|e| e.shifted(origin))
    }

    pub fn state(&self) -> State {
        S::widen(&self.driver.state())
    }
}

impl From<Train> for Compact {
    fn from(t: Train) -> Compact {
        Compact(t)
    }
}

/// The gear train and its driver together (what the train FMU steps): at the compact capacity
/// when the train's state fits it, else at the full one. The full run is boxed: the enum is as
/// large as its largest variant, and the copy that undoes a failed step copies all of it.
#[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[allow(clippy::large_enum_variant)] // the compact run inline: it is the one stepped most
pub enum TrainSimulation {
    Compact(TrainRun<Compact>),
    Full(Box<TrainRun<Train>>),
}

impl Clone for TrainSimulation {
    fn clone(&self) -> Self {
        match self {
            TrainSimulation::Compact(r) => TrainSimulation::Compact(r.clone()),
            TrainSimulation::Full(r) => TrainSimulation::Full(r.clone()),
        }
    }

    /// In place, keeping the buffers (`fmi2DoStep`'s backup).
    fn clone_from(&mut self, src: &Self) {
        match (self, src) {
            (TrainSimulation::Compact(a), TrainSimulation::Compact(b)) => a.clone_from(b),
            (TrainSimulation::Full(a), TrainSimulation::Full(b)) => a.clone_from(b),
            (a, b) => *a = b.clone(),
        }
    }
}

/// `$body` with `$r` the run, whatever its capacity.
macro_rules! each {
    ($sim:expr, $r:ident => $body:expr) => {
        match $sim {
            TrainSimulation::Compact($r) => $body,
            TrainSimulation::Full($r) => $body,
        }
    };
}

impl TrainSimulation {
    /// `statistics`: the start time of the statistics, if kept.
    pub fn new(
        spec: TrainSpec,
        tau: Vec<f64>,
        statistics: Option<f64>,
        solver: i32,
        t0: f64,
        rel_tol: f64,
    ) -> Result<TrainSimulation, ModelError> {
        let (train, y0) = Train::new(spec, tau, statistics.map(|s| s - t0))?;
        Ok(if train.dim() <= NY_COMPACT {
            TrainSimulation::Compact(TrainRun::new(train, &y0, solver, t0, rel_tol))
        } else {
            TrainSimulation::Full(Box::new(TrainRun::new(train, &y0, solver, t0, rel_tol)))
        })
    }

    pub fn train(&self) -> &Train {
        each!(self, r => r.train.train())
    }

    pub fn train_mut(&mut self) -> &mut Train {
        each!(self, r => r.train.train_mut())
    }

    /// The driver's counts.
    pub fn stats(&self) -> &Stats {
        each!(self, r => &r.driver.stats)
    }

    /// The FMU's time \[s\].
    pub fn time(&self) -> f64 {
        each!(self, r => r.time())
    }

    /// Moves the time back to t (a step that failed inside the last internal step).
    pub fn set_time(&mut self, t: f64) {
        each!(self, r => r.set_time(t))
    }

    /// Never step past t (the experiment's stop time).
    pub fn set_stop_time(&mut self, t: f64) {
        each!(self, r => r.set_stop_time(t))
    }

    /// The train for a master that integrates it in its own time (Model Exchange).
    pub fn into_train(self) -> Train {
        match self {
            TrainSimulation::Compact(r) => r.into_train(),
            TrainSimulation::Full(r) => (*r).into_train(),
        }
    }

    /// New torques or coefficients: the integration restarts at the current time.
    pub fn set_loads(&mut self, loads: TrainLoads) {
        each!(self, r => r.set_loads(loads))
    }

    /// diffsol's BDF cannot be copied: before its state is saved, the live simulation restarts
    /// at the current point too.
    pub fn make_restart_point_if_needed(&mut self) {
        each!(self, r => r.make_restart_point_if_needed())
    }

    /// Each mesh's statistics up to the current time.
    pub fn statistics(&self) -> Option<Vec<Statistics>> {
        each!(self, r => r.statistics())
    }

    /// Whether advancing to t_end integrates or handles an event.
    pub fn needs_work(&self, t_end: f64) -> bool {
        each!(self, r => r.needs_work(t_end))
    }

    /// Advances to the FMU's time t_end; `log` receives each event at its FMU time.
    pub fn advance(
        &mut self,
        t_end: f64,
        log: &mut dyn FnMut(f64, &EventReport),
    ) -> Result<(), DriverError<LawOutOfRange>> {
        each!(self, r => r.advance(t_end, log))
    }

    /// The state at the current time (at the full capacity).
    pub fn state(&self) -> State {
        each!(self, r => r.state())
    }

    /// `f` of the state at the current time at the run's capacity (the components past `dim`
    /// are 0): what reading it costs without widening it to the full capacity.
    #[inline]
    pub fn with_state<T>(&self, f: impl FnOnce(&[f64]) -> T) -> T {
        each!(self, r => f(&r.driver.state()))
    }
}

/// Model Exchange of the train: the master integrates the states `Train::master_index` lists.
impl ExchangeRig for Train {
    type Loads = TrainLoads;
    fn n_master_states(&self) -> usize {
        self.dim()
    }
    fn to_master(&self, y: &State, x: &mut [f64]) {
        for (j, xj) in x.iter_mut().enumerate() {
            *xj = self.master_index(j).map_or(0.0, |i| y[i]);
        }
    }
    fn set_from_master(&self, x: &[f64], y: &mut State) {
        for (j, &xj) in x.iter().enumerate() {
            if let Some(i) = self.master_index(j) {
                y[i] = xj;
            }
        }
    }
    /// The driver's absolute tolerances at rel_tol 1 (`Train::abs_tol`); 1 where that is 0
    /// (the quadratures, in J) and for elements not in use.
    fn nominals(&self, n: &mut [f64]) {
        let atol = self.abs_tol(1.0);
        for (j, nj) in n.iter_mut().enumerate() {
            *nj = self
                .master_index(j)
                .map(|i| atol[i])
                .filter(|&a| a > 0.0)
                .unwrap_or(1.0);
        }
    }
    /// A body's angle moves its gears' contacts: a radian. An element's rate enters the
    /// bodies' speeds mixed with the others (`Train::bodies`), whose rounding (eps times the
    /// pitch-line speeds) must stay far below the step: a tenth of the fastest pitch-line
    /// speed at least.
    fn difference_scales(&self, y: &State, s: &mut [f64]) {
        self.nominals(s);
        let b = self.bodies(y);
        let speed = self
            .meshes
            .iter()
            .zip(&self.spec().meshes)
            .map(|(mesh, mp)| {
                let w = if mp.a == crate::model::train::HOUSING {
                    0.0
                } else {
                    b.w[mp.a]
                };
                mesh.geo.r_ab * w.abs()
            })
            .fold(0.0, f64::max);
        for (j, sj) in s.iter_mut().enumerate() {
            let Some(i) = self.master_index(j) else {
                continue;
            };
            *sj = match i.checked_sub(2).map(|k| (k / 2, k % 2)) {
                // (A lateral body's translations come after the rotations' coordinates.)
                Some((k, 0)) if self.cfg.coords.coords.get(k).is_some_and(|c| c.is_body()) => 1.0,
                Some((_, 1)) => sj.max(y[i].abs()).max(0.1 * speed),
                _ => sj.max(y[i].abs()),
            };
        }
    }
    fn current_loads(&self) -> &TrainLoads {
        &self.loads
    }
    fn apply_loads(&mut self, loads: TrainLoads, y: &mut State) {
        self.set_loads(loads, y)
    }
    fn event_name(&self, i: usize) -> String {
        let (m, e) = self.event_of(i);
        format!("mesh[{}] {:?}", m + 1, EventFn::from_index(e))
    }
    fn event_indicators(&self, y: &State, z: &mut [f64]) {
        Train::event_indicators(self, y, z)
    }
}
