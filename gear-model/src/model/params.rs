//! A parameter set checked on its own, before any geometry is built from it: finiteness,
//! the variable table's ranges, the slider and the pitch-error strings. Rigs call it first;
//! `Geometry::new` then checks how the numbers fit together.

use super::ModelError;
use crate::variables::{Causality, Params, VarType, VARIABLES};

/// Checks every parameter on its own; `Geometry::new` then checks how they fit together.
pub fn validate(p: &Params) -> Result<(), ModelError> {
    // Every Real parameter is finite, used by the chosen geometry or not: none may reach a master.
    for info in VARIABLES {
        if let Some(x) = p.get_real(info.var).filter(|x| !x.is_finite()) {
            return Err(ModelError::parameter(info.name, x, "must be finite"));
        }
    }
    // The ranges of the variable table (modelDescription/variables.toml); a geometry front
    // end's own parameters only when it is the one used.
    for info in VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Parameter)
        .filter(|v| v.geometry.is_none_or(|g| g == p.geometry))
    {
        // The value is formatted only for a message: on every fmi2SetReal of a parameter the
        // formatting of all of them was 60 % of this check (callgrind).
        let (x, int) = match (p.get_real(info.var), p.get_integer(info.var)) {
            (Some(x), _) => (x, None),
            (None, Some(i)) => (i as f64, Some(i)),
            _ => continue,
        };
        if let Some(why) = info.range.violation(x) {
            let shown = int.map_or_else(|| x.to_string(), |i| i.to_string());
            let what = if info.ty == VarType::Integer {
                format!("{why} ({})", info.description)
            } else {
                why
            };
            return Err(ModelError::parameter(info.name, shown, &what));
        }
    }
    crate::model::rig::Slider::from_params(p)?;
    // The tooth counts are checked at initialization: they may be set after the strings.
    for (name, text) in [
        ("pitch_errors_A", &p.pitch_errors_A),
        ("pitch_errors_B", &p.pitch_errors_B),
    ] {
        crate::model::deviations::parse_pitch_errors(name, text, None).map_err(ModelError::new)?;
    }
    Ok(())
}
