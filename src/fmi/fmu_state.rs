//! The payload of SpurGearMesh's serialized FMU states. The envelope around it is
//! fmi2_slave's (`fmi2_slave::fmu_state`; all integers little-endian): `"SGMSTATE"`, format
//! version (u32), GUID length (u32) and bytes, payload length (u64), payload, FNV-1a 64
//! checksum of the payload (u64); the payload starts with the FMI state (u64). The rest is the
//! instance's `Snapshot` as serde derives it, written with postcard; the configuration that the
//! parameters fix (geometry, contact law, rig) is left out and built again from them, which
//! gives the same bits. A state from another format version or another build of the model
//! (GUID), or a truncated, corrupted or inconsistent one, is rejected with a reason.

use super::instance::{started_at, Snapshot};
use crate::driver::exchange::Exchange;
use crate::driver::simulation::Simulation;
use crate::driver::Method;
use crate::variables::{Causality, VARIABLES};
use fmi2_slave::fmu_state::{Reader, Writer};

/// The version of the payload below (the envelope's format version): 9 since the rig keeps the
/// dte_start of its static start; 8 since the driver saves the margins of the event functions
/// in use (7: a Model Exchange instance saves its point; 6: postcard; 1-5 were fields written
/// one by one).
pub const FORMAT_VERSION: u32 = 9;

/// The checksum only proves the bytes arrived intact; a state edited with a recomputed checksum
/// must not bring NaN, infinity or an invalid tolerance into the instance.
fn check_values(s: &Simulation) -> Result<(), String> {
    let d = &s.driver;
    let m = &s.rig;
    let (t, t_prev, h, y) = match &d.method {
        Method::Dopri5(x) => (x.t, x.t_prev, x.h, x.y),
        Method::Bdf(x) => (x.t, x.t_prev, x.h, x.y),
        Method::Dop853(x) => (x.t, x.t_prev, x.h, x.y),
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
    match &d.method {
        Method::Dopri5(x) => {
            values.extend_from_slice(&x.k1);
            x.rcont.iter().for_each(|r| values.extend_from_slice(r));
        }
        Method::Dop853(x) => {
            values.extend_from_slice(&x.k1);
            x.rcont.iter().for_each(|r| values.extend_from_slice(r));
        }
        Method::Bdf(_) => {}
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

/// The configuration a state leaves out, built again from its parameters, and the checks a
/// checksum cannot make.
fn rebuild(sim: &mut Simulation, s: &Snapshot) -> Result<(), String> {
    let p = started_at(&s.params, sim.rig.static_dte);
    let fresh = gear_model::table::simulation(&p, &s.inputs, s.start_time, s.params.rel_tol)
        .map_err(|e| format!("parameters in the state: {e}"))?;
    if sim.rig.stats.is_some() != fresh.rig.stats.is_some() {
        return Err("the statistics in the state do not match the parameter statistics".into());
    }
    sim.rig.restore_config(&fresh.rig);
    let d = &sim.driver;
    // The driver's event functions are the mesh's in use (16 without shape deviations).
    if d.pending.is_some_and(|p| p.index >= sim.rig.n_event_fns()) {
        return Err(format!("event index {:?} out of range", d.pending));
    }
    if matches!(d.method, Method::Bdf(_)) && !d.needs_restart {
        return Err("a BDF state must be a restart point".into());
    }
    check_values(sim)
}

pub fn write(w: &mut Writer, s: &Snapshot) {
    w.bytes(&postcard::to_allocvec(s).expect("a snapshot serializes"));
}

pub fn read(r: &mut Reader) -> Result<Snapshot, String> {
    let mut s: Snapshot =
        postcard::from_bytes(r.rest()).map_err(|e| format!("the payload does not decode: {e}"))?;
    let (start_time, stop_time, tolerance) = (s.start_time, s.stop_time, s.tolerance);
    if !start_time.is_finite() || stop_time.is_some_and(|t| !(t >= start_time && t.is_finite())) {
        return Err(format!(
            "invalid experiment times (start {start_time}, stop {stop_time:?})"
        ));
    }
    if tolerance.is_some_and(|t| !(1e-14..=0.1).contains(&t)) {
        return Err(format!("invalid experiment tolerance {tolerance:?}"));
    }
    gear_model::table::validate(&s.params).map_err(|e| format!("parameters in the state: {e}"))?;
    for info in VARIABLES.iter().filter(|v| v.causality == Causality::Input) {
        if let Some(bad) = s.inputs.get_real(info.var).filter(|x| !x.is_finite()) {
            return Err(format!(
                "input {} in the state is not finite ({bad})",
                info.name
            ));
        }
    }
    let ramp = &s.extra;
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
    if let Some(mut sim) = s.sim.take() {
        rebuild(&mut sim, &s)?;
        s.sim = Some(sim);
    }
    if let Some(mut ex) = s.me.take() {
        rebuild_exchange(&mut ex, &s)?;
        s.me = Some(ex);
    }
    if s.sim.is_some() && s.me.is_some() {
        return Err("a state holds both a Co-Simulation and a Model Exchange run".into());
    }
    Ok(s)
}

/// `rebuild` for a Model Exchange run: its mesh's configuration, and finite values.
fn rebuild_exchange(ex: &mut Exchange, s: &Snapshot) -> Result<(), String> {
    let p = started_at(&s.params, ex.rig.static_dte);
    let fresh = gear_model::table::simulation(&p, &s.inputs, s.start_time, s.params.rel_tol)
        .map_err(|e| format!("parameters in the state: {e}"))?;
    if ex.rig.stats.is_some() != fresh.rig.stats.is_some() {
        return Err("the statistics in the state do not match the parameter statistics".into());
    }
    let describe = ex.rig.mesh.describe_events;
    ex.rig.restore_config(&fresh.rig);
    ex.rig.mesh.describe_events = describe;
    let mut values = vec![ex.t, ex.rig.e_gate, ex.rig.e_start];
    values.extend_from_slice(&ex.y);
    values.extend_from_slice(&ex.rig.sigma);
    if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
        return Err(format!(
            "a value of the Model Exchange state is not finite ({bad})"
        ));
    }
    if !ex.points_finite() {
        return Err("a point of the Model Exchange state is not finite".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fmi::instance::{FmiState, SpurGearMesh};
    use crate::model::paper_rig::Ramp;

    use crate::variables::{Inputs, Params};
    use fmi2_slave::instance::Saved;

    /// A state in the envelope, as fmi2SerializeFMUstate writes it.
    fn encode(state: FmiState, s: &Snapshot) -> Vec<u8> {
        fmi2_slave::fmu_state::encode(&Saved {
            state,
            slave: SpurGearMesh::from(s.clone()),
        })
    }

    fn decode(bytes: &[u8]) -> Result<(FmiState, Snapshot), String> {
        let saved = fmi2_slave::fmu_state::decode::<SpurGearMesh>(
            bytes,
            &<SpurGearMesh as fmi2_slave::Slave>::fresh(),
        )?;
        Ok((saved.state, saved.slave.snap))
    }

    fn running(solver: i32) -> Snapshot {
        let mut s = Snapshot::default();
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
        let mut sim = gear_model::table::simulation(&s.params, &s.inputs, 0.0, 1e-6).unwrap();
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
        let fresh = Snapshot::default();
        let inst = FmiState::Instantiated;
        assert_eq!(decode(&encode(inst, &fresh)).unwrap(), (inst, fresh));
    }

    /// With interpolated inputs the state carries the ramp (the snapshot's and the mesh's) and
    /// the integrated time.
    #[test]
    fn round_trip_keeps_the_input_interpolation() {
        let mut s = running(1);
        s.extra = Ramp {
            t0: [3.3e-3, 0.0, 0.0, 0.0],
            rate: [250.0, 0.0, 0.0, 0.0],
            curvature: [0.0, -40.0, 0.0, 0.0],
        };
        let loads = gear_model::table::loads(&s.params, &s.inputs);
        let sim = s.sim.as_mut().unwrap();
        sim.set_loads(loads, Some(s.extra));
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
        other[8] = 10;
        assert!(decode(&other).unwrap_err().contains("version"));
        let mut guid = bytes.clone();
        guid[18] ^= 1;
        assert!(decode(&guid).unwrap_err().contains("GUID"));
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).is_err());
    }

    /// A state written by an older build (format version 5: fields written one by one; 6: no
    /// Model Exchange run; 7: margins at the capacity's size; 8: no static start kept) is
    /// refused by its version before anything of it is read, with both versions named.
    #[test]
    fn a_state_of_an_older_format_is_refused_by_its_version() {
        for old in [5u32, 6, 7, 8] {
            let mut bytes = encode(FmiState::StepComplete, &running(1));
            bytes[8..12].copy_from_slice(&old.to_le_bytes());
            let e = decode(&bytes).unwrap_err();
            let (a, b) = (format!("state format version {old}"), "reads version 9");
            assert!(e.contains(&a) && e.contains(b), "{e}");
        }
    }

    /// The payload is the snapshot as serde writes it: a state whose checksum is right but
    /// whose payload is not a snapshot (or not a consistent one) is refused with a reason.
    #[test]
    fn a_payload_that_is_no_snapshot_is_refused() {
        let s = running(1);
        let mut w = Writer::default();
        w.bytes(&postcard::to_allocvec(&s).unwrap()[..40]);
        let bytes = w.into_bytes();
        let mut r = Reader::new(&bytes);
        assert!(read(&mut r).unwrap_err().contains("does not decode"));
        // A consistent payload with a tolerance that is not the mesh's.
        let mut bad = s.clone();
        bad.sim.as_mut().unwrap().driver.tol.atol[4] = 1.0;
        let mut w = Writer::default();
        write(&mut w, &bad);
        let bytes = w.into_bytes();
        let e = read(&mut Reader::new(&bytes)).unwrap_err();
        assert!(e.contains("invalid integrator settings"), "{e}");
        // An event pending on a function the mesh does not have: without shape deviations it
        // has 16 (contact::BASE_EVENTS), the driver's margins are those.
        let mut bad = s.clone();
        let pending = crate::driver::PendingEvent {
            t: 3.4e-3,
            index: 20,
        };
        bad.sim.as_mut().unwrap().driver.pending = Some(pending);
        let mut w = Writer::default();
        write(&mut w, &bad);
        let bytes = w.into_bytes();
        let e = read(&mut Reader::new(&bytes)).unwrap_err();
        assert!(e.contains("event index"), "{e}");
    }
}
