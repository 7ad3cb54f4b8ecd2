//! SpurGearMesh's parameter table (`crate::variables`, generated from
//! `modelDescription/variables.toml`) read into the model's own description: `Pair` and the
//! paper rig's `RigSpec`. The table is checked here on its own first (finiteness, its ranges,
//! the slider, the pitch-error strings); `Geometry::new` then checks how the numbers fit
//! together. The model never reads the table; SpurGearTrain reads each mesh's pair through
//! this too.

use crate::model::pair::{Cut, Gear, Lumped, MeshLaw, Pair, PaperCut, Rack, ReliefShape};
use crate::model::paper_rig::{Loads, PaperRig, RigSpec, State};
use crate::model::rig::Slider;
use crate::model::ModelError;
use crate::variables::{Causality, Inputs, Params, VarType, VARIABLES};

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
    Slider::new(p.slider_stiffness, p.slider_damping, p.slider_mass)?;
    // The tooth counts are checked at initialization: they may be set after the strings.
    for (name, text) in [
        ("pitch_errors_A", &p.pitch_errors_A),
        ("pitch_errors_B", &p.pitch_errors_B),
    ] {
        parse_pitch_errors(name, text).map_err(ModelError::new)?;
    }
    Ok(())
}

/// Parses a pitch-deviation string: comma-separated finite numbers, or empty. Their count is
/// checked against the teeth when the pair is built (`Deviations::new`).
fn parse_pitch_errors(name: &str, text: &str) -> Result<Vec<f64>, String> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    let mut values = Vec::new();
    for (i, item) in text.split(',').enumerate() {
        let item = item.trim();
        let x: f64 = item.parse().map_err(|_| {
            format!(
                "parameter {name}: entry {} ('{item}') is not a number",
                i + 1
            )
        })?;
        if !x.is_finite() {
            return Err(format!(
                "parameter {name}: entry {} ('{item}') is not finite",
                i + 1
            ));
        }
        values.push(x);
    }
    Ok(values)
}

/// The pair the parameters describe (each checked by `validate`; the tooth counts of the pitch
/// errors when the pair is built).
pub fn pair(p: &Params) -> Result<Pair, ModelError> {
    let pitch = |name: &str, text: &str| parse_pitch_errors(name, text).map_err(ModelError::new);
    let a = Gear {
        z: p.zA,
        x: p.xA,
        e: p.E_A,
        nu: p.nu_A,
        bore_radius: p.bore_radius_A,
        tip_relief: p.tip_relief_A,
        tip_relief_length: p.tip_relief_length_A,
        ecc: p.ecc_A,
        ecc_phase: p.ecc_phase_A,
        pitch_errors: pitch("pitch_errors_A", &p.pitch_errors_A)?,
    };
    let b = Gear {
        z: p.zB,
        x: p.xB,
        e: p.E_B,
        nu: p.nu_B,
        bore_radius: p.bore_radius_B,
        tip_relief: p.tip_relief_B,
        tip_relief_length: p.tip_relief_length_B,
        ecc: p.ecc_B,
        ecc_phase: p.ecc_phase_B,
        pitch_errors: pitch("pitch_errors_B", &p.pitch_errors_B)?,
    };
    let cut = match p.geometry {
        1 => Cut::Paper(PaperCut {
            z_nominal: [p.zA_nominal, p.zB_nominal],
            r_a: p.rA,
            alpha_factor: p.alpha_factor,
        }),
        2 => Cut::Standard(Rack {
            module: p.module,
            pressure_angle: p.pressure_angle,
            addendum: p.addendum,
            dedendum: p.dedendum,
            tip_radius: p.rack_tip_radius,
        }),
        other => {
            return Err(ModelError::parameter(
                "geometry",
                other,
                "must be 1 (paper) or 2 (standard gear data)",
            ))
        }
    };
    let law = match p.contact_model {
        1 => MeshLaw::Johnson,
        2 => MeshLaw::Rigid,
        3 => MeshLaw::ToothStructure,
        4 => MeshLaw::Lumped(Lumped {
            k: p.k_lumped,
            c: p.c_lumped,
            varies: p.k_lumped_varies,
        }),
        other => {
            return Err(ModelError::parameter(
                "contact_model",
                other,
                "must be 1 (Johnson), 2 (rigid), 3 (tooth structure) or 4 (lumped)",
            ))
        }
    };
    let relief_shape = match p.tip_relief_shape {
        1 => ReliefShape::Linear,
        2 => ReliefShape::Parabolic,
        other => {
            return Err(ModelError::parameter(
                "tip_relief_shape",
                other,
                "must be 1 (linear) or 2 (parabolic)",
            ))
        }
    };
    let contacts_per_flank = usize::try_from(p.contacts_per_flank).map_err(|_| {
        ModelError::parameter(
            "contacts_per_flank",
            p.contacts_per_flank,
            "must be 0, 1 or 2",
        )
    })?;
    Ok(Pair {
        a,
        b,
        cut,
        width: p.width,
        backlash: p.backlash,
        internal: p.internal,
        center_distance_error: p.center_distance_error,
        law,
        restitution: p.restitution,
        chi: p.chi,
        mu: p.mu,
        v_reg: p.v_reg,
        relief_shape,
        contacts_per_flank,
        backward_contacts: p.backward_contacts,
    })
}

/// The paper rig the parameters describe, after `validate`.
pub fn rig(p: &Params) -> Result<RigSpec, ModelError> {
    validate(p)?;
    Ok(RigSpec {
        pair: pair(p)?,
        j_a: p.J_A,
        j_b: p.J_B,
        w_a_start: p.w_A_start,
        w_b_start: p.w_B_start,
        dte_start: p.dte_start,
        slider: Slider::new(p.slider_stiffness, p.slider_damping, p.slider_mass)?,
        stats_start: p.statistics.then_some(p.stats_start),
    })
}

/// The tunable parameters and the inputs, as the rig's loads.
pub fn loads(p: &Params, i: &Inputs) -> Loads {
    Loads {
        tau_a: i.tau_A,
        tau_b: i.tau_B,
        c_load: p.c_load,
        chi: p.chi,
        mu: p.mu,
        v_reg: p.v_reg,
        alpha_housing: i.alpha_housing,
        a_housing_x: i.a_housing_x,
    }
}

/// The rig under its driver from t0, with the parameters' integrator.
pub fn simulation(
    p: &Params,
    i: &Inputs,
    t0: f64,
    rel_tol: f64,
) -> Result<crate::driver::simulation::Simulation, ModelError> {
    crate::driver::simulation::Simulation::new(&rig(p)?, loads(p, i), p.solver, t0, rel_tol)
}

/// The paper rig and its initial state from the parameters and inputs.
pub fn paper_rig(p: &Params, i: &Inputs) -> Result<(PaperRig, State), ModelError> {
    PaperRig::new(&rig(p)?, loads(p, i))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Geometry;

    /// The table's defaults are the paper's pair, and its standard geometry the same pair cut
    /// by an ISO 53 rack: the model's tests build these pairs directly.
    #[test]
    fn pitch_strings_are_parsed_with_their_positions_named() {
        assert_eq!(parse_pitch_errors("x", " "), Ok(vec![]));
        assert_eq!(
            parse_pitch_errors("x", "1e-6, -2e-6 ,0"),
            Ok(vec![1e-6, -2e-6, 0.0])
        );
        let e = parse_pitch_errors("pitch_errors_A", "1e-6, abc, 0").unwrap_err();
        assert!(e.contains("pitch_errors_A") && e.contains("entry 2") && e.contains("abc"));
        let e = parse_pitch_errors("pitch_errors_B", "1e-6,inf").unwrap_err();
        assert!(e.contains("entry 2") && e.contains("not finite"));
        assert!(parse_pitch_errors("x", "1,,2")
            .unwrap_err()
            .contains("entry 2"));
    }

    #[test]
    fn the_defaults_are_the_papers_pair() {
        assert_eq!(pair(&Params::default()), Ok(Pair::paper()));
        assert_eq!(rig(&Params::default()), Ok(RigSpec::paper()));
        let p = Params::default();
        // The paper's drive: 100 N m on A.
        let drive = Loads {
            tau_a: 100.0,
            ..Loads::idle(&Pair::paper(), 2.0)
        };
        assert_eq!(loads(&p, &Inputs::default()), drive);
        let standard = Params {
            geometry: 2,
            ..Params::default()
        };
        assert_eq!(pair(&standard), Ok(Pair::standard()));
    }

    /// A rig checks the parameters on their own, then how they fit together (`Geometry`): both
    /// name the parameter.
    #[test]
    fn inconsistent_parameters_are_rejected_with_names() {
        let cases: Vec<(Params, &str)> = vec![
            (
                Params {
                    zA: 21,
                    ..Params::default()
                },
                "tooth ratio",
            ),
            (
                Params {
                    width: -1.0,
                    ..Params::default()
                },
                "width",
            ),
            (
                Params {
                    J_A: 0.0,
                    ..Params::default()
                },
                "J_A",
            ),
            (
                Params {
                    E_B: f64::NAN,
                    ..Params::default()
                },
                "E_B",
            ),
            (
                Params {
                    nu_A: 0.5,
                    ..Params::default()
                },
                "nu_A",
            ),
            (
                Params {
                    backlash: -1e-6,
                    ..Params::default()
                },
                "backlash",
            ),
            (
                Params {
                    rA: 0.0,
                    ..Params::default()
                },
                "rA",
            ),
            (
                Params {
                    zA: 44,
                    zB: 66,
                    ..Params::default()
                },
                "contact ratio",
            ),
            (
                Params {
                    zA: 18,
                    zB: 27,
                    ..Params::default()
                },
                "contact ratio",
            ),
            (
                Params {
                    contacts_per_flank: 1,
                    ..Params::default()
                },
                "contacts_per_flank",
            ),
            (
                Params {
                    geometry: 2,
                    addendum: 3.0,
                    ..Params::default()
                },
                "interference",
            ),
        ];
        // What a rig does: the parameters on their own, then how they fit together.
        for (p, word) in cases {
            let e = crate::table::validate(&p)
                .and_then(|_| Geometry::new(&pair(&p)?))
                .unwrap_err();
            assert!(e.message.contains(word), "{} should name {word}", e.message);
        }
    }
}
