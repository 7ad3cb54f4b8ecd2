//! Gearbox files (`../shared/spec/gearbox-file.md`): an engineer's description of a gearbox by
//! its parts, in TOML, read into one plain-Rust [`Gearbox`]. Each gear is declared once, on
//! its body; meshes name two gears; `[[planetary]]` expands into a simple planetary set. Every
//! refusal names the file's elements and the line.
//!
//! ```
//! let g = gearbox::parse(r#"
//!     name = "Pair"
//!     [[body]]
//!     name = "pinion"
//!     J = 0.01
//!     gear = { z = 20, module = 0.003 }
//!     [[body]]
//!     name = "wheel"
//!     J = 0.5
//!     gear = { z = 40, module = 0.003 }
//!     [[mesh]]
//!     gears = ["pinion", "wheel"]
//! "#).unwrap();
//! assert_eq!(g.meshes[0].name, "pinion_wheel");
//! ```

mod description;
mod expand;
mod file;

pub use description::{
    Body, Damping, Deviations, Drive, Gear, Gearbox, Lateral, Lines, Mesh, Orbit, PaperGeometry,
    Ripple, Shaft, Solver, Support,
};
pub use expand::PRESSURE_ANGLE_DEFAULT;

use serde::Deserialize;
use std::path::Path;
use toml::Spanned;

/// Why a gearbox file was refused: a sentence naming the element, the key and the line.
#[derive(Clone, Debug, PartialEq)]
pub struct Refusal(pub String);

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Refusal {}

/// A gearbox from a file's text.
pub fn parse(text: &str) -> Result<Gearbox, Refusal> {
    let file: file::File = toml::from_str(text).map_err(|e| refusal_of(text, &e))?;
    expand::expand(text, &file)
}

/// A gearbox from a file; the refusal starts with the path.
pub fn load(path: &Path) -> Result<Gearbox, Refusal> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Refusal(format!("{}: cannot be read ({e})", path.display())))?;
    parse(&text).map_err(|r| Refusal(format!("{}: {r}", path.display())))
}

/// The file's element arrays, read without their keys' meaning: to name the element a parse
/// error stands in.
#[derive(Deserialize)]
struct Outline {
    #[serde(default)]
    planetary: Vec<Spanned<toml::Table>>,
    #[serde(default)]
    gear: Vec<Spanned<toml::Table>>,
    #[serde(default)]
    body: Vec<Spanned<toml::Table>>,
    #[serde(default)]
    mesh: Vec<Spanned<toml::Table>>,
    #[serde(default)]
    shaft: Vec<Spanned<toml::Table>>,
}

/// A parse error as a refusal: "body hss: unknown field `Jx`, expected ... (line 31)".
fn refusal_of(text: &str, e: &toml::de::Error) -> Refusal {
    let message = e.message().trim_end();
    let Some(span) = e.span() else {
        return Refusal(message.to_owned());
    };
    let line = description::line_of(text, span.start);
    let element = toml::from_str::<Outline>(text).ok().and_then(|o| {
        [
            ("planetary", &o.planetary),
            ("gear", &o.gear),
            ("body", &o.body),
            ("mesh", &o.mesh),
            ("shaft", &o.shaft),
        ]
        .into_iter()
        .find_map(|(kind, entries)| {
            entries.iter().enumerate().find_map(|(k, t)| {
                description::extent(text, t.span())
                    .contains(&span.start)
                    .then(|| match t.get_ref().get("name").and_then(|n| n.as_str()) {
                        Some(name) => format!("{kind} {name}"),
                        None => format!("[[{kind}]] number {}", k + 1),
                    })
            })
        })
    });
    match element {
        Some(el) => Refusal(format!("{el}: {message} (line {line})")),
        None => Refusal(format!("{message} (line {line})")),
    }
}
