//! Directional derivatives of Model Exchange (fmi2GetDirectionalDerivative,
//! fmi3GetDirectionalDerivative) by central differences along the seed, generic over the model.
//!
//! Knowns are continuous states (`Slave::n_directional_states`: those a master integrates,
//! and any the model computes beyond them) or real inputs; unknowns are state derivatives or
//! any real variable the model reads at the point (outputs). The modes stay those of the
//! current point, so the right-hand side is smooth along the difference. The step along the seed moves no
//! known by more than eps^(1/3) of its scale (a state's: `Slave::me_difference_scales`, which
//! keeps the step far above the rounding of the model's arithmetic; an input's: |value|, at
//! least 1): central differences then err by about eps^(2/3) ~ 4e-11 of the unknown's
//! variation from truncation and as much from rounding, so 1e-8 of the derivative's scale is
//! a safe statement (tests check it against closed forms). The point is restored exactly.

use crate::instance::{error, Failure};
use crate::{Slave, ValueReference};

/// A known: continuous state k, or a real input at its value.
enum Known {
    State(usize),
    Input(ValueReference, f64),
}

/// An unknown: state k's derivative, or a variable read by value reference.
enum Unknown {
    Derivative(usize),
    Variable(ValueReference),
}

/// `out` = d(unknowns)/d(knowns) . seed at the current point.
pub fn derivative<S: Slave>(
    s: &mut S,
    unknowns: &[ValueReference],
    knowns: &[ValueReference],
    seed: &[f64],
    out: &mut [f64],
) -> Result<(), Failure> {
    let n = s.n_directional_states();
    let mut x0 = vec![0.0; n];
    s.me_states(&mut x0)?;
    let mut scale = vec![1.0; n];
    s.me_difference_scales(&mut scale)?;
    let state_of = |s: &S, vr| (0..n).find(|&k| s.state_vr(k) == Some(vr));
    let mut known = Vec::with_capacity(knowns.len());
    let mut reach: f64 = 0.0;
    for (&vr, &v) in knowns.iter().zip(seed) {
        if !v.is_finite() {
            return Err(error(format!(
                "the seed of value reference {vr} is {v}: must be finite"
            )));
        }
        let k = match state_of(s, vr) {
            Some(k) => {
                reach = reach.max(v.abs() / scale[k]);
                Known::State(k)
            }
            None if s.is_real_input(vr) => {
                let u = s.get_real(vr)?;
                reach = reach.max(v.abs() / u.abs().max(1.0));
                Known::Input(vr, u)
            }
            None => {
                return Err(error(format!(
                    "known value reference {vr} is neither a continuous state nor a real input"
                )))
            }
        };
        known.push(k);
    }
    let unknown: Vec<Unknown> = unknowns
        .iter()
        .map(
            |&vr| match (0..n).find(|&k| s.derivative_vr(k) == Some(vr)) {
                Some(k) => Unknown::Derivative(k),
                None => Unknown::Variable(vr),
            },
        )
        .collect();
    if reach == 0.0 {
        out.fill(0.0);
        return Ok(());
    }
    let h = f64::EPSILON.cbrt() / reach;
    let mut plus = vec![0.0; unknown.len()];
    let result = evaluate(s, &known, &unknown, seed, &x0, h, &mut plus)
        .and_then(|()| evaluate(s, &known, &unknown, seed, &x0, -h, out));
    // Back to the point, whatever happened.
    let restored = restore(s, &known, &x0);
    result?;
    restored?;
    for (o, p) in out.iter_mut().zip(&plus) {
        *o = (p - *o) / (2.0 * h);
    }
    Ok(())
}

/// The unknowns at the point moved by `h` along the seed.
fn evaluate<S: Slave>(
    s: &mut S,
    known: &[Known],
    unknown: &[Unknown],
    seed: &[f64],
    x0: &[f64],
    h: f64,
    out: &mut [f64],
) -> Result<(), Failure> {
    let mut x = x0.to_vec();
    for (k, &v) in known.iter().zip(seed) {
        match *k {
            Known::State(i) => x[i] += h * v,
            Known::Input(vr, u) => s.set_real(&[vr], &[u + h * v], true)?,
        }
    }
    s.me_set_states(&x)?;
    let mut dx = vec![0.0; x0.len()];
    if unknown.iter().any(|u| matches!(u, Unknown::Derivative(_))) {
        s.me_derivatives(&mut dx)?;
    }
    for (o, u) in out.iter_mut().zip(unknown) {
        *o = match *u {
            Unknown::Derivative(k) => dx[k],
            Unknown::Variable(vr) => s.get_real(vr)?,
        };
    }
    Ok(())
}

fn restore<S: Slave>(s: &mut S, known: &[Known], x0: &[f64]) -> Result<(), Failure> {
    for k in known {
        if let Known::Input(vr, u) = *k {
            s.set_real(&[vr], &[u], true)?;
        }
    }
    s.me_set_states(x0)
}
