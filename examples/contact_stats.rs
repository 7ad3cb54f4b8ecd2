//! Fraction of samples in double / single / no contact for the paper rig, for a given dte_start and chi.
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .map(|s| s.parse().unwrap())
        .collect();
    let (dte0, chi, t_end, rtol) = (a[0], a[1], a[2], a[3]);
    let p = Params {
        c_load: 2.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        dte_start: dte0,
        chi,
        ..Params::default()
    };
    let mut sim = table::simulation(
        &p,
        &Inputs {
            tau_A: 100.0,
            tau_B: 0.0,
            ..Inputs::default()
        },
        0.0,
        rtol,
    )
    .unwrap();
    let n = (t_end / 1e-6) as usize;
    let mut c = [0usize; 3];
    let mut min_dte = f64::INFINITY;
    for k in 1..=n {
        sim.advance(k as f64 * 1e-6, &mut |_, _| {}).unwrap();
        let o = outputs(&sim).unwrap();
        c[o.n_fwd as usize] += 1;
        if k > n / 2 {
            min_dte = min_dte.min(o.dte);
        }
    }
    println!("dte0={dte0:e} chi={chi} rtol={rtol:e}: none {:.3} single {:.3} double {:.3}  min dte (2nd half) {:.3e} events {}", c[0] as f64 / n as f64, c[1] as f64 / n as f64, c[2] as f64 / n as f64, min_dte, sim.driver.stats.events);
}
