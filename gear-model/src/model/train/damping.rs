//! Damping as a ratio (gearbox-file.md §3): the Hunt-Crossley coefficient chi that gives a
//! mesh's own mode a fraction zeta of critical damping at its mean stiffness under its static
//! load.
//!
//! The mesh's own mode is the two gears turning against each other along the line of
//! action, the rest of the train held: its mass is m_eq = 1 / (rAb^2 / J_A + rBb^2 / J_B) (a
//! gear in the housing adds nothing). Hunt-Crossley's force F_el (1 + chi d(delta)/dt) damps
//! it, about the static load F0, with c = chi F0; the stiffness is the mesh's tangent
//! stiffness averaged over a mesh cycle at F0 (`static_mesh`). Critical damping is
//! 2 sqrt(k m_eq), so chi = 2 zeta sqrt(k m_eq) / F0.

use super::{Train, HOUSING};
use crate::model::mesh::ContactModel;
use crate::model::static_mesh;
use crate::model::ModelError;

/// Positions per mesh cycle for the mean stiffness: the tangent stiffness is piecewise smooth
/// with a jump where a pair enters or leaves, so the midpoint mean errs by about the jump over
/// the count (1e-2 of the stiffness's variation at 64), far below what a damping ratio means.
const CYCLE_POINTS: usize = 64;

/// Mesh m's chi for damping ratio `zeta` with the train at y (its static balance).
pub fn chi_for_ratio(train: &Train, y: &[f64], m: usize, zeta: f64) -> Result<f64, ModelError> {
    let mesh = &train.meshes[m];
    let name = format!("mesh[{}]", m + 1);
    let r = train
        .mesh_readout(m, y)
        .map_err(|e| ModelError::new(format!("{name}: {e}")))?;
    let f0 = r.flank_force[0] + r.flank_force[1];
    let unloaded = || {
        ModelError::new(format!(
            "{name}: damping_ratio = {zeta} needs a static load to set chi, and this mesh carries none at the start ({f0:e} N, less than deflects it by a nanometre): give chi instead"
        ))
    };
    if !(f0 > 0.0) {
        return Err(unloaded());
    }
    let law = match &mesh.law {
        ContactModel::Compliant(law) => law,
        ContactModel::Lumped(_) => {
            return Err(ModelError::new(format!(
                "{name}: damping_ratio sets Hunt-Crossley's chi, which the lumped mesh (contact_model = 4) does not use: give c_lumped instead"
            )))
        }
        ContactModel::Rigid { .. } => {
            return Err(ModelError::new(format!(
                "{name}: damping_ratio needs a compliant contact law"
            )))
        }
    };
    let g = &mesh.geo;
    let relief = |s: f64| mesh.dev.as_ref().map_or(0.0, |d| d.tip_relief_at(s));
    let k: f64 = (0..CYCLE_POINTS)
        .map(|i| {
            let s0 = g.s_a + g.p_b * (i as f64 + 0.5) / CYCLE_POINTS as f64;
            static_mesh::balance_with(law, g, s0, f0, &relief).tangent
        })
        .sum::<f64>()
        / CYCLE_POINTS as f64;
    // A static deflection below a nanometre is the balance's rounding, not a load: a chi
    // from it would be arbitrary and huge.
    if f0 < 1e-9 * k {
        return Err(unloaded());
    }
    let spec = train.spec();
    let mp = &spec.meshes[m];
    let mobility = |body: usize, rb: f64| {
        if body == HOUSING {
            0.0
        } else {
            rb * rb / spec.bodies[body].j
        }
    };
    let m_eq = 1.0 / (mobility(mp.a, g.r_ab) + mobility(mp.b, g.r_bb));
    Ok(2.0 * zeta * (k * m_eq).sqrt() / f0)
}
