//! The diffsol wrapper's pitfalls (Err handling, stop times, dense output) and the event loop on
//! the real model. `cargo test --release -j1 --manifest-path benches/diffsol-peer/Cargo.toml`
use std::cell::Cell;
use std::rc::Rc;

use diffsol_peer::diffsol_method::{DiffsolKind, DiffsolMethod};
use diffsol_peer::method::{Method, Rhs};
use diffsol_peer::peer::{self, PeerOptions, Scene};
use spur_gear_mesh::variables::{Inputs, Params};

const KINDS: [DiffsolKind; 4] = [
    DiffsolKind::Tsit45,
    DiffsolKind::TrBdf2,
    DiffsolKind::Esdirk34,
    DiffsolKind::Bdf,
];

/// y' = -10 (y - 0.5): decays onto 0.5 from above; y < 0.5 is "outside the model's range".
/// Late in the run explicit methods sit on their stability limit, where overshoots below 0.5
/// happen and must be rejected (diffsol alone would accept a NaN stage: its error norm is
/// combined with f64::max, which drops NaN).
struct Floor {
    errs: Cell<u64>,
}
impl Rhs for Floor {
    fn dim(&self) -> usize {
        1
    }
    fn eval(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), ()> {
        if y[0] < 0.5 {
            self.errs.set(self.errs.get() + 1);
            return Err(());
        }
        dy[0] = -10.0 * (y[0] - 0.5);
        Ok(())
    }
}

#[test]
fn err_is_rejected_never_accepted() {
    for kind in KINDS {
        let model = Rc::new(Floor { errs: Cell::new(0) });
        let mut m = DiffsolMethod::new(kind, model.clone(), 1e-6, vec![1e-9]);
        m.restart(&*model, 0.0, &[1.0]);
        let mut buf = [0.0];
        while m.t() < 10.0 {
            let t = m
                .step(&*model, 10.0)
                .unwrap_or_else(|e| panic!("{kind:?}: {e}"));
            assert!(m.y()[0] >= 0.5, "{kind:?} accepted y={} at t={t}", m.y()[0]);
            m.interpolate(0.5 * (m.t_prev() + t), &mut buf);
            assert!(buf[0].is_finite());
        }
        assert!((m.y()[0] - 0.5).abs() < 1e-6);
    }
}

/// y' = -1 reaches the edge of the range at t = 1; going past it must fail, not accept y < 0.
struct Wall;
impl Rhs for Wall {
    fn dim(&self) -> usize {
        1
    }
    fn eval(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), ()> {
        if y[0] < 0.0 {
            return Err(());
        }
        dy[0] = -1.0;
        Ok(())
    }
}

#[test]
fn err_wall_fails_cleanly() {
    for kind in KINDS {
        let model = Rc::new(Wall);
        let mut m = DiffsolMethod::new(kind, model.clone(), 1e-6, vec![1e-9]);
        m.restart(&*model, 0.0, &[1.0]);
        loop {
            match m.step(&*model, 2.0) {
                Ok(_) => assert!(m.y()[0] >= 0.0, "{kind:?} accepted y={}", m.y()[0]),
                Err(_) => break,
            }
        }
        assert!(m.t() <= 1.0 + 1e-9 && m.y()[0] >= 0.0);
    }
}

/// x'' = -x: stop times are met exactly and the dense output is accurate.
struct Osc;
impl Rhs for Osc {
    fn dim(&self) -> usize {
        2
    }
    fn eval(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), ()> {
        dy[0] = y[1];
        dy[1] = -y[0];
        Ok(())
    }
}

#[test]
fn dense_output_and_stop_times() {
    for kind in KINDS {
        let model = Rc::new(Osc);
        let mut m = DiffsolMethod::new(kind, model.clone(), 1e-10, vec![1e-12, 1e-12]);
        m.restart(&*model, 0.0, &[0.0, 1.0]);
        // t_limit == t is an error, t_limit a hair after t counts as reached
        assert!(m.step(&*model, 0.0).is_err());
        assert_eq!(m.step(&*model, 1e-19).unwrap(), 1e-19);
        let (mut worst, mut buf, grid) = (0.0f64, [0.0; 2], 0.37);
        let mut next = grid;
        while m.t() < 5.0 {
            let t = m.step(&*model, f64::min(next, 5.0)).unwrap();
            assert!(t <= f64::min(next, 5.0), "{kind:?} passed t_limit");
            if t == f64::min(next, 5.0) {
                next += grid;
            }
            for j in 0..=8 {
                let tt = m.t_prev() + (t - m.t_prev()) * j as f64 / 8.0;
                m.interpolate(tt, &mut buf);
                worst = worst.max((buf[0] - tt.sin()).abs());
            }
        }
        assert_eq!(m.t(), 5.0);
        assert!(worst < 1e-6, "{kind:?}: {worst}");
    }
}

/// On the damped paper rig (20 ms) every diffsol method finds the same events as our DP5 and
/// agrees with it on dte at every communication point.
#[test]
fn event_loop_matches_our_driver() {
    let sc = Scene {
        name: "damped".into(),
        params: Params {
            c_load: 2.0,
            chi: 10.0,
            w_A_start: 100.0,
            w_B_start: 100.0 / 1.5,
            ..Params::default()
        },
        inputs: Inputs {
            tau_A: 100.0,
            tau_B: 0.0,
            ..Inputs::default()
        },
        t_end: 0.02,
        dt: 1e-4,
    };
    let reference = peer::run_ours(&sc, 1, 1e-10).unwrap();
    let scale = reference.dte.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(reference.events > 10);
    for kind in KINDS {
        let r = peer::run_diffsol(&sc, kind, 1e-8, PeerOptions::default()).unwrap();
        assert_eq!(r.events, reference.events, "{kind:?}");
        assert_eq!(r.dte.len(), reference.dte.len());
        let err = r
            .dte
            .iter()
            .zip(&reference.dte)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            / scale;
        assert!(err < 1e-3, "{kind:?}: dte error {err:e}");
    }
}
