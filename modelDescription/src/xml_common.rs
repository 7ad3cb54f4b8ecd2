//! What FMI 2.0's and 3.0's modelDescription.xml share: the header, the units, log categories
//! and default experiment, and which variables are initial unknowns.

use crate::table::{format_real, guid, Table, Var};
use quick_xml::events::{BytesEnd, BytesStart, Event};

pub(crate) fn elem<'a>(name: &'a str, attrs: &[(&str, String)]) -> BytesStart<'a> {
    let mut e = BytesStart::new(name);
    for (k, v) in attrs {
        e.push_attribute((*k, v.as_str()));
    }
    e
}

/// The attributes of fmiModelDescription that both versions have (the GUID is FMI 3.0's
/// instantiationToken).
pub(crate) fn header_attrs(
    t: &Table,
    version: &str,
    fmi_version: &str,
    guid_key: &'static str,
) -> Vec<(&'static str, String)> {
    vec![
        ("fmiVersion", fmi_version.into()),
        ("modelName", t.model.name.clone()),
        (guid_key, guid(t, version)),
        ("description", t.model.description.clone()),
        ("author", t.model.author.clone()),
        ("version", version.into()),
        (
            "generationTool",
            "SpurGearMesh modelDescription generator".into(),
        ),
        (
            "variableNamingConvention",
            t.model.naming.clone().unwrap_or_else(|| "flat".into()),
        ),
    ]
}

/// UnitDefinitions, LogCategories and DefaultExperiment: the same in FMI 2.0 and 3.0.
pub(crate) fn units_categories_experiment(t: &Table, put: &mut dyn FnMut(Event)) {
    put(Event::Start(BytesStart::new("UnitDefinitions")));
    for (name, u) in &t.units {
        put(Event::Start(elem("Unit", &[("name", name.clone())])));
        let mut base = Vec::new();
        for (k, e) in [("kg", u.kg), ("m", u.m), ("s", u.s), ("rad", u.rad)] {
            if e != 0 {
                base.push((k, e.to_string()));
            }
        }
        put(Event::Empty(elem("BaseUnit", &base)));
        for (d, factor) in &u.display {
            put(Event::Empty(elem(
                "DisplayUnit",
                &[("name", d.clone()), ("factor", format_real(*factor))],
            )));
        }
        put(Event::End(BytesEnd::new("Unit")));
    }
    put(Event::End(BytesEnd::new("UnitDefinitions")));

    put(Event::Start(BytesStart::new("LogCategories")));
    for [name, desc] in &t.model.log_categories {
        put(Event::Empty(elem(
            "Category",
            &[("name", name.clone()), ("description", desc.clone())],
        )));
    }
    put(Event::End(BytesEnd::new("LogCategories")));

    let mut experiment = vec![
        ("startTime", format_real(t.model.start_time)),
        ("stopTime", format_real(t.model.stop_time)),
    ];
    if let Some(tol) = t.model.tolerance {
        experiment.push(("tolerance", format_real(tol)));
    }
    experiment.push(("stepSize", format_real(t.model.step_size)));
    put(Event::Empty(elem("DefaultExperiment", &experiment)));
}

/// An initial unknown: an output, a calculated parameter, a state or a derivative (other
/// locals are not).
pub(crate) fn initial_unknown(t: &Table, v: &Var) -> bool {
    match v.causality.as_str() {
        "output" | "calculatedParameter" => true,
        "local" => {
            v.derivative_of.is_some()
                || t.vars
                    .iter()
                    .any(|d| d.derivative_of.as_deref() == Some(v.name.as_str()))
        }
        _ => false,
    }
}
