//! The gear-mesh model behind diffsol, an event loop for the diffsol methods that works like the
//! FMU's driver (src/driver/mod.rs), and the FMU's own driver (`Simulation`) as the other side.
//!
//! Both sides run one scene from t = 0 to t_end and record dte at every communication point
//! t_k = k dt. Neither restarts at communication points (the scenes have constant inputs): the
//! FMU's driver steps across them and interpolates, and so does the loop here.
use std::cell::RefCell;
use std::rc::Rc;

use spur_gear_mesh::driver::System;
use spur_gear_mesh::model::contact::N_EVENTS;
use spur_gear_mesh::model::paper_rig::{DTE, N_CONTROLLED};
use spur_gear_mesh::model::{PaperRig, State, NY};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

use crate::diffsol_method::{DiffsolKind, DiffsolMethod};
use crate::method::{Method, Rhs};

/// A scene: parameters, inputs (constant over the run), end time and communication step.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub params: Params,
    pub inputs: Inputs,
    pub t_end: f64,
    pub dt: f64,
}

impl Scene {
    pub fn n_comm(&self) -> usize {
        (self.t_end / self.dt - 1e-9).ceil().max(1.0) as usize
    }
    /// The communication points as tools/run_scene.rs makes them.
    pub fn t_k(&self, k: usize) -> f64 {
        (k as f64 * self.dt).min(self.t_end)
    }
}

/// What one run returns: dte at t_0 .. t_n and the work counters.
#[derive(Clone, Debug, Default)]
pub struct RunOut {
    pub dte: Vec<f64>,
    pub steps: u64,
    pub rejected: u64,
    pub rhs_evals: u64,
    pub jac_evals: u64,
    pub factorizations: u64,
    pub events: u64,
    pub restarts: u64,
}

/// Our methods: the FMU's driver through `Simulation`, solver 1 = DP5, 2 = BDF (diffsol's).
pub fn run_ours(sc: &Scene, solver: i32, rtol: f64) -> Result<RunOut, String> {
    let mut p = sc.params.clone();
    p.solver = solver;
    p.rel_tol = rtol;
    let mut sim = table::simulation(&p, &sc.inputs, 0.0, rtol).map_err(|e| e.to_string())?;
    sim.set_stop_time(sc.t_end);
    let n = sc.n_comm();
    let mut dte = Vec::with_capacity(n + 1);
    dte.push(sim.driver.state()[DTE]);
    for k in 1..=n {
        sim.advance(sc.t_k(k), &mut |_, _| {})
            .map_err(|e| e.to_string())?;
        dte.push(sim.driver.state()[DTE]);
    }
    let st = sim.driver.stats;
    Ok(RunOut {
        dte,
        steps: st.steps,
        rejected: st.rejected,
        rhs_evals: st.rhs_evals,
        jac_evals: st.jac_evals,
        factorizations: st.factorizations,
        events: st.events,
        restarts: st.events + 1,
    })
}

/// The mesh as diffsol sees it: the four controlled states (theta_A, dte, w_A, w_B). The two
/// quadratures (external work, dissipated energy) do not feed back and are under no error control
/// in the FMU either; leaving them out saves diffsol two vector lanes, a small advantage to it.
/// The modes live in the `PaperRig` and change only in `handle_event`, between restarts.
pub struct MeshRhs {
    pub mesh: RefCell<PaperRig>,
}

pub fn full(y: &[f64]) -> State {
    let mut s = [0.0; NY];
    s[..N_CONTROLLED].copy_from_slice(&y[..N_CONTROLLED]);
    s
}

impl Rhs for MeshRhs {
    fn dim(&self) -> usize {
        N_CONTROLLED
    }
    fn eval(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), ()> {
        let mut d = [0.0; NY];
        self.mesh.borrow().rhs(&full(y), &mut d).map_err(|_| ())?;
        dy.copy_from_slice(&d[..N_CONTROLLED]);
        Ok(())
    }
}

/// Options of the diffsol side.
#[derive(Clone, Copy, Debug)]
pub struct PeerOptions {
    /// After an event, start with the step size of the step that found it (as our driver does)
    /// instead of diffsol's own starting-step estimate. Off by default: diffsol's estimate
    /// measured faster here (its implicit methods 10-30 % faster on both scenes).
    pub h_hint: bool,
    /// Implicit methods: evaluate f at every accepted y so that a Newton iterate outside the
    /// contact law's range is never accepted (one more RHS evaluation per step).
    pub verify: bool,
}

impl Default for PeerOptions {
    fn default() -> Self {
        PeerOptions {
            h_hint: false,
            verify: true,
        }
    }
}

/// An event found in the last step.
#[derive(Clone, Copy, Debug)]
pub struct Pending {
    pub t: f64,
    pub index: usize,
}

/// The FMU driver's event location (Driver::locate, src/driver/mod.rs), on any dense output:
/// margins at the end point and the midpoint of the last step, then Illinois regula falsi on the
/// dense output for each function that crossed; the earliest wins.
pub fn locate(
    sys: &PaperRig,
    t0: f64,
    t1: f64,
    y1: &State,
    interp: &dyn Fn(f64) -> State,
) -> Option<Pending> {
    let tm = 0.5 * (t0 + t1);
    let n = System::n_events(sys);
    let (mut end, mut mid) = ([0.0; N_EVENTS], [0.0; N_EVENTS]);
    let (end, mid) = (&mut end[..n], &mut mid[..n]);
    System::event_margins(sys, y1, end);
    if end.iter().all(|&m| m >= 0.0) {
        System::event_margins(sys, &interp(tm), mid);
        if mid.iter().all(|&m| m >= 0.0) {
            return None;
        }
    } else {
        System::event_margins(sys, &interp(tm), mid);
    }
    let mut best: Option<Pending> = None;
    for i in 0..n {
        let (b, fb) = if mid[i] < 0.0 {
            (tm, mid[i])
        } else if end[i] < 0.0 {
            (t1, end[i])
        } else {
            continue;
        };
        let a = if b == tm { t0 } else { tm };
        let fa = if b == tm {
            System::margin(sys, i, &interp(t0)).max(0.0)
        } else {
            mid[i]
        };
        let t = root(sys, i, a, fa, b, fb, interp);
        if best.is_none_or(|e| t < e.t) {
            best = Some(Pending { t, index: i });
        }
    }
    best
}

/// Driver::root: a time at which margin i has crossed, within a few ulp of the root.
fn root(
    sys: &PaperRig,
    i: usize,
    mut a: f64,
    mut fa: f64,
    mut b: f64,
    mut fb: f64,
    interp: &dyn Fn(f64) -> State,
) -> f64 {
    let mut side = 0;
    for _ in 0..200 {
        if b - a <= 4.0 * f64::EPSILON * b.abs().max(1e-300) {
            break;
        }
        let mut c = (a * fb - b * fa) / (fb - fa);
        if !(c > a && c < b) {
            c = 0.5 * (a + b);
        }
        let fc = System::margin(sys, i, &interp(c));
        if fc < 0.0 {
            b = c;
            fb = fc;
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        } else {
            a = c;
            fa = fc;
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        }
    }
    b
}

/// Builds the model and a diffsol method for a scene, started at t = 0.
pub fn start_diffsol(
    sc: &Scene,
    kind: DiffsolKind,
    rtol: f64,
    opts: PeerOptions,
) -> Result<(Rc<MeshRhs>, DiffsolMethod), String> {
    let (mesh, y0) = table::paper_rig(&sc.params, &sc.inputs).map_err(|e| e.to_string())?;
    let atol = mesh.abs_tol(rtol).to_vec();
    let model = Rc::new(MeshRhs {
        mesh: RefCell::new(mesh),
    });
    let mut m = DiffsolMethod::new(kind, model.clone(), rtol, atol);
    m.verify_accepted &= opts.verify;
    m.restart(&*model, 0.0, &y0[..N_CONTROLLED]);
    Ok((model, m))
}

/// A diffsol method on a scene, with the FMU driver's step limit (System::max_step: a quarter of
/// a base pitch of contact travel; for Tsit45 also 2/omega_n, the explicit stability limit) and
/// its event handling: after every accepted step the event margins are checked, the earliest
/// crossing is located on diffsol's dense output, the mode changes (PaperRig::handle_event) and the
/// method restarts there.
///
/// diffsol has no maximum step size option: the limit is imposed as a stop time t + h_max, which
/// diffsol meets by shrinking the step (BDF rescales its history, keeping the order).
pub fn run_diffsol(
    sc: &Scene,
    kind: DiffsolKind,
    rtol: f64,
    opts: PeerOptions,
) -> Result<RunOut, String> {
    let (model, mut m) = start_diffsol(sc, kind, rtol, opts)?;
    // Tsit45 gets Dormand-Prince 5(4)'s limit: both are explicit pairs of order 5.
    let stability =
        (kind == DiffsolKind::Tsit45).then_some(spur_gear_mesh::driver::dopri5::STABILITY);
    let n = sc.n_comm();
    let mut dte = Vec::with_capacity(n + 1);
    dte.push(m.y()[DTE]);
    let (mut events, mut restarts) = (0u64, 1u64);
    let mut buf = [0.0; N_CONTROLLED];
    let mut k = 1;
    while k <= n {
        let t = m.t();
        let h_max = model.mesh.borrow().max_step(&full(m.y()), stability);
        let t_limit = (t + h_max).min(sc.t_end);
        let t_new = m.step(&*model, t_limit)?;
        if t_new <= t || t_new.is_nan() {
            return Err(format!("no progress at t = {t}"));
        }
        let ev = {
            let mesh = model.mesh.borrow();
            let y1 = full(m.y());
            mesh.check_state(&y1)
                .map_err(|e| format!("at t = {t_new}: {e}"))?;
            let interp = |tt: f64| {
                let mut b = [0.0; N_CONTROLLED];
                m.interpolate(tt, &mut b);
                full(&b)
            };
            locate(&mesh, m.t_prev(), t_new, &y1, &interp)
        };
        let t_hi = ev.map_or(t_new, |e| e.t);
        while k <= n && sc.t_k(k) <= t_hi {
            m.interpolate(sc.t_k(k), &mut buf);
            dte.push(buf[DTE]);
            k += 1;
        }
        if let Some(e) = ev {
            m.interpolate(e.t, &mut buf);
            model
                .mesh
                .borrow_mut()
                .handle_event(e.index, &mut full(&buf))
                .map_err(|err| format!("event at t = {}: {err}", e.t))?;
            events += 1;
            let h = opts.h_hint.then(|| m.h());
            m.restart_with_h(&*model, e.t, &buf, h);
            restarts += 1;
        }
    }
    let st = m.stats();
    Ok(RunOut {
        dte,
        steps: st.steps,
        rejected: st.rejected,
        rhs_evals: st.rhs_evals,
        jac_evals: st.jac_evals,
        factorizations: st.factorizations,
        events,
        restarts,
    })
}
