//! The gear train's elements and their tree (gear-train.md §1-§2): bodies, shafts and meshes,
//! the checks that make them a tree, the walk from body 1 that orders the edges, and each
//! body's forward sense.

use super::super::ModelError;
use crate::variables::Params;

/// Capacities of the train (gear-train.md §6).
pub const MAX_BODIES: usize = 8;
pub const MAX_SHAFTS: usize = 7;
pub const MAX_MESHES: usize = 6;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Moment of inertia \[kg m^2\].
    pub j: f64,
    /// Viscous drag to the housing \[N m s/rad\].
    pub c: f64,
    /// Start speed, forward positive \[rad/s\].
    pub w_start: f64,
    /// A torque locked to the body's angle, on top of its input torque.
    pub ripple: Ripple,
}

/// An angle-locked torque `amplitude sin(order theta + phase)`, theta the body's forward angle
/// since the start: an engine's firing-order ripple (order 2 for a four-stroke four-cylinder).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ripple {
    /// \[N m\]; 0 switches it off (and costs nothing).
    pub amplitude: f64,
    /// Periods per revolution \[1\].
    pub order: f64,
    /// \[rad\].
    pub phase: f64,
}

impl Ripple {
    pub const NONE: Ripple = Ripple {
        amplitude: 0.0,
        order: 0.0,
        phase: 0.0,
    };

    /// The torque at forward angle `theta` \[N m\].
    #[inline]
    pub fn torque(&self, theta: f64) -> f64 {
        if self.amplitude == 0.0 {
            return 0.0;
        }
        self.amplitude * (self.order * theta + self.phase).sin()
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shaft {
    /// Its ends, 0-based body indices.
    pub a: usize,
    pub b: usize,
    pub k: f64,
    pub d: f64,
    pub twist_start: f64,
}

/// A mesh's place in the train; its pair's own parameters are a single-mesh `Params`.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshPlace {
    /// The bodies carrying gear A and gear B, 0-based.
    pub a: usize,
    pub b: usize,
    /// Direction of O_A -> O_B in the housing frame \[rad\].
    pub center_angle: f64,
    pub mount_a: f64,
    pub mount_b: f64,
    pub params: Params,
}

/// Everything that defines a train.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainSpec {
    pub bodies: Vec<Body>,
    /// Body 1's absolute start angle \[rad\] (gear-train.md §4).
    pub angle_start: f64,
    pub shafts: Vec<Shaft>,
    pub meshes: Vec<MeshPlace>,
}

/// An edge of the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    Shaft(usize),
    Mesh(usize),
}

/// One step of the walk from body 1: an edge, the body reached before (`from`) and the body
/// it reaches (`to`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    pub edge: Edge,
    pub from: usize,
    pub to: usize,
}

/// The checked tree: the walk (every edge once, each reaching a new body) and the senses.
#[derive(Clone, Debug, PartialEq)]
pub struct Tree {
    pub steps: Vec<Step>,
    /// Forward sense of each body: +1 counter-clockwise, -1 clockwise.
    pub sense: Vec<f64>,
}

impl Edge {
    pub fn name(self) -> String {
        match self {
            Edge::Shaft(j) => format!("shaft[{}]", j + 1),
            Edge::Mesh(m) => format!("mesh[{}]", m + 1),
        }
    }
}

impl TrainSpec {
    /// Each edge's two bodies.
    pub fn ends(&self, e: Edge) -> (usize, usize) {
        match e {
            Edge::Shaft(j) => (self.shafts[j].a, self.shafts[j].b),
            Edge::Mesh(m) => (self.meshes[m].a, self.meshes[m].b),
        }
    }

    pub fn edges(&self) -> impl Iterator<Item = Edge> + '_ {
        (0..self.shafts.len())
            .map(Edge::Shaft)
            .chain((0..self.meshes.len()).map(Edge::Mesh))
    }

    /// Checks that bodies, shafts and meshes form a tree (gear-train.md §1) and walks it from
    /// body 1. Every message names the elements at fault.
    pub fn tree(&self) -> Result<Tree, ModelError> {
        let n = self.bodies.len();
        let err = |m: String| Err(ModelError::new(m));
        if !(1..=MAX_BODIES).contains(&n) {
            return err(format!("n_bodies = {n}: must lie in [1, {MAX_BODIES}]"));
        }
        if self.shafts.len() > MAX_SHAFTS {
            return err(format!(
                "n_shafts = {}: at most {MAX_SHAFTS}",
                self.shafts.len()
            ));
        }
        if self.meshes.len() > MAX_MESHES {
            return err(format!(
                "n_meshes = {}: at most {MAX_MESHES}",
                self.meshes.len()
            ));
        }
        for e in self.edges() {
            let (a, b) = self.ends(e);
            let (na, nb) = match e {
                Edge::Shaft(_) => ("a", "b"),
                Edge::Mesh(_) => ("A", "B"),
            };
            for (name, i) in [(na, a), (nb, b)] {
                if i >= n {
                    return err(format!(
                        "{}.{name} = {}: no such body (n_bodies = {n})",
                        e.name(),
                        i + 1
                    ));
                }
            }
            if a == b {
                return err(format!(
                    "{}: {na} = {nb} = {}: an element must join two different bodies",
                    e.name(),
                    a + 1
                ));
            }
        }
        // Union-find over the edges in their order: an edge between two bodies already joined
        // closes a cycle.
        let mut root: Vec<usize> = (0..n).collect();
        fn find(root: &mut [usize], mut i: usize) -> usize {
            while root[i] != i {
                root[i] = root[root[i]];
                i = root[i];
            }
            i
        }
        let mut path: Vec<Edge> = Vec::new();
        for e in self.edges() {
            let (a, b) = self.ends(e);
            let (ra, rb) = (find(&mut root, a), find(&mut root, b));
            if ra == rb {
                return err(format!(
                    "{} closes a cycle: bodies {} and {} are already joined by {}; a train must be a tree (planetary sets are out of scope)",
                    e.name(),
                    a + 1,
                    b + 1,
                    path.iter().map(|p| p.name()).collect::<Vec<_>>().join(", ")
                ));
            }
            root[ra] = rb;
            path.push(e);
        }
        let alone: Vec<String> = (1..n)
            .filter(|&i| find(&mut root, i) != find(&mut root, 0))
            .map(|i| format!("body[{}]", i + 1))
            .collect();
        if !alone.is_empty() {
            return err(format!(
                "{} joined to body[1] by no chain of shafts and meshes (n_shafts + n_meshes = {} edges for {n} bodies; a tree needs {})",
                alone.join(", "),
                self.shafts.len() + self.meshes.len(),
                n - 1
            ));
        }
        // Breadth first from body 1: across an external mesh the sense flips, across an
        // internal mesh (a pinion in a ring) or a shaft it stays.
        let mut sense = vec![0.0; n];
        sense[0] = -1.0;
        let mut steps = Vec::with_capacity(n - 1);
        let mut queue = std::collections::VecDeque::from([0usize]);
        while let Some(i) = queue.pop_front() {
            for e in self.edges() {
                let (a, b) = self.ends(e);
                let to = match (a == i, b == i) {
                    (true, _) if sense[b] == 0.0 => b,
                    (_, true) if sense[a] == 0.0 => a,
                    _ => continue,
                };
                sense[to] = match e {
                    Edge::Shaft(_) => sense[i],
                    Edge::Mesh(m) if self.meshes[m].params.internal => sense[i],
                    Edge::Mesh(_) => -sense[i],
                };
                steps.push(Step {
                    edge: e,
                    from: i,
                    to,
                });
                queue.push_back(to);
            }
        }
        Ok(Tree { steps, sense })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body() -> Body {
        Body {
            j: 1.0,
            c: 0.0,
            w_start: 0.0,
            ripple: Ripple::NONE,
        }
    }

    fn mesh(a: usize, b: usize) -> MeshPlace {
        MeshPlace {
            a,
            b,
            center_angle: 0.0,
            mount_a: 0.0,
            mount_b: 0.0,
            params: Params::default(),
        }
    }

    fn shaft(a: usize, b: usize) -> Shaft {
        Shaft {
            a,
            b,
            k: 1e5,
            d: 0.0,
            twist_start: 0.0,
        }
    }

    #[test]
    fn a_two_stage_reducer_walks_from_body_1() {
        let t = TrainSpec {
            bodies: vec![body(); 4],
            angle_start: 0.0,
            shafts: vec![shaft(1, 2)],
            meshes: vec![mesh(0, 1), mesh(2, 3)],
        };
        let tree = t.tree().unwrap();
        assert_eq!(tree.sense, vec![-1.0, 1.0, 1.0, -1.0]);
        let reached: Vec<usize> = tree.steps.iter().map(|s| s.to).collect();
        assert_eq!(reached, vec![1, 2, 3]);
    }

    #[test]
    fn an_idler_turns_the_third_body_like_the_first() {
        let t = TrainSpec {
            bodies: vec![body(); 3],
            angle_start: 0.0,
            shafts: vec![],
            meshes: vec![mesh(0, 1), mesh(1, 2)],
        };
        assert_eq!(t.tree().unwrap().sense, vec![-1.0, 1.0, -1.0]);
    }

    #[test]
    fn what_is_not_a_tree_is_named() {
        let base = TrainSpec {
            bodies: vec![body(); 3],
            angle_start: 0.0,
            shafts: vec![],
            meshes: vec![mesh(0, 1), mesh(1, 2)],
        };
        let message = |t: &TrainSpec| t.tree().unwrap_err().message;
        let mut t = base.clone();
        t.meshes.push(mesh(2, 0));
        assert!(
            message(&t).contains("mesh[3] closes a cycle"),
            "{}",
            message(&t)
        );
        let mut t = base.clone();
        t.meshes[1] = mesh(1, 1);
        assert!(
            message(&t).contains("mesh[2]: A = B = 2"),
            "{}",
            message(&t)
        );
        let mut t = base.clone();
        t.meshes[1] = mesh(1, 5);
        assert!(
            message(&t).contains("mesh[2].B = 6: no such body"),
            "{}",
            message(&t)
        );
        let mut t = base.clone();
        t.meshes.pop();
        assert!(
            message(&t).contains("body[3] joined to body[1] by no chain"),
            "{}",
            message(&t)
        );
        let mut t = base.clone();
        t.bodies = vec![body(); 9];
        assert!(message(&t).contains("n_bodies = 9"), "{}", message(&t));
        let mut t = base;
        t.shafts = vec![shaft(0, 1); 8];
        assert!(message(&t).contains("n_shafts = 8"), "{}", message(&t));
    }
}
