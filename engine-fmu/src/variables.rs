//! EngineTorque's variable table, generated from `engine-fmu/variables.toml` by build.rs with
//! SpurGearMesh's generator (modelDescription/src/lib.rs): `Var` with its value references, the
//! structs `Params`, `Inputs`, `Outputs`, the GUID and modelDescription.xml.
// Generated: a getter of a struct with one field of a type is a one-armed match, and a
// Default impl is written out for every struct alike.
#![allow(clippy::match_single_binding, clippy::derivable_impls)]
include!(concat!(env!("OUT_DIR"), "/variables.rs"));

pub const MODEL_NAME: &str = MODEL_IDENTIFIER;

/// The modelDescription.xml generated from the same table (the torque's dependency on the
/// crank angle written out by build.rs).
pub const MODEL_DESCRIPTION_XML: &str =
    include_str!(concat!(env!("OUT_DIR"), "/modelDescription.xml"));

/// modelDescription.xml (FMI 2.0 Co-Simulation), for the packaging step.
pub fn model_description_xml() -> String {
    MODEL_DESCRIPTION_XML.to_owned()
}
