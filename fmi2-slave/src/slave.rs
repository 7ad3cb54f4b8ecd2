//! What a model provides to the FMI layer.

use crate::fmu_state::{Reader, Writer};
use crate::instance::{error, Failure};
use crate::{Boolean, Logger, ValueReference};

/// The model side of an FMU instance. The layer owns the FMI state machine: it calls these
/// methods only in the states where the standard allows the corresponding function, and a
/// failure (`Err`) is logged with the function's name and leaves the instance in the error
/// state (status Error) or stepFailed (status Discard from `do_step`).
///
/// A value of the type is everything that determines how the instance continues: an FMU state
/// is a clone, and a serialized FMU state is its `encode`d payload.
pub trait Slave: Clone + 'static {
    /// The model identifier (also the name used in messages).
    const MODEL_NAME: &'static str;
    /// The log categories of the modelDescription, in its order.
    const LOG_CATEGORIES: &'static [&'static str];
    /// The first 8 bytes of a serialized FMU state of this model.
    const STATE_MAGIC: [u8; 8];
    /// The version of the payload format; a state of another version is rejected.
    const STATE_FORMAT_VERSION: u32;

    /// The GUID of the modelDescription; fmi2Instantiate and serialized states must match it.
    fn guid() -> &'static str;

    /// A new instance, as after fmi2Instantiate or fmi2Reset.
    fn fresh() -> Self;

    /// fmi2Instantiate: a new instance of the FMU of GUID `guid` whose resources are the
    /// directory `resources` (None when the master gives none). A model whose FMUs differ only
    /// by their resources reads them here (SpurGearTrain's gearbox FMUs); the default ignores
    /// them. The layer then checks `guid` against `instance_guid`.
    fn instantiate(_resources: Option<&std::path::Path>, _guid: &str) -> Result<Self, String> {
        Ok(Self::fresh())
    }

    /// The GUID (FMI 3.0: instantiation token) of this instance's FMU: `guid()`, unless its
    /// resources made it another FMU.
    fn instance_guid(&self) -> String {
        Self::guid().to_owned()
    }

    /// fmi2Reset: the instance as after fmi2Instantiate.
    fn reset_model(&mut self) {
        *self = Self::fresh();
    }

    /// fmi2SetupExperiment (in the instantiated state).
    fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<(), Failure>;

    /// fmi2EnterInitializationMode.
    fn enter_initialization(&mut self) -> Result<(), Failure> {
        Ok(())
    }

    /// fmi2ExitInitializationMode: afterwards the instance steps.
    fn exit_initialization(&mut self) -> Result<(), Failure>;

    /// What is valid but unusual in the model just initialized: fmi2ExitInitializationMode logs
    /// each under logStatusWarning and returns fmi2Warning.
    fn init_warnings(&self) -> Vec<String> {
        Vec::new()
    }

    /// The value of one variable (fmi2Get*, from initialization mode on).
    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure>;
    fn get_integer(&mut self, vr: ValueReference) -> Result<i32, Failure> {
        Err(no_variables::<Self>(vr, "Integer"))
    }
    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        Err(no_variables::<Self>(vr, "Boolean"))
    }
    fn get_string(&mut self, vr: ValueReference) -> Result<String, Failure> {
        Err(no_variables::<Self>(vr, "String"))
    }

    /// fmi2Set*: sets `values[k]` to `vrs[k]` (equal lengths), all or none: every value is
    /// checked before any is applied. `running`: after initialization (stepComplete), when
    /// only tunable parameters and inputs may change.
    fn set_real(
        &mut self,
        vrs: &[ValueReference],
        values: &[f64],
        running: bool,
    ) -> Result<(), Failure>;
    fn set_integer(
        &mut self,
        vrs: &[ValueReference],
        _values: &[i32],
        _running: bool,
    ) -> Result<(), Failure> {
        match vrs.first() {
            Some(&vr) => Err(no_variables::<Self>(vr, "Integer")),
            None => Ok(()),
        }
    }
    /// Booleans as the master passes them (fmi2Boolean: 0 is false).
    fn set_boolean(
        &mut self,
        vrs: &[ValueReference],
        _values: &[Boolean],
        _running: bool,
    ) -> Result<(), Failure> {
        match vrs.first() {
            Some(&vr) => Err(no_variables::<Self>(vr, "Boolean")),
            None => Ok(()),
        }
    }

    /// Strings as UTF-8 text (the layer rejects null pointers and invalid UTF-8).
    fn set_string(
        &mut self,
        vrs: &[ValueReference],
        _values: &[String],
        _running: bool,
    ) -> Result<(), Failure> {
        match vrs.first() {
            Some(&vr) => Err(no_variables::<Self>(vr, "String")),
            None => Ok(()),
        }
    }

    /// fmi2SetRealInputDerivatives: `values[k]` is the `orders[k]`-th time derivative of input
    /// `vrs[k]` at the current time (equal lengths), for a slave that interpolates its inputs
    /// over the next steps.
    fn set_real_input_derivatives(
        &mut self,
        _vrs: &[ValueReference],
        _orders: &[i32],
        _values: &[f64],
    ) -> Result<(), Failure> {
        Err(crate::error(
            "canInterpolateInputs is false: input derivatives are not supported".into(),
        ))
    }

    /// fmi2DoStep from `current` (checked to be the instance's time) over `h` (finite and
    /// positive). `h` is the interval the time represents, (current + h') - current for the
    /// master's h' (`ffi::represented_step`), so `current + h` is the step's end exactly. A
    /// failure with status Discard means the step could not be completed and the instance
    /// keeps its values at `current`.
    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure>;

    /// The time of the last communication point (the start time before the first step).
    fn time(&self) -> f64;
    /// Called before the instance is saved (fmi2GetFMUstate). A slave whose solver cannot be
    /// copied makes its current point a restart point here, so that the saved and the live
    /// instance continue identically.
    fn prepare_save(&mut self) {}

    /// Writes the payload of a serialized FMU state.
    fn encode(&self, w: &mut Writer);
    /// Reads what `encode` wrote (the layer checks that nothing is left over).
    fn decode(r: &mut Reader) -> Result<Self, String>;
    /// `decode` for the FMU of this instance (whose resources a state does not carry).
    fn decode_for(&self, r: &mut Reader) -> Result<Self, String> {
        Self::decode(r)
    }

    // ---- Model Exchange ---------------------------------------------------------------------
    // A model with `MODEL_EXCHANGE` may be instantiated as fmi2ModelExchange; the layer calls
    // the methods below only in the states the standard allows, with arrays of the sizes given
    // here (checked). The defaults serve a Co-Simulation-only model, for which the layer
    // answers every Model Exchange function with fmi2Error before calling them.

    const MODEL_EXCHANGE: bool = false;
    const N_STATES: usize = 0;
    const N_EVENT_INDICATORS: usize = 0;
    /// FMI 3.0 declares the event indicators as variables: their value references start here.
    const EVENT_INDICATOR_VR0: u32 = 0;

    /// This instance's numbers of continuous states and event indicators and the value
    /// reference of its first FMI 3.0 event indicator: the constants, unless its resources
    /// made it another FMU.
    fn n_states(&self) -> usize {
        Self::N_STATES
    }
    fn n_event_indicators(&self) -> usize {
        Self::N_EVENT_INDICATORS
    }
    fn event_indicator_vr0(&self) -> u32 {
        Self::EVENT_INDICATOR_VR0
    }
    /// The states directional derivatives take as knowns and give derivatives of: the
    /// declared ones, or more where the model has states no master integrates (`state_vr` and
    /// `derivative_vr` name them all; `me_states` and the like then fill arrays this long).
    fn n_directional_states(&self) -> usize {
        self.n_states()
    }

    /// The name of continuous state k (messages).
    fn state_name(&self, _k: usize) -> String {
        "a continuous state".into()
    }

    /// fmi2ExitInitializationMode of a Model Exchange instance: afterwards the master
    /// integrates, and the model is in event mode.
    fn me_exit_initialization(&mut self) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    /// fmi2SetTime (finite, checked).
    fn me_set_time(&mut self, _t: f64) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    /// fmi2SetContinuousStates (finite, checked).
    fn me_set_states(&mut self, _x: &[f64]) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    fn me_states(&mut self, _x: &mut [f64]) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    fn me_derivatives(&mut self, _dx: &mut [f64]) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    fn me_event_indicators(&mut self, _z: &mut [f64]) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    fn me_nominals(&mut self, _n: &mut [f64]) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    /// fmi2EnterEventMode: the master stopped at an event (or an input changed).
    fn me_enter_event_mode(&mut self) -> Result<(), Failure> {
        Err(no_model_exchange::<Self>())
    }
    /// fmi2NewDiscreteStates: handles what happened and says what changed.
    fn me_new_discrete_states(&mut self, _log: &Logger) -> Result<EventUpdate, Failure> {
        Err(no_model_exchange::<Self>())
    }
    /// fmi2CompletedIntegratorStep: the master accepted its step; true asks for event mode.
    fn me_completed_integrator_step(&mut self) -> Result<bool, Failure> {
        Err(no_model_exchange::<Self>())
    }

    /// Model Exchange provides directional derivatives (`directional.rs`): from the states'
    /// and their derivatives' value references below.
    const DIRECTIONAL_DERIVATIVES: bool = false;
    /// The value references of continuous state k and of its derivative.
    fn state_vr(&self, _k: usize) -> Option<ValueReference> {
        None
    }
    fn derivative_vr(&self, _k: usize) -> Option<ValueReference> {
        None
    }
    /// Whether a value reference is a real input (a known besides the states).
    fn is_real_input(&self, _vr: ValueReference) -> bool {
        false
    }
    /// How far each state may move for a central difference at the current point: within
    /// the smooth right-hand side and far above the rounding of the model's arithmetic.
    /// By default the larger of |x| and its nominal.
    fn me_difference_scales(&mut self, s: &mut [f64]) -> Result<(), Failure> {
        self.me_nominals(s)?;
        let mut x = vec![0.0; s.len()];
        self.me_states(&mut x)?;
        for (sk, xk) in s.iter_mut().zip(x) {
            *sk = sk.abs().max(xk.abs());
        }
        Ok(())
    }
}

/// What fmi2NewDiscreteStates reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventUpdate {
    /// The continuous states jumped (an impact changed speeds).
    pub states_changed: bool,
    /// The nominals changed (the master should re-read them).
    pub nominals_changed: bool,
    /// A time event ahead, if any.
    pub next_event_time: Option<f64>,
}

pub(crate) fn no_model_exchange<S: Slave>() -> Failure {
    error(format!(
        "{} is a Co-Simulation FMU: Model Exchange functions are not available",
        S::MODEL_NAME
    ))
}

fn no_variables<S: Slave>(vr: ValueReference, ty: &str) -> Failure {
    error(format!(
        "value reference {vr}: {} has no {ty} variables",
        S::MODEL_NAME
    ))
}

/// The checks of fmi2SetupExperiment's times that every model makes.
pub fn check_experiment_times(start: f64, stop: Option<f64>) -> Result<(), Failure> {
    if !start.is_finite() {
        return Err(error(format!("startTime = {start}: must be finite")));
    }
    if let Some(s) = stop {
        if !(s >= start) || !s.is_finite() {
            return Err(error(format!(
                "stopTime = {s}: must be finite and not before startTime = {start}"
            )));
        }
    }
    Ok(())
}
