//! Generates the Rust bindings of EngineTorque's variable table and its modelDescription.xml
//! into OUT_DIR, both from engine-fmu/variables.toml, with SpurGearMesh's generator (whose
//! `output_dependencies = "inputs"` lists the crank angle as the torque's dependency).
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let version = std::env::var("CARGO_PKG_VERSION").unwrap();
    let text = std::fs::read_to_string("variables.toml").expect("engine-fmu/variables.toml");
    let table = model_description::parse(&text);
    model_description::write_generated(&table, &version, &out);

    println!("cargo:rerun-if-changed=variables.toml");
    println!("cargo:rerun-if-changed=../modelDescription/src");
    println!("cargo:rerun-if-changed=build.rs");
}
