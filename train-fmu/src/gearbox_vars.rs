//! The variables of a gearbox's own FMU (gearbox-file.md §2): every SpurGearTrain variable of
//! an element the file has, under the element's name (`stage1.sun.w`, `wheel_hss.dte`), each
//! gear's data once under the gear's name (`wheel.z`), and the structure (counts, ends,
//! carriers) left out: the file fixes it. Value references count from 1 in this order, which
//! the packaging's modelDescription.xml and the binary both take from here.

use crate::build::element;
use crate::variables::{Causality, Var, VARIABLES};
use gearbox::{Damping, Drive, Gear, Gearbox};

/// A gear's key in the file, and the pair parameter of its meshes it sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GearKey {
    Z,
    X,
    Module,
    PressureAngle,
    Width,
    Addendum,
    TipDiameter,
    Dedendum,
    RackTipRadius,
    E,
    Nu,
    Mount,
    BoreRadius,
    TipRelief,
    TipReliefLength,
    Ecc,
    EccPhase,
    PitchErrors,
}

use GearKey::*;

/// The keys that are a gear's own in every geometry (the standard geometry adds x, the
/// module and the pressure angle).
const GEAR_KEYS: [GearKey; 14] = [
    Z,
    Width,
    Addendum,
    Dedendum,
    RackTipRadius,
    E,
    Nu,
    Mount,
    BoreRadius,
    TipRelief,
    TipReliefLength,
    Ecc,
    EccPhase,
    PitchErrors,
];

/// The keys whose value may be left to the model (an FMU state saves them in this order).
pub const OPTIONAL_KEYS: [GearKey; 15] = [
    Module,
    PressureAngle,
    Width,
    Addendum,
    TipDiameter,
    Dedendum,
    RackTipRadius,
    E,
    Nu,
    Mount,
    BoreRadius,
    TipRelief,
    TipReliefLength,
    Ecc,
    EccPhase,
];

/// A gear key's value.
#[derive(Clone, Debug, PartialEq)]
pub enum GearValue {
    Integer(i64),
    /// None: the file leaves it to the model's default.
    Real(Option<f64>),
    List(Vec<f64>),
}

impl GearKey {
    /// The key as the file writes it.
    pub fn name(self) -> &'static str {
        match self {
            Z => "z",
            X => "x",
            Module => "module",
            PressureAngle => "pressure_angle",
            Width => "width",
            Addendum => "addendum",
            TipDiameter => "tip_diameter",
            Dedendum => "dedendum",
            RackTipRadius => "rack_tip_radius",
            E => "E",
            Nu => "nu",
            Mount => "mount",
            BoreRadius => "bore_radius",
            TipRelief => "tip_relief",
            TipReliefLength => "tip_relief_length",
            Ecc => "ecc",
            EccPhase => "ecc_phase",
            PitchErrors => "pitch_errors",
        }
    }

    /// Whether `f` is `mesh_field(side)`, without building it: `variables` asks this of
    /// every mesh field of the table at each instantiation.
    fn is_mesh_field(self, side: &str, f: &str) -> bool {
        match self {
            Z | X => f.strip_suffix(side) == Some(self.name()),
            Module | PressureAngle | Width | Addendum | Dedendum | RackTipRadius => {
                f == self.name()
            }
            TipDiameter => f == "addendum",
            _ => f.strip_suffix(side).and_then(|r| r.strip_suffix('_')) == Some(self.name()),
        }
    }

    /// The pair parameter it sets on a mesh where the gear is `side` ("A" or "B").
    pub fn mesh_field(self, side: &str) -> String {
        match self {
            Z | X => format!("{}{side}", self.name()),
            Module | PressureAngle | Width | Addendum | Dedendum | RackTipRadius => {
                self.name().to_owned()
            }
            TipDiameter => "addendum".into(),
            _ => format!("{}_{side}", self.name()),
        }
    }

    pub fn get(self, g: &Gear) -> GearValue {
        let d = &g.deviations;
        let real = |x: Option<f64>| GearValue::Real(x);
        match self {
            Z => GearValue::Integer(g.z),
            X => real(Some(g.x)),
            Module => real(g.module),
            PressureAngle => real(g.pressure_angle),
            Width => real(g.width),
            Addendum => real(g.addendum),
            TipDiameter => real(g.tip_diameter),
            Dedendum => real(g.dedendum),
            RackTipRadius => real(g.rack_tip_radius),
            E => real(g.e),
            Nu => real(g.nu),
            Mount => real(g.mount),
            BoreRadius => real(g.bore_radius),
            TipRelief => real(d.tip_relief),
            TipReliefLength => real(d.tip_relief_length),
            Ecc => real(d.ecc),
            EccPhase => real(d.ecc_phase),
            PitchErrors => GearValue::List(g.pitch_errors.clone()),
        }
    }

    /// Sets the key; a value of the wrong kind is a bug of the caller.
    pub fn set(self, g: &mut Gear, v: GearValue) {
        let d = &mut g.deviations;
        match (self, v) {
            (Z, GearValue::Integer(z)) => g.z = z,
            (X, GearValue::Real(x)) => g.x = x.unwrap_or(0.0),
            (PitchErrors, GearValue::List(l)) => g.pitch_errors = l,
            (k, GearValue::Real(x)) => {
                let slot = match k {
                    Module => &mut g.module,
                    PressureAngle => &mut g.pressure_angle,
                    Width => &mut g.width,
                    Addendum => &mut g.addendum,
                    TipDiameter => &mut g.tip_diameter,
                    Dedendum => &mut g.dedendum,
                    RackTipRadius => &mut g.rack_tip_radius,
                    E => &mut g.e,
                    Nu => &mut g.nu,
                    Mount => &mut g.mount,
                    BoreRadius => &mut g.bore_radius,
                    TipRelief => &mut d.tip_relief,
                    TipReliefLength => &mut d.tip_relief_length,
                    Ecc => &mut d.ecc,
                    EccPhase => &mut d.ecc_phase,
                    Z | X | PitchErrors => unreachable!("handled above"),
                };
                *slot = x;
            }
            (k, v) => panic!("gear key {} takes no {v:?}", k.name()),
        }
    }
}

/// What a gearbox variable reads and writes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// The train variable `GearboxVar::train`.
    Train,
    /// A key of gear `gear`: every mesh of the gear follows it.
    Gear { gear: usize, key: GearKey },
    /// A mesh's normal load, whichever flank carries it: `F_fwd + F_bwd` (one of them is 0
    /// wherever the backlash is open).
    Load { bwd: Var },
}

#[derive(Clone, Debug)]
pub struct GearboxVar {
    pub name: String,
    /// The train variable it stands for (a gear key: on the gear's first mesh; a load: F_fwd).
    pub train: Var,
    pub target: Target,
    /// The train's, except outputs beyond the gearbox's own, which are locals here
    /// (`fmpy simulate` records outputs by default).
    pub causality: Causality,
    pub description: Option<String>,
}

/// The outputs a gearbox FMU keeps as outputs (gearbox-file.md §2), by element.
const BODY_OUTPUTS: [&str; 5] = ["theta", "w", "tau_drive", "x", "y"];
const MESH_OUTPUTS: [&str; 5] = ["dte", "F_fwd", "F_bwd", "n_fwd", "n_bwd"];
const SHAFT_OUTPUTS: [&str; 1] = ["tau"];
const WHOLE_OUTPUTS: [&str; 2] = ["housing.tau", "energy_residual"];

/// What the file fixes: not variables of the gearbox FMU.
const STRUCTURE: [&str; 12] = [
    "n_bodies", "n_shafts", "n_meshes", "carrier", "drive", "a", "b", "A", "B", "geometry",
    "internal", "lateral",
];
/// A speed-driven body's own variables, and what it does not use.
const SPEED_ONLY: [&str; 2] = ["w_in", "tau_drive"];
const TORQUE_ONLY: [&str; 1] = ["w_start"];
/// A planet's own body parameters.
const PLANET_ONLY: [&str; 3] = ["orbit_angle", "pin_error_r", "pin_error_t"];
/// A lateral body's own variables (lateral.md §1, §6).
const LATERAL_ONLY: [&str; 12] = [
    "k_x", "k_y", "c_x", "c_y", "x_start", "y_start", "vx_start", "vy_start", "x", "y", "vx", "vy",
];

/// Whether body i's centre moves in the plane: it is lateral, or a planet of a lateral carrier.
fn moves(g: &Gearbox, i: usize) -> bool {
    let b = &g.bodies[i];
    b.lateral.lateral || b.orbit.is_some_and(|o| g.bodies[o.carrier].lateral.lateral)
}

/// The train's coordinates: a rotation per body, two translations per lateral body.
fn n_coordinates(g: &Gearbox) -> usize {
    g.bodies.len() + 2 * g.bodies.iter().filter(|b| b.lateral.lateral).count()
}

/// The coordinates that are speed-driven bodies' angles: the first ones, one per driven body
/// (the train chooses a driven body's angle as a coordinate before any other).
pub fn driven_coordinates(g: &Gearbox) -> usize {
    g.bodies.iter().filter(|b| b.drive == Drive::Speed).count()
}

/// Model Exchange's continuous states, as indices into the train's: `W_ext`, `W_loss`, then
/// each coordinate's value and rate, except a speed-driven coordinate's rate.
pub fn state_indices(g: &Gearbox) -> Vec<usize> {
    let driven_rate = |i: usize| i >= 2 && (i - 2) % 2 == 1 && (i - 2) / 2 < driven_coordinates(g);
    (0..2 + 2 * n_coordinates(g))
        .filter(|&i| !driven_rate(i))
        .collect()
}

/// The variables of the gearbox's FMU, in value-reference order (vr = index + 1).
pub fn variables(g: &Gearbox) -> Vec<GearboxVar> {
    let mut out = Vec::new();
    let train = |name: &str| Var::from_name(name).expect("a train variable");
    let own = |info: &crate::variables::VarInfo, keep: bool| match info.causality {
        Causality::Output if !keep => Causality::Local,
        c => c,
    };
    let paper = |m: usize| g.meshes[m].paper.is_some();
    // The train as a whole, then the coordinates of the bodies in use (Model Exchange's
    // states: W_ext, W_loss, then each coordinate's value and rate, as the binary orders
    // them), then the elements.
    let mut coordinates = Vec::new();
    let mut bodies = vec![Vec::new(); g.bodies.len()];
    let mut shafts = vec![Vec::new(); g.shafts.len()];
    let mut meshes = vec![Vec::new(); g.meshes.len()];
    for info in VARIABLES {
        let v = |name: String, keep: bool| GearboxVar {
            name,
            train: info.var,
            target: Target::Train,
            causality: own(info, keep),
            description: None,
        };
        match element(info.name) {
            None if STRUCTURE.contains(&info.name) => {}
            None => out.push(v(info.name.into(), WHOLE_OUTPUTS.contains(&info.name))),
            // A state's derivative (`der(coordinate[2].value)`) goes with its state. A speed
            // drive's rate is its input, not a state: its derivative is left out.
            _ if info.name.starts_with("der(coordinate[") => {
                let inner = &info.name[4..info.name.len() - 1];
                if matches!(element(inner), Some((_, k, f)) if k <= n_coordinates(g) && !(f == "rate" && k <= driven_coordinates(g)))
                {
                    coordinates.push(v(info.name.into(), false))
                }
            }
            Some(("coordinate", k, _)) if k <= n_coordinates(g) => {
                coordinates.push(v(info.name.into(), false))
            }
            Some(("body", i, f)) if i <= g.bodies.len() => {
                let b = &g.bodies[i - 1];
                let speed = b.drive == Drive::Speed;
                let skip = STRUCTURE.contains(&f)
                    || (SPEED_ONLY.contains(&f) && !speed)
                    || (TORQUE_ONLY.contains(&f) && speed)
                    || (PLANET_ONLY.contains(&f) && b.orbit.is_none())
                    || (LATERAL_ONLY.contains(&f) && !b.lateral.lateral)
                    || (f == "m" && b.orbit.is_none() && !b.lateral.lateral)
                    || (f == "angle_start" && i != 1);
                if !skip {
                    // A lateral body's x and y are its centre's displacement: NAME.x is an
                    // inline gear's profile shift.
                    let own = match f {
                        "x" | "y" => format!("d{f}"),
                        f => f.to_string(),
                    };
                    bodies[i - 1].push(v(format!("{}.{own}", b.name), BODY_OUTPUTS.contains(&f)));
                }
            }
            Some(("shaft", j, f)) if j <= g.shafts.len() && !STRUCTURE.contains(&f) => {
                let name = format!("{}.{f}", g.shafts[j - 1].name);
                shafts[j - 1].push(v(name, SHAFT_OUTPUTS.contains(&f)));
            }
            Some(("mesh", m, f)) if m <= g.meshes.len() => {
                let geometry = if paper(m - 1) { 1 } else { 2 };
                let still = |k: usize| g.body_of_gear(k).is_none_or(|i| !moves(g, i));
                let skip = STRUCTURE.contains(&f)
                    || is_gear_field(f)
                    || info.geometry.is_some_and(|x| x != geometry)
                    || (f == "delta_lat" && g.meshes[m - 1].gears.iter().all(|&k| still(k)));
                if !skip {
                    let name = format!("{}.{f}", g.meshes[m - 1].name);
                    let mut var = v(name, MESH_OUTPUTS.contains(&f));
                    if let (Some(Damping::Ratio(zeta)), "chi") = (g.meshes[m - 1].damping, f) {
                        var.causality = Causality::CalculatedParameter;
                        var.description = Some(format!(
                            "Hunt-Crossley damping coefficient, calculated from the file's damping_ratio = {zeta}: the mesh's own mode has that fraction of critical damping at its mean stiffness under the static load (gearbox-file.md section 3) [s/m]"
                        ));
                    }
                    meshes[m - 1].push(var);
                }
                if f == "F_bwd" {
                    meshes[m - 1].push(GearboxVar {
                        name: format!("{}.F", g.meshes[m - 1].name),
                        train: train(&format!("mesh[{m}].F_fwd")),
                        target: Target::Load { bwd: info.var },
                        causality: Causality::Output,
                        description: Some(
                            "normal load of the mesh, whichever flank carries it (F_fwd + F_bwd) [N]"
                                .into(),
                        ),
                    });
                }
            }
            _ => {}
        }
    }
    out.extend(coordinates);
    for (i, b) in bodies.into_iter().enumerate() {
        out.extend(b);
        for (k, gear) in g.gears.iter().enumerate() {
            if g.body_of_gear(k) == Some(i) {
                out.extend(gear_vars(g, k, gear));
            }
        }
    }
    // Gears in the housing (a fixed ring) after the bodies.
    for (k, gear) in g.gears.iter().enumerate() {
        if g.body_of_gear(k).is_none() {
            out.extend(gear_vars(g, k, gear));
        }
    }
    out.extend(shafts.into_iter().flatten());
    out.extend(meshes.into_iter().flatten());
    out
}

/// A mesh field that is a gear's (set through the gear's variables).
fn is_gear_field(f: &str) -> bool {
    let keys = GEAR_KEYS.iter().chain(&[X, Module, PressureAngle]);
    keys.into_iter()
        .any(|k| ["A", "B"].iter().any(|s| k.is_mesh_field(s, f)))
}

/// A gear's variables: its keys, on its first mesh.
fn gear_vars(g: &Gearbox, k: usize, gear: &Gear) -> Vec<GearboxVar> {
    let Some((m, side)) = g.meshes.iter().enumerate().find_map(|(m, mesh)| {
        mesh.gears
            .iter()
            .position(|&x| x == k)
            .map(|s| (m, ["A", "B"][s]))
    }) else {
        return Vec::new();
    };
    let paper = g
        .meshes
        .iter()
        .any(|mesh| mesh.gears.contains(&k) && mesh.paper.is_some());
    let standard: &[GearKey] = if paper {
        &[]
    } else {
        &[X, Module, PressureAngle]
    };
    GEAR_KEYS
        .iter()
        .chain(standard)
        .map(|&key| match key {
            Addendum if gear.tip_diameter.is_some() => TipDiameter,
            key => key,
        })
        .map(|key| GearboxVar {
            name: format!("{}.{}", gear.name, key.name()),
            train: Var::from_name(&format!("mesh[{}].{}", m + 1, key.mesh_field(side)))
                .expect("a gear key is a pair parameter"),
            target: Target::Gear { gear: k, key },
            causality: Causality::Parameter,
            description: (key == TipDiameter)
                .then(|| "tip diameter of the gear (sets the addendum of its meshes) [m]".into()),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_mesh_field_agrees_with_mesh_field_on_every_field_of_a_mesh() {
        let keys = GEAR_KEYS
            .iter()
            .chain(&[X, Module, PressureAngle, TipDiameter]);
        let fields: Vec<&str> = VARIABLES
            .iter()
            .filter_map(|i| element(i.name))
            .filter(|&(kind, m, _)| kind == "mesh" && m == 1)
            .map(|(_, _, f)| f)
            .collect();
        let mut matched = 0;
        for &k in keys {
            for side in ["A", "B"] {
                for f in &fields {
                    let expected = k.mesh_field(side) == *f;
                    assert_eq!(k.is_mesh_field(side, f), expected, "{k:?} {side} {f}");
                    matched += expected as usize;
                }
            }
        }
        // Every key names one pair parameter on either side.
        assert_eq!(matched, 2 * (GEAR_KEYS.len() + 4));
    }
}
