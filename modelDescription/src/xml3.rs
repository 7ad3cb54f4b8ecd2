//! The FMI 3.0 modelDescription.xml, whose ModelStructure refers to variables by value reference.

use crate::table::{as_declared, Table, Var};
use crate::xml_common::{elem, header_attrs, initial_unknown, units_categories_experiment};
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;

/// The FMI 3.0 type of a table type.
fn fmi3_type(ty: &str) -> &'static str {
    match ty {
        "Real" => "Float64",
        "Integer" => "Int32",
        "Boolean" => "Boolean",
        "String" => "String",
        t => panic!("unknown type {t}"),
    }
}

/// modelDescription.xml for FMI 3.0 (Co-Simulation, and Model Exchange if the table has it) from
/// the same table: the same variables and value references, plus what FMI 3.0 declares as
/// variables of its own, the independent variable `time` (value reference 0) and the event
/// indicators.
pub fn model_description_xml3(t: &Table, version: &str) -> String {
    let declared = as_declared(t);
    let t: &Table = &declared;
    let me = t.model.model_exchange.as_ref();
    let indicators: &[[String; 2]] = me.map_or(&[], |m| &m.event_indicators);
    let indicator_vr0 = me.map_or(0, |m| m.event_indicator_vr);
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    let mut put = |ev: Event| w.write_event(ev).expect("writing to a Vec cannot fail");
    put(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)));
    let header = header_attrs(t, version, "3.0", "instantiationToken");
    put(Event::Start(elem("fmiModelDescription", &header)));
    let common = [
        ("modelIdentifier", t.model.name.clone()),
        ("canGetAndSetFMUState", "true".into()),
        ("canSerializeFMUState", "true".into()),
    ];
    if me.is_some() {
        let mut attrs = common.to_vec();
        attrs.push(("needsCompletedIntegratorStep", "true".into()));
        // By central differences (fmi2-slave/src/directional.rs).
        attrs.push(("providesDirectionalDerivatives", "true".into()));
        put(Event::Empty(elem("ModelExchange", &attrs)));
    }
    let mut attrs = common.to_vec();
    attrs.extend([
        ("canHandleVariableCommunicationStepSize", "true".into()),
        ("hasEventMode", "false".into()),
        ("maxOutputDerivativeOrder", "0".into()),
    ]);
    put(Event::Empty(elem("CoSimulation", &attrs)));
    units_categories_experiment(t, &mut put);

    put(Event::Start(BytesStart::new("ModelVariables")));
    put(Event::Empty(elem(
        "Float64",
        &[
            ("name", "time".into()),
            ("valueReference", "0".into()),
            ("causality", "independent".into()),
            ("variability", "continuous".into()),
            ("unit", "s".into()),
            ("description", "Simulation time".into()),
        ],
    )));
    let vr_of = |name: &str| t.vars.iter().find(|v| v.name == name).expect("checked").vr;
    for v in &t.vars {
        let mut attrs = v.identity_attrs();
        attrs.extend(v.value_attrs());
        let start = v.start_text();
        if v.ty != "String" {
            if let Some(s) = &start {
                attrs.push(("start", s.clone()));
            }
        }
        if let Some(of) = &v.derivative_of {
            attrs.push(("derivative", vr_of(of).to_string()));
        }
        let ty = fmi3_type(&v.ty);
        match (v.ty.as_str(), start) {
            ("String", Some(s)) => {
                put(Event::Start(elem(ty, &attrs)));
                put(Event::Empty(elem("Start", &[("value", s)])));
                put(Event::End(BytesEnd::new(ty)));
            }
            _ => put(Event::Empty(elem(ty, &attrs))),
        }
    }
    for (k, [name, desc]) in indicators.iter().enumerate() {
        put(Event::Empty(elem(
            "Float64",
            &[
                ("name", name.clone()),
                ("valueReference", (indicator_vr0 + k as u32).to_string()),
                ("description", format!("Event indicator: {desc}")),
                ("causality", "local".into()),
                ("variability", "continuous".into()),
                ("initial", "calculated".into()),
            ],
        )));
    }
    put(Event::End(BytesEnd::new("ModelVariables")));

    put(Event::Start(BytesStart::new("ModelStructure")));
    let unknowns = |put: &mut dyn FnMut(Event), tag: &str, pred: &dyn Fn(&Var) -> bool| {
        for v in t.vars.iter().filter(|v| pred(v)) {
            put(Event::Empty(elem(
                tag,
                &[("valueReference", v.vr.to_string())],
            )));
        }
    };
    unknowns(&mut put, "Output", &|v| v.causality == "output");
    unknowns(&mut put, "ContinuousStateDerivative", &|v| {
        v.derivative_of.is_some()
    });
    unknowns(&mut put, "InitialUnknown", &|v| initial_unknown(t, v));
    for k in 0..indicators.len() {
        let vr = indicator_vr0 + k as u32;
        put(Event::Empty(elem(
            "EventIndicator",
            &[("valueReference", vr.to_string())],
        )));
    }
    put(Event::End(BytesEnd::new("ModelStructure")));
    put(Event::End(BytesEnd::new("fmiModelDescription")));
    let mut xml = String::from_utf8(w.into_inner()).expect("quick-xml writes UTF-8");
    xml.push('\n');
    xml
}
