//! Reliability of the FMU under a careless or hostile master (issue 5, parts 3 to 6), through
//! the exported C functions only (tests/fmi_support/ffi.rs):
//!
//! - threads and instances: 16 instances stepped in 8 threads are bit-identical to the same
//!   instances stepped one after another; 10,000 instantiate/free cycles keep the resident set
//!   size flat;
//! - serialized FMU states: a state serialized here continues bit-identically in another process
//!   (this test binary run as a child); damaged blobs are rejected with a clear message;
//! - the long run: 1e6 communication steps of the running paper scene (100 s simulated) with the
//!   contact coordinates inside their windows, memory and speed flat;
//! - logging: every error path logs through the callback in its category; an unknown category
//!   is an error.
//!
//! The tests of this binary run one at a time (`serial()`): the memory tests measure the
//! process's resident set size. `cargo test --release --test fmi_reliability` takes about 15 s.
//! Numbers are printed with `-- --nocapture`.

mod fmi_support;

use fmi_support::ffi::*;
use fmi_support::*;
use spur_gear_mesh::variables::{Causality, VarType, GUID, LOG_CATEGORIES, VARIABLES};
use std::ffi::CString;
use std::os::raw::{c_char, c_int};
use std::ptr::null_mut;
use std::sync::{Barrier, Mutex, MutexGuard};
use std::time::Instant;

fn serial() -> MutexGuard<'static, ()> {
    static M: Mutex<()> = Mutex::new(());
    M.lock().unwrap_or_else(|e| e.into_inner())
}

/// Every Real output's value reference.
fn output_vrs() -> Vec<u32> {
    VARIABLES
        .iter()
        .filter(|v| v.ty == VarType::Real && v.causality == Causality::Output)
        .map(|v| v.vr)
        .collect()
}

// ---- 3. threads and instances ----------------------------------------------------------------

/// Start values by name: Reals and Integers.
type Starts = (Vec<(&'static str, f64)>, Vec<(&'static str, i32)>);

/// Instance k of the thread test: the paper scene with its own load, damping and method.
fn thread_scene(k: usize) -> Starts {
    let reals = vec![
        ("tau_A", 60.0 + 5.0 * k as f64),
        ("c_load", 1.0 + 0.25 * k as f64),
        ("w_A_start", 100.0),
        ("w_B_start", 100.0 / 1.5),
        ("chi", 5.0 + k as f64),
    ];
    (reals, vec![("solver", 1 + (k % 3) as i32)])
}

const THREAD_STEPS: usize = 2000;

/// Steps an instance and returns the bits of every output after every step. Halfway, its state
/// goes through get/serialize/deserialize/set (the same in both runs).
fn trajectory_step(f: &Fmu, k: usize, t: &mut f64, out: &mut Vec<u64>, vrs: &[u32]) {
    if k == THREAD_STEPS / 2 {
        let s = f.get_state();
        let blob = f.serialize(s);
        let (st, s2) = f.deserialize(&blob);
        assert_eq!(st, Status::Ok);
        assert_eq!(f.set_state(s2), Status::Ok);
        f.free_state(s);
        f.free_state(s2);
    }
    assert_eq!(f.do_step(*t, 1e-4), Status::Ok, "{:?}", f.log.take());
    *t += 1e-4;
    let (st, y) = f.get_reals(vrs);
    assert_eq!(st, Status::Ok);
    out.extend(bits(&y));
}

fn new_thread_instance(k: usize) -> Fmu {
    let f = Fmu::try_new(&format!("inst{k}"), false).unwrap();
    let (r, i) = thread_scene(k);
    f.initialize(&r, &i);
    f
}

#[test]
fn sixteen_instances_in_eight_threads_are_bit_identical_to_sequential() {
    let _s = serial();
    let vrs = output_vrs();
    let t0 = Instant::now();
    let sequential: Vec<Vec<u64>> = (0..16)
        .map(|k| {
            let f = new_thread_instance(k);
            let (mut t, mut out) = (0.0, Vec::new());
            for step in 0..THREAD_STEPS {
                trajectory_step(&f, step, &mut t, &mut out, &vrs);
            }
            out
        })
        .collect();
    let t_seq = t0.elapsed();

    // Instances created here, stepped in 8 threads two at a time, interleaved, started together.
    let t0 = Instant::now();
    let instances: Vec<Fmu> = (0..16).map(new_thread_instance).collect();
    let barrier = Barrier::new(8);
    let mut threaded: Vec<Option<Vec<u64>>> = vec![None; 16];
    std::thread::scope(|scope| {
        let mut handles = Vec::new();
        let mut it = instances.into_iter().enumerate();
        for _ in 0..8 {
            let (a, b) = (it.next().unwrap(), it.next().unwrap());
            let (barrier, vrs) = (&barrier, &vrs);
            handles.push(scope.spawn(move || {
                barrier.wait();
                let (mut ta, mut tb) = (0.0, 0.0);
                let (mut oa, mut ob) = (Vec::new(), Vec::new());
                for step in 0..THREAD_STEPS {
                    trajectory_step(&a.1, step, &mut ta, &mut oa, vrs);
                    trajectory_step(&b.1, step, &mut tb, &mut ob, vrs);
                }
                [(a.0, oa), (b.0, ob)]
            }));
        }
        for h in handles {
            for (k, o) in h.join().expect("a stepping thread panicked") {
                threaded[k] = Some(o);
            }
        }
    });
    let t_thr = t0.elapsed();
    for k in 0..16 {
        let th = threaded[k].as_ref().unwrap();
        assert_eq!(th.len(), sequential[k].len());
        if let Some(i) = th.iter().zip(&sequential[k]).position(|(a, b)| a != b) {
            panic!(
                "instance {k}: threaded run differs from the sequential one at step {}, output {}",
                i / vrs.len(),
                vrs[i % vrs.len()]
            );
        }
    }
    // The parameters differ, so must the trajectories (the comparison is not vacuous).
    for k in 1..16 {
        assert_ne!(sequential[k], sequential[k - 1]);
    }
    eprintln!(
        "threads: 16 instances x {THREAD_STEPS} steps, {} outputs each: bit-identical; \
         sequential {t_seq:?}, 8 threads {t_thr:?}",
        vrs.len()
    );
}

#[test]
fn ten_thousand_instantiate_free_cycles_keep_memory_flat() {
    let _s = serial();
    let cycle = |k: usize| {
        let f = Fmu::try_new("cycle", k.is_multiple_of(3)).unwrap();
        if k.is_multiple_of(4) {
            f.initialize(PAPER_SCENE, &[]);
            for j in 0..3 {
                assert_eq!(f.do_step(j as f64 * 1e-4, 1e-4), Status::Ok);
            }
            let s = f.get_state(); // left allocated: fmi2FreeInstance frees it
            let _ = f.serialize(s);
        }
        drop(f); // fmi2FreeInstance
    };
    for k in 0..1000 {
        cycle(k); // warm-up: the allocator's pools reach their working size
    }
    let before = rss_kb();
    let t0 = Instant::now();
    for k in 0..10_000 {
        cycle(k);
    }
    let after = rss_kb();
    eprintln!(
        "instances: 10000 instantiate/free cycles (every 4th initialized, stepped, with an FMU \
         state left for fmi2FreeInstance) in {:?}; RSS {before} kB -> {after} kB",
        t0.elapsed()
    );
    // A leak of 100 bytes per cycle would be 1 MB.
    assert!(
        after <= before + 512,
        "resident set size grew from {before} kB to {after} kB over 10000 cycles"
    );
}

// ---- 4. serialized state ---------------------------------------------------------------------

const CHILD_STEPS: usize = 2000;

fn write_bits(path: &std::path::Path, v: &[u64]) {
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap();
}

fn read_bits(path: &std::path::Path) -> Vec<u64> {
    std::fs::read(path)
        .unwrap()
        .chunks(8)
        .map(|c| u64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The child's side of `state_continues_bit_identically_in_another_process`: run by that test
/// as a separate process (this binary, `--ignored --exact`), does nothing without its inputs.
#[test]
#[ignore = "the child process of state_continues_bit_identically_in_another_process"]
fn child_process_continues_from_blob() {
    let (Some(blob), Some(out)) = (
        std::env::var_os("FMI_CHILD_BLOB"),
        std::env::var_os("FMI_CHILD_OUT"),
    ) else {
        return;
    };
    let blob = std::fs::read(blob).unwrap();
    let f = Fmu::try_new("child", false).unwrap();
    let (st, s) = f.deserialize(&blob);
    assert_eq!(st, Status::Ok, "{:?}", f.log.take());
    assert_eq!(f.set_state(s), Status::Ok);
    let mut t = f.time();
    let vrs = output_vrs();
    let mut bits_out = Vec::new();
    for _ in 0..CHILD_STEPS {
        assert_eq!(f.do_step(t, 1e-4), Status::Ok, "{:?}", f.log.take());
        t += 1e-4;
        bits_out.extend(bits(&f.get_reals(&vrs).1));
    }
    write_bits(std::path::Path::new(&out), &bits_out);
}

#[test]
fn state_continues_bit_identically_in_another_process() {
    let _s = serial();
    let dir = std::env::temp_dir();
    let vrs = output_vrs();
    for solver in [1, 2, 3] {
        let f = Fmu::new("parent");
        f.initialize(PAPER_SCENE, &[("solver", solver)]);
        let mut t = 0.0;
        for _ in 0..3000 {
            assert_eq!(f.do_step(t, 1e-4), Status::Ok);
            t += 1e-4;
        }
        let s = f.get_state();
        let blob = f.serialize(s);
        let tag = format!("sgm-{}-{solver}", std::process::id());
        let (blob_path, out_path) = (
            dir.join(format!("{tag}.state")),
            dir.join(format!("{tag}.out")),
        );
        std::fs::write(&blob_path, &blob).unwrap();
        let mut expected = Vec::new();
        for _ in 0..CHILD_STEPS {
            assert_eq!(f.do_step(t, 1e-4), Status::Ok);
            t += 1e-4;
            expected.extend(bits(&f.get_reals(&vrs).1));
        }
        let status = std::process::Command::new(std::env::current_exe().unwrap())
            .args([
                "--ignored",
                "--exact",
                "child_process_continues_from_blob",
                "--test-threads=1",
            ])
            .env("FMI_CHILD_BLOB", &blob_path)
            .env("FMI_CHILD_OUT", &out_path)
            .stdout(std::process::Stdio::null())
            .status()
            .unwrap();
        assert!(status.success(), "the child process failed: {status}");
        let got = read_bits(&out_path);
        let _ = (
            std::fs::remove_file(&blob_path),
            std::fs::remove_file(&out_path),
        );
        assert_eq!(
            got.len(),
            expected.len(),
            "the child wrote {} values",
            got.len()
        );
        assert!(
            got == expected,
            "solver {solver}: the other process diverges at step {}",
            got.iter().zip(&expected).position(|(a, b)| a != b).unwrap() / vrs.len()
        );
        eprintln!(
            "state transfer (solver {solver}): a {} byte state from t = 0.3 s continues \
             bit-identically for {CHILD_STEPS} steps in another process",
            blob.len()
        );
    }
}

/// A running state's blob and the instance that made it.
fn running_blob() -> (Fmu, Vec<u8>) {
    let f = paper_scene("src");
    let mut t = 0.0;
    for _ in 0..100 {
        assert_eq!(f.do_step(t, 1e-4), Status::Ok);
        t += 1e-4;
    }
    let s = f.get_state();
    let b = f.serialize(s);
    (f, b)
}

/// Deserializes `blob` into a fresh instance: the status and the error messages.
fn try_blob(blob: &[u8]) -> (Status, Vec<Record>) {
    let g = Fmu::try_new("reader", false).unwrap();
    let (st, s) = g.deserialize(blob);
    if st == Status::Ok {
        g.free_state(s);
    } else {
        assert!(
            s.is_null(),
            "a failed fmi2DeSerializeFMUstate returned a state"
        );
    }
    (st, g.log.take())
}

#[test]
fn damaged_or_foreign_blobs_are_rejected_with_a_clear_message() {
    let _s = serial();
    let (_f, blob) = running_blob();
    let (p0, plen) = payload_range(&blob);
    let glen = GUID.len();
    assert_eq!(
        &blob[16..16 + glen],
        GUID.as_bytes(),
        "the blob carries the GUID"
    );

    let mut cases: Vec<(String, Vec<u8>, &str)> = Vec::new();
    for v in [0u32, 1, 99, u32::MAX] {
        let mut b = blob.clone();
        b[8..12].copy_from_slice(&v.to_le_bytes());
        cases.push((format!("format version {v}"), b, "version"));
    }
    {
        // Another build of the model: the GUID (derived from the version) differs.
        let mut b = blob.clone();
        b[16 + 1] = if b[17] == b'0' { b'1' } else { b'0' };
        cases.push(("another GUID".into(), b, "GUID"));
    }
    for n in [
        0,
        1,
        7,
        8,
        12,
        16,
        20,
        16 + glen,
        p0,
        p0 + 8,
        p0 + plen / 2,
        blob.len() - 8,
        blob.len() - 1,
    ] {
        cases.push((format!("truncated to {n} bytes"), blob[..n].to_vec(), ""));
    }
    for k in [p0, p0 + 8, p0 + plen / 2, p0 + plen - 1] {
        let mut b = blob.clone();
        b[k] ^= 0x04;
        cases.push((format!("payload byte {k} flipped"), b, "checksum"));
    }
    {
        let mut b = blob.clone();
        let n = b.len();
        b[n - 3] ^= 0x80;
        cases.push(("checksum flipped".into(), b, "checksum"));
        let mut b = blob.clone();
        b.extend_from_slice(&[0; 8]);
        cases.push(("8 bytes appended".into(), b, "length"));
        let mut b = blob.clone();
        b[0] = b'X';
        cases.push(("other magic bytes".into(), b, "magic"));
        cases.push((
            "random bytes".into(),
            (0..blob.len()).map(|i| (i * 37 % 251) as u8).collect(),
            "magic",
        ));
    }
    for (what, b, keyword) in &cases {
        let (st, recs) = try_blob(b);
        assert_eq!(st, Status::Error, "{what}: accepted");
        let msg = recs
            .iter()
            .find(|r| r.status == 3 && r.category == "logStatusError")
            .unwrap_or_else(|| panic!("{what}: rejected without an error message"));
        assert!(
            msg.text()
                .starts_with("fmi2DeSerializeFMUstate: serialized state rejected: "),
            "{what}: {}",
            msg.text()
        );
        assert!(
            msg.text().contains(keyword),
            "{what}: the message does not say '{keyword}': {}",
            msg.text()
        );
    }
    // A blob with a null pointer, and the original still loads.
    let g = Fmu::try_new("reader", false).unwrap();
    let mut s: FmuState = null_mut();
    assert_eq!(
        unsafe { fmi2DeSerializeFMUstate(g.c, std::ptr::null(), 100, &mut s) },
        Status::Error
    );
    assert_eq!(try_blob(&blob).0, Status::Ok);
    eprintln!(
        "blobs: {} damaged or foreign blobs rejected with a reason",
        cases.len()
    );
    for (what, b, _) in cases.iter().step_by(4) {
        eprintln!("  {what}: {}", try_blob(b).1[0].text());
    }
}

/// A hostile blob: a payload value replaced and the checksum recomputed. The FMU should reject
/// it or keep its guarantees (finite outputs, finite time). Known gap (docs/reliability.md): the
/// decoder checks the structure but not the values, so this fails today. Run with
/// `cargo test --release --test fmi_reliability -- --ignored hostile`.
#[test]
fn hostile_blob_with_a_valid_checksum_is_rejected_or_harmless() {
    let _s = serial();
    let (_f, blob) = running_blob();
    let (p0, plen) = payload_range(&blob);
    let mut problems = Vec::new();
    for value in [f64::NAN, f64::INFINITY, 1e300, -1.0, 0.0] {
        for w in 1..plen / 8 {
            let mut b = blob.clone();
            b[p0 + 8 * w..p0 + 8 * w + 8].copy_from_slice(&value.to_bits().to_le_bytes());
            let sum = fnv64(&b[p0..p0 + plen]);
            b[p0 + plen..].copy_from_slice(&sum.to_le_bytes());
            let g = Fmu::try_new("hostile", false).unwrap();
            let (st, s) = g.deserialize(&b);
            if st != Status::Ok {
                continue;
            }
            assert_eq!(g.set_state(s), Status::Ok);
            let mut t = f64::NAN;
            let ts = unsafe { fmi2GetRealStatus(g.c, LAST_SUCCESSFUL_TIME, &mut t) };
            let (gs, y) = g.get_reals(&real_vrs());
            let bad: Vec<&str> = VARIABLES
                .iter()
                .filter(|v| v.ty == VarType::Real)
                .zip(&y)
                .filter(|(_, x)| !x.is_finite())
                .map(|(v, _)| v.name)
                .collect();
            if ts == Status::Ok && !t.is_finite() || gs == Status::Ok && !bad.is_empty() {
                problems.push(format!(
                    "payload word {w} = {value}: time {t}, fmi2GetReal {gs:?} with {bad:?}"
                ));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "{} hostile blobs accepted and harmful:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// Huge but finite parameters that the range checks accept: the FMU should refuse to leave
/// initialization (or to answer fmi2GetReal) rather than hand out inf/NaN with fmi2OK. Known bug
/// (docs/reliability.md): w_A_start = 1e200 gives E_kin = inf and energy_residual = NaN with
/// fmi2OK, in initialization mode and after fmi2ExitInitializationMode returned fmi2OK. Run with
/// `cargo test --release --test fmi_reliability -- --ignored huge`.
#[test]
fn huge_finite_parameters_give_finite_outputs_or_an_error() {
    let _s = serial();
    let mut problems = Vec::new();
    for (name, x) in [
        ("w_A_start", 1e200),
        ("w_A_start", f64::MAX),
        ("J_A", f64::MAX),
        ("dte_start", 1e300),
    ] {
        let f = quiet("q");
        assert_eq!(f.set_real(name, x), Status::Ok, "{name} = {x} is in range");
        assert_eq!(f.enter_init(), Status::Ok);
        for phase in ["initialization mode", "after fmi2ExitInitializationMode"] {
            if phase != "initialization mode" && f.exit_init() != Status::Ok {
                break; // refused: fine
            }
            let (st, y) = f.get_reals(&output_vrs());
            let bad: Vec<&str> = VARIABLES
                .iter()
                .filter(|v| v.ty == VarType::Real && v.causality == Causality::Output)
                .zip(&y)
                .filter(|(_, x)| !x.is_finite())
                .map(|(v, _)| v.name)
                .collect();
            if st == Status::Ok && !bad.is_empty() {
                problems.push(format!(
                    "{name} = {x:e}, {phase}: fmi2GetReal gives fmi2OK with {bad:?} non-finite"
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// ---- 5. the long run -------------------------------------------------------------------------

/// 1e6 communication steps of 1e-4 s of the running paper scene (100 s simulated), every output
/// read after every step: the contact coordinates s_f1, s_f2, s_b1, s_b2 stay in their windows
/// [s_b - 2 p_b, s_b], every output stays finite, the resident set size and the time per step
/// stay flat (first tenth against last tenth). About 5 s. FMI_LONG_STEPS sets the number of
/// steps (tools/long-run.sh).
#[test]
fn long_run_of_the_paper_scene_has_no_drift() {
    let _s = serial();
    let n: usize = std::env::var("FMI_LONG_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let h = 1e-4;
    // Debug logging off (the test's logger would keep a message per step in memory).
    let f = Fmu::try_new("long", false).unwrap();
    f.initialize(PAPER_SCENE, &[]);
    let (s_b, p_b) = (f.get_real("s_b"), f.get_real("base_pitch"));
    let (lo, hi) = (s_b - 2.0 * p_b, s_b);
    let eps = 1e-12 * s_b;
    let vrs = output_vrs();
    let s_idx: Vec<usize> = ["s_f1", "s_f2", "s_b1", "s_b2"]
        .iter()
        .map(|n| vrs.iter().position(|&r| r == vr(n)).unwrap())
        .collect();
    let work_vr = VARIABLES
        .iter()
        .find(|v| v.name == "n_rhs_evaluations")
        .map(|v| v.vr);
    let mut seen = [(f64::INFINITY, f64::NEG_INFINITY); 4];
    let tenth = n / 10;
    let chunk = 1000.min(tenth.max(1));
    let mut chunk_times: Vec<f64> = Vec::new();
    let (mut rss, mut work) = (Vec::new(), Vec::new());
    let mut t = 0.0;
    let mut tc = Instant::now();
    for k in 0..n {
        let st = f.do_step(t, h);
        assert_eq!(st, Status::Ok, "step {k} at t = {t}: {:?}", f.log.take());
        t += h;
        let (st, y) = f.get_reals(&vrs);
        assert_eq!(st, Status::Ok);
        for (j, &i) in s_idx.iter().enumerate() {
            let s = y[i];
            assert!(
                s >= lo - eps && s <= hi + eps,
                "t = {t}: {} = {s} left its window [{lo}, {hi}]",
                ["s_f1", "s_f2", "s_b1", "s_b2"][j]
            );
            seen[j] = (seen[j].0.min(s), seen[j].1.max(s));
        }
        if k % 100 == 0 {
            assert!(
                y.iter().all(|x| x.is_finite()),
                "t = {t}: a non-finite output"
            );
        }
        if (k + 1) % chunk == 0 {
            chunk_times.push(tc.elapsed().as_secs_f64() / chunk as f64);
            tc = Instant::now();
        }
        if (k + 1) % tenth == 0 {
            rss.push(rss_kb());
            if let Some(w) = work_vr {
                let mut x = 0;
                unsafe { fmi2GetInteger(f.c, &w, 1, &mut x) };
                work.push(x);
            }
        }
    }
    // The 10th percentile of the chunk times of a tenth: the speed when the (shared) machine
    // lets the test run, insensitive to other load.
    let low = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v[v.len() / 10]
    };
    let per_tenth = chunk_times.len() / 10;
    let (first, last) = (
        low(&chunk_times[..per_tenth]),
        low(&chunk_times[chunk_times.len() - per_tenth..]),
    );
    eprintln!(
        "long run: {n} steps of {h} s to t = {t:.3} s; windows [{lo:.6}, {hi:.6}] m; \
         s_f1, s_f2, s_b1, s_b2 ranges {seen:.6?}; time per step (10th percentile) {:.2} us (first tenth) \
         -> {:.2} us (last tenth); RSS per tenth {rss:?} kB; rhs evaluations at each tenth {work:?}",
        first * 1e6,
        last * 1e6
    );
    assert!(rss[9] <= rss[0] + 256, "memory grew: {rss:?} kB");
    // The work per simulated second is the machine-independent measure of speed.
    if work.len() == 10 {
        let (w0, w9) = (work[0] as f64, (work[9] - work[8]) as f64);
        assert!(
            w9 < 1.2 * w0,
            "the integrator works harder late in the run: {work:?}"
        );
    }
    // Wall time per step: generous, the machine is shared.
    assert!(
        last < 2.0 * first,
        "slower late in the run: {first} s -> {last} s per step"
    );
}

// ---- 6. logging ------------------------------------------------------------------------------

/// A fresh instance with debug logging off: error messages must come all the same.
fn quiet(name: &str) -> Fmu {
    Fmu::try_new(name, false).unwrap()
}

fn running() -> Fmu {
    let f = Fmu::try_new("running", false).unwrap();
    f.initialize(PAPER_SCENE, &[]);
    f
}

type Case = (
    &'static str,
    &'static str,
    Status,
    &'static str,
    Box<dyn Fn() -> (Status, Vec<Record>)>,
);

fn case(
    what: &'static str,
    func: &'static str,
    want: Status,
    keyword: &'static str,
    run: impl Fn(&Fmu) -> Status + 'static,
    setup: fn() -> Fmu,
) -> Case {
    (
        what,
        func,
        want,
        keyword,
        Box::new(move || {
            let f = setup();
            let _ = f.log.take();
            let st = run(&f);
            (st, f.log.take())
        }),
    )
}

fn cstrings(v: &[&str]) -> (Vec<CString>, Vec<*const c_char>) {
    let c: Vec<CString> = v.iter().map(|s| CString::new(*s).unwrap()).collect();
    let p = c.iter().map(|s| s.as_ptr()).collect();
    (c, p)
}

#[test]
fn every_error_path_logs_in_its_category() {
    let _s = serial();
    let r = |n: &str| vr(n);
    let setr = |name: &'static str, x: f64| move |f: &Fmu| f.set_real(name, x);
    let cases: Vec<Case> = vec![
        // State machine
        case(
            "step before initialization",
            "fmi2DoStep",
            Status::Error,
            "not allowed",
            |f| f.do_step(0.0, 1e-4),
            || quiet("q"),
        ),
        case(
            "exit without enter",
            "fmi2ExitInitializationMode",
            Status::Error,
            "not allowed",
            |f| f.exit_init(),
            || quiet("q"),
        ),
        case(
            "setup after initialization",
            "fmi2SetupExperiment",
            Status::Error,
            "not allowed",
            |f| f.setup(None),
            running,
        ),
        case(
            "enter twice",
            "fmi2EnterInitializationMode",
            Status::Error,
            "not allowed",
            |f| f.enter_init(),
            running,
        ),
        case(
            "terminate before initialization",
            "fmi2Terminate",
            Status::Error,
            "not allowed",
            |f| f.terminate(),
            || quiet("q"),
        ),
        case(
            "get before initialization",
            "fmi2GetReal",
            Status::Error,
            "not allowed",
            |f| f.get_reals(&[40]).0,
            || quiet("q"),
        ),
        case(
            "status before initialization",
            "fmi2GetRealStatus",
            Status::Error,
            "not allowed",
            |f| {
                let mut t = 0.0;
                unsafe { fmi2GetRealStatus(f.c, LAST_SUCCESSFUL_TIME, &mut t) }
            },
            || quiet("q"),
        ),
        case(
            "set after terminate",
            "fmi2SetReal",
            Status::Error,
            "not allowed",
            |f| {
                f.terminate();
                f.set_real("tau_A", 1.0)
            },
            running,
        ),
        // Arguments
        case(
            "tolerance out of range",
            "fmi2SetupExperiment",
            Status::Error,
            "tolerance",
            |f| unsafe { fmi2SetupExperiment(f.c, 1, 0.5, 0.0, 0, 0.0) },
            || quiet("q"),
        ),
        case(
            "start time NaN",
            "fmi2SetupExperiment",
            Status::Error,
            "startTime",
            |f| unsafe { fmi2SetupExperiment(f.c, 0, 0.0, f64::NAN, 0, 0.0) },
            || quiet("q"),
        ),
        case(
            "stop before start",
            "fmi2SetupExperiment",
            Status::Error,
            "stopTime",
            |f| unsafe { fmi2SetupExperiment(f.c, 0, 0.0, 1.0, 1, 0.5) },
            || quiet("q"),
        ),
        case(
            "unknown value reference (get)",
            "fmi2GetReal",
            Status::Error,
            "unknown value reference",
            |f| f.get_reals(&[9999]).0,
            running,
        ),
        case(
            "wrong type (get)",
            "fmi2GetReal",
            Status::Error,
            "Integer",
            |f| f.get_reals(&[vr("zA")]).0,
            running,
        ),
        case(
            "null value array",
            "fmi2GetReal",
            Status::Error,
            "null pointer",
            move |f| unsafe { fmi2GetReal(f.c, &r("w_A"), 1, null_mut()) },
            running,
        ),
        case(
            "string getter on an Integer",
            "fmi2GetString",
            Status::Error,
            "geometry (value reference 1) is Integer, not String",
            |f| {
                let mut p = std::ptr::null();
                unsafe { fmi2GetString(f.c, &1, 1, &mut p) }
            },
            running,
        ),
        case(
            "unknown value reference (set)",
            "fmi2SetReal",
            Status::Error,
            "unknown value reference",
            |f| f.set_reals(&[9999], &[1.0]),
            || quiet("q"),
        ),
        case(
            "set an output",
            "fmi2SetReal",
            Status::Error,
            "cannot be set",
            setr("w_A", 1.0),
            running,
        ),
        case(
            "set a calculated parameter",
            "fmi2SetReal",
            Status::Error,
            "cannot be set",
            setr("s_b", 1.0),
            || quiet("q"),
        ),
        case(
            "fixed parameter after initialization",
            "fmi2SetReal",
            Status::Error,
            "fixed",
            setr("J_A", 1.0),
            running,
        ),
        case(
            "NaN input",
            "fmi2SetReal",
            Status::Error,
            "finite",
            setr("tau_A", f64::NAN),
            running,
        ),
        case(
            "infinite parameter",
            "fmi2SetReal",
            Status::Error,
            "finite",
            setr("chi", f64::INFINITY),
            || quiet("q"),
        ),
        case(
            "negative damping",
            "fmi2SetReal",
            Status::Error,
            "chi",
            setr("chi", -1.0),
            || quiet("q"),
        ),
        case(
            "wrong type (set)",
            "fmi2SetInteger",
            Status::Error,
            "Real",
            |f| f.set_integer("tau_A", 1),
            || quiet("q"),
        ),
        case(
            "invalid integer parameter",
            "fmi2SetInteger",
            Status::Error,
            "solver",
            |f| f.set_integer("solver", 7),
            || quiet("q"),
        ),
        case(
            "pitch errors that are not numbers",
            "fmi2SetString",
            Status::Error,
            "pitch_errors_A: entry 2 ('x') is not a number",
            |f| {
                let p = c"1e-7, x".as_ptr();
                unsafe { fmi2SetString(f.c, &119, 1, &p) }
            },
            || quiet("q"),
        ),
        case(
            "pitch errors, one per tooth",
            "fmi2ExitInitializationMode",
            Status::Error,
            "pitch_errors_B: 2 entries, but the wheel has 33 teeth",
            |f| {
                let p = c"1e-7, 2e-7".as_ptr();
                assert_eq!(unsafe { fmi2SetString(f.c, &120, 1, &p) }, Status::Ok);
                f.enter_init();
                f.exit_init()
            },
            || quiet("q"),
        ),
        case(
            "inconsistent parameters at initialization",
            "fmi2ExitInitializationMode",
            Status::Error,
            "zB",
            |f| {
                f.set_integer("zB", 34);
                f.enter_init();
                f.exit_init()
            },
            || quiet("q"),
        ),
        // Steps
        case(
            "negative step",
            "fmi2DoStep",
            Status::Error,
            "communicationStepSize",
            |f| f.do_step(0.0, -1e-4),
            running,
        ),
        case(
            "NaN step",
            "fmi2DoStep",
            Status::Error,
            "must be finite",
            |f| f.do_step(0.0, f64::NAN),
            running,
        ),
        case(
            "wrong time",
            "fmi2DoStep",
            Status::Error,
            "does not match",
            |f| f.do_step(1.0, 1e-4),
            running,
        ),
        case(
            "past the stop time",
            "fmi2DoStep",
            Status::Error,
            "stopTime",
            |f| f.do_step(0.0, 0.2),
            || {
                let f = quiet("q");
                assert_eq!(f.setup(Some(0.1)), Status::Ok);
                f.enter_init();
                f.exit_init();
                f
            },
        ),
        case(
            "contact law out of range",
            "fmi2DoStep",
            Status::Error,
            "out of the model's range",
            |f| {
                f.set_real("tau_A", 1e9);
                let mut st = Status::Ok;
                let mut t = 0.0;
                while st == Status::Ok && t < 0.01 {
                    st = f.do_step(t, 1e-4);
                    t += 1e-4;
                }
                st
            },
            running,
        ),
        case(
            "work cap of a step",
            "fmi2DoStep",
            Status::Discard,
            "work cap",
            |f| f.do_step(0.0, 1.0),
            || {
                let f = quiet("q");
                f.initialize(&[("w_A_start", 1e5), ("w_B_start", 1e5 / 1.5)], &[]);
                f
            },
        ),
        case(
            "cancel",
            "fmi2CancelStep",
            Status::Error,
            "no step to cancel",
            |f| unsafe { fmi2CancelStep(f.c) },
            running,
        ),
        // Status queries
        case(
            "status not available",
            "fmi2GetStatus",
            Status::Discard,
            "not available",
            |f| {
                let mut s = 0;
                unsafe { fmi2GetStatus(f.c, DO_STEP_STATUS, &mut s) }
            },
            running,
        ),
        case(
            "unknown status kind",
            "fmi2GetRealStatus",
            Status::Error,
            "fmi2StatusKind",
            |f| {
                let mut t = 0.0;
                unsafe { fmi2GetRealStatus(f.c, 17, &mut t) }
            },
            running,
        ),
        // FMU states
        case(
            "null FMUstate argument",
            "fmi2GetFMUstate",
            Status::Error,
            "null",
            |f| unsafe { fmi2GetFMUstate(f.c, null_mut()) },
            running,
        ),
        case(
            "bogus FMU state",
            "fmi2SetFMUstate",
            Status::Error,
            "not created by this instance",
            |f| unsafe { fmi2SetFMUstate(f.c, 0x1000 as FmuState) },
            running,
        ),
        case(
            "freed FMU state",
            "fmi2SetFMUstate",
            Status::Error,
            "already freed",
            |f| {
                let s = f.get_state();
                f.free_state(s);
                f.set_state(s)
            },
            running,
        ),
        case(
            "state of another instance",
            "fmi2FreeFMUstate",
            Status::Error,
            "not created by this instance",
            |f| {
                let g = running();
                let mut s = g.get_state();
                unsafe { fmi2FreeFMUstate(f.c, &mut s) }
            },
            running,
        ),
        case(
            "size without a pointer",
            "fmi2SerializedFMUstateSize",
            Status::Error,
            "null pointer",
            |f| {
                let s = f.get_state();
                unsafe { fmi2SerializedFMUstateSize(f.c, s, null_mut()) }
            },
            running,
        ),
        case(
            "buffer too small",
            "fmi2SerializeFMUstate",
            Status::Error,
            "too small",
            |f| {
                let s = f.get_state();
                let mut b = [0 as c_char; 16];
                unsafe { fmi2SerializeFMUstate(f.c, s, b.as_mut_ptr(), 16) }
            },
            running,
        ),
        case(
            "damaged blob",
            "fmi2DeSerializeFMUstate",
            Status::Error,
            "rejected",
            |f| f.deserialize(b"SGMSTATE-not-really").0,
            running,
        ),
        // Logging and functions the FMU does not provide
        case(
            "unknown log category",
            "fmi2SetDebugLogging",
            Status::Error,
            "unknown log category",
            |f| {
                let (_k, p) = cstrings(&["logEverything"]);
                unsafe { fmi2SetDebugLogging(f.c, 1, 1, p.as_ptr()) }
            },
            || quiet("q"),
        ),
        case(
            "categories: null array",
            "fmi2SetDebugLogging",
            Status::Error,
            "null pointer",
            |f| unsafe { fmi2SetDebugLogging(f.c, 1, 2, std::ptr::null()) },
            || quiet("q"),
        ),
        case(
            "input derivative of an output",
            "fmi2SetRealInputDerivatives",
            Status::Error,
            "dte (value reference 54) is not a Real input",
            |f| unsafe { fmi2SetRealInputDerivatives(f.c, &54, 1, &1, &0.0) },
            running,
        ),
        case(
            "input derivative of order 3",
            "fmi2SetRealInputDerivatives",
            Status::Error,
            "tau_A: derivative order 3 is not supported (1 or 2)",
            |f| unsafe { fmi2SetRealInputDerivatives(f.c, &40, 1, &3, &1.0) },
            running,
        ),
        case(
            "input derivative not finite",
            "fmi2SetRealInputDerivatives",
            Status::Error,
            "tau_A: derivative of order 1 = NaN: must be finite",
            |f| unsafe { fmi2SetRealInputDerivatives(f.c, &40, 1, &1, &f64::NAN) },
            running,
        ),
        case(
            "output derivatives",
            "fmi2GetRealOutputDerivatives",
            Status::Error,
            "maxOutputDerivativeOrder",
            |f| {
                let mut x = 0.0;
                unsafe { fmi2GetRealOutputDerivatives(f.c, &52, 1, &1, &mut x) }
            },
            running,
        ),
        case(
            "directional derivative of Co-Simulation (Model Exchange provides them)",
            "fmi2GetDirectionalDerivative",
            Status::Error,
            "instantiated for Co-Simulation",
            |f| {
                let mut x = 0.0;
                unsafe { fmi2GetDirectionalDerivative(f.c, &52, 1, &40, 1, &1.0, &mut x) }
            },
            running,
        ),
        case(
            "Model Exchange function",
            "fmi2SetTime",
            Status::Error,
            "Co-Simulation",
            |f| unsafe { fmi2SetTime(f.c, 0.0) },
            running,
        ),
    ];
    let mut n_checked = 0;
    for (what, func, want, keyword, run) in &cases {
        let (st, recs) = run();
        assert_eq!(st, *want, "{what}: {func} returned {st:?}; log {recs:?}");
        let (code, cat) = if *want == Status::Discard {
            (2, "logStatusDiscard")
        } else {
            (3, "logStatusError")
        };
        let msg = recs
            .iter()
            .find(|r| r.status == code && r.category == cat && r.text().starts_with(func))
            .unwrap_or_else(|| {
                panic!("{what}: {func} gave {st:?} without a {cat} message from {func}: {recs:?}")
            });
        assert!(
            msg.text().contains(keyword),
            "{what}: '{keyword}' not in: {}",
            msg.text()
        );
        assert!(
            msg.instance == "q" || msg.instance == "running",
            "{what}: instance {}",
            msg.instance
        );
        for r in &recs {
            assert!(
                LOG_CATEGORIES.contains(&r.category.as_str()),
                "{what}: category {}",
                r.category
            );
            assert!(
                percent_escaped(&r.message),
                "{what}: unescaped % in {:?}",
                r.message
            );
        }
        n_checked += 1;
    }
    // Failed instantiations log through the callback they were given.
    let sink = LogSink::default();
    let cb = callbacks(&sink);
    let guid = CString::new(GUID).unwrap();
    let bad = [
        (
            std::ptr::null(),
            TYPE_CO_SIMULATION,
            guid.as_ptr(),
            "instanceName",
        ),
        (
            c"".as_ptr(),
            TYPE_CO_SIMULATION,
            guid.as_ptr(),
            "instanceName",
        ),
        (c"x".as_ptr(), 5, guid.as_ptr(), "fmuType = 5"),
        (
            c"x".as_ptr(),
            TYPE_CO_SIMULATION,
            c"{other}".as_ptr(),
            "GUID",
        ),
        (c"x".as_ptr(), TYPE_CO_SIMULATION, std::ptr::null(), "GUID"),
    ];
    for (name, ty, g, keyword) in bad {
        let c = unsafe { fmi2Instantiate(name, ty, g, std::ptr::null(), &*cb, 0, 0) };
        assert!(c.is_null());
        let recs = sink.take();
        assert!(
            recs.iter().any(|r| r.status == 3
                && r.category == "logStatusError"
                && r.text().starts_with("fmi2Instantiate")
                && r.text().contains(keyword)),
            "fmi2Instantiate ({keyword}): {recs:?}"
        );
        n_checked += 1;
    }
    eprintln!("logging: {n_checked} error paths, each logged in its category with a reason");
}

/// Every % of a message is escaped as %%, so a printf-style logger prints it literally.
fn percent_escaped(m: &str) -> bool {
    let mut chars = m.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '%' && chars.next() != Some('%') {
            return false;
        }
    }
    true
}

#[test]
fn debug_logging_categories() {
    let _s = serial();
    let set = |f: &Fmu, on: bool, cats: &[&str]| {
        let (_k, p) = cstrings(cats);
        unsafe {
            fmi2SetDebugLogging(
                f.c,
                on as c_int,
                p.len(),
                if p.is_empty() {
                    std::ptr::null()
                } else {
                    p.as_ptr()
                },
            )
        }
    };
    // Unknown, misspelt, null or empty names are errors, and name the valid categories.
    for bad in [
        &["logEverything"][..],
        &["logstatuserror"],
        &["logEvents", "nope"],
        &[""],
        &["100%s%n"],
    ] {
        let f = quiet("q");
        assert_eq!(set(&f, true, bad), Status::Error, "{bad:?}");
        let recs = f.log.take();
        let m = recs
            .iter()
            .find(|r| r.category == "logStatusError")
            .expect("a message");
        assert!(
            m.text().contains("logStatusDiscard"),
            "the message lists the categories: {}",
            m.text()
        );
        assert!(percent_escaped(&m.message), "{:?}", m.message);
        assert_eq!(
            f.reset(),
            Status::Ok,
            "the instance recovers with fmi2Reset"
        );
    }
    {
        let f = quiet("q");
        let p = [c"logEvents".as_ptr(), std::ptr::null()];
        assert_eq!(
            unsafe { fmi2SetDebugLogging(f.c, 1, 2, p.as_ptr()) },
            Status::Error
        );
    }
    // All declared categories are accepted, one by one and together.
    let f = quiet("q");
    for c in LOG_CATEGORIES {
        assert_eq!(set(&f, true, &[*c]), Status::Ok, "{c}");
    }
    assert_eq!(set(&f, false, LOG_CATEGORIES), Status::Ok);
    assert_eq!(set(&f, true, &[]), Status::Ok);

    // loggingOn = false: steps say nothing; errors are reported all the same.
    let f = running();
    let mut t = 0.0;
    for _ in 0..100 {
        f.do_step(t, 1e-4);
        t += 1e-4;
    }
    assert!(f.log.take().is_empty(), "debug messages with logging off");
    // Events only.
    assert_eq!(set(&f, true, &["logEvents"]), Status::Ok);
    for _ in 0..100 {
        f.do_step(t, 1e-4);
        t += 1e-4;
    }
    let recs = f.log.take();
    assert!(
        !recs.is_empty()
            && recs
                .iter()
                .all(|r| r.category == "logEvents" && r.status == 0),
        "{recs:?}"
    );
    // Errors switched off by name: then (and only then) an error is silent.
    assert_eq!(set(&f, false, &["logEvents", "logStatusError"]), Status::Ok);
    assert_eq!(f.do_step(t + 1.0, 1e-4), Status::Error);
    assert!(f.log.take().is_empty());
    assert_eq!(set(&f, true, &[]), Status::Ok, "all categories on again");
    assert_eq!(f.do_step(t + 1.0, 1e-4), Status::Error);
    let recs = f.log.take();
    assert!(
        recs.iter().any(|r| r.category == "logStatusError"),
        "{recs:?}"
    );
}
