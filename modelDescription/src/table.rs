//! The variable table's types, reading and checking a table, and what follows from the table
//! alone (the GUID, the continuous states, the Rust names of the variables).

use crate::TABLE_TOML;
use serde::Deserialize;
use std::collections::BTreeMap;

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
    /// modelDescription.xml declares only the first this many states (all when absent): the
    /// binary computes the others' derivatives too (directional derivatives read them), but no
    /// master integrates them.
    #[serde(default)]
    pub declared_states: Option<usize>,
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
    pub(crate) fn identity_attrs(&self) -> Vec<(&'static str, String)> {
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
    pub(crate) fn value_attrs(&self) -> Vec<(&'static str, String)> {
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
    pub(crate) fn start_text(&self) -> Option<String> {
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
    pub(crate) fn start_rust(&self) -> String {
        let text = self
            .start_text()
            .unwrap_or_else(|| panic!("variable {} needs a start value", self.name));
        match self.ty.as_str() {
            "Real" if !text.contains(['.', 'e', 'E']) => format!("{text}.0"),
            "String" => format!("String::from({text:?})"),
            _ => text,
        }
    }

    pub(crate) fn rust_type(&self) -> &'static str {
        match self.ty.as_str() {
            "Real" => "f64",
            "Integer" => "i32",
            "Boolean" => "bool",
            "String" => "String",
            t => panic!("variable {}: unknown type {t}", self.name),
        }
    }
}

/// A variable name as a Rust identifier: `der(x)` becomes `der_x`, `mesh[2].zA` `mesh_2_zA`.
pub fn ident(name: &str) -> String {
    name.replace(['(', '['], "_")
        .replace([')', ']'], "")
        .replace('.', "_")
}

/// Shortest text that reads back to the same f64.
pub(crate) fn format_real(f: f64) -> String {
    let s = format!("{f:?}");
    s.strip_suffix(".0").map(str::to_owned).unwrap_or(s)
}

pub fn load() -> Table {
    parse(TABLE_TOML)
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

/// How many states modelDescription.xml declares (`ModelExchange::declared_states`).
pub fn n_declared_states(t: &Table) -> usize {
    let all = states(t).len();
    let me = t.model.model_exchange.as_ref();
    me.and_then(|m| m.declared_states)
        .map_or(all, |n| n.min(all))
}

/// The table as modelDescription.xml declares it: the derivatives of the states beyond the
/// declared ones are plain locals.
pub fn as_declared(t: &Table) -> std::borrow::Cow<'_, Table> {
    let n = n_declared_states(t);
    if n == states(t).len() {
        return std::borrow::Cow::Borrowed(t);
    }
    let mut d = t.clone();
    d.vars
        .iter_mut()
        .filter(|v| v.derivative_of.is_some())
        .skip(n)
        .for_each(|v| v.derivative_of = None);
    std::borrow::Cow::Owned(d)
}

/// A stable GUID: a 128-bit FNV-1a hash of the table and the crate version, so that a changed
/// table gives a new GUID and the same table always gives the same one.
pub fn guid(t: &Table, version: &str) -> String {
    fmi2_slave::guid_from_hash(t.text.bytes().chain(version.bytes()))
}
