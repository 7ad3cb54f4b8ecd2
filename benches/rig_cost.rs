//! What the rigid contact saves (issue 8, point 8): the paper scene through the FMU's C API
//! in-process with contact_model = 1 (Johnson) and 2 (rigid), damped and undamped, interleaved
//! so both meet the same machine state. Medians of repeated runs and their ratio; the paper
//! (section 6.2) reports that its compliant model costs at most twice the rigid one.
//!
//! Run: `cargo bench --bench rig_cost` (add `-- --quick` for fewer repetitions).

use spur_gear_mesh::fmi::exports::*;
use spur_gear_mesh::fmi::{CallbackFunctions, Status};
use spur_gear_mesh::variables::{Var, GUID};
use std::ffi::CString;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

/// One run of the paper scene, 0.1 s at a communication step of 1e-4 s; returns the wall time
/// of the stepping (as `benches/throughput.rs` measures it), the wall time of instantiation and
/// initialization before it, and the internal steps.
fn run(contact_model: i32, chi: f64) -> (f64, f64, i32) {
    let name = CString::new("bench").unwrap();
    let guid = CString::new(GUID).unwrap();
    let cb = CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    };
    let real = [
        (Var::tau_A, 100.0),
        (Var::c_load, 2.0),
        (Var::w_A_start, 100.0),
        (Var::w_B_start, 100.0 / 1.5),
        (Var::chi, chi),
    ];
    let (t_end, h): (f64, f64) = (0.1, 1e-4);
    unsafe {
        let t0 = Instant::now();
        let c = fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), std::ptr::null(), &cb, 0, 0);
        for (v, x) in real {
            assert_eq!(fmi2SetReal(c, &v.info().vr, 1, &x), Status::Ok);
        }
        let vr = Var::contact_model.info().vr;
        assert_eq!(fmi2SetInteger(c, &vr, 1, &contact_model), Status::Ok);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
        let setup = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let out = Var::F_fwd.info().vr;
        let mut acc = 0.0;
        for k in 0..(t_end / h).round() as usize {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), Status::Ok);
            let mut f = 0.0;
            fmi2GetReal(c, &out, 1, &mut f);
            acc += f;
        }
        std::hint::black_box(acc);
        let wall = t0.elapsed().as_secs_f64();
        let mut steps = 0;
        fmi2GetInteger(c, &Var::n_steps.info().vr, 1, &mut steps);
        fmi2FreeInstance(c);
        (wall, setup, steps)
    }
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let reps = if quick { 5 } else { 31 };
    println!("paper scene, 0.1 s, communication step 1e-4 s, rel_tol 1e-6, {reps} interleaved repetitions, medians");
    println!("stepping: fmi2DoStep and fmi2GetReal(F_fwd) every 1e-4 s; setup: fmi2Instantiate to fmi2ExitInitializationMode");
    println!("| case | Johnson stepping [ms] (steps) | rigid stepping [ms] (steps) | Johnson / rigid | setup Johnson / rigid [us] |");
    println!("|---|---|---|---|---|");
    for (chi, label) in [(0.0, "undamped (chi = 0)"), (10.0, "damped (chi = 10 s/m)")] {
        let (mut johnson, mut rigid, mut setup_j, mut setup_r) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut sj, mut sr) = (0, 0);
        for _ in 0..reps {
            let (w, s0, s) = run(1, chi);
            (sj, setup_j) = (s, [setup_j, vec![s0]].concat());
            johnson.push(w);
            let (w, s0, s) = run(2, chi);
            (sr, setup_r) = (s, [setup_r, vec![s0]].concat());
            rigid.push(w);
        }
        let ratios: Vec<f64> = johnson.iter().zip(&rigid).map(|(j, r)| j / r).collect();
        println!(
            "| {label} | {:.3} ({sj}) | {:.4} ({sr}) | {:.1} (median of per-pair ratios) | {:.1} / {:.1} |",
            1e3 * median(johnson),
            1e3 * median(rigid),
            median(ratios),
            1e6 * median(setup_j),
            1e6 * median(setup_r)
        );
    }
}
