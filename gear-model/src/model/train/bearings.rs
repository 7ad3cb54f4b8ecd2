//! The bearings' forces (lateral.md §6) of a torsional train: every body's centre is held where
//! `planetary.md` §3 puts it, so its bearing's force is what holds it there against the mesh
//! forces (and, for a planet, what moves it on its orbit). The housing takes the bearings'
//! reactions and the forces on its own gears.

use super::*;
use std::f64::consts::PI;

/// The force each body's bearing exerts on it, in its support's frame: the housing's (x, y) or,
/// for a planet, its carrier's radial and tangential at the pin; and the resultant force the
/// bearings and the housing's own gears exert on the housing \[N\].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BearingForces {
    pub body: Vec<[f64; 2]>,
    pub housing: [f64; 2],
}

fn rotate([x, y]: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, c) = angle.sin_cos();
    [c * x - s * y, s * x + c * y]
}

impl Train {
    /// A carrier's absolute angle: it starts at 0 (planetary.md §3).
    fn carrier_angle(&self, c: usize, b: &Bodies) -> f64 {
        self.cfg.structure.sense[c] * b.theta[c]
    }

    /// Mesh m's force on its gear B in the housing frame: the single mesh's force on B in its
    /// paper frame, mirrored back and turned by the frame's angle (with the carrier's).
    fn mesh_force_on_b(&self, m: usize, r: &mesh::MeshReadout, b: &Bodies) -> [f64; 2] {
        let fr = &self.cfg.frames[m];
        let g = &self.meshes[m].geo;
        let turn = if g.internal { PI } else { 0.0 };
        let carrier = fr.carrier.map_or(0.0, |c| self.carrier_angle(c, b));
        rotate(
            [r.force_on_b[0], fr.s * r.force_on_b[1]],
            fr.beta + turn + carrier,
        )
    }

    /// Every bearing's force at y (lateral.md §6). A body on a housing-fixed axis does not
    /// move: its bearing balances the mesh forces on it. A planet moves on its carrier's circle:
    /// its pin gives it m a less the mesh forces, and its carrier takes the reaction.
    pub fn bearing_forces(&self, y: &State) -> Result<BearingForces, LawOutOfRange> {
        let b = self.bodies(y);
        let readouts = (0..self.meshes.len())
            .map(|m| self.mesh_readout_at(m, y, &b))
            .collect::<Result<Vec<_>, _>>()?;
        self.bearing_forces_with(y, &b, &readouts)
    }

    /// The same with the bodies and every mesh's readout at y at hand (the outputs after a
    /// step): only a planet with mass needs the right-hand side, for its carrier's acceleration.
    pub fn bearing_forces_with(
        &self,
        y: &State,
        b: &Bodies,
        readouts: &[mesh::MeshReadout],
    ) -> Result<BearingForces, LawOutOfRange> {
        let c = &*self.cfg;
        let n = c.spec.bodies.len();
        // Mesh forces on each body's slot, the housing's last.
        let mut on = vec![[0.0; 2]; n + 1];
        for (m, r) in readouts.iter().enumerate() {
            let f = self.mesh_force_on_b(m, r, b);
            let l = &c.links[m];
            for k in 0..2 {
                on[l.b][k] += f[k];
                on[l.a][k] -= f[k];
            }
        }
        let heavy = |body: &Body| body.planet.is_some_and(|pl| pl.m != 0.0);
        let acc = if c.spec.bodies.iter().any(heavy) {
            let mut dy = State::zeros();
            self.rhs(y, &mut dy)?;
            self.bodies(&dy).w
        } else {
            [0.0; SLOTS]
        };
        let mut force = vec![[0.0; 2]; n];
        // Planets first: their pins' reactions load their carriers.
        let mut on_carrier = vec![[0.0; 2]; n];
        for (i, body) in c.spec.bodies.iter().enumerate() {
            let Some(pl) = body.planet else { continue };
            let k = pl.carrier;
            let sense = c.structure.sense[k];
            let (psi, w, alpha) = (self.carrier_angle(k, b), sense * b.w[k], sense * acc[k]);
            // a = Rot(psi) (-w^2 r + alpha J r), J a quarter turn counter-clockwise.
            let r = c.pins[i];
            let a = rotate(
                [-w * w * r[0] - alpha * r[1], -w * w * r[1] + alpha * r[0]],
                psi,
            );
            let pin = [pl.m * a[0] - on[i][0], pl.m * a[1] - on[i][1]];
            for d in 0..2 {
                on_carrier[k][d] -= pin[d];
            }
            // Radial outwards and tangential counter-clockwise at the pin.
            let radial = rotate(r, psi);
            let len = r[0].hypot(r[1]);
            let (er, et) = (
                [radial[0] / len, radial[1] / len],
                [-radial[1] / len, radial[0] / len],
            );
            force[i] = [
                pin[0] * er[0] + pin[1] * er[1],
                pin[0] * et[0] + pin[1] * et[1],
            ];
        }
        let mut housing = on[n];
        for (i, body) in c.spec.bodies.iter().enumerate() {
            if body.planet.is_some() {
                continue;
            }
            force[i] = [
                -(on[i][0] + on_carrier[i][0]),
                -(on[i][1] + on_carrier[i][1]),
            ];
            housing[0] -= force[i][0];
            housing[1] -= force[i][1];
        }
        Ok(BearingForces {
            body: force,
            housing,
        })
    }
}
