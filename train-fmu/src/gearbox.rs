//! A gearbox file's description (the `gearbox` crate) as SpurGearTrain's start values: bodies
//! in the file's order, each mesh's pair parameters from its two gears, the start speeds of
//! rigid rolling where the file gives none. The train the values describe is built once here,
//! so a refusal comes now, in the file's names, and not from the FMU later in `mesh[4]`'s.

use crate::build;
use crate::variables::{Inputs, Params, Var};
use gear_model::model::geometry::Geometry;
use gear_model::model::train::damping::chi_for_ratio;
use gear_model::model::train::kinematics::{mesh_row, shaft_row, Row};
use gear_model::model::train::statics::static_start;
use gear_model::model::train::Train;
use gear_model::model::ModelError;
use gearbox::{Damping, Drive, Gear, Gearbox, Mesh, Support};
use nalgebra::{DMatrix, DVector};

/// One start value, typed as the train's table declares it.
#[derive(Clone, Debug, PartialEq)]
pub enum Start {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

/// Rigid rolling may leave a start speed this much (relative) off before the file's speeds
/// are taken to contradict each other: far above rounding, far below a typed wrong ratio.
const ROLLING_TOL: f64 = 1e-6;

/// SpurGearTrain's start values for the gearbox, every one of them checked by building the
/// train; a refusal names the file's elements.
pub fn start_values(g: &Gearbox) -> Result<Vec<(String, Start)>, String> {
    unsupported(g)?;
    let mut v = values(g)?;
    let (mut p, mut inputs) = params(&v).map_err(|e| in_file_names(g, &e))?;
    let speeds = start_speeds(g, &p, &inputs).map_err(|e| in_file_names(g, &e))?;
    for (i, w) in speeds.iter().enumerate() {
        // A speed-driven body's start speed is its input's start value.
        let (key, set) = match g.bodies[i].drive {
            Drive::Speed => (
                "w_in",
                inputs.set_real(build::var(&format!("body[{}].w_in", i + 1)), *w),
            ),
            Drive::Torque => (
                "w_start",
                p.set_real(build::var(&format!("body[{}].w_start", i + 1)), *w),
            ),
        };
        debug_assert!(set);
        v.push((format!("body[{}].{key}", i + 1), Start::Real(*w)));
    }
    let spec = build::spec(&p, &inputs).map_err(|e| in_file_names(g, &e))?;
    let loads = build::loads(&p, &inputs, &Default::default());
    Train::new(spec.clone(), loads.tau.clone(), None).map_err(|e| in_file_names(g, &e.message))?;
    let ratios: Vec<(usize, f64)> = (g.meshes.iter().enumerate())
        .filter_map(|(m, mesh)| match mesh.damping {
            Some(Damping::Ratio(zeta)) => Some((m, zeta)),
            _ => None,
        })
        .collect();
    if p.static_start || !ratios.is_empty() {
        let balanced = static_start(spec, &loads).map_err(|e| in_file_names(g, &e.message))?;
        // damping_ratio sets chi at the static load, whether or not the run starts there.
        if !ratios.is_empty() {
            let at = |e: ModelError| in_file_names(g, &format!("damping_ratio: {}", e.message));
            let (mut train, mut y) = Train::new(balanced, loads.tau.clone(), None).map_err(at)?;
            train.set_loads(loads, &mut y);
            for (m, zeta) in ratios {
                let chi = chi_for_ratio(&train, &y, m, zeta).map_err(at)?;
                v.push((format!("mesh[{}].chi", m + 1), Start::Real(chi)));
            }
        }
    }
    Ok(v)
}

/// A lateral body's keys (lateral.md §1) and their values in the file.
fn lateral_keys(l: &gearbox::Lateral) -> [(&'static str, Option<f64>); 8] {
    [
        ("k_x", l.k_x),
        ("k_y", l.k_y),
        ("c_x", l.c_x),
        ("c_y", l.c_y),
        ("x_start", l.x_start),
        ("y_start", l.y_start),
        ("vx_start", l.vx_start),
        ("vy_start", l.vy_start),
    ]
}

/// A lateral body's keys on a body that is not lateral: refused, not ignored.
fn unsupported(g: &Gearbox) -> Result<(), String> {
    for b in &g.bodies {
        let l = &b.lateral;
        let keys = lateral_keys(l);
        if let (false, Some((key, _))) = (l.lateral, keys.iter().find(|(_, x)| x.is_some())) {
            return Err(g.at(
                "body",
                &b.name,
                key,
                &format!("{key} is a lateral body's key (lateral.md section 1): set lateral = true, or leave it out"),
            ));
        }
    }
    Ok(())
}

/// Index of a support in the train's table: a body from 1, the housing 0.
fn index(s: Support) -> i32 {
    match s {
        Support::Housing => 0,
        Support::Body(i) => i as i32 + 1,
    }
}

/// Everything but the bodies' start speeds.
pub fn values(g: &Gearbox) -> Result<Vec<(String, Start)>, String> {
    let mut v: Vec<(String, Start)> = Vec::new();
    let mut put = |name: String, x: Start| v.push((name, x));
    let real = |x: f64| Start::Real(x);
    put("n_bodies".into(), Start::Integer(g.bodies.len() as i32));
    put("n_shafts".into(), Start::Integer(g.shafts.len() as i32));
    put("n_meshes".into(), Start::Integer(g.meshes.len() as i32));
    for (i, b) in g.bodies.iter().enumerate() {
        let at = |k: &str| format!("body[{}].{k}", i + 1);
        put(at("J"), real(b.j));
        if b.drive == Drive::Speed {
            put(at("drive"), Start::Integer(1));
        }
        // Written even when 0: the table's defaults differ from body to body.
        for (k, x) in [("m", b.m), ("c", b.c), ("tau", b.tau)] {
            put(at(k), real(x.unwrap_or(0.0)));
        }
        let optional = [
            ("tau_ripple", b.ripple.tau_ripple),
            ("ripple_order", b.ripple.ripple_order),
            ("ripple_phase", b.ripple.ripple_phase),
        ];
        for (k, x) in optional {
            if let Some(x) = x {
                put(at(k), real(x));
            }
        }
        if let Some(a) = b.angle_start {
            put("body[1].angle_start".into(), real(a));
        }
        let l = &b.lateral;
        if l.lateral {
            put(at("lateral"), Start::Boolean(true));
            for (k, x) in lateral_keys(l) {
                if let Some(x) = x {
                    put(at(k), real(x));
                }
            }
        }
        if let Some(o) = &b.orbit {
            put(at("carrier"), Start::Integer(o.carrier as i32 + 1));
            put(at("orbit_angle"), real(o.angle));
            for (k, x) in [
                ("pin_error_r", o.pin_error_r),
                ("pin_error_t", o.pin_error_t),
            ] {
                if let Some(x) = x {
                    put(at(k), real(x));
                }
            }
        }
    }
    for (j, s) in g.shafts.iter().enumerate() {
        let at = |k: &str| format!("shaft[{}].{k}", j + 1);
        put(at("a"), Start::Integer(index(s.ends[0])));
        put(at("b"), Start::Integer(index(s.ends[1])));
        put(at("k"), real(s.k));
        put(at("d"), real(s.d.unwrap_or(0.0)));
        put(at("twist_start"), real(s.twist_start.unwrap_or(0.0)));
    }
    for (m, mesh) in g.meshes.iter().enumerate() {
        mesh_values(g, m, mesh, &mut put)?;
    }
    if g.static_start {
        put("static_start".into(), Start::Boolean(true));
    }
    let s = &g.solver;
    if let Some(x) = s.solver {
        put("solver".into(), Start::Integer(x as i32));
    }
    if let Some(x) = s.rel_tol {
        put("rel_tol".into(), real(x));
    }
    if let Some(x) = s.statistics {
        put("statistics".into(), Start::Boolean(x));
    }
    if let Some(x) = s.stats_start {
        put("stats_start".into(), real(x));
    }
    Ok(v)
}

/// One value two gears must agree on, since the model keeps one per mesh.
fn shared(
    g: &Gearbox,
    mesh: &Mesh,
    key: &str,
    what: impl Fn(&Gear) -> Option<f64>,
) -> Result<Option<f64>, String> {
    let [a, b] = mesh.gears.map(|k| &g.gears[k]);
    match (what(a), what(b)) {
        (Some(x), Some(y)) if (x - y).abs() > 1e-12 * x.abs().max(y.abs()) => Err(g.at(
            "mesh",
            &mesh.name,
            "gears",
            &format!(
                "gears {} and {} have {key} {x} and {y}: SpurGearTrain takes one {key} per mesh",
                a.name, b.name
            ),
        )),
        (x, y) => Ok(x.or(y)),
    }
}

/// A gear's addendum coefficient, from its tip diameter where it gives one:
/// r_tip = m z / 2 + m (kappa h_a + x), kappa = -1 for an internal gear (planetary.md §1).
fn addendum(gear: &Gear) -> Option<f64> {
    match (gear.tip_diameter, gear.module) {
        (Some(d), Some(m)) => {
            let kappa = if gear.internal { -1.0 } else { 1.0 };
            Some(kappa * (d / (2.0 * m) - gear.z as f64 / 2.0 - gear.x))
        }
        _ => gear.addendum,
    }
}

fn mesh_values(
    g: &Gearbox,
    m: usize,
    mesh: &Mesh,
    put: &mut impl FnMut(String, Start),
) -> Result<(), String> {
    let at = |k: &str| format!("mesh[{}].{k}", m + 1);
    let [a, b] = mesh.gears.map(|k| &g.gears[k]);
    let real = |x: f64| Start::Real(x);
    let opt = |put: &mut dyn FnMut(String, Start), k: &str, x: Option<f64>| {
        if let Some(x) = x {
            put(at(k), real(x));
        }
    };
    put(at("A"), Start::Integer(index(a.support)));
    put(at("B"), Start::Integer(index(b.support)));
    put(at("zA"), Start::Integer(a.z as i32));
    put(at("zB"), Start::Integer(b.z as i32));
    match &mesh.paper {
        Some(pg) => {
            put(at("geometry"), Start::Integer(1));
            put(at("zA_nominal"), Start::Integer(pg.z_a_nominal as i32));
            put(at("zB_nominal"), Start::Integer(pg.z_b_nominal as i32));
            put(at("rA"), real(pg.r_a));
            put(at("alpha_factor"), real(pg.alpha_factor));
        }
        None => {
            put(at("geometry"), Start::Integer(2));
            opt(put, "module", a.module);
            opt(put, "pressure_angle", a.pressure_angle.or(b.pressure_angle));
            put(at("xA"), real(a.x));
            put(at("xB"), real(b.x));
        }
    }
    if b.internal {
        put(at("internal"), Start::Boolean(true));
    }
    // The narrower gear's face width carries the load.
    let width = match (a.width, b.width) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, y) => x.or(y),
    };
    opt(put, "width", width);
    opt(put, "addendum", shared(g, mesh, "addendum", addendum)?);
    opt(
        put,
        "dedendum",
        shared(g, mesh, "dedendum", |x| x.dedendum)?,
    );
    let rack = shared(g, mesh, "rack_tip_radius", |x| x.rack_tip_radius)?;
    opt(put, "rack_tip_radius", rack);
    for (gear, s) in [(a, "A"), (b, "B")] {
        let d = &gear.deviations;
        for (k, x) in [
            ("E_", gear.e),
            ("nu_", gear.nu),
            ("mount_", gear.mount),
            ("bore_radius_", gear.bore_radius),
            ("tip_relief_", d.tip_relief),
            ("tip_relief_length_", d.tip_relief_length),
            ("ecc_", d.ecc),
            ("ecc_phase_", d.ecc_phase),
        ] {
            opt(put, &format!("{k}{s}"), x);
        }
        if !gear.pitch_errors.is_empty() {
            let list: Vec<String> = gear.pitch_errors.iter().map(|x| format!("{x:e}")).collect();
            put(
                at(&format!("pitch_errors_{s}")),
                Start::String(list.join(",")),
            );
        }
    }
    if let Some(Damping::Chi(chi)) = mesh.damping {
        put(at("chi"), real(chi));
    }
    for (k, x) in [
        ("backlash", mesh.backlash),
        ("mu", mesh.mu),
        ("v_reg", mesh.v_reg),
        ("center_angle", mesh.center_angle),
        ("center_distance_error", mesh.center_distance_error),
        ("dte_start", mesh.dte_start),
        ("k_lumped", mesh.k_lumped),
        ("c_lumped", mesh.c_lumped),
    ] {
        opt(put, k, x);
    }
    for (k, x) in [
        ("contact_model", mesh.contact_model),
        ("contacts_per_flank", mesh.contacts_per_flank),
        ("tip_relief_shape", mesh.tip_relief_shape),
    ] {
        if let Some(x) = x {
            put(at(k), Start::Integer(x as i32));
        }
    }
    for (k, x) in [
        ("backward_contacts", mesh.backward_contacts),
        ("k_lumped_varies", mesh.k_lumped_varies),
    ] {
        if let Some(x) = x {
            put(at(k), Start::Boolean(x));
        }
    }
    Ok(())
}

/// The train's parameters and inputs (the torques) with these start values, the parameters
/// each checked on its own.
pub fn params(v: &[(String, Start)]) -> Result<(Params, Inputs), String> {
    let (mut p, mut inputs) = (Params::default(), Inputs::default());
    for (name, x) in v {
        let var = Var::from_name(name).ok_or_else(|| format!("no parameter {name}"))?;
        let set = match x {
            Start::Real(x) => p.set_real(var, *x) || inputs.set_real(var, *x),
            Start::Integer(x) => p.set_integer(var, *x),
            Start::Boolean(x) => p.set_boolean(var, *x),
            Start::String(x) => p.set_string(var, x.clone()),
        };
        assert!(set, "{name} is a start value of this type");
    }
    build::validate(&p)?;
    if let Some((name, x)) = inputs.first_non_finite() {
        return Err(format!("input {name} = {x}: must be finite"));
    }
    Ok((p, inputs))
}

/// Every body's start speed: the file's, and rigid rolling's from those for the others (at
/// rest where no body of their part has one). Speeds that make a mesh slip or a shaft twist
/// are refused.
fn start_speeds(g: &Gearbox, p: &Params, inputs: &Inputs) -> Result<Vec<f64>, String> {
    let spec = build::spec(p, inputs)?;
    let st = spec.structure().map_err(|e| e.message)?;
    let mut rows: Vec<(String, Row)> = Vec::new();
    for m in 0..spec.meshes.len() {
        let geo = Geometry::new(&spec.meshes[m].pair)
            .map_err(|e| format!("mesh[{}]: {}", m + 1, e.message))?;
        rows.push((format!("mesh[{}]", m + 1), mesh_row(&spec, &st, &geo, m)));
    }
    for j in 0..spec.shafts.len() {
        rows.push((format!("shaft[{}]", j + 1), shaft_row(&spec, j)));
    }
    let n = g.bodies.len();
    let known: Vec<Option<f64>> = g.bodies.iter().map(|b| b.w_start).collect();
    let mut w: Vec<f64> = known.iter().map(|x| x.unwrap_or(0.0)).collect();
    // A row with one speed left unknown gives it (a tree, a set whose ring or sun is fixed):
    // the ratio to the last bit, where a least-squares solve leaves rounding in every speed.
    let mut set: Vec<bool> = known.iter().map(Option::is_some).collect();
    if set.iter().any(|&s| s) {
        while let Some((row, i)) = rows.iter().find_map(|(_, row)| {
            let mut open = row.0.iter().filter(|&&(i, c)| !set[i] && c != 0.0);
            match (open.next(), open.next()) {
                (Some(&(i, _)), None) => Some((row, i)),
                _ => None,
            }
        }) {
            let c = coefficient(row, i);
            let rest: f64 = row
                .0
                .iter()
                .filter(|&&(j, _)| j != i)
                .map(|&(j, c)| c * w[j])
                .sum();
            w[i] = -rest / c;
            set[i] = true;
        }
    }
    let free: Vec<usize> = (0..n).filter(|&i| !set[i]).collect();
    if !free.is_empty() && free.len() < n && !rows.is_empty() {
        // Rows over the free speeds = minus the rows over the known ones (least squares; the
        // minimum-norm solution leaves a part no known speed reaches at rest).
        let a = DMatrix::from_fn(rows.len(), free.len(), |r, k| {
            coefficient(&rows[r].1, free[k])
        });
        let rhs = DVector::from_fn(rows.len(), |r, _| -rows[r].1.dot(&w));
        let x = a
            .svd(true, true)
            .solve(&rhs, 1e-12)
            .map_err(|e| e.to_string())?;
        for (k, &i) in free.iter().enumerate() {
            w[i] = x[k];
        }
    }
    let slipping: Vec<&str> = rows
        .iter()
        .filter(|(_, row)| {
            let scale: f64 = row.0.iter().map(|&(i, c)| (c * w[i]).abs()).sum();
            row.dot(&w).abs() > ROLLING_TOL * scale
        })
        .map(|(name, _)| name.as_str())
        .collect();
    if !slipping.is_empty() {
        let given: Vec<String> = (0..n)
            .filter_map(|i| known[i].map(|x| format!("body[{}].w_start = {x}", i + 1)))
            .collect();
        return Err(format!(
            "the start speeds given ({}) contradict rigid rolling, which {} would break; give w_start on fewer bodies and let rolling set the rest",
            given.join(", "),
            slipping.join(" and ")
        ));
    }
    Ok(w)
}

fn coefficient(row: &Row, i: usize) -> f64 {
    row.0
        .iter()
        .filter(|&&(j, _)| j == i)
        .map(|&(_, c)| c)
        .sum()
}

/// A message of the train (`mesh[4]`, `body[2].J`, `shaft[1]`) in the file's names, with the
/// line of the first element it names: "parameter wheel_hss.backlash = -1: ... (line 36)".
pub fn in_file_names(g: &Gearbox, msg: &str) -> String {
    match renamed(g, msg) {
        (out, Some(line)) => format!("{out} (line {line})"),
        (out, None) => out,
    }
}

/// A message of the train in the file's names, and the file's line of the first element it
/// names (a gearbox FMU's messages leave the line out: its values come from the master).
pub fn renamed(g: &Gearbox, msg: &str) -> (String, Option<usize>) {
    let mut out = String::with_capacity(msg.len() + 32);
    let mut first: Option<(String, String, String)> = None;
    let mut rest = msg;
    while let Some(k) = ["mesh[", "body[", "shaft["]
        .iter()
        .filter_map(|p| rest.find(p).map(|k| (k, *p)))
        .min()
    {
        let (at, prefix) = k;
        out.push_str(&rest[..at]);
        let after = &rest[at + prefix.len()..];
        let digits = after.chars().take_while(char::is_ascii_digit).count();
        let (Ok(i), true) = (
            after[..digits].parse::<usize>(),
            after[digits..].starts_with(']'),
        ) else {
            out.push_str(prefix);
            rest = after;
            continue;
        };
        let tail = &after[digits + 1..];
        let field_len = match tail.strip_prefix('.') {
            Some(f) => {
                1 + f
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .count()
            }
            None => 0,
        };
        let field = tail.get(1..field_len).unwrap_or("");
        let (text, place) = element_name(g, &prefix[..prefix.len() - 1], i, field);
        out.push_str(&text);
        if first.is_none() {
            first = place;
        }
        rest = &tail[field_len..];
    }
    out.push_str(rest);
    if out.contains("no operating pressure angle") {
        out.push_str(&ring_shift_hint(g, msg));
    }
    if out.contains("at the actual centre distance") && on_carrier(g, msg) {
        out.push_str("; the planets' orbit radius, which the set's other meshes fix, does not fit this pair: check the tooth counts and shifts (at zero shifts z_ring = z_sun + 2 z_planet)");
    }
    let line = first.and_then(|(kind, name, key)| g.lines.of(&kind, &name, &key));
    (out, line)
}

/// One reference in the file's names, with the (kind, name, key) whose line to give.
fn element_name(
    g: &Gearbox,
    kind: &str,
    i: usize,
    field: &str,
) -> (String, Option<(String, String, String)>) {
    let place = |k: &str, n: &str, key: &str| Some((k.to_owned(), n.to_owned(), key.to_owned()));
    let dotted = |n: &str, f: &str| {
        if f.is_empty() {
            n.to_owned()
        } else {
            format!("{n}.{f}")
        }
    };
    match kind {
        "body" if i == 0 => ("the housing".into(), None),
        "body" if i <= g.bodies.len() => {
            let n = &g.bodies[i - 1].name;
            let text = if field.is_empty() {
                format!("body {n}")
            } else {
                dotted(n, field)
            };
            (text, place("body", n, field))
        }
        "shaft" if i >= 1 && i <= g.shafts.len() => {
            let n = &g.shafts[i - 1].name;
            let text = if field.is_empty() {
                format!("shaft {n}")
            } else {
                dotted(n, field)
            };
            (text, place("shaft", n, field))
        }
        "mesh" if i >= 1 && i <= g.meshes.len() => {
            let mesh = &g.meshes[i - 1];
            let [a, b] = mesh.gears.map(|k| g.gears[k].name.as_str());
            // A gear's own data: `zA` is gear A's `z`.
            let gear_key = field
                .strip_suffix("_A")
                .or_else(|| field.strip_suffix('A'))
                .map(|k| (a, k))
                .or_else(|| {
                    field
                        .strip_suffix("_B")
                        .or_else(|| field.strip_suffix('B'))
                        .map(|k| (b, k))
                })
                .filter(|(_, k)| {
                    [
                        "z",
                        "x",
                        "E",
                        "nu",
                        "mount",
                        "bore_radius",
                        "tip_relief",
                        "tip_relief_length",
                        "ecc",
                        "ecc_phase",
                        "pitch_errors",
                    ]
                    .contains(k)
                });
            match gear_key {
                Some((gear, k)) => (format!("{gear}.{k}"), place("gear", gear, k)),
                None if field.is_empty() => (
                    format!("mesh {} (A = gear {a}, B = gear {b})", mesh.name),
                    place("mesh", &mesh.name, ""),
                ),
                None => (dotted(&mesh.name, field), place("mesh", &mesh.name, field)),
            }
        }
        _ => (
            format!(
                "{kind}[{i}]{}",
                if field.is_empty() {
                    String::new()
                } else {
                    format!(".{field}")
                }
            ),
            None,
        ),
    }
}

/// The mesh a train message starts with (`mesh[4]: ...`).
fn mesh_of<'g>(g: &'g Gearbox, msg: &str) -> Option<&'g Mesh> {
    msg.strip_prefix("mesh[")
        .and_then(|r| r.split(']').next())
        .and_then(|k| k.parse::<usize>().ok())
        .and_then(|k| g.meshes.get(k.wrapping_sub(1)))
}

/// Whether that mesh has a planet: its centre distance is the orbit radius.
fn on_carrier(g: &Gearbox, msg: &str) -> bool {
    mesh_of(g, msg).is_some_and(|m| {
        m.gears
            .iter()
            .filter_map(|&k| g.body_of_gear(k))
            .any(|i| g.bodies[i].orbit.is_some())
    })
}

/// The sign convention of a ring's profile shift, when an internal pair found no operating
/// pressure angle with a negative one.
fn ring_shift_hint(g: &Gearbox, msg: &str) -> String {
    let ring = mesh_of(g, msg)
        .map(|m| &g.gears[m.gears[1]])
        .filter(|r| r.internal && r.x < 0.0);
    match ring {
        Some(r) => format!(
            "; gear {} is internal with x = {}: here a ring's positive x moves its profile away from its axis (planetary.md §1), and sources that count a ring's teeth as negative (the NREL tables) print the opposite sign: x = {} may be meant",
            r.name, r.x, -r.x
        ),
        None => String::new(),
    }
}
