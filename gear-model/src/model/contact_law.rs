//! The interface every compliant contact law implements (`law.rs` holds the laws and their
//! dispatch): a pair's elastic force, stiffness and energy at a penetration, and, for a law
//! whose stiffness depends on where the pair sits on the line of action, that dependence.

use super::johnson::OutOfRange;

pub trait ContactLaw {
    /// Elastic normal force \[N\] of one pair (whole face width) at penetration delta >= 0, its
    /// contact at s_A on the line of action.
    fn force(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange>;
    /// dF/d(delta) \[N/m\] at fixed s_A.
    fn stiffness(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange>;
    /// The same from the pair's elastic force F at delta, without solving the law again.
    fn stiffness_at_force(&self, force: f64, delta: f64, s_a: f64) -> f64;
    /// Elastic energy \[J\]: the integral of the force from 0 to delta at fixed s_A.
    fn energy(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange>;
    /// dU/ds_A at fixed delta \[N\], given the pair's elastic force there: 0 unless the law
    /// depends on the position. The mesh force acts along the line of action only, so this term
    /// is work done on the pair by its changing stiffness (parametric excitation), booked with
    /// the external work.
    fn energy_slope(&self, force: f64, s_a: f64) -> f64;
    /// The force and `energy_slope` together (a position-dependent law looks s_A up once).
    fn force_and_slope(&self, delta: f64, s_a: f64) -> Result<(f64, f64), OutOfRange> {
        let f = self.force(delta, s_a)?;
        Ok((f, self.energy_slope(f, s_a)))
    }
    /// `force_and_slope` of the pairs of one flank, which share delta, into `out`: one call
    /// through `Law`'s dispatch for all of them (a call per pair clobbered the registers between
    /// the pairs and kept their chains apart: 1.33x instead of 1.18x contact model 1's
    /// right-hand side for model 3), and a law may share work between them.
    fn flank_forces_and_slopes(
        &self,
        delta: f64,
        s_a: &[f64],
        out: &mut [(f64, f64)],
    ) -> Result<(), OutOfRange> {
        for (o, &s) in out.iter_mut().zip(s_a) {
            *o = self.force_and_slope(delta, s)?;
        }
        Ok(())
    }
    /// Whether force, stiffness and energy depend on s_A (else one evaluation per flank serves
    /// all its pairs).
    fn depends_on_position(&self) -> bool;
    /// The penetration of one pair under force F at a typical position (a scale for tolerances).
    fn static_delta(&self, force: f64) -> f64;
    /// How the limit of the law's range is named in messages.
    fn limit_name(&self) -> &'static str;
}
