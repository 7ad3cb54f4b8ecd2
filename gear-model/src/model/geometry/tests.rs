//! Geometry checks: the test vectors, the closures, the refusals, the internal pair and the
//! centre distance.
use super::*;

fn geo(p: &Pair) -> Result<Geometry, ModelError> {
    Geometry::new(p)
}

/// The paper's pair changed by `f`.
fn paper(f: impl FnOnce(&mut Pair)) -> Pair {
    let mut p = Pair::paper();
    f(&mut p);
    p
}

/// The paper's pair with its cut changed by `f`.
fn paper_cut(f: impl FnOnce(&mut PaperCut)) -> Pair {
    paper(|p| {
        if let Cut::Paper(c) = &mut p.cut {
            f(c)
        }
    })
}

/// test-vectors.md values are printed with 12-15 significant digits; each quantity here is a
/// few floating-point operations from the inputs, so agreement to 1e-12 relative is expected.
fn close(a: f64, b: f64) {
    assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-300), "{a} vs {b}");
}

#[test]
fn paper_geometry_matches_test_vectors() {
    let g = geo(&Pair::paper()).unwrap();
    close(g.alpha_w, 0.350023621796666);
    close(g.r_ab, 0.187872922544603);
    close(g.r_bb, 0.281809383816904);
    close(g.d, 0.5);
    close(g.l, 0.1714599985155);
    close(g.s_a, 0.0562189895940214);
    close(g.s_b, 0.115241008921478);
    close(g.p_b, 0.053656381206779);
    close(g.eps, 1.1);
    assert_eq!(g.m_c, 2);
    close(g.t_a, 0.172596813864531);
    close(g.t_b, 0.125085637620684);
    close(g.e_star, 115384615384.615);
    let (lo, hi) = g.phi_window();
    close(lo, -0.263375091336776);
    close(hi, 0.307823572952278);
    close(g.r_tip_a, 0.220401282125787);
    close(g.r_tip_b, 0.304461851377974);
    close(g.r_bb * g.d_b, g.p_b);
}

#[test]
fn zero_backlash_thickness() {
    let g = geo(&paper(|p| p.backlash = 0.0)).unwrap();
    close(g.t_a, 0.172862951205255);
    // The vector has 14 significant digits.
    assert!((g.t_b - 0.12526306251450).abs() < 1e-13);
}

#[test]
fn thickness_closure_holds_for_both_front_ends() {
    for cut in [Pair::paper().cut, Pair::standard().cut] {
        let p = paper(|p| (p.cut, p.a.x, p.b.x) = (cut, 0.2, -0.1));
        let g = geo(&p).unwrap();
        let lhs = g.r_ab * g.t_a + g.r_bb * g.t_b;
        let rhs = g.p_b + 2.0 * g.d * g.alpha_w.cos() * inv(g.alpha_w) - p.backlash;
        assert!((lhs - rhs).abs() < 1e-14, "{cut:?}: {lhs} vs {rhs}");
    }
}

#[test]
fn standard_geometry_of_unshifted_gears() {
    let p = standard(20, 40, 0.0, 0.0);
    let g = geo(&p).unwrap();
    close(g.alpha_w, p.rack().unwrap().pressure_angle);
    close(g.d, 0.004 * 60.0 / 2.0);
    // Textbook contact ratio of a 20/40 pair, 20 deg, full-depth teeth: 1.6 to 1.7.
    assert!(g.eps > 1.6 && g.eps < 1.7, "{}", g.eps);
    assert_eq!(g.m_c, 2);
}

/// The paper's pair's materials and width, cut by an ISO 53 rack of module 4 mm.
fn standard(za: i32, zb: i32, xa: f64, xb: f64) -> Pair {
    paper(|p| {
        p.cut = Cut::Standard(Rack::iso53(0.004));
        (p.a.z, p.b.z, p.a.x, p.b.x) = (za, zb, xa, xb);
    })
}

/// A standard pair with its rack's addendum changed.
fn with_addendum(mut p: Pair, addendum: f64) -> Pair {
    if let Cut::Standard(r) = &mut p.cut {
        r.addendum = addendum;
    }
    p
}

/// Issue 9, point 5: teeth that cannot exist are rejected with their numbers, in both
/// front ends, and each case is one that passed every earlier check. A contact below the
/// generated involute: 20 teeth without shift are generated from 1.99 mm above the base
/// circle's tangent point (module 4 mm), and a 1.1-module addendum on the 80-tooth mate
/// brings the contact down to 1.91 mm.
#[test]
fn impossible_teeth_are_rejected() {
    let cases = [
        (
            paper_cut(|c| c.alpha_factor = 3.5),
            "pointed teeth",
            "alpha_factor = 3.5",
        ),
        (
            paper(|p| (p.a.z, p.b.z) = (40, 60)),
            "pointed teeth",
            "zA = 40",
        ),
        (standard(10, 30, 0.8, 0.0), "pointed teeth", "xA = 0.8"),
        (
            paper(|p| p.backlash = 0.06),
            "backlash = 0.06",
            "operating pitch circle",
        ),
        (
            with_addendum(standard(20, 80, 0.0, 0.0), 1.1),
            "active profile below the involute",
            "addendum = 1.1",
        ),
    ];
    for (p, what, names) in cases {
        let e = geo(&p).unwrap_err().message;
        assert!(e.contains(what) && e.contains(names), "{what}: {e}");
    }
}

/// A tip thinner than 0.2 module is accepted with a warning naming its thickness; standard
/// unshifted pairs from 18 teeth on and the paper rig have none.
#[test]
fn thin_tips_are_a_warning() {
    let g = geo(&standard(12, 40, 0.8, 0.0)).unwrap();
    assert!(
        g.warnings.iter().any(|w| w.contains("wheel A's tooth tip")),
        "{:?}",
        g.warnings
    );
    for p in [
        Pair::paper(),
        standard(18, 40, 0.0, 0.0),
        standard(30, 30, 0.0, 0.0),
    ] {
        let g = geo(&p).unwrap();
        assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    }
}

fn internal(za: i32, zb: i32, xa: f64, xb: f64, module: f64) -> Pair {
    let mut p = standard(za, zb, xa, xb);
    (p.internal, p.cut) = (true, Cut::Standard(Rack::iso53(module)));
    p
}

/// The ring front end's geometry before any check (as `at_distance` fills it in).
fn unchecked(p: &Pair) -> Geometry {
    let mut g = Geometry::standard(p, p.rack().unwrap(), 1.0).unwrap();
    g.z_a = p.a.z as f64;
    g.z_b = p.b.z as f64;
    g.d_a = 2.0 * PI / g.z_a;
    g.d_b = 2.0 * PI / g.z_b;
    g.internal = true;
    g.kappa = -1.0;
    g.j_n = p.backlash;
    g.eps = (g.s_b - g.s_a) / g.p_b;
    g
}

/// planetary.md §1: standard 20/60 at 20 deg, m = 2 mm, no shift: s_a = -0.075 mm (the
/// spec's two digits: +-0.0005 mm), refused; a positive xB cures it. xB = 0.3 lifts s_a to
/// 0.70 mm, still below where the rack-generated involute of the pinion begins (0.99 mm
/// from its tangent point); xB = 0.5 clears both.
#[test]
fn an_unshifted_20_60_ring_interferes_at_the_pinion_root() {
    let p = internal(20, 60, 0.0, 0.0, 0.002);
    let g = unchecked(&p);
    assert!((g.s_a + 0.075e-3).abs() < 0.0005e-3, "{}", g.s_a);
    let e = geo(&p).unwrap_err().message;
    assert!(
        e.contains("interference at the pinion's root") && e.contains("s_a"),
        "{e}"
    );
    let g = geo(&internal(20, 60, 0.0, 0.5, 0.002)).unwrap();
    assert!(g.s_a > 0.0 && g.eps > 1.0 && g.eps < 2.0, "{g:?}");
}

/// The ring's closure (planetary.md §1): rBb eB - rAb tA = 2 d cos(alpha_w) inv(alpha_w) + j_n
/// with eB = 2 pi/zB - tB, and rBb - rAb = d cos(alpha_w); a few roundings of numbers of
/// order 1e-2, hence 1e-15 absolute.
#[test]
fn ring_geometry_closes() {
    for (za, zb, xa, xb) in [(20, 60, 0.0, 0.5), (18, 72, 0.0, 0.6), (31, 89, 0.1, 0.6)] {
        let p = internal(za, zb, xa, xb, 0.003);
        let g = geo(&p).unwrap();
        let e_b = 2.0 * PI / g.z_b - g.t_b;
        let lhs = g.r_bb * e_b - g.r_ab * g.t_a;
        let rhs = 2.0 * g.d * g.alpha_w.cos() * inv(g.alpha_w) + p.backlash;
        assert!((lhs - rhs).abs() < 1e-15, "{za}/{zb}: {lhs} vs {rhs}");
        assert!((g.r_bb - g.r_ab - g.d * g.alpha_w.cos()).abs() < 1e-15);
        assert!((g.l - g.d * g.alpha_w.sin()).abs() < 1e-15);
        assert_eq!((g.kappa, g.j_n), (-1.0, p.backlash));
    }
}

/// planetary.md §1: 36/38 with xB = 0.3 at m = 2.5 mm passes every other rule and
/// interferes "by about half a millimetre" (read as 0.3 to 0.7 mm).
#[test]
fn a_36_38_ring_has_tip_interference() {
    let p = internal(36, 38, 0.0, 0.3, 0.0025);
    let mut g = unchecked(&p);
    assert!(g.s_a >= 0.0 && g.eps >= 1.0 && g.eps <= 2.0, "{g:?}");
    assert!(g.check_teeth(&p).is_ok());
    let c = crate::model::interference::smallest_clearance(&g);
    assert!(c.clearance < -0.3e-3 && c.clearance > -0.7e-3, "{c:?}");
    let e = geo(&p).unwrap_err().message;
    assert!(
        e.contains("tip or trochoid interference") && e.contains("zB = 38"),
        "{e}"
    );
}

/// planetary.md §1: at zero shifts the other rules already refuse every pair the tip
/// corners would (zB - zA below about 9 at 20 deg); the check finds no interference on the
/// pairs they accept, whose corners touch the ring only at the segment's end.
#[test]
fn at_zero_shift_the_other_rules_refuse_what_the_tip_corners_would() {
    let mut interfering = 0;
    for za in [12, 17, 20, 25, 30, 40] {
        for diff in 1..=30 {
            let p = internal(za, za + diff, 0.0, 0.0, 0.002);
            if Geometry::standard(&p, p.rack().unwrap(), 1.0).is_err() {
                continue; // the ring's tips inside its base circle: refused by a rule
            }
            let mut g = unchecked(&p);
            let others = !(g.r_tip_b > g.r_bb)
                || g.s_a < 0.0
                || g.eps < 1.0
                || g.eps > 2.0
                || g.check_teeth(&p).is_err();
            let c = crate::model::interference::smallest_clearance(&g);
            if c.clearance < -1e-10 * g.r_tip_b {
                interfering += 1;
                assert!(others, "{za}/{}: {c:?} and no other rule", za + diff);
            }
            if diff < 8 {
                assert!(others, "{za}/{} passes the rules", za + diff);
            }
        }
    }
    assert!(interfering > 0, "some small differences interfere");
}

/// planetary.md §2: moving the axes apart by e opens an external pair's backlash by
/// 2 e sin(alpha_w) and closes an internal pair's by as much, to first order; the central
/// difference of +-e cancels the second-order term, leaving O((e/d)^2) ~ 1e-7 relative.
#[test]
fn moving_the_axes_apart_opens_external_and_closes_internal_backlash() {
    let e = 40e-6;
    for p in [
        standard(20, 40, 0.0, 0.0),
        internal(20, 60, 0.0, 0.5, 0.004),
    ] {
        let g0 = geo(&p).unwrap();
        let at = |err: f64| {
            geo(&Pair {
                center_distance_error: err,
                ..p.clone()
            })
            .unwrap()
        };
        let (gp, gm) = (at(e), at(-e));
        assert_eq!((gp.d - g0.d - e).abs() < 1e-15, true);
        let slope = (gp.j_n - gm.j_n) / (2.0 * e);
        let expected = 2.0 * g0.kappa * g0.alpha_w.sin();
        assert!(
            (slope / expected - 1.0).abs() < 1e-5,
            "{slope} vs {expected}"
        );
        // The gears stay: base radii, tip radii, thicknesses.
        for g in [&gp, &gm] {
            assert_eq!(
                (g.r_ab, g.r_bb, g.r_tip_a, g.r_tip_b, g.t_a, g.t_b, g.s_b),
                (g0.r_ab, g0.r_bb, g0.r_tip_a, g0.r_tip_b, g0.t_a, g0.t_b, g0.s_b)
            );
            let base = g.r_bb + g.kappa * g.r_ab;
            assert!((g.d * g.alpha_w.cos() - base).abs() < 1e-15);
        }
    }
}

/// With no error, the operating geometry is the front end's, bit for bit, and the
/// backlash is the parameter.
#[test]
fn no_error_keeps_the_nominal_geometry() {
    for p in [Pair::paper(), standard(20, 40, 0.2, -0.1)] {
        let g = geo(&p).unwrap();
        assert_eq!((g.d, g.j_n, g.kappa), (g.d_nominal, p.backlash, 1.0));
        let g2 = Geometry::at_distance(&p, Some(g.d)).unwrap();
        assert_eq!(g, g2);
    }
}

/// A centre distance error that jams the teeth or drops the contact ratio below 1 is
/// refused with the numbers; the closure holds at the actual distance.
#[test]
fn a_bad_centre_distance_is_refused() {
    let p = standard(20, 40, 0.0, 0.0);
    let g = geo(&p).unwrap();
    let jam = -1.5 * p.backlash / (2.0 * g.alpha_w.sin());
    let e = geo(&Pair {
        center_distance_error: jam,
        ..p.clone()
    })
    .unwrap_err()
    .message;
    assert!(
        e.contains("center_distance_error") && e.contains("jams"),
        "{e}"
    );
    let e = geo(&Pair {
        center_distance_error: 0.003,
        ..p.clone()
    })
    .unwrap_err()
    .message;
    assert!(
        e.contains("contact ratio") && e.contains("actual centre distance"),
        "{e}"
    );
    let ring = internal(20, 60, 0.0, 0.5, 0.004);
    let gr = geo(&ring).unwrap();
    let e = geo(&Pair {
        center_distance_error: 1.5 * ring.backlash / (2.0 * gr.alpha_w.sin()),
        ..ring
    })
    .unwrap_err()
    .message;
    assert!(e.contains("jams"), "{e}");
    let g = geo(&Pair {
        center_distance_error: 50e-6,
        ..p.clone()
    })
    .unwrap();
    let lhs = g.r_ab * g.t_a + g.r_bb * g.t_b;
    let rhs = g.p_b + 2.0 * g.d * g.alpha_w.cos() * inv(g.alpha_w) - g.j_n;
    assert!((lhs - rhs).abs() < 1e-15, "{lhs} vs {rhs}");
}

/// The model keeps its own bound on the contact objects (two per flank), whoever built the
/// pair; SpurGearMesh's table refuses 3 before.
#[test]
fn more_than_two_contacts_per_flank_are_refused() {
    let e = geo(&paper(|p| p.contacts_per_flank = 3))
        .unwrap_err()
        .message;
    assert!(e.contains("contacts_per_flank = 3"), "{e}");
}

#[test]
fn internal_needs_standard_geometry() {
    let e = geo(&paper(|p| p.internal = true)).unwrap_err().message;
    assert!(
        e.contains("internal = true") && e.contains("geometry = 2"),
        "{e}"
    );
    let e = geo(&internal(20, 20, 0.0, 0.3, 0.002)).unwrap_err().message;
    assert!(e.contains("more teeth"), "{e}");
}
