//! The engine's law, free of FMI.

/// `tau_mean + tau_ripple sin(order theta + phase)`: the mean torque with its firing-order
/// ripple at crank angle `theta`. SpurGearTrain's `body[i].tau` with `body[i].tau_ripple`,
/// `ripple_order` and `ripple_phase` is the same law, evaluated in the same order.
#[inline]
pub fn torque(tau_mean: f64, tau_ripple: f64, order: f64, phase: f64, theta: f64) -> f64 {
    tau_mean + tau_ripple * (order * theta + phase).sin()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn the_ripple_repeats_order_times_per_revolution() {
        // Order 2: peaks a quarter of a period (pi/4) after each pulse's start, twice a turn.
        assert_eq!(torque(50.0, 20.0, 2.0, 0.0, 0.0), 50.0);
        assert!((torque(50.0, 20.0, 2.0, 0.0, PI / 4.0) - 70.0).abs() < 1e-12);
        assert!((torque(50.0, 20.0, 2.0, 0.0, PI + PI / 4.0) - 70.0).abs() < 1e-12);
        assert!((torque(50.0, 20.0, 2.0, 0.0, 3.0 * PI / 4.0) - 30.0).abs() < 1e-12);
        // The phase shifts the pulses; no ripple gives the mean.
        assert!((torque(50.0, 20.0, 2.0, PI / 2.0, 0.0) - 70.0).abs() < 1e-12);
        assert_eq!(torque(50.0, 0.0, 2.0, 0.0, 1.234), 50.0);
    }
}
