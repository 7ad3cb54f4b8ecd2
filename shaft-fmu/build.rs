//! Generates the Rust bindings of TorsionalShaft's variable table and its modelDescription.xml
//! into OUT_DIR, both from shaft-fmu/variables.toml, with SpurGearMesh's generator.
//!
//! The generator writes an output without a `dependencies` attribute, which FMI 2.0 reads as
//! "depends on all knowns". The shaft's outputs are a direct feedthrough of exactly its four
//! inputs, so this script names them: every `<Unknown>` under `<Outputs>` gets
//! `dependencies="<indices of the inputs>"`.
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let version = std::env::var("CARGO_PKG_VERSION").unwrap();
    let text = std::fs::read_to_string("variables.toml").expect("shaft-fmu/variables.toml");
    let table = model_description::parse(&text);
    model_description::write_generated(&table, &version, &out);

    let inputs: Vec<String> = table
        .vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == "input")
        .map(|(i, _)| (i + 1).to_string())
        .collect();
    let path = out.join("modelDescription.xml");
    let xml = std::fs::read_to_string(&path).expect("the generated modelDescription.xml");
    let (head, rest) = xml.split_once("<Outputs>").expect("an <Outputs> element");
    let (outputs, tail) = rest.split_once("</Outputs>").expect("</Outputs>");
    assert!(
        !outputs.contains("dependencies"),
        "the generator now writes dependencies"
    );
    let outputs = outputs.replace(
        "\"/>",
        &format!("\" dependencies=\"{}\"/>", inputs.join(" ")),
    );
    std::fs::write(&path, format!("{head}<Outputs>{outputs}</Outputs>{tail}")).expect("OUT_DIR");

    println!("cargo:rerun-if-changed=variables.toml");
    println!("cargo:rerun-if-changed=../modelDescription/src/lib.rs");
    println!("cargo:rerun-if-changed=build.rs");
}
