//! Runs a scene (`scenes/<name>.toml`) in-process for timing, the way a co-simulation master
//! would: inputs interpolated from the scene's input CSV at every communication point t_k and
//! held over the step, one step per output interval, the compared outputs read after every step.
//! Repeats the run, prints the median wall time and the integrator's counters as one JSON line,
//! and writes the output trace (the reference's columns, one row per communication point).
//!
//! Integrators:
//! - `--integrator fmu` (default): the FMU's own driver, `solver` and `rel_tol` from the scene or
//!   from `--solver` / `--rtol`; `--api rust` steps `Simulation` directly, `--api c` goes through
//!   the exported C functions (fmi2Instantiate ... fmi2DoStep, fmi2GetReal) like a master would.
//! - `--integrator rk4 --substeps N` or `--integrator euler --substeps N`: a naive peer of the
//!   kind simple co-simulation FMUs use, on the same model (`PaperRig::rhs`): N fixed substeps per
//!   communication step and no event location; the contact modes are updated from the state at
//!   the start of every substep (every event function found past its zero is handled there), so
//!   the right-hand side is non-smooth inside a substep.
//!
//! Usage:
//!   cargo run --release --example run_scene -- scenes/damped.toml [--solver 1|2] [--rtol 1e-6]
//!       [--integrator fmu|rk4|euler] [--substeps N] [--api rust|c] [--reps 5]
//!       [--set name=value ...] [--stop-time T] [--output-interval DT] [--trace out.csv]
//!       [--outputs theta_A,w_A,w_B,dte,n_fwd,n_bwd | all]
//!
//! `--log-events` prints every located event to stderr (`--integrator fmu --api rust`).
//! `--outputs` are the variables read after every communication step (fmi2GetReal/-Integer in
//! one call each with `--api c`) and written to the trace; `all` is the reference's columns.
//!
//! Used by tools/work_precision.py (docs/performance.md).

use spur_gear_mesh::fmi::exports::*;
use spur_gear_mesh::fmi::outputs::{outputs, write};
use spur_gear_mesh::fmi::{CallbackFunctions, Component, Status};
use spur_gear_mesh::model::{Loads, PaperRig, State, NY};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Outputs, Params, Var, VarType, GUID, VARIABLES};
use std::ffi::CString;
use std::io::Write;
use std::time::Instant;

/// The reference's columns (tests/reference/<scene>.csv).
const COLUMNS: [&str; 16] = [
    "theta_A",
    "theta_B",
    "w_A",
    "w_B",
    "dte",
    "F_f1",
    "F_f2",
    "F_b1",
    "F_b2",
    "F_fwd",
    "F_bwd",
    "n_fwd",
    "n_bwd",
    "tau_mesh_A",
    "tau_mesh_B",
    "P_loss",
];
const NCOL: usize = COLUMNS.len();
type Row = [f64; NCOL + 1];

/// CPU time of the calling thread [s] (clock_gettime(CLOCK_THREAD_CPUTIME_ID)): on a machine
/// shared with other work it leaves out the time the thread waited for a core.
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

/// Wall-clock and CPU time since a start.
struct Clock(Instant, f64);

impl Clock {
    fn start() -> Clock {
        Clock(Instant::now(), thread_cpu_time())
    }
    fn elapsed(&self) -> (f64, f64) {
        (self.0.elapsed().as_secs_f64(), thread_cpu_time() - self.1)
    }
}

fn var(name: &str) -> Var {
    VARIABLES
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable named {name}"))
        .var
}

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
        VarType::Integer => Value::Int(s.parse().expect("an integer value")),
        VarType::Boolean => Value::Bool(matches!(s, "true" | "1")),
        VarType::String => Value::Str(s.to_owned()),
    }
}

fn toml_value(v: Var, x: &toml::Value) -> Value {
    match (v.info().ty, x) {
        (VarType::Real, toml::Value::Float(f)) => Value::Real(*f),
        (VarType::Real, toml::Value::Integer(i)) => Value::Real(*i as f64),
        (VarType::Integer, toml::Value::Integer(i)) => Value::Int(*i as i32),
        (VarType::Boolean, toml::Value::Boolean(b)) => Value::Bool(*b),
        (VarType::Boolean, toml::Value::Integer(i)) => Value::Bool(*i != 0),
        (VarType::String, toml::Value::String(t)) => Value::Str(t.clone()),
        _ => panic!("start value of {} has the wrong type: {x}", v.info().name),
    }
}

/// Piecewise-linear input table in FMPy's CSV format; a repeated time is a step, and at the step
/// time itself the value after the step applies (the master holds it over the following step),
/// as in the reference (gearmesh_ref.InputTable). FMPy's co-simulation loop differs there: its
/// `input.apply(time)` (after_event = False) takes the value before the step, so FMPy applies a
/// step in the table one communication step later.
struct InputTable {
    t: Vec<f64>,
    cols: Vec<(Var, Vec<f64>)>,
}

impl InputTable {
    fn read(path: &std::path::Path) -> InputTable {
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
            .map(|(i, h)| (var(h), rows.iter().map(|r| r[i]).collect()))
            .collect();
        InputTable { t, cols }
    }

    fn at(&self, t: f64, col: &[f64]) -> f64 {
        let ts = &self.t;
        // Within rounding of a break point counts as at it (t_k = k dt in floating point).
        let eps = 1e-9 * (ts[ts.len() - 1] - ts[0]).abs().max(1e-300);
        // Last row with time <= t (the after-step value), then interpolate to the next row.
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

    fn apply(&self, t: f64, inputs: &mut Inputs) {
        for (v, col) in &self.cols {
            inputs.set_real(*v, self.at(t, col));
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Integrator {
    Fmu,
    Rk4,
    Euler,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Api {
    Rust,
    C,
}

struct Config {
    scene: String,
    params: Params,
    inputs: Inputs,
    starts: Vec<(Var, Value)>,
    table: Option<InputTable>,
    stop_time: f64,
    dt: f64,
    integrator: Integrator,
    substeps: usize,
    api: Api,
    reps: usize,
    trace: Option<String>,
    log_events: bool,
}

#[derive(Default, Clone)]
struct Counters {
    steps: u64,
    rejected: u64,
    rhs: u64,
    jacobians: u64,
    factorizations: u64,
    events: u64,
    mode_updates: u64,
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

/// The columns read after every step (`--outputs`), a subset of COLUMNS.
static SELECTED: std::sync::OnceLock<Vec<Var>> = std::sync::OnceLock::new();

fn column_vars() -> &'static [Var] {
    SELECTED.get().expect("columns selected")
}

fn outputs_row(t: f64, o: &spur_gear_mesh::variables::Outputs) -> Row {
    let mut r = [0.0; NCOL + 1];
    r[0] = t;
    for (j, &v) in column_vars().iter().enumerate() {
        r[j + 1] = o
            .get_real(v)
            .or_else(|| o.get_integer(v).map(|i| i as f64))
            .unwrap();
    }
    r
}

fn loads_of(mesh: &PaperRig, inputs: &Inputs) -> Loads {
    Loads {
        tau_a: inputs.tau_A,
        tau_b: inputs.tau_B,
        alpha_housing: inputs.alpha_housing,
        a_housing_x: inputs.a_housing_x,
        ..mesh.loads
    }
}

/// The FMU's driver through the Rust API. After every step it computes the outputs as the FMU
/// does after fmi2DoStep (`outputs::write`: the energy account only when read, here at the end).
fn run_rust(c: &Config, rows: &mut Vec<Row>) -> RunResult {
    let ts = grid(c);
    let mut inputs = c.inputs.clone();
    if let Some(tab) = &c.table {
        tab.apply(0.0, &mut inputs);
    }
    let start = Clock::start();
    let mut sim = table::simulation(&c.params, &inputs, 0.0, c.params.rel_tol).expect("scene");
    sim.set_stop_time(c.stop_time);
    let mut o = Outputs::default();
    write(&sim, &mut o).unwrap();
    rows.push(outputs_row(0.0, &o));
    let mut error = None;
    for k in 0..ts.len() - 1 {
        if let Some(tab) = &c.table {
            tab.apply(ts[k], &mut inputs);
            sim.set_loads(loads_of(&sim.rig, &inputs), None);
        }
        let log_events = c.log_events;
        let advanced = sim.advance(ts[k + 1], &mut |t, r| {
            if log_events {
                eprintln!("event t = {t:.12} s: {}", r.what);
            }
        });
        if let Err(e) = advanced {
            error = Some(e.to_string());
            break;
        }
        match write(&sim, &mut o) {
            Ok(()) => rows.push(outputs_row(ts[k + 1], &o)),
            Err(e) => {
                error = Some(e.to_string());
                break;
            }
        }
    }
    let (wall, cpu) = start.elapsed();
    let st = &sim.driver.stats;
    let energy_residual = outputs(&sim).map(|o| o.energy_residual).unwrap_or(f64::NAN);
    RunResult {
        counters: Counters {
            steps: st.steps,
            rejected: st.rejected,
            rhs: st.rhs_evals,
            jacobians: st.jac_evals,
            factorizations: st.factorizations,
            events: st.events,
            mode_updates: 0,
        },
        error,
        wall,
        cpu,
        energy_residual,
    }
}

/// The FMU through its exported C functions, in-process.
fn run_c(c: &Config, rows: &mut Vec<Row>) -> RunResult {
    let ts = grid(c);
    let name = CString::new(c.scene.as_str()).unwrap();
    let guid = CString::new(GUID).unwrap();
    let cb = CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    };
    let real_vr: Vec<u32> = column_vars()
        .iter()
        .filter(|v| v.info().ty == VarType::Real)
        .map(|v| v.info().vr)
        .collect();
    let int_vr: Vec<u32> = column_vars()
        .iter()
        .filter(|v| v.info().ty == VarType::Integer)
        .map(|v| v.info().vr)
        .collect();
    let input_vr: Vec<(u32, Var)> = c
        .table
        .as_ref()
        .map(|t| t.cols.iter().map(|(v, _)| (v.info().vr, *v)).collect())
        .unwrap_or_default();
    let is_real: Vec<bool> = column_vars()
        .iter()
        .map(|v| v.info().ty == VarType::Real)
        .collect();
    let mut re = vec![0.0; real_vr.len()];
    let mut it = vec![0i32; int_vr.len()];
    let mut error = None;
    let mut counters = Counters::default();
    let mut energy_residual = f64::NAN;
    let mut inputs = c.inputs.clone();
    let start = Clock::start();
    unsafe {
        let comp: Component =
            fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), std::ptr::null(), &cb, 0, 0);
        assert!(!comp.is_null());
        for (v, x) in &c.starts {
            let vr = v.info().vr;
            let s = match x {
                Value::Real(x) => fmi2SetReal(comp, &vr, 1, x),
                Value::Int(x) => fmi2SetInteger(comp, &vr, 1, x),
                Value::Bool(x) => fmi2SetBoolean(comp, &vr, 1, &(*x as i32)),
                Value::Str(x) => {
                    let text = std::ffi::CString::new(x.as_str()).expect("no NUL in a start value");
                    fmi2SetString(comp, &vr, 1, &text.as_ptr())
                }
            };
            assert_eq!(s, Status::Ok, "setting {}", v.info().name);
        }
        let set_inputs = |comp: Component, t: f64, inputs: &mut Inputs| {
            if let Some(tab) = &c.table {
                tab.apply(t, inputs);
                for (vr, v) in &input_vr {
                    let x = inputs.get_real(*v).unwrap();
                    assert_eq!(fmi2SetReal(comp, vr, 1, &x), Status::Ok);
                }
            }
        };
        set_inputs(comp, 0.0, &mut inputs);
        assert_eq!(
            fmi2SetupExperiment(comp, 0, 0.0, 0.0, 1, c.stop_time),
            Status::Ok
        );
        assert_eq!(fmi2EnterInitializationMode(comp), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(comp), Status::Ok);
        let read = |comp: Component, t: f64, re: &mut Vec<f64>, it: &mut Vec<i32>| -> Row {
            if !real_vr.is_empty() {
                fmi2GetReal(comp, real_vr.as_ptr(), real_vr.len(), re.as_mut_ptr());
            }
            if !int_vr.is_empty() {
                fmi2GetInteger(comp, int_vr.as_ptr(), int_vr.len(), it.as_mut_ptr());
            }
            let (mut ir, mut ii) = (0, 0);
            let mut r = [0.0; NCOL + 1];
            r[0] = t;
            for (j, &real) in is_real.iter().enumerate() {
                r[j + 1] = if real {
                    ir += 1;
                    re[ir - 1]
                } else {
                    ii += 1;
                    it[ii - 1] as f64
                };
            }
            r
        };
        rows.push(read(comp, 0.0, &mut re, &mut it));
        for k in 0..ts.len() - 1 {
            set_inputs(comp, ts[k], &mut inputs);
            let s = fmi2DoStep(comp, ts[k], ts[k + 1] - ts[k], 1);
            if s != Status::Ok {
                error = Some(format!("fmi2DoStep at t = {} returned {s:?}", ts[k]));
                break;
            }
            rows.push(read(comp, ts[k + 1], &mut re, &mut it));
        }
        let (wall, cpu) = start.elapsed();
        let cvr: Vec<u32> = [
            Var::n_steps,
            Var::n_rejected_steps,
            Var::n_rhs_evaluations,
            Var::n_jacobians,
            Var::n_factorizations,
            Var::n_events,
        ]
        .iter()
        .map(|v| v.info().vr)
        .collect();
        let mut cv = [0i32; 6];
        fmi2GetInteger(comp, cvr.as_ptr(), 6, cv.as_mut_ptr());
        counters.steps = cv[0] as u64;
        counters.rejected = cv[1] as u64;
        counters.rhs = cv[2] as u64;
        counters.jacobians = cv[3] as u64;
        counters.factorizations = cv[4] as u64;
        counters.events = cv[5] as u64;
        let evr = Var::energy_residual.info().vr;
        fmi2GetReal(comp, &evr, 1, &mut energy_residual);
        fmi2FreeInstance(comp);
        RunResult {
            counters,
            error,
            wall,
            cpu,
            energy_residual,
        }
    }
}

/// The naive peer: fixed substeps, no event location, modes from the state at each substep start.
struct Naive {
    rig: PaperRig,
    y: State,
    scheme: Integrator,
    counters: Counters,
}

impl Naive {
    /// The outputs at the state, with the energy account only if asked (as the FMU).
    fn outputs(&self, energy: bool) -> Result<Outputs, String> {
        let r = self.rig.readout(&self.y).map_err(|e| e.to_string())?;
        let mut o = Outputs::default();
        spur_gear_mesh::fmi::outputs::assemble(
            &r,
            &Default::default(),
            &Default::default(),
            &mut o,
        );
        if energy {
            let e = self.rig.energy(&self.y).map_err(|e| e.to_string())?;
            (o.E_kin, o.E_el, o.energy_residual) = (e.e_kin, e.e_el, e.residual);
        }
        Ok(o)
    }

    fn f(&mut self, y: &State) -> Result<State, String> {
        let mut dy = [0.0; NY];
        self.counters.rhs += 1;
        self.rig.rhs(y, &mut dy).map_err(|e| e.to_string())?;
        Ok(dy)
    }

    /// Every event function past its zero is handled at the current state (no location).
    fn update_modes(&mut self) -> Result<(), String> {
        use spur_gear_mesh::model::contact::N_EVENTS;
        let mut m = [0.0; N_EVENTS];
        for _ in 0..4 * N_EVENTS {
            self.rig.event_margins(&self.y, &mut m);
            match m.iter().position(|&x| x < 0.0) {
                Some(i) => {
                    self.rig
                        .handle_event(i, &mut self.y)
                        .map_err(|e| e.to_string())?;
                    self.counters.events += 1;
                }
                None => return Ok(()),
            }
        }
        Err("contact modes do not settle".into())
    }

    fn advance(&mut self, h: f64, n: usize) -> Result<(), String> {
        for _ in 0..n {
            self.update_modes()?;
            self.counters.mode_updates += 1;
            let y = self.y;
            let axpy = |a: &State, s: f64, k: &State| -> State {
                std::array::from_fn(|i| a[i] + s * k[i])
            };
            self.y = match self.scheme {
                Integrator::Euler => {
                    let k1 = self.f(&y)?;
                    axpy(&y, h, &k1)
                }
                _ => {
                    let k1 = self.f(&y)?;
                    let k2 = self.f(&axpy(&y, 0.5 * h, &k1))?;
                    let k3 = self.f(&axpy(&y, 0.5 * h, &k2))?;
                    let k4 = self.f(&axpy(&y, h, &k3))?;
                    std::array::from_fn(|i| {
                        y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
                    })
                }
            };
            self.counters.steps += 1;
            if !self.y.iter().all(|x| x.is_finite()) {
                return Err("non-finite state".into());
            }
            self.rig.check_state(&self.y).map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}

fn run_naive(c: &Config, rows: &mut Vec<Row>) -> RunResult {
    let ts = grid(c);
    let mut inputs = c.inputs.clone();
    if let Some(tab) = &c.table {
        tab.apply(0.0, &mut inputs);
    }
    let start = Clock::start();
    let (rig, y) = table::paper_rig(&c.params, &inputs).expect("scene");
    let mut nv = Naive {
        rig,
        y,
        scheme: c.integrator,
        counters: Counters::default(),
    };
    rows.push(outputs_row(0.0, &nv.outputs(false).unwrap()));
    let mut error = None;
    for k in 0..ts.len() - 1 {
        if let Some(tab) = &c.table {
            tab.apply(ts[k], &mut inputs);
            let l = loads_of(&nv.rig, &inputs);
            nv.rig.set_loads(l, &mut nv.y);
        }
        let h = (ts[k + 1] - ts[k]) / c.substeps as f64;
        if let Err(e) = nv.advance(h, c.substeps) {
            error = Some(format!("at t = {}: {e}", ts[k]));
            break;
        }
        // A master reads the outputs with the modes as they stand at the communication point.
        if let Err(e) = nv.update_modes() {
            error = Some(format!("at t = {}: {e}", ts[k + 1]));
            break;
        }
        match nv.outputs(false) {
            Ok(o) => rows.push(outputs_row(ts[k + 1], &o)),
            Err(e) => {
                error = Some(e.to_string());
                break;
            }
        }
    }
    let (wall, cpu) = start.elapsed();
    let energy_residual = nv
        .outputs(true)
        .map(|o| o.energy_residual)
        .unwrap_or(f64::NAN);
    RunResult {
        counters: nv.counters,
        error,
        wall,
        cpu,
        energy_residual,
    }
}

/// One run; its trace goes to `rows` (cleared first). The buffer is reused from run to run: a
/// fresh one of over 128 kB each time was mapped anew, and its page faults were up to 9 % of a
/// timed run (perf), none of it the integrator's work.
fn run(c: &Config, rows: &mut Vec<Row>) -> RunResult {
    rows.clear();
    match (c.integrator, c.api) {
        (Integrator::Fmu, Api::Rust) => run_rust(c, rows),
        (Integrator::Fmu, Api::C) => run_c(c, rows),
        _ => run_naive(c, rows),
    }
}

fn write_trace(path: &str, rows: &[Row]) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).expect("trace file"));
    let n = column_vars().len();
    let head: Vec<String> = std::iter::once("time")
        .chain(column_vars().iter().map(|v| v.info().name))
        .map(|n| format!("\"{n}\""))
        .collect();
    writeln!(f, "{}", head.join(",")).unwrap();
    for r in rows {
        let cells: Vec<String> = r[..=n].iter().map(|x| format!("{x:e}")).collect();
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

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut scene_path = None;
    let (mut solver, mut rtol, mut stop, mut dt) =
        (None::<i32>, None::<f64>, None::<f64>, None::<f64>);
    let (mut integrator, mut substeps, mut api, mut reps) = (Integrator::Fmu, 1, Api::Rust, 5);
    let mut sets: Vec<(String, String)> = vec![];
    let mut trace = None;
    let mut log_events = false;
    let mut outputs = "theta_A,w_A,w_B,dte,n_fwd,n_bwd".to_string();
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
            "--substeps" => substeps = val().parse().unwrap(),
            "--reps" => reps = val().parse().unwrap(),
            "--trace" => trace = Some(val()),
            "--outputs" => outputs = val(),
            "--log-events" => log_events = true,
            "--integrator" => {
                integrator = match val().as_str() {
                    "fmu" => Integrator::Fmu,
                    "rk4" => Integrator::Rk4,
                    "euler" => Integrator::Euler,
                    x => panic!("unknown integrator {x}"),
                }
            }
            "--api" => {
                api = match val().as_str() {
                    "rust" => Api::Rust,
                    "c" => Api::C,
                    x => panic!("unknown api {x}"),
                }
            }
            "--set" => {
                let kv = val();
                let (k, v) = kv.split_once('=').expect("--set name=value");
                sets.push((k.into(), v.into()));
            }
            x if !x.starts_with("--") => scene_path = Some(x.to_string()),
            x => panic!("unknown option {x}"),
        }
        i += 1;
    }
    let scene_path = scene_path.expect("usage: run_scene <scene.toml> [options]");
    let cols: Vec<Var> = if outputs == "all" {
        COLUMNS.iter().map(|n| var(n)).collect()
    } else {
        outputs.split(',').map(|n| var(n.trim())).collect()
    };
    assert!(cols.len() <= NCOL, "at most {NCOL} output columns");
    SELECTED.set(cols).unwrap();
    let text = std::fs::read_to_string(&scene_path).expect("scene file");
    let scene: toml::Table = text.parse().expect("scene TOML");
    let num = |k: &str| match &scene[k] {
        toml::Value::Float(f) => *f,
        toml::Value::Integer(i) => *i as f64,
        x => panic!("{k} = {x}"),
    };
    let mut starts: Vec<(Var, Value)> = vec![];
    if let Some(toml::Value::Table(sv)) = scene.get("start_values") {
        for (k, x) in sv {
            let v = var(k);
            starts.push((v, toml_value(v, x)));
        }
    }
    for (k, x) in &sets {
        let v = var(k);
        starts.push((v, parse_value(v, x)));
    }
    if let Some(s) = solver {
        starts.push((Var::solver, Value::Int(s)));
    }
    if let Some(r) = rtol {
        starts.push((Var::rel_tol, Value::Real(r)));
    }
    let (mut params, mut inputs) = (Params::default(), Inputs::default());
    for (v, x) in &starts {
        let ok = match *x {
            Value::Real(x) => params.set_real(*v, x) || inputs.set_real(*v, x),
            Value::Int(x) => params.set_integer(*v, x),
            Value::Bool(x) => params.set_boolean(*v, x),
            Value::Str(ref x) => params.set_string(*v, x.clone()),
        };
        assert!(ok, "{} is not a settable parameter or input", v.info().name);
    }
    let dir = std::path::Path::new(&scene_path).parent().unwrap();
    let table = scene
        .get("input_file")
        .and_then(|f| f.as_str())
        .map(|f| InputTable::read(&dir.join(f)));
    let scene_name = std::path::Path::new(&scene_path)
        .file_stem()
        .unwrap()
        .to_string_lossy()
        .to_string();
    let c = Config {
        scene: scene_name,
        params,
        inputs,
        starts,
        table,
        stop_time: stop.unwrap_or_else(|| num("stop_time")),
        dt: dt.unwrap_or_else(|| num("output_interval")),
        integrator,
        substeps,
        api,
        reps,
        trace,
        log_events,
    };
    // Room for the whole trace, touched once before the timed runs.
    let mut rows: Vec<Row> = vec![[0.0; NCOL + 1]; grid(&c).len()];
    let results: Vec<RunResult> = (0..c.reps.max(1)).map(|_| run(&c, &mut rows)).collect();
    let mut walls: Vec<f64> = results.iter().map(|r| r.wall).collect();
    walls.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let median = walls[walls.len() / 2];
    let mut cpus: Vec<f64> = results.iter().map(|r| r.cpu).collect();
    cpus.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let cpu_median = cpus[cpus.len() / 2];
    let last = results.last().unwrap();
    if let Some(path) = &c.trace {
        write_trace(path, &rows);
    }
    let t_reached = rows.last().map_or(0.0, |r| r[0]);
    let cn = &last.counters;
    let method = match c.integrator {
        Integrator::Fmu => format!("solver{}", c.params.solver),
        Integrator::Rk4 => format!("rk4x{}", c.substeps),
        Integrator::Euler => format!("eulerx{}", c.substeps),
    };
    let fields: Vec<(&str, String)> = vec![
        ("scene", json_str(&c.scene)),
        ("method", json_str(&method)),
        ("api", json_str(if c.api == Api::C { "c" } else { "rust" })),
        ("rel_tol", json_num(c.params.rel_tol)),
        ("substeps", c.substeps.to_string()),
        ("backward_contacts", c.params.backward_contacts.to_string()),
        ("stop_time", json_num(c.stop_time)),
        ("output_interval", json_num(c.dt)),
        ("t_reached", json_num(t_reached)),
        ("comm_steps", (rows.len().saturating_sub(1)).to_string()),
        ("reps", c.reps.to_string()),
        ("wall_median_s", json_num(median)),
        ("wall_min_s", json_num(walls[0])),
        ("wall_max_s", json_num(walls[walls.len() - 1])),
        ("cpu_median_s", json_num(cpu_median)),
        ("cpu_min_s", json_num(cpus[0])),
        ("sim_s_per_wall_s", json_num(t_reached / median)),
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
