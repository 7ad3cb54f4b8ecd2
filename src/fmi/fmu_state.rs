//! The payload of SpurGearMesh's serialized FMU states. The envelope around it is
//! fmi2_slave's (`fmi2_slave::fmu_state`; all integers little-endian): `"SGMSTATE"`, format
//! version (u32), GUID length (u32) and bytes, payload length (u64), payload, FNV-1a 64
//! checksum of the payload (u64); the payload starts with the FMI state (u64). What follows
//! here lists every value that determines how the instance continues, field by field; the
//! geometry is recomputed from the parameters, which gives the same bits. A state from another
//! format version or another build of the model (GUID), or a truncated or corrupted one, is
//! rejected with a reason.

use super::instance::Snapshot;
use crate::driver::bdf::Bdf;
use crate::driver::dopri5::Dopri5;
use crate::driver::simulation::Simulation;
use crate::driver::{MarginCache, Method, PendingEvent, Stats, WorkCap};
use crate::model::contact::N_EVENTS;
use crate::model::mesh::Ramp;
use crate::model::{Loads, NY};
use crate::variables::{Causality, Inputs, Params, VarType, VARIABLES};
use fmi2_slave::fmu_state::{Reader, Writer};

/// The version of the payload below (the envelope's format version).
pub const FORMAT_VERSION: u32 = 5;

/// Parameters or inputs, in the table's order.
fn write_vars(w: &mut Writer, causality: Causality, p: &Params, i: &Inputs) {
    for info in VARIABLES.iter().filter(|v| v.causality == causality) {
        let v = info.var;
        match info.ty {
            VarType::Real => w.f(p.get_real(v).or(i.get_real(v)).expect("typed")),
            VarType::Integer => {
                w.u(p.get_integer(v).or(i.get_integer(v)).expect("typed") as i64 as u64)
            }
            VarType::Boolean => w.b(p.get_boolean(v).or(i.get_boolean(v)).expect("typed")),
            VarType::String => w.s(p.get_string(v).expect("typed")),
        }
    }
}

fn read_vars(
    r: &mut Reader,
    causality: Causality,
    p: &mut Params,
    i: &mut Inputs,
) -> Result<(), String> {
    for info in VARIABLES.iter().filter(|v| v.causality == causality) {
        let v = info.var;
        match info.ty {
            VarType::Real => {
                let x = r.f()?;
                let _ = p.set_real(v, x) || i.set_real(v, x);
            }
            VarType::Integer => {
                let x = i32::try_from(r.u()? as i64)
                    .map_err(|_| format!("{} out of range", info.name))?;
                p.set_integer(v, x);
            }
            VarType::Boolean => {
                let x = r.b()?;
                p.set_boolean(v, x);
            }
            VarType::String => {
                let x = r.s()?;
                p.set_string(v, x);
            }
        }
    }
    Ok(())
}

fn write_ramp(w: &mut Writer, r: Ramp) {
    w.fs(&r.t0);
    w.fs(&r.rate);
    w.fs(&r.curvature);
}

fn read_ramp(r: &mut Reader) -> Result<Ramp, String> {
    let ramp = Ramp {
        t0: r.fs()?,
        rate: r.fs()?,
        curvature: r.fs()?,
    };
    if ramp
        .t0
        .iter()
        .chain(&ramp.rate)
        .chain(&ramp.curvature)
        .any(|x| !x.is_finite())
    {
        return Err(format!(
            "input interpolation in the state is not finite ({ramp:?})"
        ));
    }
    Ok(ramp)
}

fn write_sim(w: &mut Writer, s: &Simulation) {
    let m = &s.mesh;
    let l = &m.loads;
    w.fs(&[
        l.tau_a,
        l.tau_b,
        l.c_load,
        l.chi,
        l.mu,
        l.v_reg,
        l.alpha_housing,
        l.a_housing_x,
    ]);
    w.fs(&m.sigma);
    write_ramp(w, m.ramp.unwrap_or_default());
    m.sign.iter().for_each(|&b| w.b(b));
    w.f(m.e_gate);
    w.u(m.n_events);
    w.u(m.n_impacts);
    w.f(m.e_start);
    // The statistics (their presence follows from the parameters).
    if let Some(st) = &m.stats {
        w.fs(&st.accumulators());
    }
    let d = &s.driver;
    w.f(d.tol.rtol);
    w.fs(&d.tol.atol);
    w.f(d.t);
    w.b(d.needs_restart);
    w.b(d.pending.is_some());
    w.f(d.pending.map_or(0.0, |p| p.t));
    w.u(d.pending.map_or(0, |p| p.index as u64));
    let st = &d.stats;
    for x in [
        st.steps,
        st.rejected,
        st.rhs_evals,
        st.jac_evals,
        st.factorizations,
        st.events,
        d.cap.steps,
        d.cap.events,
    ] {
        w.u(x);
    }
    w.f(d.t_stop);
    w.fs(&d.y_start);
    w.f(d.step_limit);
    w.f(d.observed);
    w.f(d.search_from);
    // The event margins at the step's start: a recomputation would round differently.
    let start = d.start.get();
    w.b(start.is_some());
    let (t, m, r) = start.unwrap_or((0.0, [0.0; N_EVENTS], [0.0; N_EVENTS]));
    w.f(t);
    w.fs(&m);
    w.fs(&r);
    match &d.method {
        Method::Dopri5(m) => {
            w.u(1);
            w.fs(&[m.t, m.t_prev, m.h]);
            w.fs(&m.y);
            w.fs(&m.k1);
            m.rcont.iter().for_each(|r| w.fs(r));
            w.f(m.facold);
        }
        // diffsol's BDF is saved as a restart point (the driver then has needs_restart set).
        Method::Bdf(m) => {
            w.u(2);
            w.fs(&[m.t, m.t_prev, m.h]);
            w.fs(&m.y);
            w.fs(&m.y_prev);
        }
    }
}

/// The checksum only proves the bytes arrived intact; a state edited with a recomputed checksum
/// must not bring NaN, infinity or an invalid tolerance into the instance.
fn check_values(s: &Simulation) -> Result<(), String> {
    let d = &s.driver;
    let m = &s.mesh;
    let (t, t_prev, h, y) = match &d.method {
        Method::Dopri5(x) => (x.t, x.t_prev, x.h, x.y),
        Method::Bdf(x) => (x.t, x.t_prev, x.h, x.y),
    };
    let mut values = vec![
        d.t,
        d.observed,
        d.search_from,
        t,
        t_prev,
        m.e_gate,
        m.e_start,
    ];
    if let Some(st) = &m.stats {
        // dte_min and dte_max are infinite until the statistics start.
        values.extend_from_slice(&[st.duration, st.int_dte, st.int_dte2, st.f_max]);
        values.extend_from_slice(&[st.t_separated, st.t_backward]);
    }
    values.extend_from_slice(&y);
    values.extend_from_slice(&d.y_start);
    values.extend_from_slice(&m.sigma);
    values.extend_from_slice(&[
        m.loads.tau_a,
        m.loads.tau_b,
        m.loads.c_load,
        m.loads.chi,
        m.loads.mu,
        m.loads.v_reg,
        m.loads.alpha_housing,
        m.loads.a_housing_x,
    ]);
    if let Method::Dopri5(x) = &d.method {
        values.extend_from_slice(&x.k1);
        x.rcont.iter().for_each(|r| values.extend_from_slice(r));
    }
    if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
        return Err(format!(
            "a value of the simulation state is not finite ({bad})"
        ));
    }
    // The controlled components are the mesh's: a positive, finite tolerance there, 0 elsewhere.
    let controlled = crate::driver::simulation::tolerance(m, d.tol.rtol).atol;
    let tol_ok = d.tol.rtol >= 1e-14
        && d.tol.rtol <= 0.1
        && (d.tol.atol.iter().zip(&controlled))
            .all(|(a, c)| a.is_finite() && (*a > 0.0) == (*c > 0.0) && *a >= 0.0);
    if !tol_ok || !(h >= 0.0) || !(d.t_stop >= d.t) {
        return Err(format!(
            "invalid integrator settings (rel_tol {}, step {h}, stop time {})",
            d.tol.rtol, d.t_stop
        ));
    }
    Ok(())
}

fn read_sim(r: &mut Reader, p: &Params, i: &Inputs, start: f64) -> Result<Simulation, String> {
    let mut s = Simulation::new(p, i, start, p.rel_tol)
        .map_err(|e| format!("parameters in the state: {e}"))?;
    let l: [f64; 8] = r.fs()?;
    let m = &mut s.mesh;
    m.loads = Loads {
        tau_a: l[0],
        tau_b: l[1],
        c_load: l[2],
        chi: l[3],
        mu: l[4],
        v_reg: l[5],
        alpha_housing: l[6],
        a_housing_x: l[7],
    };
    m.set_sigma(r.fs()?);
    m.ramp = Some(read_ramp(r)?).filter(Ramp::is_active);
    for b in m.sign.iter_mut() {
        *b = r.b()?;
    }
    m.e_gate = r.f()?;
    m.n_events = r.u()?;
    m.n_impacts = r.u()?;
    m.e_start = r.f()?;
    if let Some(st) = m.stats.as_mut() {
        st.set_accumulators(r.fs()?);
    }
    let d = &mut s.driver;
    d.tol.rtol = r.f()?;
    d.tol.atol = r.fs::<NY>()?;
    d.t = r.f()?;
    d.needs_restart = r.b()?;
    let (has_pending, pt, pi) = (r.b()?, r.f()?, r.u()? as usize);
    if pi >= N_EVENTS {
        return Err(format!("event index {pi} out of range"));
    }
    d.pending = has_pending.then_some(PendingEvent { t: pt, index: pi });
    let mut counts = [0u64; 8];
    for c in counts.iter_mut() {
        *c = r.u()?;
    }
    let [steps, rejected, rhs_evals, jac_evals, factorizations, events, cap_steps, cap_events] =
        counts;
    d.stats = Stats {
        steps,
        rejected,
        rhs_evals,
        jac_evals,
        factorizations,
        events,
    };
    d.cap = WorkCap {
        steps: cap_steps,
        events: cap_events,
    };
    d.t_stop = r.f()?;
    d.y_start = r.fs::<NY>()?;
    d.step_limit = r.f()?;
    d.observed = r.f()?;
    d.search_from = r.f()?;
    let (has_start, t, m, rates) = (r.b()?, r.f()?, r.fs()?, r.fs()?);
    d.start = MarginCache::new(has_start.then_some((t, m, rates)));
    d.method = match r.u()? {
        1 => {
            let mut m = Dopri5::new();
            [m.t, m.t_prev, m.h] = r.fs()?;
            m.y = r.fs()?;
            m.k1 = r.fs()?;
            for row in m.rcont.iter_mut() {
                *row = r.fs::<NY>()?;
            }
            m.facold = r.f()?;
            Method::Dopri5(m)
        }
        2 => {
            let [t, t_prev, h] = r.fs()?;
            let mut m = Bdf::at(t, r.fs()?, h);
            m.t_prev = t_prev;
            m.y_prev = r.fs()?;
            if !d.needs_restart {
                return Err("a BDF state must be a restart point".into());
            }
            Method::Bdf(m)
        }
        tag => return Err(format!("unknown integration method tag {tag}")),
    };
    check_values(&s)?;
    Ok(s)
}

pub fn write(w: &mut Writer, s: &Snapshot) {
    write_vars(w, Causality::Parameter, &s.params, &s.inputs);
    write_vars(w, Causality::Input, &s.params, &s.inputs);
    w.f(s.start_time);
    w.opt(s.stop_time);
    w.opt(s.tolerance);
    write_ramp(w, s.ramp);
    w.b(s.sim.is_some());
    if let Some(sim) = &s.sim {
        write_sim(w, sim);
    }
}

pub fn read(r: &mut Reader) -> Result<Snapshot, String> {
    let (mut params, mut inputs) = (Params::default(), Inputs::default());
    read_vars(r, Causality::Parameter, &mut params, &mut inputs)?;
    read_vars(r, Causality::Input, &mut params, &mut inputs)?;
    let start_time = r.f()?;
    let stop_time = r.opt()?;
    let tolerance = r.opt()?;
    let ramp = read_ramp(r)?;
    if !start_time.is_finite() || stop_time.is_some_and(|t| !(t >= start_time && t.is_finite())) {
        return Err(format!(
            "invalid experiment times (start {start_time}, stop {stop_time:?})"
        ));
    }
    if tolerance.is_some_and(|t| !(1e-14..=0.1).contains(&t)) {
        return Err(format!("invalid experiment tolerance {tolerance:?}"));
    }
    crate::model::geometry::validate(&params)
        .map_err(|e| format!("parameters in the state: {e}"))?;
    for info in VARIABLES.iter().filter(|v| v.causality == Causality::Input) {
        if let Some(bad) = inputs.get_real(info.var).filter(|x| !x.is_finite()) {
            return Err(format!(
                "input {} in the state is not finite ({bad})",
                info.name
            ));
        }
    }
    let sim = if r.b()? {
        Some(read_sim(r, &params, &inputs, start_time)?)
    } else {
        None
    };
    Ok(Snapshot {
        params,
        inputs,
        start_time,
        stop_time,
        tolerance,
        ramp,
        sim,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fmi::instance::{FmiState, SpurGearMesh};
    use fmi2_slave::instance::Saved;

    /// A state in the envelope, as fmi2SerializeFMUstate writes it.
    fn encode(state: FmiState, s: &Snapshot) -> Vec<u8> {
        fmi2_slave::fmu_state::encode(&Saved {
            state,
            slave: SpurGearMesh::from(s.clone()),
        })
    }

    fn decode(bytes: &[u8]) -> Result<(FmiState, Snapshot), String> {
        let saved = fmi2_slave::fmu_state::decode::<SpurGearMesh>(bytes)?;
        Ok((saved.state, saved.slave.snap))
    }

    fn running(solver: i32) -> Snapshot {
        let mut s = Snapshot::fresh();
        s.params = Params {
            solver,
            w_A_start: 100.0,
            w_B_start: 66.0,
            chi: 2.0,
            mu: 0.1,
            ..Params::default()
        };
        s.inputs = Inputs {
            tau_A: 100.0,
            tau_B: -3.0,
            ..Inputs::default()
        };
        let mut sim = Simulation::new(&s.params, &s.inputs, 0.0, 1e-6).unwrap();
        sim.advance(3.3e-3, &mut |_, _| {}).unwrap();
        // What fmi2GetFMUstate does before it saves (a restart point for BDF).
        sim.make_restart_point_if_needed();
        s.sim = Some(sim);
        s
    }

    #[test]
    fn round_trip_is_exact_for_both_methods() {
        for solver in [1, 2] {
            let s = running(solver);
            let done = FmiState::StepComplete;
            assert_eq!(decode(&encode(done, &s)).unwrap(), (done, s));
        }
        let fresh = Snapshot::fresh();
        let inst = FmiState::Instantiated;
        assert_eq!(decode(&encode(inst, &fresh)).unwrap(), (inst, fresh));
    }

    /// With interpolated inputs the state carries the ramp (the snapshot's and the mesh's) and
    /// the integrated time.
    #[test]
    fn round_trip_keeps_the_input_interpolation() {
        let mut s = running(1);
        s.ramp = Ramp {
            t0: [3.3e-3, 0.0, 0.0, 0.0],
            rate: [250.0, 0.0, 0.0, 0.0],
            curvature: [0.0, -40.0, 0.0, 0.0],
        };
        let loads = Loads::new(&s.params, &s.inputs);
        let sim = s.sim.as_mut().unwrap();
        sim.set_loads(loads, Some(s.ramp));
        sim.advance(4e-3, &mut |_, _| {}).unwrap();
        let done = FmiState::StepComplete;
        assert_eq!(decode(&encode(done, &s)).unwrap(), (done, s));
    }

    #[test]
    fn damaged_states_are_rejected_with_a_reason() {
        let bytes = encode(FmiState::StepComplete, &running(1));
        for n in [0, 7, 20, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..n]).is_err(), "truncated to {n}");
        }
        let mut flipped = bytes.clone();
        let k = bytes.len() - 100;
        flipped[k] ^= 0x10;
        assert!(decode(&flipped).unwrap_err().contains("checksum"));
        let mut other = bytes.clone();
        other[8] = 9;
        assert!(decode(&other).unwrap_err().contains("version"));
        let mut guid = bytes.clone();
        guid[18] ^= 1;
        assert!(decode(&guid).unwrap_err().contains("GUID"));
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).is_err());
    }
}
