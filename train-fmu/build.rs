//! Generates SpurGearTrain's variable bindings and modelDescription.xml into OUT_DIR from
//! modelDescription/train.toml expanded with the single mesh's table (one source for both).
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let version = std::env::var("CARGO_PKG_VERSION").unwrap();
    model_description::write_generated(&model_description::train::load(), &version, &out);
    for f in [
        "../modelDescription/train.toml",
        "../modelDescription/variables.toml",
        "../modelDescription/src",
        "build.rs",
    ] {
        println!("cargo:rerun-if-changed={f}");
    }
}
