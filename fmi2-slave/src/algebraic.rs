//! A stateless FMU: outputs that are a function of the parameters and inputs set last (a direct
//! feedthrough), and a step that only advances the time. TorsionalShaft and EngineTorque are
//! such FMUs; this module is their `Slave`, written once.
//!
//! A model provides its variable table through [`Table`] (which
//! [`values_table!`](crate::values_table) implements from the crate's generated `variables`
//! module) and its law through [`Law`]. The table's helpers (`lookup`, `set_reals`, the FMU
//! state's `encode_reals`/`decode_reals`) serve a stateful FMU too: SpeedController.

use crate::fmu_state::{Reader, Writer};
use crate::instance::{error, Failure};
use crate::{Logger, Slave, ValueReference};

/// One variable of the table, as the FMI layer needs it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variable {
    pub name: &'static str,
    /// "Real", "Integer", "Boolean" or "String".
    pub ty: &'static str,
    /// A parameter or an input: the master may set it.
    pub settable: bool,
}

/// An FMU's parameters and inputs and its variable table (generated: see
/// [`values_table!`](crate::values_table)).
pub trait Table: Clone + std::fmt::Debug + PartialEq + 'static {
    const MODEL_NAME: &'static str;
    const LOG_CATEGORIES: &'static [&'static str];
    fn guid() -> &'static str;
    /// The table's start values.
    fn start() -> Self;
    fn variable(vr: ValueReference) -> Option<Variable>;
    /// The settable Reals' value references, in the table's order (the FMU state's payload).
    fn settable_reals() -> Vec<ValueReference>;
    /// Why `x` is outside the table's range of `vr`, if it is.
    fn range_violation(vr: ValueReference, x: f64) -> Option<String>;
    /// A settable Real's value.
    fn settable_real(&self, vr: ValueReference) -> Option<f64>;
    /// Sets a settable Real (false: `vr` is not one).
    fn set_settable_real(&mut self, vr: ValueReference, x: f64) -> bool;
}

/// The model's law.
pub trait Law: Table {
    /// The first 8 bytes of a serialized FMU state.
    const STATE_MAGIC: [u8; 8];
    /// An output's value at the current parameters and inputs (None: not an output).
    fn output(&self, vr: ValueReference) -> Option<f64>;
    /// Why these values cannot be the law's beyond each value's own range (an output that
    /// overflows, say), if they cannot.
    fn check(&self) -> Option<String>;
}

/// A stateless FMU instance: its values and its time.
#[derive(Clone, Debug, PartialEq)]
pub struct Algebraic<L> {
    pub law: L,
    pub start_time: f64,
    pub time: f64,
}

/// The variable behind `vr`, which must be of type `ty`.
pub fn lookup<T: Table>(vr: ValueReference, ty: &str) -> Result<Variable, Failure> {
    let v = T::variable(vr).ok_or_else(|| error(format!("unknown value reference {vr}")))?;
    if v.ty != ty {
        return Err(error(format!(
            "{} (value reference {vr}) is {}, not {ty}",
            v.name, v.ty
        )));
    }
    Ok(v)
}

/// A variable the master may set (a parameter or an input) of type `ty`.
pub fn settable<T: Table>(vr: ValueReference, ty: &str) -> Result<Variable, Failure> {
    let v = lookup::<T>(vr, ty)?;
    if !v.settable {
        return Err(error(format!("{} is an output: it cannot be set", v.name)));
    }
    Ok(v)
}

/// A settable Real's own check: finite and within the table's range.
fn value_violation<T: Table>(vr: ValueReference, name: &str, x: f64) -> Option<String> {
    if !x.is_finite() {
        return Some(format!("{name} = {x}: must be finite"));
    }
    T::range_violation(vr, x).map(|why| format!("{name} = {x}: {why}"))
}

/// `values` with `xs` set to `vrs`, all or none: each value finite and in its range, then
/// `check` (the law's own condition on all values together) passes.
pub fn set_reals<T: Table>(
    values: &T,
    vrs: &[ValueReference],
    xs: &[f64],
    check: impl Fn(&T) -> Option<String>,
) -> Result<T, Failure> {
    let mut new = values.clone();
    for (&vr, &x) in vrs.iter().zip(xs) {
        let v = settable::<T>(vr, "Real")?;
        if let Some(why) = value_violation::<T>(vr, v.name, x) {
            return Err(error(why));
        }
        new.set_settable_real(vr, x);
    }
    if let Some(why) = check(&new) {
        return Err(error(why));
    }
    Ok(new)
}

/// Writes every settable Real, in the table's order (a serialized FMU state's part).
pub fn encode_reals<T: Table>(values: &T, w: &mut Writer) {
    for vr in T::settable_reals() {
        w.f(values.settable_real(vr).expect("a settable Real"));
    }
}

/// What `encode_reals` wrote, checked as `set_reals` checks it: a state cannot bring in a
/// value that fmi2SetReal would refuse.
pub fn decode_reals<T: Table>(
    r: &mut Reader,
    check: impl Fn(&T) -> Option<String>,
) -> Result<T, String> {
    let mut values = T::start();
    for vr in T::settable_reals() {
        values.set_settable_real(vr, r.f()?);
    }
    for vr in T::settable_reals() {
        let name = T::variable(vr).expect("a table variable").name;
        let x = values.settable_real(vr).expect("a settable Real");
        if let Some(why) = value_violation::<T>(vr, name, x) {
            return Err(why);
        }
    }
    match check(&values) {
        Some(why) => Err(why),
        None => Ok(values),
    }
}

impl<L: Law> Slave for Algebraic<L> {
    const MODEL_NAME: &'static str = L::MODEL_NAME;
    const LOG_CATEGORIES: &'static [&'static str] = L::LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = L::STATE_MAGIC;
    const STATE_FORMAT_VERSION: u32 = 1;

    fn guid() -> &'static str {
        L::guid()
    }

    fn fresh() -> Self {
        Algebraic {
            law: L::start(),
            start_time: 0.0,
            time: 0.0,
        }
    }

    /// The tolerance is not used: the law is algebraic.
    fn setup_experiment(
        &mut self,
        _tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<(), Failure> {
        crate::check_experiment_times(start, stop)?;
        self.start_time = start;
        self.time = start;
        Ok(())
    }

    fn exit_initialization(&mut self) -> Result<(), Failure> {
        self.time = self.start_time;
        Ok(())
    }

    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure> {
        let v = lookup::<L>(vr, "Real")?;
        self.law
            .settable_real(vr)
            .or_else(|| self.law.output(vr))
            .ok_or_else(|| error(format!("{} has no value", v.name)))
    }

    /// All or none: the values are applied only if each is finite and in its range and the
    /// law accepts the new parameters and inputs together. Every parameter is tunable, and
    /// every value acts at once: the outputs are read from the latest values.
    fn set_real(
        &mut self,
        vrs: &[ValueReference],
        values: &[f64],
        _running: bool,
    ) -> Result<(), Failure> {
        self.law = set_reals(&self.law, vrs, values, L::check)?;
        Ok(())
    }

    /// Nothing to integrate: the step keeps the time.
    fn do_step(&mut self, current: f64, h: f64, _log: &Logger) -> Result<(), Failure> {
        self.time = current + h;
        Ok(())
    }

    fn time(&self) -> f64 {
        self.time
    }

    fn encode(&self, w: &mut Writer) {
        encode_reals(&self.law, w);
        w.f(self.start_time);
        w.f(self.time);
    }

    /// What `encode` wrote, checked as fmi2SetReal checks it.
    fn decode(r: &mut Reader) -> Result<Self, String> {
        let law = decode_reals(r, L::check)?;
        let (start_time, time) = (r.f()?, r.f()?);
        if !(start_time.is_finite() && time.is_finite() && time >= start_time) {
            return Err(format!(
                "start time {start_time} s and time {time} s: must be finite, in this order"
            ));
        }
        Ok(Algebraic {
            law,
            start_time,
            time,
        })
    }
}

/// Defines, in a model crate whose `variables` module is generated from its table (`Var`,
/// `VARIABLES`, `Params`, `Inputs`, `GUID`, `MODEL_NAME`, `LOG_CATEGORIES`), the struct `$name`
/// holding `params` and `inputs`, and its [`Table`].
// `crate::variables` on purpose: the model crate's generated table, not this crate's.
#[allow(clippy::crate_in_macro_def)]
#[macro_export]
macro_rules! values_table {
    ($name:ident) => {
        /// The parameters and inputs as the master set them.
        #[derive(Clone, Debug, PartialEq, Default)]
        pub struct $name {
            pub params: crate::variables::Params,
            pub inputs: crate::variables::Inputs,
        }

        impl $crate::algebraic::Table for $name {
            const MODEL_NAME: &'static str = crate::variables::MODEL_NAME;
            const LOG_CATEGORIES: &'static [&'static str] = crate::variables::LOG_CATEGORIES;

            fn guid() -> &'static str {
                crate::variables::GUID
            }

            fn start() -> Self {
                Self::default()
            }

            fn variable(vr: $crate::ValueReference) -> Option<$crate::algebraic::Variable> {
                use crate::variables::{Causality, Var};
                let info = Var::from_vr(vr)?.info();
                Some($crate::algebraic::Variable {
                    name: info.name,
                    ty: match info.ty {
                        crate::variables::VarType::Real => "Real",
                        crate::variables::VarType::Integer => "Integer",
                        crate::variables::VarType::Boolean => "Boolean",
                        crate::variables::VarType::String => "String",
                    },
                    settable: matches!(info.causality, Causality::Parameter | Causality::Input),
                })
            }

            fn settable_reals() -> Vec<$crate::ValueReference> {
                use crate::variables::{Causality, VarType, VARIABLES};
                VARIABLES
                    .iter()
                    .filter(|v| v.ty == VarType::Real)
                    .filter(|v| matches!(v.causality, Causality::Parameter | Causality::Input))
                    .map(|v| v.vr)
                    .collect()
            }

            fn range_violation(vr: $crate::ValueReference, x: f64) -> Option<String> {
                crate::variables::Var::from_vr(vr)?
                    .info()
                    .range
                    .violation(x)
            }

            fn settable_real(&self, vr: $crate::ValueReference) -> Option<f64> {
                let v = crate::variables::Var::from_vr(vr)?;
                self.params.get_real(v).or(self.inputs.get_real(v))
            }

            fn set_settable_real(&mut self, vr: $crate::ValueReference, x: f64) -> bool {
                match crate::variables::Var::from_vr(vr) {
                    Some(v) => self.params.set_real(v, x) || self.inputs.set_real(v, x),
                    None => false,
                }
            }
        }
    };
}

/// Defines, in a model crate with a generated `variables` module, the struct `$law` holding
/// `params` and `inputs` with its [`Table`] (see [`values_table!`](crate::values_table)), the
/// instance type `$fmu` = `Algebraic<$law>` and the exported fmi2* functions. The crate
/// implements [`Law`] for `$law`.
#[macro_export]
macro_rules! algebraic_fmu {
    ($law:ident, $fmu:ident) => {
        $crate::values_table!($law);

        pub type $fmu = $crate::algebraic::Algebraic<$law>;

        $crate::export_fmi2!($fmu);
    };
}
