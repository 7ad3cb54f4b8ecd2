//! Where the axes and the teeth are (gear-train.md §3-§4, planetary.md §3-§4): each mesh's
//! geometry and frame (a planet's from its position on the carrier), the breadth-first walk
//! that places the bodies, and the start penetration of every mesh that closes a loop.

use super::topology::{body_name, Edge, Structure, TrainSpec, HOUSING};
use crate::model::geometry::Geometry;
use crate::model::mesh::Placement;
use crate::model::ModelError;
use std::collections::VecDeque;
use std::f64::consts::PI;

/// A mesh's frame: the carrier it turns with (None: the housing), the direction of O_A -> O_B
/// in that frame \[rad\], and `s` = +1 when the frame is only rotated (sigma_A = -1), -1 when
/// it is mirrored too (sigma_A = +1): psi^m = s (psi - psi_c - beta), and a gear's tooth 0
/// axis is at chi = psi^m + s mount.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshFrame {
    pub carrier: Option<usize>,
    pub beta: f64,
    pub s: f64,
}

/// Every mesh's geometry and frame, and each body's orbit radius (0 off a carrier).
pub struct Layout {
    pub geo: Vec<Geometry>,
    pub frames: Vec<MeshFrame>,
    pub orbit_radius: Vec<f64>,
}

fn at_mesh(m: usize) -> impl Fn(ModelError) -> ModelError {
    move |e| ModelError::new(format!("mesh[{}]: {}", m + 1, e.message))
}

/// The geometry of every mesh at the distance its axes are (planetary.md §2-§3): a housing
/// mesh at its nominal distance (plus its error); a mesh in a carrier's frame at the distance
/// of its axes' positions there. Checks that each carrier's central members share its axis.
pub fn layout(spec: &TrainSpec, st: &Structure) -> Result<Layout, ModelError> {
    let n = spec.bodies.len();
    let nominal = |m: usize| -> Result<Geometry, ModelError> {
        let mut p = spec.meshes[m].pair.clone();
        p.center_distance_error = 0.0;
        Geometry::at_distance(&p, None).map_err(at_mesh(m))
    };
    // A planet's orbit radius: the nominal distance of its lowest mesh with a central member.
    let mut orbit_radius = vec![0.0; n];
    for (i, body) in spec.bodies.iter().enumerate() {
        let Some(pl) = body.planet else { continue };
        let central = spec.meshes.iter().position(|mp| {
            (mp.a == i && spec.carrier_of(mp.b).is_none())
                || (mp.b == i && spec.carrier_of(mp.a).is_none())
        });
        let Some(m) = central else {
            return Err(ModelError::new(format!(
                "body[{}] is a planet of body[{}] but meshes with no central gear (a gear on the carrier's axis or the housing): its orbit radius is undefined",
                i + 1,
                pl.carrier + 1
            )));
        };
        orbit_radius[i] = nominal(m)?.d_nominal;
    }
    // A body's axis in its carrier's frame as (radial, tangential) offsets at an orbit angle.
    let polar = |i: usize| -> (f64, f64, f64) {
        match spec.bodies.get(i).and_then(|b| b.planet) {
            Some(pl) => (
                orbit_radius[i] + pl.pin_error_r,
                pl.pin_error_t,
                pl.orbit_angle,
            ),
            None => (0.0, 0.0, 0.0),
        }
    };
    // The housing's meshes first: they place the housing-fixed axes, which must agree before
    // a carrier's meshes take their distances from the carrier's axis.
    let mut housing_geo = Vec::with_capacity(spec.meshes.len());
    for (m, mp) in spec.meshes.iter().enumerate() {
        housing_geo.push(match st.frame[m] {
            None => Some(Geometry::at_distance(&mp.pair, None).map_err(at_mesh(m))?),
            Some(_) => None,
        });
    }
    check_axes(spec, st, &housing_geo)?;
    let mut geo = Vec::with_capacity(spec.meshes.len());
    let mut frames = Vec::with_capacity(spec.meshes.len());
    for (m, mp) in spec.meshes.iter().enumerate() {
        let s = -st.mesh_sense[m].0;
        let carrier = st.frame[m];
        let (g, beta) = match (carrier, housing_geo[m].take()) {
            (None, Some(g)) => (g, mp.center_angle),
            _ => {
                let ((ra, ta, fa), (rb, tb, fb)) = (polar(mp.a), polar(mp.b));
                // Each axis from the carrier's; a central gear's is the carrier's own.
                let (d, beta) = if ra == 0.0 && ta == 0.0 {
                    (rb.hypot(tb), fb + tb.atan2(rb))
                } else if rb == 0.0 && tb == 0.0 {
                    (ra.hypot(ta), fa + ta.atan2(ra) + PI)
                } else {
                    let at = |r: f64, t: f64, f: f64| {
                        let (sn, cs) = f.sin_cos();
                        (r * cs - t * sn, r * sn + t * cs)
                    };
                    let (xa, ya) = at(ra, ta, fa);
                    let (xb, yb) = at(rb, tb, fb);
                    ((xb - xa).hypot(yb - ya), (yb - ya).atan2(xb - xa))
                };
                (
                    Geometry::at_distance(&mp.pair, Some(d)).map_err(at_mesh(m))?,
                    beta,
                )
            }
        };
        geo.push(g);
        frames.push(MeshFrame { carrier, beta, s });
    }
    Ok(Layout {
        geo,
        frames,
        orbit_radius,
    })
}

/// The housing-fixed axes, placed along the housing's meshes (O_B = O_A + d (cos beta,
/// sin beta)), shafts and carriers (a shaft and a carrier share the axes they join), must
/// agree wherever two chains reach one body: a carrier's central gears share its axis.
fn check_axes(
    spec: &TrainSpec,
    st: &Structure,
    geo: &[Option<Geometry>],
) -> Result<(), ModelError> {
    let n = spec.bodies.len();
    // Links between housing-mounted bodies: (from, to, offset, what).
    let mut links: Vec<(usize, usize, (f64, f64), String)> = Vec::new();
    for (m, mp) in spec.meshes.iter().enumerate() {
        if let (Some(g), true) = (&geo[m], mp.a != HOUSING && mp.b != HOUSING) {
            let (sn, cs) = mp.center_angle.sin_cos();
            links.push((mp.a, mp.b, (g.d * cs, g.d * sn), Edge::Mesh(m).name()));
        }
    }
    for (j, sh) in spec.shafts.iter().enumerate() {
        if sh.a != HOUSING && sh.b != HOUSING {
            links.push((sh.a, sh.b, (0.0, 0.0), Edge::Shaft(j).name()));
        }
    }
    for (m, mp) in spec.meshes.iter().enumerate() {
        let Some(c) = st.frame[m] else { continue };
        for end in [mp.a, mp.b] {
            if end != HOUSING && spec.carrier_of(end).is_none() {
                let what = format!(
                    "{} (body[{}] meshes with a planet of body[{}], so it turns on the carrier's axis)",
                    Edge::Mesh(m).name(),
                    end + 1,
                    c + 1
                );
                links.push((c, end, (0.0, 0.0), what));
            }
        }
    }
    let mut pos: Vec<Option<(f64, f64)>> = vec![None; n];
    let mut via: Vec<Vec<String>> = vec![Vec::new(); n];
    for start in 0..n {
        if pos[start].is_some() || spec.carrier_of(start).is_some() {
            continue;
        }
        pos[start] = Some((0.0, 0.0));
        let mut queue = VecDeque::from([start]);
        while let Some(i) = queue.pop_front() {
            let p = pos[i].expect("queued bodies are placed");
            for (a, b, (dx, dy), what) in &links {
                let (to, q) = if *a == i {
                    (*b, (p.0 + dx, p.1 + dy))
                } else if *b == i {
                    (*a, (p.0 - dx, p.1 - dy))
                } else {
                    continue;
                };
                match pos[to] {
                    None => {
                        pos[to] = Some(q);
                        via[to] = via[i].clone();
                        via[to].push(what.clone());
                        queue.push_back(to);
                    }
                    Some(r) => {
                        let miss = (r.0 - q.0).hypot(r.1 - q.1);
                        // An assembly tolerance: a micrometre is far below any gear's
                        // backlash, far above the rounding of the chains' sines.
                        if miss > 1e-6 {
                            let chain = |v: &[String]| {
                                if v.is_empty() {
                                    "its own place".to_string()
                                } else {
                                    v.join(", ")
                                }
                            };
                            let mut other = via[i].clone();
                            other.push(what.clone());
                            return Err(ModelError::new(format!(
                                "the axes do not close: {} and {} put {}'s axis {miss:.6e} m apart; a planet meshing with housing-mounted gears needs them coaxial with its carrier, and housing gears in a loop need centre angles and distances that close it",
                                chain(&via[to]),
                                chain(&other),
                                body_name(to)
                            )));
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// The mesh frame's rotation: the direction of O_A -> O_B for an external pair; for an
/// internal one the frame puts O_B at (-d, 0), so it is turned half a revolution more
/// (planetary.md §1, §3).
fn frame_angle(g: &Geometry, beta: f64) -> f64 {
    if g.internal {
        beta + PI
    } else {
        beta
    }
}

/// The absolute start angle psi(0) of the gear being placed, given its axis angle chi in the
/// mesh frame up to whole teeth: chi = x + q dz. Returns psi in (-dz/2, dz/2] (the tooth
/// nearest its reference is tooth 0); `pairing` then reads which teeth meet.
fn nearest(x: f64, dz: f64, s: f64, beta: f64, mount: f64) -> f64 {
    // psi = beta - mount + s chi = base + s q dz
    let base = beta - mount + s * x;
    let psi = base + (((-0.5 * dz - base) / dz).floor() + 1.0) * dz;
    // Rounding at the interval's ends.
    if psi <= -0.5 * dz {
        psi + dz
    } else if psi > 0.5 * dz {
        psi - dz
    } else {
        psi
    }
}

/// A walk step: an edge, the body reached before (`from`, perhaps the housing) and the body
/// it places (`to`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    pub edge: Edge,
    pub from: usize,
    pub to: usize,
}

/// The start of every body and mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Start {
    /// Absolute start angle of each body \[rad\].
    pub psi: Vec<f64>,
    /// Each mesh's placement for the component.
    pub meshes: Vec<Placement>,
    /// Each mesh's forward penetration at t = 0: its dte_start, or for a mesh that closes a
    /// loop what the placed angles give.
    pub dte0: Vec<f64>,
    /// The walk's steps in order, each placing one body.
    pub steps: Vec<Step>,
    /// The bodies placed without an element: the walk's starts and the carriers.
    pub free: Vec<usize>,
}

/// Places the bodies breadth first (planetary.md §4) and derives each mesh's pairing: from
/// the housing when an element names it, else from body 1 at `angle_start`; every carrier at
/// 0. Should bodies remain when the walk ends, it goes on from the lowest of them at 0.
pub fn place(spec: &TrainSpec, st: &Structure, lay: &Layout) -> Result<Start, ModelError> {
    let n = spec.bodies.len();
    let mut psi = vec![f64::NAN; n];
    let mut placed = vec![false; n];
    let mut free = Vec::new();
    let mut queue = VecDeque::new();
    if st.uses_housing {
        queue.push_back(HOUSING);
    } else if !st.carriers.contains(&0) {
        psi[0] = spec.angle_start;
        placed[0] = true;
        free.push(0);
        queue.push_back(0);
    }
    for &c in &st.carriers {
        psi[c] = 0.0;
        placed[c] = true;
        free.push(c);
        queue.push_back(c);
    }
    let angle = |psi: &[f64], i: usize| if i == HOUSING { 0.0 } else { psi[i] };
    let mut steps = Vec::new();
    let mut placing = vec![false; spec.meshes.len()];
    loop {
        while let Some(i) = queue.pop_front() {
            for e in spec.edges() {
                let (a, b) = spec.ends(e);
                let to = match (a == i, b == i) {
                    (true, _) if b != HOUSING && !placed[b] => b,
                    (_, true) if a != HOUSING && !placed[a] => a,
                    _ => continue,
                };
                psi[to] = match e {
                    Edge::Shaft(j) => {
                        let (sh, sense) = (&spec.shafts[j], st.shaft_sense[j]);
                        if to == sh.b {
                            angle(&psi, sh.a) - sense * sh.twist_start
                        } else {
                            angle(&psi, sh.b) + sense * sh.twist_start
                        }
                    }
                    Edge::Mesh(m) => {
                        placing[m] = true;
                        let (mp, g, f) = (&spec.meshes[m], &lay.geo[m], lay.frames[m]);
                        let beta = frame_angle(g, f.beta);
                        let dte = mp.dte_start;
                        // Carriers stand at 0 at the start: angles relative to them are the
                        // absolute ones. The forward delta of A's tooth n_A against B's n_B is
                        // C(chi_A, chi_B) + (n_A - n_B) p_b, linear in both axis angles:
                        // dC/dchi_A = -rAb, dC/dchi_B = -kappa rBb. Solve C = dte.
                        if to == mp.b {
                            let chi_a = f.s * (angle(&psi, mp.a) - beta) + f.s * mp.mount_a;
                            let x = (dte - forward_offset(g, chi_a, 0.0)) / (-g.kappa * g.r_bb);
                            nearest(x, g.d_b, f.s, beta, mp.mount_b)
                        } else {
                            let chi_b = f.s * (angle(&psi, mp.b) - beta) + f.s * mp.mount_b;
                            let x = (dte - forward_offset(g, 0.0, chi_b)) / (-g.r_ab);
                            nearest(x, g.d_a, f.s, beta, mp.mount_a)
                        }
                    }
                };
                placed[to] = true;
                steps.push(Step {
                    edge: e,
                    from: i,
                    to,
                });
                queue.push_back(to);
            }
        }
        match placed.iter().position(|p| !p) {
            Some(i) => {
                psi[i] = 0.0;
                placed[i] = true;
                free.push(i);
                queue.push_back(i);
            }
            None => break,
        }
    }
    let mut meshes = Vec::with_capacity(spec.meshes.len());
    let mut dte0 = Vec::with_capacity(spec.meshes.len());
    for (m, mp) in spec.meshes.iter().enumerate() {
        let (g, f) = (&lay.geo[m], lay.frames[m]);
        let (psi_a, psi_b) = (angle(&psi, mp.a), angle(&psi, mp.b));
        let dte = if placing[m] {
            mp.dte_start
        } else {
            let beta = frame_angle(g, f.beta);
            let chi_a = f.s * (psi_a - beta + mp.mount_a);
            let chi_b = f.s * (psi_b - beta + mp.mount_b);
            let c = forward_offset(g, chi_a, chi_b);
            // The pairing nearest the middle of the backlash.
            let delta = c + ((-0.5 * g.j_n - c) / g.p_b).round() * g.p_b;
            check_assembly(spec, st, lay, m, delta)?;
            delta
        };
        dte0.push(dte);
        meshes.push(pairing(g, f, mp.mount_a, mp.mount_b, psi_a, psi_b, dte));
    }
    Ok(Start {
        psi,
        meshes,
        dte0,
        steps,
        free,
    })
}

/// A loop-closing mesh whose teeth would start more than 1 % of a base pitch into each other
/// (on either flank) cannot be assembled as placed (planetary.md §4).
fn check_assembly(
    spec: &TrainSpec,
    st: &Structure,
    lay: &Layout,
    m: usize,
    delta: f64,
) -> Result<(), ModelError> {
    let g = &lay.geo[m];
    let backward = -g.j_n - delta;
    let worst = delta.max(backward);
    if worst <= 0.01 * g.p_b {
        return Ok(());
    }
    let flank = if delta >= backward {
        "forward"
    } else {
        "backward"
    };
    let mut msg = format!(
        "mesh[{}] closes a loop and cannot be assembled as placed: its {flank} flank would start {worst:.6e} m into the teeth ({:.1} % of the base pitch {:.6e} m; at most 1 % is taken as a preload)",
        m + 1,
        100.0 * worst / g.p_b,
        g.p_b
    );
    if let Some(hint) = assembly_condition(spec, st, lay, m) {
        msg.push_str(&hint);
    }
    Err(ModelError::new(msg))
}

/// For a planet of a simple set: the assembly condition with this planet's numbers.
fn assembly_condition(spec: &TrainSpec, st: &Structure, lay: &Layout, m: usize) -> Option<String> {
    let c = st.frame[m]?;
    let mp = &spec.meshes[m];
    let planet = if spec.carrier_of(mp.a) == Some(c) {
        mp.a
    } else {
        mp.b
    };
    // The carrier's sun (an external central mesh) and ring (an internal one): their teeth.
    let mut z_sun = None;
    let mut z_ring = None;
    for (k, q) in spec.meshes.iter().enumerate() {
        if st.frame[k] != Some(c) {
            continue;
        }
        let g = &lay.geo[k];
        if q.pair.internal && spec.carrier_of(q.b).is_none() {
            z_ring = Some(g.z_b);
        } else if !q.pair.internal && spec.carrier_of(q.a).is_none() {
            z_sun = Some(g.z_a);
        } else if !q.pair.internal && spec.carrier_of(q.b).is_none() {
            z_sun = Some(g.z_b);
        }
    }
    let first = (0..spec.bodies.len()).find(|&i| spec.carrier_of(i) == Some(c))?;
    let (zs, zr) = (z_sun?, z_ring?);
    let orbit = |i: usize| spec.bodies[i].planet.map_or(0.0, |p| p.orbit_angle);
    let k = (zs + zr) * (orbit(planet) - orbit(first)) / (2.0 * PI);
    Some(format!(
        ". Planet body[{}] at orbit angle {} rad against body[{}] at {} rad: the assembly condition of a simple planetary set, (z_sun + z_ring) (psi_n - psi_1) / (2 pi) = ({zs} + {zr}) ({} - {}) / (2 pi) = {k:.6}, must be an integer",
        planet + 1,
        orbit(planet),
        first + 1,
        orbit(first),
        orbit(planet),
        orbit(first)
    ))
}

/// The forward penetration of A's tooth 0 against B's tooth 0 with their axes at chi_A,
/// chi_B in the mesh frame (gear-train.md §3; planetary.md §1 for a ring, whose tooth n has
/// its forward root at chi_B - n dB + tB/2 and s_B = rBb (alpha_w - phiB)).
fn forward_offset(g: &Geometry, chi_a: f64, chi_b: f64) -> f64 {
    let s_a = g.r_ab * (g.alpha_w - chi_a + 0.5 * g.t_a);
    if g.internal {
        s_a - g.r_bb * (g.alpha_w - chi_b - 0.5 * g.t_b) + g.l
    } else {
        s_a + g.r_bb * (g.alpha_w + PI - chi_b + 0.5 * g.t_b) - g.l
    }
}

/// The same for the backward flank, whose delta is this plus (n_B - n_A) p_b.
fn backward_offset(g: &Geometry, chi_a: f64, chi_b: f64) -> f64 {
    let s_a = g.r_ab * (g.alpha_w + chi_a + 0.5 * g.t_a);
    if g.internal {
        s_a - g.r_bb * (g.alpha_w + chi_b - 0.5 * g.t_b) + g.l
    } else {
        s_a + g.r_bb * (g.alpha_w - PI + chi_b + 0.5 * g.t_b) - g.l
    }
}

/// The teeth that meet, from both gears' start angles (relative to the mesh's carrier):
/// forward, delta = C + (n_A - n_B) p_b must be `dte`; backward, delta_b = C_b + (n_B - n_A)
/// p_b must be -j_n - dte (the thickness closure at the actual centre distance makes both
/// hold at once).
pub fn pairing(
    g: &Geometry,
    f: MeshFrame,
    mount_a: f64,
    mount_b: f64,
    psi_a: f64,
    psi_b: f64,
    dte: f64,
) -> Placement {
    let beta = frame_angle(g, f.beta);
    let chi_a = f.s * (psi_a - beta) + f.s * mount_a;
    let chi_b = f.s * (psi_b - beta) + f.s * mount_b;
    let q = ((dte - forward_offset(g, chi_a, chi_b)) / g.p_b).round() as i64;
    let q_b = ((-g.j_n - dte - backward_offset(g, chi_a, chi_b)) / g.p_b).round() as i64;
    Placement::Teeth {
        chi_a,
        b_fwd: -q,
        b_bwd: q_b,
    }
}

/// A train's start from its specification alone (the structure, the layout and the walk),
/// for tests and tools that look at the placement.
pub fn start_of(spec: &TrainSpec) -> Result<Start, ModelError> {
    let st = spec.structure()?;
    let lay = layout(spec, &st)?;
    place(spec, &st, &lay)
}
