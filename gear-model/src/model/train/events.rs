//! The train's event functions: every mesh's in use, packed one mesh after the other for the
//! driver (a mesh without shape deviations brings 16, with them 32), and in the capacity's
//! layout for Model Exchange's indicators.

use super::*;

impl Train {
    /// The event functions in use: every mesh's that can trigger (the driver's margins).
    pub fn n_event_fns(&self) -> usize {
        *self
            .cfg
            .event_start
            .last()
            .expect("one entry per mesh and the total")
    }

    /// Packed event function i: its mesh, and its index among the mesh's functions.
    pub fn event_of(&self, i: usize) -> (usize, usize) {
        let start = &self.cfg.event_start;
        let m = start.partition_point(|&s| s <= i) - 1;
        (m, i - start[m])
    }

    /// The event margins, packed (`event_of`): `out` is `n_event_fns()` long.
    pub fn event_margins(&self, y: &[f64], out: &mut [f64]) {
        by_slots!(self.event_margins_in(y, out))
    }

    fn event_margins_in<const N: usize>(&self, y: &[f64], out: &mut [f64]) {
        let b = self.bodies_in::<N>(y);
        let start = &self.cfg.event_start;
        let turns = self.cfg.lateral.is_some().then(|| self.carrier_turns(&b));
        for (m, mesh) in self.meshes.iter().enumerate() {
            let k = match &turns {
                Some(t) => self.kin_turned(m, y, &b, t).0,
                None => self.kin(m, y, &b),
            };
            mesh.event_margins(&k, &mut out[start[m]..start[m + 1]]);
        }
    }

    pub fn event_margins_and_rates(
        &self,
        y: &[f64],
        dy: &[f64],
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        by_slots!(self.event_margins_and_rates_in(y, dy, margins, rates))
    }

    fn event_margins_and_rates_in<const N: usize>(
        &self,
        y: &[f64],
        dy: &[f64],
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        let b = self.bodies_in::<N>(y);
        let db = self.bodies_in::<N>(dy);
        let start = &self.cfg.event_start;
        let turns = self.cfg.lateral.is_some().then(|| self.carrier_turns(&b));
        for (m, mesh) in self.meshes.iter().enumerate() {
            let r = start[m]..start[m + 1];
            let (k, dk) = match &turns {
                Some(t) => (
                    self.kin_turned(m, y, &b, t).0,
                    self.kin_rate(m, (y, &b), (dy, &db), t),
                ),
                None => (
                    self.kin_of::<N, false>(m, y, &b),
                    self.kin_of::<N, false>(m, dy, &db),
                ),
            };
            mesh.event_margins_and_rates(&k, &dk, &mut margins[r.clone()], &mut rates[r]);
        }
    }

    /// Model Exchange's event indicators (`N_MARGINS`): mesh m's functions from m N_EVENTS
    /// on, as the indicators' names say; functions not in use read +1.
    pub fn event_indicators(&self, y: &[f64], z: &mut [f64]) {
        z.fill(1.0);
        let b = self.bodies(y);
        for (m, mesh) in self.meshes.iter().enumerate() {
            mesh.event_margins(
                &self.kin(m, y, &b),
                &mut z[m * N_EVENTS..(m + 1) * N_EVENTS],
            );
        }
    }

    pub fn margin(&self, i: usize, y: &[f64]) -> f64 {
        by_slots!(self.margin_in(i, y))
    }

    fn margin_in<const N: usize>(&self, i: usize, y: &[f64]) -> f64 {
        let (m, e) = self.event_of(i);
        let b = self.bodies_in::<N>(y);
        self.meshes[m].margin(EventFn::from_index(e), &self.kin(m, y, &b))
    }

    /// Applies packed event i (`event_of`).
    pub fn handle_event(&mut self, i: usize, y: &[f64]) -> Result<EventReport, LawOutOfRange> {
        let (m, e) = self.event_of(i);
        let b = self.bodies(y);
        let k = self.kin(m, y, &b);
        let before = self.meshes[m].contact_energy(&k).map_err(|e| named(m, e))?;
        let mut report = self.meshes[m].handle_event(e, &k);
        if self.meshes[m].describe_events {
            report.what = format!("mesh[{}]: {}", m + 1, report.what);
        }
        self.n_events += 1;
        self.e_gate += self.meshes[m].contact_energy(&k).map_err(|e| named(m, e))? - before;
        self.renew_modes(y);
        Ok(report)
    }
}
