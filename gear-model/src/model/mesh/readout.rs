//! What a mesh shows at a state: each object's force and contact point, the flanks' totals,
//! the torques, the force on B, the mesh stiffness and the pairs' elastic energy.

use super::forces::{LawOutOfRange, MeshLoad, SlotForces};
use super::{GearMesh, Kin};
use crate::model::contact::{slot_flank, Flank, SLOTS};
use crate::model::johnson::OutOfRange;
use crate::model::law::ContactLaw;
use crate::model::rig;

/// One mesh's readout (the FMI layers map it onto their outputs).
#[derive(Clone, Debug, Default)]
pub struct MeshReadout {
    /// Normal force of each contact object (slots f1, f2, b1, b2).
    pub pair_force: [f64; SLOTS],
    /// Each object's contact point on the line of action, from K_A.
    pub contact_point: [f64; SLOTS],
    /// Total normal force and number of carrying pairs, forward and backward flank.
    pub flank_force: [f64; 2],
    pub flank_pairs: [u32; 2],
    /// Mesh torques on A and B, forward positive.
    pub tq_a: f64,
    pub tq_b: f64,
    /// Power dissipated in the contacts (damping and friction).
    pub p_loss: f64,
    /// The mesh force on B (x, y), paper frame.
    pub force_on_b: [f64; 2],
    /// Tangent stiffness of the carrying pairs \[N/m\].
    pub k_mesh: f64,
}

impl GearMesh {
    /// Normal, friction and elastic force of every slot of a compliant mesh, and their load.
    pub fn compliant_pair_forces(&self, y: &Kin) -> Result<(SlotForces, MeshLoad), LawOutOfRange> {
        let mut pairs = [(0.0, 0.0, 0.0); SLOTS];
        let load = self.compliant_load(y, Some(&mut pairs))?;
        Ok((pairs, load))
    }

    /// The readout at y from the slots' forces and their load (the rig computes those: a rigid
    /// contact's come from its constraint force). Inlined: it runs after every communication
    /// step, and a call costs ~60 instructions.
    #[inline(always)]
    pub fn readout_from(&self, y: &Kin, pairs: &SlotForces, load: &MeshLoad) -> MeshReadout {
        let mut s = [0.0; SLOTS];
        let (mut flank_force, mut flank_pairs) = ([0.0; 2], [0; 2]);
        let parked = [self.parked(Flank::Forward), self.parked(Flank::Backward)];
        let mut force_on_b = [0.0; 2];
        let (mut k_mesh, mut flank_stiffness) = (0.0, [None; 2]);
        let law = self.compliance();
        let untracked = self.pairs_untracked();
        for k in 0..SLOTS {
            if !self.present[k] {
                continue;
            }
            s[k] = if parked[slot_flank(k) as usize] || untracked {
                self.placed_contact(k, y)
            } else {
                self.s_contact(k, y)
            };
            let carrying = if untracked {
                self.flank_on(slot_flank(k)) && self.gated_at(k, y)
            } else {
                self.carrying(k)
            };
            if carrying {
                let f = slot_flank(k);
                flank_force[f as usize] += pairs[k].0;
                flank_pairs[f as usize] += 1;
                let (fx, fy) = rig::force_on_b(f, pairs[k].0, pairs[k].1, self.sin_a, self.cos_a);
                force_on_b[0] += fx;
                force_on_b[1] += fy;
                if let Some(law) = law {
                    let fi = f as usize;
                    let own = law.depends_on_position() || self.dev.is_some();
                    if own || flank_stiffness[fi].is_none() {
                        let delta = self.pair_delta(k, y, self.flank_delta(f, y)).0;
                        flank_stiffness[fi] = Some(law.stiffness_at_force(pairs[k].2, delta, s[k]));
                    }
                    k_mesh += flank_stiffness[fi].expect("just set");
                }
            }
        }
        if let Some(l) = self.lumped() {
            k_mesh = self.lumped_mesh_stiffness(l);
        }
        MeshReadout {
            pair_force: pairs.map(|p| p.0),
            contact_point: s,
            flank_force,
            flank_pairs,
            tq_a: load.tq_a,
            tq_b: load.tq_b,
            p_loss: load.p_loss,
            force_on_b,
            k_mesh,
        }
    }

    /// Tangent stiffness \[N/m\] of the carrying compliant contacts, summed.
    pub fn mesh_stiffness(&self, y: &Kin) -> f64 {
        if let Some(l) = self.lumped() {
            return self.lumped_mesh_stiffness(l);
        }
        let Some(law) = self.compliance() else {
            return 0.0;
        };
        let mut k = 0.0;
        for f in [Flank::Forward, Flank::Backward] {
            k += self
                .per_carrying_pair(f, y, |delta, s| law.stiffness(delta, s))
                .unwrap_or(0.0);
        }
        k
    }

    /// Elastic energy of the carrying pairs.
    pub fn contact_energy(&self, y: &Kin) -> Result<f64, LawOutOfRange> {
        if let Some(l) = self.lumped() {
            return Ok(self.lumped_energy(l, y));
        }
        let mut e = 0.0;
        let Some(law) = self.compliance() else {
            return Ok(e);
        };
        for f in [Flank::Forward, Flank::Backward] {
            e += self
                .per_carrying_pair(f, y, |delta, s| law.energy(delta, s))
                .map_err(|err| self.out_of_range(f, err))?;
        }
        Ok(e)
    }

    /// The sum of `value(delta_i, s_A)` over the carrying pairs of flank f: one evaluation for
    /// all of them when they share delta and the law does not depend on the position.
    fn per_carrying_pair(
        &self,
        f: Flank,
        y: &Kin,
        value: impl Fn(f64, f64) -> Result<f64, OutOfRange>,
    ) -> Result<f64, OutOfRange> {
        let slots = (0..SLOTS).filter(|&k| slot_flank(k) == f && self.carrying(k));
        let flank = self.flank_delta(f, y);
        if self.dev.is_some() || self.compliance().is_some_and(|l| l.depends_on_position()) {
            slots
                .map(|k| value(self.pair_delta(k, y, flank).0, self.s_contact(k, y)))
                .sum()
        } else {
            let count = slots.count();
            Ok(if count > 0 {
                count as f64 * value(flank.0, 0.0)?
            } else {
                0.0
            })
        }
    }

    /// The penetration of one pair under the force `force` \[N\] along the line of action, and
    /// the pairs' stiffness there: the scales of a mesh's error tolerances (1e-12 m floor).
    pub fn static_scale(&self, force: f64) -> (f64, f64) {
        if let Some(l) = self.lumped() {
            return ((force / l.k).max(1e-12), l.k);
        }
        let g = &self.geo;
        let law = self.compliance();
        let delta = match law {
            Some(l) if force > 0.0 => l.static_delta(force),
            _ => 0.0,
        };
        let delta = if delta.is_finite() {
            delta.max(1e-12)
        } else {
            1e-12
        };
        let mid = 0.5 * (g.s_a + g.s_b);
        let k = law.map_or(0.0, |l| l.stiffness(delta, mid).unwrap_or(0.0));
        (delta, k)
    }
}
