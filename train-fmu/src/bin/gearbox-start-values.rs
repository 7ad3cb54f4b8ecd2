//! Prints SpurGearTrain's start values for a gearbox file (gearbox-file.md), after building
//! the train they describe: as a scene's `[start_values]` table, or as JSON for tools
//! (tools/scene_to_ssp.py). A refused file prints the refusal, in the file's names, and exits 1.
//!
//! Usage: `cargo run -q --release -p spur_gear_train --bin gearbox-start-values -- FILE [--json]`

use spur_gear_train::gearbox::{start_values, Start};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let json = args.iter().any(|a| a == "--json");
    let Some(file) = args.iter().find(|a| !a.starts_with("--")) else {
        eprintln!("usage: gearbox-start-values FILE [--json]");
        std::process::exit(2);
    };
    let values = gearbox::load(Path::new(file))
        .and_then(|g| start_values(&g).map_err(|e| gearbox::Refusal(format!("{file}: {e}"))));
    let values = match values {
        Ok(v) => v,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    // Reals in Rust's shortest round-trip form: TOML and JSON read them back exactly.
    let text = |x: &Start| match x {
        Start::Real(x) if x.fract() == 0.0 && x.abs() < 1e15 => format!("{x:.1}"),
        Start::Real(x) => format!("{x:?}"),
        Start::Integer(i) => i.to_string(),
        Start::Boolean(b) => b.to_string(),
        Start::String(s) => format!("{s:?}"),
    };
    if json {
        let items: Vec<String> = values
            .iter()
            .map(|(n, x)| format!("  {n:?}: {}", text(x)))
            .collect();
        println!("{{\n{}\n}}", items.join(",\n"));
    } else {
        println!("[start_values]");
        for (n, x) in &values {
            println!("{:<28} = {}", format!("{n:?}"), text(x));
        }
    }
}
