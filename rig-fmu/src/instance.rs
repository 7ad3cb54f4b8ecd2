//! `RigInstance`: a rig as an `fmi2_slave::Slave`. Parameters and inputs (all or none: every
//! value is checked before any is applied), the experiment, initialization, Co-Simulation
//! steps, Model Exchange's point and events, and the FMU state's snapshot; the outputs are
//! computed once after each change and then read in place. A failing call leaves the values
//! the instance had before it.

use crate::table::{Kind, Role, Scalar, Table, Values};
use crate::{ExchangeOf, Model, Outputs, Params, Rig, RigSim, State, Var};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::logging::LOG_EVENTS;
use fmi2_slave::{error, Boolean, EventUpdate, Failure, Logger, Slave, Status, ValueReference};
use gear_model::driver::exchange::{EventError, Exchange, ExchangeRig};
use gear_model::driver::DriverError;
use serde::{Deserialize, Serialize};

/// The debug category of the integrator's statistics.
pub const LOG_SOLVER: &str = "logSolver";

/// What an FMU state holds: everything that determines how the instance continues. Serialized
/// in this field order (the rigs' payloads: `Rig::encode`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "Params<R>: Serialize, crate::Inputs<R>: Serialize, R::Extra: Serialize, \
                 R::Sim: Serialize, ExchangeOf<R>: Serialize",
    deserialize = "Params<R>: Deserialize<'de>, crate::Inputs<R>: Deserialize<'de>, \
                   R::Extra: Deserialize<'de>, R::Sim: Deserialize<'de>, \
                   ExchangeOf<R>: Deserialize<'de>"
))]
pub struct Snapshot<R: Rig> {
    pub params: Params<R>,
    pub inputs: crate::Inputs<R>,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    /// The rig's own (SpurGearMesh: the inputs' interpolation).
    pub extra: R::Extra,
    /// Co-Simulation, and either interface in initialization mode.
    pub sim: Option<R::Sim>,
    /// Model Exchange after initialization (the master integrates).
    pub me: Option<ExchangeOf<R>>,
}

impl<R: Rig> Default for Snapshot<R> {
    fn default() -> Snapshot<R> {
        Snapshot {
            params: Default::default(),
            inputs: Default::default(),
            start_time: 0.0,
            stop_time: None,
            tolerance: None,
            extra: Default::default(),
            sim: None,
            me: None,
        }
    }
}

impl<R: Rig> Snapshot<R> {
    /// The model and the state at the current time, if there is a run (of either interface).
    pub fn current(&self) -> Option<(&Model<R>, State<R>)> {
        match (&self.me, &self.sim) {
            (Some(ex), _) => Some((&ex.rig, ex.y)),
            (None, Some(sim)) => Some((sim.model(), sim.state())),
            (None, None) => None,
        }
    }

    /// The master's tolerance tightens the given rel_tol, never loosens it: masters that pass a
    /// default of their own (PyFMI and OMSimulator pass 1e-4) get the FMU's own accuracy.
    pub fn rel_tol(&self, rel_tol: f64) -> f64 {
        self.tolerance.map_or(rel_tol, |t| t.min(rel_tol))
    }
}

/// The run whose outputs are read.
pub enum Run<'a, R: Rig> {
    Sim(&'a R::Sim),
    Exchange(&'a ExchangeOf<R>),
}

/// The model behind an FMU instance (the state machine around it is fmi2_slave's `Instance`).
#[derive(Clone, Debug)]
pub struct RigInstance<R: Rig> {
    pub snap: Snapshot<R>,
    /// Outputs at the current time, computed on demand (valid while `fresh`), written in
    /// place: they are read after every communication step.
    outputs: Outputs<R>,
    fresh: bool,
    /// The lazy outputs are valid too (computed on demand after `fresh`).
    lazy_fresh: bool,
    pub cache: R::Cache,
    /// The simulation before the current step, to undo it if it fails: copied in place
    /// (`clone_from`), so that its buffers are reused from step to step.
    backup: Option<R::Sim>,
}

impl<R: Rig> From<Snapshot<R>> for RigInstance<R> {
    fn from(snap: Snapshot<R>) -> RigInstance<R> {
        RigInstance {
            snap,
            outputs: Default::default(),
            fresh: false,
            lazy_fresh: false,
            cache: Default::default(),
            backup: None,
        }
    }
}

/// Inlined into every get and set of a variable; the message is built out of line.
#[inline(always)]
fn lookup<T: Table>(vr: u32, kind: Kind) -> Result<T::Var, Failure> {
    match T::from_vr(vr) {
        Some(v) if T::info(v).kind == kind => Ok(v),
        _ => Err(lookup_failure::<T>(vr, kind)),
    }
}

#[cold]
#[inline(never)]
fn lookup_failure<T: Table>(vr: u32, kind: Kind) -> Failure {
    match T::from_vr(vr) {
        None => error(format!("unknown value reference {vr}")),
        Some(v) => error(format!(
            "{} (value reference {vr}) is {:?}, not {kind:?}",
            T::info(v).name,
            T::info(v).kind
        )),
    }
}

/// Checks that a variable may be set now to the value shown (for the message).
fn settable<T: Table>(
    v: T::Var,
    shown: &dyn std::fmt::Display,
    running: bool,
) -> Result<(), Failure> {
    let info = T::info(v);
    match info.role {
        Role::Output | Role::CalculatedParameter | Role::Local => Err(error(format!(
            "{} = {shown}: {} is a {:?}, it cannot be set",
            info.name, info.name, info.role
        ))),
        Role::Parameter if info.fixed && running => Err(error(format!(
            "{} = {shown}: {} is a fixed parameter, it cannot be set after initialization",
            info.name, info.name
        ))),
        _ => Ok(()),
    }
}

/// A Real input or parameter of the table, for a rig's own setters (`Rig` hooks).
pub fn real_var<R: Rig>(vr: u32) -> Result<Var<R>, Failure> {
    lookup::<R::Table>(vr, Kind::Real)
}

impl<R: Rig> RigInstance<R> {
    /// Builds the run from the parameters (at the end of initialization, or earlier when a
    /// master reads calculated values in initialization mode).
    pub fn build(&mut self) -> Result<&mut R::Sim, Failure> {
        if self.snap.sim.is_none() {
            let s = &self.snap;
            let rel_tol = s.rel_tol(R::rel_tol(&s.params));
            let sim = R::build(s, rel_tol, &self.cache).map_err(error)?;
            self.snap.sim = Some(sim);
            self.fresh = false;
        }
        Ok(self.snap.sim.as_mut().expect("just built"))
    }

    /// The outputs are to be computed again.
    pub fn stale(&mut self) {
        self.fresh = false;
    }

    /// The Model Exchange run (after initialization).
    fn exchange(&mut self) -> Result<&mut ExchangeOf<R>, Failure> {
        self.snap
            .me
            .as_mut()
            .ok_or_else(|| error("the instance has no Model Exchange state".into()))
    }

    /// The model and the state at the current time, of either interface, built if need be.
    fn point(&mut self) -> Result<(&Model<R>, State<R>), Failure> {
        if self.snap.me.is_none() {
            self.build()?;
        }
        Ok(self.snap.current().expect("built above"))
    }

    /// The locals (the states that are not outputs, the derivatives) at the current time; a
    /// non-finite one is an error naming it, as for the outputs.
    #[cold]
    #[inline(never)]
    fn locals(&mut self) -> Result<crate::Locals<R>, Failure> {
        let t = self.time();
        let (m, y) = self.point()?;
        let l = R::locals(m, &y).map_err(|e| error(format!("at t = {t} s: {e}")))?;
        if let Some((name, x)) = l.first_non_finite() {
            return Err(error(format!(
                "{name} = {x} is not finite at t = {t}: check the parameters and start values"
            )));
        }
        Ok(l)
    }

    fn calculated(&mut self) -> Result<crate::Calculated<R>, Failure> {
        self.point()?;
        let (m, _) = self.snap.current().expect("built above");
        Ok(R::calculated(m, &self.cache))
    }

    /// Outputs at the current time, computed once after each change and then read in place.
    /// A non-finite one (e.g. from absurd start values) is an error naming it: no NaN or
    /// infinity ever reaches a master.
    pub fn outputs(&mut self) -> Result<&Outputs<R>, Failure> {
        if !self.fresh {
            if self.snap.me.is_none() {
                self.build()?;
            }
            let run = match (&self.snap.me, &self.snap.sim) {
                (Some(ex), _) => Run::Exchange(ex),
                (None, sim) => Run::Sim(sim.as_ref().expect("just built")),
            };
            R::write_outputs(run, &mut self.outputs, &self.cache).map_err(error)?;
            self.lazy_fresh = false;
            if let Some((name, x)) = R::first_non_finite(&self.outputs, &self.cache) {
                return Err(non_finite_output(name, x, self.time()));
            }
            self.fresh = true;
        }
        Ok(&self.outputs)
    }

    /// The outputs with the lazy ones (`Rig::is_lazy`), computed on the first read of one of
    /// them after each change; non-finite ones are an error naming them.
    fn lazy_outputs(&mut self) -> Result<&Outputs<R>, Failure> {
        self.outputs()?;
        if !self.lazy_fresh {
            let (m, y) = self.snap.current().expect("built by outputs()");
            R::write_lazy(m, &y, &mut self.outputs).map_err(error)?;
            if let Some((name, x)) = R::first_non_finite(&self.outputs, &self.cache) {
                return Err(non_finite_output(name, x, self.time()));
            }
            self.lazy_fresh = true;
        }
        Ok(&self.outputs)
    }

    #[inline(always)]
    fn value<X: Scalar>(&mut self, vr: ValueReference) -> Result<X, Failure> {
        let v = lookup::<R::Table>(vr, X::KIND)?;
        let role = <R::Table as Table>::info(v).role;
        let got = match role {
            // What a master reads after every step, read in place: `outputs()` is out of line.
            Role::Output if self.fresh && !R::is_lazy(v) => X::get::<R::Table>(&self.outputs, v),
            Role::Parameter => X::get::<R::Table>(&self.snap.params, v),
            Role::Input => X::get::<R::Table>(&self.snap.inputs, v),
            Role::Output if R::is_lazy(v) => X::get::<R::Table>(self.lazy_outputs()?, v),
            Role::Output => X::get::<R::Table>(self.outputs()?, v),
            Role::CalculatedParameter => X::get::<R::Table>(&self.calculated()?, v),
            // Rare (Model Exchange's states and derivatives): out of line.
            Role::Local => X::get::<R::Table>(&self.locals()?, v),
        };
        got.ok_or_else(|| no_value::<R::Table>(v))
    }

    /// Sets several variables at once: all are checked before any is applied.
    fn set_many<X: Clone + std::fmt::Display>(
        &mut self,
        kind: Kind,
        vrs: &[u32],
        values: &[X],
        running: bool,
        check: impl Fn(&X) -> bool,
        apply: impl Fn(&mut Params<R>, &mut crate::Inputs<R>, Var<R>, X),
    ) -> Result<(), Failure> {
        let mut vars = Vec::with_capacity(vrs.len());
        for (&vr, x) in vrs.iter().zip(values) {
            let v = lookup::<R::Table>(vr, kind)?;
            settable::<R::Table>(v, x, running)?;
            if !check(x) {
                return Err(error(format!(
                    "{} = {x}: the value must be finite",
                    <R::Table as Table>::info(v).name
                )));
            }
            vars.push(v);
        }
        let changed: Vec<Var<R>> = vars
            .iter()
            .copied()
            .filter(|&v| <R::Table as Table>::info(v).role == Role::Parameter)
            .collect();
        if changed.is_empty() {
            // Inputs only (a master's set at every step): finite, checked above; nothing to
            // validate, so nothing to put back, and no copy of the inputs.
            let now = self.time();
            for (&v, x) in vars.iter().zip(values) {
                apply(&mut self.snap.params, &mut self.snap.inputs, v, x.clone());
                R::on_set(&mut self.snap.extra, v, now);
            }
            self.after_set(running);
            return Ok(());
        }
        // The parameters (about a thousand in a train) are set in place and the ones changed
        // put back if the set is refused: a copy of them all per set was most of the cost of
        // setting a scene's start values.
        let saved: Vec<Saved> = changed
            .iter()
            .map(|&v| Saved::of(&self.snap.params, v))
            .collect();
        let mut inputs = self.snap.inputs.clone();
        let mut extra = self.snap.extra.clone();
        let now = self.time();
        for (&v, x) in vars.iter().zip(values) {
            apply(&mut self.snap.params, &mut inputs, v, x.clone());
            R::on_set(&mut extra, v, now);
        }
        // Inputs need only be finite (checked above); parameters against the table (the rig
        // says how much a set can change).
        if let Err(e) = R::validate_changed(&self.snap.params, &changed) {
            // In reverse: a variable set twice gets its value from before the set.
            for (&v, old) in changed.iter().zip(saved).rev() {
                old.restore(&mut self.snap.params, v);
            }
            return Err(error(e));
        }
        self.snap.inputs = inputs;
        self.snap.extra = extra;
        self.after_set(running);
        Ok(())
    }

    /// What follows a set that was applied.
    fn after_set(&mut self, running: bool) {
        self.fresh = false;
        if running {
            R::apply_loads(&mut self.snap, &self.cache);
        } else {
            // Before the end of initialization the run is rebuilt from the parameters.
            self.snap.sim = None;
        }
    }
}

/// A parameter's value before a set, to put back if the set is refused.
enum Saved {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
    None,
}

impl Saved {
    fn of<T: Table, V: Values<T>>(p: &V, v: T::Var) -> Saved {
        if let Some(x) = p.get_real(v) {
            Saved::Real(x)
        } else if let Some(x) = p.get_integer(v) {
            Saved::Integer(x)
        } else if let Some(x) = p.get_boolean(v) {
            Saved::Boolean(x)
        } else if let Some(x) = p.get_string(v) {
            Saved::String(x.to_string())
        } else {
            Saved::None
        }
    }

    fn restore<T: Table, V: Values<T>>(self, p: &mut V, v: T::Var) {
        match self {
            Saved::Real(x) => p.set_real(v, x),
            Saved::Integer(x) => p.set_integer(v, x),
            Saved::Boolean(x) => p.set_boolean(v, x),
            Saved::String(x) => p.set_string(v, x),
            Saved::None => false,
        };
    }
}

#[cold]
#[inline(never)]
fn no_value<T: Table>(v: T::Var) -> Failure {
    error(format!("{} has no value of that type", T::info(v).name))
}

#[cold]
#[inline(never)]
fn non_finite_output(name: &str, x: f64, t: f64) -> Failure {
    error(format!(
        "output {name} = {x} is not finite at t = {t}: check the parameters and start values"
    ))
}

impl<R: Rig> Slave for RigInstance<R> {
    const MODEL_NAME: &'static str = R::MODEL_NAME;
    const LOG_CATEGORIES: &'static [&'static str] = R::LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = R::STATE_MAGIC;
    const STATE_FORMAT_VERSION: u32 = R::STATE_FORMAT_VERSION;

    fn guid() -> &'static str {
        R::guid()
    }

    fn fresh() -> RigInstance<R> {
        RigInstance::from(Snapshot::default())
    }

    fn setup_experiment(
        &mut self,
        tol: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<(), Failure> {
        if let Some(t) = tol {
            if !(1e-14..=0.1).contains(&t) {
                return Err(error(format!("tolerance = {t}: must lie in [1e-14, 0.1]")));
            }
        }
        fmi2_slave::check_experiment_times(start, stop)?;
        self.snap.tolerance = tol;
        self.snap.start_time = start;
        self.snap.stop_time = stop;
        self.snap.sim = None;
        self.fresh = false;
        Ok(())
    }

    fn exit_initialization(&mut self) -> Result<(), Failure> {
        self.build()?;
        self.outputs()?;
        Ok(())
    }

    fn init_warnings(&self) -> Vec<String> {
        self.snap
            .sim
            .as_ref()
            .map_or_else(Vec::new, R::init_warnings)
    }

    #[inline]
    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure> {
        self.value(vr)
    }

    #[inline]
    fn get_integer(&mut self, vr: ValueReference) -> Result<i32, Failure> {
        self.value(vr)
    }

    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        self.value(vr)
    }

    fn get_string(&mut self, vr: ValueReference) -> Result<String, Failure> {
        self.value(vr)
    }

    fn set_real(&mut self, vrs: &[u32], values: &[f64], running: bool) -> Result<(), Failure> {
        self.set_many(
            Kind::Real,
            vrs,
            values,
            running,
            |x| x.is_finite(),
            |p, inp, v, x| {
                let _ = p.set_real(v, x) || inp.set_real(v, x);
            },
        )
    }

    fn set_integer(&mut self, vrs: &[u32], values: &[i32], running: bool) -> Result<(), Failure> {
        self.set_many(
            Kind::Integer,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_integer(v, x);
            },
        )
    }

    fn set_boolean(
        &mut self,
        vrs: &[u32],
        values: &[Boolean],
        running: bool,
    ) -> Result<(), Failure> {
        self.set_many(
            Kind::Boolean,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_boolean(v, x != 0);
            },
        )
    }

    /// Strings are checked as parameters: the model parses them (a bad entry names its position).
    fn set_string(&mut self, vrs: &[u32], values: &[String], running: bool) -> Result<(), Failure> {
        self.set_many(
            Kind::String,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_string(v, x);
            },
        )
    }

    fn set_real_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<(), Failure> {
        R::set_real_input_derivatives(self, vrs, orders, values)
    }

    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure> {
        let t = self.time();
        let t_end = current + h;
        if let Some(stop) = self.snap.stop_time {
            if t_end > stop * (1.0 + 1e-12) + 1e-12 {
                return Err(error(format!(
                    "step to {t_end} goes past the stopTime {stop} of fmi2SetupExperiment"
                )));
            }
        }
        let debug_events = log.enabled(LOG_EVENTS);
        let sim = self.snap.sim.as_mut().expect("initialized in StepComplete");
        R::Sim::describe_events(sim.model_mut(), debug_events);
        // A step inside the integrator's last internal step only moves the time: no copy is
        // needed to undo it.
        let backed_up = sim.needs_work(t_end);
        if backed_up {
            match &mut self.backup {
                Some(b) => b.clone_from(sim),
                none => *none = Some(sim.clone()),
            }
        }
        let mut events = Vec::new();
        let result = sim.advance(t_end, &mut |te, r| {
            if debug_events {
                events.push(format!("t = {te:.12} s: {}", r.what));
            }
        });
        for e in &events {
            log.log(Status::Ok, LOG_EVENTS, e);
        }
        self.fresh = false;
        let failure = match result {
            Ok(()) => self.outputs().err().map(|f| Failure {
                message: format!("{}; state kept at t = {t}", f.message),
                ..f
            }),
            Err(e @ DriverError::Law { .. }) => Some(error(format!("{e}; state kept at t = {t}"))),
            Err(e) => Some(Failure {
                status: Status::Discard,
                message: format!("{e}; state kept at t = {t}"),
            }),
        };
        if let Some(f) = failure {
            let sim = self.snap.sim.as_mut().expect("stepped");
            match self.backup.as_mut().filter(|_| backed_up) {
                Some(b) => std::mem::swap(sim, b),
                None => sim.set_time(t),
            }
            self.fresh = false;
            return Err(f);
        }
        if log.enabled(LOG_SOLVER) {
            let s = self.snap.sim.as_ref().expect("stepped").stats();
            log.log(Status::Ok, LOG_SOLVER, &R::solver_summary(t_end, s));
        }
        Ok(())
    }

    fn time(&self) -> f64 {
        match (&self.snap.me, &self.snap.sim) {
            (Some(ex), _) => ex.t,
            (None, Some(sim)) => sim.time(),
            (None, None) => self.snap.start_time,
        }
    }

    fn prepare_save(&mut self) {
        if let Some(sim) = self.snap.sim.as_mut() {
            sim.make_restart_point_if_needed();
        }
    }

    fn encode(&self, w: &mut Writer) {
        R::encode(&self.snap, w)
    }

    fn decode(r: &mut Reader) -> Result<RigInstance<R>, String> {
        R::decode(r).map(RigInstance::from)
    }

    // ---- Model Exchange: `Exchange` holds the point the master sets ---------------------------

    const MODEL_EXCHANGE: bool = true;
    const N_STATES: usize = R::N_DECLARED_STATES;
    const N_EVENT_INDICATORS: usize = R::N_EVENT_INDICATORS;
    const EVENT_INDICATOR_VR0: u32 = R::EVENT_INDICATOR_VR0;

    fn state_name(&self, k: usize) -> String {
        R::STATES
            .get(k)
            .map_or("a continuous state", |s| {
                <R::Table as Table>::info(s.0).name
            })
            .into()
    }

    fn n_directional_states(&self) -> usize {
        R::STATES.len()
    }

    const DIRECTIONAL_DERIVATIVES: bool = true;

    fn state_vr(&self, k: usize) -> Option<ValueReference> {
        R::STATES.get(k).map(|s| <R::Table as Table>::info(s.0).vr)
    }

    fn derivative_vr(&self, k: usize) -> Option<ValueReference> {
        R::STATES.get(k).map(|s| <R::Table as Table>::info(s.1).vr)
    }

    fn is_real_input(&self, vr: ValueReference) -> bool {
        <R::Table as Table>::from_vr(vr).is_some_and(|v| {
            let i = <R::Table as Table>::info(v);
            i.role == Role::Input && i.kind == Kind::Real
        })
    }

    fn me_exit_initialization(&mut self) -> Result<(), Failure> {
        R::check_model_exchange(&self.snap)?;
        let sim = self.build()?;
        let (t, y) = (sim.time(), sim.state());
        let sim = self.snap.sim.take().expect("just built");
        self.snap.me = Some(Exchange::at(sim.into_model(), t, y));
        self.fresh = false;
        self.outputs()?;
        Ok(())
    }

    fn me_set_time(&mut self, t: f64) -> Result<(), Failure> {
        let ex = self.exchange()?;
        if ex.t != t {
            ex.t = t;
            self.fresh = false;
        }
        Ok(())
    }

    fn me_set_states(&mut self, x: &[f64]) -> Result<(), Failure> {
        let ex = self.exchange()?;
        holds::<R>(&ex.rig, x.len())?;
        ex.set_states(x);
        self.fresh = false;
        Ok(())
    }

    fn me_states(&mut self, x: &mut [f64]) -> Result<(), Failure> {
        let (m, y) = self.point()?;
        holds::<R>(m, x.len())?;
        m.to_master(&y, x);
        Ok(())
    }

    fn me_derivatives(&mut self, dx: &mut [f64]) -> Result<(), Failure> {
        if self.snap.me.is_none() {
            // Initialization mode: the derivatives at the start point.
            holds::<R>(self.point()?.0, dx.len())?;
            let l = self.locals()?;
            for (d, &(_, der)) in dx.iter_mut().zip(R::STATES) {
                *d = l.get_real(der).expect("a derivative is a Real local");
            }
            return Ok(());
        }
        let t = self.time();
        let ex = self.exchange()?;
        holds::<R>(&ex.rig, dx.len())?;
        ex.derivatives(dx)
            .map_err(|e| error(format!("at t = {t} s: {e}")))
    }

    fn me_event_indicators(&mut self, z: &mut [f64]) -> Result<(), Failure> {
        let (m, y) = self.point()?;
        m.event_indicators(&y, z);
        Ok(())
    }

    fn me_nominals(&mut self, n: &mut [f64]) -> Result<(), Failure> {
        let (m, _) = self.point()?;
        holds::<R>(m, n.len())?;
        m.nominals(n);
        Ok(())
    }

    fn me_difference_scales(&mut self, s: &mut [f64]) -> Result<(), Failure> {
        self.exchange()?.difference_scales(s);
        Ok(())
    }

    fn me_enter_event_mode(&mut self) -> Result<(), Failure> {
        self.exchange().map(|_| ())
    }

    fn me_new_discrete_states(&mut self, log: &Logger) -> Result<EventUpdate, Failure> {
        let debug_events = log.enabled(LOG_EVENTS);
        let ex = self.exchange()?;
        R::Sim::describe_events(&mut ex.rig, debug_events);
        let t = ex.t;
        let mut texts = Vec::new();
        let settled = ex.settle(&mut |r| {
            if debug_events {
                texts.push(format!("t = {t:.12} s: {}", r.what));
            }
        });
        for e in &texts {
            log.log(Status::Ok, LOG_EVENTS, e);
        }
        self.fresh = false;
        let s = settled.map_err(|e: EventError| error(format!("at t = {t} s: {e}")))?;
        Ok(EventUpdate {
            states_changed: s.states_changed,
            nominals_changed: s.nominals_changed,
            next_event_time: None,
        })
    }

    fn me_completed_integrator_step(&mut self) -> Result<bool, Failure> {
        let ex = self.exchange()?;
        let t = ex.t;
        let enter = ex
            .complete_step()
            .map_err(|e| error(format!("at t = {t} s: {e}")))?;
        self.fresh = false;
        Ok(enter)
    }
}

/// Whether `n` master states hold the model's state: a model with more in use than the FMU
/// declares runs in Co-Simulation (or as an FMU that declares them), never integrated in part.
fn holds<R: Rig>(m: &Model<R>, n: usize) -> Result<(), Failure> {
    let used = m.n_master_states();
    if used <= n {
        return Ok(());
    }
    Err(error(format!(
        "the model has {used} continuous states in use, more than the {n} of this FMU's Model \
         Exchange{}",
        R::MORE_STATES_ADVICE
    )))
}
