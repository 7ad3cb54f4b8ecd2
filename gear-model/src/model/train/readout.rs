//! What the train reports at a state: energies, each mesh's readout and dte, the torques on
//! the housing and of the speed drives, and the meshes' statistics over the run.

use super::*;
use std::ops::Deref;

impl Train {
    /// The counter-clockwise torque the meshes and shafts apply to the housing at y.
    pub fn housing_torque(&self, y: &[f64]) -> Result<f64, LawOutOfRange> {
        // Read after every communication step: a train that does not touch the housing
        // evaluates no force law for it.
        if !self.cfg.structure.uses_housing {
            return Ok(0.0);
        }
        by_slots!(self.housing_torque_in(y))
    }

    fn housing_torque_in<const N: usize>(&self, y: &[f64]) -> Result<f64, LawOutOfRange> {
        let lat = self.cfg.lateral.is_some();
        let b = self.bodies_in::<N>(y);
        Ok(match lat {
            true => self.torques::<N, true>(y, &b, None, Some(&self.carrier_turns(&b)))?,
            false => self.torques::<N, false>(y, &b, None, None)?,
        }
        .housing)
    }

    /// The torque the drive of speed-driven body i applies at y, forward positive: what
    /// holds its speed against every other torque on it.
    pub fn drive_torque(&self, i: usize, y: &[f64]) -> Result<f64, LawOutOfRange> {
        by_slots!(self.drive_torque_in(i, y))
    }

    fn drive_torque_in<const N: usize>(&self, i: usize, y: &[f64]) -> Result<f64, LawOutOfRange> {
        let b = self.bodies_in::<N>(y);
        if self.cfg.lateral.is_none() {
            return Ok(-self.torques::<N, false>(y, &b, None, None)?.on[i]);
        }
        let mut q = [[0.0; 2]; MAX_BODIES];
        let turns = self.carrier_turns(&b);
        Ok(-self
            .torques::<N, true>(y, &b, Some(&mut q), Some(&turns))?
            .on[i])
    }

    /// The bodies' rotations' kinetic energy (a rigid planet's orbit in its carrier's
    /// inertia) and the lateral bodies' translations'.
    pub(super) fn kinetic_energy(&self, y: &[f64], b: &Bodies) -> f64 {
        let c = &*self.cfg;
        let turning: f64 = (0..c.j_eff.len())
            .map(|i| 0.5 * c.j_eff[i] * b.w[i] * b.w[i])
            .sum();
        if c.lateral.is_none() {
            return turning;
        }
        turning + self.lateral_energy(y, b).0
    }

    /// Elastic energy of the meshes' carrying pairs, of the shafts and of the bearings.
    pub fn elastic_energy(&self, y: &[f64]) -> Result<f64, LawOutOfRange> {
        let c = &*self.cfg;
        let b = self.bodies(y);
        let mut e = self.lateral_energy(y, &b).1;
        for (j, sh) in c.spec.shafts.iter().enumerate() {
            let twist = self.shaft_state(j, y, Some(&b)).0;
            e += 0.5 * sh.k * twist * twist;
        }
        for (m, mesh) in self.meshes.iter().enumerate() {
            e += mesh
                .contact_energy(&self.kin(m, y, &b))
                .map_err(|e| named(m, e))?;
        }
        Ok(e)
    }

    /// (E_kin + E_el + W_loss - W_ext - E_gate, E_kin, E_el).
    pub(super) fn energy_terms(&self, y: &[f64]) -> Result<(f64, f64, f64), LawOutOfRange> {
        let e_kin = self.kinetic_energy(y, &self.bodies(y));
        let e_el = self.elastic_energy(y)?;
        Ok((
            e_kin + e_el + y[W_LOSS] - y[W_EXT] - self.e_gate,
            e_kin,
            e_el,
        ))
    }

    /// (E_kin, E_el, the balance's residual against t = 0).
    pub fn energy(&self, y: &[f64]) -> Result<(f64, f64, f64), LawOutOfRange> {
        let (balance, e_kin, e_el) = self.energy_terms(y)?;
        Ok((e_kin, e_el, balance - self.e_start))
    }

    /// Mesh m's readout at y.
    pub fn mesh_readout(&self, m: usize, y: &[f64]) -> Result<mesh::MeshReadout, LawOutOfRange> {
        self.mesh_readout_at(m, y, &self.bodies(y))
    }

    /// The same with the bodies at y already at hand (every mesh's outputs after a step).
    pub fn mesh_readout_at(
        &self,
        m: usize,
        y: &[f64],
        b: &Bodies,
    ) -> Result<mesh::MeshReadout, LawOutOfRange> {
        let k = self.kin(m, y, b);
        let (pairs, load) = self.meshes[m]
            .compliant_pair_forces(&k)
            .map_err(|e| named(m, e))?;
        Ok(self.meshes[m].readout_from(&k, &pairs, &load))
    }

    /// Mesh m's dte (its forward penetration) at y.
    pub fn dte(&self, m: usize, y: &[f64]) -> f64 {
        self.dte_and_rate(m, y).0
    }

    /// Mesh m's dte rate at y.
    pub fn dte_rate(&self, m: usize, y: &[f64]) -> f64 {
        self.dte_and_rate(m, y).1
    }

    /// Adds the piece [t0, t1] (modes fixed) to each mesh's statistics.
    pub fn observe<Y: Deref<Target = [f64]>>(
        &mut self,
        t0: f64,
        t1: f64,
        y: &dyn Fn(f64) -> Y,
    ) -> Result<(), LawOutOfRange> {
        let Some(mut all) = self.stats.take() else {
            return Ok(());
        };
        let mut r = Ok(());
        for (m, s) in all.iter_mut().enumerate() {
            r = r.and(self.add_statistics(m, s, t0, t1, y));
        }
        self.stats = Some(all);
        r
    }

    pub fn add_statistics<Y: Deref<Target = [f64]>>(
        &self,
        m: usize,
        s: &mut Statistics,
        t0: f64,
        t1: f64,
        y: &dyn Fn(f64) -> Y,
    ) -> Result<(), LawOutOfRange> {
        let force = |t: f64| -> Result<f64, LawOutOfRange> {
            let r = self.mesh_readout(m, &y(t))?;
            Ok(r.flank_force[0] + r.flank_force[1])
        };
        s.add(
            self.meshes[m].contact_modes(),
            t0,
            t1,
            &|t| self.dte(m, &y(t)),
            &force,
        )
    }
}
