//! Fuzzer of FMI call sequences (issue 5, part 1).
//!
//! A property-based test (proptest) that drives the exported fmi2* functions -- the very symbols of
//! the .so, called in-process through the rlib -- with random call sequences on two instances:
//! every function of FMI 2.0 in any state, valid and invalid value references, NaN, infinite, huge
//! and tiny values and step sizes, null pointers where the standard allows them (and some where it
//! does not but a check is cheap), bogus FMU-state pointers (random integers, freed states, states
//! of the other instance) and serialized states that are valid, truncated, bit-flipped, of another
//! format version or GUID, extended, random, or edited with a recomputed checksum.
//!
//! A model of the FMI 2.0 Co-Simulation state machine runs beside the FMU and checks every call:
//!  * a call the standard allows either succeeds with the specified effect (state transition, time
//!    advanced by exactly the step size, FMU state stored/restored/freed) or returns fmi2Error or
//!    fmi2Discard; arguments that are certainly invalid must give fmi2Error;
//!  * a call the standard does not allow in the current state returns fmi2Error;
//!  * every fmi2Error / fmi2Discard comes with a message through the logger, in the category
//!    logStatusError / logStatusDiscard (unless the master switched that category off);
//!  * after fmi2Error the instance is in its previous state or in the error state; after a failed
//!    fmi2DoStep the time and every output are unchanged; fmi2Discard from fmi2DoStep leads to
//!    stepFailed;
//!  * fmi2GetReal never returns NaN or an infinity with fmi2OK, nor does fmi2GetRealStatus;
//!  * no panic reaches the boundary (the FMU reports a caught panic as an internal error: that
//!    counts as a failure here), no call takes more than CALL_LIMIT, nothing hangs (a watchdog
//!    aborts the process after HANG_LIMIT without progress).
//!
//! The FMI state of an instance is read back after every call from its own serialized FMU state
//! (header, then the state word that starts the payload: src/fmi/fmu_state.rs), so the model is
//! checked against the instance, not merely against return codes.
//!
//! Runs: `cargo test --release --test fmi_fuzz` is the bounded, deterministic CI pass: a fixed
//! seed, FMI_FUZZ_CASES cases (default 50000, about 1 ms each) within FMI_FUZZ_SECONDS (default
//! 40; later cases are not run). Longer campaigns, e.g. 10 minutes from a random seed:
//! `FMI_FUZZ_CASES=1000000 FMI_FUZZ_SECONDS=600 FMI_FUZZ_SEED=random \
//!  cargo test --release --test fmi_fuzz -- --nocapture` (tools/fuzz.sh). Instances restored
//! from hostile blobs are held to the same invariants (see `strict`); FMI_FUZZ_TRACE=1 prints
//! every call.
//! A failure is shrunk to a minimal call sequence, printed, and its seed is appended to
//! tests/fmi_fuzz.proptest-regressions (replayed first on every run; commit it). Sequences worth
//! keeping in readable form go into `corpus()` below, which runs before the random cases.

mod fmi_support;

use fmi_support::ffi::*;
use fmi_support::*;
use proptest::prelude::*;
use proptest::test_runner::{
    Config, FileFailurePersistence, RngAlgorithm, TestCaseError, TestError, TestRng, TestRunner,
};
use spur_gear_mesh::variables::{
    Causality, Inputs, Params, VarInfo, VarType, Variability, GUID, LOG_CATEGORIES, VARIABLES,
};
use std::collections::BTreeMap;
use std::ffi::CString;
use std::os::raw::{c_char, c_int, c_void};
use std::ptr::null_mut;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// The invariants (finite values, bounded time of a step) also for instances set from a hostile
/// blob (a payload edited with a recomputed checksum): the FMU validates decoded values. Set
/// FMI_FUZZ_STRICT=0 to check such instances only for crashes, panics, hangs, the state
/// machine and logging only, and are not stepped.
fn strict() -> bool {
    static S: OnceLock<bool> = OnceLock::new();
    *S.get_or_init(|| std::env::var_os("FMI_FUZZ_STRICT").is_none_or(|v| v != "0"))
}

/// A single call taking longer than this fails the property.
const CALL_LIMIT: Duration = Duration::from_secs(20);
/// No progress for this long: the watchdog prints the running call and aborts.
const HANG_LIMIT: Duration = Duration::from_secs(120);
/// Steps that would simulate more than this are skipped (legitimate work, only slow).
const MAX_SPAN: f64 = 0.05;

// ---- the standard's state table (FMI 2.0, section 4.2.4; Co-Simulation) -----------------------

const INST: u32 = FmiState::Instantiated as u32;
const INIT: u32 = FmiState::InitializationMode as u32;
const DONE: u32 = FmiState::StepComplete as u32;
const FAIL: u32 = FmiState::StepFailed as u32;
const TERM: u32 = FmiState::Terminated as u32;
const ERR: u32 = FmiState::Error as u32;
const GET: u32 = INIT | DONE | FAIL | TERM | ERR;
const SET: u32 = INST | INIT | DONE;
const STATUS: u32 = DONE | FAIL | TERM;

fn bit(s: FmiState) -> u32 {
    s as u32
}

/// What the model knows of an instance (or of an FMU state it handed out).
#[derive(Clone, Debug, PartialEq)]
struct Model {
    st: FmiState,
    t: f64,
    start: f64,
    stop: Option<f64>,
    /// False after a state of unknown content (a blob edited with a fixed checksum) was set:
    /// the state machine is then read from the instance and only the invariants are checked.
    known: bool,
}

impl Model {
    fn fresh() -> Model {
        Model {
            st: FmiState::Instantiated,
            t: 0.0,
            start: 0.0,
            stop: None,
            known: true,
        }
    }
}

// ---- operations -------------------------------------------------------------------------------

#[derive(Clone, Debug)]
enum How {
    Valid,
    NullName,
    EmptyName,
    ModelExchange,
    BadType(i32),
    WrongGuid,
    NullGuid,
    NullFunctions,
    NullLogger,
    NullResource,
}

#[derive(Clone, Debug)]
enum Cat {
    Known(usize),
    Unknown(String),
    Null,
}

#[derive(Clone, Debug)]
enum Cats {
    /// nCategories = 0, categories = NULL: all categories.
    All,
    /// nCategories > 0 with a null array.
    NullArray(usize),
    List(Vec<Cat>),
}

/// A value reference: a variable of the call's type (settable ones for set calls), any variable,
/// or a raw number (mostly unknown).
#[derive(Clone, Debug)]
enum Vr {
    Typed(usize),
    Any(usize),
    Raw(u32),
}

#[derive(Clone, Debug)]
enum Real {
    /// Scaled within the variable's plausible range.
    Plausible(f64),
    Special(f64),
}

#[derive(Clone, Debug)]
enum Int {
    Plausible(i32),
    Special(i32),
}

#[derive(Clone, Debug)]
enum Cur {
    Exact,
    Rel(f64),
    Raw(f64),
}

#[derive(Clone, Debug)]
enum StateArg {
    /// The fmi2FMUstate* argument itself is NULL.
    NullPtr,
    /// *FMUstate == NULL.
    NullValue,
    Own(usize),
    Freed(usize),
    Other(usize),
    Bogus(u64),
}

#[derive(Clone, Debug)]
enum Buf {
    Exact,
    Short(usize),
    Long(usize),
    Null,
}

#[derive(Clone, Debug)]
enum Blob {
    Valid(usize),
    Truncate(usize, usize),
    FlipBit(usize, usize),
    Version(usize, u32),
    Guid(usize, usize, u8),
    Extend(usize, Vec<u8>),
    /// Replaces a 64-bit word of the payload and recomputes the checksum: a hostile blob that
    /// passes the integrity checks.
    Word(usize, usize, u64),
    Garbage(Vec<u8>),
    NullPtr(usize),
    Empty,
}

#[derive(Clone, Debug)]
enum Op {
    Instantiate(u8, How, bool),
    FreeInstance(u8),
    NullComponent(u8),
    SetDebugLogging(u8, bool, Cats),
    SetupExperiment(u8, Option<f64>, f64, Option<f64>),
    EnterInit(u8),
    ExitInit(u8),
    Terminate(u8),
    Reset(u8),
    /// Reset, the paper scene's parameters (with the ring pair on top when the flag is set:
    /// an internal pair), setup (optional stop time), initialization.
    PaperScene(u8, i32, Option<f64>, bool),
    SetReal(u8, Vec<(Vr, Real)>, bool),
    SetInteger(u8, Vec<(Vr, Int)>, bool),
    SetBoolean(u8, Vec<(Vr, i32)>, bool),
    SetString(u8, Vec<Vr>),
    GetReal(u8, Vec<Vr>, bool),
    GetInteger(u8, Vec<Vr>, bool),
    GetBoolean(u8, Vec<Vr>, bool),
    GetString(u8, Vec<Vr>),
    DoStep(u8, Cur, f64),
    /// Several ordinary steps (1e-4 s), to get deep into a run.
    Steps(u8, u8),
    CancelStep(u8),
    Status(u8, u8, i32, bool),
    GetState(u8, StateArg),
    SetState(u8, StateArg),
    FreeState(u8, StateArg),
    StateSize(u8, StateArg, bool),
    Serialize(u8, StateArg, Buf),
    Deserialize(u8, Blob, StateArg),
    Unsupported(u8, u8),
}

// ---- strategies ----------------------------------------------------------------------------

fn special_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(-f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(0.0),
        Just(-0.0),
        Just(f64::MAX),
        Just(f64::MIN),
        Just(f64::MIN_POSITIVE),
        Just(5e-324),
        Just(1e300),
        Just(-1e300),
        Just(1e-300),
        Just(-1.0),
        Just(1.0),
        Just(1e9),
        any::<f64>(),
    ]
}

fn special_i32() -> impl Strategy<Value = i32> {
    prop_oneof![
        Just(0),
        Just(-1),
        Just(1),
        Just(2),
        Just(3),
        Just(i32::MIN),
        Just(i32::MAX),
        Just(1_000_000),
        any::<i32>(),
    ]
}

fn vr() -> impl Strategy<Value = Vr> {
    prop_oneof![
        6 => (0usize..64).prop_map(Vr::Typed),
        2 => (0usize..VARIABLES.len()).prop_map(Vr::Any),
        1 => prop_oneof![
            Just(0u32), Just(32), Just(39), Just(42), Just(77), Just(79), Just(91), Just(1000),
            Just(u32::MAX), any::<u32>()
        ].prop_map(Vr::Raw),
    ]
}

fn real() -> impl Strategy<Value = Real> {
    prop_oneof![3 => (0.0..1.0f64).prop_map(Real::Plausible), 1 => special_f64().prop_map(Real::Special)]
}

fn int() -> impl Strategy<Value = Int> {
    prop_oneof![3 => (-2i32..=2).prop_map(Int::Plausible), 1 => special_i32().prop_map(Int::Special)]
}

fn state_arg() -> impl Strategy<Value = StateArg> {
    prop_oneof![
        1 => Just(StateArg::NullPtr),
        3 => Just(StateArg::NullValue),
        5 => (0usize..8).prop_map(StateArg::Own),
        2 => (0usize..8).prop_map(StateArg::Freed),
        2 => (0usize..8).prop_map(StateArg::Other),
        2 => prop_oneof![Just(1u64), Just(8), Just(0xdead_beef), Just(u64::MAX), any::<u64>()]
            .prop_map(StateArg::Bogus),
    ]
}

fn blob() -> impl Strategy<Value = Blob> {
    let i = 0usize..16;
    prop_oneof![
        4 => i.clone().prop_map(Blob::Valid),
        2 => (i.clone(), any::<usize>()).prop_map(|(b, k)| Blob::Truncate(b, k)),
        2 => (i.clone(), any::<usize>()).prop_map(|(b, k)| Blob::FlipBit(b, k)),
        1 => (i.clone(), prop_oneof![Just(0u32), Just(1), Just(u32::MAX), any::<u32>()])
            .prop_map(|(b, v)| Blob::Version(b, v)),
        1 => (i.clone(), any::<usize>(), 1u8..=255).prop_map(|(b, k, x)| Blob::Guid(b, k, x)),
        1 => (i.clone(), prop::collection::vec(any::<u8>(), 1..16)).prop_map(|(b, v)| Blob::Extend(b, v)),
        3 => (i.clone(), any::<usize>(), prop_oneof![
                Just(f64::NAN.to_bits()), Just(f64::INFINITY.to_bits()), Just((-1.0f64).to_bits()),
                Just(0u64), Just(1u64), Just(2u64), Just(4u64), Just(u64::MAX), Just(1e300f64.to_bits()),
                any::<u64>()
            ]).prop_map(|(b, k, x)| Blob::Word(b, k, x)),
        1 => prop::collection::vec(any::<u8>(), 0..200).prop_map(Blob::Garbage),
        1 => (1usize..100).prop_map(Blob::NullPtr),
        1 => Just(Blob::Empty),
    ]
}

fn how() -> impl Strategy<Value = How> {
    prop_oneof![
        4 => Just(How::Valid),
        1 => Just(How::NullName),
        1 => Just(How::EmptyName),
        1 => Just(How::ModelExchange),
        1 => special_i32().prop_map(How::BadType),
        1 => Just(How::WrongGuid),
        1 => Just(How::NullGuid),
        1 => Just(How::NullFunctions),
        1 => Just(How::NullLogger),
        1 => Just(How::NullResource),
    ]
}

fn cats() -> impl Strategy<Value = Cats> {
    let cat = prop_oneof![
        4 => (0usize..LOG_CATEGORIES.len()).prop_map(Cat::Known),
        1 => prop_oneof![Just("logAll".to_string()), Just("".to_string()), Just("logStatusError ".to_string()),
                         Just("%s%n%%".to_string()), "[a-zA-Z]{1,12}"].prop_map(Cat::Unknown),
        1 => Just(Cat::Null),
    ];
    prop_oneof![
        2 => Just(Cats::All),
        1 => (1usize..4).prop_map(Cats::NullArray),
        4 => prop::collection::vec(cat, 1..4).prop_map(Cats::List),
    ]
}

fn step_size() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => (-6.0..-3.0f64).prop_map(|e| 10f64.powf(e)),
        1 => (-3.0..0.0f64).prop_map(|e| 10f64.powf(e)),
        3 => special_f64(),
    ]
}

fn cur() -> impl Strategy<Value = Cur> {
    prop_oneof![
        8 => Just(Cur::Exact),
        1 => prop_oneof![Just(1e-12), Just(-1e-12), Just(5e-10), Just(2e-9), Just(-2e-9), Just(1e-3)].prop_map(Cur::Rel),
        1 => special_f64().prop_map(Cur::Raw),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    let s = 0u8..2;
    let few = |st| prop::collection::vec(st, 0..4);
    prop_oneof![
        2 => (s.clone(), how(), any::<bool>()).prop_map(|(s, h, l)| Op::Instantiate(s, h, l)),
        1 => s.clone().prop_map(Op::FreeInstance),
        1 => any::<u8>().prop_map(Op::NullComponent),
        2 => (s.clone(), any::<bool>(), cats()).prop_map(|(s, on, c)| Op::SetDebugLogging(s, on, c)),
        3 => (s.clone(), prop::option::of(special_f64()), prop_oneof![3 => Just(0.0), 1 => special_f64()],
              prop::option::of(prop_oneof![2 => 0.0..1.0f64, 1 => special_f64()]))
            .prop_map(|(s, tol, t0, t1)| Op::SetupExperiment(s, tol, t0, t1)),
        4 => s.clone().prop_map(Op::EnterInit),
        4 => s.clone().prop_map(Op::ExitInit),
        1 => s.clone().prop_map(Op::Terminate),
        2 => s.clone().prop_map(Op::Reset),
        4 => (s.clone(), 1i32..=3, prop::option::of(prop_oneof![Just(0.01), Just(0.1), Just(1.0)]),
              prop::bool::weighted(0.3))
            .prop_map(|(s, solver, stop, ring)| Op::PaperScene(s, solver, stop, ring)),
        6 => (s.clone(), prop::collection::vec((vr(), real()), 0..4), prop::bool::weighted(0.05))
            .prop_map(|(s, v, n)| Op::SetReal(s, v, n)),
        2 => (s.clone(), prop::collection::vec((vr(), int()), 0..3), prop::bool::weighted(0.05))
            .prop_map(|(s, v, n)| Op::SetInteger(s, v, n)),
        1 => (s.clone(), prop::collection::vec((vr(), special_i32()), 0..3), prop::bool::weighted(0.05))
            .prop_map(|(s, v, n)| Op::SetBoolean(s, v, n)),
        1 => (s.clone(), few(vr())).prop_map(|(s, v)| Op::SetString(s, v)),
        5 => (s.clone(), prop::collection::vec(vr(), 0..8), prop::bool::weighted(0.05))
            .prop_map(|(s, v, n)| Op::GetReal(s, v, n)),
        1 => (s.clone(), few(vr()), prop::bool::weighted(0.05)).prop_map(|(s, v, n)| Op::GetInteger(s, v, n)),
        1 => (s.clone(), few(vr()), prop::bool::weighted(0.05)).prop_map(|(s, v, n)| Op::GetBoolean(s, v, n)),
        1 => (s.clone(), few(vr())).prop_map(|(s, v)| Op::GetString(s, v)),
        10 => (s.clone(), cur(), step_size()).prop_map(|(s, c, h)| Op::DoStep(s, c, h)),
        4 => (s.clone(), 1u8..50).prop_map(|(s, n)| Op::Steps(s, n)),
        1 => s.clone().prop_map(Op::CancelStep),
        2 => (s.clone(), 0u8..5, prop_oneof![4 => 0i32..4, 1 => special_i32()], prop::bool::weighted(0.1))
            .prop_map(|(s, f, k, n)| Op::Status(s, f, k, n)),
        4 => (s.clone(), state_arg()).prop_map(|(s, a)| Op::GetState(s, a)),
        4 => (s.clone(), state_arg()).prop_map(|(s, a)| Op::SetState(s, a)),
        3 => (s.clone(), state_arg()).prop_map(|(s, a)| Op::FreeState(s, a)),
        1 => (s.clone(), state_arg(), prop::bool::weighted(0.1)).prop_map(|(s, a, n)| Op::StateSize(s, a, n)),
        3 => (s.clone(), state_arg(), prop_oneof![4 => Just(Buf::Exact), 1 => (1usize..64).prop_map(Buf::Short),
                                                  1 => (1usize..64).prop_map(Buf::Long), 1 => Just(Buf::Null)])
            .prop_map(|(s, a, b)| Op::Serialize(s, a, b)),
        4 => (s.clone(), blob(), state_arg()).prop_map(|(s, b, a)| Op::Deserialize(s, b, a)),
        1 => (s, 0u8..13).prop_map(|(s, f)| Op::Unsupported(s, f)),
    ]
}

fn sequence() -> impl Strategy<Value = Vec<Op>> {
    prop::collection::vec(op(), 1..40)
}

// ---- the harness --------------------------------------------------------------------------

/// One instance under test with its model.
struct Slot {
    fmu: Fmu,
    name: String,
    m: Model,
    /// FMU states this instance handed out (pointer -> what they hold).
    live: BTreeMap<usize, Model>,
    freed: Vec<usize>,
    /// Logging categories switched on (the FMU's defaults: debug ones follow loggingOn,
    /// status ones are on).
    cats: [bool; 6],
    can_log: bool,
}

const CAT_DISCARD: usize = 3;
const CAT_ERROR: usize = 4;

#[derive(Default)]
struct Stats {
    calls: BTreeMap<String, [u64; 4]>,
    skipped: u64,
    max_call: (Duration, String),
    steps_ok: u64,
    states_seen: BTreeMap<String, u64>,
    hostile_accepted: u64,
}

static STATS: OnceLock<Mutex<Stats>> = OnceLock::new();
fn stats() -> std::sync::MutexGuard<'static, Stats> {
    STATS.get_or_init(Default::default).lock().unwrap()
}

static HEARTBEAT: AtomicU64 = AtomicU64::new(0);
static CURRENT: Mutex<String> = Mutex::new(String::new());

fn now_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64
}

fn start_watchdog() {
    static STARTED: OnceLock<()> = OnceLock::new();
    STARTED.get_or_init(|| {
        HEARTBEAT.store(now_ms(), Ordering::SeqCst);
        std::thread::spawn(|| loop {
            std::thread::sleep(Duration::from_secs(1));
            let quiet = now_ms().saturating_sub(HEARTBEAT.load(Ordering::SeqCst));
            if quiet > HANG_LIMIT.as_millis() as u64 {
                eprintln!(
                    "fmi_fuzz watchdog: no progress for {quiet} ms; the running call: {}",
                    CURRENT.lock().map(|s| s.clone()).unwrap_or_default()
                );
                std::process::abort();
            }
        });
    });
}

macro_rules! check {
    ($cond:expr, $($fmt:tt)*) => {
        if !$cond {
            return Err(TestCaseError::fail(format!($($fmt)*)));
        }
    };
}

type R = Result<(), TestCaseError>;

/// The paper-scene blob after 100 steps: a deep running state for the blob pool.
fn running_blob() -> &'static (Vec<u8>, Model) {
    static B: OnceLock<(Vec<u8>, Model)> = OnceLock::new();
    B.get_or_init(|| {
        let f = paper_scene("blob-source");
        let mut t = 0.0;
        for _ in 0..100 {
            assert!(ok(f.do_step(t, 1e-4)));
            t += 1e-4;
        }
        let s = f.get_state();
        let b = f.serialize(s);
        f.free_state(s);
        let m = Model {
            st: FmiState::StepComplete,
            t,
            ..Model::fresh()
        };
        (b, m)
    })
}

struct Harness {
    slots: [Option<Slot>; 2],
    blobs: Vec<(Vec<u8>, Model)>,
    names: u64,
    /// Log records of the call under test, taken right after it (helper calls come later).
    captured: Vec<Record>,
}

fn settable(info: &VarInfo) -> bool {
    matches!(info.causality, Causality::Parameter | Causality::Input)
}

fn vars_of(ty: VarType, set: bool) -> Vec<&'static VarInfo> {
    VARIABLES
        .iter()
        .filter(|v| v.ty == ty && (!set || settable(v)))
        .collect()
}

fn resolve_vr(v: &Vr, ty: VarType, set: bool) -> u32 {
    match *v {
        Vr::Typed(i) => {
            let l = vars_of(ty, set);
            l[i % l.len()].vr
        }
        Vr::Any(i) => VARIABLES[i % VARIABLES.len()].vr,
        Vr::Raw(x) => x,
    }
}

fn info(vr: u32) -> Option<&'static VarInfo> {
    VARIABLES.iter().find(|v| v.vr == vr)
}

fn plausible_real(info: Option<&VarInfo>, u: f64) -> f64 {
    let Some(info) = info else { return u };
    let d = Params::default()
        .get_real(info.var)
        .or(Inputs::default().get_real(info.var))
        .unwrap_or(0.0);
    if d != 0.0 {
        return d * (0.5 + 1.5 * u);
    }
    match info.name {
        "tau_A" | "tau_B" => -200.0 + 400.0 * u,
        "chi" => 20.0 * u,
        "mu" => 0.3 * u,
        "c_load" => 5.0 * u,
        "w_A_start" => 200.0 * u,
        "w_B_start" => 133.0 * u,
        "dte_start" => 1e-5 * (u - 0.5),
        _ => u - 0.5,
    }
}

fn plausible_int(info: Option<&VarInfo>, d: i32) -> i32 {
    let Some(info) = info else { return d };
    Params::default().get_integer(info.var).unwrap_or(0) + d
}

/// Why setting `vr` must fail in state `st` (None: it may succeed).
fn set_reject(vr: u32, ty: VarType, st: FmiState) -> Option<String> {
    let Some(i) = info(vr) else {
        return Some(format!("unknown vr {vr}"));
    };
    if i.ty != ty {
        return Some(format!("{} is not {ty:?}", i.name));
    }
    if !settable(i) {
        return Some(format!("{} is not settable", i.name));
    }
    if st == FmiState::StepComplete && i.variability == Variability::Fixed {
        return Some(format!("{} is fixed", i.name));
    }
    None
}

fn get_reject(vr: u32, ty: VarType) -> Option<String> {
    match info(vr) {
        None => Some(format!("unknown vr {vr}")),
        Some(i) if i.ty != ty => Some(format!("{} is not {ty:?}", i.name)),
        _ => None,
    }
}

fn status_name(s: Status) -> usize {
    match s {
        Status::Ok => 0,
        Status::Warning => 1,
        Status::Discard => 2,
        _ => 3,
    }
}

impl Harness {
    fn new() -> Harness {
        let mut h = Harness {
            slots: [None, None],
            blobs: vec![running_blob().clone()],
            names: 0,
            captured: Vec::new(),
        };
        for s in 0..2 {
            h.slots[s] = Some(h.instantiate_valid(s == 0));
        }
        // A blob of a fresh instance.
        let sl = h.slots[0].as_ref().unwrap();
        let st = sl.fmu.get_state();
        let b = sl.fmu.serialize(st);
        sl.fmu.free_state(st);
        h.blobs.push((b, Model::fresh()));
        h
    }

    fn instantiate_valid(&mut self, logging_on: bool) -> Slot {
        self.names += 1;
        let name = format!("fuzz{}", self.names);
        let fmu = Fmu::try_new(&name, logging_on).expect("valid instantiation");
        Slot {
            fmu,
            name,
            m: Model::fresh(),
            live: BTreeMap::new(),
            freed: Vec::new(),
            cats: [logging_on, logging_on, true, true, true, true],
            can_log: true,
        }
    }

    fn record(&self, func: &str, s: Status, dt: Duration) {
        let mut st = stats();
        st.calls.entry(func.to_string()).or_default()[status_name(s)] += 1;
        if dt > st.max_call.0 {
            st.max_call = (dt, func.to_string());
        }
    }

    /// Checks the log after a call of `func` that returned `s` on slot `i`.
    fn grab(&mut self, i: usize) {
        let recs = self.slots[i].as_ref().unwrap().fmu.log.take();
        self.captured.extend(recs);
    }

    fn check_log(&mut self, i: usize, func: &str, s: Status) -> R {
        let recs = std::mem::take(&mut self.captured);
        let sl = self.slots[i].as_ref().unwrap();
        for r in &recs {
            check!(
                LOG_CATEGORIES.contains(&r.category.as_str()),
                "{func}: log category {:?} is not declared",
                r.category
            );
            check!(!r.message.is_empty(), "{func}: empty log message");
            check!(
                r.instance == sl.name,
                "{func}: instance name {:?} in the log",
                r.instance
            );
            check!(
                !r.message.contains("panic"),
                "{func}: a panic inside the FMU: {}",
                r.text()
            );
            match r.status {
                3 => check!(
                    r.category == "logStatusError",
                    "{func}: error in {}",
                    r.category
                ),
                2 => check!(
                    r.category == "logStatusDiscard",
                    "{func}: discard in {}",
                    r.category
                ),
                4 => check!(false, "{func}: fatal: {}", r.text()),
                0 | 1 => {}
                x => check!(false, "{func}: log status {x}"),
            }
        }
        if !sl.can_log {
            return Ok(());
        }
        let need = match s {
            Status::Error => Some((3, CAT_ERROR)),
            Status::Discard => Some((2, CAT_DISCARD)),
            _ => None,
        };
        if let Some((status, cat)) = need {
            if sl.cats[cat] {
                check!(
                    recs.iter().any(|r| r.status == status
                        && r.category == LOG_CATEGORIES[cat]
                        && r.message.starts_with(func)),
                    "{func} returned {s:?} without a {} message naming the function; log: {recs:?}",
                    LOG_CATEGORIES[cat]
                );
            }
        } else {
            check!(
                !recs.iter().any(|r| r.status >= 2),
                "{func} returned {s:?} but logged {recs:?}"
            );
        }
        Ok(())
    }

    /// Reads the instance's FMI state from its own serialized FMU state.
    fn actual_state(&self, i: usize) -> Result<FmiState, TestCaseError> {
        let f = &self.slots[i].as_ref().unwrap().fmu;
        let mut p: FmuState = null_mut();
        check!(
            unsafe { fmi2GetFMUstate(f.c, &mut p) } == Status::Ok,
            "oracle: fmi2GetFMUstate failed: {:?}",
            f.log.take()
        );
        let b = f.serialize(p);
        check!(
            f.free_state(p) == Status::Ok,
            "oracle: fmi2FreeFMUstate failed"
        );
        let (p0, _) = payload_range(&b);
        let w = u64::from_le_bytes(b[p0..p0 + 8].try_into().unwrap());
        FmiState::from_bits(w).ok_or_else(|| TestCaseError::fail(format!("oracle: state word {w}")))
    }

    fn last_time(&self, i: usize) -> Option<f64> {
        let f = &self.slots[i].as_ref().unwrap().fmu;
        let mut t = f64::NAN;
        let s =
            unsafe { fmi2GetRealStatus(f.c, spur_gear_mesh::fmi::LAST_SUCCESSFUL_TIME, &mut t) };
        (s == Status::Ok).then_some(t)
    }

    /// After every call on a live slot: the model's state and time against the instance's.
    fn verify(&mut self, i: usize, what: &str) -> R {
        let actual = self.actual_state(i)?;
        let sl = self.slots[i].as_mut().unwrap();
        if sl.m.known {
            check!(
                actual == sl.m.st,
                "after {what}: the instance is in {actual:?}, the FMI state machine says {:?}",
                sl.m.st
            );
        } else {
            sl.m.st = actual;
        }
        *stats()
            .states_seen
            .entry(format!("{actual:?}"))
            .or_default() += 1;
        if bit(actual) & STATUS != 0 {
            let t = self.last_time(i);
            let sl = self.slots[i].as_mut().unwrap();
            check!(
                t.is_some(),
                "after {what}: fmi2GetRealStatus(LastSuccessfulTime) failed in {actual:?}"
            );
            let t = t.unwrap();
            check!(
                t.is_finite() || !sl.m.known && !strict(),
                "after {what}: the last successful time is {t}"
            );
            if sl.m.known {
                check!(
                    t.to_bits() == sl.m.t.to_bits(),
                    "after {what}: time {t}, expected {}",
                    sl.m.t
                );
            } else {
                sl.m.t = t;
            }
        }
        let recs = self.slots[i].as_ref().unwrap().fmu.log.take();
        check!(
            !recs.iter().any(|r| r.status >= 2),
            "the state/time queries logged {recs:?}"
        );
        Ok(())
    }

    /// Every Real output and calculated parameter, if they can be read now.
    fn outputs(&self, i: usize) -> Option<Vec<f64>> {
        let sl = self.slots[i].as_ref().unwrap();
        if bit(sl.m.st) & GET == 0 {
            return None;
        }
        let vrs: Vec<u32> = VARIABLES
            .iter()
            .filter(|v| v.ty == VarType::Real && v.causality == Causality::Output)
            .map(|v| v.vr)
            .collect();
        let (s, v) = sl.fmu.get_reals(&vrs);
        let _ = sl.fmu.log.take();
        (s == Status::Ok).then_some(v)
    }

    /// An Error return: the state is the previous one or Error.
    fn after_error(&mut self, i: usize, before: FmiState, what: &str) -> R {
        let actual = self.actual_state(i)?;
        let sl = self.slots[i].as_mut().unwrap();
        check!(
            actual == before || actual == FmiState::Error,
            "{what} returned fmi2Error and left the instance in {actual:?} (was {before:?})"
        );
        sl.m.st = actual;
        Ok(())
    }

    fn resolve_state(&self, i: usize, a: &StateArg) -> Option<FmuState> {
        let sl = self.slots[i].as_ref().unwrap();
        let pick = |v: Vec<usize>, k: usize| {
            if v.is_empty() {
                0x10 as FmuState // a bogus pointer if there is nothing to pick
            } else {
                v[k % v.len()] as FmuState
            }
        };
        match *a {
            StateArg::NullPtr => None,
            StateArg::NullValue => Some(null_mut()),
            StateArg::Own(k) => Some(pick(sl.live.keys().copied().collect(), k)),
            StateArg::Freed(k) => Some(pick(sl.freed.clone(), k)),
            StateArg::Other(k) => Some(match &self.slots[1 - i] {
                Some(o) => pick(o.live.keys().copied().collect(), k),
                None => 0x20 as FmuState,
            }),
            StateArg::Bogus(x) => Some(x.max(1) as FmuState),
        }
    }

    fn blob(&self, b: &Blob) -> (Option<Vec<u8>>, Option<Model>, bool) {
        // (bytes or None for a null pointer, model if it must be accepted, may_accept)
        let pick = |k: usize| &self.blobs[k % self.blobs.len()];
        match b {
            Blob::Valid(k) => {
                let (v, m) = pick(*k);
                (Some(v.clone()), Some(m.clone()), true)
            }
            Blob::Truncate(k, n) => {
                let v = &pick(*k).0;
                (Some(v[..n % v.len()].to_vec()), None, false)
            }
            Blob::FlipBit(k, n) => {
                let mut v = pick(*k).0.clone();
                let n = n % (v.len() * 8);
                v[n / 8] ^= 1 << (n % 8);
                (Some(v), None, false)
            }
            Blob::Version(k, x) => {
                let mut v = pick(*k).0.clone();
                // Any version but the current one (2).
                let x = if *x == 2 { 1 } else { *x };
                v[8..12].copy_from_slice(&x.to_le_bytes());
                (Some(v), None, false)
            }
            Blob::Guid(k, n, x) => {
                let mut v = pick(*k).0.clone();
                let n = 16 + n % GUID.len();
                v[n] ^= x;
                (Some(v), None, false)
            }
            Blob::Extend(k, extra) => {
                let mut v = pick(*k).0.clone();
                v.extend_from_slice(extra);
                (Some(v), None, false)
            }
            Blob::Word(k, n, x) => {
                let mut v = pick(*k).0.clone();
                let (p0, plen) = payload_range(&v);
                let w = p0 + 8 * (n % (plen / 8));
                v[w..w + 8].copy_from_slice(&x.to_le_bytes());
                let sum = fnv64(&v[p0..p0 + plen]);
                v[p0 + plen..].copy_from_slice(&sum.to_le_bytes());
                (Some(v), None, true)
            }
            Blob::Garbage(g) => (Some(g.clone()), None, false),
            Blob::NullPtr(_) => (None, None, false),
            Blob::Empty => (Some(Vec::new()), None, false),
        }
    }

    /// Stores the result of a successful GetFMUstate/DeSerializeFMUstate: `before` was *state.
    fn stored(&mut self, i: usize, before: FmuState, after: FmuState, m: Model, func: &str) -> R {
        let sl = self.slots[i].as_mut().unwrap();
        check!(
            !after.is_null(),
            "{func} returned fmi2OK and a null FMU state"
        );
        if sl.live.contains_key(&(before as usize)) {
            check!(
                after == before,
                "{func} did not overwrite its own FMU state in place"
            );
        } else {
            check!(
                !sl.live.contains_key(&(after as usize)),
                "{func} returned a state pointer that is already in use"
            );
        }
        sl.freed.retain(|&p| p != after as usize);
        sl.live.insert(after as usize, m);
        Ok(())
    }

    fn run(&mut self, op: &Op) -> R {
        HEARTBEAT.store(now_ms(), Ordering::SeqCst);
        *CURRENT.lock().unwrap() = format!("{op:?}");
        let slot = |s: &u8| *s as usize % 2;
        let live = |h: &Harness, s: &u8| h.slots[slot(s)].is_some();
        match op {
            Op::Instantiate(s, how, logging_on) => {
                return self.op_instantiate(slot(s), how, *logging_on)
            }
            Op::FreeInstance(s) => {
                if let Some(sl) = self.slots[slot(s)].take() {
                    drop(sl); // fmi2FreeInstance, which frees the instance's FMU states
                }
                return Ok(());
            }
            Op::NullComponent(f) => return self.op_null_component(*f),
            _ => {}
        }
        let s = match op {
            Op::SetDebugLogging(s, ..)
            | Op::SetupExperiment(s, ..)
            | Op::EnterInit(s)
            | Op::ExitInit(s)
            | Op::Terminate(s)
            | Op::Reset(s)
            | Op::PaperScene(s, ..)
            | Op::SetReal(s, ..)
            | Op::SetInteger(s, ..)
            | Op::SetBoolean(s, ..)
            | Op::SetString(s, ..)
            | Op::GetReal(s, ..)
            | Op::GetInteger(s, ..)
            | Op::GetBoolean(s, ..)
            | Op::GetString(s, ..)
            | Op::DoStep(s, ..)
            | Op::Steps(s, ..)
            | Op::CancelStep(s)
            | Op::Status(s, ..)
            | Op::GetState(s, ..)
            | Op::SetState(s, ..)
            | Op::FreeState(s, ..)
            | Op::StateSize(s, ..)
            | Op::Serialize(s, ..)
            | Op::Deserialize(s, ..)
            | Op::Unsupported(s, ..) => s,
            _ => unreachable!(),
        };
        if !live(self, s) {
            stats().skipped += 1;
            return Ok(());
        }
        let i = slot(s);
        let _ = self.slots[i].as_ref().unwrap().fmu.log.take();
        self.captured.clear();
        let before = self.slots[i].as_ref().unwrap().m.clone();
        let c = self.slots[i].as_ref().unwrap().fmu.c;
        let t0 = Instant::now();
        let (func, status): (&str, Status) = match op {
            Op::SetDebugLogging(_, on, cats) => {
                let (mut ptrs, _keep, must_fail, names) = category_args(cats);
                let (n, p) = match cats {
                    Cats::All => (0, std::ptr::null()),
                    Cats::NullArray(n) => (*n, std::ptr::null()),
                    Cats::List(_) => (ptrs.len(), ptrs.as_mut_ptr() as *const *const c_char),
                };
                let st = unsafe { fmi2SetDebugLogging(c, *on as c_int, n, p) };
                self.grab(i);
                let sl = self.slots[i].as_mut().unwrap();
                if must_fail {
                    check!(
                        st == Status::Error,
                        "fmi2SetDebugLogging({cats:?}) gave {st:?}"
                    );
                } else {
                    check!(
                        st == Status::Ok,
                        "fmi2SetDebugLogging({cats:?}) gave {st:?}"
                    );
                    if names.is_empty() {
                        sl.cats[0] = *on;
                        sl.cats[1] = *on;
                    }
                    for k in names {
                        sl.cats[k] = *on;
                    }
                }
                if st == Status::Error {
                    self.after_error(i, before.st, "fmi2SetDebugLogging")?;
                }
                ("fmi2SetDebugLogging", st)
            }
            Op::SetupExperiment(_, tol, start, stop) => {
                let st = unsafe {
                    fmi2SetupExperiment(
                        c,
                        tol.is_some() as c_int,
                        tol.unwrap_or(f64::NAN),
                        *start,
                        stop.is_some() as c_int,
                        stop.unwrap_or(f64::NAN),
                    )
                };
                self.grab(i);
                let bad = tol.is_some_and(|t| !(1e-14..=0.1).contains(&t))
                    || !start.is_finite()
                    || stop.is_some_and(|s| !(s >= *start && s.is_finite()));
                let allowed = bit(before.st) & INST != 0;
                if before.known {
                    if !allowed || bad {
                        check!(
                            st == Status::Error,
                            "fmi2SetupExperiment({tol:?}, {start}, {stop:?}) in {:?} gave {st:?}",
                            before.st
                        );
                    } else {
                        check!(
                            st == Status::Ok,
                            "fmi2SetupExperiment({tol:?}, {start}, {stop:?}) gave {st:?}"
                        );
                    }
                }
                if st == Status::Error {
                    self.after_error(i, before.st, "fmi2SetupExperiment")?;
                }
                if st == Status::Ok {
                    let m = &mut self.slots[i].as_mut().unwrap().m;
                    m.start = *start;
                    m.t = *start;
                    m.stop = *stop;
                }
                ("fmi2SetupExperiment", st)
            }
            Op::EnterInit(_) => {
                let st = unsafe { fmi2EnterInitializationMode(c) };
                self.grab(i);
                self.expect_transition(
                    i,
                    st,
                    INST,
                    FmiState::InitializationMode,
                    "fmi2EnterInitializationMode",
                    true,
                )?;
                ("fmi2EnterInitializationMode", st)
            }
            Op::ExitInit(_) => {
                let st = unsafe { fmi2ExitInitializationMode(c) };
                self.grab(i);
                self.expect_transition(
                    i,
                    st,
                    INIT,
                    FmiState::StepComplete,
                    "fmi2ExitInitializationMode",
                    false,
                )?;
                if matches!(st, Status::Ok | Status::Warning) {
                    let m = &mut self.slots[i].as_mut().unwrap().m;
                    m.t = m.start;
                }
                ("fmi2ExitInitializationMode", st)
            }
            Op::Terminate(_) => {
                let st = unsafe { fmi2Terminate(c) };
                self.grab(i);
                self.expect_transition(
                    i,
                    st,
                    DONE | FAIL,
                    FmiState::Terminated,
                    "fmi2Terminate",
                    true,
                )?;
                ("fmi2Terminate", st)
            }
            Op::Reset(_) => {
                let st = unsafe { fmi2Reset(c) };
                self.grab(i);
                check!(st == Status::Ok, "fmi2Reset gave {st:?}");
                self.slots[i].as_mut().unwrap().m = Model::fresh();
                ("fmi2Reset", st)
            }
            Op::PaperScene(_, solver, stop, ring) => {
                let f = &self.slots[i].as_ref().unwrap().fmu;
                check!(f.reset() == Status::Ok, "fmi2Reset failed");
                for &(n, x) in PAPER_SCENE {
                    check!(
                        f.set_real(n, x) == Status::Ok,
                        "set {n}: {:?}",
                        f.log.take()
                    );
                }
                if *ring {
                    check!(
                        f.set_ring_pair() == Status::Ok,
                        "set the ring pair: {:?}",
                        f.log.take()
                    );
                }
                check!(f.set_integer("solver", *solver) == Status::Ok, "set solver");
                check!(f.setup(*stop) == Status::Ok, "setup");
                check!(f.enter_init() == Status::Ok, "enter");
                let st = f.exit_init();
                check!(st == Status::Ok, "paper scene: exit {:?}", f.log.take());
                self.grab(i);
                self.slots[i].as_mut().unwrap().m = Model {
                    st: FmiState::StepComplete,
                    stop: *stop,
                    ..Model::fresh()
                };
                ("fmi2ExitInitializationMode", st)
            }
            Op::SetReal(_, args, null_values) => {
                let vrs: Vec<u32> = args
                    .iter()
                    .map(|(v, _)| resolve_vr(v, VarType::Real, true))
                    .collect();
                let vals: Vec<f64> = args
                    .iter()
                    .zip(&vrs)
                    .map(|((_, x), &r)| match x {
                        Real::Plausible(u) => plausible_real(info(r), *u),
                        Real::Special(x) => *x,
                    })
                    .collect();
                let must_fail = (*null_values && !vrs.is_empty())
                    || vrs
                        .iter()
                        .any(|&r| set_reject(r, VarType::Real, before.st).is_some())
                    || vals.iter().any(|x| !x.is_finite());
                let outs = self.outputs(i);
                let p = if *null_values {
                    std::ptr::null()
                } else {
                    vals.as_ptr()
                };
                let st = unsafe { fmi2SetReal(c, vrs.as_ptr(), vrs.len(), p) };
                self.grab(i);
                self.expect_set(i, st, must_fail, "fmi2SetReal", &before, outs)?;
                ("fmi2SetReal", st)
            }
            Op::SetInteger(_, args, null_values) => {
                let vrs: Vec<u32> = args
                    .iter()
                    .map(|(v, _)| resolve_vr(v, VarType::Integer, true))
                    .collect();
                let vals: Vec<c_int> = args
                    .iter()
                    .zip(&vrs)
                    .map(|((_, x), &r)| match x {
                        Int::Plausible(d) => plausible_int(info(r), *d),
                        Int::Special(x) => *x,
                    })
                    .collect();
                let must_fail = (*null_values && !vrs.is_empty())
                    || vrs
                        .iter()
                        .any(|&r| set_reject(r, VarType::Integer, before.st).is_some());
                let outs = self.outputs(i);
                let p = if *null_values {
                    std::ptr::null()
                } else {
                    vals.as_ptr()
                };
                let st = unsafe { fmi2SetInteger(c, vrs.as_ptr(), vrs.len(), p) };
                self.grab(i);
                self.expect_set(i, st, must_fail, "fmi2SetInteger", &before, outs)?;
                ("fmi2SetInteger", st)
            }
            Op::SetBoolean(_, args, null_values) => {
                let vrs: Vec<u32> = args
                    .iter()
                    .map(|(v, _)| resolve_vr(v, VarType::Boolean, true))
                    .collect();
                let vals: Vec<c_int> = args.iter().map(|(_, x)| *x).collect();
                let must_fail = (*null_values && !vrs.is_empty())
                    || vrs
                        .iter()
                        .any(|&r| set_reject(r, VarType::Boolean, before.st).is_some());
                let outs = self.outputs(i);
                let p = if *null_values {
                    std::ptr::null()
                } else {
                    vals.as_ptr()
                };
                let st = unsafe { fmi2SetBoolean(c, vrs.as_ptr(), vrs.len(), p) };
                self.grab(i);
                self.expect_set(i, st, must_fail, "fmi2SetBoolean", &before, outs)?;
                ("fmi2SetBoolean", st)
            }
            Op::SetString(_, v) => {
                let vrs: Vec<u32> = v
                    .iter()
                    .map(|v| resolve_vr(v, VarType::String, true))
                    .collect();
                // The empty string is valid for the String parameters (no pitch errors).
                let strs: Vec<*const c_char> = vrs.iter().map(|_| c"".as_ptr()).collect();
                let st = unsafe { fmi2SetString(c, vrs.as_ptr(), vrs.len(), strs.as_ptr()) };
                self.grab(i);
                let must_fail = vrs
                    .iter()
                    .any(|&r| set_reject(r, VarType::String, before.st).is_some());
                self.expect_set(i, st, must_fail, "fmi2SetString", &before, None)?;
                ("fmi2SetString", st)
            }
            Op::GetReal(_, v, null_values) => {
                let vrs: Vec<u32> = v
                    .iter()
                    .map(|v| resolve_vr(v, VarType::Real, false))
                    .collect();
                let mut out = vec![f64::NAN; vrs.len()];
                let p = if *null_values {
                    null_mut()
                } else {
                    out.as_mut_ptr()
                };
                let st = unsafe { fmi2GetReal(c, vrs.as_ptr(), vrs.len(), p) };
                self.grab(i);
                let must_fail = (*null_values && !vrs.is_empty())
                    || vrs.iter().any(|&r| get_reject(r, VarType::Real).is_some());
                self.expect_get(i, st, must_fail, "fmi2GetReal", &before)?;
                if st == Status::Ok && (before.known || strict()) {
                    for (r, x) in vrs.iter().zip(&out) {
                        check!(
                            x.is_finite(),
                            "fmi2GetReal returned {x} for vr {r} with fmi2OK"
                        );
                    }
                }
                ("fmi2GetReal", st)
            }
            Op::GetInteger(_, v, null_values) => {
                let vrs: Vec<u32> = v
                    .iter()
                    .map(|v| resolve_vr(v, VarType::Integer, false))
                    .collect();
                let mut out = vec![0 as c_int; vrs.len()];
                let p = if *null_values {
                    null_mut()
                } else {
                    out.as_mut_ptr()
                };
                let st = unsafe { fmi2GetInteger(c, vrs.as_ptr(), vrs.len(), p) };
                self.grab(i);
                let must_fail = (*null_values && !vrs.is_empty())
                    || vrs
                        .iter()
                        .any(|&r| get_reject(r, VarType::Integer).is_some());
                self.expect_get(i, st, must_fail, "fmi2GetInteger", &before)?;
                ("fmi2GetInteger", st)
            }
            Op::GetBoolean(_, v, null_values) => {
                let vrs: Vec<u32> = v
                    .iter()
                    .map(|v| resolve_vr(v, VarType::Boolean, false))
                    .collect();
                let mut out = vec![0 as c_int; vrs.len()];
                let p = if *null_values {
                    null_mut()
                } else {
                    out.as_mut_ptr()
                };
                let st = unsafe { fmi2GetBoolean(c, vrs.as_ptr(), vrs.len(), p) };
                self.grab(i);
                let must_fail = (*null_values && !vrs.is_empty())
                    || vrs
                        .iter()
                        .any(|&r| get_reject(r, VarType::Boolean).is_some());
                self.expect_get(i, st, must_fail, "fmi2GetBoolean", &before)?;
                ("fmi2GetBoolean", st)
            }
            Op::GetString(_, v) => {
                let vrs: Vec<u32> = v
                    .iter()
                    .map(|v| resolve_vr(v, VarType::String, false))
                    .collect();
                let mut out: Vec<*const c_char> = vec![std::ptr::null(); vrs.len()];
                let st = unsafe { fmi2GetString(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
                self.grab(i);
                let must_fail = vrs
                    .iter()
                    .any(|&r| get_reject(r, VarType::String).is_some());
                self.expect_get(i, st, must_fail, "fmi2GetString", &before)?;
                if st == Status::Ok {
                    check!(
                        out.iter().all(|p| !p.is_null()),
                        "fmi2GetString gave a null string with fmi2OK"
                    );
                }
                ("fmi2GetString", st)
            }
            Op::DoStep(_, cur, h) => match self.op_step(i, cur, *h)? {
                Some(st) => ("fmi2DoStep", st),
                None => return Ok(()),
            },
            Op::Steps(_, n) => {
                for _ in 0..*n {
                    let t1 = Instant::now();
                    match self.op_step(i, &Cur::Exact, 1e-4)? {
                        Some(st) => {
                            self.record("fmi2DoStep", st, t1.elapsed());
                            self.check_log(i, "fmi2DoStep", st)?;
                            self.verify(i, "fmi2DoStep")?;
                            if st != Status::Ok {
                                break;
                            }
                        }
                        None => break,
                    }
                }
                return Ok(());
            }
            Op::CancelStep(_) => {
                let st = unsafe { fmi2CancelStep(c) };
                self.grab(i);
                check!(
                    st == Status::Error,
                    "fmi2CancelStep gave {st:?} (no step is ever in progress)"
                );
                self.after_error(i, before.st, "fmi2CancelStep")?;
                ("fmi2CancelStep", st)
            }
            Op::Status(_, f, kind, null_value) => {
                let (func, st) = self.op_status(i, *f, *kind, *null_value, &before)?;
                (func, st)
            }
            Op::GetState(_, a) => {
                let st = match self.resolve_state(i, a) {
                    None => {
                        let st = unsafe { fmi2GetFMUstate(c, null_mut()) };
                        self.grab(i);
                        st
                    }
                    Some(p0) => {
                        let mut p = p0;
                        let st = unsafe { fmi2GetFMUstate(c, &mut p) };
                        self.grab(i);
                        if st == Status::Ok {
                            self.stored(i, p0, p, before.clone(), "fmi2GetFMUstate")?;
                        } else {
                            check!(p == p0, "failed fmi2GetFMUstate changed *FMUstate");
                        }
                        st
                    }
                };
                let must_fail = matches!(a, StateArg::NullPtr);
                check!(
                    (st == Status::Ok) != must_fail,
                    "fmi2GetFMUstate({a:?}) gave {st:?}"
                );
                if st != Status::Ok {
                    self.after_error(i, before.st, "fmi2GetFMUstate")?;
                }
                ("fmi2GetFMUstate", st)
            }
            Op::SetState(_, a) => {
                let p = self.resolve_state(i, a).unwrap_or(null_mut());
                let target = self.slots[i]
                    .as_ref()
                    .unwrap()
                    .live
                    .get(&(p as usize))
                    .cloned();
                let st = unsafe { fmi2SetFMUstate(c, p) };
                self.grab(i);
                match target {
                    Some(m) => {
                        check!(
                            st == Status::Ok,
                            "fmi2SetFMUstate of a live own state gave {st:?}"
                        );
                        self.slots[i].as_mut().unwrap().m = m;
                    }
                    None => {
                        check!(
                            st == Status::Error,
                            "fmi2SetFMUstate({a:?} = {p:p}) gave {st:?}"
                        );
                        self.after_error(i, before.st, "fmi2SetFMUstate")?;
                    }
                }
                ("fmi2SetFMUstate", st)
            }
            Op::FreeState(_, a) => {
                let r = self.resolve_state(i, a);
                let st = match r {
                    None => {
                        let st = unsafe { fmi2FreeFMUstate(c, null_mut()) };
                        self.grab(i);
                        st
                    }
                    Some(p0) => {
                        let mut p = p0;
                        let st = unsafe { fmi2FreeFMUstate(c, &mut p) };
                        self.grab(i);
                        let sl = self.slots[i].as_mut().unwrap();
                        if p0.is_null() {
                            check!(st == Status::Ok, "fmi2FreeFMUstate(NULL) gave {st:?}");
                        } else if sl.live.remove(&(p0 as usize)).is_some() {
                            check!(
                                st == Status::Ok,
                                "fmi2FreeFMUstate of a live own state gave {st:?}"
                            );
                            check!(p.is_null(), "fmi2FreeFMUstate did not null the pointer");
                            sl.freed.push(p0 as usize);
                        } else {
                            check!(
                                st == Status::Error,
                                "fmi2FreeFMUstate({a:?} = {p0:p}) gave {st:?}"
                            );
                            check!(p == p0, "failed fmi2FreeFMUstate changed *FMUstate");
                        }
                        st
                    }
                };
                if r.is_none() {
                    check!(
                        st == Status::Ok,
                        "fmi2FreeFMUstate(NULL pointer) gave {st:?}"
                    );
                }
                if st == Status::Error {
                    self.after_error(i, before.st, "fmi2FreeFMUstate")?;
                }
                ("fmi2FreeFMUstate", st)
            }
            Op::StateSize(_, a, null_size) => {
                let p = self.resolve_state(i, a).unwrap_or(null_mut());
                let own = self.slots[i]
                    .as_ref()
                    .unwrap()
                    .live
                    .contains_key(&(p as usize));
                let mut n = 0usize;
                let np = if *null_size {
                    null_mut()
                } else {
                    &mut n as *mut usize
                };
                let st = unsafe { fmi2SerializedFMUstateSize(c, p, np) };
                self.grab(i);
                if own && !null_size {
                    check!(
                        st == Status::Ok && n > 64,
                        "fmi2SerializedFMUstateSize gave {st:?}, {n}"
                    );
                } else {
                    check!(
                        st == Status::Error,
                        "fmi2SerializedFMUstateSize({a:?}, null size {null_size}) gave {st:?}"
                    );
                    self.after_error(i, before.st, "fmi2SerializedFMUstateSize")?;
                }
                ("fmi2SerializedFMUstateSize", st)
            }
            Op::Serialize(_, a, buf) => {
                let p = self.resolve_state(i, a).unwrap_or(null_mut());
                let m = self.slots[i]
                    .as_ref()
                    .unwrap()
                    .live
                    .get(&(p as usize))
                    .cloned();
                let mut n = 0usize;
                if m.is_some() {
                    check!(
                        unsafe { fmi2SerializedFMUstateSize(c, p, &mut n) } == Status::Ok,
                        "size"
                    );
                } else {
                    n = 100;
                }
                let (size, extra) = match buf {
                    Buf::Exact | Buf::Null => (n, 0),
                    Buf::Short(k) => (n.saturating_sub(1 + k % n.max(1)), 0),
                    Buf::Long(k) => (n + k, *k),
                };
                let mut v = vec![0xA5u8; size + 1];
                let bp = if matches!(buf, Buf::Null) {
                    null_mut()
                } else {
                    v.as_mut_ptr() as *mut c_char
                };
                let st = unsafe { fmi2SerializeFMUstate(c, p, bp, size) };
                self.grab(i);
                match (m, buf) {
                    (Some(m), Buf::Exact | Buf::Long(_)) => {
                        check!(st == Status::Ok, "fmi2SerializeFMUstate gave {st:?}");
                        check!(
                            v[n..].iter().all(|&b| b == 0xA5),
                            "fmi2SerializeFMUstate wrote past the state's {n} bytes (buffer {size}, {extra} spare)"
                        );
                        v.truncate(n);
                        if self.blobs.len() < 16 {
                            self.blobs.push((v, m));
                        } else {
                            let k = (n + self.names as usize) % 16;
                            self.blobs[k] = (v, m);
                        }
                    }
                    _ => {
                        check!(
                            st == Status::Error,
                            "fmi2SerializeFMUstate({a:?}, {buf:?}) gave {st:?}"
                        );
                        check!(
                            v.iter().all(|&b| b == 0xA5),
                            "a failed fmi2SerializeFMUstate wrote into the buffer"
                        );
                        self.after_error(i, before.st, "fmi2SerializeFMUstate")?;
                    }
                }
                ("fmi2SerializeFMUstate", st)
            }
            Op::Deserialize(_, b, a) => {
                let (bytes, accept, may) = self.blob(b);
                let (bp, size) = match (&bytes, b) {
                    (Some(v), _) => (v.as_ptr() as *const c_char, v.len()),
                    (None, Blob::NullPtr(n)) => (std::ptr::null(), *n),
                    _ => unreachable!(),
                };
                let target = self.resolve_state(i, a);
                let st = match target {
                    None => {
                        let st = unsafe { fmi2DeSerializeFMUstate(c, bp, size, null_mut()) };
                        self.grab(i);
                        st
                    }
                    Some(p0) => {
                        let mut p = p0;
                        let st = unsafe { fmi2DeSerializeFMUstate(c, bp, size, &mut p) };
                        self.grab(i);
                        if st == Status::Ok {
                            check!(
                                may,
                                "fmi2DeSerializeFMUstate accepted a damaged state ({b:?})"
                            );
                            let m = accept.clone().unwrap_or(Model {
                                known: false,
                                ..Model::fresh()
                            });
                            if accept.is_none() {
                                stats().hostile_accepted += 1;
                            }
                            self.stored(i, p0, p, m, "fmi2DeSerializeFMUstate")?;
                        } else {
                            check!(p == p0, "failed fmi2DeSerializeFMUstate changed *FMUstate");
                        }
                        st
                    }
                };
                if target.is_none() || accept.is_none() && !may {
                    check!(
                        st == Status::Error,
                        "fmi2DeSerializeFMUstate({b:?}, {a:?}) gave {st:?}"
                    );
                } else if accept.is_some() {
                    check!(
                        st == Status::Ok,
                        "fmi2DeSerializeFMUstate of a valid state gave {st:?}"
                    );
                }
                if st != Status::Ok {
                    self.after_error(i, before.st, "fmi2DeSerializeFMUstate")?;
                }
                ("fmi2DeSerializeFMUstate", st)
            }
            Op::Unsupported(_, f) if f % 13 == 10 => {
                // canInterpolateInputs: a zero first derivative of tau_A is accepted wherever
                // fmi2SetReal is, and changes nothing.
                let (func, st) = unsupported(c, *f);
                self.grab(i);
                self.expect_set(i, st, false, func, &before, None)?;
                (func, st)
            }
            Op::Unsupported(_, f) => {
                let (func, st) = unsupported(c, *f);
                self.grab(i);
                check!(
                    st == Status::Error,
                    "{func} gave {st:?}: the FMU does not support it"
                );
                self.after_error(i, before.st, func)?;
                (func, st)
            }
            _ => unreachable!(),
        };
        let dt = t0.elapsed();
        if std::env::var_os("FMI_FUZZ_TRACE").is_some() {
            eprintln!(
                "{op:?} -> {status:?} in {dt:?}; {} log records",
                self.captured.len()
            );
        }
        self.record(func, status, dt);
        check!(dt < CALL_LIMIT, "{op:?} took {dt:?}");
        self.check_log(i, func, status)?;
        self.verify(i, func)
    }

    /// A state transition `to` from the states `from` on fmi2OK; fmi2Error in any other state.
    fn expect_transition(
        &mut self,
        i: usize,
        st: Status,
        from: u32,
        to: FmiState,
        func: &str,
        always: bool,
    ) -> R {
        let m = self.slots[i].as_ref().unwrap().m.clone();
        let allowed = bit(m.st) & from != 0;
        if m.known {
            if !allowed {
                check!(st == Status::Error, "{func} in {:?} gave {st:?}", m.st);
            } else if always {
                check!(st == Status::Ok, "{func} in {:?} gave {st:?}", m.st);
            }
        }
        match st {
            // fmi2ExitInitializationMode warns about valid but unusual geometry (thin tips).
            Status::Ok | Status::Warning => {
                check!(
                    st == Status::Ok || func == "fmi2ExitInitializationMode",
                    "{func} gave {st:?}"
                );
                if m.known {
                    check!(allowed, "{func} succeeded in {:?}", m.st);
                }
                self.slots[i].as_mut().unwrap().m.st = to;
            }
            Status::Error => self.after_error(i, m.st, func)?,
            other => check!(false, "{func} gave {other:?}"),
        }
        Ok(())
    }

    fn expect_set(
        &mut self,
        i: usize,
        st: Status,
        must_fail: bool,
        func: &str,
        before: &Model,
        outs: Option<Vec<f64>>,
    ) -> R {
        let allowed = bit(before.st) & SET != 0;
        if before.known && (!allowed || must_fail) {
            check!(
                st == Status::Error,
                "{func} in {:?} (must fail: {must_fail}) gave {st:?}",
                before.st
            );
        }
        match st {
            Status::Ok => check!(
                !before.known || allowed,
                "{func} succeeded in {:?}",
                before.st
            ),
            Status::Error => {
                self.after_error(i, before.st, func)?;
                // All values are checked before any is applied: the outputs are unchanged.
                if let (Some(a), Some(b)) = (outs, self.outputs(i)) {
                    check!(bits(&a) == bits(&b), "a failed {func} changed the outputs");
                }
            }
            other => check!(false, "{func} gave {other:?}"),
        }
        Ok(())
    }

    fn expect_get(
        &mut self,
        i: usize,
        st: Status,
        must_fail: bool,
        func: &str,
        before: &Model,
    ) -> R {
        let allowed = bit(before.st) & GET != 0;
        if before.known && (!allowed || must_fail) {
            check!(
                st == Status::Error,
                "{func} in {:?} (must fail: {must_fail}) gave {st:?}",
                before.st
            );
        }
        match st {
            Status::Ok => check!(
                !before.known || allowed,
                "{func} succeeded in {:?}",
                before.st
            ),
            Status::Error => self.after_error(i, before.st, func)?,
            other => check!(false, "{func} gave {other:?}"),
        }
        Ok(())
    }

    /// One fmi2DoStep; None if skipped (a long but legitimate step).
    fn op_step(&mut self, i: usize, cur: &Cur, h: f64) -> Result<Option<Status>, TestCaseError> {
        let m = self.slots[i].as_ref().unwrap().m.clone();
        let t = m.t;
        let current = match *cur {
            Cur::Exact => t,
            Cur::Rel(r) => t + r * t.abs().max(1.0),
            Cur::Raw(x) => x,
        };
        let tol_ok = (current - t).abs() <= 1e-9 * t.abs().max(1.0);
        let args_ok = current.is_finite() && h.is_finite() && h > 0.0 && tol_ok;
        let t_end = current + h;
        let stop_ok = m.stop.is_none_or(|s| t_end <= s * (1.0 + 1e-12) + 1e-12);
        let allowed = m.st == FmiState::StepComplete;
        let hostile = !m.known && !strict();
        if hostile || allowed && h.is_finite() && h > MAX_SPAN && (!m.known || (args_ok && stop_ok))
        {
            stats().skipped += 1;
            return Ok(None);
        }
        let outs = self.outputs(i);
        let c = self.slots[i].as_ref().unwrap().fmu.c;
        let st = unsafe { fmi2DoStep(c, current, h, 0) };
        self.grab(i);
        if m.known && (!allowed || !args_ok || !stop_ok) {
            check!(
                st == Status::Error,
                "fmi2DoStep({current}, {h}) at t = {t} in {:?} (stop {:?}) gave {st:?}",
                m.st,
                m.stop
            );
        }
        let h_valid = h.is_finite() && h > 0.0;
        if !m.known && !h_valid {
            check!(st == Status::Error, "fmi2DoStep(h = {h}) gave {st:?}");
        }
        match st {
            // Warning: a step the time resolves only coarsely (start time 1e9): it advances to
            // current + h as represented, and says so once (fmi2_slave::ffi::do_step).
            Status::Ok | Status::Warning => {
                check!(!m.known || allowed, "fmi2DoStep succeeded in {:?}", m.st);
                stats().steps_ok += 1;
                let sl = self.slots[i].as_mut().unwrap();
                sl.m.t = t_end;
                sl.m.st = FmiState::StepComplete;
                let o = self.outputs(i);
                check!(
                    o.is_some(),
                    "fmi2GetReal of the outputs failed after a successful step"
                );
                for x in o.unwrap() {
                    check!(x.is_finite(), "an output is {x} after a successful step");
                }
            }
            Status::Discard | Status::Error => {
                if st == Status::Discard {
                    check!(allowed || !m.known, "fmi2DoStep discarded in {:?}", m.st);
                    let a = self.actual_state(i)?;
                    check!(
                        a == FmiState::StepFailed,
                        "fmi2Discard from fmi2DoStep left the instance in {a:?}"
                    );
                    self.slots[i].as_mut().unwrap().m.st = a;
                } else {
                    self.after_error(i, m.st, "fmi2DoStep")?;
                }
                if let (Some(a), Some(b)) = (outs, self.outputs(i)) {
                    check!(
                        bits(&a) == bits(&b),
                        "a failed fmi2DoStep changed the outputs"
                    );
                }
            }
            other => check!(false, "fmi2DoStep gave {other:?}"),
        }
        Ok(Some(st))
    }

    fn op_status(
        &mut self,
        i: usize,
        f: u8,
        kind: i32,
        null_value: bool,
        before: &Model,
    ) -> Result<(&'static str, Status), TestCaseError> {
        let c = self.slots[i].as_ref().unwrap().fmu.c;
        let mut buf = [0u64; 2];
        let p = if null_value {
            null_mut()
        } else {
            buf.as_mut_ptr() as *mut c_void
        };
        let (func, st, answer): (&'static str, Status, bool) = unsafe {
            match f {
                0 => (
                    "fmi2GetStatus",
                    fmi2GetStatus(c, kind, p as *mut c_int),
                    false,
                ),
                1 => (
                    "fmi2GetRealStatus",
                    fmi2GetRealStatus(c, kind, p as *mut f64),
                    kind == 2,
                ),
                2 => (
                    "fmi2GetIntegerStatus",
                    fmi2GetIntegerStatus(c, kind, p as *mut c_int),
                    false,
                ),
                3 => (
                    "fmi2GetBooleanStatus",
                    fmi2GetBooleanStatus(c, kind, p as *mut c_int),
                    kind == 3,
                ),
                _ => (
                    "fmi2GetStringStatus",
                    fmi2GetStringStatus(c, kind, p as *mut *const c_char),
                    false,
                ),
            }
        };
        self.grab(i);
        let std_allowed = bit(before.st) & STATUS != 0;
        let lenient = before.st == FmiState::Error; // the FMU also answers in the error state
        let valid_kind = (0..4).contains(&kind);
        if before.known && !std_allowed && !lenient {
            check!(st == Status::Error, "{func} in {:?} gave {st:?}", before.st);
        } else if before.known && (null_value || !valid_kind) {
            check!(
                st == Status::Error,
                "{func}(kind {kind}, null {null_value}) gave {st:?}"
            );
        } else if before.known && std_allowed {
            let want = if answer { Status::Ok } else { Status::Discard };
            check!(
                st == want,
                "{func}(kind {kind}) in {:?} gave {st:?}, expected {want:?}",
                before.st
            );
        }
        match st {
            Status::Ok => {
                if f == 1 {
                    let t = f64::from_bits(buf[0]);
                    check!(
                        t.is_finite() || !before.known && !strict(),
                        "{func} returned {t}"
                    );
                    if before.known {
                        check!(
                            t.to_bits() == before.t.to_bits(),
                            "{func} returned {t}, time is {}",
                            before.t
                        );
                    }
                }
                if f == 3 {
                    check!(
                        buf[0] as u32 == 0,
                        "{func}(fmi2Terminated) says the FMU wants to stop"
                    );
                }
            }
            Status::Discard => {
                check!(valid_kind, "{func}(kind {kind}) gave fmi2Discard");
            }
            Status::Error => self.after_error(i, before.st, func)?,
            other => check!(false, "{func} gave {other:?}"),
        }
        Ok((func, st))
    }

    fn op_instantiate(&mut self, i: usize, how: &How, logging_on: bool) -> R {
        if matches!(how, How::Valid) && self.slots[i].is_none() {
            self.slots[i] = Some(self.instantiate_valid(logging_on));
            return self.verify(i, "fmi2Instantiate");
        }
        self.names += 1;
        let name = format!("fuzz{}", self.names);
        let log = Box::<LogSink>::default();
        let mut cb = callbacks(&log);
        let cname = CString::new(name.clone()).unwrap();
        let guid = CString::new(GUID).unwrap();
        let wrong = CString::new("{00000000-0000-0000-0000-000000000000}").unwrap();
        let mut ty = TYPE_CO_SIMULATION;
        let mut n = cname.as_ptr();
        let mut g = guid.as_ptr();
        let mut f: *const CallbackFunctions = &*cb;
        let mut res = c"file:///tmp".as_ptr();
        let mut expect_ok = false;
        match how {
            How::Valid => expect_ok = true,
            How::NullName => n = std::ptr::null(),
            How::EmptyName => n = c"".as_ptr(),
            How::ModelExchange => ty = 0,
            How::BadType(t) => ty = if matches!(*t, 0 | 1) { 7 } else { *t },
            How::WrongGuid => g = wrong.as_ptr(),
            How::NullGuid => g = std::ptr::null(),
            How::NullFunctions => f = std::ptr::null(),
            How::NullLogger => {
                cb.logger = None;
                expect_ok = true;
            }
            How::NullResource => {
                res = std::ptr::null();
                expect_ok = true;
            }
        }
        let c: Component = unsafe { fmi2Instantiate(n, ty, g, res, f, 0, logging_on as c_int) };
        let recs = log.take();
        if matches!(how, How::ModelExchange) {
            // A Model Exchange instance: this harness models Co-Simulation, so it is freed at
            // once (tests/model_exchange.rs drives the Model Exchange state machine).
            check!(
                !c.is_null(),
                "fmi2Instantiate(ModelExchange) failed: {recs:?}"
            );
            unsafe { fmi2FreeInstance(c) };
            self.record("fmi2Instantiate", Status::Ok, Duration::ZERO);
            return Ok(());
        }
        if !expect_ok {
            check!(c.is_null(), "fmi2Instantiate({how:?}) returned an instance");
            if !matches!(how, How::NullFunctions) {
                check!(
                    recs.iter().any(|r| r.status == 3
                        && r.category == "logStatusError"
                        && r.message.starts_with("fmi2Instantiate")),
                    "fmi2Instantiate({how:?}) failed without an error message: {recs:?}"
                );
            }
            self.record("fmi2Instantiate", Status::Error, Duration::ZERO);
            return Ok(());
        }
        check!(!c.is_null(), "fmi2Instantiate({how:?}) failed: {recs:?}");
        self.record("fmi2Instantiate", Status::Ok, Duration::ZERO);
        let can_log = !matches!(how, How::NullLogger);
        let slot = Slot {
            fmu: Fmu::from_parts(c, log, cb),
            name,
            m: Model::fresh(),
            live: BTreeMap::new(),
            freed: Vec::new(),
            cats: [logging_on, logging_on, true, true, true, true],
            can_log,
        };
        if self.slots[i].is_none() {
            self.slots[i] = Some(slot);
            self.verify(i, "fmi2Instantiate")
        } else {
            drop(slot); // a third, short-lived instance
            Ok(())
        }
    }

    fn op_null_component(&mut self, f: u8) -> R {
        let z: Component = null_mut();
        let mut p: FmuState = null_mut();
        let mut x = 0f64;
        let mut k: c_int = 0;
        let vr = 40u32;
        let st = unsafe {
            match f % 24 {
                0 => fmi2SetDebugLogging(z, 1, 0, std::ptr::null()),
                1 => fmi2SetupExperiment(z, 0, 0.0, 0.0, 0, 0.0),
                2 => fmi2EnterInitializationMode(z),
                3 => fmi2ExitInitializationMode(z),
                4 => fmi2Terminate(z),
                5 => fmi2Reset(z),
                6 => fmi2GetReal(z, &vr, 1, &mut x),
                7 => fmi2SetReal(z, &vr, 1, &x),
                8 => fmi2GetInteger(z, &vr, 1, &mut k),
                9 => fmi2SetInteger(z, &vr, 1, &k),
                10 => fmi2GetBoolean(z, &vr, 1, &mut k),
                11 => fmi2SetBoolean(z, &vr, 1, &k),
                12 => fmi2DoStep(z, 0.0, 1e-4, 0),
                13 => fmi2CancelStep(z),
                14 => fmi2GetFMUstate(z, &mut p),
                15 => fmi2SetFMUstate(z, 0x10 as FmuState),
                16 => fmi2FreeFMUstate(z, &mut p),
                17 => fmi2SerializedFMUstateSize(z, 0x10 as FmuState, &mut (k as usize)),
                18 => fmi2DeSerializeFMUstate(z, c"x".as_ptr(), 1, &mut p),
                19 => fmi2GetRealStatus(z, 2, &mut x),
                20 => fmi2GetBooleanStatus(z, 3, &mut k),
                21 => fmi2SetTime(z, 0.0),
                22 => {
                    fmi2FreeInstance(z);
                    Status::Error
                }
                _ => {
                    let a = std::ffi::CStr::from_ptr(fmi2GetVersion());
                    let b = std::ffi::CStr::from_ptr(fmi2GetTypesPlatform());
                    check!(
                        a.to_bytes() == b"2.0" && b.to_bytes() == b"default",
                        "version {a:?}, platform {b:?}"
                    );
                    Status::Error
                }
            }
        };
        check!(
            st == Status::Error,
            "call {f} with a null instance gave {st:?}"
        );
        check!(
            p.is_null(),
            "a call with a null instance wrote an FMU state"
        );
        Ok(())
    }
}

/// The category arguments: pointers, their storage, whether the call must fail, and the
/// indices of the named categories.
fn category_args(c: &Cats) -> (Vec<*const c_char>, Vec<CString>, bool, Vec<usize>) {
    match c {
        Cats::All => (vec![], vec![], false, vec![]),
        Cats::NullArray(_) => (vec![], vec![], true, vec![]),
        Cats::List(l) => {
            let keep: Vec<Option<CString>> = l
                .iter()
                .map(|c| match c {
                    Cat::Known(k) => {
                        Some(CString::new(LOG_CATEGORIES[k % LOG_CATEGORIES.len()]).unwrap())
                    }
                    Cat::Unknown(s) => Some(CString::new(s.replace('\0', "")).unwrap()),
                    Cat::Null => None,
                })
                .collect();
            let ptrs = keep
                .iter()
                .map(|k| k.as_ref().map_or(std::ptr::null(), |s| s.as_ptr()))
                .collect();
            let mut must_fail = false;
            let mut names = vec![];
            for k in &keep {
                match k.as_ref().and_then(|s| {
                    LOG_CATEGORIES
                        .iter()
                        .position(|c| c.as_bytes() == s.as_bytes())
                }) {
                    Some(i) => names.push(i),
                    None => must_fail = true,
                }
            }
            (
                ptrs,
                keep.into_iter().flatten().collect(),
                must_fail,
                if must_fail { vec![] } else { names },
            )
        }
    }
}

/// Functions the FMU does not provide (Model Exchange, output derivatives, directional
/// derivatives): called with harmless arguments, each must answer fmi2Error. Also
/// fmi2SetRealInputDerivatives (number 10), which it provides, with a zero derivative.
fn unsupported(c: Component, f: u8) -> (&'static str, Status) {
    let mut x = [0f64; 4];
    let mut b: c_int = 0;
    let vr = [40u32];
    let order = [1 as c_int];
    unsafe {
        match f % 13 {
            0 => ("fmi2EnterEventMode", fmi2EnterEventMode(c)),
            1 => (
                "fmi2NewDiscreteStates",
                fmi2NewDiscreteStates(c, x.as_mut_ptr() as *mut c_void),
            ),
            2 => (
                "fmi2EnterContinuousTimeMode",
                fmi2EnterContinuousTimeMode(c),
            ),
            3 => ("fmi2CompletedIntegratorStep", {
                let mut b2: c_int = 0;
                fmi2CompletedIntegratorStep(c, 0, &mut b, &mut b2)
            }),
            4 => ("fmi2SetTime", fmi2SetTime(c, 0.5)),
            5 => (
                "fmi2SetContinuousStates",
                fmi2SetContinuousStates(c, x.as_ptr(), 4),
            ),
            6 => (
                "fmi2GetDerivatives",
                fmi2GetDerivatives(c, x.as_mut_ptr(), 4),
            ),
            7 => (
                "fmi2GetEventIndicators",
                fmi2GetEventIndicators(c, x.as_mut_ptr(), 4),
            ),
            8 => (
                "fmi2GetContinuousStates",
                fmi2GetContinuousStates(c, x.as_mut_ptr(), 4),
            ),
            9 => (
                "fmi2GetNominalsOfContinuousStates",
                fmi2GetNominalsOfContinuousStates(c, x.as_mut_ptr(), 4),
            ),
            10 => (
                "fmi2SetRealInputDerivatives",
                fmi2SetRealInputDerivatives(c, vr.as_ptr(), 1, order.as_ptr(), x.as_ptr()),
            ),
            11 => (
                "fmi2GetRealOutputDerivatives",
                fmi2GetRealOutputDerivatives(c, vr.as_ptr(), 1, order.as_ptr(), x.as_mut_ptr()),
            ),
            _ => ("fmi2GetDirectionalDerivative", {
                let (a, mut d) = ([1.0f64], [0f64]);
                fmi2GetDirectionalDerivative(
                    c,
                    vr.as_ptr(),
                    1,
                    vr.as_ptr(),
                    1,
                    a.as_ptr(),
                    d.as_mut_ptr(),
                )
            }),
        }
    }
}

/// Runs one call sequence on two fresh instances; frees everything at the end.
fn run_sequence(ops: &[Op]) -> R {
    let mut h = Harness::new();
    for s in 0..2 {
        h.verify(s, "fmi2Instantiate")?;
    }
    for op in ops {
        h.run(op)?;
    }
    // A last check of every live instance: it can still be reset and run.
    for s in 0..2 {
        if h.slots[s].is_some() {
            h.run(&Op::PaperScene(s as u8, 1, None, false))?;
            h.run(&Op::Steps(s as u8, 3))?;
        }
    }
    Ok(())
}

/// Readable regression sequences: cases found by the fuzzer or written by hand. They run first.
fn corpus() -> Vec<(&'static str, Vec<Op>)> {
    use Op::*;
    vec![
        (
            "an internal pair: run, state, step, restore, round trip through a blob",
            vec![
                PaperScene(0, 1, None, true),
                Steps(0, 20),
                GetState(0, StateArg::NullValue),
                Steps(0, 5),
                SetState(0, StateArg::Own(0)),
                Serialize(0, StateArg::Own(0), Buf::Exact),
                Deserialize(1, Blob::Valid(2), StateArg::NullValue),
                SetState(1, StateArg::Own(0)),
                Steps(1, 5),
            ],
        ),
        (
            "run, state, step, restore, serialize, round trip through a blob",
            vec![
                PaperScene(0, 1, None, false),
                Steps(0, 20),
                GetState(0, StateArg::NullValue),
                Steps(0, 5),
                SetState(0, StateArg::Own(0)),
                Serialize(0, StateArg::Own(0), Buf::Exact),
                Deserialize(1, Blob::Valid(2), StateArg::NullValue),
                SetState(1, StateArg::Own(0)),
                Steps(1, 5),
            ],
        ),
        (
            "states of the other instance, freed states and random integers are rejected",
            vec![
                GetState(0, StateArg::NullValue),
                GetState(1, StateArg::NullValue),
                SetState(0, StateArg::Other(0)),
                FreeState(0, StateArg::Own(0)),
                SetState(0, StateArg::Freed(0)),
                FreeState(0, StateArg::Freed(0)),
                SetState(1, StateArg::Bogus(0xdead_beef)),
                FreeState(1, StateArg::Bogus(8)),
                Serialize(1, StateArg::Bogus(u64::MAX), Buf::Exact),
                StateSize(1, StateArg::Other(0), false),
            ],
        ),
        (
            "damaged blobs",
            vec![
                Deserialize(0, Blob::Truncate(0, 100), StateArg::NullValue),
                Deserialize(0, Blob::FlipBit(0, 4000), StateArg::NullValue),
                Reset(0),
                Deserialize(0, Blob::Version(0, 1), StateArg::NullValue),
                Reset(0),
                Deserialize(0, Blob::Guid(0, 3, 1), StateArg::NullValue),
                Reset(0),
                Deserialize(0, Blob::Extend(0, vec![0]), StateArg::NullValue),
                Reset(0),
                Deserialize(0, Blob::Garbage(vec![1, 2, 3]), StateArg::NullValue),
                Reset(0),
                Deserialize(0, Blob::NullPtr(10), StateArg::NullValue),
                Reset(0),
                Deserialize(0, Blob::Empty, StateArg::NullValue),
            ],
        ),
        (
            "hostile blobs with a recomputed checksum: state word, times, method tag",
            (0..40)
                .map(|k| Deserialize(0, Blob::Word(0, k, f64::NAN.to_bits()), StateArg::NullValue))
                .chain([
                    SetState(0, StateArg::Own(3)),
                    DoStep(0, Cur::Exact, 1e-4),
                    Steps(0, 3),
                ])
                .collect(),
        ),
        (
            "bad arguments in every state",
            vec![
                SetupExperiment(0, Some(f64::NAN), 0.0, None),
                Reset(0),
                SetupExperiment(0, None, 0.0, Some(-1.0)),
                Reset(0),
                EnterInit(0),
                SetReal(0, vec![(Vr::Raw(40), Real::Special(f64::NAN))], false),
                Reset(0),
                PaperScene(0, 2, Some(0.01), false),
                DoStep(0, Cur::Exact, f64::INFINITY),
                PaperScene(0, 2, Some(0.01), false),
                DoStep(0, Cur::Exact, -1e-4),
                PaperScene(0, 2, Some(0.01), false),
                DoStep(0, Cur::Exact, 1.0),
                PaperScene(0, 2, Some(0.01), false),
                DoStep(0, Cur::Rel(1e-3), 1e-4),
                PaperScene(0, 2, Some(0.01), false),
                DoStep(0, Cur::Exact, 5e-324),
                SetReal(0, vec![(Vr::Raw(6), Real::Plausible(0.5))], false),
                PaperScene(0, 1, None, false),
                SetDebugLogging(0, true, Cats::List(vec![Cat::Unknown("logAll".into())])),
                Status(0, 0, 0, false),
            ],
        ),
        (
            "calls in the wrong state",
            vec![
                DoStep(0, Cur::Exact, 1e-4),
                ExitInit(0),
                Terminate(0),
                GetReal(0, vec![Vr::Typed(0)], false),
                Status(0, 1, 2, false),
                EnterInit(0),
                EnterInit(0),
                SetupExperiment(0, None, 0.0, None),
                DoStep(0, Cur::Exact, 1e-4),
                ExitInit(0),
                ExitInit(0),
                SetupExperiment(0, None, 0.0, None),
                Terminate(0),
                Terminate(0),
                DoStep(0, Cur::Exact, 1e-4),
                SetReal(0, vec![(Vr::Raw(40), Real::Plausible(0.5))], false),
                CancelStep(0),
                Unsupported(0, 4),
            ],
        ),
    ]
}

#[test]
fn corpus_sequences() {
    start_watchdog();
    for (name, ops) in corpus() {
        if let Err(e) = run_sequence(&ops) {
            panic!("corpus sequence {name:?}: {e}");
        }
    }
}

#[test]
fn random_call_sequences() {
    start_watchdog();
    let cases: u32 = std::env::var("FMI_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(50_000);
    // The CI pass is bounded in time too: cases past the budget are not run (unless a failure is
    // being shrunk). The cases are the same for a seed; a slower machine runs fewer of them.
    let budget = Duration::from_secs_f64(
        std::env::var("FMI_FUZZ_SECONDS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(40.0),
    );
    let seed = match std::env::var("FMI_FUZZ_SEED").ok().as_deref() {
        None => 0x5350_5552_4745_4152u64,
        Some("random") => now_ms() ^ (std::process::id() as u64) << 32,
        Some(s) => s.parse().expect("FMI_FUZZ_SEED: an integer or 'random'"),
    };
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases,
        max_shrink_iters: 4096,
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "tests/fmi_fuzz.proptest-regressions",
        ))),
        source_file: Some(file!()),
        rng_algorithm: RngAlgorithm::ChaCha,
        max_global_rejects: 1,
        ..Config::default()
    };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes));
    let t0 = Instant::now();
    let (ran, failing) = (AtomicU64::new(0), std::sync::atomic::AtomicBool::new(false));
    let over = std::sync::atomic::AtomicBool::new(false);
    let result = runner.run(&sequence(), |ops| {
        HEARTBEAT.store(now_ms(), Ordering::SeqCst);
        if t0.elapsed() > budget && !failing.load(Ordering::SeqCst) {
            // Ends the run: the first global reject aborts it (max_global_rejects = 1).
            over.store(true, Ordering::SeqCst);
            return Err(TestCaseError::reject("time budget reached"));
        }
        ran.fetch_add(1, Ordering::SeqCst);
        let r = run_sequence(&ops);
        if r.is_err() {
            failing.store(true, Ordering::SeqCst);
        }
        r
    });
    let st = stats();
    eprintln!(
        "fmi_fuzz: seed {seed}, {} of {cases} cases run in {:.1} s (budget {budget:?}); {} successful \
         steps; {} skipped calls; {} hostile blobs accepted; slowest call {:?} ({})",
        ran.load(Ordering::SeqCst),
        t0.elapsed().as_secs_f64(),
        st.steps_ok,
        st.skipped,
        st.hostile_accepted,
        st.max_call.0,
        st.max_call.1
    );
    eprintln!("  states seen: {:?}", st.states_seen);
    eprintln!("  resident set size at the end: {} kB", rss_kb());
    for (f, n) in &st.calls {
        eprintln!(
            "  {f:32} ok {:6} warning {:3} discard {:5} error {:6}",
            n[0], n[1], n[2], n[3]
        );
    }
    drop(st);
    match result {
        Ok(()) => {}
        Err(TestError::Abort(_)) if over.load(Ordering::SeqCst) => {}
        Err(TestError::Fail(why, ops)) => {
            panic!(
                "fmi_fuzz: {why}\nminimal call sequence ({} calls):\n{ops:#?}",
                ops.len()
            )
        }
        Err(e) => panic!("fmi_fuzz: {e}"),
    }
}
