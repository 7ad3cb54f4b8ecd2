//! The bearings' forces (lateral.md §6). A body that is not lateral is held where
//! `planetary.md` §3 puts it, so its bearing's force is what holds it there against the mesh
//! forces (and, for a planet, what moves it on its orbit); a lateral body's is its bearing's
//! spring and damper. The housing takes the bearings' reactions and the forces on its own
//! gears.
//!
//! They are outputs after every communication step: fixed-size arrays, and each mesh frame's
//! turn computed once (a carrier's frame turns with it), so that a train that never reads them
//! pays little for them.

use super::*;
use std::f64::consts::PI;

/// The force each body's bearing exerts on it, in its support's frame: the housing's (x, y) or,
/// for a planet, its carrier's radial and tangential at the pin; and the resultant force the
/// bearings and the housing's own gears exert on the housing \[N\]. Bodies past the train's
/// read 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BearingForces {
    pub body: [[f64; 2]; MAX_BODIES],
    pub housing: [f64; 2],
}

fn rotate([x, y]: [f64; 2], (s, c): (f64, f64)) -> [f64; 2] {
    [c * x - s * y, s * x + c * y]
}

/// How mesh m's paper frame turns into its own frame (the housing's, or its carrier's at the
/// carrier's angle 0): sin and cos of its angle, and the mirror of y.
pub(super) fn frame_turn(frame: &placement::MeshFrame, internal: bool) -> ((f64, f64), f64) {
    let turn = if internal { PI } else { 0.0 };
    ((frame.beta + turn).sin_cos(), frame.s)
}

impl Train {
    /// Mesh m's force on its gear B in the housing frame, from the single mesh's force on B in
    /// its paper frame: mirrored back, turned by the frame and then by its carrier (`turns`:
    /// each carrier's sin and cos).
    fn mesh_force_on_b(&self, m: usize, paper: [f64; 2], turns: &[(f64, f64)]) -> [f64; 2] {
        let (turn, s) = self.cfg.frame_turns[m];
        let f = rotate([paper[0], s * paper[1]], turn);
        match self.cfg.frames[m].carrier {
            Some(c) => rotate(f, turns[c]),
            None => f,
        }
    }

    /// Every bearing's force at y (lateral.md §6).
    pub fn bearing_forces(&self, y: &[f64]) -> Result<BearingForces, LawOutOfRange> {
        let b = self.bodies(y);
        let mut paper = [[0.0; 2]; MAX_MESHES];
        for (m, p) in paper.iter_mut().enumerate().take(self.meshes.len()) {
            *p = self.mesh_readout_at(m, y, &b)?.force_on_b;
        }
        self.bearing_forces_with(y, &b, &paper[..self.meshes.len()])
    }

    /// The same with the bodies and each mesh's force on B in its paper frame (its readout's
    /// `force_on_b`) at y at hand. A body on a housing-fixed axis does not move: its bearing
    /// balances the mesh forces on it. A planet moves on its carrier's circle: its pin gives it
    /// m a less the mesh forces, and its carrier takes the reaction; only a planet with mass
    /// needs the right-hand side, for its carrier's acceleration.
    pub fn bearing_forces_with(
        &self,
        y: &[f64],
        b: &Bodies,
        paper: &[[f64; 2]],
    ) -> Result<BearingForces, LawOutOfRange> {
        let c = &*self.cfg;
        let n = c.spec.bodies.len();
        let st = &c.structure;
        // Each carrier's angle (it starts at 0, planetary.md §3) as sin and cos.
        let mut turns = [(0.0, 1.0); MAX_BODIES];
        for &k in &st.carriers {
            turns[k] = (st.sense[k] * b.theta[k]).sin_cos();
        }
        // Mesh forces on each body's slot, the housing's last.
        let mut on = [[0.0; 2]; SLOTS];
        for (m, &p) in paper.iter().enumerate() {
            let f = self.mesh_force_on_b(m, p, &turns);
            let l = &c.links[m];
            for k in 0..2 {
                on[l.b][k] += f[k];
                on[l.a][k] -= f[k];
            }
        }
        let heavy =
            |body: &Body| body.planet.is_some_and(|pl| pl.m != 0.0) && body.lateral.is_none();
        // A lateral body's bearing force is its spring-damper's.
        let mut lateral = [None; MAX_BODIES];
        for (i, f) in self.lateral_bearing_forces(y) {
            lateral[i] = Some(f);
        }
        let acc = if c.spec.bodies.iter().any(heavy) {
            let mut dy = State::zeros();
            self.rhs(y, &mut dy)?;
            self.bodies(&dy).w
        } else {
            [0.0; SLOTS]
        };
        let mut out = BearingForces {
            body: [[0.0; 2]; MAX_BODIES],
            housing: on[c.housing],
        };
        // Planets first: their pins' reactions load their carriers.
        let mut on_carrier = [[0.0; 2]; MAX_BODIES];
        for (i, body) in c.spec.bodies.iter().enumerate() {
            let Some(pl) = body.planet else { continue };
            let k = pl.carrier;
            if let Some(f) = lateral[i] {
                // From the pin's radial and tangential axes to the carrier's, then the housing's.
                let r = c.pins[i];
                let len = r[0].hypot(r[1]);
                let pin = rotate(rotate(f, (r[1] / len, r[0] / len)), turns[k]);
                for d in 0..2 {
                    on_carrier[k][d] -= pin[d];
                }
                out.body[i] = f;
                continue;
            }
            let (w, alpha) = (st.sense[k] * b.w[k], st.sense[k] * acc[k]);
            // a = Rot(psi) (-w^2 r + alpha J r), J a quarter turn counter-clockwise.
            let r = c.pins[i];
            let a = rotate(
                [-w * w * r[0] - alpha * r[1], -w * w * r[1] + alpha * r[0]],
                turns[k],
            );
            let pin = [pl.m * a[0] - on[i][0], pl.m * a[1] - on[i][1]];
            for d in 0..2 {
                on_carrier[k][d] -= pin[d];
            }
            // Radial outwards and tangential counter-clockwise at the pin.
            let len = r[0].hypot(r[1]);
            let er = rotate([r[0] / len, r[1] / len], turns[k]);
            out.body[i] = [
                pin[0] * er[0] + pin[1] * er[1],
                -pin[0] * er[1] + pin[1] * er[0],
            ];
        }
        for (i, body) in c.spec.bodies.iter().enumerate().take(n) {
            if body.planet.is_some() {
                continue;
            }
            let f = lateral[i].unwrap_or([
                -(on[i][0] + on_carrier[i][0]),
                -(on[i][1] + on_carrier[i][1]),
            ]);
            out.body[i] = f;
            out.housing[0] -= f[0];
            out.housing[1] -= f[1];
        }
        Ok(out)
    }
}
