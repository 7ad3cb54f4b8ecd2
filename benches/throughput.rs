//! Throughput of the FMU through its C API, in-process: simulated seconds per wall-clock second
//! of the paper scene, and the cost of an fmi2DoStep that contains no event. Medians of repeated
//! runs; the same scene stepped through the Rust driver directly runs beside it as the peer
//! (the FMI layer's overhead is the ratio).
//!
//! Run: `cargo bench --bench throughput` (add `-- --quick` for fewer repetitions).

use spur_gear_mesh::fmi::exports::*;
use spur_gear_mesh::fmi::outputs::{is_energy, write};
use spur_gear_mesh::fmi::{CallbackFunctions, Component, Status};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{
    Causality, Inputs, Outputs, Params, Var, VarType, GUID, VARIABLES,
};
use std::ffi::CString;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

struct Fmu {
    c: Component,
    _keep: (CString, CString, Box<CallbackFunctions>),
}

impl Fmu {
    fn new(real: &[(Var, f64)]) -> Fmu {
        let name = CString::new("bench").unwrap();
        let guid = CString::new(GUID).unwrap();
        let cb = Box::new(CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        });
        unsafe {
            let c = fmi2Instantiate(
                name.as_ptr(),
                1,
                guid.as_ptr(),
                std::ptr::null(),
                &*cb,
                0,
                0,
            );
            assert!(!c.is_null());
            for (v, x) in real {
                assert_eq!(fmi2SetReal(c, &v.info().vr, 1, x), Status::Ok);
            }
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
            assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
            assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
            Fmu {
                c,
                _keep: (name, guid, cb),
            }
        }
    }
    fn run(&self, t_end: f64, h: f64) -> f64 {
        let n = (t_end / h).round() as usize;
        let vr = [Var::dte.info().vr, Var::F_fwd.info().vr, Var::w_A.info().vr];
        let mut out = [0.0; 3];
        let mut sum = 0.0;
        for k in 0..n {
            unsafe {
                assert_eq!(fmi2DoStep(self.c, k as f64 * h, h, 1), Status::Ok);
                fmi2GetReal(self.c, vr.as_ptr(), 3, out.as_mut_ptr());
            }
            sum += out[0];
        }
        sum
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) };
    }
}

fn paper_start(rel_tol: f64, chi: f64) -> Vec<(Var, f64)> {
    vec![
        (Var::tau_A, 100.0),
        (Var::c_load, 2.0),
        (Var::w_A_start, 100.0),
        (Var::w_B_start, 100.0 / 1.5),
        (Var::rel_tol, rel_tol),
        (Var::chi, chi),
    ]
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let reps = if quick { 5 } else { 21 };
    let (t_end, h) = (0.1, 1e-4);
    println!("paper scene (tau_A = 100 N m, c_load = 2, running start), {t_end} s, communication step {h} s, {reps} repetitions, medians");
    for (chi, label) in [(0.0, "chi = 0 (paper)"), (10.0, "chi = 10 s/m")] {
        for rel_tol in [1e-4, 1e-6, 1e-8] {
            let fmi: Vec<f64> = (0..reps)
                .map(|_| {
                    let f = Fmu::new(&paper_start(rel_tol, chi));
                    let t0 = Instant::now();
                    std::hint::black_box(f.run(t_end, h));
                    t0.elapsed().as_secs_f64()
                })
                .collect();
            let p = Params {
                c_load: 2.0,
                w_A_start: 100.0,
                w_B_start: 100.0 / 1.5,
                chi,
                rel_tol,
                ..Params::default()
            };
            let i = Inputs {
                tau_A: 100.0,
                tau_B: 0.0,
                ..Inputs::default()
            };
            let direct: Vec<f64> = (0..reps)
                .map(|_| {
                    let mut s = table::simulation(&p, &i, 0.0, rel_tol).unwrap();
                    let t0 = Instant::now();
                    let (mut acc, mut o) = (0.0, Outputs::default());
                    for k in 1..=(t_end / h).round() as usize {
                        s.advance(k as f64 * h, &mut |_, _| {}).unwrap();
                        // What fmi2DoStep computes after the step (the energy only when read).
                        write(&s, &mut o).unwrap();
                        acc += o.dte;
                    }
                    std::hint::black_box(acc);
                    t0.elapsed().as_secs_f64()
                })
                .collect();
            let (mf, md) = (median(fmi), median(direct));
            println!(
                "  {label:16} rel_tol {rel_tol:.0e}: C API {:8.1} sim s/wall s ({:.2} ms); Rust driver peer {:8.1} sim s/wall s; ratio {:.2}",
                t_end / mf,
                mf * 1e3,
                t_end / md,
                mf / md
            );
        }
    }
    // fmi2DoStep with no event inside: steps of 1e-7 s inside a damped single-contact interval
    // (the internal step is longer, so most calls only interpolate and read outputs).
    let f = Fmu::new(&paper_start(1e-6, 10.0));
    f.run(0.0101, 1e-4); // settle into the run, stop inside a single-contact interval
    let vr = [Var::dte.info().vr];
    let mut out = [0.0];
    let samples: Vec<f64> = (0..reps)
        .map(|r| {
            let n = 1000;
            let t0 = Instant::now();
            for k in 0..n {
                let t = 0.0101 + (r * n + k) as f64 * 1e-7;
                unsafe {
                    fmi2DoStep(f.c, t, 1e-7, 1);
                    fmi2GetReal(f.c, vr.as_ptr(), 1, out.as_mut_ptr());
                }
            }
            t0.elapsed().as_secs_f64() / n as f64
        })
        .collect();
    println!(
        "fmi2DoStep(1e-7 s) + fmi2GetReal(dte), no event in the step: median {:.0} ns per call",
        median(samples) * 1e9
    );
    // A master that records every output (FMPy's default) reads them all after each step in
    // one call; the outputs are computed by fmi2DoStep, so this is the reading alone.
    let vr: Vec<u32> = VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Output && v.ty == VarType::Real)
        .filter(|v| !is_energy(v.var))
        .map(|v| v.vr)
        .collect();
    let mut out = vec![0.0; vr.len()];
    let samples: Vec<f64> = (0..reps)
        .map(|_| {
            let n = 1000;
            let t0 = Instant::now();
            for _ in 0..n {
                unsafe { fmi2GetReal(f.c, vr.as_ptr(), vr.len(), out.as_mut_ptr()) };
                std::hint::black_box(&out);
            }
            t0.elapsed().as_secs_f64() / (n * vr.len()) as f64
        })
        .collect();
    println!(
        "fmi2GetReal of all {} Real outputs but the energy account (computed on reading) in one call: median {:.1} ns per variable",
        vr.len(),
        median(samples) * 1e9
    );
}
