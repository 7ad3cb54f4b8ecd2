//! The drawing of a gearbox for its FMU's documentation: every gear's pitch circle at its axis,
//! to scale, with its name; meshes as lines between axes. Axes are placed as the file says: a
//! housing mesh along its `center_angle` at the reference centre distance, a planet at its
//! orbit angle around its carrier, a shaft's bodies on one axis.

use gearbox::{Gearbox, Support};
use std::fmt::Write;

/// An axis: a body's, or a housing-fixed gear's (a fixed ring).
#[derive(Clone, Copy, PartialEq)]
enum Node {
    Body(usize),
    Fixed(usize),
}

fn node(g: &Gearbox, gear: usize) -> Node {
    match g.gears[gear].support {
        Support::Body(i) => Node::Body(i),
        Support::Housing => Node::Fixed(gear),
    }
}

/// Pitch radius \[m\] (the paper geometry's: from its operating radius).
fn radius(g: &Gearbox, gear: usize) -> f64 {
    let z = g.gears[gear].z as f64;
    if let Some(m) = g.gears[gear].module {
        return m * z / 2.0;
    }
    g.meshes
        .iter()
        .find_map(|mesh| {
            let p = mesh.paper?;
            let side = mesh.gears.iter().position(|&k| k == gear)?;
            let nominal = [p.z_a_nominal, p.z_b_nominal][side] as f64;
            Some(p.r_a * nominal / p.z_a_nominal as f64)
        })
        .unwrap_or(z / 2.0)
}

/// A point in the housing's plane \[m\], where known.
type At = Option<(f64, f64)>;

/// The bodies' axes and the housing-fixed gears' axes.
fn positions(g: &Gearbox) -> (Vec<At>, Vec<At>) {
    let mut body: Vec<Option<(f64, f64)>> = vec![None; g.bodies.len()];
    let mut fixed: Vec<Option<(f64, f64)>> = vec![None; g.gears.len()];
    if !body.is_empty() {
        body[0] = Some((0.0, 0.0));
    }
    let planet = |i: usize| g.bodies[i].orbit;
    for _ in 0..=g.bodies.len() + g.gears.len() {
        let get = |n: Node, body: &[Option<(f64, f64)>], fixed: &[Option<(f64, f64)>]| match n {
            Node::Body(i) => body[i],
            Node::Fixed(k) => fixed[k],
        };
        for mesh in &g.meshes {
            let [a, b] = mesh.gears;
            let (na, nb) = (node(g, a), node(g, b));
            let (ra, rb) = (radius(g, a), radius(g, b));
            let d = if g.gears[b].internal {
                rb - ra
            } else {
                ra + rb
            };
            let planet_side = [na, nb]
                .iter()
                .position(|n| matches!(n, Node::Body(i) if planet(*i).is_some()));
            if let Some(side) = planet_side {
                // The other gear is central: on the carrier's axis.
                let Node::Body(p) = [na, nb][side] else {
                    unreachable!()
                };
                let o = planet(p).expect("a planet");
                let other = [na, nb][1 - side];
                let centre = get(other, &body, &fixed).or(body[o.carrier]);
                if let Some(c) = centre {
                    body[o.carrier].get_or_insert(c);
                    if let Node::Fixed(k) = other {
                        fixed[k].get_or_insert(c);
                    }
                    if let Node::Body(i) = other {
                        body[i].get_or_insert(c);
                    }
                    body[p].get_or_insert((c.0 + d * o.angle.cos(), c.1 + d * o.angle.sin()));
                }
                continue;
            }
            let beta = mesh.center_angle.unwrap_or(0.0);
            let sign = if g.gears[b].internal { -1.0 } else { 1.0 };
            let step = (sign * d * beta.cos(), sign * d * beta.sin());
            match (get(na, &body, &fixed), get(nb, &body, &fixed)) {
                (Some(pa), None) => set(nb, (pa.0 + step.0, pa.1 + step.1), &mut body, &mut fixed),
                (None, Some(pb)) => set(na, (pb.0 - step.0, pb.1 - step.1), &mut body, &mut fixed),
                _ => {}
            }
        }
        for s in &g.shafts {
            let ends = s.ends.map(|e| match e {
                Support::Body(i) => Some(i),
                Support::Housing => None,
            });
            if let [Some(i), Some(j)] = ends {
                match (body[i], body[j]) {
                    (Some(p), None) => body[j] = Some(p),
                    (None, Some(p)) => body[i] = Some(p),
                    _ => {}
                }
            }
        }
    }
    (body, fixed)
}

fn set(n: Node, p: (f64, f64), body: &mut [Option<(f64, f64)>], fixed: &mut [Option<(f64, f64)>]) {
    match n {
        Node::Body(i) => body[i] = Some(p),
        Node::Fixed(k) => fixed[k] = Some(p),
    }
}

/// The SVG drawing.
pub fn svg(g: &Gearbox) -> String {
    let (body, fixed) = positions(g);
    let at = |gear: usize| match node(g, gear) {
        Node::Body(i) => body[i],
        Node::Fixed(k) => fixed[k],
    };
    let circles: Vec<(usize, (f64, f64), f64)> = (0..g.gears.len())
        .filter_map(|k| at(k).map(|p| (k, p, radius(g, k))))
        .collect();
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for &(_, (x, y), r) in &circles {
        (x0, y0, x1, y1) = (x0.min(x - r), y0.min(y - r), x1.max(x + r), y1.max(y + r));
    }
    if circles.is_empty() {
        (x0, y0, x1, y1) = (-1.0, -1.0, 1.0, 1.0);
    }
    let size = (x1 - x0).max(y1 - y0).max(1e-9);
    let scale = 600.0 / size;
    let px = |(x, y): (f64, f64)| (40.0 + (x - x0) * scale, 40.0 + (y1 - y) * scale);
    let (w, h) = (80.0 + (x1 - x0) * scale, 80.0 + (y1 - y0) * scale);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.0} {h:.0}\" font-family=\"sans-serif\" font-size=\"12\">"
    );
    let _ = writeln!(s, "<title>{}</title>", fmu_packaging::esc(&g.name));
    for &(k, p, r) in &circles {
        let (cx, cy) = px(p);
        let (fill, width) = if g.gears[k].internal {
            ("none", 3.0)
        } else {
            ("#dde8f4", 1.0)
        };
        let _ = writeln!(
            s,
            "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"{:.1}\" fill=\"{fill}\" fill-opacity=\"0.5\" stroke=\"#345\" stroke-width=\"{width}\"/>",
            r * scale
        );
    }
    for mesh in &g.meshes {
        if let (Some(a), Some(b)) = (at(mesh.gears[0]), at(mesh.gears[1])) {
            let ((xa, ya), (xb, yb)) = (px(a), px(b));
            let _ = writeln!(s, "<line x1=\"{xa:.1}\" y1=\"{ya:.1}\" x2=\"{xb:.1}\" y2=\"{yb:.1}\" stroke=\"#c33\" stroke-width=\"1.5\"><title>mesh {}</title></line>", fmu_packaging::esc(&mesh.name));
        }
    }
    let mut labels: Vec<(f64, f64)> = Vec::new();
    for &(k, p, r) in &circles {
        let (cx, cy) = px(p);
        // A ring's name at its rim, the others' at their axis; gears on one axis (a shaft's
        // bodies, two gears of a body) one line below the other.
        let y = if g.gears[k].internal {
            cy - r * scale + 14.0
        } else {
            cy + 4.0
        };
        let same = labels
            .iter()
            .filter(|&&(x, y0)| (x - cx).abs() < 1.0 && (y0 - y).abs() < 1.0)
            .count();
        labels.push((cx, y));
        let y = y + 14.0 * same as f64;
        let _ = writeln!(
            s,
            "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"2\" fill=\"#345\"/><text x=\"{cx:.1}\" y=\"{y:.1}\" text-anchor=\"middle\">{} (z = {})</text>",
            fmu_packaging::esc(&g.gears[k].name),
            g.gears[k].z
        );
    }
    s.push_str("</svg>\n");
    s
}
