//! From the train's FMI parameters to the model: the train's specification (bodies, shafts,
//! meshes in use, each mesh's pair parameters as a single-mesh `Params`) and its loads.

use crate::variables::{Inputs, Params, Var, VarInfo, VARIABLES};
use gear_model::model::mesh::Coefficients;
use gear_model::model::train::{
    Body, Lateral, MeshPlace, Planet, Ripple, Shaft, TrainLoads, TrainSpec, HOUSING, MAX_BODIES,
    MAX_MESHES,
};
use gear_model::variables as single;

/// A train variable by its structured name (all of them exist: the table is generated).
pub fn var(name: &str) -> Var {
    Var::from_name(name).unwrap_or_else(|| panic!("no variable {name}"))
}

fn real(p: &Params, name: &str) -> f64 {
    p.get_real(var(name)).expect("a Real parameter")
}

fn boolean(p: &Params, name: &str) -> bool {
    p.get_boolean(var(name)).expect("a Boolean parameter")
}

fn int(p: &Params, name: &str) -> i32 {
    p.get_integer(var(name)).expect("an Integer parameter")
}

/// Checks every parameter on its own, as the single mesh does: finite, and within the table's
/// range. How they fit together (a tree, the geometry) is checked when the train is built.
pub fn validate(p: &Params) -> Result<(), String> {
    // Each mesh's front end, read once.
    let geometry: Vec<i32> = (1..=MAX_MESHES).map(|m| geometry(p, m)).collect();
    VARIABLES
        .iter()
        .try_for_each(|info| check(p, info, &|m| geometry[m - 1]))
}

/// `validate` after a set of the `changed` parameters, the others valid before: the changed
/// ones, and all of a mesh's front-end parameters when its front end changed. A master may set
/// start values one at a time, and the table holds about a thousand.
pub fn validate_changed(p: &Params, changed: &[Var]) -> Result<(), String> {
    let geometry = |m: usize| geometry(p, m);
    for &v in changed {
        let info = v.info();
        check(p, info, &geometry)?;
        if let Some(("mesh", m, "geometry")) = element(info.name) {
            VARIABLES
                .iter()
                .filter(|i| {
                    i.geometry.is_some()
                        && matches!(element(i.name), Some(("mesh", k, _)) if k == m)
                })
                .try_for_each(|i| check(p, i, &geometry))?;
        }
    }
    Ok(())
}

/// Mesh m's front end (1-based).
fn geometry(p: &Params, m: usize) -> i32 {
    int(p, &format!("mesh[{m}].geometry"))
}

/// One parameter: finite, and within its range if its mesh's front end (`geometry`, by mesh)
/// uses it.
fn check(p: &Params, info: &VarInfo, geometry: &dyn Fn(usize) -> i32) -> Result<(), String> {
    let x = match p.get_real(info.var) {
        Some(x) if !x.is_finite() => {
            return Err(format!("parameter {} = {x}: must be finite", info.name));
        }
        Some(x) => x,
        None => match p.get_integer(info.var) {
            Some(i) => i as f64,
            None => return Ok(()),
        },
    };
    // Most variables belong to every front end: their names are not parsed.
    if let Some(g) = info.geometry {
        if let Some(("mesh", m, _)) = element(info.name) {
            if geometry(m) != g {
                return Ok(());
            }
        }
    }
    match info.range.violation(x) {
        Some(why) => Err(format!("parameter {} = {x}: {why}", info.name)),
        None => Ok(()),
    }
}

/// `mesh[2].zA` -> ("mesh", 2, "zA").
pub fn element(name: &str) -> Option<(&str, usize, &str)> {
    // A plain scan of the bytes: `split_once`'s searchers cost most of an instance's setup
    // (every output's name is split when the instance is made).
    let at =
        |from: usize, c: u8| Some(from + name.as_bytes()[from..].iter().position(|&b| b == c)?);
    let open = at(0, b'[')?;
    let close = at(open, b']')?;
    let field = name[close + 1..].strip_prefix('.')?;
    Some((&name[..open], name[open + 1..close].parse().ok()?, field))
}

/// Mesh m's pair parameters (1-based) as the single mesh's: every single-mesh parameter the
/// train has as `mesh[m].<name>`; the others (the rig's) keep their defaults.
pub fn mesh_params(p: &Params, m: usize) -> single::Params {
    let mut s = single::Params::default();
    // The train also shows a mesh's outputs and calculated parameters under `mesh[m].`: only
    // parameters are copied.
    let parameters = single::VARIABLES
        .iter()
        .filter(|i| i.causality == single::Causality::Parameter);
    for info in parameters {
        let Some(v) = Var::from_name(&format!("mesh[{m}].{}", info.name)) else {
            continue;
        };
        let set = if let Some(x) = p.get_real(v) {
            s.set_real(info.var, x)
        } else if let Some(x) = p.get_integer(v) {
            s.set_integer(info.var, x)
        } else if let Some(x) = p.get_boolean(v) {
            s.set_boolean(info.var, x)
        } else if let Some(x) = p.get_string(v) {
            s.set_string(info.var, x.to_owned())
        } else {
            false
        };
        debug_assert!(set, "{} is a parameter of both tables", info.name);
    }
    s
}

/// The train the parameters describe (indices checked against the counts here; the tree and
/// each mesh's parameters when the train is built). A speed-driven body starts at its input
/// `w_in`.
pub fn spec(p: &Params, inputs: &Inputs) -> Result<TrainSpec, String> {
    let (nb, ns, nm) = (
        p.n_bodies as usize,
        p.n_shafts as usize,
        p.n_meshes as usize,
    );
    // An element's end: a body, or 0 for the housing.
    let body_index = |name: String| -> Result<usize, String> {
        let i = int(p, &name);
        if i < 0 || i as usize > nb {
            return Err(format!(
                "parameter {name} = {i}: no such body (n_bodies = {nb}; 0 is the housing)"
            ));
        }
        Ok(if i == 0 { HOUSING } else { i as usize - 1 })
    };
    let mut planets = Vec::with_capacity(nb);
    for i in 1..=nb {
        let name = format!("body[{i}].carrier");
        let c = int(p, &name);
        if c < 0 || c as usize > nb {
            return Err(format!(
                "parameter {name} = {c}: no such body (n_bodies = {nb}; 0: the housing holds its axis)"
            ));
        }
        planets.push((c > 0).then(|| Planet {
            carrier: c as usize - 1,
            orbit_angle: real(p, &format!("body[{i}].orbit_angle")),
            m: real(p, &format!("body[{i}].m")),
            pin_error_r: real(p, &format!("body[{i}].pin_error_r")),
            pin_error_t: real(p, &format!("body[{i}].pin_error_t")),
        }));
    }
    let mut bodies = Vec::with_capacity(nb);
    for i in 1..=nb {
        let name = format!("body[{i}].drive");
        let speed_driven = match int(p, &name) {
            0 => false,
            1 => true,
            d => return Err(format!("parameter {name} = {d}: 0 (torque) or 1 (speed)")),
        };
        let w_start = if speed_driven {
            let w_in = format!("body[{i}].w_in");
            inputs.get_real(var(&w_in)).expect("a Real input")
        } else {
            real(p, &format!("body[{i}].w_start"))
        };
        let pair = |x: &str, y: &str| {
            [
                real(p, &format!("body[{i}].{x}")),
                real(p, &format!("body[{i}].{y}")),
            ]
        };
        let lateral = boolean(p, &format!("body[{i}].lateral")).then(|| Lateral {
            m: real(p, &format!("body[{i}].m")),
            k: pair("k_x", "k_y"),
            c: pair("c_x", "c_y"),
            q_start: pair("x_start", "y_start"),
            v_start: pair("vx_start", "vy_start"),
        });
        bodies.push(Body {
            lateral,
            planet: planets[i - 1],
            j: real(p, &format!("body[{i}].J")),
            c: real(p, &format!("body[{i}].c")),
            w_start,
            speed_driven,
            ripple: Ripple {
                amplitude: real(p, &format!("body[{i}].tau_ripple")),
                order: real(p, &format!("body[{i}].ripple_order")),
                phase: real(p, &format!("body[{i}].ripple_phase")),
            },
        });
    }
    let mut shafts = Vec::with_capacity(ns);
    for j in 1..=ns {
        shafts.push(Shaft {
            a: body_index(format!("shaft[{j}].a"))?,
            b: body_index(format!("shaft[{j}].b"))?,
            k: real(p, &format!("shaft[{j}].k")),
            d: real(p, &format!("shaft[{j}].d")),
            twist_start: real(p, &format!("shaft[{j}].twist_start")),
        });
    }
    let mut meshes = Vec::with_capacity(nm);
    for m in 1..=nm {
        // The pair checked as the single mesh checks it, named as the train's mesh.
        let single = mesh_params(p, m);
        let pair = gear_model::table::validate(&single)
            .and_then(|()| gear_model::table::pair(&single))
            .map_err(|e| format!("mesh[{m}]: {}", e.message))?;
        meshes.push(MeshPlace {
            a: body_index(format!("mesh[{m}].A"))?,
            b: body_index(format!("mesh[{m}].B"))?,
            center_angle: real(p, &format!("mesh[{m}].center_angle")),
            mount_a: real(p, &format!("mesh[{m}].mount_A")),
            mount_b: real(p, &format!("mesh[{m}].mount_B")),
            pair,
            dte_start: single.dte_start,
        });
    }
    Ok(TrainSpec {
        bodies,
        angle_start: p.body_1_angle_start,
        shafts,
        meshes,
    })
}

/// The variables a master may change while the train runs (every body's torque, every mesh's
/// chi, mu, v_reg), looked up by name once per instance: `loads` runs on every input change.
#[derive(Clone, Debug)]
pub struct LoadVars {
    tau: Vec<Var>,
    w_in: Vec<Var>,
    coef: Vec<[Var; 3]>,
}

impl Default for LoadVars {
    fn default() -> Self {
        LoadVars {
            tau: (1..=MAX_BODIES)
                .map(|k| var(&format!("body[{k}].tau")))
                .collect(),
            w_in: (1..=MAX_BODIES)
                .map(|k| var(&format!("body[{k}].w_in")))
                .collect(),
            coef: (1..=MAX_MESHES)
                .map(|m| ["chi", "mu", "v_reg"].map(|n| var(&format!("mesh[{m}].{n}"))))
                .collect(),
        }
    }
}

/// The bodies' torques and speed inputs, and the meshes' tunable coefficients.
pub fn loads(p: &Params, i: &Inputs, v: &LoadVars) -> TrainLoads {
    let real = |x: Option<f64>| x.expect("a Real input or parameter");
    let inputs = |of: &[Var]| -> Vec<f64> {
        of[..p.n_bodies as usize]
            .iter()
            .map(|&t| real(i.get_real(t)))
            .collect()
    };
    let coef = v.coef[..p.n_meshes as usize]
        .iter()
        .map(|&[chi, mu, v_reg]| Coefficients {
            chi: real(p.get_real(chi)),
            mu: real(p.get_real(mu)),
            v_reg: real(p.get_real(v_reg)),
        })
        .collect();
    TrainLoads {
        tau: inputs(&v.tau),
        w_in: inputs(&v.w_in),
        coef,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After every set from a valid table, `validate_changed` refuses exactly what `validate`
    /// refuses, the front-end switch included (a parameter of the other front end is not
    /// checked until its front end is chosen). A refused set leaves the table as it was, as
    /// the FMU does.
    #[test]
    fn the_check_of_a_set_agrees_with_the_whole_check() {
        let mut p = Params::default();
        validate(&p).expect("the defaults are valid");
        let steps: &[(&[(&str, f64)], bool)] = &[
            (&[("mesh[3].rA", -1.0)], false),
            (&[("mesh[3].geometry", 2.0)], true),
            (&[("mesh[3].rA", -1.0)], true),
            (&[("mesh[3].geometry", 1.0)], false),
            (
                &[("mesh[3].module", 0.002), ("mesh[3].geometry", 2.0)],
                true,
            ),
            (&[("body[2].J", f64::NAN)], false),
            (&[("body[2].J", 0.5), ("n_meshes", 99.0)], false),
            (&[("mesh[16].zA", 2.0)], false),
            (&[("n_bodies", 3.0)], true),
        ];
        for &(set, ok) in steps {
            let mut q = p.clone();
            let changed: Vec<Var> = set
                .iter()
                .map(|&(name, x)| {
                    let v = var(name);
                    assert!(q.set_real(v, x) || q.set_integer(v, x as i32), "{name}");
                    v
                })
                .collect();
            let (whole, part) = (validate(&q), validate_changed(&q, &changed));
            assert_eq!(whole.is_ok(), ok, "{set:?}: {whole:?}");
            assert_eq!(part, whole, "{set:?}");
            if ok {
                p = q;
            }
        }
    }
}
