//! What packaging an FMU of this repository takes, whichever the model: building its release
//! binary and zipping the .fmu into target/fmu/. The zip crate lives here only, never in an FMU
//! binary.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace's target directory (CARGO_TARGET_DIR if set).
pub fn target_dir() -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| root.join("target"))
}

/// Builds the cdylib of a workspace package in release mode and returns the binary; exits
/// the process if the build fails.
pub fn release_binary(package: &str) -> Vec<u8> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--release", "--lib", "-p", package])
        .current_dir(&root)
        .status()
        .expect("running cargo");
    if !status.success() {
        eprintln!("packaging: the release build of {package} failed");
        std::process::exit(1);
    }
    let so = target_dir().join(format!("release/lib{package}.so"));
    std::fs::read(&so).unwrap_or_else(|e| panic!("reading {}: {e}", so.display()))
}

/// Writes `target/fmu/<model>.fmu` with the given files (name in the archive, contents) and
/// returns its path. Binaries (.so) are executable.
pub fn write_fmu(model: &str, files: &[(&str, &[u8])]) -> PathBuf {
    let out_dir = target_dir().join("fmu");
    std::fs::create_dir_all(&out_dir).expect("creating target/fmu");
    let path = out_dir.join(format!("{model}.fmu"));
    write_zip(&path, files);
    path.canonicalize().unwrap_or(path)
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
