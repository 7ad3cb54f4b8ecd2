//! The contact objects against plain geometry. At random configurations of a two-body train with
//! one mesh (internal pairs, planetary.md §1-§2, and external ones, gear-train.md §3-§4), the
//! test builds both gears' tooth outlines in the housing frame (involute flanks, tip circles),
//! finds where each tooth's flank crosses the lines of action by solving for the involute's
//! roll parameter numerically, and measures every tooth pair's penetration along the line.
//! It uses none of the spec's closed formulas for the objects (no phi, no s_A = rAb(alpha_w -
//! phiA)): only the gears' data (base and tip radii, base thickness angles, the actual centre
//! distance) and the bodies' angles go in; the pairs' positions and penetrations come out of
//! the outlines. They must agree with the model's dte (forward), -j_n - dte (backward) and its
//! objects' contact points.
//!
//! Geometry used (all in the housing frame, angles counter-clockwise, e(a) = (cos a, sin a),
//! e'(a) = (-sin a, cos a)):
//! - An involute of a base circle (centre c, radius r_b) that leaves the circle at angle th0
//!   and unwinds in the sense w (+1: its polar angle grows outwards) is
//!   P(v) = c + r_b (e(phi) - w v e'(phi)), phi = th0 + w v, v >= 0 the roll parameter; its
//!   polar angle is th0 + w inv(alpha_r), its normal at P is the generating line through the
//!   tangent point c + r_b e(phi), along e'(phi), and dP/dv = r_b v e(phi).
//! - A flank on the counter-clockwise side of a tooth (side = +1) or the clockwise side (-1):
//!   an external tooth narrows outwards, angle axis + side (t/2 - inv), so w = -side; a ring's
//!   tooth widens outwards, axis + side (t/2 + inv), so w = +side. The material lies on the
//!   other side, so the outward normal is side e'(phi) in both cases.
//! - Forward drive: A (body 1) turns clockwise and leads with its clockwise flanks; it pushes
//!   the flank of B that trails in B's forward rotation: the clockwise flank of an external B
//!   (which turns counter-clockwise), the counter-clockwise flank of a ring (which turns
//!   clockwise, like A). Backward: the other flanks.
//! - A line of action of a flank pair is a line, direction u, along which A's flank's outward
//!   normal is u and B's is -u at their tangent points: K_A = O_A + rAb side_A e(g - pi/2),
//!   K_B = O_B + rBb side_B e(g + pi/2) for u = e(g), and K_B on the line through K_A gives
//!   d sin(g - beta) = side_A rAb + side_B rBb: two mirror-image candidates. The flank points
//!   that meet the line perpendicularly are K_A + v rAb u on A (s >= 0 from K_A) and
//!   K_B - v rBb u (external B) or K_B + v rBb u (ring) on B; only one candidate has a stretch
//!   of line where both gears' teeth exist (inside A's tip circle; inside B's, or outside the
//!   ring's), and that stretch is the contact segment.
//! - The penetration of a pair is s_A - s_B, s the positions of the two flanks' crossings along
//!   u: A's tooth lies behind its flank (-u), B's ahead of its own, so s_A > s_B is overlap.
//!
//! The gears' data come from the standard gear data (reference thickness m (pi/2 + 2 x tan a0),
//! a ring's space m (pi/2 + 2 xB tan a0), each less/plus half the backlash parameter; radii from
//! m, z, a0, x) and must equal the model's Geometry to 1e-14 relative; the centre distance error
//! enters only through the model's actual d. Checks, on each flank at the start:
//! (1) every pair on the contact segment (A's crossing between the ring's (B's) tip circle and
//! A's) penetrates by dte (forward) or -j_n - dte (backward); (2) the pairs' positions are the
//! contact points of the model's present objects in [s_a, s_b], as sets; (3) so are their
//! numbers; the segment's ends from the tip circles are the model's s_a, s_b; objects carry
//! force only on the segment with positive penetration. Then with body 1 turned by up to 20 rad
//! at another dte (rigid rolling through `Train::bodies`), (1) again, and each pair's position
//! must be an object's contact point modulo the base pitch (objects jump only at events).

use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::model::train::{coord_index, Body, MeshPlace, Ripple, State, Train, TrainSpec};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::Params;
use std::f64::consts::PI;

/// Tolerance on positions and penetrations \[m\]. Every number here is a coordinate of at most
/// ~0.3 m (radii up to 0.3 m, centre distance up to 0.2 m) built from angles of at most ~60 rad
/// (start angles, mounts, up to 120 teeth round, a turn of body 1 by up to 20 rad times a ratio
/// up to 2): one rounding of such an angle is 60 * 1.1e-16 = 6.7e-15 rad, 2e-15 m at 0.3 m. The
/// crossings' root finding adds nothing to first order: a flank crosses its line of action at
/// right angles, so its position along the line is stationary in the roll parameter. The
/// model's side (placement, psi_start, the closure for j_n, the objects' sigma) rounds in the
/// same way. A few dozen such terms stay below 1e-13 m; the largest difference seen is 7e-16 m.
/// Mutations of the outline (B's teeth turned by 1e-10 rad, 1e-11 m along the line) fail.
const TOL: f64 = 1e-13;

/// Configurations to try and the least number that must be checked (Train::new refuses some).
const TRIES: usize = 150;
const AT_LEAST: usize = 30;

// ---------------------------------------------------------------------------------------------
// A small PRNG (SplitMix64), fixed seed.

struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [a, b).
    fn uniform(&mut self, a: f64, b: f64) -> f64 {
        let x = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        a + (b - a) * x
    }

    /// Uniform integer in lo..=hi.
    fn int(&mut self, lo: i32, hi: i32) -> i32 {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as i32
    }
}

// ---------------------------------------------------------------------------------------------
// Plane geometry.

type V2 = [f64; 2];

fn e(a: f64) -> V2 {
    [a.cos(), a.sin()]
}

fn e_perp(a: f64) -> V2 {
    [-a.sin(), a.cos()]
}

fn add(p: V2, q: V2) -> V2 {
    [p[0] + q[0], p[1] + q[1]]
}

fn sub(p: V2, q: V2) -> V2 {
    [p[0] - q[0], p[1] - q[1]]
}

fn scale(k: f64, p: V2) -> V2 {
    [k * p[0], k * p[1]]
}

fn dot(p: V2, q: V2) -> f64 {
    p[0] * q[0] + p[1] * q[1]
}

fn cross(p: V2, q: V2) -> f64 {
    p[0] * q[1] - p[1] * q[0]
}

fn norm(p: V2) -> f64 {
    p[0].hypot(p[1])
}

fn inv(a: f64) -> f64 {
    a.tan() - a
}

/// A gear's outline: centre, base and tip radii, base thickness angle of a tooth, number of
/// teeth, ring (internal teeth, outside the tip circle) or external (inside it), and the
/// absolute angle of tooth 0's symmetry axis.
#[derive(Clone, Debug)]
struct Gear {
    c: V2,
    r_b: f64,
    r_tip: f64,
    t: f64,
    z: usize,
    ring: bool,
    axis0: f64,
}

impl Gear {
    /// The roll sense of the flank on `side` (+1 counter-clockwise, -1 clockwise).
    fn w(&self, side: f64) -> f64 {
        if self.ring {
            side
        } else {
            -side
        }
    }

    /// The tangent-point angle phi and the point P of tooth k's flank on `side` at roll v.
    fn flank(&self, k: usize, side: f64, v: f64) -> (f64, V2) {
        let w = self.w(side);
        let axis = self.axis0 + k as f64 * 2.0 * PI / self.z as f64;
        let phi = axis + side * 0.5 * self.t + w * v;
        let p = add(
            self.c,
            scale(self.r_b, sub(e(phi), scale(w * v, e_perp(phi)))),
        );
        (phi, p)
    }

    /// Half the angular thickness of a tooth on the circle of radius r (from the outline's
    /// definition): the flank's polar angle relative to the axis.
    fn half_thickness(&self, r: f64) -> f64 {
        let a = (self.r_b / r).acos();
        if self.ring {
            0.5 * self.t + inv(a)
        } else {
            0.5 * self.t - inv(a)
        }
    }
}

/// A line of action: A's base-circle tangent point K_A, the unit direction u (A's flank's
/// outward normal), and the stretch [s_lo, s_hi] (from K_A) where both gears have teeth.
#[derive(Clone, Copy, Debug)]
struct Line {
    k_a: V2,
    u: V2,
    s_kb: f64,
    s_lo: f64,
    s_hi: f64,
}

/// The line of action of A's flanks on side_a against B's on side_b.
fn line_of_action(a: &Gear, b: &Gear, side_a: f64, side_b: f64) -> Result<Line, String> {
    let ob = sub(b.c, a.c);
    let (d, beta) = (norm(ob), ob[1].atan2(ob[0]));
    let x = (side_a * a.r_b + side_b * b.r_b) / d;
    if x.is_nan() || x.abs() >= 1.0 {
        return Err(format!("no common tangent: sin = {x}"));
    }
    let l_a = (a.r_tip * a.r_tip - a.r_b * a.r_b).sqrt();
    let l_b = (b.r_tip * b.r_tip - b.r_b * b.r_b).sqrt();
    let mut found = vec![];
    for g in [beta + x.asin(), beta + PI - x.asin()] {
        let u = e(g);
        let k_a = add(a.c, scale(a.r_b * side_a, e(g - 0.5 * PI)));
        let k_b = add(b.c, scale(b.r_b * side_b, e(g + 0.5 * PI)));
        debug_assert!(cross(sub(k_b, k_a), u).abs() < 1e-12);
        let s_kb = dot(sub(k_b, k_a), u);
        // A's flank meets the line at right angles at K_A + v rAb u, inside its tip circle for
        // s <= l_a; B's at K_B - v rBb u (external, inside its tip circle) or K_B + v rBb u
        // (ring, outside its tip circle).
        let (b_lo, b_hi) = if b.ring {
            (s_kb + l_b, f64::INFINITY)
        } else {
            (s_kb - l_b, s_kb)
        };
        let (lo, hi) = (b_lo.max(0.0), b_hi.min(l_a));
        if lo < hi {
            found.push(Line {
                k_a,
                u,
                s_kb,
                s_lo: lo,
                s_hi: hi,
            });
        }
    }
    match found.len() {
        1 => Ok(found[0]),
        n => Err(format!(
            "{n} candidate lines of action have a contact stretch"
        )),
    }
}

/// Where a flank crosses the line: the tooth, the position along u from K_A, the radius from
/// the gear's centre and |e(phi) . u| (0: the flank is normal to the line there).
#[derive(Clone, Copy, Debug)]
struct Crossing {
    tooth: usize,
    s: f64,
    r: f64,
    slant: f64,
}

/// Every crossing of the flanks on `side` of all of g's teeth with the line, for rolls in
/// [0, v_hi]: sign changes of the signed distance from the line on a grid, then bisection to
/// the last bit.
fn crossings(g: &Gear, side: f64, line: &Line, v_hi: f64) -> Vec<Crossing> {
    const N: usize = 256;
    let h = |k: usize, v: f64| cross(sub(g.flank(k, side, v).1, line.k_a), line.u);
    let mut out: Vec<Crossing> = vec![];
    for k in 0..g.z {
        let mut v0 = 0.0;
        let mut h0 = h(k, v0);
        for i in 1..=N {
            let v1 = v_hi * i as f64 / N as f64;
            let h1 = h(k, v1);
            if (h0 < 0.0) != (h1 < 0.0) {
                let (mut lo, mut hi, h_lo) = (v0, v1, h0);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if mid <= lo || mid >= hi {
                        break;
                    }
                    if (h(k, mid) < 0.0) == (h_lo < 0.0) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let v = 0.5 * (lo + hi);
                let (phi, p) = g.flank(k, side, v);
                let s = dot(sub(p, line.k_a), line.u);
                // A root on a grid point is seen by two intervals.
                if !out.iter().any(|c| c.tooth == k && (c.s - s).abs() < 1e-9) {
                    out.push(Crossing {
                        tooth: k,
                        s,
                        r: norm(sub(p, g.c)),
                        slant: dot(e(phi), line.u).abs(),
                    });
                }
            }
            v0 = v1;
            h0 = h1;
        }
    }
    out
}

/// A tooth pair on a line: A's tooth and crossing, B's, and the penetration s_A - s_B.
#[derive(Clone, Copy, Debug)]
struct Pair {
    a: usize,
    b: usize,
    s_a: f64,
    s_b: f64,
    r_a: f64,
    r_b: f64,
}

impl Pair {
    fn delta(&self) -> f64 {
        self.s_a - self.s_b
    }
}

/// The pairs of one flank side whose A crossing lies within a pitch of the contact stretch;
/// each A flank normal to the line on the stretch faces exactly one B flank normal to it within
/// half a pitch (off the stretch, possibly none).
fn pairs(a: &Gear, b: &Gear, line: &Line, side_a: f64, side_b: f64) -> Result<Vec<Pair>, String> {
    let p_b = 2.0 * PI * a.r_b / a.z as f64;
    let near = |c: &Crossing| c.slant < 1e-6 && c.s > line.s_lo - p_b && c.s < line.s_hi + p_b;
    let v_a = (line.s_hi + 2.0 * p_b) / a.r_b;
    let v_b = if b.ring {
        (line.s_hi - line.s_kb + 2.0 * p_b) / b.r_b
    } else {
        (line.s_kb - line.s_lo + 2.0 * p_b) / b.r_b
    };
    let ca: Vec<Crossing> = crossings(a, side_a, line, v_a)
        .into_iter()
        .filter(near)
        .collect();
    let cb: Vec<Crossing> = crossings(b, side_b, line, v_b)
        .into_iter()
        .filter(|c| c.slant < 1e-6)
        .collect();
    let mut out = vec![];
    for x in &ca {
        let facing: Vec<&Crossing> = cb
            .iter()
            .filter(|y| (x.s - y.s).abs() < 0.5 * p_b)
            .collect();
        let on_segment = x.s >= line.s_lo && x.s <= line.s_hi;
        if facing.is_empty() && !on_segment {
            // Off the segment, beyond B's tangent point or its tip: no B flank to face.
            continue;
        }
        if facing.len() != 1 {
            return Err(format!(
                "A's tooth {} crosses at s = {}: {} facing B flanks",
                x.tooth,
                x.s,
                facing.len()
            ));
        }
        out.push(Pair {
            a: x.tooth,
            b: facing[0].tooth,
            s_a: x.s,
            s_b: facing[0].s,
            r_a: x.r,
            r_b: facing[0].r,
        });
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// The configurations.

struct Config {
    label: String,
    spec: TrainSpec,
    /// The pair's standard gear data, which the checks compute the gears from.
    params: Params,
}

/// A random pair from standard gear data and its random placement; Err: the model refuses
/// the geometry (the reason is counted).
fn random_config(rng: &mut Rng, internal: bool, n: usize) -> Result<Config, String> {
    let module = rng.uniform(1e-3, 5e-3);
    let pressure_angle = if rng.uniform(0.0, 1.0) < 0.7 {
        20f64.to_radians()
    } else {
        25f64.to_radians()
    };
    let z_a = rng.int(15, 40);
    let (z_b, x_a, x_b) = if internal {
        (
            z_a + rng.int(25, 80),
            rng.uniform(0.0, 0.3),
            rng.uniform(0.4, 0.9),
        )
    } else {
        (
            rng.int(20, 80),
            rng.uniform(0.0, 0.3),
            rng.uniform(0.0, 0.5),
        )
    };
    let backlash = rng.uniform(0.0, 2e-4);
    let center_distance_error = if internal {
        rng.uniform(-backlash / 3.0, backlash / 3.0)
    } else {
        rng.uniform(-backlash / 3.0, backlash)
    };
    let mut p = Params {
        geometry: 2,
        internal,
        module,
        pressure_angle,
        zA: z_a,
        zB: z_b,
        xA: x_a,
        xB: x_b,
        addendum: 1.0,
        backlash,
        center_distance_error,
        backward_contacts: true,
        contacts_per_flank: 0,
        contact_model: 1,
        ..Params::default()
    };
    let center_angle = rng.uniform(-PI, PI);
    let mount_a = rng.uniform(-PI, PI);
    let mount_b = rng.uniform(-PI, PI);
    let angle_start = rng.uniform(-PI, PI);
    let j_n = Geometry::new(&table::pair(&p).unwrap())
        .map_err(|e| e.message)?
        .j_n;
    p.dte_start = rng.uniform(-j_n, 1e-6);
    let label = format!(
        "#{n} {} m = {module}, alpha0 = {:.0} deg, zA = {z_a}, zB = {z_b}, xA = {x_a}, xB = {x_b}, backlash = {backlash}, cde = {center_distance_error}, dte_start = {}, center_angle = {center_angle}, mount_a = {mount_a}, mount_b = {mount_b}, angle_start = {angle_start}",
        if internal { "internal" } else { "external" },
        pressure_angle.to_degrees(),
        p.dte_start
    );
    let body = Body {
        j: 0.01,
        c: 0.0,
        w_start: 0.0,
        ripple: Ripple::NONE,
        speed_driven: false,
        lateral: None,
        planet: None,
    };
    Ok(Config {
        label,
        spec: TrainSpec {
            bodies: vec![body, body],
            angle_start,
            shafts: vec![],
            meshes: vec![MeshPlace {
                a: 0,
                b: 1,
                center_angle,
                mount_a,
                mount_b,
                pair: table::pair(&p).unwrap(),
                dte_start: p.dte_start,
            }],
        },
        params: p,
    })
}

/// The gears' data from the standard gear data (planetary.md §1, gear-train.md §3): base and
/// tip radii, base thickness angles with half the backlash parameter each. Returns
/// (r_ab, r_bb, r_tip_a, r_tip_b, t_a, t_b).
fn standard_gears(p: &Params) -> [f64; 6] {
    let (m, a0) = (p.module, p.pressure_angle);
    let (za, zb) = (p.zA as f64, p.zB as f64);
    let (r_ab, r_bb) = (m * za * a0.cos() / 2.0, m * zb * a0.cos() / 2.0);
    let r_tip_a = m * za / 2.0 + m * (p.addendum + p.xA);
    // Reference thickness m (pi/2 + 2 x tan a0) over the reference radius, plus 2 inv(a0) on
    // the base circle (the involute narrows outwards).
    let t_a =
        (PI / 2.0 + 2.0 * p.xA * a0.tan()) * 2.0 / za + 2.0 * inv(a0) - p.backlash / (2.0 * r_ab);
    let (r_tip_b, t_b) = if p.internal {
        // The ring's space is an external tooth with shift xB, widened by half the backlash.
        let e_b = (PI / 2.0 + 2.0 * p.xB * a0.tan()) * 2.0 / zb
            + 2.0 * inv(a0)
            + p.backlash / (2.0 * r_bb);
        (m * zb / 2.0 - m * (p.addendum - p.xB), 2.0 * PI / zb - e_b)
    } else {
        let t_b = (PI / 2.0 + 2.0 * p.xB * a0.tan()) * 2.0 / zb + 2.0 * inv(a0)
            - p.backlash / (2.0 * r_bb);
        (m * zb / 2.0 + m * (p.addendum + p.xB), t_b)
    };
    [r_ab, r_bb, r_tip_a, r_tip_b, t_a, t_b]
}

/// What one check found, for the summary.
#[derive(Default)]
struct Summary {
    checked: usize,
    turned: usize,
    refused: Vec<String>,
    failures: Vec<String>,
    max_delta_err: f64,
    max_pos_err: f64,
    max_data_err: f64,
    pairs_seen: usize,
    ends_ambiguous: usize,
}

/// Checks one state: the outlines at the bodies' angles psi_a, psi_b against the model's dte,
/// backlash and contact points. `start`: the objects are where Train::new put them (compare
/// the set in [s_a, s_b]); otherwise only modulo the base pitch.
fn check_state(
    train: &Train,
    y: &State,
    psi: [f64; 2],
    data: [f64; 6],
    start: bool,
    label: &str,
    sum: &mut Summary,
) {
    let mp = &train.spec().meshes[0];
    let g = &train.meshes[0].geo;
    let internal = mp.pair.internal;
    let [r_ab, r_bb, r_tip_a, r_tip_b, t_a, t_b] = data;
    let beta = mp.center_angle;
    let a = Gear {
        c: [0.0, 0.0],
        r_b: r_ab,
        r_tip: r_tip_a,
        t: t_a,
        z: mp.pair.a.z as usize,
        ring: false,
        axis0: psi[0] + mp.mount_a,
    };
    let b = Gear {
        c: scale(g.d, e(beta)),
        r_b: r_bb,
        r_tip: r_tip_b,
        t: t_b,
        z: mp.pair.b.z as usize,
        ring: internal,
        axis0: psi[1] + mp.mount_b,
    };
    let p_b = 2.0 * PI * r_ab / a.z as f64;
    // The outline is sane: both gears' teeth have thickness at their tips.
    assert!(a.half_thickness(a.r_tip) > 0.0 && b.half_thickness(b.r_tip) > 0.0);
    let dte = train.dte(0, y);
    let readout = match train.mesh_readout(0, y) {
        Ok(r) => r,
        Err(e) => {
            sum.failures.push(format!("{label}: mesh_readout: {e:?}"));
            return;
        }
    };
    let mesh = &train.meshes[0];
    // Forward: A's clockwise flanks against B's trailing ones; backward: the others.
    let b_fwd = if internal { 1.0 } else { -1.0 };
    for (flank, side_a, side_b, expected, slots) in [
        ("forward", -1.0, b_fwd, dte, [0usize, 1]),
        ("backward", 1.0, -b_fwd, -g.j_n - dte, [2, 3]),
    ] {
        let what = format!("{label} [{flank}{}]", if start { "" } else { ", turned" });
        let line = match line_of_action(&a, &b, side_a, side_b) {
            Ok(l) => l,
            Err(e) => {
                sum.failures.push(format!("{what}: {e}"));
                continue;
            }
        };
        // The contact segment from the tip circles against the model's.
        let seg_err = (line.s_lo - g.s_a).abs().max((line.s_hi - g.s_b).abs());
        sum.max_pos_err = sum.max_pos_err.max(seg_err);
        if seg_err > TOL {
            sum.failures.push(format!(
                "{what}: contact segment from the outlines [{}, {}], model [{}, {}]",
                line.s_lo, line.s_hi, g.s_a, g.s_b
            ));
        }
        let all = match pairs(&a, &b, &line, side_a, side_b) {
            Ok(p) => p,
            Err(e) => {
                sum.failures.push(format!("{what}: {e}"));
                continue;
            }
        };
        let on: Vec<Pair> = all
            .iter()
            .copied()
            .filter(|q| q.s_a >= line.s_lo && q.s_a <= line.s_hi)
            .collect();
        sum.pairs_seen += on.len();
        if on.is_empty() {
            sum.failures
                .push(format!("{what}: no tooth pair on the segment"));
        }
        // (1) Every pair on the segment penetrates by the flank's shared delta.
        for q in &on {
            // The A crossing lies on A's tooth (inside its tip circle) by construction; the B
            // crossing on B's tooth up to the penetration.
            let in_b = if internal {
                q.r_b >= r_tip_b - q.delta().abs() - TOL
            } else {
                q.r_b <= r_tip_b + q.delta().abs() + TOL
            };
            if q.r_a > r_tip_a + TOL || !in_b {
                sum.failures.push(format!(
                    "{what}: pair A{}/B{} off its teeth: r_A = {}, r_B = {}",
                    q.a, q.b, q.r_a, q.r_b
                ));
            }
            let err = (q.delta() - expected).abs();
            sum.max_delta_err = sum.max_delta_err.max(err);
            if err > TOL {
                sum.failures.push(format!(
                    "{what}: pair A{}/B{} at s = {}: penetration from the outlines {}, model {} (difference {:e})",
                    q.a, q.b, q.s_a, q.delta(), expected, q.delta() - expected
                ));
            }
        }
        // (2), (3) The objects' contact points.
        let objects: Vec<(usize, f64)> = slots
            .iter()
            .filter(|&&k| mesh.present(k))
            .map(|&k| (k, readout.contact_point[k]))
            .collect();
        if start {
            // Both sides use A's flank point for membership: only rounding at the ends can
            // make them differ.
            let near_end = |s: f64| (s - line.s_lo).abs() <= 1e-9 || (s - line.s_hi).abs() <= 1e-9;
            if on.iter().any(|q| near_end(q.s_a)) || objects.iter().any(|o| near_end(o.1)) {
                sum.ends_ambiguous += 1;
                continue;
            }
            let mut geo: Vec<f64> = on.iter().map(|q| q.s_a).collect();
            let mut model: Vec<f64> = objects
                .iter()
                .map(|o| o.1)
                .filter(|&s| s >= g.s_a && s <= g.s_b)
                .collect();
            geo.sort_by(f64::total_cmp);
            model.sort_by(f64::total_cmp);
            if geo.len() != model.len() {
                sum.failures.push(format!(
                    "{what}: {} pairs on the segment from the outlines at {geo:?}, {} objects of the model in [s_a, s_b] = [{}, {}] at {model:?} (all objects: {objects:?})",
                    geo.len(), model.len(), g.s_a, g.s_b
                ));
                continue;
            }
            for (x, m) in geo.iter().zip(&model) {
                let err = (x - m).abs();
                sum.max_pos_err = sum.max_pos_err.max(err);
                if err > TOL {
                    sum.failures.push(format!(
                        "{what}: contact point from the outlines {x}, model {m} (difference {:e}); all objects {objects:?}",
                        x - m
                    ));
                }
            }
            // The objects on the segment carry force exactly when their flank penetrates
            // (no deviations; the bodies start at rest, so the damped force is the elastic
            // one); those off it carry none.
            if expected.abs() > 1e-12 {
                for &(k, s) in &objects {
                    let inside = s >= g.s_a && s <= g.s_b;
                    let gate_ok = s - expected.max(0.0) >= g.s_a;
                    let should = inside && gate_ok && expected > 0.0;
                    if mesh.carrying(k) != should {
                        sum.failures.push(format!(
                            "{what}: slot {k} at s = {s} carrying = {}, the geometry says {should} (delta {expected})",
                            mesh.carrying(k)
                        ));
                    }
                }
            }
        } else {
            // The objects jump only at events: each pair on the segment must be an object's
            // position modulo the base pitch.
            for q in &on {
                let best = objects
                    .iter()
                    .map(|o| {
                        let x = (o.1 - q.s_a) / p_b;
                        (x - x.round()).abs() * p_b
                    })
                    .fold(f64::INFINITY, f64::min);
                sum.max_pos_err = sum.max_pos_err.max(best);
                if best > TOL {
                    sum.failures.push(format!(
                        "{what}: pair A{}/B{} at s = {} is no object's position modulo p_b = {p_b} (nearest {best:e} off; objects {objects:?})",
                        q.a, q.b, q.s_a
                    ));
                }
            }
        }
    }
}

fn run(internal: bool, seed: u64) -> Summary {
    let mut rng = Rng(seed);
    let mut sum = Summary::default();
    for n in 0..TRIES {
        let cfg = match random_config(&mut rng, internal, n) {
            Ok(c) => c,
            Err(e) => {
                sum.refused.push(e);
                continue;
            }
        };
        // Draw the turn before Train::new so that refusals do not shift the sequence.
        let turn = rng.uniform(-20.0, 20.0);
        let dte_frac = rng.uniform(0.0, 1.0);
        let (train, y0) = match Train::new(cfg.spec.clone(), vec![0.0, 0.0], None) {
            Ok(t) => t,
            Err(e) => {
                sum.refused.push(e.message);
                continue;
            }
        };
        sum.checked += 1;
        let p = &cfg.params;
        let g = &train.meshes[0].geo;
        // The gears' data: standard gear data against the model's.
        let data = standard_gears(p);
        let model_data = [g.r_ab, g.r_bb, g.r_tip_a, g.r_tip_b, g.t_a, g.t_b];
        for (i, (x, m)) in data.iter().zip(&model_data).enumerate() {
            let err = (x - m).abs() / m.abs();
            sum.max_data_err = sum.max_data_err.max(err);
            if err > 1e-14 {
                sum.failures.push(format!(
                    "{}: gear datum {i} (r_ab, r_bb, r_tip_a, r_tip_b, t_a, t_b) from standard data {x}, model {m}",
                    cfg.label
                ));
            }
        }
        let psi = [train.cfg.psi_start[0], train.cfg.psi_start[1]];
        check_state(&train, &y0, psi, data, true, &cfg.label, &mut sum);

        // Body 1 turned, the mesh at another dte; the bodies' angles from the train's rigid
        // kinematics. B's forward sense: counter-clockwise for an external mesh, clockwise (as
        // body 1's) for an internal one.
        let mut y = y0;
        // Coordinate 0 is body 1's angle, coordinate 1 the mesh's dte.
        y[coord_index(0)] = turn;
        let dte = -g.j_n + dte_frac * (g.j_n + 1e-6);
        y[coord_index(1)] = dte;
        assert_eq!(train.dte(0, &y), dte, "the mesh's dte is coordinate 1");
        let bodies = train.bodies(&y);
        let sense_b = if internal { -1.0 } else { 1.0 };
        let psi = [
            train.cfg.psi_start[0] - bodies.theta[0],
            train.cfg.psi_start[1] + sense_b * bodies.theta[1],
        ];
        let label = format!("{} turned by {turn} rad, dte = {dte}", cfg.label);
        check_state(&train, &y, psi, data, false, &label, &mut sum);
        sum.turned += 1;
    }
    sum
}

fn report(name: &str, sum: &Summary) {
    println!(
        "{name}: {} configurations checked (+{} turned states), {} refused by the model, {} pairs on segments; max |penetration error| {:e} m, max |position error| {:e} m, max relative gear-data difference {:e}; {} flank comparisons skipped for a pair within 1e-9 m of a segment end",
        sum.checked,
        sum.turned,
        sum.refused.len(),
        sum.pairs_seen,
        sum.max_delta_err,
        sum.max_pos_err,
        sum.max_data_err,
        sum.ends_ambiguous
    );
    let mut reasons: Vec<String> = sum
        .refused
        .iter()
        .map(|r| r.chars().take(60).collect())
        .collect();
    reasons.sort();
    reasons.dedup();
    for r in reasons.iter().take(8) {
        println!("  refused: {r}...");
    }
    for f in sum.failures.iter().take(20) {
        println!("  FAIL {f}");
    }
}

#[test]
fn internal_pairs_match_their_outlines() {
    let sum = run(true, 0x5eed_1234_abcd_0001);
    report("internal", &sum);
    assert!(
        sum.checked >= AT_LEAST,
        "only {} configurations",
        sum.checked
    );
    assert!(
        sum.failures.is_empty(),
        "{} failures, first: {}",
        sum.failures.len(),
        sum.failures[0]
    );
}

#[test]
fn external_pairs_match_their_outlines() {
    let sum = run(false, 0x5eed_1234_abcd_0002);
    report("external", &sum);
    assert!(
        sum.checked >= AT_LEAST,
        "only {} configurations",
        sum.checked
    );
    assert!(
        sum.failures.is_empty(),
        "{} failures, first: {}",
        sum.failures.len(),
        sum.failures[0]
    );
}
