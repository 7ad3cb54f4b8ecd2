//! The static start (gearbox-file.md §3): the start deflections of the meshes, twists of the
//! shafts and displacements of the lateral bodies at which the start loads (torques, drags at
//! the start speeds, friction, a carrier's centrifugal loads) are in balance, so a run starts
//! without a transient. Where the loads do not balance, the train accelerates as a rigid body
//! and the balance is taken in that accelerating frame: every mesh's dte, every shaft's twist
//! and every lateral displacement then has zero second derivative at t = 0.
//!
//! The unknowns are the coordinates' edges (the meshes that place a body, through their
//! `dte_start`, and the shafts, through their `twist_start`) and the lateral bodies' start
//! displacements; the meshes that close loops follow from them. The equations are the train's own right-hand side, so whatever the
//! model carries (the pairs in contact, their positions, tooth structure, friction) is in the
//! balance. Newton's method on them, with a Jacobian by differences: a handful of train
//! builds per iteration, once, at initialization. Where planets' pin errors defeat Newton from
//! its guess, the balance is followed from the train without them (`follow_pin_errors`).

use super::kinematics::Coord;
use super::topology::{Edge, TrainSpec};
use super::{coord_index, State, Train, TrainLoads};
use crate::driver::Vector;
use crate::model::contact::Flank;
use crate::model::ModelError;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// A start deflection of a loaded flank before Newton's first step \[m\]: the micrometre of a
/// gear's static deflection (the scenes' are 0.5-3.3 um), only to start on the right side.
const DELTA_GUESS: f64 = 1e-6;
/// Converged when no unknown moves by more than this fraction of its size (or of a
/// nanometre for one near 0): far below what the forces resolve.
const STEP_TOL: f64 = 1e-10;
const MAX_ITER: usize = 40;
/// Balanced when every edge's acceleration is below this fraction of what the deflections give
/// it: the forces then balance to far better than the contact laws' own accuracy.
const BALANCE_TOL: f64 = 1e-10;
/// Where rounding in the other edges' forces keeps a lightly loaded edge from that, the steps
/// stand still with its residual at this fraction.
const NOISE_TOL: f64 = 1e-6;
/// Or they stall: a loop's closing mesh has its deflection from the bodies' positions, resolved
/// to the rounding of a radius (~1e-17 m), which is 1e-9 of a deflection of nanometres (Lin &
/// Parker's set at 1 N.m). Steps below this fraction of their unknowns that no longer halve are
/// that rounding: the steps stand still there.
const STALL_TOL: f64 = 1e-6;

/// The start deflections a static start found: every mesh's `dte_start` and every shaft's
/// `twist_start` as the train was built with them. A saved FMU state keeps them, since
/// solving again from a later state's inputs would give another start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StartDeflections {
    pub dte: Vec<f64>,
    pub twist: Vec<f64>,
}

impl StartDeflections {
    pub fn of(spec: &TrainSpec) -> StartDeflections {
        StartDeflections {
            dte: spec.meshes.iter().map(|m| m.dte_start).collect(),
            twist: spec.shafts.iter().map(|s| s.twist_start).collect(),
        }
    }

    /// Puts them into `spec`; refused when they do not fit it or are not finite.
    pub fn apply(&self, spec: &mut TrainSpec) -> Result<(), ModelError> {
        let fits = self.dte.len() == spec.meshes.len() && self.twist.len() == spec.shafts.len();
        if !fits || !self.dte.iter().chain(&self.twist).all(|x| x.is_finite()) {
            return Err(ModelError::new(
                "the static start's deflections do not fit the train".to_string(),
            ));
        }
        for (m, &x) in spec.meshes.iter_mut().zip(&self.dte) {
            m.dte_start = x;
        }
        for (s, &x) in spec.shafts.iter_mut().zip(&self.twist) {
            s.twist_start = x;
        }
        Ok(())
    }
}

/// What sets one coordinate's start value.
#[derive(Clone, Copy, Debug)]
enum Unknown {
    Mesh(usize),
    Shaft(usize),
    /// A lateral body's start displacement along x (0) or y (1).
    Lateral(usize, usize),
}

fn get(spec: &TrainSpec, u: Unknown) -> f64 {
    match u {
        Unknown::Mesh(m) => spec.meshes[m].dte_start,
        Unknown::Shaft(j) => spec.shafts[j].twist_start,
        Unknown::Lateral(i, d) => spec.bodies[i].lateral.map_or(0.0, |l| l.q_start[d]),
    }
}

fn set(spec: &mut TrainSpec, u: Unknown, x: f64) {
    match u {
        Unknown::Mesh(m) => spec.meshes[m].dte_start = x,
        Unknown::Shaft(j) => spec.shafts[j].twist_start = x,
        Unknown::Lateral(i, d) => {
            if let Some(l) = spec.bodies[i].lateral.as_mut() {
                l.q_start[d] = x;
            }
        }
    }
}

fn name(u: Unknown) -> String {
    match u {
        Unknown::Mesh(m) => format!("mesh[{}]", m + 1),
        Unknown::Shaft(j) => format!("shaft[{}]", j + 1),
        Unknown::Lateral(i, d) => format!("body[{}].{}_start", i + 1, ["x", "y"][d]),
    }
}

/// The unknowns' start values and the edges' accelerations there.
struct Balance<'a> {
    spec: TrainSpec,
    loads: &'a TrainLoads,
    unknowns: Vec<(usize, Unknown)>,
}

impl Balance<'_> {
    fn with(&self, x: &[f64]) -> TrainSpec {
        let mut spec = self.spec.clone();
        for (&(_, u), &v) in self.unknowns.iter().zip(x) {
            set(&mut spec, u, v);
        }
        spec
    }

    /// Each unknown's deflection on its flank: a mesh's penetration there, side (x - edge)
    /// plus the gain its centres' displacements give along that flank's line of action
    /// (lateral.md §3); another unknown's value.
    fn deflections(&self, mid: &[f64], side: &[f64], x: &[f64]) -> Result<Vec<f64>, ModelError> {
        let own = |k: usize| match self.unknowns[k].1 {
            Unknown::Mesh(_) => side[k] * (x[k] - edge(mid, side, k)),
            Unknown::Shaft(_) | Unknown::Lateral(..) => x[k],
        };
        let lateral = self
            .unknowns
            .iter()
            .any(|(_, u)| matches!(u, Unknown::Lateral(..)));
        if !lateral {
            return Ok((0..x.len()).map(own).collect());
        }
        let (train, y) = Train::new(self.with(x), self.loads.tau.clone(), None)?;
        let bodies = train.bodies(&y);
        let gain = |m: usize, flank: Flank| {
            if !train.meshes[m].moving_centres {
                return 0.0;
            }
            let [z, ..] = train.centre_motion(m, &y, &bodies, None);
            train.meshes[m].centre_gain(flank, z[0], z[1])
        };
        Ok((0..x.len())
            .map(|k| match self.unknowns[k].1 {
                Unknown::Mesh(m) if side[k] > 0.0 => own(k) + gain(m, Flank::Forward),
                Unknown::Mesh(m) if side[k] < 0.0 => own(k) + gain(m, Flank::Backward),
                _ => own(k),
            })
            .collect())
    }

    /// The second derivatives of the coordinates' edges at the start.
    fn residual(&self, x: &[f64]) -> Result<DVector<f64>, ModelError> {
        let (mut train, mut y) = Train::new(self.with(x), self.loads.tau.clone(), None)?;
        train.set_loads(self.loads.clone(), &mut y);
        let mut dy = State::zeros();
        train
            .rhs(&y, &mut dy)
            .map_err(|e| ModelError::new(format!("static start: {e}")))?;
        Ok(DVector::from_iterator(
            self.unknowns.len(),
            self.unknowns.iter().map(|&(k, _)| dy[coord_index(k) + 1]),
        ))
    }
}

/// `spec` with the start deflections and twists at which `loads` balance (see the module).
/// Refused when a loop-closing mesh is a coordinate (its start is the assembly's, which no
/// parameter sets), or when no balance is found (a load beyond what the teeth can carry).
pub fn static_start(spec: TrainSpec, loads: &TrainLoads) -> Result<TrainSpec, ModelError> {
    let (train, _) = Train::new(spec.clone(), loads.tau.clone(), None)?;
    let coords = &train.cfg.coords;
    let mut unknowns = Vec::new();
    for (k, c) in coords.coords.iter().enumerate() {
        let u = match c {
            Coord::Body(_) => continue,
            Coord::Edge(Edge::Mesh(m)) => Unknown::Mesh(*m),
            Coord::Edge(Edge::Shaft(j)) => Unknown::Shaft(*j),
        };
        // A placing mesh starts at its dte_start, a shaft at its twist_start; a loop-closing
        // mesh at what the assembly gives.
        if coords.offset[k] != get(&spec, u) {
            return Err(ModelError::new(format!(
                "static start: {} closes a loop whose start deflection the gears' mounts fix, not its dte_start: set the mounts so that the loop assembles under load, or start without static_start",
                name(u)
            )));
        }
        unknowns.push((k, u));
    }
    // Each lateral body's displacement, after the rotations (`lateral.rs`).
    let first = coords.coords.len();
    let lateral = (0..spec.bodies.len()).filter(|&i| spec.bodies[i].lateral.is_some());
    for (l, i) in lateral.enumerate() {
        for d in 0..2 {
            unknowns.push((first + 2 * l + d, Unknown::Lateral(i, d)));
        }
    }
    if unknowns.is_empty() {
        return Ok(spec);
    }
    let b = Balance {
        spec,
        loads,
        unknowns,
    };
    let no_pin_errors = b.spec.bodies.iter().all(|body| {
        body.planet
            .is_none_or(|p| p.pin_error_r == 0.0 && p.pin_error_t == 0.0)
    });
    match solve(&b) {
        Ok((x, _)) => Ok(b.with(&x)),
        Err(e) if no_pin_errors => Err(e),
        Err(_) => follow_pin_errors(&b).map(|x| b.with(&x)),
    }
}

/// The guess every Newton of `b` starts from: each mesh in the middle of its backlash, each
/// shaft untwisted, each lateral body on its axis; and the edges' accelerations there.
fn middle(b: &Balance) -> Result<(Vec<f64>, DVector<f64>), ModelError> {
    let mid: Vec<f64> = b
        .unknowns
        .iter()
        .map(|&(_, u)| match u {
            Unknown::Mesh(m) => -0.5 * b.spec.meshes[m].pair.backlash,
            Unknown::Shaft(_) | Unknown::Lateral(..) => 0.0,
        })
        .collect();
    let r0 = b.residual(&mid)?;
    Ok((mid, r0))
}

/// The balance and each mesh's flank there. Which flank each mesh loads is first guessed from
/// the edges' accelerations in the middle; a mesh that the balance pins to the edge of its gap
/// loads the other flank, and Newton starts again.
fn solve(b: &Balance) -> Result<(Vec<f64>, Vec<f64>), ModelError> {
    let (mid, r0) = middle(b)?;
    let mut side: Vec<f64> = b
        .unknowns
        .iter()
        .zip(r0.iter())
        .map(|(&(_, u), &r)| match u {
            Unknown::Mesh(_) if r < 0.0 => -1.0,
            Unknown::Mesh(_) => 1.0,
            Unknown::Shaft(_) | Unknown::Lateral(..) => 0.0,
        })
        .collect();
    for _ in 0..=b.unknowns.len() {
        match newton(b, &mid, &side, &r0, None)? {
            Ok(x) => return Ok((x, side)),
            Err(pinned) => pinned.iter().for_each(|&k| side[k] = -side[k]),
        }
    }
    Err(ModelError::new(
        "static start: no balance found: the meshes' flanks keep changing (a load near zero on a mesh with backlash?)".to_string(),
    ))
}

/// Pin errors misplace the meshes that close the loops through the planets: at Newton's guess
/// they can sit in their gaps (a floating sun then hangs on one mesh, its Jacobian singular)
/// or on their other flanks. Where Newton from the guess fails, the balance is followed from
/// the train without pin errors (every loop then closes as assembled) to the train with them,
/// scaled by s = 0 -> 1. Each step is predicted along the tangent dx/ds = -J^-1 dr/ds at the
/// last balance, where every loaded mesh is in the Jacobian: the balance moves nearly linearly
/// with the errors (the shares of a floating sun do not change), so the first step, to the
/// full errors, usually lands close enough for Newton. One that fails is halved (to 1/1024 of
/// the errors, a nanometre's share of a pin error of a micrometre), one that succeeds doubled.
fn follow_pin_errors(b: &Balance) -> Result<Vec<f64>, ModelError> {
    let at = |s: f64| {
        let mut spec = b.spec.clone();
        for p in spec
            .bodies
            .iter_mut()
            .filter_map(|body| body.planet.as_mut())
        {
            p.pin_error_r *= s;
            p.pin_error_t *= s;
        }
        Balance {
            spec,
            loads: b.loads,
            unknowns: b.unknowns.clone(),
        }
    };
    let (mut x, side) = solve(&at(0.0)).map_err(|e| {
        ModelError::new(format!(
            "{e} (without the planets' pin errors, from where the balance would follow them)"
        ))
    })?;
    let n = x.len();
    let largest = b
        .spec
        .bodies
        .iter()
        .filter_map(|body| body.planet)
        .fold(0.0f64, |m, p| {
            m.max(p.pin_error_r.abs()).max(p.pin_error_t.abs())
        });
    let (mut s, mut ds) = (0.0f64, 1.0);
    while s < 1.0 {
        let bs = at(s);
        let (mid, _) = middle(&bs)?;
        let r = bs.residual(&x)?;
        let defl = bs.deflections(&mid, &side, &x)?;
        let jac = jacobian(&bs, &side, &x, &defl, &r)?;
        // dr/ds by a difference that moves the pins by 1e-6 of the largest deflection.
        let d = (0..n)
            .map(|k| size(&bs, &side, &defl, k))
            .fold(0.0, f64::max);
        let eps = (1e-6 * d / largest).min(1e-6);
        let drds = (at(s + eps).residual(&x)? - &r) / eps;
        let Some(dxds) = jac.clone().lu().solve(&(-drds)) else {
            return Err(singular(b, jac));
        };
        loop {
            let t = (s + ds).min(1.0);
            let bt = at(t);
            let (mid, r0) = middle(&bt)?;
            // The prediction, each mesh kept on its flank as in Newton.
            let trial: Vec<f64> = (0..n).map(|k| x[k] + (t - s) * dxds[k]).collect();
            let corrected = keep(&bt, &mid, &side, &trial, &defl)
                .and_then(|xp| newton(&bt, &mid, &side, &r0, Some(&xp)));
            let failure = match corrected {
                Ok(Ok(xn)) => {
                    (x, s) = (xn, t);
                    ds *= 2.0;
                    break;
                }
                Ok(Err(pinned)) => {
                    let names: Vec<String> =
                        pinned.iter().map(|&k| name(b.unknowns[k].1)).collect();
                    format!("{} leaves its flank", names.join(", "))
                }
                Err(e) => e.to_string(),
            };
            if ds <= 1.0 / 1024.0 {
                return Err(ModelError::new(format!(
                    "static start: no balance found following the pin errors from 0: at {:.1} % of them, {}",
                    100.0 * t,
                    failure
                )));
            }
            ds *= 0.5;
        }
    }
    Ok(x)
}

/// Newton's method from `start` (the balance of a nearby train, on the same flanks), or from
/// a deflection of DELTA_GUESS on each mesh's `side` (+1 forward, -1 backward; 0, a shaft or a
/// lateral displacement, starts at 0).
/// Returns the balance, or the meshes it pinned to the edge of their gap.
#[allow(clippy::type_complexity)]
fn newton(
    b: &Balance,
    mid: &[f64],
    side: &[f64],
    r0: &DVector<f64>,
    start: Option<&[f64]>,
) -> Result<Result<Vec<f64>, Vec<usize>>, ModelError> {
    let n = mid.len();
    // The flank's edge: 0 forward, -j_n backward.
    let edge = |k: usize| edge(mid, side, k);
    let mut x: Vec<f64> = match start {
        Some(x) => x.to_vec(),
        None => (0..n)
            .map(|k| {
                if side[k] == 0.0 {
                    0.0
                } else {
                    edge(k) + side[k] * DELTA_GUESS
                }
            })
            .collect(),
    };
    let mut defl = b.deflections(mid, side, &x)?;
    let mut r = b.residual(&x)?;
    // Each edge's residual on its own scale: its size unloaded or at the first guess (an
    // edge that the external loads alone do not accelerate has 0 unloaded).
    let top = r0
        .iter()
        .chain(r.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let scale: Vec<f64> = (0..n)
        .map(|k| {
            r0[k]
                .abs()
                .max(r[k].abs())
                .max(1e-12 * top)
                .max(f64::MIN_POSITIVE)
        })
        .collect();
    let mut last_moved = f64::INFINITY;
    for _ in 0..MAX_ITER {
        let jac = jacobian(b, side, &x, &defl, &r)?;
        let step = match jac.clone().lu().solve(&(-&r)) {
            Some(step) => step,
            None => return Err(singular(b, jac)),
        };
        // The full step: each law is monotone and convex on its flank (stiffer as it is
        // pressed), so a step from too light a deflection overshoots once and the steps
        // from beyond converge from there; a halved step would crawl.
        // Halved only where it would press a contact law beyond its range.
        let mut frac = 1.0;
        let (xn, rn) = loop {
            let trial: Vec<f64> = (0..n).map(|k| x[k] + frac * step[k]).collect();
            // A step that the train refuses (a loop that no longer assembles) is halved too.
            let at =
                keep(b, mid, side, &trial, &defl).and_then(|xn| b.residual(&xn).map(|rn| (xn, rn)));
            match at {
                Ok((xn, rn)) if rn.iter().all(|v| v.is_finite()) => break (xn, rn),
                _ if frac > 1e-6 => frac *= 0.5,
                Ok(_) => {
                    return Err(ModelError::new(
                        "static start: a residual is not finite".into(),
                    ))
                }
                Err(e) => return Err(e),
            }
        };
        let moved = (0..n)
            .map(|k| (xn[k] - x[k]).abs() / size(b, side, &defl, k))
            .fold(0.0, f64::max);
        let still = moved <= STEP_TOL || moved <= STALL_TOL && moved >= 0.5 * last_moved;
        last_moved = moved;
        x = xn;
        r = rn;
        defl = b.deflections(mid, side, &x)?;
        // Against the accelerations the deflections give the edge (the elastic terms that
        // balance in its equation: a lateral body at rest on its bearing has none of its
        // own, but the meshes' forces on it), or once the steps stand still at rounding, also
        // against its size unloaded.
        let own = |k: usize| {
            (0..n)
                .map(|j| (jac[(k, j)] * (x[j] - edge(j))).abs())
                .sum::<f64>()
        };
        if (0..n).all(|k| r[k].abs() <= BALANCE_TOL * own(k))
            || still && (0..n).all(|k| r[k].abs() <= NOISE_TOL * own(k).max(scale[k]))
        {
            return Ok(Ok(x));
        }
        if still {
            // Pinned: a mesh at the edge of its flank that the balance pushes further.
            let pinned: Vec<usize> = (0..n)
                .filter(|&k| side[k] != 0.0 && defl[k] <= 1e-3 * DELTA_GUESS)
                .collect();
            if pinned.is_empty() {
                break;
            }
            return Ok(Err(pinned));
        }
    }
    let worst = (0..n)
        .max_by(|&i, &j| (r[i] / scale[i]).abs().total_cmp(&(r[j] / scale[j]).abs()))
        .map(|k| name(b.unknowns[k].1))
        .unwrap_or_default();
    Err(ModelError::new(format!(
        "static start: no balance found ({worst} least balanced): a load beyond what the teeth can carry, or a train that cannot hold still"
    )))
}

/// The edge of unknown k's flank: 0 forward, -j_n backward (`mid` is -j_n / 2); 0 for a
/// shaft or a lateral displacement.
fn edge(mid: &[f64], side: &[f64], k: usize) -> f64 {
    if side[k] > 0.0 {
        0.0
    } else {
        2.0 * mid[k]
    }
}

/// Each mesh stays on its flank, where its force law is smooth and monotone (the gap has no
/// stiffness): a step to `trial` from deflections `defl` that takes a mesh past its flank's
/// edge goes a tenth of the way there instead. The edge is on the whole penetration: a
/// lateral body's displacement moves its meshes' too.
fn keep(
    b: &Balance,
    mid: &[f64],
    side: &[f64],
    trial: &[f64],
    defl: &[f64],
) -> Result<Vec<f64>, ModelError> {
    let at = b.deflections(mid, side, trial)?;
    Ok((0..trial.len())
        .map(|k| {
            if side[k] != 0.0 && at[k] <= 0.0 {
                trial[k] + side[k] * (0.1 * defl[k].abs() - at[k])
            } else {
                trial[k]
            }
        })
        .collect())
}

/// Unknown k's size: a mesh's deflection on its flank; a lateral displacement's, at least
/// the largest such deflection (the meshes that hold the body move by as much as it does); a
/// shaft's twist, at least its twist under the largest external torque. Not a lateral's or a
/// twist's value alone, which starts at 0.
fn size(b: &Balance, side: &[f64], defl: &[f64], k: usize) -> f64 {
    let d = (0..defl.len())
        .filter(|&j| side[j] != 0.0)
        .map(|j| defl[j].abs())
        .fold(0.0, f64::max);
    let natural = match b.unknowns[k].1 {
        Unknown::Mesh(_) => 0.0,
        Unknown::Lateral(..) if d > 0.0 => d,
        Unknown::Lateral(..) => DELTA_GUESS,
        Unknown::Shaft(j) if b.spec.shafts[j].k > 0.0 => {
            b.loads.tau.iter().fold(0.0f64, |m, t| m.max(t.abs())) / b.spec.shafts[j].k
        }
        Unknown::Shaft(_) => 0.0,
    };
    defl[k].abs().max(natural).max(1e-9)
}

/// d(residual)/dx at x (r its residual, defl its deflections), by forward differences away
/// from each flank's edge, into the contact: 1e-6 of each unknown's size, far above the
/// forces' rounding and far below the laws' curvature.
fn jacobian(
    b: &Balance,
    side: &[f64],
    x: &[f64],
    defl: &[f64],
    r: &DVector<f64>,
) -> Result<DMatrix<f64>, ModelError> {
    let n = x.len();
    let mut jac = DMatrix::zeros(n, n);
    for k in 0..n {
        let h = 1e-6 * size(b, side, defl, k);
        let mut xh = x.to_vec();
        xh[k] += if side[k] < 0.0 { -h } else { h };
        let rh = b.residual(&xh)?;
        jac.set_column(k, &((rh - r) / (xh[k] - x[k])));
    }
    Ok(jac)
}

/// The refusal of a singular Jacobian, naming the unknown that its null direction moves most.
fn singular(b: &Balance, jac: DMatrix<f64>) -> ModelError {
    let svd = jac.svd(false, true);
    let weakest = svd.singular_values.argmin().0;
    let worst = svd.v_t.map_or(0, |v| {
        let row = v.row(weakest);
        (0..row.len()).fold(0, |w, k| if row[k].abs() > row[w].abs() { k } else { w })
    });
    ModelError::new(format!(
        "static start: the balance is singular along {} (a body that nothing holds against its load)",
        name(b.unknowns[worst].1)
    ))
}
