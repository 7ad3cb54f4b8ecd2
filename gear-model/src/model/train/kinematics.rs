//! The train's coordinates (planetary.md §4): the bodies no rigid rolling lets turn, the
//! generalized coordinates the integrator uses, and how every body's angle and every mesh's
//! dte follow from them.
//!
//! The coordinates are one per body: every mesh's dte that is independent of the others'
//! (the placing walk's meshes first), then the shafts' twists, then the angles of the
//! lowest-numbered bodies that complete a basis; the state holds the bodies' angles first.
//! The bodies follow from the coordinates by the inverse of that linear map. A mesh that is
//! not a coordinate has its dte as a combination of the meshes' alone (rigid rolling leaves
//! it unchanged, so its coefficients on the free angles vanish), and it keeps full precision
//! however far the bodies turn.

use super::placement::{Layout, Start};
use super::topology::{body_name, Edge, Structure, TrainSpec, HOUSING};
use crate::model::geometry::Geometry;
use crate::model::ModelError;
use nalgebra::{DMatrix, SymmetricEigen};

/// A linear form over the bodies' forward angles, the housing left out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row(pub Vec<(usize, f64)>);

impl Row {
    #[inline]
    pub fn dot(&self, x: &[f64]) -> f64 {
        self.0.iter().map(|&(i, c)| c * x[i]).sum()
    }
}

/// Mesh m's dte - dte0 over the bodies' forward angles: rAb theta_A^rel - rBb theta_B^rel,
/// with theta^rel = theta - sigma sigma_c theta_c in a carrier's frame (a housing end has
/// theta 0 and the sense the mesh gives it).
pub fn mesh_row(spec: &TrainSpec, st: &Structure, g: &Geometry, m: usize) -> Row {
    let mp = &spec.meshes[m];
    let (sa, sb) = st.mesh_sense[m];
    let mut row = Vec::with_capacity(3);
    if mp.a != HOUSING {
        row.push((mp.a, g.r_ab));
    }
    if mp.b != HOUSING {
        row.push((mp.b, -g.r_bb));
    }
    if let Some(c) = st.frame[m] {
        let sc = st.sense[c];
        row.push((c, -g.r_ab * sa * sc + g.r_bb * sb * sc));
    }
    Row(row)
}

/// Shaft j's twist - twist_start: theta_a - theta_b.
pub fn shaft_row(spec: &TrainSpec, j: usize) -> Row {
    let sh = &spec.shafts[j];
    let mut row = Vec::with_capacity(2);
    if sh.a != HOUSING {
        row.push((sh.a, 1.0));
    }
    if sh.b != HOUSING {
        row.push((sh.b, -1.0));
    }
    Row(row)
}

/// Refuses the bodies that no rigid rolling motion of the meshes lets turn (planetary.md
/// §4): each mesh a rolling constraint relative to its frame, in absolute angles (so a loop
/// whose senses conflict shows as jammed first), shafts absent.
pub fn check_jammed(spec: &TrainSpec, st: &Structure, geo: &[Geometry]) -> Result<(), ModelError> {
    let n = spec.bodies.len();
    if spec.meshes.is_empty() {
        return Ok(());
    }
    let mut a = DMatrix::<f64>::zeros(spec.meshes.len(), n);
    for (m, mp) in spec.meshes.iter().enumerate() {
        let g = &geo[m];
        // External: rAb w_A^rel + rBb w_B^rel = 0; internal: rAb w_A^rel - rBb w_B^rel = 0.
        let rb = g.kappa * g.r_bb;
        if mp.a != HOUSING {
            a[(m, mp.a)] += g.r_ab;
        }
        if mp.b != HOUSING {
            a[(m, mp.b)] += rb;
        }
        if let Some(c) = st.frame[m] {
            a[(m, c)] -= g.r_ab + rb;
        }
    }
    let eig = SymmetricEigen::new(a.transpose() * &a);
    let top = eig.eigenvalues.amax();
    // Null directions: eigenvalues at the rounding of a sum of r^2 terms.
    let null: Vec<usize> = (0..n)
        .filter(|&k| eig.eigenvalues[k] <= 1e-12 * top)
        .collect();
    let jammed: Vec<usize> = (0..n)
        .filter(|&i| {
            let motion: f64 = null.iter().map(|&k| eig.eigenvectors[(i, k)].powi(2)).sum();
            motion <= 1e-12
        })
        .collect();
    if jammed.is_empty() {
        return Ok(());
    }
    let meshes: Vec<String> = spec
        .meshes
        .iter()
        .enumerate()
        .filter(|(m, mp)| {
            jammed.contains(&mp.a)
                || jammed.contains(&mp.b)
                || st.frame[*m].is_some_and(|c| jammed.contains(&c))
        })
        .map(|(m, _)| Edge::Mesh(m).name())
        .collect();
    Err(ModelError::new(format!(
        "{} cannot turn: no rigid rolling of {} lets {} (external gears in a loop of odd length jam, and so does a planetary set with two central members fixed)",
        jammed.iter().map(|&i| body_name(i)).collect::<Vec<_>>().join(", "),
        meshes.join(", "),
        if jammed.len() == 1 { "it" } else { "them" }
    )))
}

/// What a coordinate is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coord {
    /// A body's forward angle.
    Body(usize),
    /// A placing mesh's dte or a placing shaft's twist.
    Edge(Edge),
}

impl Coord {
    pub fn is_body(&self) -> bool {
        matches!(self, Coord::Body(_))
    }
}

/// Where an element's coordinate comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// It is coordinate k.
    Coord(usize),
    /// A mesh closing a loop: dte0 + sum c (x_k - offset_k) over the steps' coordinates.
    Combination(Vec<(usize, f64)>),
    /// A shaft closing a loop: from the bodies' angles.
    Bodies,
}

/// The coordinates and the maps between them and the bodies.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Coordinates {
    pub coords: Vec<Coord>,
    /// Each coordinate's value when its bodies' angles are 0 (dte0, twist_start, 0).
    pub offset: Vec<f64>,
    /// Each coordinate over the bodies' angles.
    pub rows: Vec<Row>,
    /// Each body's angle over the coordinates (less their offsets): the nonzero entries of
    /// the inverse of the rows' matrix.
    pub inverse: Vec<Vec<(usize, f64)>>,
    /// When the rows can be taken in an order in which each brings one new body (every tree,
    /// and trains whose loops are closed by meshes that are not coordinates): (coordinate,
    /// its body, 1 / its coefficient there), a forward substitution as cheap as the rows
    /// are sparse, where the inverse of a chain is dense.
    pub substitution: Option<Vec<(usize, usize, f64)>>,
    pub mesh: Vec<Source>,
    pub shaft: Vec<Source>,
    /// d theta_i / d x_k (bodies by coordinates).
    pub t: DMatrix<f64>,
}

impl Coordinates {
    /// Chooses the coordinates: the meshes' dtes first (the placing walk's, then the others
    /// by index) as long as they are independent, then the shafts' twists, then the bodies'
    /// angles that complete a basis. Every mesh's row then lies in the span of the chosen
    /// meshes', so a mesh that is not a coordinate has its dte from theirs alone.
    pub fn new(
        spec: &TrainSpec,
        st: &Structure,
        lay: &Layout,
        start: &Start,
    ) -> Result<Coordinates, ModelError> {
        let n = spec.bodies.len();
        let placing = |e: Edge| start.steps.iter().position(|s| s.edge == e);
        let mut edges: Vec<Edge> = start.steps.iter().map(|s| s.edge).collect();
        edges.extend(
            (0..spec.meshes.len())
                .map(Edge::Mesh)
                .filter(|&e| placing(e).is_none()),
        );
        edges.extend(
            (0..spec.shafts.len())
                .map(Edge::Shaft)
                .filter(|&e| placing(e).is_none()),
        );
        // Meshes before shafts, each group in the order above.
        edges.sort_by_key(|e| matches!(e, Edge::Shaft(_)));
        // A speed-driven body's angle is a coordinate of its own, first: its rate is the
        // input's, and the rest follow the dynamics.
        let driven = |i: &usize| spec.bodies[*i].speed_driven;
        let body = |i: usize| (Coord::Body(i), Row(vec![(i, 1.0)]), 0.0);
        let mut candidates: Vec<(Coord, Row, f64)> = (0..n).filter(driven).map(body).collect();
        candidates.extend(edges.iter().map(|&e| match e {
            Edge::Mesh(m) => (
                Coord::Edge(e),
                mesh_row(spec, st, &lay.geo[m], m),
                start.dte0[m],
            ),
            Edge::Shaft(j) => (
                Coord::Edge(e),
                shaft_row(spec, j),
                spec.shafts[j].twist_start,
            ),
        }));
        candidates.extend((0..n).filter(|i| !driven(i)).map(body));
        // Greedy independence by Gram-Schmidt (twice, for rounding): a row is kept when what
        // it adds is more than 1e-9 of its length (rows mix radii of 1e-3..1 m and ones).
        let mut basis: Vec<Vec<f64>> = Vec::new();
        let mut chosen: Vec<(Coord, Row, f64)> = Vec::new();
        for (coord, row, offset) in candidates {
            if chosen.len() == n {
                break;
            }
            let mut v = vec![0.0; n];
            for &(i, c) in &row.0 {
                v[i] += c;
            }
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            for _ in 0..2 {
                for b in &basis {
                    let dot: f64 = b.iter().zip(&v).map(|(x, y)| x * y).sum();
                    v.iter_mut().zip(b).for_each(|(x, y)| *x -= dot * y);
                }
            }
            let rest = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm > 0.0 && rest > 1e-9 * norm {
                basis.push(v.iter().map(|x| x / rest).collect());
                chosen.push((coord, row, offset));
            }
        }
        assert_eq!(chosen.len(), n, "the bodies' unit rows complete any basis");
        // The free bodies first, then the edges (the state's order).
        chosen.sort_by_key(|(c, _, _)| matches!(c, Coord::Edge(_)));
        let mut c = Coordinates::default();
        for (coord, row, offset) in chosen {
            c.coords.push(coord);
            c.rows.push(row);
            c.offset.push(offset);
        }
        let g = DMatrix::from_fn(n, n, |k, i| {
            c.rows[k]
                .0
                .iter()
                .filter(|&&(j, _)| j == i)
                .map(|&(_, r)| r)
                .sum()
        });
        c.t = g
            .lu()
            .try_inverse()
            .expect("the chosen rows are independent");
        c.substitution = substitution_order(&c.rows, n);
        c.inverse = (0..n)
            .map(|i| {
                (0..n)
                    .filter(|&k| c.t[(i, k)] != 0.0)
                    .map(|k| (k, c.t[(i, k)]))
                    .collect()
            })
            .collect();
        let index = |e: Edge| c.coords.iter().position(|&x| x == Coord::Edge(e));
        c.mesh = Vec::with_capacity(spec.meshes.len());
        for m in 0..spec.meshes.len() {
            let src = match index(Edge::Mesh(m)) {
                Some(k) => Source::Coord(k),
                None => {
                    let g = &lay.geo[m];
                    let row = mesh_row(spec, st, g, m);
                    let scale = g.r_ab + g.r_bb;
                    let mut comb = Vec::new();
                    for k in 0..n {
                        let l: f64 = row.0.iter().map(|&(i, r)| r * c.t[(i, k)]).sum();
                        // The mesh's row lies in the span of the chosen meshes': a body's or a
                        // shaft's coefficient is rounding (a few 1e-16 of the radii), dropped so
                        // that the dte is the meshes' alone.
                        match c.coords[k] {
                            Coord::Edge(Edge::Mesh(_)) => {
                                if l.abs() > 1e-13 * scale {
                                    comb.push((k, l));
                                }
                            }
                            _ => {
                                if l.abs() > 1e-9 * scale {
                                    if let Coord::Body(i) = c.coords[k] {
                                        return Err(ModelError::new(format!(
                                            "mesh[{}]: the speed of {} is driven, and this mesh closes a loop through it: two speed drives joined by gear meshes alone would force the teeth apart or into each other; join them through a shaft",
                                            m + 1,
                                            body_name(i)
                                        )));
                                    }
                                    return Err(ModelError::new(format!(
                                        "mesh[{}]: its dte depends on a coordinate other than the meshes' ({l:.6e} m per unit): an inconsistent loop",
                                        m + 1
                                    )));
                                }
                            }
                        }
                    }
                    Source::Combination(comb)
                }
            };
            c.mesh.push(src);
        }
        c.shaft = (0..spec.shafts.len())
            .map(|j| index(Edge::Shaft(j)).map_or(Source::Bodies, Source::Coord))
            .collect();
        Ok(c)
    }
}

/// An order of the rows in which each has exactly one body not known from the rows before.
fn substitution_order(rows: &[Row], n: usize) -> Option<Vec<(usize, usize, f64)>> {
    let mut known = vec![false; n];
    let mut used = vec![false; rows.len()];
    let mut order = Vec::with_capacity(rows.len());
    while order.len() < rows.len() {
        let next = (0..rows.len()).find_map(|k| {
            if used[k] {
                return None;
            }
            let mut unknown = rows[k].0.iter().filter(|&&(i, c)| !known[i] && c != 0.0);
            match (unknown.next(), unknown.next()) {
                (Some(&(i, c)), None) => Some((k, i, 1.0 / c)),
                _ => None,
            }
        })?;
        used[next.0] = true;
        known[next.1] = true;
        order.push(next);
    }
    Some(order)
}
