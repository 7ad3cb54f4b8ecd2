//! The integration driver on toy problems with known answers (issue 12, point 3): both explicit
//! methods (Dormand-Prince 5(4) and DOP853, solvers 1 and 3) on a harmonic oscillator, and event
//! location on a bouncing ball with analytic impact times and on a ball whose flight grazes a
//! ceiling. The driver sees them only through `System`,
//! with their own state (two components), events (two) and error types: nothing of the gear.

use spur_gear_mesh::driver::{Driver, EventOutcome, Method, System, Tolerance};

/// The toys' state: position and velocity.
type State = [f64; 2];

/// The toys never fail.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("never")]
struct Never;

/// What a toy reports of an event.
struct Hit {
    what: &'static str,
}

impl EventOutcome for Hit {
    fn smooth(&self) -> bool {
        false
    }
}

const G: f64 = 9.81;

/// x'' = -omega^2 x (state [x, v]), or a ball under gravity (state [h, v]) that bounces on the
/// floor h = 0 with restitution e and, with a ceiling it passes through, reports each crossing
/// (event 1; `above` is the side it is on, so the margin is positive until the next crossing).
#[derive(Clone, Debug, PartialEq)]
enum Toy {
    Oscillator {
        omega: f64,
    },
    Ball {
        e: f64,
        ceiling: Option<f64>,
        above: bool,
    },
}

impl Toy {
    fn value(&self, i: usize, y: &State) -> Option<(f64, f64)> {
        match (self, i) {
            (Toy::Ball { .. }, 0) => Some((y[0], y[1])),
            (
                Toy::Ball {
                    ceiling: Some(c),
                    above,
                    ..
                },
                1,
            ) => Some(if *above {
                (y[0] - c, y[1])
            } else {
                (c - y[0], -y[1])
            }),
            _ => None,
        }
    }
}

impl System for Toy {
    type State = State;
    type Error = Never;
    type Report = Hit;
    fn rhs(&self, y: &State, dy: &mut State) -> Result<(), Never> {
        dy[0] = y[1];
        dy[1] = match self {
            Toy::Oscillator { omega } => -omega * omega * y[0],
            Toy::Ball { .. } => -G,
        };
        Ok(())
    }
    /// Floor and ceiling.
    fn n_events(&self) -> usize {
        2
    }
    fn event_margins(&self, y: &State, out: &mut [f64]) {
        for (i, m) in out.iter_mut().enumerate() {
            *m = self.value(i, y).map_or(1.0, |v| v.0);
        }
    }
    fn event_margins_and_rates(
        &self,
        y: &State,
        _dy: &State,
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        for i in 0..2 {
            (margins[i], rates[i]) = self.value(i, y).unwrap_or((1.0, 0.0));
        }
    }
    fn margin(&self, i: usize, y: &State) -> f64 {
        self.value(i, y).map_or(1.0, |v| v.0)
    }
    fn handle_event(&mut self, i: usize, y: &mut State) -> Result<Hit, Never> {
        let Toy::Ball { e, above, .. } = self else {
            unreachable!()
        };
        let e = *e;
        if i == 1 {
            *above = !*above;
        }
        if i == 0 {
            // On the floor exactly, bouncing back.
            y[0] = 0.0;
            y[1] *= -e;
        }
        Ok(Hit {
            what: if i == 0 { "floor" } else { "ceiling" },
        })
    }
    fn check_state(&self, _y: &State) -> Result<(), Never> {
        Ok(())
    }
    /// As the gear limits a step to a fraction of a tooth pitch: a step far longer than the
    /// flights would locate their ends on an interpolant whose terms are large (a 1000 s step of
    /// free fall spans 5e6 m), losing digits to rounding.
    fn max_step(&self, _y: &State, _stability: Option<spur_gear_mesh::driver::Stability>) -> f64 {
        0.1
    }
    fn dim(&self) -> usize {
        2
    }
}

/// The explicit methods: Dormand-Prince 5(4) and DOP853.
const SOLVERS: [i32; 2] = [1, 3];

fn driver(solver: i32, y0: State, rtol: f64) -> Driver<Toy> {
    let tol = Tolerance {
        rtol,
        atol: [rtol; 2],
    };
    Driver::new(Method::from_solver(solver), tol, 0.0, y0)
}

/// Each method keeps its step's local error below rel_tol times the state (the estimate is
/// that of an embedded lower-order solution, larger than the error of the one it keeps). The oscillator's flow is a rotation in (x, v/omega), so local errors add without
/// growth: after N steps the error is at most N rel_tol times the amplitude.
#[test]
fn harmonic_oscillator_against_cos() {
    let omega = 2.0 * std::f64::consts::PI;
    for (solver, rtol) in SOLVERS.iter().flat_map(|&s| [(s, 1e-6), (s, 1e-10)]) {
        let mut sys = Toy::Oscillator { omega };
        let mut d = driver(solver, [1.0, 0.0], rtol);
        for k in 1..=100 {
            let t = 0.1 * k as f64;
            d.advance(&mut sys, t, &mut |_, _| {}).unwrap();
            let y = d.state();
            let bound = (d.stats.steps as f64 + 1.0) * rtol * 2.0;
            assert!(
                (y[0] - (omega * t).cos()).abs() <= bound,
                "solver {solver}, rtol {rtol}, t {t}: {}",
                y[0]
            );
            assert!(
                (y[1] / omega + (omega * t).sin()).abs() <= bound,
                "t {t}: v {}",
                y[1]
            );
        }
    }
}

/// Dropped from 1 m: the first impact at sqrt(2/g), each rebound flies 2 e v_k / g with v_k the
/// impact speed, v_{k+1} = e v_k. Free flight is a parabola, which both methods and their dense
/// outputs integrate exactly, so every impact is located to rounding at any tolerance: a few ulp of t (1e-15 s),
/// which each bounce amplifies by 1 + 2e (a late impact rebounds faster), so 1e-12 s after six.
#[test]
fn bouncing_ball_impacts_at_the_analytic_times() {
    for (solver, rtol) in SOLVERS.iter().flat_map(|&s| [(s, 1e-3), (s, 1e-8)]) {
        let e = 0.8;
        let mut sys = Toy::Ball {
            e,
            ceiling: None,
            above: false,
        };
        let mut d = driver(solver, [1.0, 0.0], rtol);
        let mut hits = Vec::new();
        d.advance(&mut sys, 3.0, &mut |t, r| hits.push((t, r.what)))
            .unwrap();
        let mut t = (2.0 / G).sqrt();
        let mut v = G * t;
        assert!(hits.len() >= 6, "{hits:?}");
        for (k, (th, what)) in hits.iter().enumerate() {
            assert_eq!(*what, "floor");
            assert!(
                (th - t).abs() <= 1e-12,
                "solver {solver}, rtol {rtol}, impact {k}: {th} vs {t}"
            );
            v *= e;
            t += 2.0 * v / G;
        }
    }
}

/// Thrown up from the floor so that the apex comes 1 nm below a ceiling at 1 m, then 1 nm above
/// it: the first never crosses, the second crosses and comes back inside one free-flight step
/// (0.1 s against 29 us above the ceiling); both crossings are located at the parabola's roots.
#[test]
fn a_ceiling_grazed_by_1_nm_is_located() {
    for (solver, (reach, touches)) in SOLVERS
        .iter()
        .flat_map(|&s| [(s, (-1e-9, false)), (s, (1e-9, true))])
    {
        let apex = 1.0 + reach;
        let v0 = (2.0 * G * apex).sqrt();
        let mut sys = Toy::Ball {
            e: 0.5,
            ceiling: Some(1.0),
            above: false,
        };
        let mut d = driver(solver, [0.0, v0], 1e-6);
        let mut hits = Vec::new();
        d.advance(&mut sys, v0 / G * 1.5, &mut |t, r| hits.push((t, r.what)))
            .unwrap();
        let crossings: Vec<f64> = hits
            .iter()
            .filter(|(_, w)| *w == "ceiling")
            .map(|(t, _)| *t)
            .collect();
        if !touches {
            assert!(
                crossings.is_empty(),
                "solver {solver}, reach {reach}: {hits:?}"
            );
            continue;
        }
        let half = (2.0 * G * reach).sqrt() / G;
        let (up, down) = (v0 / G - half, v0 / G + half);
        assert_eq!(crossings.len(), 2, "solver {solver}: {hits:?}");
        // A graze is ill-conditioned: a rounding of h (a few ulp of 1 m) moves the crossing by
        // that over the crossing speed sqrt(2 g reach) = 1.4e-4 m/s.
        let bound = 8.0 * f64::EPSILON / (2.0 * G * reach).sqrt();
        assert!(
            (crossings[0] - up).abs() <= bound,
            "{} vs {up}",
            crossings[0]
        );
        assert!(
            (crossings[1] - down).abs() <= bound,
            "{} vs {down}",
            crossings[1]
        );
    }
}
