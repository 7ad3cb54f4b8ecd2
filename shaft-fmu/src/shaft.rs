//! The shaft's law, free of FMI. Every angle, speed and torque is forward positive at its end.

/// The torque the shaft applies to end b, `k (theta_a - theta_b + twist_start) + d (w_a - w_b)`;
/// end a gets its negative. Evaluated in this order, so that a reference computing the same
/// expression gets the same bits.
#[inline]
pub fn torque_b(
    k: f64,
    d: f64,
    twist_start: f64,
    theta_a: f64,
    w_a: f64,
    theta_b: f64,
    w_b: f64,
) -> f64 {
    k * (theta_a - theta_b + twist_start) + d * (w_a - w_b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spring_and_damper_act_from_a_to_b() {
        // a ahead of b: the spring drives b forward.
        assert_eq!(torque_b(10.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0), 5.0);
        // The pre-twist alone loads the spring.
        assert_eq!(torque_b(10.0, 0.0, -0.25, 0.0, 0.0, 0.0, 0.0), -2.5);
        // a faster than b: the damper drives b forward.
        assert_eq!(torque_b(0.0, 2.0, 0.0, 0.0, 3.0, 0.0, 1.0), 4.0);
    }
}
