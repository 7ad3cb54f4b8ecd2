//! One gearbox as plain data: bodies, the gears on them, the meshes between gears and the
//! shafts between bodies, every element with its name. Values the file left out are `None`:
//! the model's own defaults apply to them (docs/gearbox-file.md lists them).

use std::collections::BTreeMap;

/// Where a gear sits or a shaft ends: the housing (body 0), or a body by index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    Housing,
    Body(usize),
}

/// How a body is driven (gearbox-file.md §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Drive {
    /// `tau` is an input torque.
    #[default]
    Torque,
    /// The speed is an input, `NAME.w_in`; the torque is an output.
    Speed,
}

/// A planet's place on its carrier (planetary.md §3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub carrier: usize,
    /// Polar angle about the carrier's axis in its frame \[rad\].
    pub angle: f64,
    pub pin_error_r: Option<f64>,
    pub pin_error_t: Option<f64>,
}

/// A body's bearing in the plane (lateral.md §1).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Lateral {
    pub lateral: bool,
    pub k_x: Option<f64>,
    pub k_y: Option<f64>,
    pub c_x: Option<f64>,
    pub c_y: Option<f64>,
    /// Start displacement \[m\] and velocity \[m/s\] (a static start solves for the first).
    pub x_start: Option<f64>,
    pub y_start: Option<f64>,
    pub vx_start: Option<f64>,
    pub vy_start: Option<f64>,
}

/// An angle-locked torque ripple on a body.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Ripple {
    pub tau_ripple: Option<f64>,
    pub ripple_order: Option<f64>,
    pub ripple_phase: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    pub name: String,
    /// Moment of inertia about its axis \[kg.m2\].
    pub j: f64,
    /// Mass \[kg\]: a planet's orbital mass, a lateral body's translational mass.
    pub m: Option<f64>,
    /// Viscous drag \[N.m.s/rad\].
    pub c: Option<f64>,
    /// External torque's start value \[N.m\], forward positive.
    pub tau: Option<f64>,
    /// Start speed \[rad/s\], forward positive; None: rigid rolling from the others.
    pub w_start: Option<f64>,
    /// Absolute start angle \[rad\]: the first body only.
    pub angle_start: Option<f64>,
    pub drive: Drive,
    pub orbit: Option<Orbit>,
    pub ripple: Ripple,
    pub lateral: Lateral,
}

/// Paper geometry for a mesh (gear-mesh-model.md §1): the paper's nominal tooth counts,
/// operating pitch radius and pressure-angle factor instead of standard gear data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperGeometry {
    pub z_a_nominal: i64,
    pub z_b_nominal: i64,
    pub r_a: f64,
    pub alpha_factor: f64,
}

/// A gear's tip relief and runout (tooth-structure.md).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Deviations {
    pub tip_relief: Option<f64>,
    pub tip_relief_length: Option<f64>,
    pub ecc: Option<f64>,
    pub ecc_phase: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Gear {
    pub name: String,
    pub support: Support,
    pub z: i64,
    /// Profile shift coefficient (planetary.md §1 for an internal gear).
    pub x: f64,
    pub internal: bool,
    /// Module \[m\] (None only in a paper-geometry mesh).
    pub module: Option<f64>,
    /// Reference pressure angle \[rad\].
    pub pressure_angle: Option<f64>,
    pub width: Option<f64>,
    /// Addendum coefficient; a tip diameter is turned into one.
    pub addendum: Option<f64>,
    /// Tip diameter \[m\], when the file gives one instead of the addendum.
    pub tip_diameter: Option<f64>,
    pub e: Option<f64>,
    pub nu: Option<f64>,
    /// Angle of tooth 0 from its body's reference \[rad\].
    pub mount: Option<f64>,
    pub dedendum: Option<f64>,
    pub rack_tip_radius: Option<f64>,
    pub bore_radius: Option<f64>,
    pub deviations: Deviations,
    /// Pitch deviations per tooth \[m\], tooth 0 first (empty: none).
    pub pitch_errors: Vec<f64>,
}

/// A mesh's contact damping: the Hunt–Crossley factor, or a fraction of critical.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damping {
    Chi(f64),
    Ratio(f64),
}

#[derive(Clone, Debug, PartialEq, Default)]
pub struct Mesh {
    pub name: String,
    /// Gear A and gear B, by index into `Gearbox::gears`.
    pub gears: [usize; 2],
    pub paper: Option<PaperGeometry>,
    pub backlash: Option<f64>,
    pub damping: Option<Damping>,
    pub mu: Option<f64>,
    pub v_reg: Option<f64>,
    pub contact_model: Option<i64>,
    pub contacts_per_flank: Option<i64>,
    pub backward_contacts: Option<bool>,
    pub center_angle: Option<f64>,
    pub center_distance_error: Option<f64>,
    pub tip_relief_shape: Option<i64>,
    /// Start deflection \[m\] (a running start without the static one).
    pub dte_start: Option<f64>,
    pub k_lumped: Option<f64>,
    pub c_lumped: Option<f64>,
    pub k_lumped_varies: Option<bool>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Shaft {
    pub name: String,
    pub ends: [Support; 2],
    pub k: f64,
    pub d: Option<f64>,
    pub twist_start: Option<f64>,
}

/// `[solver]`: the whole train's integrator settings.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Solver {
    pub solver: Option<i64>,
    pub rel_tol: Option<f64>,
    pub statistics: Option<bool>,
    pub stats_start: Option<f64>,
}

/// The whole gearbox. Bodies are in the file's order (the first plays `gear-train.md`'s body
/// 1), meshes and shafts too; a `[[planetary]]` adds its parts where it stands.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Gearbox {
    pub name: String,
    pub description: String,
    pub bodies: Vec<Body>,
    pub gears: Vec<Gear>,
    pub meshes: Vec<Mesh>,
    pub shafts: Vec<Shaft>,
    pub solver: Solver,
    /// Start in static balance (gearbox-file.md §3): true unless the file says otherwise.
    pub static_start: bool,
    /// Where each element and key stands in the file, for messages.
    pub lines: Lines,
}

/// Where the file's elements stand: the source and each element's byte range, so that a
/// message can give the line of the element or of one of its keys.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Lines {
    pub(crate) text: String,
    pub(crate) element: BTreeMap<String, std::ops::Range<usize>>,
}

impl Lines {
    /// The line (1-based) of `key` in element `name` of `kind` (body, gear, mesh, shaft,
    /// planetary), or of the element where the key is not written there (a default, a
    /// planetary set's shorthand).
    pub fn of(&self, kind: &str, name: &str, key: &str) -> Option<usize> {
        let span = self.element.get(&format!("{kind}:{name}"))?;
        let at = key_offset(&self.text[span.clone()], key).map_or(span.start, |k| span.start + k);
        Some(line_of(&self.text, at))
    }
}

/// The 1-based line of byte `at`.
pub(crate) fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// An element's text: toml gives an array-of-tables entry the span of its `[[header]]`
/// only, so such an entry reaches to the next header (or the end); an inline table is its span.
pub(crate) fn extent(text: &str, span: std::ops::Range<usize>) -> std::ops::Range<usize> {
    if !text[span.clone()].starts_with("[[") {
        return span;
    }
    let next = text[span.end..]
        .match_indices('\n')
        .map(|(k, _)| span.end + k + 1)
        .find(|&k| text[k..].trim_start_matches([' ', '\t']).starts_with('['));
    span.start..next.unwrap_or(text.len())
}

/// Where `key = ` is written in a table's text: at a line's start or after `{` or `,`.
fn key_offset(table: &str, key: &str) -> Option<usize> {
    if key.is_empty() {
        return None;
    }
    let mut from = 0;
    while let Some(k) = table[from..].find(key).map(|k| k + from) {
        let before = table[..k].trim_end_matches([' ', '\t']).chars().next_back();
        let after = table[k + key.len()..].trim_start_matches([' ', '\t']);
        if matches!(before, None | Some('\n' | '{' | ',')) && after.starts_with('=') {
            return Some(k);
        }
        from = k + key.len();
    }
    None
}

impl Gearbox {
    /// The body a gear turns with (None: the housing).
    pub fn body_of_gear(&self, g: usize) -> Option<usize> {
        match self.gears[g].support {
            Support::Housing => None,
            Support::Body(i) => Some(i),
        }
    }

    /// `what` with the line where `key` of element `name` stands: "gear pinion: z = 2 must
    /// be at least 3 (line 31)".
    pub fn at(&self, kind: &str, name: &str, key: &str, what: &str) -> String {
        match self.lines.of(kind, name, key) {
            Some(l) => format!("{kind} {name}: {what} (line {l})"),
            None => format!("{kind} {name}: {what}"),
        }
    }
}
