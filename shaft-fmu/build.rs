//! Generates the Rust bindings of TorsionalShaft's variable table and its modelDescription.xml
//! into OUT_DIR, both from shaft-fmu/variables.toml, with SpurGearMesh's generator (whose
//! `output_dependencies = "inputs"` lists the four inputs as every output's dependencies).
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let version = std::env::var("CARGO_PKG_VERSION").unwrap();
    let text = std::fs::read_to_string("variables.toml").expect("shaft-fmu/variables.toml");
    let table = model_description::parse(&text);
    model_description::write_generated(&table, &version, &out);

    println!("cargo:rerun-if-changed=variables.toml");
    println!("cargo:rerun-if-changed=../modelDescription/src");
    println!("cargo:rerun-if-changed=build.rs");
}
