//! Runs a gear-train scene in-process for timing, the train's counterpart of
//! examples/run_scene.rs (the single mesh): the FMU's own `Slave` (`SpurGearTrain`, the code
//! behind fmi2DoStep and fmi2GetReal, without the C shim) stepped as a co-simulation master
//! would: inputs from the scene's input CSV at every communication point t_k, held over the
//! step, one step per output interval, the outputs read after every step. Repeats the run,
//! prints the medians of the thread's CPU time and of wall time and the integrator's counters as
//! one JSON line, and writes the output trace (one row per communication point).
//!
//! The scene's start values come on the command line (`--set name=value`, as `fmpy simulate
//! --start-values` takes them; tools/work_precision.py reads `scenes/train/<scene>.toml` and passes
//! them), so this example needs no TOML parser:
//!
//!   cargo run --release -p spur_gear_train --example run_train_scene -- \
//!       --set n_bodies=2 --set 'body[1].J=0.4' ... --stop-time 0.1 --output-interval 1e-4 \
//!       [--input-file scenes/train/rattle.input.csv] [--solver 1|2|3] [--rtol 1e-6] \
//!       [--reps 5] [--trace out.csv] [--outputs 'body[1].w,mesh[1].dte,...']
//!
//! `--outputs` defaults to the reference's columns (`tests/reference/train/<scene>.csv` of a trace
//! scene, train_ref.output_names): every body's theta and w, every shaft's tau, every mesh's
//! dte, F_fwd, F_bwd, n_fwd, n_bwd, F_f1, F_f2, F_b1, F_b2, P_loss, then the energies.
//!
//! Input table semantics are run_scene's (and train_ref.TrainInputs'): piecewise linear, a
//! repeated time is a step, at the step time the value after it.
//!
//! Used by tools/work_precision.py (docs/performance.md, section "Gear trains").

use fmi2_slave::logging::Logger;
use fmi2_slave::Slave;
use spur_gear_train::instance::SpurGearTrain;
use spur_gear_train::variables::{Var, VarType, LOG_CATEGORIES};
use std::io::Write;
use std::time::Instant;

/// CPU time of the calling thread [s] (clock_gettime(CLOCK_THREAD_CPUTIME_ID)), as run_scene.
fn thread_cpu_time() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: a valid pointer to a timespec; the clock id is Linux's.
    let rc = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc == 0 {
        ts.sec as f64 + 1e-9 * ts.nsec as f64
    } else {
        f64::NAN
    }
}

fn var(name: &str) -> Var {
    Var::from_name(name).unwrap_or_else(|| panic!("no train variable named {name}"))
}

/// A start value, typed by the variable table.
#[derive(Clone, Debug)]
enum Value {
    Real(f64),
    Int(i32),
    Bool(bool),
    Str(String),
}

fn parse_value(v: Var, s: &str) -> Value {
    match v.info().ty {
        VarType::Real => Value::Real(s.parse().expect("a real value")),
        VarType::Integer => Value::Int(
            s.parse::<i32>()
                .or_else(|_| s.parse::<f64>().map(|x| x as i32))
                .expect("an integer value"),
        ),
        VarType::Boolean => Value::Bool(matches!(s, "true" | "1")),
        VarType::String => Value::Str(s.to_owned()),
    }
}

/// run_scene's InputTable on the train's variables (body[i].tau).
struct InputTable {
    t: Vec<f64>,
    cols: Vec<(u32, Vec<f64>)>,
}

impl InputTable {
    fn read(path: &str) -> InputTable {
        let text = std::fs::read_to_string(path).expect("input CSV");
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let head: Vec<String> = lines
            .next()
            .unwrap()
            .split(',')
            .map(|h| h.trim().trim_matches('"').to_string())
            .collect();
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|x| x.trim().parse().unwrap()).collect())
            .collect();
        let it = head
            .iter()
            .position(|h| h == "time")
            .expect("a time column");
        let t = rows.iter().map(|r| r[it]).collect();
        let cols = head
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != it)
            .map(|(i, h)| (var(h).info().vr, rows.iter().map(|r| r[i]).collect()))
            .collect();
        InputTable { t, cols }
    }

    fn at(&self, t: f64, col: &[f64]) -> f64 {
        let ts = &self.t;
        let eps = 1e-9 * (ts[ts.len() - 1] - ts[0]).abs().max(1e-300);
        let i = match ts.iter().rposition(|&x| x <= t + eps) {
            Some(i) => i,
            None => return col[0],
        };
        if i + 1 >= ts.len() {
            return col[i];
        }
        let (t0, t1) = (ts[i], ts[i + 1]);
        let w = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        col[i] + w * (col[i + 1] - col[i])
    }

    /// Sets every column's value at t (fmi2SetReal of all inputs in one call).
    fn apply(&self, s: &mut SpurGearTrain, t: f64, running: bool) -> Result<(), String> {
        let vrs: Vec<u32> = self.cols.iter().map(|(vr, _)| *vr).collect();
        let xs: Vec<f64> = self.cols.iter().map(|(_, c)| self.at(t, c)).collect();
        s.set_real(&vrs, &xs, running).map_err(|f| f.message)
    }
}

struct Config {
    starts: Vec<(Var, Value)>,
    table: Option<InputTable>,
    stop_time: f64,
    dt: f64,
    outputs: Option<Vec<String>>,
}

#[derive(Default, Clone)]
struct Counters {
    steps: i32,
    rejected: i32,
    rhs: i32,
    jacobians: i32,
    factorizations: i32,
    events: i32,
}

struct RunResult {
    counters: Counters,
    error: Option<String>,
    wall: f64,
    cpu: f64,
    energy_residual: f64,
}

fn grid(c: &Config) -> Vec<f64> {
    let n = (c.stop_time / c.dt - 1e-9).ceil().max(1.0) as usize;
    (0..=n)
        .map(|k| (k as f64 * c.dt).min(c.stop_time))
        .collect()
}

/// The reference's columns for the train's counts (train_ref.output_names without time);
/// `general`: a planetary train (the housing named, a carrier, or a loop), which has
/// housing.tau too.
fn default_columns(nb: i32, ns: i32, nm: i32, general: bool) -> Vec<String> {
    let mut names = vec![];
    for i in 1..=nb {
        names.push(format!("body[{i}].theta"));
        names.push(format!("body[{i}].w"));
    }
    for j in 1..=ns {
        names.push(format!("shaft[{j}].tau"));
    }
    for m in 1..=nm {
        for v in [
            "dte", "F_fwd", "F_bwd", "n_fwd", "n_bwd", "F_f1", "F_f2", "F_b1", "F_b2", "P_loss",
        ] {
            names.push(format!("mesh[{m}].{v}"));
        }
    }
    if general {
        names.push("housing.tau".into());
    }
    for v in [
        "E_kin",
        "E_el",
        "E_gate",
        "W_ext",
        "W_loss",
        "energy_residual",
    ] {
        names.push(v.to_string());
    }
    names
}

fn set_start(s: &mut SpurGearTrain, v: Var, x: &Value) -> Result<(), String> {
    let vr = [v.info().vr];
    match x {
        Value::Real(x) => s.set_real(&vr, &[*x], false),
        Value::Int(x) => s.set_integer(&vr, &[*x], false),
        Value::Bool(x) => s.set_boolean(&vr, &[*x as i32], false),
        Value::Str(x) => s.set_string(&vr, std::slice::from_ref(x), false),
    }
    .map_err(|f| format!("{} = {x:?}: {}", v.info().name, f.message))
}

/// The columns' variables and whether each is Real (else Integer).
fn columns(names: &[String]) -> Vec<(u32, bool)> {
    names
        .iter()
        .map(|n| {
            let i = var(n).info();
            (i.vr, i.ty == VarType::Real)
        })
        .collect()
}

fn read_row(
    s: &mut SpurGearTrain,
    t: f64,
    cols: &[(u32, bool)],
    row: &mut Vec<f64>,
) -> Result<(), String> {
    row.clear();
    row.push(t);
    for &(vr, real) in cols {
        let x = if real {
            s.get_real(vr)
        } else {
            s.get_integer(vr).map(f64::from)
        };
        row.push(x.map_err(|f| f.message)?);
    }
    Ok(())
}

/// One run through the Slave; the trace goes to `rows` (its row buffers reused from run to run,
/// as run_scene reuses its buffer: fresh allocations are no part of the FMU's work).
fn run(c: &Config, names: &[String], rows: &mut Vec<Vec<f64>>, logger: &Logger) -> RunResult {
    let ts = grid(c);
    let cols = columns(names);
    let mut used = 0;
    let mut error = None;
    let start = (Instant::now(), thread_cpu_time());
    let mut s = SpurGearTrain::fresh();
    let setup = (|| -> Result<(), String> {
        for (v, x) in &c.starts {
            set_start(&mut s, *v, x)?;
        }
        if let Some(tab) = &c.table {
            tab.apply(&mut s, 0.0, false)?;
        }
        s.setup_experiment(None, 0.0, Some(c.stop_time))
            .map_err(|f| f.message)?;
        s.enter_initialization().map_err(|f| f.message)?;
        s.exit_initialization().map_err(|f| f.message)
    })();
    let mut next_row = |s: &mut SpurGearTrain, t: f64, rows: &mut Vec<Vec<f64>>| {
        if used == rows.len() {
            rows.push(Vec::with_capacity(cols.len() + 1));
        }
        used += 1;
        read_row(s, t, &cols, &mut rows[used - 1])
    };
    match setup.and_then(|()| next_row(&mut s, 0.0, rows)) {
        Err(e) => error = Some(e),
        Ok(()) => {
            for k in 0..ts.len() - 1 {
                if let Some(tab) = &c.table {
                    if let Err(e) = tab.apply(&mut s, ts[k], true) {
                        error = Some(e);
                        break;
                    }
                }
                if let Err(f) = s.do_step(ts[k], ts[k + 1] - ts[k], logger) {
                    error = Some(format!("fmi2DoStep at t = {}: {}", ts[k], f.message));
                    break;
                }
                if let Err(e) = next_row(&mut s, ts[k + 1], rows) {
                    error = Some(e);
                    break;
                }
            }
        }
    }
    let wall = start.0.elapsed().as_secs_f64();
    let cpu = thread_cpu_time() - start.1;
    rows.truncate(used);
    let int = |s: &mut SpurGearTrain, n: &str| s.get_integer(var(n).info().vr).unwrap_or(-1);
    let counters = Counters {
        steps: int(&mut s, "n_steps"),
        rejected: int(&mut s, "n_rejected_steps"),
        rhs: int(&mut s, "n_rhs_evaluations"),
        jacobians: int(&mut s, "n_jacobians"),
        factorizations: int(&mut s, "n_factorizations"),
        events: int(&mut s, "n_events"),
    };
    let energy_residual = s
        .get_real(var("energy_residual").info().vr)
        .unwrap_or(f64::NAN);
    RunResult {
        counters,
        error,
        wall,
        cpu,
        energy_residual,
    }
}

fn write_trace(path: &str, names: &[String], rows: &[Vec<f64>]) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).expect("trace file"));
    let head: Vec<String> = std::iter::once("time")
        .chain(names.iter().map(String::as_str))
        .map(|n| format!("\"{n}\""))
        .collect();
    writeln!(f, "{}", head.join(",")).unwrap();
    for r in rows {
        let cells: Vec<String> = r.iter().map(|x| format!("{x:e}")).collect();
        writeln!(f, "{}", cells.join(",")).unwrap();
    }
}

fn json_str(s: &str) -> String {
    let mut out = String::from("\"");
    for ch in s.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn json_num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:e}")
    } else {
        "null".into()
    }
}

fn median(mut xs: Vec<f64>) -> (f64, f64, f64) {
    xs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    (xs[xs.len() / 2], xs[0], xs[xs.len() - 1])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut solver, mut rtol, mut stop, mut dt) =
        (None::<i32>, None::<f64>, None::<f64>, None::<f64>);
    let (mut reps, mut trace, mut input_file, mut outputs) = (5usize, None, None, None);
    let mut sets: Vec<(String, String)> = vec![];
    let mut i = 0;
    while i < args.len() {
        let a = args[i].as_str();
        let mut val = || {
            i += 1;
            args.get(i)
                .cloned()
                .unwrap_or_else(|| panic!("{a} needs a value"))
        };
        match a {
            "--solver" => solver = Some(val().parse().unwrap()),
            "--rtol" => rtol = Some(val().parse().unwrap()),
            "--stop-time" => stop = Some(val().parse().unwrap()),
            "--output-interval" => dt = Some(val().parse().unwrap()),
            "--reps" => reps = val().parse().unwrap(),
            "--trace" => trace = Some(val()),
            "--input-file" => input_file = Some(val()),
            "--outputs" => {
                outputs = Some(
                    val()
                        .split(',')
                        .map(|s| s.trim().to_string())
                        .filter(|s| !s.is_empty())
                        .collect::<Vec<_>>(),
                )
            }
            "--set" => {
                let kv = val();
                let (k, v) = kv.split_once('=').expect("--set name=value");
                sets.push((k.trim().into(), v.trim().into()));
            }
            x => panic!("unknown argument {x} (see the header of run_train_scene.rs)"),
        }
        i += 1;
    }
    let mut starts: Vec<(Var, Value)> = sets
        .iter()
        .map(|(k, x)| {
            let v = var(k);
            (v, parse_value(v, x))
        })
        .collect();
    if let Some(s) = solver {
        starts.push((Var::solver, Value::Int(s)));
    }
    if let Some(r) = rtol {
        starts.push((Var::rel_tol, Value::Real(r)));
    }
    let c = Config {
        starts,
        table: input_file.as_deref().map(InputTable::read),
        stop_time: stop.expect("--stop-time"),
        dt: dt.expect("--output-interval"),
        outputs,
    };
    // The columns: given, or the reference's for the train's counts (read from the parameters).
    let names = c.outputs.clone().unwrap_or_else(|| {
        let mut s = SpurGearTrain::fresh();
        for (v, x) in &c.starts {
            set_start(&mut s, *v, x).expect("start value");
        }
        let n = |s: &mut SpurGearTrain, k: &str| s.get_integer(var(k).info().vr).unwrap();
        let (nb, ns, nm) = (
            n(&mut s, "n_bodies"),
            n(&mut s, "n_shafts"),
            n(&mut s, "n_meshes"),
        );
        let named_housing = (1..=nm).any(|m| {
            n(&mut s, &format!("mesh[{m}].A")) == 0 || n(&mut s, &format!("mesh[{m}].B")) == 0
        }) || (1..=ns).any(|j| {
            n(&mut s, &format!("shaft[{j}].a")) == 0 || n(&mut s, &format!("shaft[{j}].b")) == 0
        });
        let carried = (1..=nb).any(|i| n(&mut s, &format!("body[{i}].carrier")) != 0);
        let general = named_housing || carried || ns + nm > nb - 1;
        default_columns(nb, ns, nm, general)
    });
    let logger = Logger::new(
        None,
        std::ptr::null_mut(),
        "run_train_scene",
        LOG_CATEGORIES,
        false,
    );
    // Room for the whole trace, touched once before the timed runs.
    let mut rows: Vec<Vec<f64>> = (0..grid(&c).len())
        .map(|_| vec![0.0; names.len() + 1])
        .collect();
    let results: Vec<RunResult> = (0..reps.max(1))
        .map(|_| run(&c, &names, &mut rows, &logger))
        .collect();
    let (wall, wall_min, wall_max) = median(results.iter().map(|r| r.wall).collect());
    let (cpu, cpu_min, _) = median(results.iter().map(|r| r.cpu).collect());
    let last = results.last().unwrap();
    if let Some(path) = &trace {
        write_trace(path, &names, &rows);
    }
    let t_reached = rows.last().map_or(0.0, |r| r[0]);
    let (sv, rt) = {
        let mut s = SpurGearTrain::fresh();
        for (v, x) in &c.starts {
            set_start(&mut s, *v, x).expect("start value");
        }
        (
            s.get_integer(Var::solver.info().vr).unwrap(),
            s.get_real(Var::rel_tol.info().vr).unwrap(),
        )
    };
    let cn = &last.counters;
    let fields: Vec<(&str, String)> = vec![
        ("scene", json_str("train")),
        ("method", json_str(&format!("solver{sv}"))),
        ("api", json_str("slave")),
        ("rel_tol", json_num(rt)),
        ("stop_time", json_num(c.stop_time)),
        ("output_interval", json_num(c.dt)),
        ("t_reached", json_num(t_reached)),
        ("comm_steps", rows.len().saturating_sub(1).to_string()),
        ("reps", reps.to_string()),
        ("wall_median_s", json_num(wall)),
        ("wall_min_s", json_num(wall_min)),
        ("wall_max_s", json_num(wall_max)),
        ("cpu_median_s", json_num(cpu)),
        ("cpu_min_s", json_num(cpu_min)),
        ("sim_s_per_wall_s", json_num(t_reached / wall)),
        ("n_steps", cn.steps.to_string()),
        ("n_rejected_steps", cn.rejected.to_string()),
        ("n_rhs_evaluations", cn.rhs.to_string()),
        ("n_jacobians", cn.jacobians.to_string()),
        ("n_factorizations", cn.factorizations.to_string()),
        ("n_events", cn.events.to_string()),
        ("energy_residual", json_num(last.energy_residual)),
        (
            "error",
            last.error.as_deref().map_or("null".into(), json_str),
        ),
    ];
    let body: Vec<String> = fields
        .iter()
        .map(|(k, v)| format!("\"{k}\": {v}"))
        .collect();
    println!("{{{}}}", body.join(", "));
}
