//! The loaded static transmission error and the mesh stiffness over mesh cycles (issue 9,
//! point 4), by exact static balance at each wheel position (`model::static_mesh`), for
//! contact models 1 and 3, as CSV: contact_model, theta_A [rad], s0 [m], static_te [m] (the
//! shared penetration), k_mesh [N/m] (sum of dF_i/d(delta)), secant [N/m] (W/te), pairs.
//! `tools/static_te.py` plots it.
//!
//!     cargo run --release --example static_te -- [--torque 100] [--cycles 2] [--points 256]
//!         [--set name=value ...] > out/static-te.csv
//!
//! The pair is the table's standard geometry (geometry = 2) unless --set says otherwise.

use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::model::law::{ContactLaw, JohnsonLaw};
use spur_gear_mesh::model::static_mesh;
use spur_gear_mesh::model::tooth_structure::structure_law;
use spur_gear_mesh::variables::{Params, Var, VarType, VARIABLES};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut torque, mut cycles, mut points) = (100.0, 2usize, 256usize);
    let mut p = Params {
        geometry: 2,
        ..Params::default()
    };
    let mut i = 0;
    while i < args.len() {
        let val = args.get(i + 1).cloned().unwrap_or_default();
        match args[i].as_str() {
            "--torque" => torque = val.parse().expect("--torque N.m"),
            "--cycles" => cycles = val.parse().expect("--cycles N"),
            "--points" => points = val.parse().expect("--points N"),
            "--set" => {
                let (k, v) = val.split_once('=').expect("--set name=value");
                let info = VARIABLES
                    .iter()
                    .find(|x| x.name == k)
                    .unwrap_or_else(|| panic!("unknown variable {k}"));
                let var: Var = info.var;
                let ok = match info.ty {
                    VarType::Real => p.set_real(var, v.parse().expect("a number")),
                    VarType::Integer => p.set_integer(var, v.parse().expect("an integer")),
                    VarType::Boolean => p.set_boolean(var, v.parse().expect("true or false")),
                    VarType::String => p.set_string(var, v.to_owned()),
                };
                assert!(ok, "{k} is not a parameter");
            }
            other => panic!("unknown option {other}"),
        }
        i += 2;
    }
    let g = Geometry::new(&p).unwrap_or_else(|e| panic!("{}", e.message));
    let w = torque / g.r_ab;
    let johnson = JohnsonLaw {
        l: g.l,
        e_star: g.e_star,
        width: p.width,
    };
    let structure = structure_law(&p, &g).unwrap_or_else(|e| panic!("{}", e.message));
    println!("contact_model,theta_A,s0,static_te,k_mesh,secant,pairs");
    for (cm, law) in [
        (1, &johnson as &dyn ContactLaw),
        (3, &structure as &dyn ContactLaw),
    ] {
        for c in 0..cycles {
            for j in 0..points {
                let frac = (j as f64 + 0.5) / points as f64;
                let s0 = g.s_a + frac * g.p_b;
                let pt = static_mesh::balance(law, &g, s0, w);
                let theta = (c as f64 + frac) * g.p_b / g.r_ab;
                println!(
                    "{cm},{theta:.12e},{s0:.12e},{:.12e},{:.12e},{:.12e},{}",
                    pt.delta, pt.tangent, pt.secant, pt.pairs
                );
            }
        }
    }
}
