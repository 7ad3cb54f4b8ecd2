//! Lateral bodies (lateral.md §1-§3): centres that move in the plane on their bearings, and
//! the meshes whose centres move with them.
//!
//! Coordinates: each lateral body's displacement q from its nominal centre, in the housing
//! frame, or for a planet (zeta, eta) radial and tangential at its pin, after the torsional
//! coordinates. A planet's vectors are taken in its pin's frame, its carrier's turned by the
//! pin's polar angle. Lagrange's equations from T = sum J psi'^2/2 + sum m |p'|^2/2, with
//! p = O_c + q_c + Rot(psi_c) u for a planet (u = pin + q), reduce to
//! - a planet: m Rot^T p'' = Q_u, i.e. u'' = Q_u/m - 2 psi' S u' - psi'' S u + psi'^2 u
//!   - Rot^T q_c'' (Coriolis, Euler, centrifugal, the carrier's translation);
//! - its carrier: m_c q_c'' = Q_c - sum Rot Q_u and J_c psi_c'' = Q_psi - sum u x Q_u,
//!   which no longer involve the planets' accelerations: the system is solved in that order.
//!
//! S is the quarter turn counter-clockwise. Q are generalized forces: the bearings', and each
//! mesh's as the gradient of its penetrations, whose gain (Dp_A - Dp_B) . n depends on the
//! displacements and, through n turning with a carrier, on the carrier's angle. So the
//! balance of energy closes exactly.
//!
//! A lateral carrier's planets must be lateral too: a rigid pin on a moving carrier would
//! couple the carrier's translation and rotation through the planet's mass.

use super::*;

/// A lateral body: where its coordinates sit and what moves it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct LatBody {
    pub body: usize,
    /// State index of x; vx, y and vy follow.
    pub at: usize,
    pub inv_m: f64,
    pub m: f64,
    pub k: [f64; 2],
    pub c: [f64; 2],
    /// A planet's carrier, its pin's distance from the carrier's axis and the sine and
    /// cosine of its polar angle there (the pin's frame), and the carrier's own lateral
    /// number if the carrier is lateral.
    pub carrier: Option<usize>,
    pub pin_r: f64,
    pub pin_dir: (f64, f64),
    pub carrier_lat: Option<usize>,
    /// A carrier's lateral planets.
    pub planets: Vec<usize>,
}

impl LatBody {
    /// A planet's centre from its carrier's axis in its pin's frame, u = (R + zeta, eta).
    #[inline(always)]
    fn arm(&self, y: &[f64]) -> [f64; 2] {
        [self.pin_r + y[self.at], y[self.at + 2]]
    }
}

/// What moves a mesh end's centre: a housing-frame pair of coordinates (a body on a fixed
/// axis, or a planet's lateral carrier) and a carrier-frame one (a lateral planet), by their
/// lateral numbers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct End {
    housing: Option<usize>,
    carrier: Option<usize>,
}

impl End {
    fn moves(&self) -> bool {
        self.housing.is_some() || self.carrier.is_some()
    }
}

#[derive(Clone, Debug, PartialEq)]
pub(super) struct LateralConfig {
    pub bodies: Vec<LatBody>,
    /// Each body's lateral number.
    pub of_body: Vec<Option<usize>>,
    /// Each mesh's ends, A then B.
    ends: Vec<[End; 2]>,
    /// The carriers whose angle turns a lateral vector: of a mesh whose centres move, of a
    /// lateral planet, or lateral with planets (`Train::carrier_turns`).
    pub turning: Vec<usize>,
}

/// The sine and cosine of each carrier's angle in `LateralConfig::turning`, by body.
pub(super) type Turns<const N: usize> = [(f64, f64); N];

/// The quarter turn counter-clockwise.
#[inline(always)]
fn quarter([x, y]: [f64; 2]) -> [f64; 2] {
    [-y, x]
}

#[inline(always)]
fn turn([x, y]: [f64; 2], (s, c): (f64, f64)) -> [f64; 2] {
    [c * x - s * y, s * x + c * y]
}

#[inline(always)]
fn unturn([x, y]: [f64; 2], (s, c): (f64, f64)) -> [f64; 2] {
    [c * x + s * y, -s * x + c * y]
}

#[inline(always)]
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[inline(always)]
fn axpy(a: f64, x: [f64; 2], y: [f64; 2]) -> [f64; 2] {
    [a * x[0] + y[0], a * x[1] + y[1]]
}

const AXES: [&str; 2] = ["x", "y"];
const PLANET_AXES: [&str; 2] = ["zeta (radial)", "eta (tangential)"];

impl LateralConfig {
    /// The lateral bodies of `spec`, their coordinates from `first` on, checked (lateral.md
    /// §1): None when no body is lateral.
    pub fn new(
        spec: &TrainSpec,
        st: &Structure,
        frames: &[placement::MeshFrame],
        frame_turns: &[((f64, f64), f64)],
        geo: &[crate::model::geometry::Geometry],
        pins: &[[f64; 2]],
        first: usize,
    ) -> Result<Option<LateralConfig>, ModelError> {
        let n = spec.bodies.len();
        let mut of_body = vec![None; n];
        let mut bodies = Vec::new();
        for (i, b) in spec.bodies.iter().enumerate() {
            let Some(l) = b.lateral else { continue };
            let name = body_name(i);
            let axes = if b.planet.is_some() {
                PLANET_AXES
            } else {
                AXES
            };
            for d in 0..2 {
                let ax = &AXES[d];
                for (what, v) in [("k", l.k[d]), ("c", l.c[d])] {
                    if !(v >= 0.0 && v.is_finite()) {
                        return Err(ModelError::new(format!(
                            "parameter {name}.{what}_{ax} = {v}: a bearing's stiffness and damping must be finite and >= 0 ({})",
                            axes[d]
                        )));
                    }
                }
            }
            if !(l.m > 0.0 && l.m.is_finite()) {
                return Err(ModelError::new(format!(
                    "parameter {name}.m = {}: a lateral body needs its mass, > 0 kg",
                    l.m
                )));
            }
            of_body[i] = Some(bodies.len());
            bodies.push(LatBody {
                body: i,
                at: coord_index(first + 2 * bodies.len()),
                inv_m: 1.0 / l.m,
                m: l.m,
                k: l.k,
                c: l.c,
                carrier: b.planet.map(|p| p.carrier),
                pin_r: pins[i][0].hypot(pins[i][1]),
                pin_dir: pins[i][1].atan2(pins[i][0]).sin_cos(),
                carrier_lat: None,
                planets: vec![],
            });
        }
        if bodies.is_empty() {
            return Ok(None);
        }
        // One rotation per body and two translations per lateral body always fit.
        debug_assert!(first + 2 * bodies.len() <= MAX_COORDS);
        for l in 0..bodies.len() {
            let Some(c) = bodies[l].carrier else { continue };
            bodies[l].carrier_lat = of_body[c];
            if let Some(lc) = of_body[c] {
                bodies[lc].planets.push(l);
            }
        }
        for &c in &st.carriers {
            let Some(lc) = of_body[c] else { continue };
            let rigid: Vec<String> = (0..n)
                .filter(|&i| spec.carrier_of(i) == Some(c) && of_body[i].is_none())
                .map(body_name)
                .collect();
            if !rigid.is_empty() {
                return Err(ModelError::new(format!(
                    "{}.lateral = true: a lateral carrier needs lateral planets (a rigid pin on a moving carrier is not modelled); set {}.lateral = true with the pins' stiffness",
                    body_name(bodies[lc].body),
                    rigid.join(".lateral, ")
                )));
            }
        }
        let ends: Vec<[End; 2]> = spec
            .meshes
            .iter()
            .enumerate()
            .map(|(m, mp)| {
                [mp.a, mp.b].map(|i| {
                    if i == HOUSING {
                        return End::default();
                    }
                    match spec.bodies[i].planet {
                        Some(p) if frames[m].carrier == Some(p.carrier) => End {
                            housing: of_body[p.carrier],
                            carrier: of_body[i],
                        },
                        _ => End {
                            housing: of_body[i],
                            carrier: None,
                        },
                    }
                })
            })
            .collect();
        let mut turning: Vec<usize> = (0..spec.meshes.len())
            .filter(|&m| ends[m].iter().any(End::moves))
            .filter_map(|m| frames[m].carrier)
            .chain(bodies.iter().filter_map(|lb| lb.carrier))
            .collect();
        turning.sort_unstable();
        turning.dedup();
        let cfg = LateralConfig {
            bodies,
            of_body,
            ends,
            turning,
        };
        cfg.check_held(spec, frame_turns, geo)?;
        Ok(Some(cfg))
    }

    /// Refuses a body that nothing holds in some direction (lateral.md §1): its bearing's
    /// stiff directions and its meshes' forward lines of action (a carrier's through its
    /// planets, at the carrier's angle 0) must span the plane.
    fn check_held(
        &self,
        spec: &TrainSpec,
        frame_turns: &[((f64, f64), f64)],
        geo: &[crate::model::geometry::Geometry],
    ) -> Result<(), ModelError> {
        for lb in &self.bodies {
            let mut a = [[0.0; 2]; 2];
            for (d, row) in a.iter_mut().enumerate() {
                if lb.k[d] > 0.0 {
                    row[d] += 1.0;
                }
            }
            let holds = |i: usize| i == lb.body || spec.carrier_of(i) == Some(lb.body);
            for (m, mp) in spec.meshes.iter().enumerate() {
                if !(holds(mp.a) || holds(mp.b)) {
                    continue;
                }
                let (sn, cs) = geo[m].alpha_w.sin_cos();
                let (tn, s) = frame_turns[m];
                let mut nf = turn([sn, -s * cs], tn);
                if lb.carrier.is_some() {
                    nf = unturn(nf, lb.pin_dir);
                }
                for r in 0..2 {
                    for col in 0..2 {
                        a[r][col] += nf[r] * nf[col];
                    }
                }
            }
            // The smaller eigenvalue of the symmetric 2x2 against its trace (each term adds at
            // most 1): a direction a million times weaker than the other, lines of action
            // within 0.1 deg of each other, is not held (nothing but rounding would set it).
            let (tr, det) = (a[0][0] + a[1][1], a[0][0] * a[1][1] - a[0][1] * a[1][0]);
            let small = 0.5 * (tr - (tr * tr - 4.0 * det).max(0.0).sqrt());
            if small <= 1e-6 * tr.max(1.0) {
                // The free direction: the eigenvector of the smaller eigenvalue.
                let v = if a[0][1].abs() > 1e-12 {
                    [a[0][1], small - a[0][0]]
                } else if a[0][0] <= a[1][1] {
                    [1.0, 0.0]
                } else {
                    [0.0, 1.0]
                };
                let deg = v[1].atan2(v[0]).to_degrees().rem_euclid(180.0);
                let frame = if lb.carrier.is_some() {
                    "from the radial direction, in its carrier's frame"
                } else {
                    "from the housing's x axis"
                };
                return Err(ModelError::new(format!(
                    "{}: floating at {deg:.1} deg {frame}: its bearing has no stiffness there and its meshes' lines of action do not span the plane (a floating gear needs meshes in two directions, e.g. three planets)",
                    body_name(lb.body)
                )));
            }
        }
        Ok(())
    }

    /// Whether mesh m's centres move.
    pub fn moves(&self, m: usize) -> bool {
        self.ends[m].iter().any(End::moves)
    }
}

/// A displacement and its first two time derivatives.
type Motion = [[f64; 2]; 3];

impl Train {
    fn lat(&self) -> &LateralConfig {
        self.cfg.lateral.as_ref().expect("a lateral train")
    }

    /// A carrier's absolute angle, speed and (with `acc`) acceleration.
    #[inline]
    fn carrier_motion<const N: usize>(
        &self,
        c: usize,
        b: &Bodies<N>,
        acc: Option<f64>,
    ) -> [f64; 3] {
        let s = self.cfg.structure.sense[c];
        [s * b.theta[c], s * b.w[c], s * acc.unwrap_or(0.0)]
    }

    /// Mesh m's Dp_A - Dp_B split into its housing-frame part X and its carrier-frame part P
    /// (lateral planets), each with its rate and, with `dy`, acceleration. Inlined: without
    /// `dy` (the right-hand side) the accelerations' terms vanish.
    #[inline(always)]
    fn centre_parts(&self, m: usize, y: &[f64], dy: Option<&[f64]>) -> (Motion, Motion) {
        let lat = self.lat();
        let (mut x, mut p) = ([[0.0; 2]; 3], [[0.0; 2]; 3]);
        for (e, sign) in lat.ends[m].iter().zip([1.0, -1.0]) {
            for (l, out) in [(e.housing, &mut x), (e.carrier, &mut p)] {
                let Some(l) = l else { continue };
                let lb = &lat.bodies[l];
                let i = lb.at;
                let mut motion = [
                    [y[i], y[i + 2]],
                    [y[i + 1], y[i + 3]],
                    dy.map_or([0.0; 2], |dy| [dy[i + 1], dy[i + 3]]),
                ];
                if lb.carrier.is_some() {
                    motion = motion.map(|v| turn(v, lb.pin_dir));
                }
                for (o, v) in out.iter_mut().zip(motion) {
                    *o = axpy(sign, v, *o);
                }
            }
        }
        (x, p)
    }

    /// Each turning carrier's sine and cosine, once per evaluation: its meshes and planets
    /// all use them (a sine and cosine per mesh, twice, was 18 % of a lateral set's rhs).
    #[inline]
    pub(super) fn carrier_turns<const N: usize>(&self, b: &Bodies<N>) -> Turns<N> {
        let mut r = [(0.0, 1.0); N];
        for &c in &self.lat().turning {
            r[c] = self.carrier_motion(c, b, None)[0].sin_cos();
        }
        r
    }

    /// Mesh m's Dp_A - Dp_B in its paper frame, and its rate and acceleration in the mesh's
    /// frame (`Kin`'s DX..VY): in a carrier's frame Z = Rot^T X + P, so Z' = Rot^T X' -
    /// psi' S Rot^T X + P' and Z'' = Rot^T X'' - 2 psi' S Rot^T X' - psi'' S Rot^T X -
    /// psi'^2 Rot^T X + P''.
    pub(super) fn centre_motion<const N: usize>(
        &self,
        m: usize,
        y: &[f64],
        b: &Bodies<N>,
        d: Option<(&[f64], &Bodies<N>)>,
    ) -> Motion {
        let r = self.cfg.frames[m]
            .carrier
            .map_or((0.0, 1.0), |c| self.carrier_motion(c, b, None)[0].sin_cos());
        self.centre_motion_turned(m, y, b, d, r).0
    }

    /// `centre_motion` with the mesh's carrier's sine and cosine `r` given, and the housing
    /// part of the displacement (X, which `book_mesh_force` needs).
    #[inline(always)]
    pub(super) fn centre_motion_turned<const N: usize>(
        &self,
        m: usize,
        y: &[f64],
        b: &Bodies<N>,
        d: Option<(&[f64], &Bodies<N>)>,
        r: (f64, f64),
    ) -> (Motion, [f64; 2]) {
        let (x, p) = self.centre_parts(m, y, d.map(|d| d.0));
        let z = match self.cfg.frames[m].carrier {
            None => x,
            Some(c) => {
                let [_, w, alpha] = self.carrier_motion(c, b, d.map(|d| d.1.w[c]));
                let (zx, zv, za) = (unturn(x[0], r), unturn(x[1], r), unturn(x[2], r));
                let (szx, szv) = (quarter(zx), quarter(zv));
                let mut out = [[0.0; 2]; 3];
                for k in 0..2 {
                    out[0][k] = zx[k] + p[0][k];
                    out[1][k] = zv[k] - w * szx[k] + p[1][k];
                    out[2][k] = za[k] - 2.0 * w * szv[k] - alpha * szx[k] - w * w * zx[k] + p[2][k];
                }
                out
            }
        };
        let (t, s) = self.cfg.frame_turns[m];
        let z = z.map(|v| {
            let u = unturn(v, t);
            [u[0], s * u[1]]
        });
        (z, x[0])
    }

    /// `kin` of a lateral train, with its carriers' turns computed once for all meshes
    /// (`carrier_turns`); also the mesh's carrier's turn and the housing part of its centres'
    /// displacement, which booking its force needs (`book_mesh_force`).
    #[inline(always)]
    pub(super) fn kin_turned<const N: usize>(
        &self,
        m: usize,
        y: &[f64],
        b: &Bodies<N>,
        turns: &Turns<N>,
    ) -> (Kin, ((f64, f64), [f64; 2])) {
        let mut k = self.kin_of::<N, false>(m, y, b);
        let mut turned = ((0.0, 1.0), [0.0; 2]);
        if self.meshes[m].moving_centres {
            turned.0 = self.cfg.frames[m].carrier.map_or((0.0, 1.0), |c| turns[c]);
            let ([z, v, _], x) = self.centre_motion_turned(m, y, b, None, turned.0);
            [k[mesh::DX], k[mesh::DY], k[mesh::VX], k[mesh::VY]] = [z[0], z[1], v[0], v[1]];
            turned.1 = x;
        }
        (k, turned)
    }

    /// The time derivative of mesh m's `kin` at y, given the state's derivative dy.
    #[inline]
    pub(super) fn kin_rate<const N: usize>(
        &self,
        m: usize,
        (y, b): (&[f64], &Bodies<N>),
        (dy, db): (&[f64], &Bodies<N>),
        turns: &Turns<N>,
    ) -> Kin {
        let mut k = self.kin_of::<N, false>(m, dy, db);
        if self.meshes[m].moving_centres {
            let r = self.cfg.frames[m].carrier.map_or((0.0, 1.0), |c| turns[c]);
            let ([_, v, a], _) = self.centre_motion_turned(m, y, b, Some((dy, db)), r);
            [k[mesh::DX], k[mesh::DY], k[mesh::VX], k[mesh::VY]] = [v[0], v[1], a[0], a[1]];
        }
        k
    }

    /// Books mesh m's force on B (`f_b`, paper frame) on the lateral coordinates, and the
    /// torque its turning line of action puts on its carrier (module doc): the gradient of
    /// its penetrations, A taking -f_b and B +f_b. `r` and `x` as `centre_motion_turned`'s.
    pub(super) fn book_mesh_force<const N: usize>(
        &self,
        m: usize,
        f_b: [f64; 2],
        (r, x): ((f64, f64), [f64; 2]),
        on: &mut [f64; N],
        q: &mut [[f64; 2]; MAX_BODIES],
    ) {
        let (t, s) = self.cfg.frame_turns[m];
        let fc = turn([f_b[0], s * f_b[1]], t);
        let fh = match self.cfg.frames[m].carrier {
            None => fc,
            Some(c) => {
                on[c] += self.cfg.structure.sense[c] * cross(unturn(x, r), fc);
                turn(fc, r)
            }
        };
        for (e, sign) in self.lat().ends[m].iter().zip([-1.0, 1.0]) {
            if let Some(l) = e.housing {
                q[l] = axpy(sign, fh, q[l]);
            }
            if let Some(l) = e.carrier {
                q[l] = axpy(sign, unturn(fc, self.lat().bodies[l].pin_dir), q[l]);
            }
        }
    }

    /// Adds the bearings' forces to `q` (their dampers' power to `p_loss`) and the lateral
    /// planets' reactions to their carriers' torques: J_c psi_c'' = Q_psi - sum u x Q_u.
    pub(super) fn book_bearings<const N: usize>(
        &self,
        y: &[f64],
        on: &mut [f64; N],
        q: &mut [[f64; 2]; MAX_BODIES],
        p_loss: &mut f64,
    ) {
        let c = &*self.cfg;
        let lat = self.lat();
        for (l, lb) in lat.bodies.iter().enumerate() {
            for d in 0..2 {
                let (x, v) = (y[lb.at + 2 * d], y[lb.at + 2 * d + 1]);
                q[l][d] -= lb.k[d] * x + lb.c[d] * v;
                *p_loss += lb.c[d] * v * v;
            }
        }
        for (l, lb) in lat.bodies.iter().enumerate() {
            if let Some(k) = lb.carrier {
                on[k] -= c.structure.sense[k] * cross(lb.arm(y), q[l]);
            }
        }
    }

    /// The lateral coordinates' derivatives from their generalized forces `q` and the bodies'
    /// accelerations `acc` (forward): fixed axes and carriers first, then the planets, which
    /// need their carriers' accelerations.
    pub(super) fn lateral_rates<const N: usize>(
        &self,
        y: &[f64],
        b: &Bodies<N>,
        (acc, turns): (&[f64; N], &Turns<N>),
        q: &[[f64; 2]; MAX_BODIES],
        dy: &mut [f64],
    ) {
        let lat = self.lat();
        let mut a = [[0.0; 2]; MAX_BODIES];
        for (l, lb) in lat
            .bodies
            .iter()
            .enumerate()
            .filter(|(_, lb)| lb.carrier.is_none())
        {
            let mut f = q[l];
            if !lb.planets.is_empty() {
                let r = turns[lb.body];
                for &n in &lb.planets {
                    let qh = turn(turn(q[n], lat.bodies[n].pin_dir), r);
                    f = [f[0] - qh[0], f[1] - qh[1]];
                }
            }
            a[l] = [f[0] * lb.inv_m, f[1] * lb.inv_m];
        }
        for (l, lb) in lat.bodies.iter().enumerate() {
            let Some(k) = lb.carrier else { continue };
            let [_, w, alpha] = self.carrier_motion(k, b, Some(acc[k]));
            let (u, v) = (lb.arm(y), [y[lb.at + 1], y[lb.at + 3]]);
            let ac = lb
                .carrier_lat
                .map_or([0.0; 2], |kl| unturn(unturn(a[kl], turns[k]), lb.pin_dir));
            let (su, sv) = (quarter(u), quarter(v));
            for d in 0..2 {
                a[l][d] =
                    q[l][d] * lb.inv_m - 2.0 * w * sv[d] - alpha * su[d] + w * w * u[d] - ac[d];
            }
        }
        for (l, lb) in lat.bodies.iter().enumerate() {
            for (d, &acc) in a[l].iter().enumerate() {
                let i = lb.at + 2 * d;
                dy[i] = y[i + 1];
                dy[i + 1] = acc;
            }
        }
    }

    /// The lateral bodies' kinetic energy sum m |p'|^2 / 2 (a planet's p' = q_c' + Rot (psi'
    /// S u + u')) and their bearings' elastic energy.
    pub(super) fn lateral_energy(&self, y: &[f64], b: &Bodies) -> (f64, f64) {
        let Some(lat) = &self.cfg.lateral else {
            return (0.0, 0.0);
        };
        let (mut kin, mut el) = (0.0, 0.0);
        for lb in &lat.bodies {
            let v = [y[lb.at + 1], y[lb.at + 3]];
            let p = match lb.carrier {
                None => v,
                Some(k) => {
                    let [psi, w, _] = self.carrier_motion(k, b, None);
                    let r = psi.sin_cos();
                    let rel = turn(axpy(w, quarter(lb.arm(y)), v), lb.pin_dir);
                    let qc = lb.carrier_lat.map_or([0.0; 2], |kl| {
                        let at = lat.bodies[kl].at;
                        [y[at + 1], y[at + 3]]
                    });
                    axpy(1.0, turn(rel, r), qc)
                }
            };
            kin += 0.5 * lb.m * (p[0] * p[0] + p[1] * p[1]);
            for d in 0..2 {
                el += 0.5 * lb.k[d] * y[lb.at + 2 * d].powi(2);
            }
        }
        (kin, el)
    }

    /// Whether any body is lateral.
    pub fn has_lateral(&self) -> bool {
        self.cfg.lateral.is_some()
    }

    /// Body i's lateral displacement and velocity (x, y, vx, vy; a planet's zeta, eta and
    /// their rates in its carrier's frame): 0 for a body that is not lateral.
    pub fn lateral_state(&self, i: usize, y: &[f64]) -> [f64; 4] {
        let Some(l) = self.cfg.lateral.as_ref().and_then(|lat| lat.of_body[i]) else {
            return [0.0; 4];
        };
        let at = self.lat().bodies[l].at;
        [y[at], y[at + 2], y[at + 1], y[at + 3]]
    }

    /// Mesh m's forward gain (Dp_A - Dp_B) . n_f (`mesh[m].delta_lat`).
    pub fn delta_lat(&self, m: usize, y: &[f64]) -> f64 {
        if !self.meshes[m].moving_centres {
            return 0.0;
        }
        let b = self.bodies(y);
        let [z, ..] = self.centre_motion(m, y, &b, None);
        self.meshes[m].centre_gain(crate::model::contact::Flank::Forward, z[0], z[1])
    }

    /// The bearing force on each lateral body (-k q - c q', in its support's frame), by body.
    pub(super) fn lateral_bearing_forces(&self, y: &[f64]) -> Vec<(usize, [f64; 2])> {
        let Some(lat) = &self.cfg.lateral else {
            return vec![];
        };
        lat.bodies
            .iter()
            .map(|lb| {
                let f =
                    [0, 1].map(|d| -(lb.k[d] * y[lb.at + 2 * d] + lb.c[d] * y[lb.at + 2 * d + 1]));
                (lb.body, f)
            })
            .collect()
    }

    /// Bound on the lateral part of the trace of M^-1 K: each bearing's k/m, and each mesh's
    /// stiffness over the masses of its moving ends.
    pub(super) fn lateral_trace(&self, mesh_stiffness: &[f64]) -> f64 {
        let Some(lat) = &self.cfg.lateral else {
            return 0.0;
        };
        let mut sum: f64 = lat
            .bodies
            .iter()
            .map(|lb| (lb.k[0] + lb.k[1]) * lb.inv_m)
            .sum();
        for (m, ends) in lat.ends.iter().enumerate() {
            for e in ends {
                for l in [e.housing, e.carrier].into_iter().flatten() {
                    sum += mesh_stiffness[m] * lat.bodies[l].inv_m;
                }
            }
        }
        sum
    }
}
