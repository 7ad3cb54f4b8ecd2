//! The gear train and its driver together (what the train FMU steps), and the train as the
//! driver's `System`: the same event location as the single mesh, over every mesh's events.

use super::exchange::ExchangeRig;
use super::{Driver, DriverError, Method, System, Tolerance};
use crate::model::contact::EventFn;
use crate::model::mesh::{EventReport, LawOutOfRange};
use crate::model::statistics::Statistics;
use crate::model::train::{State, Train, TrainLoads, TrainSpec};
use crate::model::ModelError;

impl System for Train {
    type State = State;
    type Error = LawOutOfRange;
    type Report = EventReport;
    fn rhs(&self, y: &State, dy: &mut State) -> Result<(), LawOutOfRange> {
        Train::rhs(self, y, dy)
    }
    fn event_margins(&self, y: &State, out: &mut [f64]) {
        Train::event_margins(self, y, out)
    }
    fn event_margins_and_rates(
        &self,
        y: &State,
        dy: &State,
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        Train::event_margins_and_rates(self, y, dy, margins, rates)
    }
    fn margin(&self, i: usize, y: &State) -> f64 {
        Train::margin(self, i, y)
    }
    fn n_events(&self) -> usize {
        self.n_event_fns()
    }
    fn check_state(&self, y: &State) -> Result<(), LawOutOfRange> {
        Train::check_state(self, y)
    }
    fn handle_event(&mut self, i: usize, y: &mut State) -> Result<EventReport, LawOutOfRange> {
        Train::handle_event(self, i, y)
    }
    fn max_step(&self, y: &State, stability: Option<f64>) -> f64 {
        Train::max_step(self, y, stability)
    }
    fn dim(&self) -> usize {
        Train::dim(self)
    }
    fn observe(&mut self, t0: f64, t1: f64, y: &dyn Fn(f64) -> State) -> Result<(), LawOutOfRange> {
        Train::observe(self, t0, t1, y)
    }
}

/// The driver's tolerances for the train at rel_tol (`Train::abs_tol`).
pub fn tolerance(train: &Train, rtol: f64) -> Tolerance<State> {
    Tolerance {
        rtol,
        atol: train.abs_tol(rtol),
    }
}

#[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrainSimulation {
    pub train: Train,
    /// Integrates in time since `origin` (see `Simulation::driver`).
    pub driver: Driver<Train>,
    /// The experiment's start time \[s\]: the driver's time 0.
    pub origin: f64,
}

impl Clone for TrainSimulation {
    /// As `Simulation::clone`: a BDF driver clones into a restart point, with the statistics
    /// up to now.
    fn clone(&self) -> Self {
        let d = &self.driver;
        let restart_point = matches!(d.method, Method::Bdf(_)) && !d.needs_restart;
        let mut train = self.train.clone();
        let mut driver = self.driver.clone();
        if restart_point && train.stats.is_some() && d.t > d.observed {
            train.stats = self.statistics();
            driver.observed = driver.t;
        }
        TrainSimulation {
            train,
            driver,
            origin: self.origin,
        }
    }
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
        let tol = tolerance(&train, rel_tol);
        let driver = Driver::new(Method::from_solver(solver), tol, super::since(t0, t0), y0);
        Ok(TrainSimulation {
            train,
            driver,
            origin: t0,
        })
    }

    /// The FMU's time \[s\].
    pub fn time(&self) -> f64 {
        self.origin + self.driver.t
    }

    /// Moves the time back to t (a step that failed inside the last internal step).
    pub fn set_time(&mut self, t: f64) {
        self.driver.t = super::since(t, self.origin);
    }

    /// Never step past t (the experiment's stop time).
    pub fn set_stop_time(&mut self, t: f64) {
        self.driver.t_stop = t - self.origin;
    }

    /// The train for a master that integrates it in its own time (Model Exchange).
    pub fn into_train(self) -> Train {
        let mut train = self.train;
        for s in train.stats.iter_mut().flatten() {
            s.start += self.origin;
        }
        train
    }

    /// New torques or coefficients: the integration restarts at the current time.
    pub fn set_loads(&mut self, loads: TrainLoads) {
        if loads != self.train.loads {
            self.observe_to_now();
            self.driver.invalidate();
            let mut y = self.driver.state();
            self.train.set_loads(loads, &mut y);
            self.driver.y_start = y;
            self.driver.tol = tolerance(&self.train, self.driver.tol.rtol);
        }
    }

    /// diffsol's BDF cannot be copied: before its state is saved, the live simulation restarts
    /// at the current point too.
    pub fn make_restart_point_if_needed(&mut self) {
        if matches!(self.driver.method, Method::Bdf(_)) {
            self.observe_to_now();
            self.driver.invalidate();
        }
    }

    fn observe_to_now(&mut self) {
        let t = self.driver.t;
        if self.driver.observe_to(&mut self.train, t).is_err() {
            if let Some(all) = self.train.stats.as_mut() {
                all.iter_mut().for_each(Statistics::poison);
            }
        }
    }

    /// Each mesh's statistics up to the current time.
    pub fn statistics(&self) -> Option<Vec<Statistics>> {
        let mut all = self.train.stats.clone()?;
        let d = &self.driver;
        if !d.needs_restart && d.t > d.observed {
            let y = |x| d.method.interpolate(x);
            for (m, s) in all.iter_mut().enumerate() {
                if self
                    .train
                    .add_statistics(m, s, d.observed, d.t, &y)
                    .is_err()
                {
                    s.poison();
                }
            }
        }
        Some(all)
    }

    /// Whether advancing to t_end integrates or handles an event.
    pub fn needs_work(&self, t_end: f64) -> bool {
        let (d, t_end) = (&self.driver, t_end - self.origin);
        d.needs_restart || d.pending.is_some_and(|e| e.t <= t_end) || d.method_time() < t_end
    }

    /// Advances to the FMU's time t_end; `log` receives each event at its FMU time.
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

    /// The state at the current time.
    pub fn state(&self) -> State {
        self.driver.state()
    }
}

/// Model Exchange of the train: the master integrates the states `Train::master_index` lists.
impl ExchangeRig for Train {
    type Loads = TrainLoads;
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
