//! The FMI 2.0 modelDescription.xml, whose ModelStructure refers to variables by index.

use crate::table::{as_declared, Table, Var};
use crate::xml_common::{elem, header_attrs, initial_unknown, units_categories_experiment};
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, BytesText, Event};
use quick_xml::Writer;

/// modelDescription.xml for FMI 2.0: Co-Simulation, and Model Exchange if the table has it.
pub fn model_description_xml(t: &Table, version: &str) -> String {
    let declared = as_declared(t);
    let t: &Table = &declared;
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    let mut put = |ev: Event| w.write_event(ev).expect("writing to a Vec cannot fail");
    put(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)));
    let mut header = header_attrs(t, version, "2.0", "guid");
    let indicators = t.model.model_exchange.as_ref();
    header.push((
        "numberOfEventIndicators",
        indicators
            .map_or(0, |m| m.event_indicators.len())
            .to_string(),
    ));
    put(Event::Start(elem("fmiModelDescription", &header)));
    if t.model.model_exchange.is_some() {
        put(Event::Empty(elem(
            "ModelExchange",
            &[
                ("modelIdentifier", t.model.name.clone()),
                ("needsExecutionTool", "false".into()),
                ("completedIntegratorStepNotNeeded", "false".into()),
                ("canBeInstantiatedOnlyOncePerProcess", "false".into()),
                ("canNotUseMemoryManagementFunctions", "true".into()),
                ("canGetAndSetFMUstate", "true".into()),
                ("canSerializeFMUstate", "true".into()),
                // By central differences (fmi2-slave/src/directional.rs).
                ("providesDirectionalDerivative", "true".into()),
            ],
        )));
    }
    put(Event::Empty(elem(
        "CoSimulation",
        &[
            ("modelIdentifier", t.model.name.clone()),
            ("needsExecutionTool", "false".into()),
            ("canHandleVariableCommunicationStepSize", "true".into()),
            (
                "canInterpolateInputs",
                t.model.can_interpolate_inputs.to_string(),
            ),
            ("maxOutputDerivativeOrder", "0".into()),
            ("canRunAsynchronuously", "false".into()),
            ("canBeInstantiatedOnlyOncePerProcess", "false".into()),
            ("canNotUseMemoryManagementFunctions", "true".into()),
            ("canGetAndSetFMUstate", "true".into()),
            ("canSerializeFMUstate", "true".into()),
            ("providesDirectionalDerivative", "false".into()),
        ],
    )));

    units_categories_experiment(t, &mut put);

    put(Event::Start(BytesStart::new("ModelVariables")));
    for (i, v) in t.vars.iter().enumerate() {
        put(Event::Comment(BytesText::new(&format!(
            " index {} ",
            i + 1
        ))));
        put(Event::Start(elem("ScalarVariable", &v.identity_attrs())));
        let mut tattrs = Vec::new();
        if let Some(s) = v.start_text() {
            tattrs.push(("start", s));
        }
        if let Some(of) = &v.derivative_of {
            tattrs.push(("derivative", index_of_name(t, of).to_string()));
        }
        tattrs.extend(v.value_attrs());
        put(Event::Empty(elem(&v.ty, &tattrs)));
        put(Event::End(BytesEnd::new("ScalarVariable")));
    }
    put(Event::End(BytesEnd::new("ModelVariables")));

    put(Event::Start(BytesStart::new("ModelStructure")));
    put(Event::Start(BytesStart::new("Outputs")));
    let dependencies = match t.model.output_dependencies.as_deref() {
        Some("none") => Some(String::new()),
        Some("inputs") => Some(
            indices(t, |v| v.causality == "input")
                .iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(" "),
        ),
        _ => None,
    };
    for i in indices(t, |v| v.causality == "output") {
        let mut attrs = vec![("index", i.to_string())];
        if let Some(d) = &dependencies {
            attrs.push(("dependencies", d.clone()));
        }
        put(Event::Empty(elem("Unknown", &attrs)));
    }
    put(Event::End(BytesEnd::new("Outputs")));
    let derivatives = indices(t, |v| v.derivative_of.is_some());
    if !derivatives.is_empty() {
        put(Event::Start(BytesStart::new("Derivatives")));
        for i in derivatives {
            put(Event::Empty(elem("Unknown", &[("index", i.to_string())])));
        }
        put(Event::End(BytesEnd::new("Derivatives")));
    }
    put(Event::Start(BytesStart::new("InitialUnknowns")));
    // Outputs, calculated parameters, and (Model Exchange) the states and their derivatives.
    let initial = |v: &Var| initial_unknown(t, v);
    for i in indices(t, initial) {
        put(Event::Empty(elem("Unknown", &[("index", i.to_string())])));
    }
    put(Event::End(BytesEnd::new("InitialUnknowns")));
    put(Event::End(BytesEnd::new("ModelStructure")));
    put(Event::End(BytesEnd::new("fmiModelDescription")));
    let mut xml = String::from_utf8(w.into_inner()).expect("quick-xml writes UTF-8");
    xml.push('\n');
    xml
}

/// Indices (1-based, the modelDescription's) of the variables that match.
fn indices(t: &Table, pred: impl Fn(&Var) -> bool) -> Vec<usize> {
    t.vars
        .iter()
        .enumerate()
        .filter(|(_, v)| pred(v))
        .map(|(i, _)| i + 1)
        .collect()
}

/// The index of the named variable (1-based).
fn index_of_name(t: &Table, name: &str) -> usize {
    t.vars.iter().position(|v| v.name == name).expect("checked") + 1
}
