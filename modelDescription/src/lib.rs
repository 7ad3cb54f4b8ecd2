//! The variable tables of the repository's FMUs (SpurGearMesh's `variables.toml` here, the
//! SpeedController's in controller-fmu/) and what is generated from a table:
//! `modelDescription.xml` and the Rust bindings (`Var`, value references, `Params`, `Inputs`,
//! `Outputs`, `Calculated`). Each crate's build.rs and the packaging step both call this, so the
//! XML inside an FMU and the value references compiled into its binary cannot disagree.
//!
//! The modules: `table` (the table's types, `parse`, `load`, `guid`, `states`), `xml2` and
//! `xml3` (modelDescription.xml for FMI 2.0 and 3.0, their shared parts in `xml_common`),
//! `bindings` (the Rust bindings) and `train` (SpurGearTrain's table, expanded into a `Table`).

mod bindings;
mod table;
mod xml2;
mod xml3;
mod xml_common;

pub mod train;

pub use bindings::rust_bindings;
pub use table::{guid, ident, load, parse, states, ModelExchange, ModelInfo, Table, Unit, Var};
pub use xml2::model_description_xml;
pub use xml3::model_description_xml3;

/// The table's source text, compiled in so every user sees the same table.
pub const TABLE_TOML: &str = include_str!("../variables.toml");

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
