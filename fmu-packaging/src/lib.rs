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
    // With fmu-packaging in the same build, cargo resolves the dependencies' features as for
    // the packager that runs this (which links the model crates too): the two builds share
    // their artifacts instead of rebuilding the model in turn (each takes minutes).
    let status = Command::new(cargo)
        .args([
            "build",
            "--release",
            "--lib",
            "-p",
            package,
            "-p",
            "fmu-packaging",
        ])
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

/// Binaries are stored, the rest deflated. A master that unpacks the FMU for every run (FMPy's
/// `simulate_fmu`) then copies the binary instead of inflating it: 1.6 against 7.9 ms for
/// SpurGearMesh, 3.1 against 16.9 ms for SpurGearTrain's binary (`fmpy.extract`, median of 15;
/// docs/gearbox-file.md, "What it costs"), for an archive about three times larger.
fn write_zip(path: &Path, files: &[(&str, &[u8])]) {
    let file = std::fs::File::create(path).expect("creating the .fmu");
    let mut zip = zip::ZipWriter::new(file);
    for (name, data) in files {
        let binary = name.ends_with(".so") || name.ends_with(".dll");
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(if binary {
                zip::CompressionMethod::Stored
            } else {
                zip::CompressionMethod::Deflated
            })
            .unix_permissions(if binary { 0o755 } else { 0o644 });
        zip.start_file(*name, opts).expect("zip entry");
        zip.write_all(data).expect("zip data");
    }
    zip.finish().expect("finishing the zip");
}

/// Packages a model crate's FMU: its release binary (and the Windows DLL when
/// `FMU_WINDOWS_DIR` is set), its modelDescription.xml and `extra` files; returns the path.
pub fn package(package: &str, model: &str, xml: &str, extra: &[(&str, &[u8])]) -> PathBuf {
    let so = release_binary(package);
    let binary = format!("binaries/linux64/{model}.so");
    let dll = windows_binary(package);
    let win = format!("binaries/win64/{model}.dll");
    let mut files: Vec<(&str, &[u8])> =
        vec![("modelDescription.xml", xml.as_bytes()), (&binary, &so)];
    if let Some(dll) = &dll {
        files.push((&win, dll));
    }
    files.extend_from_slice(extra);
    write_fmu(model, &files)
}

/// Text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The head of a model's documentation/index.html, up to its `<body>`.
pub fn html_head(title: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 6px;font-size:90%}}th{{background:#eee}}code{{background:#f4f4f4}}</style></head><body>\n"
    )
}

/// A documentation table of every variable of a model's table (`variables.toml`): name,
/// value reference, causality, unit, start, valid values, description.
pub fn variables_table(table_toml: &str) -> String {
    let t = model_description::parse(table_toml);
    let mut h = String::from(
        "<table><tr><th>name</th><th>value reference</th><th>causality</th><th>unit</th><th>start</th><th>valid</th><th>description</th></tr>\n",
    );
    for v in &t.vars {
        let causality = match v.causality.as_str() {
            "parameter" => format!("parameter ({})", v.variability),
            c => c.to_string(),
        };
        let start = match &v.start {
            Some(toml::Value::Float(x)) => x.to_string(),
            Some(x) => x.to_string(),
            None if v.causality == "input" => "0".into(),
            None => String::new(),
        };
        let range = match (v.min, v.max) {
            _ if v.causality == "output" => String::new(),
            (None, None) => "any finite".into(),
            (min, max) => {
                let lo =
                    min.map(|m| format!("&{}; {m}", if v.exclusive_min { "gt" } else { "ge" }));
                let hi =
                    max.map(|m| format!("&{}; {m}", if v.exclusive_max { "lt" } else { "le" }));
                lo.into_iter().chain(hi).collect::<Vec<_>>().join(", ")
            }
        };
        h.push_str(&format!(
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            v.name,
            v.vr,
            causality,
            v.unit.as_deref().unwrap_or(""),
            start,
            range,
            esc(&v.description)
        ));
    }
    h.push_str("</table>\n");
    h
}
