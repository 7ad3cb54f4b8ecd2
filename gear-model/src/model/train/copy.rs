//! Copies of a train. `clone_from` copies in place and keeps the buffers: `fmi2DoStep` copies
//! the simulation into its backup before every step that integrates (to undo a failed one),
//! and a fresh clone's allocations and moves were a tenth of a short scene's run. The fields
//! are listed by destructuring, so that a new field cannot be left out of either copy.

use super::*;

impl Clone for TrainLoads {
    fn clone(&self) -> Self {
        let TrainLoads { tau, w_in, coef } = self;
        TrainLoads {
            tau: tau.clone(),
            w_in: w_in.clone(),
            coef: coef.clone(),
        }
    }

    fn clone_from(&mut self, src: &Self) {
        let TrainLoads { tau, w_in, coef } = self;
        tau.clone_from(&src.tau);
        w_in.clone_from(&src.w_in);
        coef.clone_from(&src.coef);
    }
}

impl Clone for Train {
    fn clone(&self) -> Self {
        let Train {
            cfg,
            meshes,
            loads,
            e_gate,
            n_events,
            e_start,
            stats,
            static_start,
            modes,
        } = self;
        Train {
            cfg: cfg.clone(),
            meshes: meshes.clone(),
            loads: loads.clone(),
            e_gate: *e_gate,
            n_events: *n_events,
            e_start: *e_start,
            stats: stats.clone(),
            static_start: static_start.clone(),
            modes: modes.clone(),
        }
    }

    fn clone_from(&mut self, src: &Self) {
        let Train {
            cfg,
            meshes,
            loads,
            e_gate,
            n_events,
            e_start,
            stats,
            static_start,
            modes,
        } = self;
        if !Arc::ptr_eq(cfg, &src.cfg) {
            *cfg = src.cfg.clone();
        }
        meshes.clone_from(&src.meshes);
        loads.clone_from(&src.loads);
        (*e_gate, *n_events, *e_start) = (src.e_gate, src.n_events, src.e_start);
        stats.clone_from(&src.stats);
        static_start.clone_from(&src.static_start);
        modes.clone_from(&src.modes);
    }
}
