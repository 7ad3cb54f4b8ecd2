//! The gear train's elements and their graph (gear-train.md §1-§2, planetary.md §3-§4):
//! bodies, shafts and meshes, the housing as body 0, carriers and their planets; the checks
//! of the structure, and each body's forward sense.

use super::super::ModelError;
use crate::model::pair::Pair;

/// Capacities of the train (planetary.md §5).
pub const MAX_BODIES: usize = 16;
pub const MAX_SHAFTS: usize = 15;
pub const MAX_MESHES: usize = 16;
/// The coordinates a train may have: its rotations (one per body) and two translations per
/// lateral body (lateral.md §1), every body lateral at most. A train whose state fits
/// `NY_COMPACT` steps on that smaller state (`driver::train_simulation::Compact`).
pub const MAX_COORDS: usize = 3 * MAX_BODIES;
/// The housing (FMI body 0) as an element end: the slot after the bodies in every per-body
/// array, where angles and speeds stay 0.
pub const HOUSING: usize = MAX_BODIES;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// Moment of inertia \[kg m^2\].
    pub j: f64,
    /// Viscous drag to the housing (to the carrier for a planet) \[N m s/rad\].
    pub c: f64,
    /// Start speed, forward positive \[rad/s\].
    pub w_start: f64,
    /// A torque locked to the body's angle, on top of its input torque.
    pub ripple: Ripple,
    /// The carrier whose frame holds the body's axis; None: the housing's.
    pub planet: Option<Planet>,
    /// Its speed is an input (`TrainLoads::w_in`, held over a step) and the drive's torque an
    /// output (gearbox-file.md §3); its start speed is `w_start`.
    pub speed_driven: bool,
    /// Its centre moves in the plane on its bearing (lateral.md §1); None: held where
    /// planetary.md §3 puts it.
    pub lateral: Option<Lateral>,
}

/// A lateral body's translation (lateral.md §1-§2): x and y in the housing frame, or a
/// planet's radial zeta and tangential eta at its pin in its carrier's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lateral {
    /// Translational mass \[kg\] (a planet's is `Planet::m`, the same parameter).
    pub m: f64,
    /// The bearing's stiffness \[N/m\] and damping \[N s/m\] in x and y; 0 stiffness: floating.
    pub k: [f64; 2],
    pub c: [f64; 2],
    /// Start displacement \[m\] and velocity \[m/s\].
    pub q_start: [f64; 2],
    pub v_start: [f64; 2],
}

/// A planet's place on its carrier (planetary.md §3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Planet {
    /// The carrier, 0-based.
    pub carrier: usize,
    /// Polar angle of the axis in the carrier's frame \[rad\].
    pub orbit_angle: f64,
    /// Mass, for the orbital inertia m R^2 it adds to the carrier \[kg\].
    pub m: f64,
    /// Pin position errors, radial outwards and tangential counter-clockwise \[m\].
    pub pin_error_r: f64,
    pub pin_error_t: f64,
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
    /// Its ends, 0-based body indices or `HOUSING` (a torsional mount).
    pub a: usize,
    pub b: usize,
    pub k: f64,
    pub d: f64,
    pub twist_start: f64,
}

/// A mesh's place in the train, its pair, and its start.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshPlace {
    /// The bodies carrying gear A and gear B, 0-based, or `HOUSING` (a fixed gear).
    pub a: usize,
    pub b: usize,
    /// Direction of O_A -> O_B in the housing frame \[rad\] (not used in a carrier's frame).
    pub center_angle: f64,
    pub mount_a: f64,
    pub mount_b: f64,
    pub pair: Pair,
    /// The start penetration of a mesh that closes a loop (planetary.md §4) \[m\].
    pub dte_start: f64,
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

/// An element joining two bodies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    Shaft(usize),
    Mesh(usize),
}

impl Edge {
    pub fn name(self) -> String {
        match self {
            Edge::Shaft(j) => format!("shaft[{}]", j + 1),
            Edge::Mesh(m) => format!("mesh[{}]", m + 1),
        }
    }
}

/// A body's FMI name (`body[3]`, the housing `body[0]`).
pub fn body_name(i: usize) -> String {
    if i == HOUSING {
        "body[0] (the housing)".into()
    } else {
        format!("body[{}]", i + 1)
    }
}

/// What the structure fixes: the frame each mesh turns in, and the forward senses.
#[derive(Clone, Debug, PartialEq)]
pub struct Structure {
    /// Each mesh's carrier (its frame), None for the housing's frame.
    pub frame: Vec<Option<usize>>,
    /// Forward sense of each body: +1 counter-clockwise, -1 clockwise.
    pub sense: Vec<f64>,
    /// Each mesh's senses of A and B; a housing end takes the one the mesh gives it.
    pub mesh_sense: Vec<(f64, f64)>,
    /// Each shaft's sense (both ends share it).
    pub shaft_sense: Vec<f64>,
    /// Whether an element names the housing (the placement then starts there).
    pub uses_housing: bool,
    /// The carriers, ascending.
    pub carriers: Vec<usize>,
}

impl TrainSpec {
    /// Each edge's two ends.
    pub fn ends(&self, e: Edge) -> (usize, usize) {
        match e {
            Edge::Shaft(j) => (self.shafts[j].a, self.shafts[j].b),
            Edge::Mesh(m) => (self.meshes[m].a, self.meshes[m].b),
        }
    }

    /// Meshes in index order, then shafts (the placement's order at each body).
    pub fn edges(&self) -> impl Iterator<Item = Edge> + '_ {
        (0..self.meshes.len())
            .map(Edge::Mesh)
            .chain((0..self.shafts.len()).map(Edge::Shaft))
    }

    /// The carrier of body i (None for the housing and housing-mounted bodies).
    pub fn carrier_of(&self, i: usize) -> Option<usize> {
        self.bodies.get(i).and_then(|b| b.planet).map(|p| p.carrier)
    }

    /// Checks the elements and how they join (planetary.md §3-§4, all but the jammed bodies
    /// and the senses, which need the gears' radii: `Structure::check_senses`). Every message
    /// names the elements at fault.
    pub fn structure(&self) -> Result<Structure, ModelError> {
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
                if i >= n && i != HOUSING {
                    return err(format!(
                        "{}.{name} = {}: no such body (n_bodies = {n}; 0 is the housing)",
                        e.name(),
                        i + 1
                    ));
                }
            }
            if a == b {
                let which = if a == HOUSING { 0 } else { a + 1 };
                return err(format!(
                    "{}: {na} = {nb} = {which}: an element must join two different bodies",
                    e.name()
                ));
            }
        }
        self.check_carriers()?;
        let frame = self.mesh_frames()?;
        self.check_connected()?;
        let sense = self.senses();
        let other = |own: f64, internal: bool| if internal { own } else { -own };
        let mesh_sense = self
            .meshes
            .iter()
            .map(|mp| {
                let internal = mp.pair.internal;
                match (mp.a == HOUSING, mp.b == HOUSING) {
                    (true, _) => (other(sense[mp.b], internal), sense[mp.b]),
                    (_, true) => (sense[mp.a], other(sense[mp.a], internal)),
                    _ => (sense[mp.a], sense[mp.b]),
                }
            })
            .collect();
        let shaft_sense = self
            .shafts
            .iter()
            .map(|sh| sense[if sh.a == HOUSING { sh.b } else { sh.a }])
            .collect();
        let mut carriers: Vec<usize> = (0..n).filter_map(|i| self.carrier_of(i)).collect();
        carriers.sort_unstable();
        carriers.dedup();
        Ok(Structure {
            frame,
            sense,
            mesh_sense,
            shaft_sense,
            uses_housing: self.edges().any(|e| {
                let (a, b) = self.ends(e);
                a == HOUSING || b == HOUSING
            }),
            carriers,
        })
    }

    /// Carriers exist, are not carried, and their planets mesh; shafts stay on housing axes.
    fn check_carriers(&self) -> Result<(), ModelError> {
        let n = self.bodies.len();
        let err = |m: String| Err(ModelError::new(m));
        for i in 0..n {
            let Some(c) = self.carrier_of(i) else {
                continue;
            };
            if c >= n {
                return err(format!(
                    "body[{}].carrier = {}: no such body (n_bodies = {n})",
                    i + 1,
                    c + 1
                ));
            }
            if c == i {
                return err(format!(
                    "body[{}].carrier = {}: a body cannot carry itself",
                    i + 1,
                    c + 1
                ));
            }
            if let Some(cc) = self.carrier_of(c) {
                return err(format!(
                    "body[{}].carrier = {}, but body[{}] is itself carried by body[{}]: a carrier turns about a housing-fixed axis (no planet carries another)",
                    i + 1,
                    c + 1,
                    c + 1,
                    cc + 1
                ));
            }
        }
        // After the carriers' own rules, so that a carried carrier is named as such.
        for i in 0..n {
            let Some(c) = self.carrier_of(i) else {
                continue;
            };
            if !self.meshes.iter().any(|mp| mp.a == i || mp.b == i) {
                return err(format!(
                    "body[{}] is a planet of body[{}] but no mesh names it: a planet turns only through its meshes",
                    i + 1,
                    c + 1
                ));
            }
        }
        for (j, sh) in self.shafts.iter().enumerate() {
            for end in [sh.a, sh.b] {
                if let Some(c) = self.carrier_of(end) {
                    return err(format!(
                        "shaft[{}] names body[{}], a planet of body[{}]: a shaft joins bodies on one housing-fixed axis (a stepped planet is one body with several meshes)",
                        j + 1,
                        end + 1,
                        c + 1
                    ));
                }
            }
        }
        Ok(())
    }

    /// The frame of each mesh: a carrier's when it names a planet (planetary.md §3).
    fn mesh_frames(&self) -> Result<Vec<Option<usize>>, ModelError> {
        let mut frames = Vec::with_capacity(self.meshes.len());
        for (m, mp) in self.meshes.iter().enumerate() {
            let name = format!("mesh[{}]", m + 1);
            let frame = match (self.carrier_of(mp.a), self.carrier_of(mp.b)) {
                (None, None) => None,
                (Some(ca), Some(cb)) if ca != cb => {
                    return Err(ModelError::new(format!(
                        "{name} joins body[{}], a planet of body[{}], and body[{}], a planet of body[{}]: planets of different carriers cannot mesh",
                        mp.a + 1,
                        ca + 1,
                        mp.b + 1,
                        cb + 1
                    )))
                }
                (Some(c), _) | (_, Some(c)) => {
                    let other = if self.carrier_of(mp.a) == Some(c) {
                        mp.b
                    } else {
                        mp.a
                    };
                    if other == c {
                        return Err(ModelError::new(format!(
                            "{name} joins body[{}] with its own carrier body[{}]: a planet meshes with central gears or other planets",
                            if other == mp.a { mp.b + 1 } else { mp.a + 1 },
                            c + 1
                        )));
                    }
                    if mp.center_angle != 0.0 {
                        return Err(ModelError::new(format!(
                            "{name}.center_angle = {}: the mesh turns in the frame of carrier body[{}], where the planets' positions give its direction; set it to 0",
                            mp.center_angle,
                            c + 1
                        )));
                    }
                    Some(c)
                }
            };
            frames.push(frame);
        }
        Ok(frames)
    }

    /// Every body is joined to the rest by meshes, shafts or carrier ties.
    fn check_connected(&self) -> Result<(), ModelError> {
        let n = self.bodies.len();
        // Union-find over the bodies and the housing (slot n).
        let mut root: Vec<usize> = (0..=n).collect();
        fn find(root: &mut [usize], mut i: usize) -> usize {
            while root[i] != i {
                root[i] = root[root[i]];
                i = root[i];
            }
            i
        }
        let slot = |i: usize| if i == HOUSING { n } else { i };
        let mut join = |a: usize, b: usize| {
            let (ra, rb) = (find(&mut root, slot(a)), find(&mut root, slot(b)));
            root[ra] = rb;
        };
        for e in self.edges() {
            let (a, b) = self.ends(e);
            join(a, b);
        }
        for i in 0..n {
            if let Some(c) = self.carrier_of(i) {
                join(i, c);
            }
        }
        let start = find(&mut root, 0);
        let alone: Vec<String> = (1..n)
            .filter(|&i| find(&mut root, i) != start)
            .map(|i| format!("body[{}]", i + 1))
            .collect();
        if !alone.is_empty() {
            return Err(ModelError::new(format!(
                "{} joined to body[1] by no chain of meshes, shafts and carriers",
                alone.join(", ")
            )));
        }
        Ok(())
    }

    /// Forward senses (planetary.md §3): from body 1 (clockwise) across meshes and shafts
    /// between bodies, an external mesh flipping it; a part the walk does not reach starts
    /// clockwise at its lowest body. Conflicts are found by `Structure::check_senses`.
    fn senses(&self) -> Vec<f64> {
        let n = self.bodies.len();
        let mut sense = vec![0.0; n];
        for start in 0..n {
            if sense[start] != 0.0 {
                continue;
            }
            sense[start] = -1.0;
            let mut queue = std::collections::VecDeque::from([start]);
            while let Some(i) = queue.pop_front() {
                for e in self.edges() {
                    let (a, b) = self.ends(e);
                    if a == HOUSING || b == HOUSING {
                        continue;
                    }
                    let to = match (a == i, b == i) {
                        (true, _) if sense[b] == 0.0 => b,
                        (_, true) if sense[a] == 0.0 => a,
                        _ => continue,
                    };
                    sense[to] = if self.flips(e) { -sense[i] } else { sense[i] };
                    queue.push_back(to);
                }
            }
        }
        sense
    }

    /// The elements of a shortest chain from body a to body b that avoids `skip` and the
    /// housing (for messages).
    fn path(&self, a: usize, b: usize, skip: Edge) -> Vec<Edge> {
        let mut from: Vec<Option<(usize, Edge)>> = vec![None; self.bodies.len()];
        let mut queue = std::collections::VecDeque::from([a]);
        while let Some(i) = queue.pop_front() {
            if i == b {
                break;
            }
            for e in self.edges().filter(|&e| e != skip) {
                let (p, q) = self.ends(e);
                let to = if p == i {
                    q
                } else if q == i {
                    p
                } else {
                    continue;
                };
                if to != HOUSING && to != a && from[to].is_none() {
                    from[to] = Some((i, e));
                    queue.push_back(to);
                }
            }
        }
        let mut path = Vec::new();
        let mut i = b;
        while let Some((prev, e)) = from[i] {
            path.push(e);
            i = prev;
        }
        path.reverse();
        path
    }

    /// Whether an edge turns its two ends opposite ways (an external mesh).
    pub fn flips(&self, e: Edge) -> bool {
        matches!(e, Edge::Mesh(m) if !self.meshes[m].pair.internal)
    }
}

impl Structure {
    /// A loop whose senses conflict cannot turn (planetary.md §4).
    pub fn check_senses(&self, spec: &TrainSpec) -> Result<(), ModelError> {
        let turn = |s: f64| {
            if s < 0.0 {
                "clockwise"
            } else {
                "counter-clockwise"
            }
        };
        for e in spec.edges() {
            let (a, b) = spec.ends(e);
            if a == HOUSING || b == HOUSING {
                continue;
            }
            let want = if spec.flips(e) {
                -self.sense[a]
            } else {
                self.sense[a]
            };
            if want != self.sense[b] {
                let how = match e {
                    Edge::Mesh(_) if spec.flips(e) => {
                        "an external mesh turns its gears opposite ways"
                    }
                    Edge::Mesh(_) => "an internal mesh turns its gears the same way",
                    Edge::Shaft(_) => "a shaft turns its ends the same way",
                };
                let path = spec
                    .path(a, b, e)
                    .iter()
                    .map(|p| p.name())
                    .collect::<Vec<_>>();
                return Err(ModelError::new(format!(
                    "{} closes a loop whose senses conflict: the other elements ({}) turn body[{}] {} and body[{}] {} when the train is driven forward, but {how}; such a loop cannot turn",
                    e.name(),
                    path.join(", "),
                    a + 1,
                    turn(self.sense[a]),
                    b + 1,
                    turn(self.sense[b])
                )));
            }
        }
        Ok(())
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
            speed_driven: false,
            lateral: None,
            planet: None,
        }
    }

    fn planet(carrier: usize) -> Body {
        Body {
            planet: Some(Planet {
                carrier,
                orbit_angle: 0.0,
                m: 0.0,
                pin_error_r: 0.0,
                pin_error_t: 0.0,
            }),
            ..body()
        }
    }

    fn mesh(a: usize, b: usize) -> MeshPlace {
        MeshPlace {
            a,
            b,
            center_angle: 0.0,
            mount_a: 0.0,
            mount_b: 0.0,
            pair: Pair::paper(),
            dte_start: 0.0,
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

    fn train(bodies: Vec<Body>, shafts: Vec<Shaft>, meshes: Vec<MeshPlace>) -> TrainSpec {
        TrainSpec {
            bodies,
            angle_start: 0.0,
            shafts,
            meshes,
        }
    }

    #[test]
    fn a_two_stage_reducer_takes_its_senses_from_body_1() {
        let t = train(
            vec![body(); 4],
            vec![shaft(1, 2)],
            vec![mesh(0, 1), mesh(2, 3)],
        );
        let st = t.structure().unwrap();
        assert_eq!(st.sense, vec![-1.0, 1.0, 1.0, -1.0]);
        assert!(!st.uses_housing);
        st.check_senses(&t).unwrap();
    }

    #[test]
    fn a_planetary_set_turns_its_planets_in_the_carriers_frame() {
        // Sun 1, carrier 2, planets 3 and 4, ring fixed (the housing).
        let ring = |p: usize| {
            let mut m = mesh(p, HOUSING);
            m.pair.internal = true;
            m
        };
        let t = train(
            vec![body(), body(), planet(1), planet(1)],
            vec![],
            vec![mesh(0, 2), mesh(0, 3), ring(2), ring(3)],
        );
        let st = t.structure().unwrap();
        assert_eq!(st.frame, vec![Some(1); 4]);
        assert_eq!(st.carriers, vec![1]);
        assert!(st.uses_housing);
        // Sun clockwise, planets counter-clockwise, the fixed ring as the planet; the
        // carrier, reached by no mesh, clockwise.
        assert_eq!(st.sense, vec![-1.0, -1.0, 1.0, 1.0]);
        assert_eq!(st.mesh_sense[2], (1.0, 1.0));
        st.check_senses(&t).unwrap();
    }

    #[test]
    fn what_cannot_be_a_train_is_named() {
        let base = train(vec![body(); 3], vec![], vec![mesh(0, 1), mesh(1, 2)]);
        let message = |t: &TrainSpec| t.structure().unwrap_err().message;
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
        t.bodies = vec![body(); 17];
        assert!(message(&t).contains("n_bodies = 17"), "{}", message(&t));
        let mut t = base.clone();
        t.shafts = vec![shaft(0, 1); 16];
        assert!(message(&t).contains("n_shafts = 16"), "{}", message(&t));
        // A carried carrier; a planet with no mesh; a shaft on a planet.
        let mut t = base.clone();
        t.bodies = vec![body(), planet(2), planet(0)];
        assert!(message(&t).contains("is itself carried"), "{}", message(&t));
        let mut t = base.clone();
        t.bodies.push(planet(0));
        t.meshes.push(mesh(3, 1));
        t.shafts.push(shaft(3, 2));
        assert!(
            message(&t).contains("shaft[1] names body[4], a planet of body[1]"),
            "{}",
            message(&t)
        );
        let mut t = base.clone();
        t.bodies.push(planet(0));
        assert!(message(&t).contains("no mesh names it"), "{}", message(&t));
        // Planets of two carriers; a planet meshing with its own carrier; a centre angle in
        // a carrier's frame.
        let mut t = train(
            vec![body(), body(), planet(0), planet(1)],
            vec![],
            vec![mesh(2, 3)],
        );
        assert!(
            message(&t).contains("planets of different carriers"),
            "{}",
            message(&t)
        );
        t.bodies[3] = planet(0);
        t.meshes = vec![mesh(2, 0), mesh(3, 1)];
        assert!(
            message(&t).contains("with its own carrier body[1]"),
            "{}",
            message(&t)
        );
        t.meshes = vec![mesh(1, 2), mesh(1, 3)];
        t.meshes[1].center_angle = 0.5;
        assert!(
            message(&t).contains("mesh[2].center_angle = 0.5"),
            "{}",
            message(&t)
        );
    }

    #[test]
    fn a_loop_whose_senses_conflict_is_named() {
        // Two external gears also joined by a shaft: one way round they turn opposite, the
        // other the same.
        let t = train(vec![body(); 2], vec![shaft(0, 1)], vec![mesh(0, 1)]);
        let st = t.structure().unwrap();
        let e = st.check_senses(&t).unwrap_err().message;
        assert!(
            e.contains("shaft[1] closes a loop whose senses conflict"),
            "{e}"
        );
    }
}
