//! Runs the paper scene through the driver directly (no FMI) and prints a summary.
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let rtol: f64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(1e-6);
    let solver: i32 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(1);
    let p = Params {
        c_load: 2.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        // The paper's mesh is undamped.
        chi: 0.0,
        solver,
        ..Params::default()
    };
    let i = Inputs {
        tau_A: 100.0,
        tau_B: 0.0,
        ..Inputs::default()
    };
    let t0 = std::time::Instant::now();
    let mut sim = table::simulation(&p, &i, 0.0, rtol).unwrap();
    let h = 1e-5;
    let (mut n2, mut n1, mut n0) = (0, 0, 0);
    let mut max_diff: f64 = 0.0;
    for k in 1..=10000 {
        sim.advance(k as f64 * h, &mut |_, _| {}).unwrap();
        let o = outputs(&sim).unwrap();
        match o.n_fwd {
            2 => n2 += 1,
            1 => n1 += 1,
            _ => n0 += 1,
        }
        if o.n_fwd == 2 {
            max_diff = max_diff.max((o.F_f1 - o.F_f2).abs());
        }
        if k % 1000 == 0 {
            println!("t={:.4} wA={:.4} wB={:.4} dte={:.4e} F1={:.2} F2={:.2} n={} bwd={} E_res={:.3e} Ekin={:.1}", sim.time(), o.w_A, o.w_B, o.dte, o.F_f1, o.F_f2, o.n_fwd, o.n_bwd, o.energy_residual, o.E_kin);
        }
    }
    let el = t0.elapsed().as_secs_f64();
    println!(
        "double {} single {} none {}  max|F1-F2| in double {:e}",
        n2, n1, n0, max_diff
    );
    println!(
        "stats {:?} wall {:.4}s => {:.1} sim s / wall s",
        sim.driver.stats,
        el,
        0.1 / el
    );
}
