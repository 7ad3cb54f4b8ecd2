//! Generates the Rust bindings of SpeedController's variable table and its modelDescription.xml
//! into OUT_DIR, both from controller-fmu/variables.toml, with SpurGearMesh's generator.
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let version = std::env::var("CARGO_PKG_VERSION").unwrap();
    let text = std::fs::read_to_string("variables.toml").expect("controller-fmu/variables.toml");
    model_description::write_generated(&model_description::parse(&text), &version, &out);
    println!("cargo:rerun-if-changed=variables.toml");
    println!("cargo:rerun-if-changed=../modelDescription/src");
    println!("cargo:rerun-if-changed=build.rs");
}
