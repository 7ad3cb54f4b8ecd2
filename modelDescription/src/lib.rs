//! The variable tables of the repository's FMUs (SpurGearMesh's `variables.toml` here, the
//! SpeedController's in controller-fmu/) and what is generated from a table:
//! `modelDescription.xml` and the Rust bindings (`Var`, value references, `Params`, `Inputs`,
//! `Outputs`, `Calculated`). Each crate's build.rs and the packaging step both call this, so the
//! XML inside an FMU and the value references compiled into its binary cannot disagree.

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, BytesText, Event};
use quick_xml::Writer;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

pub mod train;

/// The table's source text, compiled in so every user sees the same table.
pub const TABLE_TOML: &str = include_str!("../variables.toml");

#[derive(Clone, Debug, Deserialize)]
pub struct Table {
    /// The source text (the GUID is its hash).
    #[serde(skip)]
    pub text: String,
    pub model: ModelInfo,
    pub units: BTreeMap<String, Unit>,
    #[serde(rename = "var")]
    pub vars: Vec<Var>,
}

#[derive(Clone, Debug, Deserialize)]
pub struct ModelInfo {
    pub name: String,
    pub description: String,
    pub author: String,
    pub start_time: f64,
    pub stop_time: f64,
    pub step_size: f64,
    /// The DefaultExperiment's tolerance, if any.
    #[serde(default)]
    pub tolerance: Option<f64>,
    pub log_categories: Vec<[String; 2]>,
    /// "none": no output depends on an input at a communication point (ModelStructure lists
    /// the outputs with empty dependencies); "inputs": every output depends on exactly the
    /// inputs (a direct feedthrough, e.g. a massless shaft); absent: the default, dependent on
    /// all knowns.
    #[serde(default)]
    pub output_dependencies: Option<String>,
    /// The variableNamingConvention ("flat" unless given: "structured" for `body[1].J`).
    #[serde(default)]
    pub naming: Option<String>,
    /// The model reads input derivatives (fmi2SetRealInputDerivatives) and interpolates.
    #[serde(default)]
    pub can_interpolate_inputs: bool,
    /// Params and Inputs derive serde's Serialize and Deserialize (the crate depends on serde).
    #[serde(default)]
    pub serde: bool,
    /// The FMU offers Model Exchange too: its continuous states are the variables that a
    /// `derivative_of` names, in the table's order of the derivatives, and it has this many
    /// event indicators.
    #[serde(default)]
    pub model_exchange: Option<ModelExchange>,
}

#[derive(Clone, Debug, Deserialize)]
pub struct ModelExchange {
    /// The value reference of the first event indicator (FMI 3.0 declares them as variables).
    pub event_indicator_vr: u32,
    /// Name and description of each event indicator, in order (a train's are generated).
    #[serde(default)]
    pub event_indicators: Vec<[String; 2]>,
}

#[derive(Clone, Debug, Deserialize)]
pub struct Unit {
    #[serde(default)]
    pub kg: i32,
    #[serde(default)]
    pub m: i32,
    #[serde(default)]
    pub s: i32,
    #[serde(default)]
    pub rad: i32,
    #[serde(default)]
    pub display: Vec<(String, f64)>,
}

#[derive(Clone, Debug, Deserialize)]
pub struct Var {
    pub name: String,
    pub vr: u32,
    #[serde(rename = "type")]
    pub ty: String,
    pub causality: String,
    pub variability: String,
    pub start: Option<toml::Value>,
    pub unit: Option<String>,
    pub display_unit: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// The value must differ from min / max too (FMI's bounds are inclusive; the XML shows them).
    #[serde(default)]
    pub exclusive_min: bool,
    #[serde(default)]
    pub exclusive_max: bool,
    /// A parameter of one geometry front end only: its range is checked when that one is used.
    pub geometry: Option<i32>,
    /// This variable is the time derivative of the named one, a continuous state (Model Exchange).
    pub derivative_of: Option<String>,
    pub description: String,
}

impl Var {
    /// The name as a Rust identifier: `der(x)` becomes `der_x`.
    pub fn ident(&self) -> String {
        ident(&self.name)
    }

    /// name, valueReference, description, causality, variability and initial: the same
    /// attributes in FMI 2.0 (on ScalarVariable) and 3.0.
    fn identity_attrs(&self) -> Vec<(&'static str, String)> {
        let mut attrs = vec![
            ("name", self.name.clone()),
            ("valueReference", self.vr.to_string()),
            ("description", self.description.clone()),
            ("causality", self.causality.clone()),
            ("variability", self.variability.clone()),
        ];
        match self.causality.as_str() {
            "parameter" => attrs.push(("initial", "exact".into())),
            "calculatedParameter" | "output" | "local" => {
                attrs.push(("initial", "calculated".into()))
            }
            _ => {}
        }
        attrs
    }

    /// unit, displayUnit, min and max, where the table gives them.
    fn value_attrs(&self) -> Vec<(&'static str, String)> {
        let mut attrs = Vec::new();
        if let Some(u) = &self.unit {
            attrs.push(("unit", u.clone()));
        }
        if let Some(d) = &self.display_unit {
            attrs.push(("displayUnit", d.clone()));
        }
        for (k, bound) in [("min", self.min), ("max", self.max)] {
            if let Some(b) = bound {
                let text = if self.ty == "Integer" {
                    (b as i64).to_string()
                } else {
                    format_real(b)
                };
                attrs.push((k, text));
            }
        }
        attrs
    }

    /// The start value as FMI text ("1e-6", "true", "20").
    fn start_text(&self) -> Option<String> {
        self.start.as_ref().map(|v| match v {
            toml::Value::Float(f) => format_real(*f),
            toml::Value::Integer(i) if self.ty == "Real" => format_real(*i as f64),
            toml::Value::Integer(i) => i.to_string(),
            toml::Value::Boolean(b) => b.to_string(),
            toml::Value::String(t) if self.ty == "String" => t.clone(),
            other => panic!("variable {}: unsupported start value {other}", self.name),
        })
    }

    /// The start value as Rust source for the field's type.
    fn start_rust(&self) -> String {
        let text = self
            .start_text()
            .unwrap_or_else(|| panic!("variable {} needs a start value", self.name));
        match self.ty.as_str() {
            "Real" if !text.contains(['.', 'e', 'E']) => format!("{text}.0"),
            "String" => format!("String::from({text:?})"),
            _ => text,
        }
    }

    fn rust_type(&self) -> &'static str {
        match self.ty.as_str() {
            "Real" => "f64",
            "Integer" => "i32",
            "Boolean" => "bool",
            "String" => "String",
            t => panic!("variable {}: unknown type {t}", self.name),
        }
    }
}

/// Why a value lies outside a variable's bounds, written into every crate's bindings.
const RANGE_VIOLATION: &str = r#"
impl Range {
    /// Why x lies outside the bounds ("must be > 0"), or None.
    pub fn violation(&self, x: f64) -> Option<String> {
        let below = self.min.is_some_and(|m| x < m || (self.exclusive_min && x == m));
        let above = self.max.is_some_and(|m| x > m || (self.exclusive_max && x == m));
        if !(below || above) {
            return None;
        }
        let (lo, hi) = (
            if self.exclusive_min { "(" } else { "[" },
            if self.exclusive_max { ")" } else { "]" },
        );
        Some(match (self.min, self.max) {
            (Some(a), Some(b)) => format!("must lie in {lo}{a}, {b}{hi}"),
            (Some(a), None) => format!("must be {} {a}", if self.exclusive_min { ">" } else { ">=" }),
            (None, Some(b)) => format!("must be {} {b}", if self.exclusive_max { "<" } else { "<=" }),
            (None, None) => unreachable!("a violation needs a bound"),
        })
    }
}
"#;

/// A variable name as a Rust identifier: `der(x)` becomes `der_x`, `mesh[2].zA` `mesh_2_zA`.
pub fn ident(name: &str) -> String {
    name.replace(['(', '['], "_")
        .replace([')', ']'], "")
        .replace('.', "_")
}

/// A description as rustdoc text: its units in brackets (\[m\]) are not links, and a `<` opens no
/// HTML tag.
fn doc_text(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if matches!(c, '[' | ']' | '<' | '>') {
            out.push('\\');
        }
        out.push(c);
    }
    out
}

/// Shortest text that reads back to the same f64.
fn format_real(f: f64) -> String {
    let s = format!("{f:?}");
    s.strip_suffix(".0").map(str::to_owned).unwrap_or(s)
}

pub fn load() -> Table {
    parse(TABLE_TOML)
}

/// What a build script writes into OUT_DIR: `variables.rs` (the bindings) and
/// `modelDescription.xml`, both from the same table.
pub fn write_generated(t: &Table, version: &str, out: &std::path::Path) {
    std::fs::write(out.join("variables.rs"), rust_bindings(t, version)).expect("OUT_DIR");
    std::fs::write(
        out.join("modelDescription.xml"),
        model_description_xml(t, version),
    )
    .expect("OUT_DIR");
}

/// A table from its TOML text (panics with the reason on a malformed one: build scripts call it).
pub fn parse(text: &str) -> Table {
    let mut table: Table = toml::from_str(text).expect("the variable table does not parse");
    table.text = text.to_owned();
    check(&table);
    table
}

/// Structural checks that a typo in the table would otherwise only show at run time.
pub(crate) fn check(t: &Table) {
    let mut seen_vr = std::collections::BTreeSet::new();
    let mut seen_name = std::collections::BTreeSet::new();
    for v in &t.vars {
        assert!(seen_vr.insert(v.vr), "value reference {} used twice", v.vr);
        assert!(
            seen_name.insert(&v.name),
            "variable {} declared twice",
            v.name
        );
        v.rust_type();
        let needs_start = matches!(v.causality.as_str(), "parameter" | "input");
        assert_eq!(
            needs_start,
            v.start.is_some(),
            "variable {}: start value",
            v.name
        );
        if let Some(u) = &v.unit {
            assert!(
                t.units.contains_key(u),
                "variable {}: unit {u} not in [units]",
                v.name
            );
        }
        assert!(
            (!v.exclusive_min || v.min.is_some()) && (!v.exclusive_max || v.max.is_some()),
            "variable {}: an exclusive bound needs the bound",
            v.name
        );
        if let Some(of) = &v.derivative_of {
            let state = t.vars.iter().find(|s| &s.name == of);
            assert!(
                state.is_some_and(|s| s.ty == "Real" && s.variability == "continuous"),
                "variable {}: derivative_of {of} must name a continuous Real variable",
                v.name
            );
            assert!(
                v.causality == "local" && v.ty == "Real",
                "variable {}: a derivative is a local Real",
                v.name
            );
        }
    }
    if let Some(me) = &t.model.model_exchange {
        let n = me.event_indicators.len() as u32;
        let block = me.event_indicator_vr..me.event_indicator_vr + n;
        assert!(
            t.vars.iter().all(|v| !block.contains(&v.vr) && v.vr != 0),
            "the event indicators' value references {block:?} and 0 (FMI 3.0's time) must be free"
        );
    }
    assert!(
        matches!(
            t.model.output_dependencies.as_deref(),
            None | Some("none" | "inputs")
        ),
        "output_dependencies must be \"none\", \"inputs\" or absent"
    );
    let derivatives = t.vars.iter().filter(|v| v.derivative_of.is_some()).count();
    assert_eq!(
        t.model.model_exchange.is_some(),
        derivatives > 0,
        "Model Exchange needs derivatives in the table, and derivatives need model_exchange"
    );
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

/// The continuous states with their derivatives, in the order of the state vector.
pub fn states(t: &Table) -> Vec<(&Var, &Var)> {
    t.vars
        .iter()
        .filter_map(|d| {
            let of = d.derivative_of.as_ref()?;
            Some((t.vars.iter().find(|s| &s.name == of)?, d))
        })
        .collect()
}

/// The index of the named variable (1-based).
fn index_of_name(t: &Table, name: &str) -> usize {
    t.vars.iter().position(|v| v.name == name).expect("checked") + 1
}

/// A stable GUID: a 128-bit FNV-1a hash of the table and the crate version, so that a changed
/// table gives a new GUID and the same table always gives the same one.
pub fn guid(t: &Table, version: &str) -> String {
    fmi2_slave::guid_from_hash(t.text.bytes().chain(version.bytes()))
}

fn elem<'a>(name: &'a str, attrs: &[(&str, String)]) -> BytesStart<'a> {
    let mut e = BytesStart::new(name);
    for (k, v) in attrs {
        e.push_attribute((*k, v.as_str()));
    }
    e
}

/// The attributes of fmiModelDescription that both versions have (the GUID is FMI 3.0's
/// instantiationToken).
fn header_attrs(
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
fn units_categories_experiment(t: &Table, put: &mut dyn FnMut(Event)) {
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

/// modelDescription.xml for FMI 2.0: Co-Simulation, and Model Exchange if the table has it.
pub fn model_description_xml(t: &Table, version: &str) -> String {
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
                ("providesDirectionalDerivative", "false".into()),
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

/// An initial unknown: an output, a calculated parameter, a state or a derivative (other
/// locals are not).
fn initial_unknown(t: &Table, v: &Var) -> bool {
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

/// Rust bindings: `Var` (one variant per variable, named as in the table), its metadata,
/// and one struct per causality group with typed getters and setters by `Var`.
pub fn rust_bindings(t: &Table, version: &str) -> String {
    let mut s = String::new();
    let w = &mut s;
    writeln!(
        w,
        "// Generated from modelDescription/variables.toml by build.rs. Do not edit."
    )
    .unwrap();
    writeln!(w, "pub const GUID: &str = {:?};", guid(t, version)).unwrap();
    writeln!(w, "pub const MODEL_IDENTIFIER: &str = {:?};", t.model.name).unwrap();
    let cats: Vec<&str> = t
        .model
        .log_categories
        .iter()
        .map(|c| c[0].as_str())
        .collect();
    writeln!(w, "pub const LOG_CATEGORIES: &[&str] = &{cats:?};").unwrap();
    let me = t.model.model_exchange.as_ref();
    writeln!(
        w,
        "/// Model Exchange's event indicators (0: Co-Simulation only).\npub const N_EVENT_INDICATORS: usize = {};",
        me.map_or(0, |m| m.event_indicators.len())
    )
    .unwrap();
    writeln!(
        w,
        "/// The value reference of the first event indicator (FMI 3.0).\npub const EVENT_INDICATOR_VR0: u32 = {};",
        me.map_or(0, |m| m.event_indicator_vr)
    )
    .unwrap();
    let names: Vec<&str> = me
        .map(|m| m.event_indicators.iter().map(|e| e[0].as_str()).collect())
        .unwrap_or_default();
    writeln!(
        w,
        "/// The event indicators' names (FMI 3.0 variables).\npub const EVENT_INDICATOR_NAMES: &[&str] = &{names:?};"
    )
    .unwrap();
    let pairs: Vec<String> = states(t)
        .iter()
        .map(|(x, d)| format!("(Var::{}, Var::{})", x.ident(), d.ident()))
        .collect();
    writeln!(
        w,
        "/// The continuous states and their derivatives, in the order of the state vector.\npub const STATES: &[(Var, Var)] = &[{}];",
        pairs.join(", ")
    )
    .unwrap();
    writeln!(
        w,
        "pub const DEFAULT_STOP_TIME: f64 = {};",
        format_real(t.model.stop_time)
    )
    .unwrap();

    writeln!(w, "#[allow(non_camel_case_types)]").unwrap();
    writeln!(
        w,
        "#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]\npub enum Var {{"
    )
    .unwrap();
    for v in &t.vars {
        writeln!(
            w,
            "    /// {}\n    {},",
            doc_text(&v.description),
            v.ident()
        )
        .unwrap();
    }
    writeln!(w, "}}").unwrap();

    writeln!(w, "#[derive(Clone, Copy, Debug, PartialEq, Eq)]\npub enum VarType {{ Real, Integer, Boolean, String }}").unwrap();
    writeln!(w, "#[derive(Clone, Copy, Debug, PartialEq, Eq)]\npub enum Causality {{ Parameter, CalculatedParameter, Input, Output, Local }}").unwrap();
    writeln!(w, "#[derive(Clone, Copy, Debug, PartialEq, Eq)]\npub enum Variability {{ Fixed, Tunable, Continuous, Discrete }}").unwrap();
    writeln!(w, "#[derive(Clone, Copy, Debug)]\npub struct VarInfo {{ pub var: Var, pub name: &'static str, pub vr: u32, pub ty: VarType, pub causality: Causality, pub variability: Variability, pub unit: Option<&'static str>, pub range: Range, pub geometry: Option<i32>, pub description: &'static str }}").unwrap();
    writeln!(w, "/// A variable's bounds from the table (None: unbounded), each inclusive unless marked.\n#[derive(Clone, Copy, Debug)]\npub struct Range {{ pub min: Option<f64>, pub max: Option<f64>, pub exclusive_min: bool, pub exclusive_max: bool }}").unwrap();
    w.push_str(RANGE_VIOLATION);

    let camel = |x: &str| -> String {
        let mut c = x.chars();
        match c.next() {
            Some(f) => f.to_ascii_uppercase().to_string() + c.as_str(),
            None => String::new(),
        }
    };
    writeln!(w, "pub const VARIABLES: &[VarInfo] = &[").unwrap();
    for v in &t.vars {
        let causality = match v.causality.as_str() {
            "calculatedParameter" => "CalculatedParameter".to_string(),
            c => camel(c),
        };
        writeln!(
            w,
            "    VarInfo {{ var: Var::{id}, name: {n:?}, vr: {vr}, ty: VarType::{ty}, causality: Causality::{c}, variability: Variability::{va}, unit: {u:?}, range: Range {{ min: {min}, max: {max}, exclusive_min: {emin}, exclusive_max: {emax} }}, geometry: {g:?}, description: {d:?} }},",
            id = v.ident(),
            n = v.name,
            vr = v.vr,
            ty = v.ty,
            c = causality,
            va = camel(&v.variability),
            u = v.unit.as_deref(),
            min = v.min.map_or("None".into(), |x| format!("Some({x:?})")),
            max = v.max.map_or("None".into(), |x| format!("Some({x:?})")),
            emin = v.exclusive_min,
            emax = v.exclusive_max,
            g = v.geometry,
            d = v.description,
        )
        .unwrap();
    }
    writeln!(w, "];").unwrap();

    writeln!(w, "impl Var {{").unwrap();
    writeln!(
        w,
        "    pub fn from_vr(vr: u32) -> Option<Var> {{\n        match vr {{"
    )
    .unwrap();
    for v in &t.vars {
        writeln!(w, "            {} => Some(Var::{}),", v.vr, v.ident()).unwrap();
    }
    writeln!(w, "            _ => None,\n        }}\n    }}").unwrap();
    writeln!(
        w,
        "    pub fn from_name(name: &str) -> Option<Var> {{\n        match name {{"
    )
    .unwrap();
    for v in &t.vars {
        writeln!(w, "            {:?} => Some(Var::{}),", v.name, v.ident()).unwrap();
    }
    writeln!(w, "            _ => None,\n        }}\n    }}").unwrap();
    writeln!(
        w,
        "    pub fn info(self) -> &'static VarInfo {{\n        match self {{"
    )
    .unwrap();
    for (i, v) in t.vars.iter().enumerate() {
        writeln!(w, "            Var::{} => &VARIABLES[{i}],", v.ident()).unwrap();
    }
    writeln!(w, "        }}\n    }}\n}}").unwrap();

    for (st, causality, doc) in [
        (
            "Params",
            "parameter",
            "Parameters, with the table's start values as defaults.",
        ),
        (
            "Inputs",
            "input",
            "Inputs, with the table's start values as defaults.",
        ),
        ("Outputs", "output", "Outputs, computed by the model."),
        (
            "Calculated",
            "calculatedParameter",
            "Calculated parameters, computed from the geometry.",
        ),
        (
            "Locals",
            "local",
            "Locals: the continuous states that are not outputs, and the state derivatives.",
        ),
    ] {
        let fields: Vec<&Var> = t.vars.iter().filter(|v| v.causality == causality).collect();
        let serde = if t.model.serde && matches!(causality, "parameter" | "input") {
            ", serde::Serialize, serde::Deserialize"
        } else {
            ""
        };
        writeln!(w, "/// {doc}\n#[allow(non_snake_case)]\n#[derive(Clone, Debug, PartialEq{serde})]\npub struct {st} {{").unwrap();
        for v in &fields {
            let unit = v
                .unit
                .as_deref()
                .map(|u| format!(" \\[{u}\\]"))
                .unwrap_or_default();
            writeln!(
                w,
                "    /// {}{unit}\n    pub {}: {},",
                doc_text(&v.description),
                v.ident(),
                v.rust_type()
            )
            .unwrap();
        }
        writeln!(w, "}}").unwrap();
        let has_start = matches!(causality, "parameter" | "input");
        writeln!(
            w,
            "impl Default for {st} {{\n    fn default() -> Self {{\n        Self {{"
        )
        .unwrap();
        for v in &fields {
            let value = if has_start {
                v.start_rust()
            } else {
                match v.ty.as_str() {
                    "Real" => "0.0".into(),
                    "Integer" => "0".into(),
                    "String" => "String::new()".into(),
                    _ => "false".into(),
                }
            };
            writeln!(w, "            {}: {value},", v.ident()).unwrap();
        }
        writeln!(w, "        }}\n    }}\n}}").unwrap();
        writeln!(w, "impl {st} {{").unwrap();
        for (ty, rty, get_ty) in [
            ("Real", "f64", "f64"),
            ("Integer", "i32", "i32"),
            ("Boolean", "bool", "bool"),
            ("String", "String", "&str"),
        ] {
            let lower = ty.to_ascii_lowercase();
            writeln!(w, "    #[allow(unreachable_patterns)]\n    #[inline]\n    pub fn get_{lower}(&self, v: Var) -> Option<{get_ty}> {{\n        match v {{").unwrap();
            for f in fields.iter().filter(|f| f.ty == ty) {
                let value = if ty == "String" {
                    format!("self.{}.as_str()", f.ident())
                } else {
                    format!("self.{}", f.ident())
                };
                writeln!(w, "            Var::{n} => Some({value}),", n = f.ident()).unwrap();
            }
            writeln!(w, "            _ => None,\n        }}\n    }}").unwrap();
            writeln!(w, "    #[allow(unreachable_patterns, unused_variables)]\n    pub fn set_{lower}(&mut self, v: Var, x: {rty}) -> bool {{\n        match v {{").unwrap();
            for f in fields.iter().filter(|f| f.ty == ty) {
                writeln!(
                    w,
                    "            Var::{n} => {{ self.{n} = x; true }}",
                    n = f.ident()
                )
                .unwrap();
            }
            writeln!(w, "            _ => false,\n        }}\n    }}").unwrap();
        }
        // Runs at every communication step. x - x is 0 for a finite x and NaN otherwise, so one
        // balanced sum clears all fields at once (no per-field branch, a short dependency
        // chain; it halved the check's instructions); the per-field scan names the culprit.
        let reals: Vec<String> = fields
            .iter()
            .filter(|f| f.ty == "Real")
            .map(|f| format!("(self.{n} - self.{n})", n = f.ident()))
            .collect();
        writeln!(w, "    /// The first Real field that is NaN or infinite, with its name.\n    #[allow(clippy::eq_op)]\n    pub fn first_non_finite(&self) -> Option<(&'static str, f64)> {{").unwrap();
        if !reals.is_empty() {
            writeln!(
                w,
                "        if {} == 0.0 {{ return None; }}",
                balanced_sum(&reals)
            )
            .unwrap();
        }
        for f in fields.iter().filter(|f| f.ty == "Real") {
            writeln!(
                w,
                "        if !self.{id}.is_finite() {{ return Some(({n:?}, self.{id})); }}",
                id = f.ident(),
                n = f.name
            )
            .unwrap();
        }
        writeln!(w, "        None\n    }}").unwrap();
        writeln!(w, "}}").unwrap();
    }
    s
}

/// `a + b + ...` as a balanced tree of parenthesized sums.
fn balanced_sum(terms: &[String]) -> String {
    match terms.len() {
        1 => terms[0].clone(),
        n => format!(
            "({} + {})",
            balanced_sum(&terms[..n / 2]),
            balanced_sum(&terms[n / 2..])
        ),
    }
}
