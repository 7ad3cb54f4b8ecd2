//! An explicit method's step limit (`Train::max_step`): from the modes of a lateral train's
//! linearization where those change only with the meshes' contact flanks, else from the trace
//! of M^-1 K. The trace bounds the highest mode of docs/lateral.md's 4-planet set at 26 kHz
//! against its true 13 kHz, and takes no account of its damping: the steps it allows are less
//! than half of what the method's stability region holds.

use super::*;
use crate::driver::Stability;
use crate::model::contact::Flank;
use nalgebra::Schur;

/// The share of what the region holds that a step takes: the modes drift between mode changes
/// with the carrier's speed (its Coriolis and centrifugal terms).
const SHARE: f64 = 0.9;

// Every mesh's two flanks fit the signature's 64 bits.
const _: () = assert!(2 * MAX_MESHES <= 64);

/// The modes found at the last change of the flanks in contact.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Modes {
    /// `Train::flank_signature` when they were found.
    signature: u64,
    /// Each mode's |lambda| \[rad/s\] and damping ratio (one of each conjugate pair).
    modes: Vec<(f64, f64)>,
}

impl Train {
    /// Bound on the highest natural frequency \[rad/s\] (the trace of M^-1 K bounds its
    /// largest eigenvalue): each mesh's stiffness along its line of action, each shaft's.
    pub fn vibration_frequency(&self, y: &[f64]) -> f64 {
        let c = &*self.cfg;
        let b = self.bodies(y);
        let mut sum = 0.0;
        let mut stiffness = [0.0; MAX_MESHES];
        for (m, mesh) in self.meshes.iter().enumerate() {
            let k = mesh.mesh_stiffness(&self.kin(m, y, &b));
            stiffness[m] = k;
            sum += k * c.mobility(&kinematics::mesh_row(&c.spec, &c.structure, &mesh.geo, m));
        }
        sum += self.lateral_trace(&stiffness);
        for (j, sh) in c.spec.shafts.iter().enumerate() {
            sum += sh.k * c.mobility(&kinematics::shaft_row(&c.spec, j));
        }
        sum.sqrt()
    }

    /// At most a quarter pitch of contact travel in any mesh (its objects' events recur every
    /// pitch), and for an explicit method what its stability region holds: on the modes where
    /// the flanks in contact set them (`modal`), else reach/omega of the fastest vibration.
    pub fn max_step(&self, y: &[f64], stability: Option<crate::driver::Stability>) -> f64 {
        let b = self.bodies(y);
        let mut h = f64::INFINITY;
        for (m, mesh) in self.meshes.iter().enumerate() {
            let l = &self.cfg.links[m];
            let speed = mesh.geo.r_ab * (b.w[l.a] - l.rel_a * b.w[l.carrier]).abs();
            // A quarter pitch as the single mesh's compliant law, a pitch for the lumped mesh.
            let pitches = if mesh.lumped().is_some() { 1.0 } else { 0.25 };
            if speed > 0.0 {
                h = h.min(pitches * mesh.geo.p_b / speed);
            }
        }
        if let Some(s) = stability {
            if let Some(modal) = self.modal_step(s) {
                return h.min(modal);
            }
            let omega = self.vibration_frequency(y);
            if omega > 0.0 {
                h = h.min(s.reach / omega);
            }
        }
        h
    }

    /// Whether the linearization changes only with the flanks in contact: lateral bodies,
    /// every mesh lumped at a constant stiffness (linear springs), at most one carrier turning
    /// lateral vectors, and isotropic bearings in the housing's frame (so that the modes do not
    /// turn with the carrier).
    fn modes_set_by_flanks(&self) -> bool {
        let Some(lat) = &self.cfg.lateral else {
            return false;
        };
        lat.turning.len() <= 1
            && self.meshes.iter().all(|m| m.pairs_untracked())
            && lat
                .bodies
                .iter()
                .filter(|lb| lb.carrier.is_none())
                .all(|lb| lb.k[0] == lb.k[1] && lb.c[0] == lb.c[1])
    }

    /// Two bits per mesh: its forward and backward flanks in contact.
    fn flank_signature(&self) -> u64 {
        self.meshes.iter().enumerate().fold(0, |s, (m, mesh)| {
            let on = |f| u64::from(mesh.flank_on(f));
            s | on(Flank::Forward) << (2 * m) | on(Flank::Backward) << (2 * m + 1)
        })
    }

    /// Finds the modes again where the flanks in contact changed (at the start, after an event).
    pub(super) fn renew_modes(&mut self, y: &[f64]) {
        if !self.modes_set_by_flanks() {
            return;
        }
        let signature = self.flank_signature();
        if self
            .modes
            .as_ref()
            .is_some_and(|m| m.signature == signature)
        {
            return;
        }
        self.modes = self.linear_modes(y).map(|modes| Modes { signature, modes });
    }

    /// The eigenvalues of d(rates)/d(coordinates and their rates) at y, by central differences
    /// (exact but for rounding on linear springs), as (|lambda|, damping ratio).
    fn linear_modes(&self, y: &[f64]) -> Option<Vec<(f64, f64)>> {
        let n = self.dim() - 2;
        let scale = self.abs_tol(1.0);
        let (mut yp, mut fp, mut fm) = (y.to_vec(), vec![0.0; y.len()], vec![0.0; y.len()]);
        let mut jac = DMatrix::zeros(n, n);
        for c in 0..n {
            let j = c + 2;
            let h = 1e-3 * scale[j].max(1e-12);
            yp[j] = y[j] + h;
            self.rhs(&yp, &mut fp).ok()?;
            yp[j] = y[j] - h;
            self.rhs(&yp, &mut fm).ok()?;
            yp[j] = y[j];
            for r in 0..n {
                jac[(r, c)] = (fp[r + 2] - fm[r + 2]) / (2.0 * h);
            }
        }
        // A state the law refuses gives no modes, nor one whose rates are not finite; Francis'
        // iteration takes a few sweeps per eigenvalue, so 30 n bounds a stall.
        if !jac.iter().all(|v| v.is_finite()) {
            return None;
        }
        let ev = Schur::try_new(jac, f64::EPSILON, 30 * n)?.complex_eigenvalues();
        Some(
            ev.iter()
                .filter(|l| l.im >= 0.0 && l.norm() > 0.0)
                .map(|l| (l.norm(), -l.re / l.norm()))
                .collect(),
        )
    }

    /// The modes found at the last change of the flanks in contact, as (|lambda| \[rad/s\],
    /// damping ratio); None where they do not set the steps.
    pub fn limiting_modes(&self) -> Option<&[(f64, f64)]> {
        self.modes.as_ref().map(|m| &m.modes[..])
    }

    /// The longest step the method's region holds on every mode (`SHARE` of it), while the
    /// flanks in contact are those the modes were found for; None otherwise, or where the
    /// method's region is not tabulated.
    pub(super) fn modal_step(&self, s: Stability) -> Option<f64> {
        let m = self.modes.as_ref()?;
        if m.signature != self.flank_signature() {
            return None;
        }
        let mut h = f64::INFINITY;
        for &(omega, zeta) in &m.modes {
            h = h.min(s.reach_at(zeta)? / omega);
        }
        Some(SHARE * h)
    }
}
