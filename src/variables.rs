//! The variable table, generated from `modelDescription/variables.toml` by build.rs: `Var` with
//! its value references, and the structs `Params`, `Inputs`, `Outputs`, `Calculated`.
// Generated: ranges are literal values (pi/2 among them) and a getter of a struct with one
// field of a type is a one-armed match.
#![allow(clippy::approx_constant, clippy::match_single_binding)]
include!(concat!(env!("OUT_DIR"), "/variables.rs"));

/// The modelDescription.xml generated from the same table (the packaging step writes the same text).
pub const MODEL_DESCRIPTION_XML: &str =
    include_str!(concat!(env!("OUT_DIR"), "/modelDescription.xml"));
