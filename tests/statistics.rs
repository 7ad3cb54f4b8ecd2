//! The run's statistics (issue 11, point 1): exact along the internal steps, so they do not
//! depend on the communication step, and they agree with a finely sampled trace of the same run
//! within the sampling error bounded from that trace.

use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Outputs, Params};

const T_END: f64 = 0.1;
const STATS_START: f64 = 0.02;

/// The paper rig with a running start: damped (chi = 10, the mesh stays in contact) or undamped
/// (the teeth separate and re-impact after about 0.03 s).
fn rig(chi: f64, statistics: bool) -> Params {
    Params {
        c_load: 2.0,
        chi,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        statistics,
        stats_start: STATS_START,
        ..Params::default()
    }
}

/// Outputs at every communication point k h, k = 1..n.
fn run(p: &Params, h: f64) -> Vec<(f64, Outputs)> {
    let inputs = Inputs {
        tau_A: 100.0,
        ..Inputs::default()
    };
    let mut sim = table::simulation(p, &inputs, 0.0, 1e-6).unwrap();
    let n = (T_END / h).round() as usize;
    (1..=n)
        .map(|k| {
            let t = k as f64 * h;
            sim.advance(t, &mut |_, _| {}).unwrap();
            (t, outputs(&sim).unwrap())
        })
        .collect()
}

fn stats(o: &Outputs) -> [f64; 7] {
    [
        o.dte_mean,
        o.dte_rms,
        o.dte_min,
        o.dte_max,
        o.F_max,
        o.t_separated,
        o.t_backward,
    ]
}

/// The internal steps do not depend on the communication points, and the statistics are
/// committed only at steps and events (the piece up to the current time is added when read):
/// one long communication step sums the very same pieces as a thousand short ones.
#[test]
fn a_long_communication_step_gives_the_same_statistics() {
    for (chi, solver) in [(10.0, 1), (0.0, 1), (10.0, 2)] {
        let p = Params {
            solver,
            ..rig(chi, true)
        };
        let short = run(&p, 1e-4);
        let long = run(&p, T_END);
        let (a, b) = (stats(&short.last().unwrap().1), stats(&long[0].1));
        assert_eq!(a, b, "chi = {chi}, solver {solver}");
        assert!(a[3] > a[2] && a[4] > 0.0, "chi = {chi}: {a:?}");
    }
}

/// Turning the statistics on observes the run without changing it, and off they are zero.
#[test]
fn statistics_do_not_change_the_run() {
    let on = run(&rig(0.0, true), 1e-3);
    let off = run(&rig(0.0, false), 1e-3);
    for ((_, a), (_, b)) in on.iter().zip(&off) {
        assert_eq!((a.dte, a.w_A, a.n_steps), (b.dte, b.w_A, b.n_steps));
        assert_eq!(stats(b), [0.0; 7]);
    }
}

/// Against the same run sampled every h = 1e-6 s (about 70 samples per mesh vibration period):
/// - mean and RMS: the trapezoidal rule's error is at most T h^2/12 max|f''|, with f'' bounded
///   by the samples' second differences (twice that bound, for the bound's own sampling);
/// - extremes: a sampled extreme lies inside the true one, by at most h^2/8 max|f''| (the
///   force's by h max|F'| where its peak sits at a pair switch);
/// - times separated / backward: a sample misclassifies at most the h around each mode switch,
///   and there are at most n_events switches.
#[test]
fn statistics_match_a_finely_sampled_trace() {
    let h = 1e-6;
    for chi in [10.0, 0.0] {
        let trace = run(&rig(chi, true), h);
        let fin = &trace.last().unwrap().1;
        let window: Vec<&(f64, Outputs)> =
            trace.iter().filter(|(t, _)| *t >= STATS_START).collect();
        let dte: Vec<f64> = window.iter().map(|(_, o)| o.dte).collect();
        let force: Vec<f64> = window.iter().map(|(_, o)| o.F_fwd + o.F_bwd).collect();
        // A pair's gate switches the number of carrying pairs and steps the force: the bound on
        // f'' holds between such switches, so windows across one are left out.
        let pairs: Vec<i32> = window.iter().map(|(_, o)| o.n_fwd + 10 * o.n_bwd).collect();
        let curvature = |f: &[f64]| {
            (0..f.len() - 2)
                .filter(|&k| pairs[k] == pairs[k + 1] && pairs[k + 1] == pairs[k + 2])
                .map(|k| (f[k] - 2.0 * f[k + 1] + f[k + 2]).abs() / (h * h))
                .fold(0.0, f64::max)
        };
        let (c_dte, c_f) = (2.0 * curvature(&dte), 2.0 * curvature(&force));
        let t = T_END - STATS_START;
        let trapezoid = |f: &[f64]| h * (f.iter().sum::<f64>() - 0.5 * (f[0] + f[f.len() - 1])) / t;
        let mean = trapezoid(&dte);
        let sq: Vec<f64> = dte.iter().map(|d| d * d).collect();
        let mean_sq = trapezoid(&sq);
        let dmax = dte.iter().cloned().fold(f64::MIN, f64::max);
        let dmin = dte.iter().cloned().fold(f64::MAX, f64::min);
        let fmax = force.iter().cloned().fold(f64::MIN, f64::max);
        let quad = t * h * h / 12.0;
        let scale = dmax.abs().max(dmin.abs());
        // Rounding of sums over 80000 samples: far below 1e-12 of the scale.
        let round = 1e-12 * scale;
        assert!(
            (fin.dte_mean - mean).abs() <= quad * c_dte / t + round,
            "chi {chi}: mean {} vs {mean}",
            fin.dte_mean
        );
        let c_sq = 2.0 * curvature(&sq);
        assert!(
            (fin.dte_rms.powi(2) - mean_sq).abs() <= quad * c_sq / t + round * scale,
            "chi {chi}: rms^2 {} vs {mean_sq}",
            fin.dte_rms.powi(2)
        );
        let ext = h * h / 8.0;
        assert!(
            fin.dte_max >= dmax - round && fin.dte_max <= dmax + ext * c_dte + round,
            "chi {chi}: max {} vs {dmax}",
            fin.dte_max
        );
        assert!(
            fin.dte_min <= dmin + round && fin.dte_min >= dmin - ext * c_dte - round,
            "chi {chi}: min {} vs {dmin}",
            fin.dte_min
        );
        // The peak force may sit at a pair switch, where F steps: there a sample can miss it by
        // h times the slope F' (largest first difference between switches).
        let slope = (0..force.len() - 1)
            .filter(|&k| pairs[k] == pairs[k + 1])
            .map(|k| (force[k + 1] - force[k]).abs())
            .fold(0.0, f64::max);
        assert!(
            fin.F_max >= fmax * (1.0 - 1e-12)
                && fin.F_max <= fmax + (ext * c_f).max(slope) + 1e-12 * fmax,
            "chi {chi}: F_max {} vs {fmax}",
            fin.F_max
        );
        let switches = fin.n_events as f64 + 1.0;
        let count = |pred: &dyn Fn(&Outputs) -> bool| {
            h * window.iter().filter(|(_, o)| pred(o)).count() as f64
        };
        let sep = count(&|o| o.n_fwd + o.n_bwd == 0);
        let bwd = count(&|o| o.n_bwd > 0);
        assert!(
            (fin.t_separated - sep).abs() <= switches * h,
            "chi {chi}: t_separated {} vs {sep}",
            fin.t_separated
        );
        assert!(
            (fin.t_backward - bwd).abs() <= switches * h,
            "chi {chi}: t_backward {} vs {bwd}",
            fin.t_backward
        );
        if chi == 0.0 {
            assert!(fin.t_separated > 0.0, "the undamped rig rattles");
        }
    }
}
