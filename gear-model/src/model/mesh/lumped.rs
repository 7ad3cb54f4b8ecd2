//! The lumped mesh (`contact_model = 4`, lateral.md §4): one linear spring-damper along each
//! flank's line of action. The teeth are not tracked for the force. With the square wave the
//! objects follow the pairs, gated at their rigid positions, to count them; with a constant
//! stiffness they are not tracked at all (no pair-switch events: they would be most of a run's
//! events and change nothing), and the readout places the pairs on the segment from the
//! position when it shares the flank's force among them.

use super::forces::{MeshLoad, SlotForces};
use super::{GearMesh, Kin, THETA_A};
use crate::model::contact::{self, slot_flank, Flank, SLOTS};
use crate::model::pair::Lumped;
use crate::model::rig;

const FLANKS: [Flank; 2] = [Flank::Forward, Flank::Backward];

impl GearMesh {
    /// A lumped mesh of constant stiffness: its contact objects stay where they started.
    #[inline]
    pub(crate) fn pairs_untracked(&self) -> bool {
        self.lumped().is_some_and(|l| !l.varies)
    }

    /// Pair k's contact point at y: within the window of its untracked object.
    pub(crate) fn placed_contact(&self, k: usize, y: &Kin) -> f64 {
        let dir = slot_flank(k).dir();
        let sigma = contact::wrap_into_window(&self.geo, self.sigma[k], dir, y[THETA_A]);
        sigma + dir * self.geo.r_ab * y[THETA_A]
    }

    /// Whether pair k is on the contact segment at y (its gate, `events.rs`, as a formula of
    /// the position where the objects are not tracked).
    pub(crate) fn gated_at(&self, k: usize, y: &Kin) -> bool {
        if !self.pairs_untracked() {
            return self.gated(k);
        }
        let delta = self.flank_delta(slot_flank(k), y).0;
        self.present[k]
            && self.placed_contact(k, y) - self.gate_shift * delta.max(0.0) >= self.geo.s_a
    }

    /// The pairs of flank f on the contact segment.
    fn gated_on(&self, f: Flank) -> usize {
        (0..SLOTS)
            .filter(|&k| slot_flank(k) == f && self.gated(k))
            .count()
    }

    /// Flank f's stiffness: k, or with the square wave k n / eps, whose mean over a mesh
    /// cycle is k.
    pub(crate) fn lumped_stiffness(&self, l: &Lumped, f: Flank) -> f64 {
        if l.varies {
            l.k * self.gated_on(f) as f64 / self.geo.eps
        } else {
            l.k
        }
    }

    /// The flanks in contact (delta > 0, a mode the events keep).
    fn lumped_flanks(&self) -> impl Iterator<Item = Flank> + '_ {
        FLANKS
            .into_iter()
            .filter(|&f| self.flank_present(f) && self.flank_on(f))
    }

    /// The load of the flanks in contact: F = k delta + c d(delta)/dt along each one's line of
    /// action, moment arms rAb and rBb, no friction. `pairs` receives each gated pair's share.
    /// MOVING: `moving_centres`, tested once by the caller.
    #[inline(always)]
    pub(crate) fn lumped_load<const MOVING: bool>(
        &self,
        l: &Lumped,
        y: &Kin,
        mut pairs: Option<&mut SlotForces>,
    ) -> MeshLoad {
        let g = &self.geo;
        let mut m = MeshLoad::default();
        for f in self.lumped_flanks() {
            let (delta, ddelta) = self.flank_delta_of::<MOVING>(f, y);
            let k = self.lumped_stiffness(l, f);
            let force = k * delta + l.c * ddelta;
            m.tq_a -= f.dir() * force * g.r_ab;
            m.tq_b += f.dir() * force * g.r_bb;
            m.p_loss += l.c * ddelta * ddelta;
            if self.slider {
                m.f_bx += rig::force_on_b(f, force, 0.0, self.sin_a, self.cos_a).0;
            } else if MOVING {
                let (fx, fy) = rig::force_on_b(f, force, 0.0, self.sin_a, self.cos_a);
                m.f_bx += fx;
                m.f_by += fy;
            }
            if let Some(p) = pairs.as_deref_mut() {
                let on = |s: &usize| slot_flank(*s) == f && self.gated_at(*s, y);
                let n = (0..SLOTS).filter(on).count() as f64;
                for k_slot in (0..SLOTS).filter(on) {
                    p[k_slot] = (force / n, 0.0, k * delta / n);
                }
            }
        }
        m
    }

    /// The springs' energy k delta^2 / 2 over the flanks in contact.
    pub(crate) fn lumped_energy(&self, l: &Lumped, y: &Kin) -> f64 {
        self.lumped_flanks()
            .map(|f| 0.5 * self.lumped_stiffness(l, f) * self.flank_delta(f, y).0.powi(2))
            .sum()
    }

    /// The stiffness of the flanks in contact (the `k_mesh` output).
    pub(crate) fn lumped_mesh_stiffness(&self, l: &Lumped) -> f64 {
        self.lumped_flanks()
            .map(|f| self.lumped_stiffness(l, f))
            .sum()
    }
}
