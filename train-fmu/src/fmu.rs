//! The exported model: SpurGearTrain, or the FMU of one gearbox (gearbox-file.md §2). Both
//! are this binary. A gearbox FMU carries its file as `resources/gearbox.toml` and a GUID of
//! its own; at instantiation the binary reads the file, sets the train's parameters from it,
//! and from then on speaks the gearbox's variables (`gearbox_vars`): their value references,
//! names in messages, exactly its Model Exchange states and event indicators. The train runs
//! underneath unchanged, so both FMUs give the same traces.

use crate::gearbox::{self as file, Start};
use crate::gearbox_vars::{self, GearKey, GearValue, GearboxVar, Target};
use crate::instance::SpurGearTrain;
use crate::variables::{
    Causality, Inputs, Params, Var, VarType, GUID, N_DECLARED_STATES, N_EVENT_INDICATORS, STATES,
};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::{error, Boolean, EventUpdate, Failure, Logger, Slave, ValueReference};
use gear_model::model::train::MAX_MESHES;
use gearbox::{Gear, Gearbox};
use std::sync::Arc;

/// The gearbox file's name in the FMU's resources.
pub const RESOURCE: &str = "gearbox.toml";
/// The version the GUIDs hash with the table (as build.rs gives SpurGearTrain's).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The train's states, all of them (SpurGearTrain declares `N_DECLARED_STATES` to masters).
const N_STATES: usize = STATES.len();
/// Event indicators per mesh.
const PER_MESH: usize = N_EVENT_INDICATORS / MAX_MESHES;

/// What a gearbox FMU's GUID hashes: SpurGearTrain's GUID and the file, so that another
/// binary or another file gives another GUID.
pub fn guid_source(text: &str) -> String {
    format!("{GUID}\n{text}")
}

/// A gearbox FMU's GUID (the packaging writes it with `guid_source` and `VERSION`).
pub fn guid(text: &str) -> String {
    fmi2_slave::guid_from_hash(guid_source(text).bytes().chain(VERSION.bytes()))
}

/// One gearbox, as its FMU's instances share it.
#[derive(Debug)]
pub struct GearboxFmu {
    pub gearbox: Gearbox,
    pub vars: Vec<GearboxVar>,
    /// Model Exchange's states as indices into the train's (`gearbox_vars::state_indices`).
    pub states: Vec<usize>,
    pub guid: String,
    params: Params,
    inputs: Inputs,
}

impl GearboxFmu {
    /// From the file's text; a refusal names the file's elements and lines.
    pub fn new(text: &str) -> Result<GearboxFmu, String> {
        let g = gearbox::parse(text).map_err(|e| e.0)?;
        let values = file::start_values(&g)?;
        let (params, inputs) = file::params(&values).map_err(|e| file::in_file_names(&g, &e))?;
        Ok(GearboxFmu {
            vars: gearbox_vars::variables(&g),
            states: gearbox_vars::state_indices(&g),
            guid: guid(text),
            gearbox: g,
            params,
            inputs,
        })
    }

    /// Model Exchange's continuous states: the two work accounts and a coordinate per body,
    /// its value and rate (a speed drive's rate is its input, not a state).
    pub fn n_states(&self) -> usize {
        self.states.len()
    }

    pub fn n_event_indicators(&self) -> usize {
        PER_MESH * self.gearbox.meshes.len()
    }
}

/// The model of an FMU instance.
#[derive(Clone, Debug)]
pub struct TrainFmu {
    pub train: SpurGearTrain,
    gearbox: Option<Box<Own>>,
}

#[derive(Clone, Debug)]
struct Own {
    fmu: Arc<GearboxFmu>,
    /// The gears as the master last set them (the file's until it sets a gear's key).
    gears: Vec<Gear>,
}

impl TrainFmu {
    /// The value reference, in this FMU's numbering, of state k's variable or its derivative
    /// (`pick` chooses from SpurGearTrain's pair): a gearbox's own variable of the same train
    /// variable.
    fn own_vr(&self, k: usize, pick: fn((Var, Var)) -> Var) -> Option<ValueReference> {
        match self.gearbox.as_deref() {
            None => STATES.get(k).map(|&s| pick(s).info().vr),
            Some(o) => {
                let train = pick(*STATES.get(*o.fmu.states.get(k)?)?);
                let i = o.fmu.vars.iter().position(|v| v.train == train)?;
                Some(i as ValueReference + 1)
            }
        }
    }

    /// An instance of a gearbox's FMU.
    pub fn gearbox(fmu: Arc<GearboxFmu>) -> TrainFmu {
        let mut train = SpurGearTrain::fresh();
        train.snap.params = fmu.params.clone();
        train.snap.inputs = fmu.inputs.clone();
        let gears = fmu.gearbox.gears.clone();
        TrainFmu {
            train,
            gearbox: Some(Box::new(Own { fmu, gears })),
        }
    }

    /// The gearbox of a gearbox FMU's instance.
    pub fn gearbox_fmu(&self) -> Option<&Arc<GearboxFmu>> {
        self.gearbox.as_ref().map(|o| &o.fmu)
    }

    /// A train failure in the gearbox's names.
    fn named(&self, f: Failure) -> Failure {
        match &self.gearbox {
            Some(o) => Failure {
                message: file::renamed(&o.fmu.gearbox, &f.message).0,
                ..f
            },
            None => f,
        }
    }

    /// Runs a call of the train, its failure in the gearbox's names.
    fn on_train<T>(
        &mut self,
        f: impl FnOnce(&mut SpurGearTrain) -> Result<T, Failure>,
    ) -> Result<T, Failure> {
        f(&mut self.train).map_err(|e| self.named(e))
    }

    /// The train's value reference of a gearbox variable of type `ty` (or the gearbox
    /// variable itself, for a target that is not one train variable).
    /// The gearbox variable at vr if it is a calculated parameter.
    fn calculated(&self, vr: ValueReference) -> Option<&GearboxVar> {
        let o = self.gearbox.as_ref()?;
        let v = o.fmu.vars.get((vr as usize).checked_sub(1)?)?;
        (v.causality == Causality::CalculatedParameter).then_some(v)
    }

    fn resolve(&self, vr: ValueReference, ty: VarType) -> Result<Resolved<'_>, Failure> {
        let Some(o) = &self.gearbox else {
            return Ok(Resolved::Train(vr));
        };
        let v = (vr as usize)
            .checked_sub(1)
            .and_then(|k| o.fmu.vars.get(k))
            .ok_or_else(|| error(format!("unknown value reference {vr}")))?;
        let own = v.train.info().ty;
        if own != ty {
            return Err(error(format!(
                "value reference {vr} is {}, a variable of type {own:?}, not {ty:?}",
                v.name
            )));
        }
        Ok(match v.target {
            Target::Train => Resolved::Train(v.train.info().vr),
            _ => Resolved::Other(v, &o.gears),
        })
    }

    fn get<X>(
        &mut self,
        vr: ValueReference,
        ty: VarType,
        train: fn(&mut SpurGearTrain, ValueReference) -> Result<X, Failure>,
        other: impl FnOnce(&mut SpurGearTrain, Other, GearValue) -> Result<X, Failure>,
    ) -> Result<X, Failure> {
        // Copied out (no allocation): outputs such as MESH.F are read after every step.
        let (v, value) = match self.resolve(vr, ty)? {
            Resolved::Train(r) => return self.on_train(|t| train(t, r)),
            Resolved::Other(v, gears) => {
                let value = match v.target {
                    Target::Gear { gear, key } => key.get(&gears[gear]),
                    _ => GearValue::Real(None),
                };
                (
                    Other {
                        target: v.target,
                        train: v.train,
                    },
                    value,
                )
            }
        };
        self.on_train(|t| other(t, v, value))
    }

    /// A set of values of one type: the train's variables go to the train in one call, a
    /// gear's keys change the gear and then every value of its meshes that follows. All or
    /// none: a refused set leaves the instance as it was.
    fn set<X: Clone>(
        &mut self,
        vrs: &[ValueReference],
        values: &[X],
        running: bool,
        ty: VarType,
        train: SetOf<X>,
        gear_value: fn(&X) -> Result<GearValue, String>,
    ) -> Result<(), Failure> {
        if self.gearbox.is_none() {
            return train(&mut self.train, vrs, values, running);
        }
        let mut direct = (Vec::new(), Vec::new());
        let mut gear_sets = Vec::new();
        for (&vr, x) in vrs.iter().zip(values) {
            if let Some(v) = self.calculated(vr) {
                return Err(error(format!(
                    "{} is a calculated parameter (from the gearbox file's damping_ratio): it cannot be set",
                    v.name
                )));
            }
            match self.resolve(vr, ty)? {
                Resolved::Train(r) => {
                    direct.0.push(r);
                    direct.1.push(x.clone());
                }
                Resolved::Other(v, _) => match v.target {
                    Target::Gear { gear, key } => {
                        if running {
                            return Err(error(format!(
                                "{} is a gear's fixed parameter: it may change only before fmi2ExitInitializationMode",
                                v.name
                            )));
                        }
                        let value = gear_value(x).map_err(|e| error(format!("{} {e}", v.name)))?;
                        gear_sets.push((gear, key, value));
                    }
                    _ => return Err(error(format!("{} is an output: it cannot be set", v.name))),
                },
            }
        }
        if gear_sets.is_empty() {
            return self.on_train(|t| train(t, &direct.0, &direct.1, running));
        }
        let backup = self.clone();
        let result = self
            .on_train(|t| train(t, &direct.0, &direct.1, running))
            .and_then(|()| self.set_gears(gear_sets));
        if result.is_err() {
            *self = backup;
        }
        result
    }

    /// Sets gears' keys and every pair parameter of their meshes that changes with them.
    fn set_gears(&mut self, sets: Vec<(usize, GearKey, GearValue)>) -> Result<(), Failure> {
        let o = self.gearbox.as_ref().expect("a gearbox FMU");
        let mut gears = o.gears.clone();
        for (gear, key, value) in sets {
            key.set(&mut gears[gear], value);
        }
        let with = |gears: &[Gear]| {
            let mut g = o.fmu.gearbox.clone();
            g.gears = gears.to_vec();
            file::values(&g).map_err(|e| error(file::renamed(&g, &e).0))
        };
        let before = with(&o.gears)?;
        let after = with(&gears)?;
        let changed: Vec<(u32, Start)> = after
            .into_iter()
            .filter(|x| !before.contains(x))
            .map(|(name, x)| (crate::build::var(&name).info().vr, x))
            .collect();
        for (vr, x) in changed {
            self.on_train(|t| match x {
                Start::Real(x) => t.set_real(&[vr], &[x], false),
                Start::Integer(x) => t.set_integer(&[vr], &[x], false),
                Start::Boolean(x) => t.set_boolean(&[vr], &[x as Boolean], false),
                Start::String(x) => t.set_string(&[vr], &[x], false),
            })?;
        }
        self.gearbox.as_mut().expect("a gearbox FMU").gears = gears;
        Ok(())
    }

    /// Model Exchange's arrays: the train's, of which a gearbox uses the first `n`.
    fn prefix<const N: usize>(
        &mut self,
        out: &mut [f64],
        get: fn(&mut SpurGearTrain, &mut [f64]) -> Result<(), Failure>,
    ) -> Result<(), Failure> {
        if self.gearbox.is_none() {
            return get(&mut self.train, out);
        }
        let mut full = [0.0; N];
        self.on_train(|t| get(t, &mut full))?;
        out.copy_from_slice(&full[..out.len()]);
        Ok(())
    }

    /// A per-state array of the train, for a gearbox its states only.
    fn states_of(
        &mut self,
        out: &mut [f64],
        get: fn(&mut SpurGearTrain, &mut [f64]) -> Result<(), Failure>,
    ) -> Result<(), Failure> {
        let Some(o) = self.gearbox.as_ref() else {
            return get(&mut self.train, out);
        };
        // The gearbox is shared (an Arc): no copy of its state list per call.
        let fmu = o.fmu.clone();
        let mut full = [0.0; N_STATES];
        self.on_train(|t| get(t, &mut full))?;
        for (x, &i) in out.iter_mut().zip(&fmu.states) {
            *x = full[i];
        }
        Ok(())
    }
}

/// A gearbox variable that is not one train variable, as a get needs it.
#[derive(Clone, Copy)]
struct Other {
    target: Target,
    train: Var,
}

/// One of the train's fmi2Set* bodies.
type SetOf<X> = fn(&mut SpurGearTrain, &[u32], &[X], bool) -> Result<(), Failure>;

enum Resolved<'a> {
    Train(ValueReference),
    Other(&'a GearboxVar, &'a [Gear]),
}

/// A gear key's value from a master's Real.
fn real_key(x: &f64) -> Result<GearValue, String> {
    Ok(GearValue::Real(Some(*x)))
}

fn integer_key(x: &i32) -> Result<GearValue, String> {
    Ok(GearValue::Integer(*x as i64))
}

/// Pitch errors as the train takes them: numbers separated by commas.
fn list_key(x: &String) -> Result<GearValue, String> {
    x.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f64>()
                .map_err(|_| format!("= \"{x}\": {s:?} is not a number"))
        })
        .collect::<Result<Vec<f64>, String>>()
        .map(GearValue::List)
}

fn no_boolean_key(_: &Boolean) -> Result<GearValue, String> {
    Err("is not a Boolean".into())
}

impl Slave for TrainFmu {
    const MODEL_NAME: &'static str = SpurGearTrain::MODEL_NAME;
    const LOG_CATEGORIES: &'static [&'static str] = SpurGearTrain::LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = SpurGearTrain::STATE_MAGIC;
    const STATE_FORMAT_VERSION: u32 = SpurGearTrain::STATE_FORMAT_VERSION;

    fn guid() -> &'static str {
        GUID
    }

    fn fresh() -> TrainFmu {
        TrainFmu {
            train: SpurGearTrain::fresh(),
            gearbox: None,
        }
    }

    fn instantiate(resources: Option<&std::path::Path>, guid: &str) -> Result<TrainFmu, String> {
        if guid == GUID {
            return Ok(TrainFmu::fresh());
        }
        // Another GUID: a gearbox FMU, whose file says which (or a wrong GUID, which the
        // layer reports once the file is read).
        let dir = resources.ok_or_else(|| {
            format!("GUID {guid:?} is not SpurGearTrain's, so this is a gearbox FMU, but the master gave no resource location to read its {RESOURCE} from")
        })?;
        let path = dir.join(RESOURCE);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            format!("GUID {guid:?} is not SpurGearTrain's ({GUID}), so this is a gearbox FMU, but its gearbox file {} cannot be read: {e}", path.display())
        })?;
        let fmu = GearboxFmu::new(&text)
            .map_err(|e| format!("the gearbox file {}: {e}", path.display()))?;
        Ok(TrainFmu::gearbox(Arc::new(fmu)))
    }

    fn instance_guid(&self) -> String {
        match &self.gearbox {
            Some(o) => o.fmu.guid.clone(),
            None => GUID.into(),
        }
    }

    fn reset_model(&mut self) {
        *self = match self.gearbox.take() {
            Some(o) => TrainFmu::gearbox(o.fmu),
            None => TrainFmu::fresh(),
        };
    }

    fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<(), Failure> {
        self.on_train(|t| t.setup_experiment(tolerance, start, stop))
    }

    fn enter_initialization(&mut self) -> Result<(), Failure> {
        self.on_train(|t| t.enter_initialization())
    }

    fn exit_initialization(&mut self) -> Result<(), Failure> {
        self.on_train(|t| t.exit_initialization())
    }

    fn init_warnings(&self) -> Vec<String> {
        let w = self.train.init_warnings();
        match &self.gearbox {
            Some(o) => w
                .into_iter()
                .map(|m| file::renamed(&o.fmu.gearbox, &m).0)
                .collect(),
            None => w,
        }
    }

    #[inline]
    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure> {
        self.get(vr, VarType::Real, SpurGearTrain::get_real, |t, v, value| {
            match (v.target, value) {
                (Target::Load { bwd }, _) => {
                    Ok(t.get_real(v.train.info().vr)? + t.get_real(bwd.info().vr)?)
                }
                (_, GearValue::Real(Some(x))) => Ok(x),
                // The model's default, which the gear's first mesh holds.
                _ => t.get_real(v.train.info().vr),
            }
        })
    }

    fn get_integer(&mut self, vr: ValueReference) -> Result<i32, Failure> {
        self.get(
            vr,
            VarType::Integer,
            SpurGearTrain::get_integer,
            |t, v, value| match value {
                GearValue::Integer(z) => Ok(z as i32),
                _ => t.get_integer(v.train.info().vr),
            },
        )
    }

    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        self.get(
            vr,
            VarType::Boolean,
            SpurGearTrain::get_boolean,
            |t, v, _| t.get_boolean(v.train.info().vr),
        )
    }

    fn get_string(&mut self, vr: ValueReference) -> Result<String, Failure> {
        self.get(
            vr,
            VarType::String,
            SpurGearTrain::get_string,
            |t, v, value| match value {
                GearValue::List(l) => Ok(l
                    .iter()
                    .map(|x| format!("{x:e}"))
                    .collect::<Vec<_>>()
                    .join(",")),
                _ => t.get_string(v.train.info().vr),
            },
        )
    }

    fn set_real(&mut self, vrs: &[u32], values: &[f64], running: bool) -> Result<(), Failure> {
        self.set(
            vrs,
            values,
            running,
            VarType::Real,
            SpurGearTrain::set_real,
            real_key,
        )
    }

    fn set_integer(&mut self, vrs: &[u32], values: &[i32], running: bool) -> Result<(), Failure> {
        let train = SpurGearTrain::set_integer;
        self.set(vrs, values, running, VarType::Integer, train, integer_key)
    }

    fn set_boolean(
        &mut self,
        vrs: &[u32],
        values: &[Boolean],
        running: bool,
    ) -> Result<(), Failure> {
        let train = SpurGearTrain::set_boolean;
        self.set(
            vrs,
            values,
            running,
            VarType::Boolean,
            train,
            no_boolean_key,
        )
    }

    fn set_string(&mut self, vrs: &[u32], values: &[String], running: bool) -> Result<(), Failure> {
        let train = SpurGearTrain::set_string;
        self.set(vrs, values, running, VarType::String, train, list_key)
    }

    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure> {
        self.on_train(|t| t.do_step(current, h, log))
    }

    fn time(&self) -> f64 {
        self.train.time()
    }

    fn prepare_save(&mut self) {
        self.train.prepare_save()
    }

    /// A gearbox's gears (a master may have set their keys), then the train's payload (which
    /// reads to the end).
    fn encode(&self, w: &mut Writer) {
        if let Some(o) = &self.gearbox {
            for g in &o.gears {
                w.u(g.z as u64);
                w.f(g.x);
                for key in gearbox_vars::OPTIONAL_KEYS {
                    if let GearValue::Real(x) = key.get(g) {
                        w.opt(x);
                    }
                }
                w.u(g.pitch_errors.len() as u64);
                g.pitch_errors.iter().for_each(|&x| w.f(x));
            }
        }
        self.train.encode(w);
    }

    fn decode(r: &mut Reader) -> Result<TrainFmu, String> {
        Ok(TrainFmu {
            train: SpurGearTrain::decode(r)?,
            gearbox: None,
        })
    }

    fn decode_for(&self, r: &mut Reader) -> Result<TrainFmu, String> {
        let Some(o) = &self.gearbox else {
            return TrainFmu::decode(r);
        };
        let mut gears = o.fmu.gearbox.gears.clone();
        for g in &mut gears {
            g.z = r.u()? as i64;
            g.x = r.f()?;
            for key in gearbox_vars::OPTIONAL_KEYS {
                key.set(g, GearValue::Real(r.opt()?));
            }
            let n = r.u()? as usize;
            if n > 100_000 {
                return Err(format!("{n} pitch errors on gear {}", g.name));
            }
            g.pitch_errors = (0..n).map(|_| r.f()).collect::<Result<_, _>>()?;
        }
        Ok(TrainFmu {
            train: SpurGearTrain::decode(r)?,
            gearbox: Some(Box::new(Own {
                fmu: o.fmu.clone(),
                gears,
            })),
        })
    }

    // ---- Model Exchange: a gearbox's states and indicators are the train's first ----------

    const MODEL_EXCHANGE: bool = true;
    const N_STATES: usize = N_DECLARED_STATES;
    const N_EVENT_INDICATORS: usize = N_EVENT_INDICATORS;
    const EVENT_INDICATOR_VR0: u32 = SpurGearTrain::EVENT_INDICATOR_VR0;

    fn n_states(&self) -> usize {
        let own = |o: &Own| o.fmu.n_states();
        self.gearbox.as_deref().map_or(N_DECLARED_STATES, own)
    }

    /// SpurGearTrain's directional derivatives cover every coordinate; a gearbox's, its own.
    fn n_directional_states(&self) -> usize {
        let own = |o: &Own| o.fmu.n_states();
        self.gearbox.as_deref().map_or(N_STATES, own)
    }

    fn n_event_indicators(&self) -> usize {
        let own = |o: &Own| o.fmu.n_event_indicators();
        self.gearbox.as_deref().map_or(N_EVENT_INDICATORS, own)
    }

    /// A gearbox's event indicators follow its variables.
    fn event_indicator_vr0(&self) -> u32 {
        let own = |o: &Own| o.fmu.vars.len() as u32 + 1;
        self.gearbox
            .as_deref()
            .map_or(SpurGearTrain::EVENT_INDICATOR_VR0, own)
    }

    fn state_name(&self, k: usize) -> String {
        let k = self.gearbox.as_ref().map_or(k, |o| o.fmu.states[k]);
        self.train.state_name(k)
    }

    const DIRECTIONAL_DERIVATIVES: bool = true;

    fn state_vr(&self, k: usize) -> Option<ValueReference> {
        self.own_vr(k, |(state, _)| state)
    }

    fn derivative_vr(&self, k: usize) -> Option<ValueReference> {
        self.own_vr(k, |(_, der)| der)
    }

    fn is_real_input(&self, vr: ValueReference) -> bool {
        match self.gearbox.as_deref() {
            None => self.train.is_real_input(vr),
            Some(o) => o.fmu.vars.get(vr as usize - 1).is_some_and(|v| {
                v.causality == Causality::Input && v.train.info().ty == VarType::Real
            }),
        }
    }

    fn me_exit_initialization(&mut self) -> Result<(), Failure> {
        self.on_train(|t| t.me_exit_initialization())
    }

    fn me_set_time(&mut self, t: f64) -> Result<(), Failure> {
        self.on_train(|s| s.me_set_time(t))
    }

    fn me_set_states(&mut self, x: &[f64]) -> Result<(), Failure> {
        if self.gearbox.is_none() {
            return self.train.me_set_states(x);
        }
        // The coordinates beyond the gearbox's bodies are not in use: they keep their 0; a
        // speed drive's rate keeps its input.
        let mut full = [0.0; N_STATES];
        self.on_train(|t| t.me_states(&mut full))?;
        let states = &self.gearbox.as_ref().expect("a gearbox").fmu.states;
        for (&i, &xi) in states.iter().zip(x) {
            full[i] = xi;
        }
        self.on_train(|t| t.me_set_states(&full))
    }

    fn me_states(&mut self, x: &mut [f64]) -> Result<(), Failure> {
        self.states_of(x, SpurGearTrain::me_states)
    }

    fn me_derivatives(&mut self, dx: &mut [f64]) -> Result<(), Failure> {
        self.states_of(dx, SpurGearTrain::me_derivatives)
    }

    fn me_event_indicators(&mut self, z: &mut [f64]) -> Result<(), Failure> {
        self.prefix::<N_EVENT_INDICATORS>(z, SpurGearTrain::me_event_indicators)
    }

    fn me_nominals(&mut self, n: &mut [f64]) -> Result<(), Failure> {
        self.states_of(n, SpurGearTrain::me_nominals)
    }

    fn me_difference_scales(&mut self, s: &mut [f64]) -> Result<(), Failure> {
        self.states_of(s, SpurGearTrain::me_difference_scales)
    }

    fn me_enter_event_mode(&mut self) -> Result<(), Failure> {
        self.on_train(|t| t.me_enter_event_mode())
    }

    fn me_new_discrete_states(&mut self, log: &Logger) -> Result<EventUpdate, Failure> {
        self.on_train(|t| t.me_new_discrete_states(log))
    }

    fn me_completed_integrator_step(&mut self) -> Result<bool, Failure> {
        self.on_train(|t| t.me_completed_integrator_step())
    }
}
