//! Model Exchange: the master integrates and locates the events, and the rig is driven from
//! outside. `Exchange` holds what the master sets (time and state), evaluates the right-hand
//! side and the event functions there, and handles the events the master found, as the driver
//! does inside a Co-Simulation step. It serves any rig that says how its state maps onto the
//! master's (`ExchangeRig`): the paper's two-wheel rig and the gear train.
//!
//! The run's statistics (dte_mean, F_max...) are accumulated over the points where the master
//! completes its steps, with the state interpolated linearly between them.

use super::simulation::Simulation;
use super::{Stats, System, Vector};
use crate::model::contact::{EventFn, N_EVENTS};
use crate::model::mesh::{EventReport, LawOutOfRange};
use crate::model::paper_rig::{DDTE, DTE, NY, THETA_A, V_S, W_A, W_EXT, W_LOSS, X_S};
use crate::model::{Loads, PaperRig, State};
use serde::{Deserialize, Serialize};

/// The components of the paper rig's state that are Model Exchange's states, in order (the
/// integrator's state without its time component).
pub const ME_STATE: [usize; NY - 1] = [THETA_A, DTE, W_A, DDTE, W_EXT, W_LOSS, X_S, V_S];

/// What Model Exchange needs of a rig beyond the driver's `System`: how the master's states
/// map onto the rig's state, their scales, and new loads from the master.
pub trait ExchangeRig: System<Error = LawOutOfRange, Report = EventReport> {
    type Loads: PartialEq;
    /// How many of the master's states are in use: an array of fewer cannot hold the state.
    fn n_master_states(&self) -> usize;
    /// The master's states (or their rates, from the state's rates) from the rig's state.
    fn to_master(&self, y: &Self::State, x: &mut [f64]);
    /// The rig's state from the master's states (components the master does not see keep
    /// their values).
    fn set_from_master(&self, x: &[f64], y: &mut Self::State);
    /// Scales of the master's states.
    fn nominals(&self, n: &mut [f64]);
    /// How far each master state may move for a central difference (directional
    /// derivatives): within the smooth right-hand side, and large against the rounding of the
    /// rig's own arithmetic in what it changes. By default the larger of |x| and its nominal.
    fn difference_scales(&self, y: &Self::State, s: &mut [f64]) {
        self.nominals(s);
        let mut x = vec![0.0; s.len()];
        self.to_master(y, &mut x);
        for (sj, xj) in s.iter_mut().zip(x) {
            *sj = sj.max(xj.abs());
        }
    }
    fn current_loads(&self) -> &Self::Loads;
    /// New loads; the rig may move the state (a rigid lock released).
    fn apply_loads(&mut self, loads: Self::Loads, y: &mut Self::State);
    /// The name of event function i (messages).
    fn event_name(&self, i: usize) -> String;
    /// The master's event indicators at y: every event function in the order the
    /// indicators' names give, the ones not in use at +1.
    fn event_indicators(&self, y: &Self::State, z: &mut [f64]);
}

impl ExchangeRig for PaperRig {
    type Loads = Loads;
    fn n_master_states(&self) -> usize {
        ME_STATE.len()
    }
    fn to_master(&self, y: &State, x: &mut [f64]) {
        for (xj, &i) in x.iter_mut().zip(&ME_STATE) {
            *xj = y[i];
        }
    }
    fn set_from_master(&self, x: &[f64], y: &mut State) {
        for (&xj, &i) in x.iter().zip(&ME_STATE) {
            y[i] = xj;
        }
    }
    /// Those of the driver's absolute tolerances (the static penetration under the current
    /// loads and its vibration speed; 1 rad and 1 rad/s), 1 J for the work accounts.
    fn nominals(&self, n: &mut [f64]) {
        let s = self.abs_tol(1.0);
        let scale = [s[0], s[1], s[2], s[3], 1.0, 1.0, s[4], s[5]];
        n.copy_from_slice(&scale[..n.len()]);
    }
    /// A's angle moves the contacts along the line of action: a radian. The error's rate
    /// also moves B's speed, rBb w_B = rAb w_A - d(dte)/dt, whose rounding (eps rAb |w_A|)
    /// must stay far below the step: a tenth of the pitch-line speed at least.
    fn difference_scales(&self, y: &State, s: &mut [f64]) {
        let mut x = [0.0; NY - 1];
        self.to_master(y, &mut x);
        self.nominals(s);
        for (j, (sj, xj)) in s.iter_mut().zip(x).enumerate() {
            *sj = match ME_STATE[j] {
                THETA_A => 1.0,
                DDTE => sj.max(xj.abs()).max(0.1 * self.geo.r_ab * y[W_A].abs()),
                _ => sj.max(xj.abs()),
            };
        }
    }
    fn current_loads(&self) -> &Loads {
        &self.loads
    }
    fn apply_loads(&mut self, loads: Loads, y: &mut State) {
        self.set_loads(loads, y)
    }
    fn event_name(&self, i: usize) -> String {
        format!("{:?}", (i < N_EVENTS).then(|| EventFn::from_index(i)))
    }
    fn event_indicators(&self, y: &State, z: &mut [f64]) {
        let n = self.n_event_fns();
        self.event_margins(y, &mut z[..n]);
        z[n..].fill(1.0);
    }
}

/// More events at one instant than this is a model that cannot settle (it is reported).
const MAX_EVENTS_PER_INSTANT: usize = 64;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Exchange<R: ExchangeRig = PaperRig> {
    pub rig: R,
    pub t: f64,
    pub y: R::State,
    /// The last accepted point (completed step or event): the statistics are added up to it.
    last: (f64, R::State),
    /// Completed integrator steps and right-hand-side evaluations (the master's), and events.
    pub stats: Stats,
    jumped: bool,
    nominals_changed: bool,
}

impl Exchange {
    /// Continues a simulation built at initialization from its current time and state.
    pub fn new(sim: Simulation) -> Exchange {
        let t = sim.time();
        let (rig, y) = sim.into_rig();
        Exchange::at(rig, t, y)
    }

    /// `nominals` of a rig before its run starts.
    pub fn scales(mesh: &PaperRig, n: &mut [f64]) {
        mesh.nominals(n)
    }
}

impl<R: ExchangeRig> Exchange<R> {
    /// The master takes over the rig at time t and state y.
    pub fn at(rig: R, t: f64, y: R::State) -> Exchange<R> {
        Exchange {
            rig,
            t,
            y,
            last: (t, y),
            stats: Stats::default(),
            jumped: false,
            nominals_changed: false,
        }
    }

    /// Whether the current and the last accepted point are finite (a restored FMU state).
    pub fn points_finite(&self) -> bool {
        let (t0, y0) = &self.last;
        [self.t, *t0]
            .iter()
            .chain(self.y.as_slice())
            .chain(y0.as_slice())
            .all(|v| v.is_finite())
    }

    pub fn set_states(&mut self, x: &[f64]) {
        self.rig.set_from_master(x, &mut self.y);
    }

    /// The master's states at the current point.
    pub fn states(&self, x: &mut [f64]) {
        self.rig.to_master(&self.y, x);
    }

    pub fn derivatives(&mut self, dx: &mut [f64]) -> Result<(), LawOutOfRange> {
        let dy = self.rates()?;
        self.stats.rhs_evals += 1;
        self.rig.to_master(&dy, dx);
        Ok(())
    }

    /// The state's time derivative at the current point.
    pub fn rates(&self) -> Result<R::State, LawOutOfRange> {
        let mut dy = R::State::zeros();
        self.rig.rhs(&self.y, &mut dy)?;
        Ok(dy)
    }

    /// Scales of the master's states (`ExchangeRig::nominals`).
    pub fn nominals(&self, n: &mut [f64]) {
        self.rig.nominals(n)
    }

    /// Scales for central differences at the current point (`ExchangeRig::difference_scales`).
    pub fn difference_scales(&self, s: &mut [f64]) {
        self.rig.difference_scales(&self.y, s)
    }

    /// New inputs or tunable parameters: the right-hand side reads them from now on. A rigid
    /// lock that the new loads would make pull is released at once, which may move the state
    /// (two-sided contact); then the master is asked for an event (`take_jump`).
    pub fn set_loads(&mut self, loads: R::Loads) {
        if &loads == self.rig.current_loads() {
            return;
        }
        let before = self.y;
        self.rig.apply_loads(loads, &mut self.y);
        self.jumped |= self.y != before;
        self.nominals_changed = true;
    }

    /// Whether the state jumped outside the events the master located (the master should
    /// enter event mode; `take_jump` there clears it).
    pub fn jump_pending(&self) -> bool {
        self.jumped
    }

    pub fn take_jump(&mut self) -> bool {
        std::mem::take(&mut self.jumped)
    }

    /// Whether the nominals changed since the last call (they scale with the loads).
    pub fn take_nominals_changed(&mut self) -> bool {
        std::mem::take(&mut self.nominals_changed)
    }

    /// The master accepted its step up to the current point: the statistics take the piece
    /// since the last one, and a state beyond the model's limits is an error.
    pub fn completed_step(&mut self) -> Result<(), LawOutOfRange> {
        self.rig.check_state(&self.y)?;
        self.stats.steps += 1;
        self.observe_to_now()
    }

    fn observe_to_now(&mut self) -> Result<(), LawOutOfRange> {
        let (t0, y0) = self.last;
        let (t1, y1) = (self.t, self.y);
        let line = |t: f64| -> R::State {
            let w = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
            R::State::from_fn(|i| y0[i] + w * (y1[i] - y0[i]))
        };
        self.rig.observe(t0, t1, &line)?;
        self.last = (t1, y1);
        Ok(())
    }

    /// The master accepted its step (`completed_step`); returns whether it should enter event
    /// mode (the state jumped outside the events it located).
    pub fn complete_step(&mut self) -> Result<bool, LawOutOfRange> {
        self.completed_step()?;
        Ok(self.jump_pending())
    }

    /// Event mode: handles the crossed events (`handle_events`) and says what changed since the
    /// master last asked, a jump from new loads included.
    pub fn settle(&mut self, log: &mut dyn FnMut(&EventReport)) -> Result<Settled, EventError> {
        let handled = self.handle_events(log);
        // The flags are taken whether or not the events settled.
        let jumped = self.take_jump();
        let nominals_changed = self.take_nominals_changed();
        let changed = handled?;
        Ok(Settled {
            states_changed: jumped || changed,
            nominals_changed,
        })
    }

    /// Handles every event function that has crossed at the current point, one after the other
    /// until none has: each handled event may change the others' functions (a pair switch moves
    /// the gates). `log` receives each. Returns whether the state changed (an impact changes the
    /// speeds).
    ///
    /// Crossed: a margin at or below 0 and falling, or below `-ROUNDING` whatever its rate (a
    /// master without root finding stops after the crossing). A root finder such as CVODE's
    /// stops where a function has changed sign or is exactly 0, and continues from there without
    /// reporting the same root again. A margin at 0 that rises, or one a hair below 0 that
    /// rises (the next function of a pair that just jumped, off by the jump's rounding), has
    /// not crossed.
    pub fn handle_events(&mut self, log: &mut dyn FnMut(&EventReport)) -> Result<bool, EventError> {
        self.observe_to_now().map_err(EventError::Law)?;
        let before = self.y;
        // Event mode only (not every step): these may allocate.
        let n = self.rig.n_events();
        let (mut m, mut rate) = (vec![0.0; n], vec![0.0; n]);
        for _ in 0..MAX_EVENTS_PER_INSTANT {
            let dy = self.rates().map_err(EventError::Law)?;
            self.rig
                .event_margins_and_rates(&self.y, &dy, &mut m, &mut rate);
            let crossed = (0..n).find(|&i| crossed(m[i], rate[i]));
            let Some(i) = crossed else {
                self.last = (self.t, self.y);
                return Ok(self.y != before);
            };
            let report = self
                .rig
                .handle_event(i, &mut self.y)
                .map_err(EventError::Law)?;
            self.stats.events += 1;
            log(&report);
        }
        let last = (0..n).find(|&i| crossed(m[i], rate[i]));
        Err(EventError::NoSettle {
            last: last.map_or("None".into(), |i| self.rig.event_name(i)),
        })
    }
}

/// What event mode changed (`Exchange::settle`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settled {
    /// The continuous states jumped (an impact, a released lock).
    pub states_changed: bool,
    /// The nominals changed (they scale with the loads).
    pub nominals_changed: bool,
}

/// Margins with a rate are lengths in metres or dimensionless factors of order 1, and the
/// rounding of a handled switch leaves them within about 1e-16 of 0: this separates that from
/// a crossing.
const ROUNDING: f64 = 1e-12;

/// Whether an event function with this margin and rate has crossed (`handle_events`). The
/// rigid constraint force has no rate (NaN): below 0 it has crossed.
fn crossed(margin: f64, rate: f64) -> bool {
    margin < -ROUNDING || (margin <= 0.0 && rate < 0.0) || (margin < 0.0 && rate.is_nan())
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EventError {
    #[error(transparent)]
    Law(LawOutOfRange),
    #[error(
        "the events did not settle after {MAX_EVENTS_PER_INSTANT} at one instant (still crossed: \
         {last})"
    )]
    NoSettle { last: String },
}
