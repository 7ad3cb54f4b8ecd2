//! TorsionalShaft's variable table, generated from `shaft-fmu/variables.toml` by build.rs with
//! SpurGearMesh's generator (modelDescription/src/lib.rs): `Var` with its value references, the
//! structs `Params`, `Inputs`, `Outputs`, the GUID and modelDescription.xml.
// Generated: a getter of a struct with one field of a type is a one-armed match, and a
// Default impl is written out for every struct alike.
#![allow(clippy::match_single_binding, clippy::derivable_impls)]
include!(concat!(env!("OUT_DIR"), "/variables.rs"));

pub const MODEL_NAME: &str = MODEL_IDENTIFIER;

/// The modelDescription.xml generated from the same table (the outputs' dependencies on the
/// four inputs written out by build.rs).
pub const MODEL_DESCRIPTION_XML: &str =
    include_str!(concat!(env!("OUT_DIR"), "/modelDescription.xml"));

/// modelDescription.xml (FMI 2.0 Co-Simulation), for the packaging step.
pub fn model_description_xml() -> String {
    MODEL_DESCRIPTION_XML.to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xml_lists_every_variable_with_its_value_reference_and_the_guid() {
        let x = model_description_xml();
        for v in VARIABLES {
            assert!(x.contains(&format!("name=\"{}\" valueReference=\"{}\"", v.name, v.vr)));
            assert_eq!(Var::from_vr(v.vr), Some(v.var));
        }
        assert!(x.contains(&format!("guid=\"{GUID}\"")));
    }

    #[test]
    fn both_outputs_depend_on_exactly_the_four_inputs() {
        let x = model_description_xml();
        let outputs = x.split("<Outputs>").nth(1).unwrap();
        let outputs = outputs.split("</Outputs>").next().unwrap();
        // theta_a, w_a, theta_b, w_b are the table's first four variables (indices 1-4), the
        // outputs its last two.
        for name in ["theta_a", "w_a", "theta_b", "w_b"] {
            let i = VARIABLES.iter().position(|v| v.name == name).unwrap() + 1;
            assert!(i <= 4, "{name}");
        }
        for i in [8, 9] {
            assert!(
                outputs.contains(&format!(
                    "<Unknown index=\"{i}\" dependencies=\"1 2 3 4\"/>"
                )),
                "{outputs}"
            );
        }
        assert_eq!(outputs.matches("<Unknown").count(), 2);
        // The initial unknowns keep the default (all knowns: inputs and parameters).
        let initial = x.split("<InitialUnknowns>").nth(1).unwrap();
        assert!(!initial
            .split("</InitialUnknowns>")
            .next()
            .unwrap()
            .contains("dependencies"));
    }

    #[test]
    fn start_values_are_admissible() {
        let (p, i) = (Params::default(), Inputs::default());
        for v in VARIABLES {
            if let Some(x) = p.get_real(v.var).or(i.get_real(v.var)) {
                assert_eq!(v.range.violation(x), None, "{}", v.name);
            }
        }
    }
}
