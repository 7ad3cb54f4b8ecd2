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

/// The Windows build of a workspace package's cdylib, `<package>.dll`, when the packager runs
/// with `FMU_WINDOWS_DIR` set to the directory that holds it: tools/windows.sh cross-builds the
/// DLLs into target/windows/x86_64-pc-windows-gnu/release and sets it right after that build,
/// so the DLL and the Linux binary come from the same sources. Without the variable the FMU
/// carries the Linux binary only (None). Exits the process if the variable is set but the DLL
/// is missing.
pub fn windows_binary(package: &str) -> Option<Vec<u8>> {
    let dir = PathBuf::from(std::env::var_os("FMU_WINDOWS_DIR")?);
    let dll = dir.join(format!("{package}.dll"));
    match std::fs::read(&dll) {
        Ok(bytes) => Some(bytes),
        Err(e) => {
            eprintln!(
                "packaging: FMU_WINDOWS_DIR is set but {} cannot be read ({e}); bash tools/windows.sh builds it",
                dll.display()
            );
            std::process::exit(1);
        }
    }
}

/// Writes `target/fmu/<model>.fmu` (or into `FMU_OUT_DIR` if set) with the given files (name in
/// the archive, contents) and returns its path. Binaries (.so, .dll) are executable. The file is
/// written beside and renamed into place, so a reader never sees half an archive.
pub fn write_fmu(model: &str, files: &[(&str, &[u8])]) -> PathBuf {
    let out_dir = std::env::var_os("FMU_OUT_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| target_dir().join("fmu"));
    std::fs::create_dir_all(&out_dir).expect("creating the FMU directory");
    let path = out_dir.join(format!("{model}.fmu"));
    let tmp = out_dir.join(format!(".{model}.fmu.{}", std::process::id()));
    write_zip(&tmp, files);
    std::fs::rename(&tmp, &path).expect("moving the .fmu into place");
    path.canonicalize().unwrap_or(path)
}

fn write_zip(path: &Path, files: &[(&str, &[u8])]) {
    let file = std::fs::File::create(path).expect("creating the .fmu");
    let mut zip = zip::ZipWriter::new(file);
    for (name, data) in files {
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .unix_permissions(if name.ends_with(".so") || name.ends_with(".dll") {
                0o755
            } else {
                0o644
            });
        zip.start_file(*name, opts).expect("zip entry");
        zip.write_all(data).expect("zip data");
    }
    zip.finish().expect("finishing the zip");
}
