//! The modelDescription.xml compiled into the binary and the value references the FMI layer
//! uses come from one table; this test reads the XML back and checks every ScalarVariable
//! against the generated Rust table.

use quick_xml::events::Event;
use quick_xml::Reader;
use spur_gear_mesh::variables::{
    Causality, Var, VarType, Variability, GUID, MODEL_DESCRIPTION_XML, VARIABLES,
};

struct XmlVar {
    name: String,
    vr: u32,
    causality: String,
    variability: String,
    ty: String,
}

fn attr(e: &quick_xml::events::BytesStart, key: &str) -> Option<String> {
    e.attributes()
        .flatten()
        .find(|a| a.key.into_inner() == key)
        .map(|a| {
            a.normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .unwrap()
                .into_owned()
        })
}

fn xml_vars() -> (Vec<XmlVar>, String) {
    let mut r = Reader::from_str(MODEL_DESCRIPTION_XML);
    let (mut vars, mut guid, mut current) = (Vec::new(), String::new(), None::<XmlVar>);
    loop {
        match r.read_event().unwrap() {
            Event::Start(e) | Event::Empty(e) => match e.name().into_inner() {
                "fmiModelDescription" => guid = attr(&e, "guid").unwrap(),
                "ScalarVariable" => {
                    current = Some(XmlVar {
                        name: attr(&e, "name").unwrap(),
                        vr: attr(&e, "valueReference").unwrap().parse().unwrap(),
                        causality: attr(&e, "causality").unwrap(),
                        variability: attr(&e, "variability").unwrap(),
                        ty: String::new(),
                    })
                }
                t @ ("Real" | "Integer" | "Boolean" | "String") => {
                    let mut v = current
                        .take()
                        .expect("a type element inside a ScalarVariable");
                    v.ty = t.to_string();
                    vars.push(v);
                }
                _ => {}
            },
            Event::Eof => break,
            _ => {}
        }
    }
    (vars, guid)
}

#[test]
fn xml_and_value_references_agree() {
    let (vars, guid) = xml_vars();
    assert_eq!(guid, GUID);
    assert_eq!(vars.len(), VARIABLES.len());
    for x in &vars {
        let v = Var::from_vr(x.vr)
            .unwrap_or_else(|| panic!("vr {} of {} unknown to the binary", x.vr, x.name));
        let info = v.info();
        assert_eq!(info.name, x.name);
        let ty = match info.ty {
            VarType::Real => "Real",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
            VarType::Integer => "Integer",
        };
        assert_eq!(ty, x.ty, "{}", x.name);
        let causality = match info.causality {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
        };
        assert_eq!(causality, x.causality, "{}", x.name);
        let variability = match info.variability {
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Continuous => "continuous",
            Variability::Discrete => "discrete",
        };
        assert_eq!(variability, x.variability, "{}", x.name);
    }
}

/// The interface page's names are a contract: every one of them must exist with its causality.
#[test]
fn interface_names_exist() {
    let names = |c: Causality| -> Vec<&str> {
        VARIABLES
            .iter()
            .filter(|v| v.causality == c)
            .map(|v| v.name)
            .collect()
    };
    let params = names(Causality::Parameter);
    for p in [
        "geometry",
        "zA_nominal",
        "zB_nominal",
        "zA",
        "zB",
        "rA",
        "alpha_factor",
        "module",
        "pressure_angle",
        "xA",
        "xB",
        "addendum",
        "width",
        "E_A",
        "E_B",
        "nu_A",
        "nu_B",
        "J_A",
        "J_B",
        "backlash",
        "chi",
        "mu",
        "v_reg",
        "c_load",
        "contacts_per_flank",
        "backward_contacts",
        "w_A_start",
        "w_B_start",
        "dte_start",
        "solver",
        "rel_tol",
        // rig-and-modes.md
        "contact_model",
        "restitution",
        "slider_stiffness",
        "slider_damping",
        "slider_mass",
    ] {
        assert!(params.contains(&p), "parameter {p}");
    }
    assert_eq!(
        names(Causality::Input),
        ["tau_A", "tau_B", "alpha_housing", "a_housing_x"]
    );
    let outputs = names(Causality::Output);
    for o in [
        "theta_A",
        "theta_B",
        "w_A",
        "w_B",
        "dte",
        "F_f1",
        "F_f2",
        "F_b1",
        "F_b2",
        "F_fwd",
        "F_bwd",
        "n_fwd",
        "n_bwd",
        "tau_mesh_A",
        "tau_mesh_B",
        "P_loss",
        "x_slider",
        "F_B_x",
        "F_B_y",
    ] {
        assert!(outputs.contains(&o), "output {o}");
    }
    let calc = names(Causality::CalculatedParameter);
    for c in [
        "alpha_w",
        "rAb",
        "rBb",
        "line_of_action",
        "s_a",
        "s_b",
        "contact_ratio",
        "r_tipA",
        "r_tipB",
    ] {
        assert!(calc.contains(&c), "calculated parameter {c}");
    }
}

/// The parameters' ranges are the table's (issue 12, point 4): just outside a bound the
/// parameter set is refused with a message naming the parameter, on the bound itself it is
/// refused only when the bound is exclusive. Geometry parameters are checked with their own
/// geometry front end (`geometry` = their table entry's).
#[test]
fn parameter_ranges_come_from_the_table() {
    use spur_gear_mesh::table::validate;
    use spur_gear_mesh::variables::Params;
    let mut checked = 0;
    for info in VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Parameter)
    {
        let r = info.range;
        let base = Params {
            geometry: info.geometry.unwrap_or(1),
            ..Params::default()
        };
        for (bound, exclusive, outward) in [
            (r.min, r.exclusive_min, -1.0),
            (r.max, r.exclusive_max, 1.0),
        ] {
            let Some(b) = bound else { continue };
            // Outside: a unit past an integer bound, a relative step past a real one.
            let (outside, on) = match info.ty {
                VarType::Integer => (b + outward, b),
                _ => (b + outward * (1e-3 * b.abs()).max(1e-3), b),
            };
            for (x, must_fail) in [(outside, true), (on, exclusive)] {
                let mut p = base.clone();
                let set = match info.ty {
                    VarType::Integer => p.set_integer(info.var, x as i32),
                    _ => p.set_real(info.var, x),
                };
                assert!(set, "{}", info.name);
                match validate(&p) {
                    Err(e) => assert!(
                        must_fail && e.message.contains(info.name),
                        "{} = {x}: {}",
                        info.name,
                        e.message
                    ),
                    Ok(()) => assert!(!must_fail, "{} = {x} was accepted", info.name),
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 25, "{checked} bounds");
}

/// The event indicators of Model Exchange are the mesh's event functions, in their order.
#[test]
fn event_indicators_are_the_event_functions() {
    use spur_gear_mesh::model::contact::{EventFn, N_EVENTS};
    use spur_gear_mesh::variables::{EVENT_INDICATOR_NAMES, N_EVENT_INDICATORS};
    assert_eq!(N_EVENT_INDICATORS, N_EVENTS);
    for (i, name) in EVENT_INDICATOR_NAMES.iter().enumerate() {
        assert_eq!(
            *name,
            format!("z_{}", EventFn::from_index(i).name()),
            "indicator {i}"
        );
    }
}
