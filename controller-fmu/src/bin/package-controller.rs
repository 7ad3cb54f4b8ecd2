//! Builds target/fmu/SpeedController.fmu (in the repository root's target/): the release
//! binary and modelDescription.xml, both from this crate's variable table.
//!
//! Usage: `cargo run -q --release --manifest-path controller-fmu/Cargo.toml`; prints the path.

use speed_controller::variables::{model_description_xml, MODEL_NAME};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    let krate = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let root = krate.join("..");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--release", "--lib"])
        .current_dir(&krate)
        .status()
        .expect("running cargo");
    if !status.success() {
        eprintln!("package-controller: the release build failed");
        std::process::exit(1);
    }
    let target = std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| krate.join("target"));
    let so = std::fs::read(target.join("release/libspeed_controller.so"))
        .expect("reading the release binary");
    let out_dir = root.join("target/fmu");
    std::fs::create_dir_all(&out_dir).expect("creating target/fmu");
    let path = out_dir.join(format!("{MODEL_NAME}.fmu"));
    let binary = format!("binaries/linux64/{MODEL_NAME}.so");
    write_zip(
        &path,
        &[
            ("modelDescription.xml", model_description_xml().as_bytes()),
            (&binary, &so),
        ],
    );
    println!("{}", path.canonicalize().unwrap_or(path).display());
}

fn write_zip(path: &Path, files: &[(&str, &[u8])]) {
    let file = std::fs::File::create(path).expect("creating the .fmu");
    let mut zip = zip::ZipWriter::new(file);
    for (name, data) in files {
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .unix_permissions(if name.ends_with(".so") { 0o755 } else { 0o644 });
        zip.start_file(*name, opts).expect("zip entry");
        zip.write_all(data).expect("zip data");
    }
    zip.finish().expect("finishing the zip");
}
