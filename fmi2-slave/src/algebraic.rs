//! A stateless FMU: outputs that are a function of the parameters and inputs set last (a direct
//! feedthrough), and a step that only advances the time. TorsionalShaft and EngineTorque are
//! such FMUs; this module is their `Slave`, written once.
//!
//! A model provides its variable table through [`Table`] (which [`algebraic_fmu!`](crate::algebraic_fmu) implements
//! from the crate's generated `variables` module) and its law through [`Law`].

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

/// The parameters and inputs of a stateless FMU and its variable table (generated: see
/// [`algebraic_fmu!`](crate::algebraic_fmu)).
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

fn lookup<L: Law>(vr: ValueReference, ty: &str) -> Result<Variable, Failure> {
    let v = L::variable(vr).ok_or_else(|| error(format!("unknown value reference {vr}")))?;
    if v.ty != ty {
        return Err(error(format!(
            "{} (value reference {vr}) is {}, not {ty}",
            v.name, v.ty
        )));
    }
    Ok(v)
}

/// A settable Real's own check: finite and within the table's range.
fn value_violation<L: Law>(vr: ValueReference, name: &str, x: f64) -> Option<String> {
    if !x.is_finite() {
        return Some(format!("{name} = {x}: must be finite"));
    }
    L::range_violation(vr, x).map(|why| format!("{name} = {x}: {why}"))
}

/// Why these values cannot be the model's: a value (named) or the law.
fn violation<L: Law>(law: &L) -> Option<String> {
    for vr in L::settable_reals() {
        let name = L::variable(vr).expect("a table variable").name;
        let x = law.settable_real(vr).expect("a settable Real");
        if let Some(why) = value_violation::<L>(vr, name, x) {
            return Some(why);
        }
    }
    law.check()
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
        let mut law = self.law.clone();
        for (&vr, &x) in vrs.iter().zip(values) {
            let v = lookup::<L>(vr, "Real")?;
            if !v.settable {
                return Err(error(format!("{} is an output: it cannot be set", v.name)));
            }
            if let Some(why) = value_violation::<L>(vr, v.name, x) {
                return Err(error(why));
            }
            law.set_settable_real(vr, x);
        }
        if let Some(why) = law.check() {
            return Err(error(why));
        }
        self.law = law;
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
        for vr in L::settable_reals() {
            w.f(self.law.settable_real(vr).expect("a settable Real"));
        }
        w.f(self.start_time);
        w.f(self.time);
    }

    /// What `encode` wrote, checked as fmi2SetReal checks it: a state cannot bring in a value
    /// that fmi2SetReal would refuse.
    fn decode(r: &mut Reader) -> Result<Self, String> {
        let mut law = L::start();
        for vr in L::settable_reals() {
            law.set_settable_real(vr, r.f()?);
        }
        let (start_time, time) = (r.f()?, r.f()?);
        if let Some(why) = violation(&law) {
            return Err(why);
        }
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
/// `VARIABLES`, `Params`, `Inputs`, `GUID`, `MODEL_NAME`, `LOG_CATEGORIES`), the struct `$law`
/// holding `params` and `inputs`, its [`Table`], the instance type `$fmu` =
/// `Algebraic<$law>` and the exported fmi2* functions. The crate implements [`Law`] for
/// `$law`.
// `crate::variables` on purpose: the model crate's generated table, not this crate's.
#[allow(clippy::crate_in_macro_def)]
#[macro_export]
macro_rules! algebraic_fmu {
    ($law:ident, $fmu:ident) => {
        /// The parameters and inputs (everything an instance holds besides its time).
        #[derive(Clone, Debug, PartialEq, Default)]
        pub struct $law {
            pub params: crate::variables::Params,
            pub inputs: crate::variables::Inputs,
        }

        pub type $fmu = $crate::algebraic::Algebraic<$law>;

        impl $crate::algebraic::Table for $law {
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

        $crate::export_fmi2!($fmu);
    };
}
