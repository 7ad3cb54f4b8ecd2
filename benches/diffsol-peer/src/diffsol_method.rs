//! diffsol 0.18.0 (`diffsol = "=0.18.0"`) behind our `Method` trait: Tsit45, TR-BDF2, ESDIRK34, BDF.
//!
//! Why it looks the way it does:
//! * diffsol's solvers borrow their problem (`Bdf<'a, ..>` holds `&'a OdeSolverProblem`), and the
//!   problem owns the RHS closure. So (a) the problem and solver must live together in one
//!   self-referential value, done safely with the `self_cell` crate (no `unsafe` here, no leaking);
//!   (b) the closure cannot borrow the per-call `&dyn Rhs`: it holds an `Rc<dyn Rhs>` given to
//!   `DiffsolMethod::new`. The loop keeps the modes inside that same model object (`peer::MeshRhs`
//!   holds the `PaperRig` in a `RefCell`) and changes them only between restarts. The `rhs` argument of the trait methods must be that
//!   same object (checked by `debug_assert`); it is otherwise unused.
//! * `restart` keeps the problem (closures, tolerances, Jacobian statistics) and rebuilds only the
//!   solver, with `t0`/`y0` changed: cheap, and it drops all history, Jacobians and LU factors
//!   from the previous mode.
//! * diffsol closures cannot return errors. An `Err` from `Rhs::eval` is written as NaN. diffsol on
//!   its own does NOT reject such steps reliably (its error norm is combined with `f64::max`, which
//!   ignores NaN, so an explicit RK step with a NaN stage is *accepted*), so every step is checked
//!   here: non-finite y or dy (and, for the implicit methods, an `Err` at the accepted y) makes us
//!   roll the solver back to the previous accepted point and retry with 0.3x the step.
//! * Implicit methods get a finite-difference Jacobian (our `Rhs` has no Jacobian), with f(y)
//!   cached so a dense Jacobian costs n+1 evaluations, not 2n.
//! * Stop times: `step(t_limit)` sets diffsol's stop time only when t_limit changes (diffsol
//!   forgets it once reached, and errors if it is at the current time). A t_limit closer than
//!   `min_timestep` (1e-13) counts as reached without a step: BDF keeps the tiny h of such a step
//!   and then fails with StepSizeTooSmall.
//! * After `step` returns Err the solver is at the last accepted point; call `restart` before
//!   stepping again.
//! * Not `Send` (Rc, boxed closures). Moving the whole method between threads is harmless at the
//!   FFI level because every Rc clone moves with it; for a `Send` type use Arc/atomics instead.
use std::cell::{Cell, RefCell};
use std::rc::Rc;

use diffsol::{
    Bdf, Closure, ConstantClosure, DiffsolError, ExplicitRk, NalgebraLU, NalgebraMat, NalgebraVec,
    OdeBuilder, OdeEquations, OdeSolverEquations, OdeSolverMethod, OdeSolverProblem,
    OdeSolverStopReason, Op, Sdirk, UnitCallable, Vector,
};
use self_cell::self_cell;

use crate::method::{Method, Rhs, Stats};

type M = NalgebraMat<f64>;
type V = NalgebraVec<f64>;
type LS = NalgebraLU<f64>;
// Boxed closures give the problem a nameable, 'static type (self_cell needs both).
type RhsFn = Box<dyn Fn(&[f64], &[f64], f64, &mut [f64])>;
type JacFn = Box<dyn Fn(&[f64], &[f64], f64, &[f64], &mut [f64])>;
type InitFn = Box<dyn Fn(&[f64], f64, &mut [f64])>;
type Unit = UnitCallable<M>;
type Eqn = OdeSolverEquations<
    M,
    Closure<M, RhsFn, JacFn>,
    ConstantClosure<M, InitFn>,
    Unit,
    Unit,
    Unit,
    Unit,
>;
type Problem = OdeSolverProblem<Eqn>;

// Lives inside self_cell's single heap allocation, so the variant size difference is harmless.
#[allow(clippy::large_enum_variant)]
enum Solver<'a> {
    Erk(ExplicitRk<'a, Eqn>),
    Sdirk(Sdirk<'a, Eqn, LS>),
    Bdf(Bdf<'a, Eqn, LS>),
}

self_cell!(
    struct SolverCell {
        owner: Problem,
        #[not_covariant]
        dependent: Solver,
    }
);

/// Run the same generic code on whichever solver is inside.
macro_rules! dispatch {
    ($solver:expr, $s:ident => $body:expr) => {
        match $solver {
            Solver::Erk($s) => $body,
            Solver::Sdirk($s) => $body,
            Solver::Bdf($s) => $body,
        }
    };
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiffsolKind {
    Tsit45,
    TrBdf2,
    Esdirk34,
    Bdf,
}

impl DiffsolKind {
    fn is_implicit(self) -> bool {
        self != DiffsolKind::Tsit45
    }
}

/// Everything the closures inside the diffsol problem need. No back-reference to the problem
/// or the solver, so there is no Rc cycle.
struct Shared {
    model: Rc<dyn Rhs>,
    /// y at the restart point; read by the problem's `init` closure when the state is built.
    y0: RefCell<Vec<f64>>,
    rhs_evals: Cell<u64>,
    /// Per-component magnitude below which a component counts as "small" (atol/rtol); sets the FD increment.
    fd_scale: Vec<f64>,
    fd: RefCell<FdCache>,
}

struct FdCache {
    valid: bool,
    t: f64,
    x: Vec<f64>,
    fx: Vec<f64>,
    xp: Vec<f64>,
    fp: Vec<f64>,
}

impl Shared {
    /// The RHS as diffsol sees it: an Err becomes NaN, which our step check then rejects.
    fn eval_poison(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.rhs_evals.set(self.rhs_evals.get() + 1);
        if self.model.eval(t, y, dy).is_err() {
            dy.fill(f64::NAN);
        }
    }

    fn eval_ok(&self, t: f64, y: &[f64], dy: &mut [f64]) -> bool {
        self.rhs_evals.set(self.rhs_evals.get() + 1);
        self.model.eval(t, y, dy).is_ok()
    }

    /// J(x) v by forward differences (backward if x + s v is outside the model's range).
    /// diffsol builds a dense Jacobian by calling this with the unit vectors e_0..e_{n-1} at the
    /// same (t, x), so f(x) is cached.
    fn jac_mul(&self, x: &[f64], t: f64, v: &[f64], out: &mut [f64]) {
        let mut guard = self.fd.borrow_mut();
        let c = &mut *guard;
        if !(c.valid && c.t == t && c.x.as_slice() == x) {
            c.t = t;
            c.x.copy_from_slice(x);
            self.eval_poison(t, x, &mut c.fx);
            c.valid = true;
        }
        let vmax = v.iter().fold(0.0f64, |m, vi| m.max(vi.abs()));
        if vmax == 0.0 {
            out.fill(0.0);
            return;
        }
        let mut s = 0.0f64;
        for i in 0..x.len() {
            s = s.max(x[i].abs().max(self.fd_scale[i]) * v[i].abs());
        }
        let s = f64::EPSILON.sqrt() * s / (vmax * vmax);
        for sign in [1.0, -1.0] {
            for i in 0..x.len() {
                c.xp[i] = x[i] + sign * s * v[i];
            }
            if self.eval_ok(t, &c.xp, &mut c.fp) {
                for ((o, fp), fx) in out.iter_mut().zip(&c.fp).zip(&c.fx) {
                    *o = sign * (fp - fx) / s;
                }
                return;
            }
        }
        out.fill(0.0); // both sides outside the range: an approximate Newton matrix is still usable
    }
}

/// What we report through the trait, kept outside the solver so that `y()` can hand out a slice.
struct Track {
    t: f64,
    t_prev: f64,
    /// diffsol's own times of the last two accepted points (t may be snapped onto t_limit).
    t_int: f64,
    t_int_prev: f64,
    y: Vec<f64>,
    y_prev: Vec<f64>,
    dy: Vec<f64>,
    tstop: Option<f64>,
    steps: u64,
    rollbacks: u64,
}

pub struct DiffsolMethod {
    kind: DiffsolKind,
    rtol: f64,
    atol: Vec<f64>,
    /// Evaluate f at every accepted y of the implicit methods (one extra RHS call per step), so that
    /// a Newton iterate outside the model's range is never accepted. Explicit RK does not need it:
    /// its FSAL stage already evaluates f at the accepted y.
    pub verify_accepted: bool,
    /// Max. roll-backs (Err/NaN steps) in a row before `step` gives up.
    pub max_rollbacks: u32,
    shared: Rc<Shared>,
    cell: Option<SolverCell>,
    spare: Option<Problem>,
    error: Option<String>,
    tr: Track,
    base: Stats,
    scratch: RefCell<V>,
}

impl DiffsolMethod {
    /// `model` must be the object the driver passes as `rhs` to the trait methods.
    pub fn new(kind: DiffsolKind, model: Rc<dyn Rhs>, rtol: f64, atol: Vec<f64>) -> Self {
        let n = model.dim();
        assert_eq!(atol.len(), n, "one atol per state");
        let fd_scale = atol.iter().map(|a| a / rtol).collect();
        let shared = Rc::new(Shared {
            model,
            y0: RefCell::new(vec![0.0; n]),
            rhs_evals: Cell::new(0),
            fd_scale,
            fd: RefCell::new(FdCache {
                valid: false,
                t: 0.0,
                x: vec![0.0; n],
                fx: vec![0.0; n],
                xp: vec![0.0; n],
                fp: vec![0.0; n],
            }),
        });
        Self {
            kind,
            rtol,
            atol,
            verify_accepted: kind.is_implicit(),
            max_rollbacks: 30,
            shared,
            cell: None,
            spare: None,
            error: Some("restart() not called yet".into()),
            tr: Track {
                t: 0.0,
                t_prev: 0.0,
                t_int: 0.0,
                t_int_prev: 0.0,
                y: vec![0.0; n],
                y_prev: vec![0.0; n],
                dy: vec![0.0; n],
                tstop: None,
                steps: 0,
                rollbacks: 0,
            },
            base: Stats::default(),
            scratch: RefCell::new(V::zeros(n, Default::default())),
        }
    }

    pub fn kind(&self) -> DiffsolKind {
        self.kind
    }

    /// The step size the solver proposes next (0 before the first restart).
    pub fn h(&self) -> f64 {
        self.cell.as_ref().map_or(0.0, |c| {
            c.with_dependent(|_, s| dispatch!(s, s => s.state().h))
        })
    }

    /// `restart`, then start with the step size `h` instead of diffsol's own estimate (Hairer's
    /// starting-step heuristic, which costs one more RHS evaluation): what our driver does after
    /// an event, where it keeps the step size of the step that found the event.
    pub fn restart_with_h(&mut self, rhs: &dyn Rhs, t: f64, y: &[f64], h: Option<f64>) {
        Method::restart(self, rhs, t, y);
        if let (Some(h), Some(cell)) = (h, self.cell.as_mut()) {
            if h.is_finite() && h > 0.0 {
                cell.with_dependent_mut(|_, s| dispatch!(s, s => *s.state_mut().h = h));
            }
        }
    }

    fn build_problem(&self) -> Result<Problem, DiffsolError> {
        let n = self.atol.len();
        let (s1, s2, s3) = (
            self.shared.clone(),
            self.shared.clone(),
            self.shared.clone(),
        );
        let rhs: RhsFn = Box::new(move |x, _p, t, y| s1.eval_poison(t, x, y));
        let jac: JacFn = Box::new(move |x, _p, t, v, y| s2.jac_mul(x, t, v, y));
        let init: InitFn = Box::new(move |_p, _t, y| y.copy_from_slice(&s3.y0.borrow()));
        let mut problem = OdeBuilder::<M>::new()
            .rtol(self.rtol)
            .atol(self.atol.iter().copied())
            .rhs_implicit(rhs, jac)
            .init(init, n)
            .build()?;
        // The Newton-failure limit counts over the solver's whole life, not per step (default 50).
        problem.ode_options.max_nonlinear_solver_failures = usize::MAX / 2;
        Ok(problem)
    }

    fn solver_stats(&self) -> Stats {
        let Some(cell) = self.cell.as_ref() else {
            return Stats::default();
        };
        let s = cell.with_dependent(|_, s| dispatch!(s, s => s.get_statistics().clone()));
        Stats {
            steps: 0,
            rejected: (s.number_of_error_test_failures + s.number_of_nonlinear_solver_fails) as u64,
            rhs_evals: 0,
            jac_evals: 0,
            factorizations: if self.kind.is_implicit() {
                s.number_of_linear_solver_setups as u64
            } else {
                0
            },
        }
    }
}

fn build_solver<'a>(kind: DiffsolKind, p: &'a Problem) -> Result<Solver<'a>, DiffsolError> {
    Ok(match kind {
        DiffsolKind::Tsit45 => Solver::Erk(p.tsit45()?),
        DiffsolKind::TrBdf2 => Solver::Sdirk(p.tr_bdf2::<LS>()?),
        DiffsolKind::Esdirk34 => Solver::Sdirk(p.esdirk34::<LS>()?),
        DiffsolKind::Bdf => Solver::Bdf(p.bdf::<LS>()?),
    })
}

fn finite(v: &V) -> bool {
    v.batch_as_slice(0).iter().all(|x| x.is_finite())
}

/// One accepted step of any diffsol solver, with the stop-time and Err/NaN handling.
fn step_solver<'a, S: OdeSolverMethod<'a, Eqn>>(
    s: &mut S,
    tr: &mut Track,
    shared: &Shared,
    t_limit: f64,
    verify: bool,
    max_rollbacks: u32,
) -> Result<f64, String> {
    // diffsol refuses a stop time within 100 eps (|t|+|h|) of t ("StopTimeAtCurrentTime"), and a
    // step shorter than min_timestep (1e-13) to reach a stop time leaves that tiny h in the solver:
    // BDF then fails its next step with StepSizeTooSmall. So a t_limit that close counts as reached
    // without stepping (the state is then reported at t_limit but is from <= 1e-13 earlier).
    let h = s.state().h;
    let min_step = s.problem().ode_options.min_timestep;
    let troundoff = 100.0 * f64::EPSILON * (tr.t_int.abs() + h.abs());
    if t_limit - tr.t_int <= troundoff.max(min_step) {
        tr.t = t_limit;
        return Ok(t_limit);
    }
    if tr.tstop != Some(t_limit) {
        s.set_stop_time(t_limit)
            .map_err(|e| format!("set_stop_time({t_limit}): {e}"))?;
        tr.tstop = Some(t_limit);
    }
    let mut rollbacks = 0;
    loop {
        let reason = s
            .step()
            .map_err(|e| format!("diffsol step from t={}: {e}", tr.t_int))?;
        let st = s.state();
        let t_new = st.t;
        let mut ok = finite(st.y) && finite(st.dy);
        if ok && verify {
            let mut fd = shared.fd.borrow_mut(); // reuse its buffers as scratch
            ok = shared.eval_ok(t_new, st.y.batch_as_slice(0), &mut fd.fp);
        }
        if ok {
            tr.t_prev = tr.t;
            tr.t_int_prev = tr.t_int;
            tr.t_int = t_new;
            std::mem::swap(&mut tr.y, &mut tr.y_prev);
            tr.y.copy_from_slice(st.y.batch_as_slice(0));
            tr.dy.copy_from_slice(st.dy.batch_as_slice(0));
            tr.steps += 1;
            tr.t = if reason == OdeSolverStopReason::TstopReached {
                tr.tstop = None; // diffsol forgets the stop time once reached
                t_limit // diffsol's t may be 1 ulp off t_limit; report t_limit exactly
            } else {
                t_new
            };
            return Ok(tr.t);
        }
        // Roll back to the last accepted point and retry with a smaller step. For BDF this restarts
        // at order 1 (state_mut marks the state modified); for RK it just resets y, dy, t, h.
        // Rolled back even when giving up, so the solver never sits on a NaN state.
        let h_retry = 0.3 * (t_new - tr.t_int);
        {
            let sm = s.state_mut();
            sm.y.batch_as_mut_slice(0).copy_from_slice(&tr.y);
            sm.dy.batch_as_mut_slice(0).copy_from_slice(&tr.dy);
            *sm.t = tr.t_int;
            *sm.h = h_retry;
        }
        rollbacks += 1;
        tr.rollbacks += 1;
        if rollbacks > max_rollbacks {
            return Err(format!(
                "model range error (Err/NaN) persists after {max_rollbacks} step reductions at t={}",
                tr.t_int
            ));
        }
        // explicit RK checks min_timestep only after error-test failures, so an Err that keeps
        // coming back would otherwise shrink h forever
        if h_retry.abs() < min_step.max(16.0 * f64::EPSILON * tr.t_int.abs()) {
            return Err(format!(
                "model range error (Err/NaN): step size {h_retry:e} too small at t={}",
                tr.t_int
            ));
        }
        // A reached stop time is forgotten by diffsol, so set it again.
        s.set_stop_time(t_limit)
            .map_err(|e| format!("set_stop_time({t_limit}): {e}"))?;
        tr.tstop = Some(t_limit);
    }
}

impl Method for DiffsolMethod {
    fn restart(&mut self, rhs: &dyn Rhs, t: f64, y: &[f64]) {
        debug_assert!(
            std::ptr::addr_eq(rhs as *const dyn Rhs, Rc::as_ptr(&self.shared.model)),
            "DiffsolMethod: rhs must be the model object given to DiffsolMethod::new"
        );
        let _ = rhs;
        // Fold the old solver's counters into the totals, then keep only its problem.
        let old = self.solver_stats();
        self.base.rejected += old.rejected;
        self.base.factorizations += old.factorizations;
        let mut problem = match self
            .cell
            .take()
            .map(SolverCell::into_owner)
            .or(self.spare.take())
        {
            Some(p) => p,
            None => match self.build_problem() {
                Ok(p) => p,
                Err(e) => {
                    self.error = Some(format!("building diffsol problem: {e}"));
                    return;
                }
            },
        };
        problem.t0 = t;
        self.shared.y0.borrow_mut().copy_from_slice(y);
        self.shared.fd.borrow_mut().valid = false; // cached f(x) belongs to the old mode
        let kind = self.kind;
        match SolverCell::try_new_or_recover(problem, |p| build_solver(kind, p)) {
            Ok(cell) => {
                let dy = cell.with_dependent(
                    |_, s| dispatch!(s, s => s.state().dy.batch_as_slice(0).to_vec()),
                );
                self.cell = Some(cell);
                self.error = None;
                let tr = &mut self.tr;
                tr.t = t;
                tr.t_prev = t;
                tr.t_int = t;
                tr.t_int_prev = t;
                tr.y.copy_from_slice(y);
                tr.y_prev.copy_from_slice(y);
                tr.dy.copy_from_slice(&dy);
                tr.tstop = None;
            }
            Err((p, e)) => {
                self.spare = Some(p);
                self.error = Some(format!("creating diffsol solver at t={t}: {e}"));
            }
        }
    }

    fn step(&mut self, rhs: &dyn Rhs, t_limit: f64) -> Result<f64, String> {
        debug_assert!(std::ptr::addr_eq(
            rhs as *const dyn Rhs,
            Rc::as_ptr(&self.shared.model)
        ));
        let _ = rhs;
        if let Some(e) = &self.error {
            return Err(e.clone());
        }
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // also rejects a NaN t_limit
        if !(t_limit > self.tr.t) {
            return Err(format!(
                "step: t_limit {t_limit} is not after t {}",
                self.tr.t
            ));
        }
        let (verify, maxrb) = (self.verify_accepted, self.max_rollbacks);
        let (tr, shared) = (&mut self.tr, &*self.shared);
        let cell = self.cell.as_mut().expect("no error implies a solver");
        cell.with_dependent_mut(
            |_, s| dispatch!(s, s => step_solver(s, tr, shared, t_limit, verify, maxrb)),
        )
    }

    fn t(&self) -> f64 {
        self.tr.t
    }
    fn t_prev(&self) -> f64 {
        self.tr.t_prev
    }
    fn y(&self) -> &[f64] {
        &self.tr.y
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) {
        let tr = &self.tr;
        if t >= tr.t_int || tr.t_int == tr.t_int_prev {
            out.copy_from_slice(&tr.y);
            return;
        }
        if t <= tr.t_int_prev {
            out.copy_from_slice(&tr.y_prev);
            return;
        }
        let Some(cell) = self.cell.as_ref() else {
            out.copy_from_slice(&tr.y);
            return;
        };
        let mut v = self.scratch.borrow_mut();
        let r = cell.with_dependent(|_, s| dispatch!(s, s => s.interpolate_inplace(t, &mut v)));
        match r {
            Ok(()) => out.copy_from_slice(v.batch_as_slice(0)),
            // Only after a failed step (the solver was rolled back and refuses to interpolate):
            // fall back to linear interpolation rather than panicking inside an FMU.
            Err(_) => {
                let th = (t - tr.t_int_prev) / (tr.t_int - tr.t_int_prev);
                for ((o, a), b) in out.iter_mut().zip(&tr.y_prev).zip(&tr.y) {
                    *o = a + th * (b - a);
                }
            }
        }
    }

    fn stats(&self) -> Stats {
        let cur = self.solver_stats();
        let jac_evals = self
            .cell
            .as_ref()
            .map(|c| {
                c.borrow_owner()
                    .eqn()
                    .rhs()
                    .statistics()
                    .number_of_matrix_evals as u64
            })
            .or_else(|| {
                self.spare
                    .as_ref()
                    .map(|p| p.eqn().rhs().statistics().number_of_matrix_evals as u64)
            })
            .unwrap_or(0);
        Stats {
            steps: self.tr.steps,
            rejected: self.base.rejected + cur.rejected + self.tr.rollbacks,
            rhs_evals: self.shared.rhs_evals.get(),
            jac_evals,
            factorizations: self.base.factorizations + cur.factorizations,
        }
    }
}
