//! The static start of the single mesh (parameter `static_start`, gearbox-file.md §3): the
//! `dte_start` at which the start loads (torques, the load's drag at the start speed, the
//! housing's motion, friction) are in balance. Where they do not balance, the wheels
//! accelerate together and the balance is taken in that frame: the dte's second derivative is
//! zero at t = 0, as in the train's static start (train/statics.rs).
//!
//! One unknown on one flank, where the force law is monotone: the flank is the one the
//! unloaded mesh closes, and the root is bracketed and then found by bisection with secant
//! steps, on the rig's own right-hand side.

use super::{Loads, PaperRig, RigSpec, State, DDTE};
use crate::model::geometry::Geometry;
use crate::model::pair::MeshLaw;
use crate::model::ModelError;

/// Converged when the bracket is this fraction of the deflection: far below what the forces
/// resolve (as the train's STEP_TOL).
const TOL: f64 = 1e-12;
/// The first trial deflection \[m\]: a micrometre, a gear's static deflection; doubled until
/// the contact pushes back.
const GUESS: f64 = 1e-6;

/// The dte's acceleration at t = 0 with the rig started at `dte_start = d`.
fn residual(spec: &RigSpec, loads: &Loads, d: f64) -> Result<f64, ModelError> {
    let q = RigSpec {
        dte_start: d,
        ..spec.clone()
    };
    let (rig, y) = PaperRig::new(&q, *loads)?;
    let mut dy = State::default();
    rig.rhs(&y, &mut dy)
        .map_err(|e| ModelError::new(format!("static start: {e}")))?;
    Ok(dy[DDTE])
}

/// The balanced `dte_start`; the given one when nothing loads the mesh.
pub fn static_dte_start(spec: &RigSpec, loads: &Loads) -> Result<f64, ModelError> {
    if spec.pair.law == MeshLaw::Rigid {
        return Err(ModelError::parameter(
            "static_start",
            "true",
            "rigid contact (contact_model = 2) has no deflection to balance: it starts at its dte_start",
        ));
    }
    if spec.slider.is_some() {
        return Err(ModelError::parameter(
            "static_start",
            "true",
            "not available with the slider S (its displacement would be a second unknown); set slider_stiffness = 0 or start without it",
        ));
    }
    let j_n = Geometry::new(&spec.pair)?.j_n;
    let mid = -0.5 * j_n;
    let r_mid = residual(spec, loads, mid)?;
    if r_mid == 0.0 {
        return Ok(spec.dte_start);
    }
    // Forward flank: penetration d > 0 pushes the dte back; backward: d < -j_n.
    let (side, edge) = if r_mid > 0.0 {
        (1.0, 0.0)
    } else {
        (-1.0, -j_n)
    };
    let at = |x: f64| edge + side * x;
    let (mut lo, mut hi) = (0.0, GUESS);
    let (mut r_lo, mut r_hi) = (r_mid, residual(spec, loads, at(hi))?);
    while r_hi.signum() == r_mid.signum() {
        if hi > 1e-2 {
            return Err(ModelError::parameter(
                "static_start",
                "true",
                "no balance within 1 cm of deflection: a load beyond what the teeth can carry",
            ));
        }
        (lo, r_lo) = (hi, r_hi);
        hi *= 2.0;
        r_hi = residual(spec, loads, at(hi))?;
    }
    while hi - lo > TOL * hi {
        let secant = lo - r_lo * (hi - lo) / (r_hi - r_lo);
        let bisect = 0.5 * (lo + hi);
        // A secant step that would barely move the far end bisects instead.
        let x = if secant > lo + 0.01 * (hi - lo) && secant < hi - 0.01 * (hi - lo) {
            secant
        } else {
            bisect
        };
        let r = residual(spec, loads, at(x))?;
        if r == 0.0 {
            return Ok(at(x));
        }
        if r.signum() == r_lo.signum() {
            (lo, r_lo) = (x, r);
        } else {
            (hi, r_hi) = (x, r);
        }
    }
    Ok(at(0.5 * (lo + hi)))
}
