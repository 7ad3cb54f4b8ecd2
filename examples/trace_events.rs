//! Prints every located event and a few samples: a debugging aid for scenes.
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let t_end: f64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(0.003);
    let dte0: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(0.0);
    let chi: f64 = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(0.0);
    let p = Params {
        c_load: 2.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        dte_start: dte0,
        chi,
        ..Params::default()
    };
    let i = Inputs {
        tau_A: 100.0,
        tau_B: 0.0,
        ..Inputs::default()
    };
    let mut sim = table::simulation(&p, &i, 0.0, 1e-8).unwrap();
    let n = 60;
    for k in 1..=n {
        sim.advance(k as f64 * t_end / n as f64, &mut |t, r| {
            println!("  event t={t:.9} {}", r.what)
        })
        .unwrap();
        let o = outputs(&sim).unwrap();
        println!(
            "t={:.6} dte={:+.4e} F1={:8.2} F2={:8.2} n={} s1={:.5} s2={:.5}",
            sim.time(),
            o.dte,
            o.F_f1,
            o.F_f2,
            o.n_fwd,
            o.s_f1,
            o.s_f2
        );
    }
}
