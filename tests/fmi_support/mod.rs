//! Shared helpers of the tests/fmi_*.rs integration tests: an FMU instance driven through the
//! exported C functions (the same symbols as in the .so, called in-process: the test binary links
//! the crate's rlib and declares the functions itself, from the FMI 2.0 headers, so the tests
//! see the C ABI as a master does and nothing of the crate's Rust-level FMI types), a logger
//! callback that records every message with its status and category, the paper scene, and the
//! resident set size of the process.
#![allow(dead_code, non_snake_case, non_upper_case_globals)]

pub mod ffi;

use ffi::*;
use spur_gear_mesh::variables::{VarType, GUID, VARIABLES};
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int, c_void};
use std::sync::Mutex;

/// One message received by the logger callback.
#[derive(Clone, Debug)]
pub struct Record {
    pub instance: String,
    pub status: c_int,
    pub category: String,
    /// As received: a literal % arrives doubled (%%), ready for a printf-style master.
    pub message: String,
}

impl Record {
    /// The message as a printf-style master shows it.
    pub fn text(&self) -> String {
        self.message.replace("%%", "%")
    }
}

/// What the logger writes to; the instance's componentEnvironment points at it.
#[derive(Default)]
pub struct LogSink {
    pub records: Mutex<Vec<Record>>,
}

impl LogSink {
    pub fn take(&self) -> Vec<Record> {
        std::mem::take(&mut *self.records.lock().unwrap())
    }
    pub fn len(&self) -> usize {
        self.records.lock().unwrap().len()
    }
}

unsafe fn cstr(p: *const c_char) -> String {
    if p.is_null() {
        "<null>".into()
    } else {
        CStr::from_ptr(p).to_string_lossy().into_owned()
    }
}

/// The logger, declared without the variadic tail of fmi2CallbackLogger. Rust cannot define a
/// C-variadic function on stable, so it is transmuted to `LoggerFn`: on x86-64 System V (and
/// AArch64) a variadic call that passes no variadic arguments is ABI-compatible with a call to
/// a non-variadic function of the fixed parameters (the callee only ignores %al). The FMU never
/// passes variadic arguments: it formats the message itself and escapes % as %%.
/// The status is taken as a C int, so a bogus value could not be UB here.
unsafe extern "C" fn record_logger(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    if env.is_null() {
        return;
    }
    let sink = &*(env as *const LogSink);
    let r = Record {
        instance: cstr(instance),
        status,
        category: cstr(category),
        message: cstr(message),
    };
    if std::env::var_os("FMI_TEST_ECHO_LOG").is_some() {
        eprintln!("[{} {} {}] {}", r.instance, r.status, r.category, r.text());
    }
    sink.records.lock().unwrap().push(r);
}

pub fn logger_fn() -> LoggerFn {
    type Plain =
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);
    // SAFETY: see record_logger.
    unsafe { std::mem::transmute::<Plain, LoggerFn>(record_logger as Plain) }
}

extern "C" {
    fn calloc(n: usize, size: usize) -> *mut c_void;
    fn free(p: *mut c_void);
}
unsafe extern "C" fn c_calloc(n: usize, size: usize) -> *mut c_void {
    calloc(n, size)
}
unsafe extern "C" fn c_free(p: *mut c_void) {
    free(p)
}

/// Callback functions whose logger records into `sink`.
pub fn callbacks(sink: &LogSink) -> Box<CallbackFunctions> {
    Box::new(CallbackFunctions {
        logger: Some(logger_fn()),
        allocate_memory: Some(c_calloc),
        free_memory: Some(c_free),
        step_finished: None,
        component_environment: sink as *const LogSink as *mut c_void,
    })
}

/// Value reference of a variable by name (panics on an unknown name: a test bug).
pub fn vr(name: &str) -> u32 {
    VARIABLES
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .vr
}

/// Every Real variable's value reference.
pub fn real_vrs() -> Vec<u32> {
    VARIABLES
        .iter()
        .filter(|v| v.ty == VarType::Real)
        .map(|v| v.vr)
        .collect()
}

pub fn ok(s: Status) -> bool {
    s == Status::Ok
}

/// An instance created through fmi2Instantiate with its logger and callbacks kept alive.
pub struct Fmu {
    pub c: Component,
    pub log: Box<LogSink>,
    _callbacks: Box<CallbackFunctions>,
    _name: CString,
}

// The instance is used by one thread at a time (FMI allows that; it is what the thread test does).
unsafe impl Send for Fmu {}

impl Fmu {
    pub fn new(name: &str) -> Fmu {
        Self::try_new(name, true).expect("fmi2Instantiate")
    }

    pub fn try_new(name: &str, logging_on: bool) -> Option<Fmu> {
        Self::try_new_of(name, logging_on, TYPE_CO_SIMULATION)
    }

    /// A Model Exchange instance.
    pub fn new_me(name: &str) -> Fmu {
        Self::try_new_of(name, true, TYPE_MODEL_EXCHANGE).expect("fmi2Instantiate")
    }

    pub fn try_new_of(name: &str, logging_on: bool, fmu_type: c_int) -> Option<Fmu> {
        let log = Box::<LogSink>::default();
        let cb = callbacks(&log);
        let cname = CString::new(name).unwrap();
        let guid = CString::new(GUID).unwrap();
        let c = unsafe {
            fmi2Instantiate(
                cname.as_ptr(),
                fmu_type,
                guid.as_ptr(),
                c"file:///nonexistent".as_ptr(),
                &*cb,
                0,
                logging_on as c_int,
            )
        };
        (!c.is_null()).then_some(Fmu {
            c,
            log,
            _callbacks: cb,
            _name: cname,
        })
    }

    /// Wraps an instance created elsewhere (its logger, if any, writes to `log`).
    pub fn from_parts(c: Component, log: Box<LogSink>, callbacks: Box<CallbackFunctions>) -> Fmu {
        Fmu {
            c,
            log,
            _callbacks: callbacks,
            _name: CString::default(),
        }
    }

    pub fn set_reals(&self, vrs: &[u32], vals: &[f64]) -> Status {
        assert_eq!(vrs.len(), vals.len());
        unsafe { fmi2SetReal(self.c, vrs.as_ptr(), vrs.len(), vals.as_ptr()) }
    }
    pub fn set_real(&self, name: &str, x: f64) -> Status {
        self.set_reals(&[vr(name)], &[x])
    }
    pub fn set_integer(&self, name: &str, x: i32) -> Status {
        unsafe { fmi2SetInteger(self.c, &vr(name), 1, &x) }
    }
    pub fn set_boolean(&self, name: &str, x: bool) -> Status {
        let b: Boolean = x.into();
        unsafe { fmi2SetBoolean(self.c, &vr(name), 1, &b) }
    }
    /// Sets the ring pair's parameters (`RING_PAIR`) on top of whatever else is set.
    pub fn set_ring_pair(&self) -> Status {
        let worst = |a: Status, b: Status| if b != Status::Ok { b } else { a };
        let mut st = self.set_boolean("internal", true);
        for &(n, x) in RING_PAIR_INTEGERS {
            st = worst(st, self.set_integer(n, x));
        }
        for &(n, x) in RING_PAIR {
            st = worst(st, self.set_real(n, x));
        }
        st
    }
    pub fn get_reals(&self, vrs: &[u32]) -> (Status, Vec<f64>) {
        let mut out = vec![f64::NAN; vrs.len()];
        let s = unsafe { fmi2GetReal(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        (s, out)
    }
    pub fn get_real(&self, name: &str) -> f64 {
        let (s, v) = self.get_reals(&[vr(name)]);
        assert_eq!(s, Status::Ok, "fmi2GetReal({name}): {:?}", self.log.take());
        v[0]
    }
    pub fn get_integer(&self, name: &str) -> i32 {
        let mut v = 0;
        let s = unsafe { fmi2GetInteger(self.c, &vr(name), 1, &mut v) };
        assert_eq!(
            s,
            Status::Ok,
            "fmi2GetInteger({name}): {:?}",
            self.log.take()
        );
        v
    }
    pub fn setup(&self, stop: Option<f64>) -> Status {
        unsafe {
            fmi2SetupExperiment(
                self.c,
                0,
                0.0,
                0.0,
                stop.is_some() as c_int,
                stop.unwrap_or(0.0),
            )
        }
    }
    pub fn enter_init(&self) -> Status {
        unsafe { fmi2EnterInitializationMode(self.c) }
    }
    pub fn exit_init(&self) -> Status {
        unsafe { fmi2ExitInitializationMode(self.c) }
    }
    pub fn do_step(&self, t: f64, h: f64) -> Status {
        unsafe { fmi2DoStep(self.c, t, h, 1) }
    }
    pub fn time(&self) -> f64 {
        let mut t = f64::NAN;
        let s = unsafe { fmi2GetRealStatus(self.c, LAST_SUCCESSFUL_TIME, &mut t) };
        assert_eq!(s, Status::Ok);
        t
    }
    pub fn get_state(&self) -> FmuState {
        let mut s: FmuState = std::ptr::null_mut();
        assert_eq!(unsafe { fmi2GetFMUstate(self.c, &mut s) }, Status::Ok);
        s
    }
    pub fn set_state(&self, s: FmuState) -> Status {
        unsafe { fmi2SetFMUstate(self.c, s) }
    }
    pub fn free_state(&self, mut s: FmuState) -> Status {
        unsafe { fmi2FreeFMUstate(self.c, &mut s) }
    }
    pub fn serialize(&self, s: FmuState) -> Vec<u8> {
        let mut n = 0usize;
        assert_eq!(
            unsafe { fmi2SerializedFMUstateSize(self.c, s, &mut n) },
            Status::Ok
        );
        let mut buf = vec![0u8; n];
        assert_eq!(
            unsafe { fmi2SerializeFMUstate(self.c, s, buf.as_mut_ptr() as *mut c_char, n) },
            Status::Ok
        );
        buf
    }
    /// Deserializes into a new FMU state of this instance.
    pub fn deserialize(&self, blob: &[u8]) -> (Status, FmuState) {
        let mut s: FmuState = std::ptr::null_mut();
        let st = unsafe {
            fmi2DeSerializeFMUstate(self.c, blob.as_ptr() as *const c_char, blob.len(), &mut s)
        };
        (st, s)
    }
    pub fn reset(&self) -> Status {
        unsafe { fmi2Reset(self.c) }
    }
    pub fn terminate(&self) -> Status {
        unsafe { fmi2Terminate(self.c) }
    }

    /// Sets parameters, initializes (start time 0, no stop time) and leaves the instance in
    /// stepComplete. `reals` and `ints` are (name, value) pairs.
    pub fn initialize(&self, reals: &[(&str, f64)], ints: &[(&str, i32)]) {
        for &(n, x) in reals {
            assert_eq!(
                self.set_real(n, x),
                Status::Ok,
                "set {n}: {:?}",
                self.log.take()
            );
        }
        for &(n, x) in ints {
            assert_eq!(
                self.set_integer(n, x),
                Status::Ok,
                "set {n}: {:?}",
                self.log.take()
            );
        }
        assert_eq!(self.setup(None), Status::Ok);
        assert_eq!(self.enter_init(), Status::Ok);
        assert_eq!(self.exit_init(), Status::Ok, "{:?}", self.log.take());
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) };
    }
}

/// The running paper scene (damped, well-conditioned variant): tau_A = 100 N m,
/// c_load = 2, w_A_start = 100 rad/s, w_B_start = 100/1.5 rad/s, chi = 10.
pub const PAPER_SCENE: &[(&str, f64)] = &[
    ("tau_A", 100.0),
    ("c_load", 2.0),
    ("w_A_start", 100.0),
    ("w_B_start", 100.0 / 1.5),
    ("chi", 10.0),
];

/// A pinion in a ring (docs/internal-pair.md's worked pair, scenes/internal-damped.toml): with
/// `internal` true, these integers and reals on top of the paper scene's loads.
pub const RING_PAIR_INTEGERS: &[(&str, i32)] = &[("geometry", 2), ("zA", 20), ("zB", 60)];
pub const RING_PAIR: &[(&str, f64)] = &[
    ("module", 0.002),
    ("xB", 0.5),
    ("width", 0.02),
    ("J_A", 5e-3),
    ("J_B", 0.5),
    ("backlash", 5e-5),
    ("mu", 0.05),
    ("tau_A", 20.0),
    ("c_load", 3.0),
    ("w_A_start", 60.0),
    ("w_B_start", 20.0),
];

pub fn paper_scene(name: &str) -> Fmu {
    let f = Fmu::new(name);
    f.initialize(PAPER_SCENE, &[]);
    f
}

/// Resident set size of this process in kB, from /proc/self/statm.
pub fn rss_kb() -> u64 {
    let s = std::fs::read_to_string("/proc/self/statm").expect("/proc/self/statm");
    let pages: u64 = s.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * page_size() / 1024
}

fn page_size() -> u64 {
    extern "C" {
        fn sysconf(name: c_int) -> std::os::raw::c_long;
    }
    const SC_PAGESIZE: c_int = 30; // Linux
    unsafe { sysconf(SC_PAGESIZE) as u64 }
}

/// Bits of every value, for bit-identical comparisons (NaN-safe).
pub fn bits(xs: &[f64]) -> Vec<u64> {
    xs.iter().map(|x| x.to_bits()).collect()
}
