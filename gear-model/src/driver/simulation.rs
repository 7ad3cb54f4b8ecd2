//! A model and its driver together: what the FMI layer steps. Also connects the model to the
//! driver's `System` trait.

use super::{Driver, DriverError, EventOutcome, Method, System, Tolerance};
use crate::model::mesh::{EventReport, LawOutOfRange};
use crate::model::paper_rig::{Ramp, RigSpec, CONTROLLED};
use crate::model::statistics::Statistics;
use crate::model::{Loads, ModelError, PaperRig, State};

impl EventOutcome for EventReport {
    fn smooth(&self) -> bool {
        self.smooth
    }
}

impl System for PaperRig {
    type State = State;
    type Error = LawOutOfRange;
    type Report = EventReport;
    fn rhs(&self, y: &State, dy: &mut State) -> Result<(), LawOutOfRange> {
        PaperRig::rhs(self, y, dy)
    }
    fn event_margins(&self, y: &State, out: &mut [f64]) {
        PaperRig::event_margins(self, y, out)
    }
    fn event_margins_and_rates(
        &self,
        y: &State,
        dy: &State,
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        PaperRig::event_margins_and_rates(self, y, dy, margins, rates)
    }
    fn margin(&self, i: usize, y: &State) -> f64 {
        PaperRig::margin(self, crate::model::contact::EventFn::from_index(i), y)
    }
    fn n_events(&self) -> usize {
        self.n_event_fns()
    }
    fn check_state(&self, y: &State) -> Result<(), LawOutOfRange> {
        PaperRig::check_state(self, y)
    }
    fn handle_event(&mut self, i: usize, y: &mut State) -> Result<EventReport, LawOutOfRange> {
        PaperRig::handle_event(self, i, y)
    }
    /// At most a base pitch of contact travel: the objects' events recur every pitch, so a
    /// longer step is cut back at an event anyway, and the driver's cubic check finds a gate or
    /// window crossed twice inside a step. The compliant mesh keeps the quarter pitch it had
    /// before that check, so its scenes keep their answers (the lumped mesh, newer, does not);
    /// its steps are set by the vibration
    /// nearly everywhere. For an explicit method also `stability`/omega_n of the mesh vibration
    /// (2 for Dormand-Prince 5(4), 4 for DOP853: `dopri5::STABILITY`, `dop853::STABILITY`):
    /// near an equilibrium the error estimate sees nothing and would let the step grow until
    /// rounding errors are amplified.
    fn max_step(&self, y: &State, stability: Option<super::Stability>) -> f64 {
        let speed = self.geo.r_ab * y[crate::model::paper_rig::W_A].abs();
        let pitches = match self.law {
            crate::model::ContactModel::Compliant(_) => 0.25,
            crate::model::ContactModel::Rigid { .. } | crate::model::ContactModel::Lumped(_) => 1.0,
        };
        let travel = if speed > 0.0 {
            pitches * self.geo.p_b / speed
        } else {
            f64::INFINITY
        };
        if let Some(s) = stability {
            let omega = self.vibration_frequency(y);
            if omega > 0.0 {
                return travel.min(s.reach / omega);
            }
        }
        travel
    }
    fn dim(&self) -> usize {
        PaperRig::dim(self)
    }
    fn observe(&mut self, t0: f64, t1: f64, y: &dyn Fn(f64) -> State) -> Result<(), LawOutOfRange> {
        PaperRig::observe(self, t0, t1, y)
    }
}

#[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Simulation {
    pub rig: PaperRig,
    /// Integrates in time since `origin`: a master on a late clock (epoch time, 1e12 s) would
    /// leave the internal steps below the spacing of the doubles near its time.
    pub driver: Driver<PaperRig>,
    /// The experiment's start time \[s\]: the driver's time 0.
    pub origin: f64,
}

/// The driver's tolerances for the mesh at rel_tol: the mesh's absolute tolerances of its
/// controlled components, 0 (no control) for the others.
pub fn tolerance(mesh: &PaperRig, rtol: f64) -> Tolerance<State> {
    let abs = mesh.abs_tol(rtol);
    let mut atol = [0.0; crate::model::NY];
    for (j, &i) in CONTROLLED[..mesh.n_controlled()].iter().enumerate() {
        atol[i] = abs[j];
    }
    Tolerance { rtol, atol }
}

impl Clone for Simulation {
    /// A BDF driver clones into a restart point at the current time (see `Driver::clone`), so
    /// the clone takes the statistics up to that time with it.
    fn clone(&self) -> Self {
        let d = &self.driver;
        let restart_point = matches!(d.method, Method::Bdf(_)) && !d.needs_restart;
        if restart_point && self.rig.stats.is_some() && d.t > d.observed {
            return self.clone_with_statistics_to_now();
        }
        Simulation {
            rig: self.rig.clone(),
            driver: self.driver.clone(),
            origin: self.origin,
        }
    }
}

impl Simulation {
    #[cold]
    fn clone_with_statistics_to_now(&self) -> Simulation {
        let mut rig = self.rig.clone();
        rig.stats = self.statistics();
        let mut driver = self.driver.clone();
        driver.observed = driver.t;
        Simulation {
            rig,
            driver,
            origin: self.origin,
        }
    }
}

impl Simulation {
    /// The rig of `spec` under `loads`, integrated from t0 by the method `solver` numbers
    /// (`Method::from_solver`).
    pub fn new(
        spec: &RigSpec,
        loads: Loads,
        solver: i32,
        t0: f64,
        rel_tol: f64,
    ) -> Result<Simulation, ModelError> {
        let (mut rig, mut y0) = PaperRig::new(spec, loads)?;
        y0[crate::model::paper_rig::TIME] = 0.0;
        if let Some(s) = rig.stats.as_mut() {
            s.start -= t0;
        }
        let tol = tolerance(&rig, rel_tol);
        let driver = Driver::new(Method::from_solver(solver), tol, super::since(t0, t0), y0);
        Ok(Simulation {
            rig,
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

    /// The rig for a master that integrates it in its own time (Model Exchange), and the state.
    pub fn into_rig(self) -> (PaperRig, State) {
        let (mut rig, mut y) = (self.rig, self.driver.state());
        if let Some(s) = rig.stats.as_mut() {
            s.start += self.origin;
        }
        y[crate::model::paper_rig::TIME] = self.origin + self.driver.t;
        (rig, y)
    }

    /// New inputs or tunable parameters, and the inputs' interpolation from here on (`Ramp`,
    /// in the FMU's time); a change restarts the integration at the current time.
    pub fn set_loads(&mut self, loads: Loads, ramp: Option<Ramp>) {
        let ramp = ramp.map(|mut r| {
            r.t0.iter_mut().for_each(|t| *t -= self.origin);
            r
        });
        if loads != self.rig.loads || ramp != self.rig.ramp {
            self.observe_to_now();
            self.driver.invalidate();
            let mut y = self.driver.state();
            // The time component is integrated only while a ramp is on: set it here.
            y[crate::model::paper_rig::TIME] = self.driver.t;
            self.rig.ramp = ramp;
            self.rig.set_loads(loads, &mut y);
            // Releasing a rigid lock may move the state onto the other flank (two-sided contact).
            self.driver.y_start = y;
            self.driver.tol = tolerance(&self.rig, self.driver.tol.rtol);
        }
    }

    /// diffsol's BDF cannot be copied: before its state is saved, the live simulation restarts
    /// at the current point too, so the saved and the live one continue identically.
    pub fn make_restart_point_if_needed(&mut self) {
        if matches!(self.driver.method, super::Method::Bdf(_)) {
            self.observe_to_now();
            self.driver.invalidate();
        }
    }

    /// Commits the statistics up to the current time before a restart drops the dense output.
    fn observe_to_now(&mut self) {
        let t = self.driver.t;
        if self.driver.observe_to(&mut self.rig, t).is_err() {
            if let Some(s) = self.rig.stats.as_mut() {
                s.poison();
            }
        }
    }

    /// The statistics up to the current time: those committed at the last step or event, and
    /// the piece of the current step since then.
    pub fn statistics(&self) -> Option<Statistics> {
        let mut s = self.rig.stats.clone()?;
        let d = &self.driver;
        if !d.needs_restart && d.t > d.observed {
            let y = |x| d.method.interpolate(x);
            if self
                .rig
                .add_statistics(&mut s, d.observed, d.t, &y)
                .is_err()
            {
                s.poison();
            }
        }
        Some(s)
    }

    /// Whether advancing to t_end integrates or handles an event (else it only moves the time).
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
            .advance(&mut self.rig, super::since(t_end, origin), &mut |t, r| {
                log(origin + t, r)
            })
            .map_err(|e| e.shifted(origin))
    }
}
