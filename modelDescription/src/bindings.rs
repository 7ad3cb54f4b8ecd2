//! The Rust bindings compiled into each FMU's binary (`variables.rs` in OUT_DIR).

use crate::table::{format_real, guid, n_declared_states, states, Table, Var};
use std::fmt::Write as _;

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
        "/// How many of them modelDescription.xml declares, the first: what a master integrates.\npub const N_DECLARED_STATES: usize = {};",
        n_declared_states(t)
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
