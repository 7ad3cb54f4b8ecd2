//! The loaded static mesh: at each wheel position the penetration shared by the gated pairs
//! that carries a total force W along the line of action, by exact static balance (no
//! dynamics). Gives the static transmission error and the mesh stiffness over a mesh cycle.

use super::geometry::Geometry;
use super::law::ContactLaw;

/// The balance at one position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticPoint {
    /// Position of the mesh cycle: s_A of the pair nearest the segment's start.
    pub s0: f64,
    /// The shared penetration (the static transmission error) \[m\].
    pub delta: f64,
    pub pairs: usize,
    /// W / delta and sum dF_i/d(delta) \[N/m\].
    pub secant: f64,
    pub tangent: f64,
}

/// A pair at s_A with its shape deviation e (tip relief): it carries at delta + e > 0.
type Pair = (f64, f64);

/// Total force of the pairs at penetration delta, its derivative, and how many carry.
fn total(law: &dyn ContactLaw, pairs: &[Pair], delta: f64) -> (f64, f64, usize) {
    pairs
        .iter()
        .filter(|&&(_, e)| delta + e > 0.0)
        .fold((0.0, 0.0, 0), |(f, k, n), &(s, e)| {
            (
                f + law.force(delta + e, s).unwrap_or(f64::INFINITY),
                k + law.stiffness(delta + e, s).unwrap_or(f64::INFINITY),
                n + 1,
            )
        })
}

/// The delta with total force w on these pairs: bisection on a bracket grown from the law's
/// scale, each step tightened by Newton where it stays inside (the force is increasing and
/// concave-up in delta where pairs carry, so this converges to rounding).
fn solve(law: &dyn ContactLaw, pairs: &[Pair], w: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, law.static_delta(w));
    while total(law, pairs, hi).0 < w {
        (lo, hi) = (hi, 2.0 * hi);
    }
    let mut d = 0.5 * (lo + hi);
    for _ in 0..200 {
        let (f, k, _) = total(law, pairs, d);
        if f > w {
            hi = d;
        } else {
            lo = d;
        }
        let newton = d - (f - w) / k;
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - d).abs() <= 1e-15 * d || hi - lo <= 1e-15 * hi {
            return next;
        }
        d = next;
    }
    d
}

/// The balance at cycle position s0 in [s_a, s_a + p_b): the pairs at s0 + k p_b on the
/// segment are gated while s_A <= s_b and s_A - delta >= s_a (gear-mesh-model.md §3); a pair
/// the solution pushes out of the gate is dropped and the balance solved again.
pub fn balance(law: &dyn ContactLaw, g: &Geometry, s0: f64, w: f64) -> StaticPoint {
    balance_with(law, g, s0, w, &|_| 0.0)
}

/// The same with a shape deviation e(s_A) on every pair (tip relief): each pair carries at
/// delta + e, and `pairs` counts those that do.
pub fn balance_with(
    law: &dyn ContactLaw,
    g: &Geometry,
    s0: f64,
    w: f64,
    deviation: &dyn Fn(f64) -> f64,
) -> StaticPoint {
    let mut pairs: Vec<Pair> = (-2..=2)
        .map(|k| s0 + k as f64 * g.p_b)
        .filter(|&s| s >= g.s_a && s <= g.s_b)
        .map(|s| (s, deviation(s)))
        .collect();
    loop {
        let delta = solve(law, &pairs, w);
        let before = pairs.len();
        if before > 1 {
            pairs.retain(|&(s, _)| s - delta >= g.s_a);
        }
        if pairs.len() == before || pairs.is_empty() {
            let (_, tangent, carrying) = total(law, &pairs, delta);
            return StaticPoint {
                s0,
                delta,
                pairs: carrying,
                secant: w / delta,
                tangent,
            };
        }
    }
}

/// The balance at n positions evenly over one mesh cycle (midpoints), and their means:
/// (points, mean secant, mean tangent) \[N/m\].
pub fn cycle(law: &dyn ContactLaw, g: &Geometry, w: f64, n: usize) -> (Vec<StaticPoint>, f64, f64) {
    let points: Vec<StaticPoint> = (0..n)
        .map(|i| balance(law, g, g.s_a + g.p_b * (i as f64 + 0.5) / n as f64, w))
        .collect();
    let mean = |f: fn(&StaticPoint) -> f64| points.iter().map(f).sum::<f64>() / n as f64;
    let (secant, tangent) = (mean(|p| p.secant), mean(|p| p.tangent));
    (points, secant, tangent)
}

/// The secant stiffness W/delta of one pair at s_A carrying w alone.
pub fn single_pair_stiffness(law: &dyn ContactLaw, s: f64, w: f64) -> f64 {
    w / solve(law, &[(s, 0.0)], w)
}

/// The largest secant stiffness W/delta of a single pair carrying w alone over the
/// single-contact zone [s_b - p_b, s_a + p_b]: sampled, then refined by golden section.
pub fn single_pair_peak(law: &dyn ContactLaw, g: &Geometry, w: f64) -> f64 {
    let (lo, hi) = (g.s_b - g.p_b, g.s_a + g.p_b);
    let k = |s: f64| single_pair_stiffness(law, s, w);
    let n = 200;
    let at = |i: usize| lo + (hi - lo) * i as f64 / n as f64;
    let best = (0..=n)
        .max_by(|&a, &b| k(at(a)).total_cmp(&k(at(b))))
        .expect("samples");
    let (mut a, mut b) = (at(best.saturating_sub(1)), at((best + 1).min(n)));
    const R: f64 = 0.618_033_988_749_894_9;
    while b - a > 1e-9 * (hi - lo) {
        let (x1, x2) = (b - R * (b - a), a + R * (b - a));
        if k(x1) >= k(x2) {
            b = x2;
        } else {
            a = x1;
        }
    }
    k(0.5 * (a + b)).max(k(at(best)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::law::JohnsonLaw;
    use crate::model::pair::Pair;

    /// With Johnson's law (independent of position) two pairs share W equally: the balance
    /// with two pairs is the single-pair balance at W/2, and the single-pair stiffness is the
    /// same everywhere on the segment.
    /// The standard pair with Johnson's law at 300 N/mm.
    fn johnson_pair() -> (Geometry, JohnsonLaw, f64) {
        let p = Pair::standard();
        let g = Geometry::new(&p).unwrap();
        let law = JohnsonLaw::new(g.l, g.kappa, g.e_star, p.width);
        (g, law, 3e5 * p.width)
    }

    #[test]
    fn two_pairs_share_the_load_under_a_position_independent_law() {
        let (g, law, w) = johnson_pair();
        // The middle of the double-contact zone [s_a, s_b - p_b].
        let s0 = g.s_a + 0.5 * (g.s_b - g.p_b - g.s_a);
        let two = balance(&law, &g, s0, w);
        assert_eq!(two.pairs, 2);
        let one = solve(&law, &[(s0, 0.0)], w / 2.0);
        assert!(
            (two.delta - one).abs() <= 1e-14 * one,
            "{} vs {one}",
            two.delta
        );
        let f = law.force(two.delta, s0).unwrap();
        assert!((2.0 * f - w).abs() <= 1e-13 * w);
        let peak = single_pair_peak(&law, &g, w);
        let mid = w / solve(&law, &[(0.5 * (g.s_a + g.s_b), 0.0)], w);
        assert!((peak - mid).abs() <= 1e-12 * mid);
    }

    /// A pair relieved by more than the balance's penetration carries nothing (the balance is
    /// the single pair's); relieved by less, the two pairs' forces at delta + e and delta add
    /// up to W.
    #[test]
    fn a_relieved_pair_carries_less_or_nothing() {
        let (g, law, w) = johnson_pair();
        let s0 = g.s_a + 0.25 * (g.s_b - g.p_b - g.s_a);
        let relieved = |e: f64| move |s: f64| if s < s0 + 0.5 * g.p_b { e } else { 0.0 };
        let alone = solve(&law, &[(s0 + g.p_b, 0.0)], w);
        let deep = balance_with(&law, &g, s0, w, &relieved(-2.0 * alone));
        assert_eq!(deep.pairs, 1);
        assert!((deep.delta - alone).abs() <= 1e-14 * alone);
        let e = -0.3 * alone;
        let shallow = balance_with(&law, &g, s0, w, &relieved(e));
        assert_eq!(shallow.pairs, 2);
        let f = law.force(shallow.delta + e, s0).unwrap() + law.force(shallow.delta, s0).unwrap();
        assert!((f - w).abs() <= 1e-13 * w, "{f} vs {w}");
    }
}
