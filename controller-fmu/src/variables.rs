//! The one variable table of SpeedController. The value references, the start values the
//! instance begins with, modelDescription.xml and the GUID are all derived from `VARS`.
//! A variable's value reference is its position in the table.

use std::fmt::Write as _;

pub const MODEL_NAME: &str = "SpeedController";
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The log categories: the debug categories logEvents and logSolver, then the four status
/// categories of fmi2_slave's logger.
pub const LOG_CATEGORIES: &[&str] = &[
    "logEvents",
    "logSolver",
    "logStatusWarning",
    "logStatusDiscard",
    "logStatusError",
    "logStatusFatal",
];
const LOG_CATEGORY_DESCRIPTIONS: [&str; 6] = [
    "The torque saturation is entered or left",
    "The PI update of every communication step",
    "Warnings",
    "Status queries that are not available (fmi2Discard)",
    "Errors: invalid arguments, parameters, calls in the wrong state",
    "Fatal errors",
];

/// Every variable, by name. `Id as usize` is the value reference.
#[allow(non_camel_case_types)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Id {
    w_A,
    w_ref,
    t_ramp,
    w_step,
    t_step,
    kp,
    ki,
    tau_max,
    tau,
    w_r,
    error,
    integral,
    saturated,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Type {
    Real,
    Boolean,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    Input,
    Output,
}

pub struct VarDef {
    pub id: Id,
    pub name: &'static str,
    pub ty: Type,
    pub causality: Causality,
    pub start: f64,
    /// The least admissible value (parameters): `Some((x, true))` for x <= value,
    /// `Some((x, false))` for x < value.
    pub lower: Option<(f64, bool)>,
    pub unit: Option<&'static str>,
    pub description: &'static str,
}

const fn var(
    id: Id,
    name: &'static str,
    causality: Causality,
    start: f64,
    lower: Option<(f64, bool)>,
    unit: Option<&'static str>,
    description: &'static str,
) -> VarDef {
    VarDef {
        id,
        name,
        ty: Type::Real,
        causality,
        start,
        lower,
        unit,
        description,
    }
}

use Causality::{Input, Output, Parameter};

pub const VARS: [VarDef; 13] = [
    var(Id::w_A, "w_A", Input, 0.0, None, Some("rad/s"),
        "Measured speed of the controlled wheel (connect SpurGearMesh.w_A)"),
    var(Id::w_ref, "w_ref", Parameter, 100.0, None, Some("rad/s"),
        "Speed set-point reached at the end of the ramp"),
    var(Id::t_ramp, "t_ramp", Parameter, 0.1, Some((0.0, true)), Some("s"),
        "The reference ramps linearly from 0 at the start time to w_ref in t_ramp (0: a step at the start)"),
    var(Id::w_step, "w_step", Parameter, 0.0, None, Some("rad/s"),
        "A step added to the reference at t_step"),
    var(Id::t_step, "t_step", Parameter, 0.0, None, Some("s"),
        "Time of the reference step w_step"),
    var(Id::kp, "kp", Parameter, 200.0, Some((0.0, true)), Some("N.m.s/rad"),
        "Proportional gain"),
    var(Id::ki, "ki", Parameter, 3000.0, Some((0.0, true)), Some("N.m/rad"),
        "Integral gain"),
    var(Id::tau_max, "tau_max", Parameter, 2000.0, Some((0.0, false)), Some("N.m"),
        "Saturation: |tau| <= tau_max; the integral is frozen while the output is saturated in the error's direction"),
    var(Id::tau, "tau", Output, 0.0, None, Some("N.m"),
        "Drive torque (connect to SpurGearMesh.tau_A): tau = sat(kp*error + integral), held over the next communication step"),
    var(Id::w_r, "w_r", Output, 0.0, None, Some("rad/s"),
        "Reference speed at the current communication point"),
    var(Id::error, "error", Output, 0.0, None, Some("rad/s"),
        "Error w_r - w_A sampled at the start of the last step (at initialization: at the start time)"),
    var(Id::integral, "integral", Output, 0.0, None, Some("N.m"),
        "Integral term: sum of ki*error*h over the steps"),
    VarDef {
        id: Id::saturated,
        name: "saturated",
        ty: Type::Boolean,
        causality: Output,
        start: 0.0,
        lower: None,
        unit: None,
        description: "The output is limited by tau_max",
    },
];

impl Id {
    pub fn def(self) -> &'static VarDef {
        &VARS[self as usize]
    }

    pub fn from_vr(vr: u32) -> Option<Id> {
        VARS.get(vr as usize).map(|v| v.id)
    }
}

/// Units: name and SI exponents (kg, m, s, rad).
const UNITS: [(&str, [i32; 4]); 6] = [
    ("rad/s", [0, 0, -1, 1]),
    ("s", [0, 0, 1, 0]),
    ("N.m", [1, 2, -2, 0]),
    ("N.m.s/rad", [1, 2, -1, -1]),
    ("N.m/rad", [1, 2, -2, -1]),
    ("1", [0, 0, 0, 0]),
];

/// The GUID: a 128-bit FNV-1a hash of the table's text and the version, so a changed table
/// gives a new GUID.
pub fn guid() -> String {
    let mut text = String::new();
    let mut feed = |s: &str| {
        text.push_str(s);
        text.push('\0');
    };
    feed(MODEL_NAME);
    feed(VERSION);
    for v in &VARS {
        feed(&format!(
            "{}|{:?}|{:?}|{}|{:?}|{:?}",
            v.name, v.ty, v.causality, v.start, v.lower, v.unit
        ));
    }
    fmi2_slave::guid_from_hash(text.into_bytes())
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A real as FMI text that reads back to the same f64.
fn real(x: f64) -> String {
    format!("{x:?}")
}

/// modelDescription.xml (FMI 2.0 Co-Simulation).
pub fn model_description_xml() -> String {
    let mut x = String::new();
    let w = &mut x;
    writeln!(w, r#"<?xml version="1.0" encoding="UTF-8"?>"#).unwrap();
    writeln!(
        w,
        r#"<fmiModelDescription fmiVersion="2.0" modelName="{MODEL_NAME}" guid="{}" description="Sampled PI speed controller with output saturation and conditional integration; the partner of SpurGearMesh in a speed loop" author="SpurGearMesh developers" version="{VERSION}" generationTool="speed_controller variables.rs" variableNamingConvention="flat" numberOfEventIndicators="0">"#,
        guid()
    )
    .unwrap();
    writeln!(
        w,
        r#"  <CoSimulation modelIdentifier="{MODEL_NAME}" needsExecutionTool="false" canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false" maxOutputDerivativeOrder="0" canRunAsynchronuously="false" canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="false"/>"#
    )
    .unwrap();
    writeln!(w, "  <UnitDefinitions>").unwrap();
    for (name, [kg, m, s, rad]) in UNITS {
        let mut base = String::new();
        for (k, e) in [("kg", kg), ("m", m), ("s", s), ("rad", rad)] {
            if e != 0 {
                write!(base, r#" {k}="{e}""#).unwrap();
            }
        }
        writeln!(
            w,
            r#"    <Unit name="{}"><BaseUnit{base}/></Unit>"#,
            esc(name)
        )
        .unwrap();
    }
    writeln!(w, "  </UnitDefinitions>").unwrap();
    writeln!(w, "  <LogCategories>").unwrap();
    for (c, d) in LOG_CATEGORIES.iter().zip(LOG_CATEGORY_DESCRIPTIONS) {
        writeln!(w, r#"    <Category name="{c}" description="{}"/>"#, esc(d)).unwrap();
    }
    writeln!(w, "  </LogCategories>").unwrap();
    writeln!(
        w,
        r#"  <DefaultExperiment startTime="0.0" stopTime="0.3" stepSize="0.0001"/>"#
    )
    .unwrap();
    writeln!(w, "  <ModelVariables>").unwrap();
    for (i, v) in VARS.iter().enumerate() {
        let (causality, variability, initial) = match v.causality {
            Causality::Parameter => ("parameter", "tunable", Some("exact")),
            Causality::Input => ("input", "continuous", None),
            // Outputs change only at communication points.
            Causality::Output => ("output", "discrete", Some("calculated")),
        };
        let variability = if v.ty == Type::Boolean {
            "discrete"
        } else {
            variability
        };
        write!(
            w,
            r#"    <ScalarVariable name="{}" valueReference="{i}" description="{}" causality="{causality}" variability="{variability}""#,
            v.name,
            esc(v.description)
        )
        .unwrap();
        if let Some(init) = initial {
            write!(w, r#" initial="{init}""#).unwrap();
        }
        w.push('>');
        let start = (v.causality != Causality::Output).then(|| match v.ty {
            Type::Real => real(v.start),
            Type::Boolean => (v.start != 0.0).to_string(),
        });
        let mut attrs = String::new();
        if let Some(s) = start {
            write!(attrs, r#" start="{s}""#).unwrap();
        }
        if let Some(u) = v.unit {
            write!(attrs, r#" unit="{}""#, esc(u)).unwrap();
        }
        if let Some((lo, _)) = v.lower {
            write!(attrs, r#" min="{}""#, real(lo)).unwrap();
        }
        match v.ty {
            Type::Real => write!(w, "<Real{attrs}/>").unwrap(),
            Type::Boolean => write!(w, "<Boolean{attrs}/>").unwrap(),
        }
        writeln!(w, "</ScalarVariable>").unwrap();
    }
    writeln!(w, "  </ModelVariables>").unwrap();
    // No output depends on the input at a communication point (the controller samples w_A at
    // the start of a step and changes its outputs only in fmi2DoStep): empty dependencies. In
    // initialization mode the outputs follow the input (no dependencies attribute: all knowns).
    let outputs: Vec<usize> = VARS
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i + 1)
        .collect();
    writeln!(w, "  <ModelStructure>\n    <Outputs>").unwrap();
    for i in &outputs {
        writeln!(w, r#"      <Unknown index="{i}" dependencies=""/>"#).unwrap();
    }
    writeln!(w, "    </Outputs>\n    <InitialUnknowns>").unwrap();
    for i in &outputs {
        writeln!(w, r#"      <Unknown index="{i}"/>"#).unwrap();
    }
    writeln!(w, "    </InitialUnknowns>\n  </ModelStructure>").unwrap();
    writeln!(w, "</fmiModelDescription>").unwrap();
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_reference_is_the_position() {
        for (i, v) in VARS.iter().enumerate() {
            assert_eq!(v.id as usize, i, "{}", v.name);
            assert_eq!(Id::from_vr(i as u32), Some(v.id));
        }
        assert_eq!(Id::from_vr(VARS.len() as u32), None);
    }

    #[test]
    fn names_unique_and_starts_admissible() {
        for (i, a) in VARS.iter().enumerate() {
            assert!(VARS[i + 1..].iter().all(|b| b.name != a.name), "{}", a.name);
            if let Some((lo, inclusive)) = a.lower {
                assert!(
                    if inclusive {
                        a.start >= lo
                    } else {
                        a.start > lo
                    },
                    "{}",
                    a.name
                );
            }
        }
    }

    #[test]
    fn xml_lists_every_variable_and_a_stable_guid() {
        let x = model_description_xml();
        for v in &VARS {
            assert!(x.contains(&format!("name=\"{}\"", v.name)));
        }
        assert_eq!(guid(), guid());
        assert!(x.contains(&guid()));
    }
}
