//! The forces of the carrying pairs (spec §4): Johnson's law or the tooth structure, damping,
//! friction, the shape deviations' penetrations, and the torques they make on both wheels.

use super::{ContactModel, GearMesh, Kin, DDTE, DTE, THETA_A, W_A};
use crate::model::contact::{slot_flank, EventFn, Flank, SLOTS, SLOT_NAMES};
use crate::model::deviations::Deviations;
use crate::model::johnson::OutOfRange;
use crate::model::law::{ContactLaw, Law};
use crate::model::rig;

/// A contact left the model's range: reported with the contact, the penetration and the limit.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("contact {contact} out of the model's range: penetration {delta} m reaches {limit_name} = {limit} m")]
pub struct LawOutOfRange {
    pub contact: String,
    pub delta: f64,
    pub limit: f64,
    pub limit_name: &'static str,
}

/// Beyond the segment length no pair can be gated (s_A - delta >= s_a and s_A <= s_b): the teeth
/// would pass through each other and the mesh would carry nothing.
pub const SEGMENT_LIMIT: &str =
    "the contact segment length |ab|, beyond which the teeth would pass through each other";

/// Normal, friction and elastic force of the pair each slot holds.
pub type SlotForces = [(f64, f64, f64); SLOTS];

/// What the mesh applies to the wheels and to B's bearing, forward-positive torques.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshLoad {
    pub tq_a: f64,
    pub tq_b: f64,
    /// The force on B in the paper frame; computed only where a slider (x) or moving centres
    /// (both) need it.
    pub f_bx: f64,
    pub f_by: f64,
    pub p_loss: f64,
    /// Power of a position-dependent stiffness on the pairs' elastic energy (`ContactLaw::
    /// energy_slope`), booked with the external work.
    pub p_param: f64,
}

impl MeshLoad {
    pub fn scaled(&self, n: f64) -> MeshLoad {
        MeshLoad {
            tq_a: n * self.tq_a,
            tq_b: n * self.tq_b,
            f_bx: n * self.f_bx,
            f_by: n * self.f_by,
            p_loss: n * self.p_loss,
            p_param: n * self.p_param,
        }
    }
}

impl GearMesh {
    /// Pair k's shape deviation [e, de/dt, d2e/dt2] at y (with `dy`, the rates of y, for the
    /// last; else it reads 0). The tip relief follows the recorded ReliefA/B modes.
    pub(crate) fn deviation(
        &self,
        d: &Deviations,
        k: usize,
        y: &Kin,
        dy: Option<&Kin>,
    ) -> [f64; 3] {
        let g = &self.geo;
        let f = slot_flank(k);
        let mut e = [self.pitch_e[k], 0.0, 0.0];
        let (acc_a, acc_b) = dy.map_or((0.0, 0.0), |dy| {
            (dy[W_A], (g.r_ab * dy[W_A] - dy[DDTE]) / g.r_bb)
        });
        if d.has_runout() {
            let theta_b = (g.r_ab * y[THETA_A] - y[DTE]) / g.r_bb;
            let r = d.runout(
                f,
                [y[THETA_A], theta_b],
                [y[W_A], self.w_b(y)],
                [acc_a, acc_b],
            );
            (0..3).for_each(|i| e[i] += r[i]);
        }
        if d.relief[0].is_some() || d.relief[1].is_some() {
            let s = self.s_contact(k, y);
            let (ds, dds) = (f.dir() * g.r_ab * y[W_A], f.dir() * g.r_ab * acc_a);
            for (w, mode) in [(0, EventFn::ReliefA(k)), (1, EventFn::ReliefB(k))] {
                let (r, dr, ddr) = d.relief(w, s, self.sign[mode.index()]);
                e[0] += r;
                e[1] += dr * ds;
                e[2] += ddr * ds * ds + dr * dds;
            }
        }
        e
    }

    /// Penetration of pair k and its rate, given its flank's: with shape deviations its own.
    #[inline]
    pub(crate) fn pair_delta(&self, k: usize, y: &Kin, flank: (f64, f64)) -> (f64, f64) {
        match self.dev.as_deref() {
            None => flank,
            Some(d) => {
                let e = self.deviation(d, k, y, None);
                (flank.0 + e[0], flank.1 + e[1])
            }
        }
    }

    /// Elastic force of one pair on a carrying flank, and with damping N(delta)(1 + chi
    /// d(delta)/dt).
    #[inline]
    fn pair_force(
        &self,
        law: &Law,
        delta: f64,
        ddelta: f64,
        s_a: f64,
    ) -> Result<(f64, f64), OutOfRange> {
        let n = law.force(delta, s_a)?;
        Ok((n, n * (1.0 + self.coef.chi * ddelta)))
    }

    /// Friction force per unit normal force of a pair, and its sliding velocity (spec §4).
    pub(crate) fn friction(&self, s_a: f64, s_b: f64, w_a: f64, w_b: f64) -> (f64, f64) {
        self.friction_at(-w_a * s_a + w_b * s_b)
    }

    #[inline(always)]
    fn friction_at(&self, v_s: f64) -> (f64, f64) {
        (self.coef.mu * (v_s / self.coef.v_reg).tanh(), v_s)
    }

    /// The compliant (or lumped) mesh's load at y; `pairs` also receives each slot's normal,
    /// friction and elastic force. Errors only when the law leaves its range.
    pub fn compliant_load(
        &self,
        y: &Kin,
        pairs: Option<&mut SlotForces>,
    ) -> Result<MeshLoad, LawOutOfRange> {
        let law = match &self.law {
            ContactModel::Compliant(law) => law,
            ContactModel::Lumped(l) if self.moving_centres => {
                return Ok(self.lumped_load::<true>(l, y, pairs))
            }
            ContactModel::Lumped(l) => return Ok(self.lumped_load::<false>(l, y, pairs)),
            ContactModel::Rigid { .. } => unreachable!("a rigid mesh's load is its rig's"),
        };
        // Fixed centres take a path without the moving centres' terms: tested once per call,
        // they cost the base scenes nothing (callgrind).
        if self.moving_centres {
            self.law_load::<true>(law, y, pairs)
        } else {
            self.law_load::<false>(law, y, pairs)
        }
    }

    /// `compliant_load` under a compliant law; MOVING: `moving_centres`.
    #[inline(always)]
    fn law_load<const MOVING: bool>(
        &self,
        law: &Law,
        y: &Kin,
        mut pairs: Option<&mut SlotForces>,
    ) -> Result<MeshLoad, LawOutOfRange> {
        let w_b = self.w_b(y);
        let mut m = MeshLoad::default();
        if let Some(d) = self.dev.as_deref() {
            self.deviated_pairs::<MOVING>(law, d, y, w_b, &mut m, &mut pairs)?;
            return Ok(m);
        }
        for f in [Flank::Forward, Flank::Backward] {
            if !self.flank_present(f) || !self.flank_on(f) {
                continue;
            }
            let slots = if f == Flank::Forward { 0..2 } else { 2..4 };
            let mut gated = slots.filter(|&k| self.gated(k)).peekable();
            if gated.peek().is_none() {
                continue;
            }
            let (delta, ddelta) = self.flank_delta_of::<MOVING>(f, y);
            if law.depends_on_position() {
                self.position_dependent_pairs::<MOVING>(law, f, gated, y, w_b, &mut m, &mut pairs)?;
                continue;
            }
            // One evaluation serves every pair of the flank. Johnson's is called directly: through
            // `pair_force` it cost the base scenes 3 % more instructions (callgrind).
            let forces = match law {
                Law::Johnson(j) => {
                    let n = j.force(delta, 0.0).map_err(|e| self.out_of_range(f, e))?;
                    (n, n * (1.0 + self.coef.chi * ddelta))
                }
                _ => self
                    .pair_force(law, delta, ddelta, 0.0)
                    .map_err(|e| self.out_of_range(f, e))?,
            };
            for k in gated {
                self.apply_pair::<MOVING>(k, forces, (delta, ddelta), y, w_b, &mut m, &mut pairs);
            }
        }
        Ok(m)
    }

    /// The pairs of flank f under a law that depends on where each sits: a force each, and the
    /// work of the changing stiffness (kept out of the common path's loop).
    // What the caller holds is passed on, not looked up again in the right-hand side.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn position_dependent_pairs<const MOVING: bool>(
        &self,
        law: &Law,
        f: Flank,
        gated: impl Iterator<Item = usize>,
        y: &Kin,
        w_b: f64,
        m: &mut MeshLoad,
        pairs: &mut Option<&mut SlotForces>,
    ) -> Result<(), LawOutOfRange> {
        let (delta, ddelta) = self.flank_delta_of::<MOVING>(f, y);
        let (mut slots, mut s_a, mut count) = ([0; 2], [0.0; 2], 0);
        for k in gated {
            slots[count] = k;
            s_a[count] = self.s_contact(k, y);
            count += 1;
        }
        // Every pair's force in one call before any pair's load, so that the law's latency
        // chains of the pairs overlap (1.33x -> 1.18x contact model 1's right-hand side,
        // benches/rhs_cost.rs; forces then loads with a call per pair stayed at 1.33x).
        let mut out = [(0.0, 0.0); 2];
        law.flank_forces_and_slopes(delta, &s_a[..count], &mut out[..count])
            .map_err(|e| self.out_of_range(f, e))?;
        for (&k, &(n, slope)) in slots.iter().zip(&out).take(count) {
            m.p_param += slope * f.dir() * self.geo.r_ab * y[W_A];
            let forces = (n, n * (1.0 + self.coef.chi * ddelta));
            self.apply_pair::<MOVING>(k, forces, (delta, ddelta), y, w_b, m, pairs);
        }
        Ok(())
    }

    /// Each carrying pair at its own penetration (shape deviations): a force each, and the work
    /// that the deviations and a position-dependent stiffness do on the pair (booked with the
    /// external work: the force acts along the line of action only).
    #[inline(never)]
    fn deviated_pairs<const MOVING: bool>(
        &self,
        law: &Law,
        d: &Deviations,
        y: &Kin,
        w_b: f64,
        m: &mut MeshLoad,
        pairs: &mut Option<&mut SlotForces>,
    ) -> Result<(), LawOutOfRange> {
        for k in (0..SLOTS).filter(|&k| self.carrying(k)) {
            let f = slot_flank(k);
            let flank = self.flank_delta_of::<MOVING>(f, y);
            let e = self.deviation(d, k, y, None);
            let (delta, ddelta) = (flank.0 + e[0], flank.1 + e[1]);
            let s_a = self.s_contact(k, y);
            let forces = self
                .pair_force(law, delta, ddelta, s_a)
                .map_err(|err| self.out_of_range(f, err))?;
            m.p_param += forces.1 * e[1];
            if law.depends_on_position() {
                m.p_param += law.energy_slope(forces.0, s_a) * f.dir() * self.geo.r_ab * y[W_A];
            }
            self.apply_pair::<MOVING>(k, forces, (delta, ddelta), y, w_b, m, pairs);
        }
        Ok(())
    }

    /// Adds pair k's elastic and damped normal force `forces` and its friction to the load.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn apply_pair<const MOVING: bool>(
        &self,
        k: usize,
        (n, fn_): (f64, f64),
        (delta, ddelta): (f64, f64),
        y: &Kin,
        w_b: f64,
        m: &mut MeshLoad,
        pairs: &mut Option<&mut SlotForces>,
    ) {
        let g = &self.geo;
        let f = slot_flank(k);
        let dir = f.dir();
        // Normal force: the spec's paper-frame torques, turned into the forward sense.
        m.tq_a -= dir * fn_ * g.r_ab;
        m.tq_b += dir * fn_ * g.r_bb;
        if self.coef.chi > 0.0 {
            m.p_loss += n * self.coef.chi * ddelta * ddelta;
        }
        let mut ft = 0.0;
        if self.coef.mu > 0.0 {
            let s_a = self.s_contact(k, y);
            let s_b = g.s_b_of(s_a, delta);
            let v_s = -y[W_A] * s_a + w_b * s_b;
            let (mu_eff, v_s) = if MOVING {
                self.friction_at(v_s + self.centre_slip(f, y))
            } else {
                self.friction_at(v_s)
            };
            ft = mu_eff * fn_;
            m.tq_a += ft * s_a;
            m.tq_b -= ft * s_b;
            m.p_loss += ft * v_s;
        }
        if self.slider {
            m.f_bx += rig::force_on_b(f, fn_, ft, self.sin_a, self.cos_a).0;
        } else if MOVING {
            let (fx, fy) = rig::force_on_b(f, fn_, ft, self.sin_a, self.cos_a);
            m.f_bx += fx;
            m.f_by += fy;
        }
        if let Some(p) = pairs.as_deref_mut() {
            p[k] = (fn_, ft, n);
        }
    }

    pub(crate) fn out_of_range(&self, f: Flank, e: OutOfRange) -> LawOutOfRange {
        let names: Vec<&str> = (0..SLOTS)
            .filter(|&k| slot_flank(k) == f && self.carrying(k))
            .map(|k| SLOT_NAMES[k])
            .collect();
        LawOutOfRange {
            contact: names.join("+"),
            delta: e.delta,
            limit: e.limit,
            limit_name: self.compliance().map_or("", |l| l.limit_name()),
        }
    }
}
