//! SpurGearTrain through its exported C functions, in-process (the test links the crate's rlib:
//! the same symbols as the .so): bad input is refused with messages naming the elements,
//! instances on many threads give identical answers, FMU states round-trip through their bytes,
//! Model Exchange gives the states, derivatives and event indicators the table declares, and
//! random call sequences never crash, never return NaN and never let a panic out.
#![allow(non_snake_case)]

use fmi2_slave::{CallbackFunctions, Component, LoggerFn, Status};
use proptest::prelude::*;
use spur_gear_train::exports::*;
use spur_gear_train::instance::vr_of;
use spur_gear_train::variables::GUID;
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int, c_void};
use std::sync::Mutex;

/// The messages an instance logged.
#[derive(Default)]
struct Sink(Mutex<Vec<(c_int, String)>>);

/// The logger without the variadic tail: the FMU passes no variadic arguments, and on x86-64
/// System V such a call is ABI-compatible with this function (tests/fmi_support does the same).
unsafe extern "C" fn logger(
    env: *mut c_void,
    _instance: *const c_char,
    status: c_int,
    _category: *const c_char,
    message: *const c_char,
) {
    let sink = &*(env as *const Sink);
    let text = CStr::from_ptr(message).to_string_lossy().into_owned();
    sink.0.lock().unwrap().push((status, text));
}

struct Fmu {
    c: Component,
    sink: Box<Sink>,
    _callbacks: Box<CallbackFunctions>,
}

impl Fmu {
    /// A Co-Simulation instance.
    fn new() -> Fmu {
        Fmu::of_type(1)
    }

    /// fmuType 0: Model Exchange, 1: Co-Simulation.
    fn of_type(fmu_type: c_int) -> Fmu {
        let sink = Box::new(Sink::default());
        let callbacks = Box::new(CallbackFunctions {
            logger: Some(unsafe {
                std::mem::transmute::<
                    unsafe extern "C" fn(
                        *mut c_void,
                        *const c_char,
                        c_int,
                        *const c_char,
                        *const c_char,
                    ),
                    LoggerFn,
                >(logger)
            }),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: &*sink as *const Sink as *mut c_void,
        });
        let name = CString::new("train").unwrap();
        let guid = CString::new(GUID).unwrap();
        let c = unsafe {
            fmi2Instantiate(
                name.as_ptr(),
                fmu_type,
                guid.as_ptr(),
                std::ptr::null(),
                &*callbacks,
                0,
                1,
            )
        };
        assert!(!c.is_null());
        Fmu {
            c,
            sink,
            _callbacks: callbacks,
        }
    }

    fn set_real(&self, name: &str, x: f64) -> Status {
        unsafe { fmi2SetReal(self.c, &vr_of(name), 1, &x) }
    }
    fn set_int(&self, name: &str, x: i32) -> Status {
        unsafe { fmi2SetInteger(self.c, &vr_of(name), 1, &x) }
    }
    fn set_bool(&self, name: &str, x: bool) -> Status {
        unsafe { fmi2SetBoolean(self.c, &vr_of(name), 1, &(x as c_int)) }
    }
    /// A simple planetary set (scenes/train/planetary-simple.toml's gears, started from rest
    /// with the sun driven): sun body 1, carrier 2 with a drag load, planets 3-5, the ring fixed.
    fn planetary(&self) -> Status {
        let worst = std::cell::Cell::new(Status::Ok);
        let ok = |s: Status| {
            if s != Status::Ok && worst.get() == Status::Ok {
                worst.set(s);
            }
        };
        ok(self.set_int("n_bodies", 5));
        ok(self.set_int("n_shafts", 0));
        ok(self.set_int("n_meshes", 6));
        ok(self.set_real("body[1].J", 2e-3));
        ok(self.set_real("body[1].tau", 50.0));
        ok(self.set_real("body[2].J", 0.05));
        ok(self.set_real("body[2].c", 6.9));
        ok(self.set_real("body[4].tau", 0.0));
        for k in 0..3 {
            let (b, s, r) = (3 + k, 1 + k, 4 + k);
            ok(self.set_real(&format!("body[{b}].J"), 1e-4));
            ok(self.set_real(&format!("body[{b}].m"), 0.3));
            ok(self.set_int(&format!("body[{b}].carrier"), 2));
            ok(self.set_real(
                &format!("body[{b}].orbit_angle"),
                2.0 * std::f64::consts::PI * k as f64 / 3.0,
            ));
            for (m, a, bb, za, zb, xa, xb) in
                [(s, 1, b, 21, 18, 0.5, 0.0), (r, b, 0, 18, 57, 0.0, 0.5)]
            {
                let n = |v: &str| format!("mesh[{m}].{v}");
                ok(self.set_int(&n("A"), a));
                ok(self.set_int(&n("B"), bb));
                ok(self.set_int(&n("geometry"), 2));
                ok(self.set_real(&n("module"), 2e-3));
                ok(self.set_int(&n("zA"), za));
                ok(self.set_int(&n("zB"), zb));
                ok(self.set_real(&n("xA"), xa));
                ok(self.set_real(&n("xB"), xb));
                ok(self.set_real(&n("width"), 0.02));
                ok(self.set_real(&n("backlash"), 5e-5));
                ok(self.set_real(&n("chi"), 20.0));
                ok(self.set_bool(&n("internal"), m == r));
            }
        }
        worst.get()
    }
    /// The planetary set with a floating sun (lateral, no bearing: the three planets hold it)
    /// and the planets lateral on their pins (1e8 N/m, damped): 5 rotations and 8 translations.
    fn lateral_planetary(&self) -> Status {
        let mut worst = self.planetary();
        let mut ok = |s: Status| {
            if s != Status::Ok && worst == Status::Ok {
                worst = s;
            }
        };
        ok(self.set_bool("body[1].lateral", true));
        ok(self.set_real("body[1].m", 0.5));
        for b in 3..=5 {
            ok(self.set_bool(&format!("body[{b}].lateral"), true));
            for (key, x) in [("k_x", 1e8), ("k_y", 1e8), ("c_x", 550.0), ("c_y", 550.0)] {
                ok(self.set_real(&format!("body[{b}].{key}"), x));
            }
        }
        worst
    }
    fn real(&self, name: &str) -> f64 {
        let mut x = f64::NAN;
        assert_eq!(
            unsafe { fmi2GetReal(self.c, &vr_of(name), 1, &mut x) },
            Status::Ok
        );
        x
    }
    fn init(&self, stop: f64) -> Status {
        unsafe {
            assert_eq!(
                fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 1, stop),
                Status::Ok
            );
            assert_eq!(fmi2EnterInitializationMode(self.c), Status::Ok);
            fmi2ExitInitializationMode(self.c)
        }
    }
    fn step(&self, t: f64, h: f64) -> Status {
        unsafe { fmi2DoStep(self.c, t, h, 1) }
    }
    fn errors(&self) -> Vec<String> {
        let log = self.sink.0.lock().unwrap();
        log.iter()
            .filter(|(s, _)| *s == Status::Error as c_int)
            .map(|(_, m)| m.clone())
            .collect()
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

/// Each broken train is refused at fmi2ExitInitializationMode with fmi2Error, its message
/// naming the elements at fault.
#[test]
fn broken_trains_are_refused_with_the_elements_named() {
    type Setup = Box<dyn Fn(&Fmu)>;
    let cases: Vec<(&str, Setup, &str)> = vec![
        (
            "cycle",
            Box::new(|f: &Fmu| {
                f.set_int("n_meshes", 3);
                f.set_int("mesh[3].A", 4);
                f.set_int("mesh[3].B", 1);
            }),
            "the axes do not close: mesh[1], shaft[1] and mesh[3], mesh[2]",
        ),
        (
            "disconnected",
            Box::new(|f: &Fmu| {
                f.set_int("n_bodies", 5);
            }),
            "body[5]",
        ),
        (
            "index",
            Box::new(|f: &Fmu| {
                f.set_int("mesh[2].B", 6);
            }),
            "mesh[2].B = 6",
        ),
        (
            "A = B",
            Box::new(|f: &Fmu| {
                f.set_int("mesh[2].B", 3);
            }),
            "mesh[2]: A = B = 3",
        ),
        (
            "rigid",
            Box::new(|f: &Fmu| {
                f.set_int("mesh[1].contact_model", 2);
            }),
            "mesh[1].contact_model = 2",
        ),
        (
            "a mesh's geometry",
            Box::new(|f: &Fmu| {
                f.set_int("mesh[2].zA", 23);
            }),
            "mesh[2]:",
        ),
    ];
    for (what, setup, expected) in cases {
        let f = Fmu::new();
        setup(&f);
        assert_eq!(f.init(0.1), Status::Error, "{what}");
        let errors = f.errors();
        assert!(
            errors.iter().any(|e| e.contains(expected)),
            "{what}: {errors:?}"
        );
    }
    // A count above capacity and a NaN are refused when set, naming the variable.
    for (set, expected) in [
        (
            Box::new(|f: &Fmu| f.set_int("n_meshes", 17)) as Box<dyn Fn(&Fmu) -> Status>,
            "n_meshes = 17",
        ),
        (
            Box::new(|f: &Fmu| f.set_real("body[2].J", f64::NAN)),
            "body[2].J = NaN",
        ),
        (
            Box::new(|f: &Fmu| f.set_real("shaft[1].k", -1.0)),
            "shaft[1].k = -1",
        ),
    ] {
        let f = Fmu::new();
        assert_eq!(set(&f), Status::Error, "{expected}");
        let errors = f.errors().join("\n");
        assert!(errors.contains(expected), "{errors}");
    }
}

fn run_default(steps: usize) -> Vec<f64> {
    let f = Fmu::new();
    assert_eq!(f.init(1.0), Status::Ok);
    let h = 1e-4;
    let mut out = Vec::new();
    for k in 0..steps {
        assert_eq!(f.step(k as f64 * h, h), Status::Ok);
        out.extend(["mesh[1].dte", "mesh[2].dte", "shaft[1].tau", "body[4].w"].map(|n| f.real(n)));
    }
    out
}

/// On a late clock (t0 = 1e12 s, where the doubles are 1.2e-4 s apart) the train advances by the
/// represented interval and integrates in time since its start: the trajectory is the one from
/// 0 stepped by that interval, bit for bit ((t0 + k h_r) - t0 = k h_r exactly).
#[test]
fn a_late_clock_integrates_as_from_zero() {
    let (t0, h) = (1e12, 1e-4);
    let represented = (t0 + h) - t0;
    let run = |start: f64, step: f64, stepped: f64| {
        let f = Fmu::new();
        unsafe {
            assert_eq!(fmi2SetupExperiment(f.c, 0, 0.0, start, 0, 0.0), Status::Ok);
            assert_eq!(fmi2EnterInitializationMode(f.c), Status::Ok);
            assert_eq!(fmi2ExitInitializationMode(f.c), Status::Ok);
        }
        let mut t = start;
        for k in 0..50 {
            let s = f.step(t, step);
            assert!(s == Status::Ok || (k == 0 && s == Status::Warning), "{s:?}");
            t += stepped;
        }
        ["mesh[1].dte", "mesh[2].dte", "shaft[1].tau", "body[4].w"].map(|n| f.real(n).to_bits())
    };
    assert_eq!(run(t0, h, h), run(0.0, represented, represented));
}

/// The planetary set's meshes and bodies after each of `steps` steps.
fn run_planetary(steps: usize) -> Vec<f64> {
    run_set(Fmu::planetary, steps, &[])
}

/// The lateral planetary set's after each of `steps` steps, its translations and bearing
/// forces too.
fn run_lateral(steps: usize) -> Vec<f64> {
    let lateral = ["body[1].x", "body[3].y", "body[4].Fx", "housing.Fy"];
    run_set(Fmu::lateral_planetary, steps, &lateral)
}

/// The set `setup` makes, run for `steps` steps: its meshes, bodies and `more` after each.
fn run_set(setup: fn(&Fmu) -> Status, steps: usize, more: &[&str]) -> Vec<f64> {
    let f = Fmu::new();
    assert_eq!(setup(&f), Status::Ok, "{:?}", f.errors());
    assert_eq!(f.init(1.0), Status::Ok, "{:?}", f.errors());
    let h = 1e-4;
    let mut out = Vec::new();
    for k in 0..steps {
        assert_eq!(f.step(k as f64 * h, h), Status::Ok, "{:?}", f.errors());
        out.extend(
            [
                "mesh[1].dte",
                "mesh[3].dte",
                "mesh[6].F_fwd",
                "body[2].w",
                "housing.tau",
            ]
            .map(|n| f.real(n)),
        );
        out.extend(more.iter().map(|n| f.real(n)));
    }
    assert!(out.iter().all(|x| x.is_finite()));
    out
}

/// Instances share nothing: six on six threads, two each with the default train, a planetary
/// set and a lateral planetary set, give the sequential runs' numbers bit for bit.
#[test]
fn instances_on_threads_agree_bit_for_bit() {
    let runs: [fn() -> Vec<f64>; 3] = [
        || run_default(200),
        || run_planetary(100),
        || run_lateral(100),
    ];
    let sequential: Vec<Vec<f64>> = runs.iter().map(|r| r()).collect();
    let handles: Vec<_> = (0..6).map(|k| std::thread::spawn(runs[k % 3])).collect();
    for (k, h) in handles.into_iter().enumerate() {
        assert_eq!(h.join().unwrap(), sequential[k % 3], "set {}", k % 3);
    }
}

/// Moves `a`'s FMU state into `b` through its bytes; returns the bytes.
fn transfer_state(a: &Fmu, b: &Fmu) -> Vec<c_char> {
    unsafe {
        let mut s: *mut c_void = std::ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(a.c, &mut s), Status::Ok);
        let mut size = 0usize;
        assert_eq!(fmi2SerializedFMUstateSize(a.c, s, &mut size), Status::Ok);
        let mut bytes = vec![0 as c_char; size];
        assert_eq!(
            fmi2SerializeFMUstate(a.c, s, bytes.as_mut_ptr(), size),
            Status::Ok
        );
        let mut t: *mut c_void = std::ptr::null_mut();
        let st = fmi2DeSerializeFMUstate(b.c, bytes.as_ptr(), size, &mut t);
        assert_eq!(st, Status::Ok, "{:?}", b.errors());
        assert_eq!(fmi2SetFMUstate(b.c, t), Status::Ok);
        fmi2FreeFMUstate(a.c, &mut s);
        fmi2FreeFMUstate(b.c, &mut t);
        bytes
    }
}

/// `a` and `b` step on together from step `from` to `to`, bit for bit alike.
fn in_lockstep(a: &Fmu, b: &Fmu, from: usize, to: usize, h: f64) {
    for k in from..to {
        assert_eq!(a.step(k as f64 * h, h), Status::Ok, "{:?}", a.errors());
        assert_eq!(b.step(k as f64 * h, h), Status::Ok, "{:?}", b.errors());
        for n in ["mesh[1].dte", "mesh[2].F_fwd", "body[3].w", "E_el"] {
            assert_eq!(a.real(n).to_bits(), b.real(n).to_bits(), "{n} at step {k}");
        }
    }
}

/// An FMU state serialized, deserialized into another instance and set there continues exactly
/// as the original.
#[test]
fn fmu_states_round_trip_through_their_bytes() {
    let (a, b) = (Fmu::new(), Fmu::new());
    assert_eq!(a.init(1.0), Status::Ok);
    assert_eq!(b.init(1.0), Status::Ok);
    let h = 1e-4;
    for k in 0..50 {
        assert_eq!(a.step(k as f64 * h, h), Status::Ok);
    }
    let mut bytes = transfer_state(&a, &b);
    // A corrupted blob is refused (by a third instance: the failure is fmi2Error).
    let size = bytes.len();
    bytes[size / 2] ^= 0x55;
    let c = Fmu::new();
    let mut u: *mut c_void = std::ptr::null_mut();
    let st = unsafe { fmi2DeSerializeFMUstate(c.c, bytes.as_ptr(), size, &mut u) };
    assert_ne!(st, Status::Ok);
    in_lockstep(&a, &b, 50, 150, h);
}

/// The lateral planetary set under abuse: its FMU state continues bit for bit in another
/// instance (after a corrupted copy is refused), and bad lateral values are refused at
/// initialization naming the body and the value.
#[test]
fn a_lateral_planetary_set_survives_its_fmu_state_and_refuses_bad_values() {
    let (a, b) = (Fmu::new(), Fmu::new());
    for f in [&a, &b] {
        assert_eq!(f.lateral_planetary(), Status::Ok, "{:?}", f.errors());
        assert_eq!(f.init(1.0), Status::Ok, "{:?}", f.errors());
    }
    let h = 1e-4;
    for k in 0..50 {
        assert_eq!(a.step(k as f64 * h, h), Status::Ok, "{:?}", a.errors());
    }
    transfer_state(&a, &b);
    in_lockstep(&a, &b, 50, 120, h);
    assert_eq!(a.real("body[3].x").to_bits(), b.real("body[3].x").to_bits());
    for (key, x, want) in [
        ("body[3].k_x", -1e8, "-100000000"),
        ("body[4].c_y", -5.0, "-5"),
        ("body[1].m", 0.0, "body[1]"),
    ] {
        let f = Fmu::new();
        assert_eq!(f.lateral_planetary(), Status::Ok);
        let set = f.set_real(key, x);
        let status = if set == Status::Ok { f.init(1.0) } else { set };
        let body = &key[..key.find('.').unwrap()];
        assert_eq!(status, Status::Error, "{key} = {x}");
        let said = f.errors().join(" ");
        assert!(
            said.contains(body) && said.contains(want),
            "{key} = {x}: {said}"
        );
    }
}

/// A static start's state keeps the deflections it started from: set in an instance that
/// started under another drive torque, it continues exactly as the original (solving the
/// balance again from the state's inputs would start elsewhere).
#[test]
fn a_static_start_survives_its_fmu_state() {
    let (a, b) = (Fmu::new(), Fmu::new());
    for (fmu, tau) in [(&a, 100.0), (&b, 160.0)] {
        assert_eq!(fmu.set_bool("static_start", true), Status::Ok);
        assert_eq!(fmu.set_real("body[1].tau", tau), Status::Ok);
        assert_eq!(fmu.init(1.0), Status::Ok, "{:?}", fmu.errors());
    }
    let h = 1e-4;
    for k in 0..50 {
        assert_eq!(a.step(k as f64 * h, h), Status::Ok);
    }
    assert_eq!(a.set_real("body[1].tau", 130.0), Status::Ok);
    transfer_state(&a, &b);
    in_lockstep(&a, &b, 50, 150, h);
}

/// One call of a random sequence.
#[derive(Clone, Debug)]
enum Call {
    SetReal(&'static str, f64),
    SetInt(&'static str, i32),
    Init,
    Step(f64),
    Get(&'static str),
    Reset,
    /// Every parameter of a planetary set (`Fmu::planetary`).
    Planetary,
    /// The same with a floating sun and lateral planets (`Fmu::lateral_planetary`).
    LateralPlanetary,
}

fn call() -> impl Strategy<Value = Call> {
    let reals = prop::sample::select(vec![
        "body[1].J",
        "body[2].c",
        "body[1].tau",
        "body[4].tau",
        "shaft[1].k",
        "shaft[1].d",
        "mesh[1].chi",
        "mesh[2].mu",
        "mesh[1].backlash",
        "mesh[2].dte_start",
        "body[1].w_start",
        "mesh[2].center_angle",
        "body[3].k_x",
        "body[1].c_y",
        "body[4].m",
        "body[5].x_start",
    ]);
    let ints = prop::sample::select(vec![
        "n_bodies",
        "n_shafts",
        "n_meshes",
        "mesh[1].A",
        "mesh[2].B",
        "shaft[1].a",
        "mesh[1].contact_model",
        "mesh[2].zA",
        "solver",
    ]);
    let outputs = prop::sample::select(vec![
        "mesh[1].dte",
        "mesh[2].F_fwd",
        "shaft[1].tau",
        "body[3].w",
        "energy_residual",
        "mesh[6].dte",
        "body[8].theta",
        "housing.tau",
        "mesh[4].F_fwd",
        "body[3].x",
        "body[1].Fy",
        "housing.Fx",
        "mesh[1].delta_lat",
    ]);
    let value = prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(-1.0),
        Just(0.0),
        -1e3..1e3f64,
        1e-6..1e6f64,
    ];
    prop_oneof![
        (reals, value).prop_map(|(n, x)| Call::SetReal(n, x)),
        (ints, -2..10i32).prop_map(|(n, x)| Call::SetInt(n, x)),
        Just(Call::Init),
        prop_oneof![Just(-1e-4), Just(0.0), Just(f64::NAN), 1e-6..2e-3f64].prop_map(Call::Step),
        outputs.prop_map(Call::Get),
        Just(Call::Reset),
        Just(Call::Planetary),
        Just(Call::LateralPlanetary),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Whatever the sequence: statuses are Ok, Warning, Discard or Error, never a crash or a
    /// panic across the boundary, and a value read with fmi2OK is finite.
    #[test]
    fn random_call_sequences_never_crash(calls in prop::collection::vec(call(), 1..25)) {
        let f = Fmu::new();
        let mut t = 0.0;
        for c in calls {
            let status = match c {
                Call::SetReal(n, x) => f.set_real(n, x),
                Call::SetInt(n, x) => f.set_int(n, x),
                Call::Init => {
                    t = 0.0;
                    unsafe {
                        fmi2SetupExperiment(f.c, 0, 0.0, 0.0, 0, 0.0);
                        fmi2EnterInitializationMode(f.c);
                        fmi2ExitInitializationMode(f.c)
                    }
                }
                Call::Step(h) => {
                    let s = f.step(t, h);
                    if s == Status::Ok {
                        t += h;
                    }
                    s
                }
                Call::Get(n) => {
                    let mut x = 0.0;
                    let s = unsafe { fmi2GetReal(f.c, &vr_of(n), 1, &mut x) };
                    if s == Status::Ok {
                        prop_assert!(x.is_finite(), "{n} = {x}");
                    }
                    s
                }
                Call::Reset => {
                    t = 0.0;
                    unsafe { fmi2Reset(f.c) }
                }
                Call::Planetary => f.planetary(),
                Call::LateralPlanetary => f.lateral_planetary(),
            };
            prop_assert!(matches!(status, Status::Ok | Status::Warning | Status::Discard | Status::Error), "{status:?}");
        }
    }
}

// ---- Model Exchange -------------------------------------------------------------------------

use spur_gear_train::variables::{Var, N_DECLARED_STATES, N_EVENT_INDICATORS, STATES};

/// The states a master integrates: the first of the table's.
fn declared() -> &'static [(Var, Var)] {
    &STATES[..N_DECLARED_STATES]
}

/// An initialized Model Exchange instance of the default train, in continuous-time mode.
fn model_exchange() -> Fmu {
    model_exchange_of(None)
}

/// An instance in continuous-time mode: the default train, or the set `setup` makes.
fn model_exchange_of(setup: Option<fn(&Fmu) -> Status>) -> Fmu {
    let f = Fmu::of_type(0);
    if let Some(setup) = setup {
        assert_eq!(setup(&f), Status::Ok, "{:?}", f.errors());
    }
    assert_eq!(f.init(1.0), Status::Ok, "{:?}", f.errors());
    let mut info = fmi2_slave::EventInfo::default();
    unsafe {
        assert_eq!(fmi2NewDiscreteStates(f.c, &mut info), Status::Ok);
        assert_eq!(fmi2EnterContinuousTimeMode(f.c), Status::Ok);
    }
    f
}

impl Fmu {
    fn states(&self) -> Vec<f64> {
        let mut x = vec![f64::NAN; N_DECLARED_STATES];
        let st = unsafe { fmi2GetContinuousStates(self.c, x.as_mut_ptr(), x.len()) };
        assert_eq!(st, Status::Ok, "{:?}", self.errors());
        x
    }
    fn derivatives(&self) -> Vec<f64> {
        let mut dx = vec![f64::NAN; N_DECLARED_STATES];
        let st = unsafe { fmi2GetDerivatives(self.c, dx.as_mut_ptr(), dx.len()) };
        assert_eq!(st, Status::Ok, "{:?}", self.errors());
        dx
    }
}

/// The states are the table's state variables and the derivatives its derivative variables
/// (read back by name), elements not in use read 0 with rate 0, der(theta) is w, and the event
/// indicators and nominals have the declared sizes and are finite.
#[test]
fn model_exchange_states_are_the_variables_the_table_declares() {
    let f = model_exchange();
    let (x, dx) = (f.states(), f.derivatives());
    for (k, &(state, der)) in declared().iter().enumerate() {
        let (s, d) = (state.info().name, der.info().name);
        assert_eq!(f.real(s).to_bits(), x[k].to_bits(), "{s}");
        assert_eq!(f.real(d).to_bits(), dx[k].to_bits(), "{d}");
        // The default train: 4 bodies, so coordinates 1 to 4 in use.
        let unused = (5..=16).any(|k| s.starts_with(&format!("coordinate[{k}].")));
        if unused {
            assert!(
                x[k] == 0.0 && dx[k] == 0.0,
                "{s} = {}, {d} = {}",
                x[k],
                dx[k]
            );
        }
    }
    // The free body (body 1), then the meshes' dtes, then the shaft's twist.
    for (k, value, rate) in [
        (1, "body[1].theta", "body[1].w"),
        (2, "mesh[1].dte", "mesh[1].dte_rate"),
        (3, "mesh[2].dte", "mesh[2].dte_rate"),
        (4, "shaft[1].twist", "shaft[1].twist_rate"),
    ] {
        assert_eq!(
            f.real(&format!("coordinate[{k}].value")),
            f.real(value),
            "{value}"
        );
        assert_eq!(
            f.real(&format!("coordinate[{k}].rate")),
            f.real(rate),
            "{rate}"
        );
        assert_eq!(
            f.real(&format!("der(coordinate[{k}].value)")),
            f.real(rate),
            "{rate}"
        );
    }
    // The twist state starts at the shaft's twist_start.
    assert_eq!(f.real("shaft[1].twist"), f.real("shaft[1].twist_start"));
    let w = |i: usize| f.real(&format!("body[{i}].w"));
    assert_eq!(f.real("shaft[1].twist_rate"), w(2) - w(3));
    let mut z = vec![f64::NAN; N_EVENT_INDICATORS];
    let mut n = vec![f64::NAN; N_DECLARED_STATES];
    unsafe {
        assert_eq!(
            fmi2GetEventIndicators(f.c, z.as_mut_ptr(), z.len()),
            Status::Ok
        );
        assert_eq!(
            fmi2GetNominalsOfContinuousStates(f.c, n.as_mut_ptr(), n.len()),
            Status::Ok
        );
    }
    assert!(z.iter().all(|v| v.is_finite()));
    assert!(n.iter().all(|v| v.is_finite() && *v > 0.0), "{n:?}");
    // The dte's nominal is its static penetration: micrometres, not 1.
    let dte1 = declared()
        .iter()
        .position(|s| s.0.info().name == "coordinate[2].value")
        .unwrap();
    assert!(n[dte1] > 1e-8 && n[dte1] < 1e-4, "{}", n[dte1]);
}

/// Wrong sizes, non-finite states and Co-Simulation calls are refused with fmi2Error and a
/// message naming the argument; nothing crashes.
#[test]
fn model_exchange_refuses_bad_input() {
    let f = model_exchange();
    let mut x = f.states();
    unsafe {
        assert_eq!(fmi2SetContinuousStates(f.c, x.as_ptr(), 3), Status::Error);
    }
    assert!(
        f.errors().iter().any(|m| m.contains("nx = 3")),
        "{:?}",
        f.errors()
    );
    let f = model_exchange();
    x[5] = f64::NAN;
    unsafe {
        assert_eq!(
            fmi2SetContinuousStates(f.c, x.as_ptr(), x.len()),
            Status::Error
        );
    }
    assert!(
        f.errors().iter().any(|m| m.contains("x[5] = NaN")),
        "{:?}",
        f.errors()
    );
    let f = model_exchange();
    assert_eq!(f.step(0.0, 1e-4), Status::Error);
    assert!(
        f.errors().iter().any(|m| m.contains("fmi2DoStep")),
        "{:?}",
        f.errors()
    );
}

/// An FMU state of a Model Exchange instance, serialized and set in another, gives the same
/// derivatives bit for bit after the same state changes.
#[test]
fn model_exchange_fmu_states_round_trip() {
    let (a, b) = (model_exchange(), model_exchange());
    let mut x = a.states();
    let dx = a.derivatives();
    for (xi, di) in x.iter_mut().zip(&dx) {
        *xi += 1e-5 * di;
    }
    unsafe {
        assert_eq!(fmi2SetTime(a.c, 1e-5), Status::Ok);
        assert_eq!(
            fmi2SetContinuousStates(a.c, x.as_ptr(), x.len()),
            Status::Ok
        );
        let (mut enter, mut stop) = (0, 0);
        assert_eq!(
            fmi2CompletedIntegratorStep(a.c, 1, &mut enter, &mut stop),
            Status::Ok
        );
        let mut s: *mut c_void = std::ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(a.c, &mut s), Status::Ok);
        let mut size = 0usize;
        assert_eq!(fmi2SerializedFMUstateSize(a.c, s, &mut size), Status::Ok);
        let mut bytes = vec![0 as c_char; size];
        assert_eq!(
            fmi2SerializeFMUstate(a.c, s, bytes.as_mut_ptr(), size),
            Status::Ok
        );
        let mut t: *mut c_void = std::ptr::null_mut();
        let st = fmi2DeSerializeFMUstate(b.c, bytes.as_ptr(), size, &mut t);
        assert_eq!(st, Status::Ok, "{:?}", b.errors());
        assert_eq!(fmi2SetFMUstate(b.c, t), Status::Ok, "{:?}", b.errors());
        fmi2FreeFMUstate(a.c, &mut s);
        fmi2FreeFMUstate(b.c, &mut t);
    }
    let bits = |v: Vec<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(a.states()), bits(b.states()));
    assert_eq!(bits(a.derivatives()), bits(b.derivatives()));
    for n in ["mesh[2].F_fwd", "shaft[1].tau", "E_el", "mesh[1].dte_mean"] {
        assert_eq!(a.real(n).to_bits(), b.real(n).to_bits(), "{n}");
    }
}

/// One call of a random Model Exchange sequence.
#[derive(Clone, Debug)]
enum MeCall {
    SetTime(f64),
    /// Sets state k to x (the others as they are).
    SetState(usize, f64),
    /// Scales state k by 1 + r (a master's small correction).
    Nudge(usize, f64),
    /// Moves every state along its derivative by h (an explicit Euler step).
    Euler(f64),
    Derivatives,
    Indicators,
    Nominals,
    EnterEventMode,
    NewDiscreteStates,
    EnterContinuousTimeMode,
    Completed,
    SetReal(&'static str, f64),
    Get(&'static str),
}

fn me_call() -> impl Strategy<Value = MeCall> {
    let value = prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(1e300),
        Just(-1e300),
        Just(0.0),
        -1e-3..1e-3f64,
        -1e3..1e3f64,
    ];
    let settable = prop::sample::select(vec![
        "body[1].tau",
        "body[4].tau",
        "mesh[1].chi",
        "mesh[2].mu",
    ]);
    let outputs = prop::sample::select(vec![
        "mesh[1].dte",
        "mesh[2].F_fwd",
        "shaft[1].twist",
        "der(coordinate[2].rate)",
        "der(coordinate[1].rate)",
        "energy_residual",
        "mesh[1].dte_mean",
    ]);
    // Mostly the calls of a working master, now and then a hostile one: an instance is done
    // after its first fmi2Error.
    let others = prop_oneof![
        Just(MeCall::Derivatives),
        Just(MeCall::Indicators),
        Just(MeCall::Nominals),
        Just(MeCall::EnterEventMode),
        Just(MeCall::NewDiscreteStates),
        Just(MeCall::EnterContinuousTimeMode),
        (settable, value.clone()).prop_map(|(n, x)| MeCall::SetReal(n, x)),
        outputs.prop_map(MeCall::Get),
    ];
    prop_oneof![
        1 => prop_oneof![Just(f64::NAN), Just(-1.0), 0.0..0.01f64].prop_map(MeCall::SetTime),
        1 => (0..N_DECLARED_STATES, value).prop_map(|(k, x)| MeCall::SetState(k, x)),
        4 => (0..N_DECLARED_STATES, -1e-3..1e-3f64).prop_map(|(k, r)| MeCall::Nudge(k, r)),
        8 => prop_oneof![9 => 1e-7..2e-6f64, 1 => Just(1e-2)].prop_map(MeCall::Euler),
        2 => Just(MeCall::Completed),
        6 => others,
    ]
}

/// Whether a status is one of those a call may return, and an array read with fmi2OK is finite.
fn finite_if_ok(status: Status, values: &[f64]) -> bool {
    status != Status::Ok || values.iter().all(|v| v.is_finite())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Model Exchange, whatever states, times and calls a master sends: never a crash or a
    /// panic across the boundary, and nothing read with fmi2OK is NaN or infinite.
    #[test]
    fn random_model_exchange_sequences_never_crash(
        set in prop::sample::select(vec![None, Some(Fmu::planetary as fn(&Fmu) -> Status), Some(Fmu::lateral_planetary)]),
        calls in prop::collection::vec(me_call(), 1..60),
    ) {
        let f = model_exchange_of(set);
        let n = N_DECLARED_STATES;
        let mut t = 0.0;
        for c in calls {
            let status = unsafe {
                match c {
                    MeCall::SetTime(x) => {
                        let s = fmi2SetTime(f.c, x);
                        if s == Status::Ok {
                            t = x;
                        }
                        s
                    }
                    MeCall::SetState(k, _) | MeCall::Nudge(k, _) => {
                        let mut v = vec![0.0; n];
                        let s = fmi2GetContinuousStates(f.c, v.as_mut_ptr(), n);
                        v[k] = match c {
                            MeCall::Nudge(_, r) => v[k] * (1.0 + r),
                            MeCall::SetState(_, x) => x,
                            _ => unreachable!(),
                        };
                        if s == Status::Ok { fmi2SetContinuousStates(f.c, v.as_ptr(), n) } else { s }
                    }
                    MeCall::Euler(h) => {
                        let (mut x, mut dx) = (vec![0.0; n], vec![0.0; n]);
                        let s = fmi2GetContinuousStates(f.c, x.as_mut_ptr(), n);
                        let d = fmi2GetDerivatives(f.c, dx.as_mut_ptr(), n);
                        prop_assert!(finite_if_ok(d, &dx), "derivatives {dx:?}");
                        if s == Status::Ok && d == Status::Ok {
                            for (xi, di) in x.iter_mut().zip(&dx) {
                                *xi += h * di;
                            }
                            t += h;
                            fmi2SetTime(f.c, t);
                            fmi2SetContinuousStates(f.c, x.as_ptr(), n)
                        } else {
                            d
                        }
                    }
                    MeCall::Derivatives => {
                        let mut dx = vec![0.0; n];
                        let s = fmi2GetDerivatives(f.c, dx.as_mut_ptr(), n);
                        prop_assert!(finite_if_ok(s, &dx), "derivatives {dx:?}");
                        s
                    }
                    MeCall::Indicators => {
                        let mut z = vec![0.0; N_EVENT_INDICATORS];
                        let s = fmi2GetEventIndicators(f.c, z.as_mut_ptr(), z.len());
                        prop_assert!(finite_if_ok(s, &z), "indicators");
                        s
                    }
                    MeCall::Nominals => {
                        let mut v = vec![0.0; n];
                        let s = fmi2GetNominalsOfContinuousStates(f.c, v.as_mut_ptr(), n);
                        prop_assert!(finite_if_ok(s, &v), "nominals {v:?}");
                        s
                    }
                    MeCall::EnterEventMode => fmi2EnterEventMode(f.c),
                    MeCall::NewDiscreteStates => {
                        let mut info = fmi2_slave::EventInfo::default();
                        fmi2NewDiscreteStates(f.c, &mut info)
                    }
                    MeCall::EnterContinuousTimeMode => fmi2EnterContinuousTimeMode(f.c),
                    MeCall::Completed => {
                        let (mut enter, mut stop) = (0, 0);
                        fmi2CompletedIntegratorStep(f.c, 1, &mut enter, &mut stop)
                    }
                    MeCall::SetReal(name, x) => f.set_real(name, x),
                    MeCall::Get(name) => {
                        let mut x = 0.0;
                        let s = fmi2GetReal(f.c, &vr_of(name), 1, &mut x);
                        prop_assert!(finite_if_ok(s, &[x]), "{name} = {x}");
                        s
                    }
                }
            };
            prop_assert!(matches!(status, Status::Ok | Status::Warning | Status::Discard | Status::Error), "{status:?}");
        }
    }
}
