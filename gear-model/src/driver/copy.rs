//! Copies of a driver: `clone` for an FMU state and a BDF restart point, `clone_from` in place
//! for `fmi2DoStep`'s backup (see `model/train/copy.rs`).

use super::locate::{MarginCache, Scratch};
use super::*;

impl<S: System + Clone + 'static> Clone for Driver<S> {
    /// A Dormand-Prince driver clones exactly. diffsol's solver cannot be cloned, so a BDF driver
    /// clones into a restart point at its current state (see `Simulation::make_restart_point_if_needed`).
    /// Inlined into the caller's slot: a call here added a second copy of the driver.
    #[inline(always)]
    fn clone(&self) -> Self {
        let restart_point = matches!(self.method, Method::Bdf(_)) && !self.needs_restart;
        Driver {
            method: self.method.clone(),
            tol: self.tol.clone(),
            t: self.t,
            needs_restart: self.needs_restart || restart_point,
            pending: if restart_point { None } else { self.pending },
            stats: self.stats,
            cap: self.cap,
            t_stop: self.t_stop,
            y_start: if restart_point {
                self.state()
            } else {
                self.y_start
            },
            step_limit: if restart_point {
                f64::NAN
            } else {
                self.step_limit
            },
            // A copy continues exactly as the original only with the same margins at its start.
            start: if restart_point {
                MarginCache::default()
            } else {
                self.start.clone()
            },
            scratch: Scratch::default(),
            max_step: self.max_step,
            observed: self.observed,
            search_from: self.search_from,
        }
    }

    /// In place, keeping the buffers (`fmi2DoStep`'s backup, `model/train/copy.rs`); a BDF
    /// driver as `clone`.
    fn clone_from(&mut self, src: &Self) {
        if matches!(src.method, Method::Bdf(_)) || matches!(self.method, Method::Bdf(_)) {
            *self = src.clone();
            return;
        }
        let Driver {
            method,
            tol,
            t,
            needs_restart,
            pending,
            stats,
            cap,
            t_stop,
            y_start,
            step_limit,
            start,
            scratch: _,
            max_step,
            observed,
            search_from,
        } = self;
        match (method, &src.method) {
            (Method::Dopri5(a), Method::Dopri5(b)) => a.clone_from(b),
            (m, b) => *m = b.clone(),
        }
        tol.clone_from(&src.tol);
        start.clone_from(&src.start);
        (*t, *needs_restart, *pending, *stats) = (src.t, src.needs_restart, src.pending, src.stats);
        (*cap, *t_stop, *y_start, *step_limit) = (src.cap, src.t_stop, src.y_start, src.step_limit);
        (*max_step, *observed, *search_from) = (src.max_step, src.observed, src.search_from);
    }
}
