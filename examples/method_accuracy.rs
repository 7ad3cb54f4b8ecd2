//! Error of each method against a tight Dormand-Prince run, over a range of tolerances, on the
//! damped paper rig and on a hard, light variant: a quick look at convergence.
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

fn run(p: &Params, tau: f64, rtol: f64, h: f64, t_end: f64) -> (Vec<f64>, u64) {
    let mut s = table::simulation(
        p,
        &Inputs {
            tau_A: tau,
            tau_B: 0.0,
            ..Inputs::default()
        },
        0.0,
        rtol,
    )
    .unwrap();
    let n = (t_end / h).round() as usize;
    let v = (1..=n)
        .map(|k| {
            s.advance(k as f64 * h, &mut |_, _| {}).unwrap();
            outputs(&s).unwrap().dte
        })
        .collect();
    (v, s.driver.stats.steps)
}

fn main() {
    let paper = Params {
        c_load: 2.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        chi: 10.0,
        ..Params::default()
    };
    let light = Params {
        E_A: 1e12,
        E_B: 1e12,
        J_A: 1e-6,
        J_B: 5e-6,
        w_A_start: 10.0,
        w_B_start: 10.0 / 1.5,
        ..paper.clone()
    };
    for (name, p, tau, t_end) in [
        ("paper damped", paper, 100.0, 0.02),
        ("hard+light", light, 2.5e-4, 0.002),
    ] {
        let (r, _) = run(
            &Params {
                solver: 1,
                ..p.clone()
            },
            tau,
            1e-12,
            1e-5,
            t_end,
        );
        let scale = r.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for solver in [1, 2] {
            for rtol in [1e-4, 1e-6, 1e-8, 1e-10] {
                let (v, steps) = run(
                    &Params {
                        solver,
                        ..p.clone()
                    },
                    tau,
                    rtol,
                    1e-5,
                    t_end,
                );
                let err = v
                    .iter()
                    .zip(&r)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
                    / scale;
                println!("{name:12} solver {solver} rtol {rtol:.0e}: max |dte err|/max|dte| {err:.2e}  steps {steps}");
            }
        }
    }
}
