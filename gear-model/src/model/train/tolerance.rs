//! The integrator's error scales: each coordinate's absolute tolerance from the load it
//! carries when the train turns rigidly.

use super::*;

impl Train {
    /// The load each coordinate carries when the train turns rigidly under the current
    /// torques (drag and vibration left out): the scale of its error tolerance. With theta =
    /// T x, the free coordinates accelerate as (T^T J T)_FF a = (T^T tau)_F, and an edge's
    /// coordinate needs the generalized force (T^T J T)_EF a - (T^T tau)_E: a mesh's normal
    /// force, a shaft's torque. A loop's meshes share the load; this books it on the steps.
    /// A speed-driven body's coordinate does not accelerate: its drive takes the rest.
    fn static_loads(&self) -> Vec<f64> {
        let c = &*self.cfg;
        let t = &c.coords.t;
        let n = t.ncols();
        let j = DMatrix::from_diagonal(&DVector::from_column_slice(&c.j_eff));
        let m = t.transpose() * j * t;
        let tau = DVector::from_iterator(n, self.loads.tau.iter().copied());
        let q = t.transpose() * tau;
        let free: Vec<usize> = (0..n)
            .filter(|&k| matches!(c.coords.coords[k], Coord::Body(i) if !c.driven.contains(&i)))
            .collect();
        let mff = DMatrix::from_fn(free.len(), free.len(), |r, s| m[(free[r], free[s])]);
        let qf = DVector::from_iterator(free.len(), free.iter().map(|&k| q[k]));
        // Every body speed-driven (or held by them): nothing accelerates.
        let a = match free.len() {
            0 => DVector::zeros(0),
            _ => mff
                .lu()
                .solve(&qf)
                .unwrap_or_else(|| DVector::zeros(free.len())),
        };
        (0..n)
            .map(|k| {
                let need: f64 = free
                    .iter()
                    .enumerate()
                    .map(|(r, &f)| m[(k, f)] * a[r])
                    .sum();
                need - q[k]
            })
            .collect()
    }

    /// Absolute tolerances at a relative tolerance: 1 rad and 1 rad/s for a free body's
    /// angle (relative control above); for a mesh, the static penetration of one pair under
    /// its load (floor 1e-12 m) and that penetration at the mesh's natural frequency, as in
    /// the single mesh; for a shaft, its static twist (floor 1e-12 rad) and that twist at its
    /// own frequency. 0: not under error control (the quadratures).
    pub fn abs_tol(&self, rel_tol: f64) -> State {
        let c = &*self.cfg;
        let load = self.static_loads();
        let mut atol = State::zeros();
        for (k, coord) in c.coords.coords.iter().enumerate() {
            let i = coord_index(k);
            let mobility = c.mobility(&c.coords.rows[k]);
            let (x, omega) = match *coord {
                Coord::Body(_) => (1.0, 1.0),
                Coord::Edge(Edge::Mesh(m)) => {
                    let (delta, stiffness) = self.meshes[m].static_scale(load[k].abs());
                    (delta, (stiffness * mobility).sqrt())
                }
                Coord::Edge(Edge::Shaft(j)) => {
                    let sh = &c.spec.shafts[j];
                    ((load[k].abs() / sh.k).max(1e-12), (sh.k * mobility).sqrt())
                }
            };
            atol[i] = rel_tol * x;
            atol[i + 1] = rel_tol * (x * omega).max(1e-12);
            if matches!(coord, Coord::Body(_)) {
                atol[i + 1] = rel_tol;
            }
        }
        if let Some(lat) = &c.lateral {
            // A lateral displacement adds to the meshes' penetrations: their finest scale.
            let finest = |off: usize| {
                (0..c.coords.coords.len())
                    .filter(|&k| matches!(c.coords.coords[k], Coord::Edge(Edge::Mesh(_))))
                    .map(|k| atol[coord_index(k) + off])
                    .fold(f64::INFINITY, f64::min)
            };
            let (x, v) = match (finest(0), finest(1)) {
                (x, v) if x.is_finite() => (x, v),
                _ => (rel_tol * 1e-12, rel_tol * 1e-12),
            };
            for lb in &lat.bodies {
                for d in 0..2 {
                    atol[lb.at + 2 * d] = x;
                    atol[lb.at + 2 * d + 1] = v;
                }
            }
        }
        atol
    }
}
