//! diffsol 0.18.0 against the FMU's hand-written integrators on the real gear-mesh model
//! (docs/integrators.md has the results and what they mean).
//!
//!   cargo run --release -j1 --manifest-path benches/diffsol-peer/Cargo.toml -- [options]
//!
//! Options:
//!   --reps N          timed repetitions per method and tolerance (default 9; at least 7 advised)
//!   --tols a,b,..     relative tolerances (default 1e-4,1e-5,1e-6,1e-7,1e-8)
//!   --scenes a,b      damped, stiff (default both)
//!   --h-hint          diffsol restarts after an event with the last step size, as our driver
//!                     does (default: diffsol's own starting-step estimate, faster here)
//!   --no-verify       implicit diffsol methods skip the range check of accepted states
//!   --no-explicit-stiff   skip DP5 and Tsit45 on the stiff scene (stability-limited, slow)
//!
//! For every scene and tolerance each method runs once for its counters and its error, then all
//! methods are timed interleaved (repetition-major, so drifting machine load hits all alike) and
//! the median wall time is reported. A run is: build the model, integrate 0..t_end recording dte
//! at every communication point. The error is max_k |dte(t_k) - dte_ref(t_k)| / max_k |dte_ref|,
//! the reference being our DP5 at rel_tol 1e-11. Equal-error ratios interpolate log(time) over
//! log(error) on the other method's curve.
use std::hint::black_box;
use std::time::Instant;

use diffsol_peer::diffsol_method::{DiffsolKind, DiffsolMethod};
use diffsol_peer::method::Method;
use diffsol_peer::peer::{self, MeshRhs, PeerOptions, RunOut, Scene};
use spur_gear_mesh::driver::bdf::Bdf;
use spur_gear_mesh::driver::dopri5::Dopri5;
use spur_gear_mesh::driver::simulation::tolerance;
use spur_gear_mesh::driver::Stats;
use spur_gear_mesh::model::paper_rig::N_CONTROLLED;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params, VarType, VARIABLES};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Who {
    Ours(i32),
    Diffsol(DiffsolKind),
}

impl Who {
    fn name(self) -> &'static str {
        match self {
            Who::Ours(1) => "ours DP5",
            Who::Ours(_) => "ours BDF (diffsol's, our driver)",
            Who::Diffsol(DiffsolKind::Tsit45) => "diffsol Tsit45",
            Who::Diffsol(DiffsolKind::TrBdf2) => "diffsol TR-BDF2",
            Who::Diffsol(DiffsolKind::Esdirk34) => "diffsol ESDIRK34",
            Who::Diffsol(DiffsolKind::Bdf) => "diffsol BDF",
        }
    }
    fn explicit(self) -> bool {
        matches!(self, Who::Ours(1) | Who::Diffsol(DiffsolKind::Tsit45))
    }
    fn run(self, sc: &Scene, rtol: f64, opts: PeerOptions) -> Result<RunOut, String> {
        match self {
            Who::Ours(s) => peer::run_ours(sc, s, rtol),
            Who::Diffsol(k) => peer::run_diffsol(sc, k, rtol, opts),
        }
    }
}

const ALL: [Who; 6] = [
    Who::Ours(1),
    Who::Diffsol(DiffsolKind::Tsit45),
    Who::Ours(2),
    Who::Diffsol(DiffsolKind::TrBdf2),
    Who::Diffsol(DiffsolKind::Esdirk34),
    Who::Diffsol(DiffsolKind::Bdf),
];

/// The damped paper rig: 22/33 teeth, tau_A = 100 N m, c_load = 2 N m s/rad, chi = 10 s/m,
/// running start at 100 rad/s (dte_start = 0), 0.05 s, communication step 1e-4 s.
fn damped() -> Scene {
    Scene {
        name: "damped paper rig".into(),
        params: Params {
            c_load: 2.0,
            chi: 10.0,
            w_A_start: 100.0,
            w_B_start: 100.0 / 1.5,
            ..Params::default()
        },
        inputs: Inputs {
            tau_A: 100.0,
            tau_B: 0.0,
            ..Inputs::default()
        },
        t_end: 0.05,
        dt: 1e-4,
    }
}

/// scenes/stiff.toml: its start values, stop time and output interval; `solver` is set per method.
fn stiff() -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/stiff.toml");
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let scene: toml::Table = text.parse().expect("scene TOML");
    let num = |v: &toml::Value| match v {
        toml::Value::Float(f) => *f,
        toml::Value::Integer(i) => *i as f64,
        x => panic!("not a number: {x}"),
    };
    let (mut params, mut inputs) = (Params::default(), Inputs::default());
    if let Some(toml::Value::Table(sv)) = scene.get("start_values") {
        for (k, x) in sv {
            let info = VARIABLES
                .iter()
                .find(|v| v.name == k)
                .unwrap_or_else(|| panic!("no variable {k}"));
            let ok = match (info.ty, x) {
                (VarType::Real, _) => {
                    params.set_real(info.var, num(x)) || inputs.set_real(info.var, num(x))
                }
                (VarType::Integer, toml::Value::Integer(i)) => {
                    params.set_integer(info.var, *i as i32)
                }
                (VarType::Boolean, toml::Value::Boolean(b)) => params.set_boolean(info.var, *b),
                _ => false,
            };
            assert!(ok, "start value {k} = {x} not settable");
        }
    }
    Scene {
        name: "stiff (scenes/stiff.toml)".into(),
        params,
        inputs,
        t_end: num(&scene["stop_time"]),
        dt: num(&scene["output_interval"]),
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn dte_error(r: &RunOut, reference: &RunOut) -> f64 {
    let scale = reference.dte.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let worst = r
        .dte
        .iter()
        .zip(&reference.dte)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    if r.dte.len() != reference.dte.len() {
        return f64::NAN;
    }
    worst / scale
}

/// One measured point of a method's work-precision curve.
#[derive(Clone, Copy, Debug)]
struct Point {
    rtol: f64,
    err: f64,
    time: f64,
}

/// The curve's lower envelope: points no other point beats in both error and time, by error
/// ascending (time then descends). Error is not monotone in the tolerance here (event timing
/// errors dominate at some tolerances), so the raw points can zig-zag.
fn envelope(curve: &[Point]) -> Vec<Point> {
    let mut c: Vec<Point> = curve
        .iter()
        .copied()
        .filter(|p| p.err > 0.0 && p.err.is_finite())
        .collect();
    c.sort_by(|a, b| a.err.partial_cmp(&b.err).unwrap());
    let mut out: Vec<Point> = Vec::new();
    for p in c {
        if out.last().is_none_or(|q| p.time < q.time) {
            out.push(p);
        }
    }
    out
}

/// log(time) at log(err) on a curve's envelope, by piecewise-linear interpolation; None
/// outside its error range.
fn time_at(curve: &[Point], err: f64) -> Option<f64> {
    let c = envelope(curve);
    if c.len() == 1 && c[0].err == err {
        return Some(c[0].time);
    }
    for w in c.windows(2) {
        let (a, b) = (w[0], w[1]);
        if err >= a.err && err <= b.err {
            let s = (err.ln() - a.err.ln()) / (b.err.ln() - a.err.ln());
            return Some((a.time.ln() + s * (b.time.ln() - a.time.ln())).exp());
        }
    }
    None
}

/// Equal-error comparison of `d` against `o`: time(d)/time(o) at each point of either curve that
/// lies inside the other's error range; if none does, the closest pair in log(error).
fn compare(d: &[Point], o: &[Point]) -> String {
    // (error, ratio, whose point) at every envelope point of either curve inside the other's range
    let mut pts: Vec<(f64, f64, &str, f64)> = Vec::new();
    for p in envelope(d) {
        if let Some(t) = time_at(o, p.err) {
            pts.push((p.err, p.time / t, "its", p.rtol));
        }
    }
    for p in envelope(o) {
        if let Some(t) = time_at(d, p.err) {
            pts.push((p.err, t / p.time, "our", p.rtol));
        }
    }
    pts.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
    let parts: Vec<String> = pts
        .iter()
        .map(|(e, r, who, rtol)| format!("{r:.2} @{e:.1e} ({who} {rtol:.0e})"))
        .collect();
    if parts.is_empty() {
        let mut best: Option<(f64, Point, Point)> = None;
        for a in d {
            for b in o {
                if a.err > 0.0 && b.err > 0.0 && a.err.is_finite() && b.err.is_finite() {
                    let dist = (a.err.ln() - b.err.ln()).abs();
                    if best.is_none_or(|(x, _, _)| dist < x) {
                        best = Some((dist, *a, *b));
                    }
                }
            }
        }
        return match best {
            Some((_, a, b)) => format!(
                "no overlap in error; closest points: {:.2} (err {:.1e} at its rtol {:.0e} vs {:.1e} at our rtol {:.0e})",
                a.time / b.time,
                a.err,
                a.rtol,
                b.err,
                b.rtol
            ),
            None => "no comparable points".into(),
        };
    }
    parts.join("; ")
}

struct Args {
    reps: usize,
    tols: Vec<f64>,
    scenes: Vec<String>,
    opts: PeerOptions,
    explicit_stiff: bool,
}

fn args() -> Args {
    let mut a = Args {
        reps: 9,
        tols: vec![1e-4, 1e-5, 1e-6, 1e-7, 1e-8],
        scenes: vec!["damped".into(), "stiff".into()],
        opts: PeerOptions::default(),
        explicit_stiff: true,
    };
    let v: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < v.len() {
        let opt = v[i].clone();
        let mut val = || {
            i += 1;
            v.get(i).cloned().expect("option needs a value")
        };
        match opt.as_str() {
            "--reps" => a.reps = val().parse().expect("--reps N"),
            "--tols" => {
                a.tols = val()
                    .split(',')
                    .map(|x| x.parse().expect("tolerance"))
                    .collect()
            }
            "--scenes" => a.scenes = val().split(',').map(String::from).collect(),
            "--h-hint" => a.opts.h_hint = true,
            "--no-verify" => a.opts.verify = false,
            "--no-explicit-stiff" => a.explicit_stiff = false,
            x => panic!("unknown option {x} (see the head of src/main.rs)"),
        }
        i += 1;
    }
    a
}

fn bench_scene(sc: &Scene, a: &Args, methods: &[Who]) {
    println!(
        "\n##### {}: t_end {} s, communication step {} s #####",
        sc.name, sc.t_end, sc.dt
    );
    let t0 = Instant::now();
    let reference = peer::run_ours(sc, 1, 1e-11).expect("reference run (ours DP5, rel_tol 1e-11)");
    let dmax = reference.dte.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    println!(
        "reference: ours DP5 at rel_tol 1e-11: {} steps, {} events, max|dte| = {dmax:.4e} m ({:.2} s)",
        reference.steps,
        reference.events,
        t0.elapsed().as_secs_f64()
    );
    let mut curves: Vec<Vec<Point>> = vec![Vec::new(); methods.len()];
    for &rtol in &a.tols {
        println!("\n=== rel_tol {rtol:.0e} ===");
        let mut results: Vec<Option<RunOut>> = Vec::new();
        for &w in methods {
            match w.run(sc, rtol, a.opts) {
                Ok(r) => results.push(Some(r)),
                Err(e) => {
                    println!("{:18} FAILED: {e}", w.name());
                    results.push(None);
                }
            }
        }
        let mut times = vec![Vec::new(); methods.len()];
        for _ in 0..a.reps {
            for (j, &w) in methods.iter().enumerate() {
                if results[j].is_none() {
                    continue;
                }
                let t = Instant::now();
                let r = black_box(w.run(sc, rtol, a.opts));
                times[j].push(t.elapsed().as_secs_f64());
                drop(r);
            }
        }
        println!(
            "{:18} {:>10} {:>10} {:>8} {:>6} {:>8} {:>6} {:>6} {:>6} {:>8} {:>9}",
            "method",
            "median ms",
            "min ms",
            "steps",
            "rej",
            "rhs",
            "jac",
            "LU",
            "events",
            "us/step",
            "dte err"
        );
        for (j, &w) in methods.iter().enumerate() {
            let Some(r) = &results[j] else { continue };
            let min = times[j].iter().cloned().fold(f64::INFINITY, f64::min);
            let med = median(&mut times[j]);
            let err = dte_error(r, &reference);
            curves[j].push(Point {
                rtol,
                err,
                time: med,
            });
            let ev = if r.events == reference.events {
                format!("{}", r.events)
            } else {
                format!("{}!", r.events)
            };
            println!(
                "{:18} {:>10.3} {:>10.3} {:>8} {:>6} {:>8} {:>6} {:>6} {:>6} {:>8.3} {:>9.2e}",
                w.name(),
                med * 1e3,
                min * 1e3,
                r.steps,
                r.rejected,
                r.rhs_evals,
                r.jac_evals,
                r.factorizations,
                ev,
                med * 1e6 / r.steps.max(1) as f64,
                err
            );
        }
    }
    println!(
        "\n--- {}: time(diffsol) / time(ours) at equal dte error (< 1: diffsol faster) ---",
        sc.name
    );
    for (j, &w) in methods.iter().enumerate() {
        let Who::Diffsol(_) = w else { continue };
        for (i, &o) in methods.iter().enumerate() {
            let Who::Ours(_) = o else { continue };
            println!(
                "{:18} vs {:13}: {}",
                w.name(),
                o.name(),
                compare(&curves[j], &curves[i])
            );
        }
    }
}

/// Cost of one restart (what every event costs besides locating it) at a mid-run state of the
/// damped rig: batches of restarts, median over batches.
fn restart_cost(opts: PeerOptions) {
    let sc = damped();
    let rtol = 1e-6;
    let mut p = sc.params.clone();
    p.rel_tol = rtol;
    let mut sim = table::simulation(&p, &sc.inputs, 0.0, rtol).unwrap();
    sim.advance(0.025, &mut |_, _| {}).unwrap();
    let (mesh, y, t) = (sim.rig.clone(), sim.driver.state(), 0.025);
    let tol = tolerance(&mesh, rtol);
    let h = 1e-6;
    let (batch, rounds) = (500, 9);
    let time = |f: &mut dyn FnMut()| {
        let mut v: Vec<f64> = (0..rounds)
            .map(|_| {
                let t0 = Instant::now();
                for _ in 0..batch {
                    f();
                }
                t0.elapsed().as_secs_f64() / batch as f64
            })
            .collect();
        median(&mut v) * 1e6
    };
    println!("\n=== restart cost at a mid-run state of the damped rig (rel_tol {rtol:.0e}), us per restart ===");
    let mut st = Stats::default();
    let mut d = Dopri5::new();
    let us = time(&mut || {
        d.restart(&mesh, black_box(t), black_box(&y), Some(h), &tol, &mut st)
            .unwrap();
        black_box(&d);
    });
    println!("{:18} {us:8.3}", "ours DP5");
    let mut bdf = Bdf::new();
    let us = time(&mut || {
        bdf.restart(&mesh, black_box(t), black_box(&y), Some(h), &tol, &mut st)
            .unwrap();
        black_box(&bdf);
    });
    println!("{:18} {us:8.3}", "ours BDF");
    for kind in [
        DiffsolKind::Tsit45,
        DiffsolKind::TrBdf2,
        DiffsolKind::Esdirk34,
        DiffsolKind::Bdf,
    ] {
        let model = std::rc::Rc::new(MeshRhs {
            mesh: std::cell::RefCell::new(mesh.clone()),
        });
        let mut m = DiffsolMethod::new(kind, model.clone(), rtol, mesh.abs_tol(rtol).to_vec());
        let y4 = &y[..N_CONTROLLED];
        let us = time(&mut || {
            m.restart_with_h(
                &*model,
                black_box(t),
                black_box(y4),
                opts.h_hint.then_some(h),
            );
            black_box(&m);
        });
        let s0 = m.stats().rhs_evals;
        m.restart_with_h(&*model, t, y4, opts.h_hint.then_some(h));
        let rhs = m.stats().rhs_evals - s0;
        println!(
            "{:18} {us:8.3}   ({rhs} RHS evaluations per restart)",
            Who::Diffsol(kind).name()
        );
    }
}

fn main() {
    let a = args();
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    println!(
        "diffsol-peer: diffsol 0.18.0 vs the FMU's DP5 / BDF; {cpu}, {cores} logical CPUs; {} reps, medians; options {:?}",
        a.reps, a.opts
    );
    for s in &a.scenes {
        match s.as_str() {
            "damped" => bench_scene(&damped(), &a, &ALL),
            "stiff" => {
                let m: Vec<Who> = ALL
                    .iter()
                    .copied()
                    .filter(|w| a.explicit_stiff || !w.explicit())
                    .collect();
                bench_scene(&stiff(), &a, &m)
            }
            x => panic!("unknown scene {x}"),
        }
    }
    restart_cost(a.opts);
}
