//! SpurGearTrain's table (`train.toml`) expanded into a flat `Table`: its own rows, each
//! element template once per index (`body[2].J`), and every mesh's rows taken from the single
//! mesh's table (`mesh[3].zA`), so the single mesh's parameters, outputs and units stay
//! written once. The generators of modelDescription.xml and of the Rust bindings then treat it
//! like any table.

use crate::{ModelInfo, Table, Unit, Var};
use serde::Deserialize;
use std::collections::BTreeMap;

/// The train's table as written (before expansion).
#[derive(Debug, Deserialize)]
struct TrainTable {
    model: ModelInfo,
    #[serde(default)]
    from_single: Vec<String>,
    units: BTreeMap<String, Unit>,
    #[serde(rename = "var")]
    vars: Vec<Var>,
    #[serde(rename = "element")]
    elements: Vec<Element>,
}

/// `count` copies of its rows, named `kind[i].name`.
#[derive(Debug, Deserialize)]
struct Element {
    kind: String,
    count: u32,
    vr_base: u32,
    vr_stride: u32,
    #[serde(default)]
    single_parameters_except: Option<Vec<String>>,
    #[serde(default)]
    single_outputs: Vec<String>,
    #[serde(default)]
    single_calculated: bool,
    #[serde(rename = "var")]
    vars: Vec<Var>,
}

pub const TRAIN_TOML: &str = include_str!("../train.toml");

/// The expanded train table; `single` is the single mesh's.
pub fn expand(text: &str, single: &Table) -> Table {
    let t: TrainTable = toml::from_str(text).expect("train.toml does not parse");
    let mut vars = Vec::new();
    for name in &t.from_single {
        let v = single
            .vars
            .iter()
            .find(|v| &v.name == name)
            .unwrap_or_else(|| panic!("from_single: {name} is not in the single mesh's table"));
        vars.push(copy(v, v.name.clone(), v.vr, v.description.clone()));
    }
    vars.extend(t.vars.iter().map(|v| Var {
        derivative_of: v.derivative_of.clone(),
        ..copy(v, v.name.clone(), v.vr, v.description.clone())
    }));
    for e in &t.elements {
        for i in 1..=e.count {
            let base = e.vr_base + i * e.vr_stride;
            let who = format!("{} {i}", capitalized(&e.kind));
            for v in &e.vars {
                let mut x = copy(
                    v,
                    element_name(&e.kind, i, &v.name),
                    base + v.vr,
                    format!("{who}: {}", v.description),
                );
                x.derivative_of = v
                    .derivative_of
                    .as_ref()
                    .map(|of| element_name(&e.kind, i, of));
                // A start value per index, or one for all.
                if let Some(toml::Value::Array(a)) = &v.start {
                    x.start = Some(a.get(i as usize - 1).cloned().unwrap_or_else(|| {
                        panic!(
                            "{}: {} start values for {} elements",
                            x.name,
                            a.len(),
                            e.count
                        )
                    }));
                }
                vars.push(x);
            }
            let from_single = single.vars.iter().filter(|v| match v.causality.as_str() {
                "parameter" => e
                    .single_parameters_except
                    .as_ref()
                    .is_some_and(|except| !except.contains(&v.name)),
                "output" => e.single_outputs.contains(&v.name),
                "calculatedParameter" => e.single_calculated,
                _ => false,
            });
            for v in from_single {
                assert!(
                    v.vr < e.vr_stride,
                    "{}: value reference {} does not fit the stride",
                    v.name,
                    v.vr
                );
                vars.push(copy(
                    v,
                    format!("{}[{i}].{}", e.kind, v.name),
                    base + v.vr,
                    format!("{who}: {}", v.description),
                ));
            }
        }
    }
    let mut units = single.units.clone();
    units.extend(t.units);
    let mut model = t.model;
    if let Some(me) = model.model_exchange.as_mut() {
        // Every mesh's event functions, as the single mesh names them.
        let single_me = single.model.model_exchange.as_ref();
        let indicators = single_me.map_or(&[][..], |s| &s.event_indicators[..]);
        let meshes = t
            .elements
            .iter()
            .find(|e| e.kind == "mesh")
            .map_or(0, |e| e.count);
        me.event_indicators = (1..=meshes)
            .flat_map(|m| {
                indicators.iter().map(move |[name, what]| {
                    [element_name("mesh", m, name), format!("Mesh {m}: {what}")]
                })
            })
            .collect();
    }
    let table = Table {
        text: format!("{text}\n{}", single.text),
        model,
        units,
        vars,
    };
    crate::table::check(&table);
    table
}

/// `kind[i].name`, and `der(kind[i].x)` for a template's `der(x)`.
fn element_name(kind: &str, i: u32, name: &str) -> String {
    match name.strip_prefix("der(").and_then(|n| n.strip_suffix(')')) {
        Some(of) => format!("der({kind}[{i}].{of})"),
        None => format!("{kind}[{i}].{name}"),
    }
}

fn capitalized(s: &str) -> String {
    let mut c = s.chars();
    c.next().map_or_else(String::new, |f| {
        f.to_ascii_uppercase().to_string() + c.as_str()
    })
}

fn copy(v: &Var, name: String, vr: u32, description: String) -> Var {
    Var {
        name,
        vr,
        ty: v.ty.clone(),
        causality: v.causality.clone(),
        variability: v.variability.clone(),
        start: v.start.clone(),
        unit: v.unit.clone(),
        display_unit: v.display_unit.clone(),
        min: v.min,
        max: v.max,
        exclusive_min: v.exclusive_min,
        exclusive_max: v.exclusive_max,
        geometry: v.geometry,
        derivative_of: None,
        description,
    }
}

/// The expanded table of SpurGearTrain.
pub fn load() -> Table {
    expand(TRAIN_TOML, &crate::load())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every element's rows exist once per index, the meshes' are the single mesh's, and the
    /// value references are unique (`check`).
    #[test]
    fn the_train_table_expands_from_its_templates_and_the_single_mesh() {
        let single = crate::load();
        let t = load();
        let has = |n: &str| t.vars.iter().any(|v| v.name == n);
        for n in [
            "n_bodies",
            "body[8].J",
            "body[1].angle_start",
            "shaft[7].twist_start",
            "mesh[6].zA",
            "mesh[1].dte",
            "mesh[2].contact_ratio",
            "mesh[3].mount_B",
            "solver",
            "E_kin",
        ] {
            assert!(has(n), "{n}");
        }
        for n in [
            "mesh[1].J_A",
            "mesh[1].slider_mass",
            "mesh[1].solver",
            "body[17].J",
            "mesh[1].theta_A",
        ] {
            assert!(!has(n), "{n}");
        }
        let per_mesh = t
            .vars
            .iter()
            .filter(|v| v.name.starts_with("mesh[1]."))
            .count();
        let single_params = single
            .vars
            .iter()
            .filter(|v| v.causality == "parameter")
            .count();
        assert!(per_mesh > single_params - 13, "{per_mesh}");
        let zb = t.vars.iter().find(|v| v.name == "mesh[4].zB").unwrap();
        assert_eq!(zb.vr, 100000 + 4 * 1000 + 5);
        let j2 = t.vars.iter().find(|v| v.name == "body[2].J").unwrap();
        assert_eq!(j2.start, Some(toml::Value::Float(2.0)));
        let xml = crate::model_description_xml(&t, "0");
        assert!(xml.contains("variableNamingConvention=\"structured\""));
        assert!(xml.contains("name=\"mesh[2].backlash\""));
    }
}
