//! Generates the Rust bindings of the variable table and modelDescription.xml into OUT_DIR,
//! both from modelDescription/variables.toml (see modelDescription/src/lib.rs).
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let version = std::env::var("CARGO_PKG_VERSION").unwrap();
    model_description::write_generated(&model_description::load(), &version, &out);
    println!("cargo:rerun-if-changed=modelDescription/variables.toml");
    println!("cargo:rerun-if-changed=modelDescription/src/lib.rs");
    println!("cargo:rerun-if-changed=build.rs");
}
