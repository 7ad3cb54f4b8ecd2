//! The loaded static transmission error and the mesh stiffness over mesh cycles (issue 9,
//! point 4), by exact static balance at each wheel position (`model::static_mesh`), for
//! contact models 1 and 3, each without and with tip relief, as CSV: contact_model,
//! tip_relief (0/1), theta_A [rad], s0 [m], static_te [m] (the flank's penetration),
//! k_mesh [N/m] (sum of dF_i/d(delta) of the carrying pairs), secant [N/m] (W/te), pairs
//! (carrying). `tools/static_te.py` plots it.
//!
//!     cargo run --release --example static_te -- [--torque 100] [--cycles 2] [--points 256]
//!         [--set name=value ...] > out/static-te.csv
//!
//! The pair is the table's standard geometry (geometry = 2) unless --set says otherwise. The
//! relief is the one the parameters give (tip_relief_*); without one, a textbook design: the
//! same linear "long" relief on both wheels, over the double-contact zone ((eps - 1) p_b from
//! each tip) and as deep as one pair's static deflection under the whole load at the pitch
//! point (contact model 3), so that a pair enters and leaves the mesh unloaded.

use spur_gear_mesh::model::deviations::Deviations;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::model::law::{ContactLaw, JohnsonLaw};
use spur_gear_mesh::model::static_mesh;
use spur_gear_mesh::model::tooth_structure::structure_law;
use spur_gear_mesh::table;
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
    let pair = table::pair(&p).unwrap_or_else(|e| panic!("{}", e.message));
    let g = Geometry::new(&pair).unwrap_or_else(|e| panic!("{}", e.message));
    let w = torque / g.r_ab;
    let johnson = JohnsonLaw::new(g.l, g.kappa, g.e_star, p.width);
    let structure =
        structure_law(&pair, pair.rack().unwrap(), &g).unwrap_or_else(|e| panic!("{}", e.message));
    if p.tip_relief_A == 0.0 && p.tip_relief_B == 0.0 {
        let pitch_point = g.l * g.r_ab / (g.r_ab + g.r_bb);
        let single = w / static_mesh::single_pair_stiffness(&structure, pitch_point, w);
        let length = g.s_b - g.s_a - g.p_b;
        eprintln!(
            "tip relief: linear, {:.3} um over {:.3} mm on both wheels",
            1e6 * single,
            1e3 * length
        );
        (p.tip_relief_A, p.tip_relief_B) = (single, single);
        (p.tip_relief_length_A, p.tip_relief_length_B) = (length, length);
        p.tip_relief_shape = 1;
    }
    let relief = Deviations::new(&table::pair(&p).unwrap(), &g)
        .unwrap_or_else(|e| panic!("{}", e.message))
        .expect("a tip relief");
    println!("contact_model,tip_relief,theta_A,s0,static_te,k_mesh,secant,pairs");
    for (cm, law) in [
        (1, &johnson as &dyn ContactLaw),
        (3, &structure as &dyn ContactLaw),
    ] {
        for with_relief in [false, true] {
            let deviation = |s: f64| {
                if with_relief {
                    relief.tip_relief_at(s)
                } else {
                    0.0
                }
            };
            for c in 0..cycles {
                for j in 0..points {
                    let frac = (j as f64 + 0.5) / points as f64;
                    let s0 = g.s_a + frac * g.p_b;
                    let pt = static_mesh::balance_with(law, &g, s0, w, &deviation);
                    let theta = (c as f64 + frac) * g.p_b / g.r_ab;
                    println!(
                        "{cm},{},{theta:.12e},{s0:.12e},{:.12e},{:.12e},{:.12e},{}",
                        with_relief as u8, pt.delta, pt.tangent, pt.secant, pt.pairs
                    );
                }
            }
        }
    }
}
