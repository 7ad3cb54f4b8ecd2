//! SpurGearMesh as an `fmi2_slave::Slave`: parameter and input handling, initialization and
//! stepping. The FMI state machine around it (state checks, panic guard, failure logging) is
//! `fmi2_slave::Instance`, whose names this module re-exports. A failing call leaves the values
//! the instance had before it.

use super::{fmu_state, outputs};
use crate::driver::exchange::{EventError, Exchange};
use crate::driver::simulation::Simulation;
use crate::driver::DriverError;

use crate::model::paper_rig::Ramp;
use crate::model::Loads;
use crate::model::{PaperRig, State};
use crate::variables::{
    Causality, Inputs, Outputs, Params, Var, VarType, Variability, GUID, LOG_CATEGORIES,
    MODEL_IDENTIFIER,
};
use crate::variables::{N_EVENT_INDICATORS, STATES};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::logging::LOG_EVENTS;
use fmi2_slave::{Boolean, EventUpdate, Logger, Slave, Status, ValueReference};

// The event indicators are the mesh's event functions.
const _: () = assert!(N_EVENT_INDICATORS == crate::model::contact::N_EVENTS);
const _: () = assert!(STATES.len() == crate::driver::exchange::ME_STATE.len());

pub use fmi2_slave::instance::{allowed, error, CallResult, Failure, FmiState};

/// SpurGearMesh's own debug category: integrator statistics.
pub const LOG_SOLVER: &str = "logSolver";

/// What an FMU state holds: everything that determines how the instance continues.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Snapshot {
    pub params: Params,
    pub inputs: Inputs,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    /// The inputs' interpolation (fmi2SetRealInputDerivatives); all zero: held inputs.
    pub ramp: Ramp,
    /// Co-Simulation, and either interface in initialization mode.
    pub sim: Option<Simulation>,
    /// Model Exchange after initialization (the master integrates).
    pub me: Option<Exchange>,
}

/// The model behind an FMU instance (the state machine around it is fmi2_slave's `Instance`).
#[derive(Clone, Debug)]
pub struct SpurGearMesh {
    pub snap: Snapshot,
    /// Outputs at the current time, computed on demand (valid while `fresh`), written in
    /// place: they are read after every communication step.
    outputs: Outputs,
    fresh: bool,
    /// The energy outputs are valid too (computed on demand after `fresh`).
    energy_fresh: bool,
}

impl Snapshot {
    pub fn fresh() -> Snapshot {
        Snapshot {
            params: Params::default(),
            inputs: Inputs::default(),
            start_time: 0.0,
            stop_time: None,
            tolerance: None,
            ramp: Ramp::default(),
            sim: None,
            me: None,
        }
    }

    /// The mesh and the state at the current time, if there is a run (of either interface).
    fn current(&self) -> Option<(&PaperRig, State)> {
        match (&self.me, &self.sim) {
            (Some(ex), _) => Some((&ex.rig, ex.y)),
            (None, Some(sim)) => Some((&sim.rig, sim.driver.state())),
            (None, None) => None,
        }
    }

    fn active_ramp(&self) -> Option<Ramp> {
        self.ramp.is_active().then_some(self.ramp)
    }
}

/// The position of an input in `Ramp` (inputs in the table's order).
fn ramp_slot(v: Var) -> Option<usize> {
    match v {
        Var::tau_A => Some(0),
        Var::tau_B => Some(1),
        Var::alpha_housing => Some(2),
        Var::a_housing_x => Some(3),
        _ => None,
    }
}

impl Slave for SpurGearMesh {
    const MODEL_NAME: &'static str = MODEL_IDENTIFIER;
    const LOG_CATEGORIES: &'static [&'static str] = LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = *b"SGMSTATE";
    const STATE_FORMAT_VERSION: u32 = fmu_state::FORMAT_VERSION;

    fn guid() -> &'static str {
        GUID
    }

    fn fresh() -> SpurGearMesh {
        SpurGearMesh::from(Snapshot::fresh())
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
            .map_or_else(Vec::new, |s| s.rig.geo.warnings.clone())
    }

    #[inline]
    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure> {
        let v = lookup(vr, VarType::Real)?;
        self.value(
            v,
            |p| p.get_real(v),
            |i| i.get_real(v),
            |o| o.get_real(v),
            |c| c.get_real(v),
            |l| l.get_real(v),
        )
    }

    #[inline]
    fn get_integer(&mut self, vr: ValueReference) -> Result<i32, Failure> {
        let v = lookup(vr, VarType::Integer)?;
        self.value(
            v,
            |p| p.get_integer(v),
            |i| i.get_integer(v),
            |o| o.get_integer(v),
            |c| c.get_integer(v),
            |l| l.get_integer(v),
        )
    }

    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        let v = lookup(vr, VarType::Boolean)?;
        self.value(
            v,
            |p| p.get_boolean(v),
            |i| i.get_boolean(v),
            |o| o.get_boolean(v),
            |c| c.get_boolean(v),
            |l| l.get_boolean(v),
        )
    }

    fn get_string(&mut self, vr: ValueReference) -> Result<String, Failure> {
        let v = lookup(vr, VarType::String)?;
        self.value(
            v,
            |p| p.get_string(v).map(str::to_owned),
            |i| i.get_string(v).map(str::to_owned),
            |o| o.get_string(v).map(str::to_owned),
            |c| c.get_string(v).map(str::to_owned),
            |l| l.get_string(v).map(str::to_owned),
        )
    }

    fn set_real(&mut self, vrs: &[u32], values: &[f64], running: bool) -> Result<(), Failure> {
        self.set_many(
            VarType::Real,
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
            VarType::Integer,
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
            VarType::Boolean,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_boolean(v, x != 0);
            },
        )
    }

    /// Input derivatives at the current time (canInterpolateInputs): order 1 (rate) or 2
    /// (curvature) of tau_A, tau_B, alpha_housing, a_housing_x. The input is re-based to now
    /// first, so a derivative given without a new value continues from the input's current
    /// value. All are checked before any is applied.
    fn set_real_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<(), Failure> {
        let now = self.time();
        let (mut inputs, mut ramp) = (self.snap.inputs.clone(), self.snap.ramp);
        for ((&vr, &order), &x) in vrs.iter().zip(orders).zip(values) {
            let v = lookup(vr, VarType::Real)?;
            let name = v.info().name;
            let k = ramp_slot(v).ok_or_else(|| {
                error(format!(
                    "{name} (value reference {vr}) is not a Real input: it has no input derivative"
                ))
            })?;
            if !(order == 1 || order == 2) {
                return Err(error(format!(
                    "{name}: derivative order {order} is not supported (1 or 2)"
                )));
            }
            if !x.is_finite() {
                return Err(error(format!(
                    "{name}: derivative of order {order} = {x}: must be finite"
                )));
            }
            let u = inputs.get_real(v).expect("a Real input");
            let (u_now, rate_now) = ramp.extrapolate(k, u, now);
            inputs.set_real(v, u_now);
            ramp.t0[k] = now;
            ramp.rate[k] = rate_now;
            if order == 1 {
                ramp.rate[k] = x;
            } else {
                ramp.curvature[k] = x;
            }
        }
        self.snap.inputs = inputs;
        self.snap.ramp = ramp;
        self.fresh = false;
        let (loads, ramp) = (self.loads(), self.snap.active_ramp());
        if let Some(sim) = self.snap.sim.as_mut() {
            sim.set_loads(loads, ramp);
        }
        Ok(())
    }

    /// Strings are checked as parameters: the model parses them (a bad entry names its position).
    fn set_string(&mut self, vrs: &[u32], values: &[String], running: bool) -> Result<(), Failure> {
        self.set_many(
            VarType::String,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_string(v, x);
            },
        )
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
        sim.rig.mesh.describe_events = debug_events;
        // A step inside the integrator's last internal step only moves the time: no copy is
        // needed to undo it.
        let before = sim.needs_work(t_end).then(|| sim.clone());
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
            Ok(()) => match self.outputs() {
                Ok(_) => None,
                Err(f) => Some(Failure {
                    message: format!("{}; state kept at t = {t}", f.message),
                    ..f
                }),
            },
            Err(e @ DriverError::Law { .. }) => Some(error(format!("{e}; state kept at t = {t}"))),
            Err(e) => Some(Failure {
                status: Status::Discard,
                message: format!("{e}; state kept at t = {t}"),
            }),
        };
        if let Some(f) = failure {
            match before {
                Some(b) => self.snap.sim = Some(b),
                None => self.snap.sim.as_mut().expect("stepped").driver.t = t,
            }
            self.fresh = false;
            return Err(f);
        }
        if log.enabled(LOG_SOLVER) {
            let s = &self.snap.sim.as_ref().expect("stepped").driver.stats;
            log.log(
                Status::Ok,
                LOG_SOLVER,
                &format!(
                    "t = {t_end}: {} steps, {} rejected, {} rhs evaluations, {} Jacobians, {} factorizations, {} events so far",
                    s.steps, s.rejected, s.rhs_evals, s.jac_evals, s.factorizations, s.events
                ),
            );
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
        fmu_state::write(w, &self.snap)
    }

    fn decode(r: &mut Reader) -> Result<SpurGearMesh, String> {
        fmu_state::read(r).map(SpurGearMesh::from)
    }

    // ---- Model Exchange: `Exchange` holds the point the master sets ---------------------------

    const MODEL_EXCHANGE: bool = true;
    const N_STATES: usize = STATES.len();
    const N_EVENT_INDICATORS: usize = N_EVENT_INDICATORS;
    const EVENT_INDICATOR_VR0: u32 = crate::variables::EVENT_INDICATOR_VR0;

    fn state_name(k: usize) -> &'static str {
        STATES
            .get(k)
            .map_or("a continuous state", |s| s.0.info().name)
    }

    fn me_exit_initialization(&mut self) -> Result<(), Failure> {
        if self.snap.ramp.is_active() {
            return Err(error(
                "input derivatives are a Co-Simulation feature; a Model Exchange master sets the inputs".into(),
            ));
        }
        self.build()?;
        let sim = self.snap.sim.take().expect("just built");
        self.snap.me = Some(Exchange::new(sim));
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
        self.exchange()?.set_states(x);
        self.fresh = false;
        Ok(())
    }

    fn me_states(&mut self, x: &mut [f64]) -> Result<(), Failure> {
        let (_, y) = self.point()?;
        for (xj, &i) in x.iter_mut().zip(&crate::driver::exchange::ME_STATE) {
            *xj = y[i];
        }
        Ok(())
    }

    fn me_derivatives(&mut self, dx: &mut [f64]) -> Result<(), Failure> {
        if self.snap.me.is_none() {
            // Initialization mode: the derivatives at the start point.
            let l = self.locals()?;
            for (d, &(_, der)) in dx.iter_mut().zip(STATES) {
                *d = l.get_real(der).expect("a derivative is a Real local");
            }
            return Ok(());
        }
        let t = self.time();
        self.exchange()?
            .derivatives(dx)
            .map_err(|e| error(format!("at t = {t} s: {e}")))
    }

    fn me_event_indicators(&mut self, z: &mut [f64]) -> Result<(), Failure> {
        let (mesh, y) = self.point()?;
        let mut m = [0.0; N_EVENT_INDICATORS];
        mesh.event_margins(&y, &mut m);
        z.copy_from_slice(&m);
        Ok(())
    }

    fn me_nominals(&mut self, n: &mut [f64]) -> Result<(), Failure> {
        match &self.snap.me {
            Some(ex) => ex.nominals(n),
            None => Exchange::scales(&self.build()?.rig, n),
        }
        Ok(())
    }

    fn me_enter_event_mode(&mut self) -> Result<(), Failure> {
        self.exchange().map(|_| ())
    }

    fn me_new_discrete_states(&mut self, log: &Logger) -> Result<EventUpdate, Failure> {
        let debug_events = log.enabled(LOG_EVENTS);
        let ex = self.exchange()?;
        ex.rig.mesh.describe_events = debug_events;
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

impl From<Snapshot> for SpurGearMesh {
    fn from(snap: Snapshot) -> SpurGearMesh {
        SpurGearMesh {
            snap,
            outputs: Outputs::default(),
            fresh: false,
            energy_fresh: false,
        }
    }
}

impl SpurGearMesh {
    /// The master's tolerance tightens rel_tol, never loosens it: masters that pass a default
    /// of their own (PyFMI and OMSimulator pass 1e-4) get the FMU's own accuracy.
    fn tolerance(&self) -> f64 {
        let rel_tol = self.snap.params.rel_tol;
        self.snap.tolerance.map_or(rel_tol, |t| t.min(rel_tol))
    }

    fn loads(&self) -> Loads {
        Loads::new(&self.snap.params, &self.snap.inputs)
    }

    /// Builds the simulation from the parameters (at the end of initialization, or earlier when
    /// a master reads calculated values in initialization mode).
    fn build(&mut self) -> Result<&mut Simulation, Failure> {
        if self.snap.sim.is_none() {
            let s = &self.snap;
            let mut sim = Simulation::new(&s.params, &s.inputs, s.start_time, self.tolerance())
                .map_err(|e| error(e.message))?;
            if let Some(stop) = s.stop_time {
                sim.driver.t_stop = stop;
            }
            if let Some(r) = s.active_ramp() {
                sim.set_loads(Loads::new(&s.params, &s.inputs), Some(r));
            }
            self.snap.sim = Some(sim);
            self.fresh = false;
        }
        Ok(self.snap.sim.as_mut().expect("just built"))
    }

    /// The Model Exchange run (after initialization).
    fn exchange(&mut self) -> Result<&mut Exchange, Failure> {
        self.snap
            .me
            .as_mut()
            .ok_or_else(|| error("the instance has no Model Exchange state".into()))
    }

    /// The mesh and the state at the current time, of either interface, built if need be.
    fn point(&mut self) -> Result<(&PaperRig, State), Failure> {
        if self.snap.me.is_none() {
            self.build()?;
        }
        Ok(self.snap.current().expect("built above"))
    }

    /// The locals (the states that are not outputs, the derivatives) at the current time; a
    /// non-finite one is an error naming it, as for the outputs.
    #[cold]
    #[inline(never)]
    fn locals(&mut self) -> Result<crate::variables::Locals, Failure> {
        let t = self.time();
        let (mesh, y) = self.point()?;
        let l = outputs::locals(mesh, &y).map_err(|e| error(format!("at t = {t} s: {e}")))?;
        if let Some((name, x)) = l.first_non_finite() {
            return Err(error(format!(
                "{name} = {x} is not finite at t = {t}: check the parameters and start values"
            )));
        }
        Ok(l)
    }

    /// Outputs at the current time, computed once after each change and then read in place.
    /// A non-finite one (e.g. from absurd start values) is an error naming it: no NaN or
    /// infinity ever reaches a master.
    pub fn outputs(&mut self) -> Result<&Outputs, Failure> {
        if !self.fresh {
            match &self.snap.me {
                Some(ex) => outputs::write_exchange(ex, &mut self.outputs),
                None => {
                    self.build()?;
                    let sim = self.snap.sim.as_ref().expect("just built");
                    outputs::write(sim, &mut self.outputs)
                }
            }
            .map_err(|e| error(e.to_string()))?;
            self.energy_fresh = false;
            if let Some((name, x)) = self.outputs.first_non_finite() {
                return Err(error(format!(
                    "output {name} = {x} is not finite at t = {}: check the parameters and start values",
                    self.time()
                )));
            }
            self.fresh = true;
        }
        Ok(&self.outputs)
    }

    /// The outputs with the energy account, computed on the first read of one of its outputs
    /// after each change (`outputs::is_energy`); non-finite ones are an error naming them.
    fn energy_outputs(&mut self) -> Result<&Outputs, Failure> {
        self.outputs()?;
        if !self.energy_fresh {
            let (mesh, y) = self.snap.current().expect("built by outputs()");
            outputs::write_energy(mesh, &y, &mut self.outputs).map_err(|e| error(e.to_string()))?;
            let o = &self.outputs;
            for (name, x) in [
                ("E_kin", o.E_kin),
                ("E_el", o.E_el),
                ("energy_residual", o.energy_residual),
            ] {
                if !x.is_finite() {
                    return Err(error(format!(
                        "output {name} = {x} is not finite at t = {}: check the parameters and start values",
                        self.time()
                    )));
                }
            }
            self.energy_fresh = true;
        }
        Ok(&self.outputs)
    }

    fn value<T>(
        &mut self,
        v: Var,
        param: impl Fn(&Params) -> Option<T>,
        input: impl Fn(&Inputs) -> Option<T>,
        output: impl Fn(&Outputs) -> Option<T>,
        calc: impl Fn(&crate::variables::Calculated) -> Option<T>,
        local: impl Fn(&crate::variables::Locals) -> Option<T>,
    ) -> Result<T, Failure> {
        let got = match v.info().causality {
            // What a master reads after every step, read in place: `outputs()` is out of line.
            Causality::Output if self.fresh && !outputs::is_energy(v) => output(&self.outputs),
            Causality::Parameter => param(&self.snap.params),
            Causality::Input => input(&self.snap.inputs),
            Causality::Output if outputs::is_energy(v) => output(self.energy_outputs()?),
            Causality::Output => output(self.outputs()?),
            Causality::CalculatedParameter => calc(&outputs::calculated(self.point()?.0)),
            // Rare (Model Exchange's states and derivatives): out of line.
            Causality::Local => local(&self.locals()?),
        };
        Ok(got.expect("the generated table gives every variable a getter of its type"))
    }

    /// Sets several variables at once: all are checked before any is applied.
    fn set_many<T: Clone + std::fmt::Display>(
        &mut self,
        ty: VarType,
        vrs: &[u32],
        values: &[T],
        running: bool,
        check: impl Fn(&T) -> bool,
        apply: impl Fn(&mut Params, &mut Inputs, Var, T),
    ) -> Result<(), Failure> {
        let (mut params, mut inputs) = (self.snap.params.clone(), self.snap.inputs.clone());
        let mut ramp = self.snap.ramp;
        let now = self.time();
        let mut any_parameter = false;
        for (&vr, x) in vrs.iter().zip(values) {
            let v = lookup(vr, ty)?;
            settable(v, x, running)?;
            if !check(x) {
                return Err(error(format!(
                    "{} = {x}: the value must be finite",
                    v.info().name
                )));
            }
            apply(&mut params, &mut inputs, v, x.clone());
            any_parameter |= v.info().causality == Causality::Parameter;
            // A value set for an input holds from now on until derivatives are given for it.
            if let Some(k) = ramp_slot(v) {
                (ramp.t0[k], ramp.rate[k], ramp.curvature[k]) = (now, 0.0, 0.0);
            }
        }
        // Inputs need only be finite (checked above); parameters are checked as a whole.
        if any_parameter {
            crate::model::params::validate(&params).map_err(|e| error(e.message))?;
        }
        self.snap.params = params;
        self.snap.inputs = inputs;
        self.snap.ramp = ramp;
        self.fresh = false;
        if running {
            let (loads, ramp) = (self.loads(), self.snap.active_ramp());
            if let Some(sim) = self.snap.sim.as_mut() {
                sim.set_loads(loads, ramp);
            }
            if let Some(ex) = self.snap.me.as_mut() {
                ex.set_loads(loads);
            }
        } else {
            // Before the end of initialization the simulation is rebuilt from the parameters.
            self.snap.sim = None;
        }
        Ok(())
    }
}

/// Inlined into every get and set of a variable; the message is built out of line.
#[inline(always)]
fn lookup(vr: u32, ty: VarType) -> Result<Var, Failure> {
    match Var::from_vr(vr) {
        Some(v) if v.info().ty == ty => Ok(v),
        _ => Err(lookup_failure(vr, ty)),
    }
}

#[cold]
#[inline(never)]
fn lookup_failure(vr: u32, ty: VarType) -> Failure {
    match Var::from_vr(vr) {
        None => error(format!("unknown value reference {vr}")),
        Some(v) => error(format!(
            "{} (value reference {vr}) is {:?}, not {ty:?}",
            v.info().name,
            v.info().ty
        )),
    }
}

/// Checks that a variable may be set now to the value shown (for the message).
fn settable(v: Var, shown: &dyn std::fmt::Display, running: bool) -> Result<(), Failure> {
    let info = v.info();
    match (info.causality, info.variability) {
        (Causality::Output | Causality::CalculatedParameter | Causality::Local, _) => {
            Err(error(format!(
                "{} = {shown}: {} is a {:?}, it cannot be set",
                info.name, info.name, info.causality
            )))
        }
        (Causality::Parameter, Variability::Fixed) if running => Err(error(format!(
            "{} = {shown}: {} is a fixed parameter, it cannot be set after initialization",
            info.name, info.name
        ))),
        _ => Ok(()),
    }
}
