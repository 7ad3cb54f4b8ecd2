//! Rigid contact on the paper rig (`contact_model = 2`, rig-and-modes.md §2): the constraint
//! force of a locked flank, impacts, locks and releases. The laws are in `model::rigid`; the
//! modes (which flank is locked, which is parked) are the mesh's recorded signs.

use super::{kin, PaperRig, State, DDTE, DTE, NY, V_S, W_A, W_LOSS, X_S};
use crate::model::contact::{slot_flank, EventFn, Flank, SLOTS};
use crate::model::mesh::{describe, other, ContactModel, MeshLoad, SlotForces};
use crate::model::rig;
use crate::model::rigid::{self, Impact};

impl PaperRig {
    /// The load of a locked flank per newton of total constraint force, with the equal split
    /// between its gated pairs; `None` when no pair is gated there.
    fn unit_load(&self, f: Flank, y: &State) -> Option<MeshLoad> {
        let g = &self.geo;
        let slots = if f == Flank::Forward { 0..2 } else { 2..4 };
        let n = slots.clone().filter(|&k| self.gated(k)).count();
        if n == 0 {
            return None;
        }
        let dir = f.dir();
        let share = 1.0 / n as f64;
        // Without friction the normal forces of the pairs add up to N along the line of action.
        let mut m = MeshLoad {
            tq_a: -dir * g.r_ab,
            tq_b: dir * g.r_bb,
            f_bx: self.sin_a,
            ..MeshLoad::default()
        };
        if self.mesh.coef.mu > 0.0 {
            let (w_a, w_b) = (y[W_A], self.w_b(y));
            for k in slots.filter(|&k| self.gated(k)) {
                let s_a = self.s_contact(k, y);
                let s_b = g.s_b_of(s_a, 0.0);
                let (mu_eff, v_s) = self.mesh.friction(s_a, s_b, w_a, w_b);
                let ft = mu_eff * share;
                m.tq_a += ft * s_a;
                m.tq_b -= ft * s_b;
                m.p_loss += ft * v_s;
                m.f_bx += rig::force_on_b(f, 0.0, ft, self.sin_a, self.cos_a).0;
            }
        }
        Some(m)
    }

    /// Total constraint force that keeps flank f locked, with the current gates and speeds.
    pub(crate) fn constraint_force(&self, f: Flank, y: &State) -> Option<(f64, MeshLoad)> {
        let unit = self.unit_load(f, y)?;
        let g = &self.geo;
        let c = &*self.cfg;
        // d^2 delta/dt^2 = a0 + a1 N: the free acceleration and the effect of a unit N.
        // The free accelerations as in `accelerations_given`, by reciprocals: this runs at every
        // communication point of a locked rigid mesh, where the chain of three divisions was
        // a tenth of the wall time. (The compliant right-hand side keeps its divisions, and so
        // its trajectories bit for bit.)
        let l = &self.loads_at(y);
        let w_b = (g.r_ab * y[W_A] - y[DDTE]) * c.inv_r_bb;
        let dw_a = l.tau_a * c.inv_j_a + l.alpha_housing;
        let acc_b = (l.tau_b - l.c_load * w_b) * c.inv_j_b - g.kappa * l.alpha_housing;
        let inv_m = c.slider.map_or(0.0, |s| 1.0 / s.m);
        let acc_x = c.slider.map_or(0.0, |s| {
            -(s.k * y[X_S] + s.c * y[V_S]) * inv_m - l.a_housing_x
        });
        let a0 = f.dir() * (g.r_ab * dw_a - g.r_bb * acc_b) - self.sin_a * acc_x;
        // Without friction a1 = -1/m_eff.
        let a1 = f.dir() * (g.r_ab * unit.tq_a * c.inv_j_a - g.r_bb * unit.tq_b * c.inv_j_b)
            - self.sin_a * unit.f_bx * inv_m;
        let n = rigid::lock_force(a0, a1)?;
        Some((n, unit))
    }

    /// The rigid mesh's load, its locked flank and constraint force (none when free).
    pub(crate) fn rigid_load(&self, y: &State) -> (MeshLoad, Option<(Flank, f64)>) {
        match self.locked() {
            Some(f) => match self.constraint_force(f, y) {
                Some((n, unit)) => (unit.scaled(n), Some((f, n))),
                None => (MeshLoad::default(), None),
            },
            None => (MeshLoad::default(), None),
        }
    }

    /// Each slot's normal, friction and elastic force under a lock (N split equally), and the
    /// load.
    pub(crate) fn rigid_pair_forces(&self, y: &State) -> (SlotForces, MeshLoad) {
        let mut pairs = [(0.0, 0.0, 0.0); SLOTS];
        let (load, locked) = self.rigid_load(y);
        if let Some((f, n)) = locked {
            let gated = || (0..SLOTS).filter(move |&k| slot_flank(k) == f && self.gated(k));
            // 1 or 2 pairs: the product by the exact reciprocal is the quotient, without a
            // second division after the constraint force's.
            let share = [1.0, 0.5][gated().count() - 1];
            let (w_a, w_b) = (y[W_A], self.w_b(y));
            for k in gated() {
                let fn_ = n * share;
                let mut ft = 0.0;
                if self.mesh.coef.mu > 0.0 {
                    let s_a = self.s_contact(k, y);
                    ft = self
                        .mesh
                        .friction(s_a, self.geo.s_b_of(s_a, 0.0), w_a, w_b)
                        .0
                        * fn_;
                }
                pairs[k] = (fn_, ft, fn_);
            }
        }
        (pairs, load)
    }

    /// The release margin of a locked flank is its constraint force (-1 when none holds).
    pub(crate) fn fill_rigid_release(&self, y: &State, out: &mut [f64]) {
        for f in [Flank::Forward, Flank::Backward] {
            let i = EventFn::Rel(f).index();
            if self.locked() == Some(f) {
                let v = self.constraint_force(f, y).map_or(-1.0, |c| c.0);
                out[i] = if self.sign[i] { v } else { -v };
            }
        }
    }

    /// The rigid contact at t = 0 (rig-and-modes §2): a flank touching with delta = 0 is an
    /// impact if it approaches faster than double precision resolves, free if it separates,
    /// else locked when the constraint force is >= 0.
    pub(crate) fn init_rigid(&mut self, y: &mut State) {
        let g = &self.geo;
        let res = rigid::speed_resolution(g.r_ab, g.r_bb, y[W_A], self.w_b(y));
        for f in [Flank::Forward, Flank::Backward] {
            let (delta, rate) = self.flank_delta(f, y);
            if !self.flank_present(f) || delta != 0.0 || self.locked().is_some() {
                continue;
            }
            if rate > res {
                self.impact(f, y);
            } else if rate >= -res {
                self.try_lock(f, y);
            }
        }
    }

    /// A rigid tooth impact on flank f (Newton's law), then a lock if the rebound is too short
    /// to resolve (see `rigid::Impact::ends_in_lock`). Returns what happened.
    pub(crate) fn impact(&mut self, f: Flank, y: &mut State) -> String {
        let ContactModel::Rigid {
            restitution,
            two_sided,
        } = self.law
        else {
            unreachable!("impacts are rigid-contact events")
        };
        let e_kin = self.kinetic_energy(y);
        // The event was located just past delta = 0: put the teeth exactly on the flank, so the
        // rebound starts from delta = 0 and the event cannot fire again at its own restart.
        self.touch(f, y);
        let (_, rate) = self.flank_delta(f, y);
        let g = &self.geo;
        if rate < -rigid::speed_resolution(g.r_ab, g.r_bb, y[W_A], self.w_b(y)) {
            return describe!(self.mesh, "{f:?} flank grazed while separating: no impact");
        }
        let v_minus = rate.max(0.0);
        // No room to rebound into with two-sided contact: the impact is plastic.
        let e = if two_sided { 0.0 } else { restitution };
        let imp = Impact::new(v_minus, e, self.cfg.inv_m_eff);
        self.apply_impulse(f, imp.impulse, y);
        let g = &self.geo;
        let mut dy = [0.0; NY];
        self.motion(y, &MeshLoad::default(), None, &mut dy);
        let approach = f.dir() * dy[DDTE] - self.sin_a * dy[V_S];
        let res = rigid::speed_resolution(g.r_ab, g.r_bb, y[W_A], self.w_b(y));
        let locked = (e == 0.0 || imp.ends_in_lock(approach, res)) && self.try_lock(f, y);
        self.n_impacts += 1;
        y[W_LOSS] += e_kin - self.kinetic_energy(y);
        describe!(
            self.mesh,
            "{f:?} flank impact at {v_minus:.6e} m/s, rebound {:.6e} m/s: {}",
            imp.rebound_speed,
            if locked { "locks" } else { "free" }
        )
    }

    /// Sets dte so that flank f's penetration is exactly 0.
    fn touch(&self, f: Flank, y: &mut State) {
        let x = y[X_S] * self.sin_a;
        y[DTE] = match f {
            Flank::Forward => x,
            Flank::Backward => -self.backlash - x,
        };
    }

    /// An impulse p along flank f's line of action, pushing the teeth apart (rig-and-modes §2:
    /// forward, J_A dw_A = -P rAb and J_B dw_B = +P rBb; backward the opposite; the slider
    /// takes P sin(alpha_w) either way).
    fn apply_impulse(&self, f: Flank, p: f64, y: &mut State) {
        let g = &self.geo;
        let c = &*self.cfg;
        let dir = f.dir();
        y[W_A] -= dir * p * g.r_ab / c.j_a;
        y[DDTE] -= dir * p * (g.r_ab * g.r_ab / c.j_a + g.r_bb * g.r_bb / c.j_b);
        if let Some(s) = c.slider {
            y[V_S] += p * self.sin_a / s.m;
        }
    }

    /// Locks flank f if its constraint force is >= 0 (two-sided: either flank, by the sign of
    /// N). A lock is a plastic impact: the impulse along the line of action that stops the
    /// relative normal motion; the penetration and its rate are then exactly 0.
    fn try_lock(&mut self, f: Flank, y: &mut State) -> bool {
        let mut candidates = vec![f];
        if self.two_sided() {
            candidates.push(other(f));
        }
        for c in candidates {
            let mut yl = *y;
            let rate = self.flank_delta(c, &yl).1;
            self.apply_impulse(c, rate / self.cfg.inv_m_eff, &mut yl);
            self.touch(c, &mut yl);
            let vx = yl[V_S] * self.sin_a;
            yl[DDTE] = match c {
                Flank::Forward => vx,
                Flank::Backward => -vx,
            };
            if matches!(self.constraint_force(c, &yl), Some((n, _)) if n >= 0.0) {
                self.mesh.sign[EventFn::Pen(c).index()] = true;
                self.mesh.sign[EventFn::Rel(c).index()] = true;
                *y = yl;
                return true;
            }
        }
        false
    }

    /// After a change of gates or loads a locked flank must still press (N >= 0); else it is
    /// released (two-sided: the other flank takes over).
    pub(crate) fn recheck_lock(&mut self, y: &mut State) -> Option<String> {
        let f = self.locked()?;
        if matches!(self.constraint_force(f, y), Some((n, _)) if n >= 0.0) {
            return None;
        }
        Some(self.release(f, y))
    }

    /// Wraps the objects of flank f into their windows at the current angle and re-derives their
    /// gates, as at t = 0.
    fn resume_tracking(&mut self, f: Flank, y: &State) {
        let present = self.present;
        let k_y = kin(y);
        for k in (0..SLOTS).filter(|&k| slot_flank(k) == f && present[k]) {
            self.mesh.sigma[k] = crate::model::contact::wrap_into_window(
                &self.geo,
                self.sigma[k],
                f.dir(),
                y[super::THETA_A],
            );
            self.mesh.update_teeth(k);
            self.mesh.set_sign(EventFn::Gate(k), &k_y);
        }
    }

    pub(crate) fn release(&mut self, f: Flank, y: &mut State) -> String {
        let parked = self.parked(other(f));
        self.mesh.sign[EventFn::Pen(f).index()] = false;
        if parked {
            self.resume_tracking(other(f), y);
        }
        if self.two_sided() && self.try_lock(other(f), y) {
            return describe!(
                self.mesh,
                "constraint force changes sign: the {:?} flank carries",
                other(f)
            );
        }
        describe!(
            self.mesh,
            "{f:?} flank releases (constraint force reaches 0)"
        )
    }

    /// What a rigid mesh's right-hand side depends on besides the state: the locked flank, and
    /// on it which pairs are gated (their friction arms; without friction only that one is, as
    /// the equal split does not enter the motion). A pair switch that keeps them is only
    /// bookkeeping. (The compliant mesh's free-flight switches are such too; they still restart
    /// so that today's compliant scenes keep their step sequences.)
    pub(crate) fn rigid_motion_modes(&self) -> Option<(Option<Flank>, [bool; SLOTS])> {
        if !self.rigid() {
            return None;
        }
        let locked = self.locked();
        let gated: [bool; SLOTS] = std::array::from_fn(|k| {
            locked == Some(slot_flank(k)) && self.gated(k) && self.mesh.coef.mu > 0.0
        });
        let any = locked.is_some_and(|f| (0..SLOTS).any(|k| slot_flank(k) == f && self.gated(k)));
        Some((locked.filter(|_| any), gated))
    }
}
