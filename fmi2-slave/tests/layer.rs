//! The layer with a toy model, through the exported functions `export_fmi2!` defines here:
//! state machine, failures and their log messages, FMU states and their serialization.
//! (The FMUs of the repository test the same functions with their own models.)

#![allow(non_snake_case)]

use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::{error, CallbackFunctions, Component, Failure, FmuState, Logger, Slave, Status};
use std::ffi::{c_void, CStr, CString};
use std::os::raw::{c_char, c_int};
use std::ptr::null_mut;
use std::sync::Mutex;

/// A tank: `level` (vr 2, output) integrates `inflow` (vr 1, input) up to `capacity` (vr 0,
/// parameter); a step that would overflow is discarded.
#[derive(Clone, Debug, PartialEq)]
struct Tank {
    capacity: f64,
    inflow: f64,
    level: f64,
    time: f64,
}

impl Slave for Tank {
    const MODEL_NAME: &'static str = "Tank";
    const LOG_CATEGORIES: &'static [&'static str] =
        &["logEvents", "logStatusDiscard", "logStatusError"];
    const STATE_MAGIC: [u8; 8] = *b"TANKSTAT";
    const STATE_FORMAT_VERSION: u32 = 3;

    fn guid() -> &'static str {
        "{tank}"
    }
    fn fresh() -> Tank {
        Tank {
            capacity: 1.0,
            inflow: 0.0,
            level: 0.0,
            time: 0.0,
        }
    }
    fn setup_experiment(
        &mut self,
        _: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<(), Failure> {
        fmi2_slave::check_experiment_times(start, stop)?;
        self.time = start;
        Ok(())
    }
    fn exit_initialization(&mut self) -> Result<(), Failure> {
        Ok(())
    }
    fn get_real(&mut self, vr: u32) -> Result<f64, Failure> {
        [self.capacity, self.inflow, self.level]
            .get(vr as usize)
            .copied()
            .ok_or_else(|| error(format!("unknown value reference {vr}")))
    }
    fn set_real(&mut self, vrs: &[u32], values: &[f64], running: bool) -> Result<(), Failure> {
        let mut new = self.clone();
        for (&vr, &x) in vrs.iter().zip(values) {
            match vr {
                0 if !running => new.capacity = x,
                1 => new.inflow = x,
                _ => return Err(error(format!("value reference {vr} = {x}: cannot be set"))),
            }
        }
        *self = new;
        Ok(())
    }
    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure> {
        let level = self.level + self.inflow * h;
        if level > self.capacity {
            return Err(Failure {
                status: Status::Discard,
                message: format!("overflow at t = {}", current + h),
            });
        }
        log.log(Status::Ok, "logEvents", &format!("level {level}"));
        self.level = level;
        self.time = current + h;
        Ok(())
    }
    fn time(&self) -> f64 {
        self.time
    }
    fn encode(&self, w: &mut Writer) {
        w.fs(&[self.capacity, self.inflow, self.level, self.time]);
    }
    fn decode(r: &mut Reader) -> Result<Tank, String> {
        let [capacity, inflow, level, time] = r.fs()?;
        Ok(Tank {
            capacity,
            inflow,
            level,
            time,
        })
    }
}

fmi2_slave::export_fmi2!(Tank);

/// Log records (category, message) of every instance of this test binary.
static LOG: Mutex<Vec<(String, String)>> = Mutex::new(Vec::new());

/// The logger is C-variadic, which Rust cannot define on stable; a function with the fixed
/// arguments is called the same way on x86-64 System V (the messages have no format arguments).
unsafe extern "C" fn record(
    _env: *mut c_void,
    _name: *const c_char,
    _status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let text = |p| CStr::from_ptr(p).to_string_lossy().into_owned();
    LOG.lock().unwrap().push((text(category), text(message)));
}

type Plain = unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);

fn callbacks() -> CallbackFunctions {
    CallbackFunctions {
        logger: Some(unsafe {
            std::mem::transmute::<Plain, fmi2_slave::LoggerFn>(record as Plain)
        }),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: null_mut(),
    }
}

fn instantiate(name: &str, guid: &str, logging_on: bool) -> Component {
    let (name, guid) = (CString::new(name).unwrap(), CString::new(guid).unwrap());
    let f = callbacks();
    unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            fmi2_slave::TYPE_CO_SIMULATION,
            guid.as_ptr(),
            c"".as_ptr(),
            &f,
            0,
            logging_on as c_int,
        )
    }
}

/// The messages logged for one instance name since the last call (the tests run in parallel).
fn messages(tag: &str) -> Vec<(String, String)> {
    let mut log = LOG.lock().unwrap();
    let (mine, rest) = log.drain(..).partition(|(_, m)| m.contains(tag));
    *log = rest;
    mine
}

fn level(c: Component) -> f64 {
    let mut x = f64::NAN;
    assert_eq!(unsafe { fmi2GetReal(c, &2, 1, &mut x) }, Status::Ok);
    x
}

#[test]
fn instantiate_checks_the_guid() {
    assert!(instantiate("g", "{other}", false).is_null());
    let m = messages("{other}");
    assert_eq!(m.len(), 1);
    assert_eq!(m[0].0, "logStatusError");
    assert!(m[0].1.starts_with("fmi2Instantiate: GUID"), "{m:?}");
    let c = instantiate("g", "{tank}", false);
    assert!(!c.is_null());
    unsafe { fmi2FreeInstance(c) };
}

#[test]
fn state_machine_failures_and_discard() {
    let c = instantiate("sm", "{tank}", false);
    unsafe {
        // Not allowed before initialization: fmi2Error, logged; the state does not change.
        assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), Status::Error);
        let m = messages("not allowed in state");
        assert_eq!(
            m,
            [(
                "logStatusError".into(),
                "fmi2DoStep: not allowed in state Instantiated".into()
            )]
        );
        // A failing call: the error state, where only a few functions are allowed.
        assert_eq!(
            fmi2SetupExperiment(c, 0, 0.0, f64::NAN, 0, 0.0),
            Status::Error
        );
        assert_eq!(
            messages("startTime")[0].1,
            "fmi2SetupExperiment: startTime = NaN: must be finite"
        );
        assert_eq!(fmi2EnterInitializationMode(c), Status::Error);
        assert!(messages("in state Error")[0]
            .1
            .starts_with("fmi2EnterInitializationMode"));
        assert_eq!(fmi2Reset(c), Status::Ok);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(
            fmi2SetReal(c, [0, 1].as_ptr(), 2, [1.0, 4.0].as_ptr()),
            Status::Ok
        );
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
        // A fixed parameter after initialization: all or none, so the inflow keeps its value.
        assert_eq!(
            fmi2SetReal(c, [1, 0].as_ptr(), 2, [2.0, 9.0].as_ptr()),
            Status::Error
        );
        assert!(messages("cannot be set")[0]
            .1
            .starts_with("fmi2SetReal: value reference 0"));
        assert_eq!(fmi2Reset(c), Status::Ok);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(fmi2SetReal(c, [1].as_ptr(), 1, [4.0].as_ptr()), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
        assert_eq!(fmi2DoStep(c, 0.0, 0.125, 1), Status::Ok);
        assert_eq!(level(c), 0.5);
        // Checked by the layer: the communication point and the step size.
        assert_eq!(fmi2DoStep(c, 0.0, 0.125, 1), Status::Error);
        assert!(messages("does not match")[0]
            .1
            .contains("the FMU's time 0.125"));
        assert_eq!(fmi2Reset(c), Status::Ok);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(fmi2SetReal(c, [1].as_ptr(), 1, [4.0].as_ptr()), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
        // Discard from the model: stepFailed, where fmi2DoStep is not allowed, Terminate is.
        assert_eq!(fmi2DoStep(c, 0.0, 1.0, 1), Status::Discard);
        let m = messages("overflow");
        assert_eq!(
            m,
            [(
                "logStatusDiscard".into(),
                "fmi2DoStep: overflow at t = 1".into()
            )]
        );
        assert_eq!(level(c), 0.0);
        assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), Status::Error);
        assert_eq!(fmi2Terminate(c), Status::Ok);
        // No Integer variables, no Model Exchange.
        let mut i = 0;
        assert_eq!(fmi2GetInteger(c, &7, 1, &mut i), Status::Error);
        assert_eq!(
            messages("Integer")[0].1,
            "fmi2GetInteger: value reference 7: Tank has no Integer variables"
        );
        assert_eq!(fmi2SetTime(c, 0.0), Status::Error);
        assert!(messages("Model Exchange")[0]
            .1
            .starts_with("fmi2SetTime: Tank is a Co-Simulation FMU"));
        fmi2FreeInstance(c);
    }
}

#[test]
fn fmu_states_and_their_serialization() {
    let c = instantiate("st", "{tank}", true);
    let other = instantiate("st-other", "{tank}", false);
    unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(fmi2SetReal(c, [1].as_ptr(), 1, [0.5].as_ptr()), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
        assert_eq!(fmi2DoStep(c, 0.0, 1.0, 1), Status::Ok);
        assert_eq!(
            messages("level 0.5").len(),
            1,
            "logging on: the model's events"
        );
        let mut s: FmuState = null_mut();
        assert_eq!(fmi2GetFMUstate(c, &mut s), Status::Ok);
        let mut size = 0;
        assert_eq!(fmi2SerializedFMUstateSize(c, s, &mut size), Status::Ok);
        let mut blob = vec![0u8; size];
        assert_eq!(
            fmi2SerializeFMUstate(c, s, blob.as_mut_ptr() as *mut c_char, size),
            Status::Ok
        );
        // Magic, format version, GUID, payload (FMI state first: StepComplete = 4), checksum.
        assert_eq!(&blob[..8], b"TANKSTAT");
        assert_eq!(&blob[8..12], &3u32.to_le_bytes());
        assert_eq!(&blob[16..22], b"{tank}");
        assert_eq!(size, 8 + 4 + 4 + 6 + 8 + 8 * 5 + 8);
        assert_eq!(&blob[30..38], &4u64.to_le_bytes());
        assert_eq!(fmi2DoStep(c, 1.0, 1.0, 1), Status::Ok);
        assert_eq!(level(c), 1.0);
        assert_eq!(fmi2SetFMUstate(c, s), Status::Ok);
        assert_eq!(level(c), 0.5);
        // Another instance's state is refused; a deserialized one is its own.
        assert_eq!(fmi2SetFMUstate(other, s), Status::Error);
        let mut t: FmuState = null_mut();
        assert_eq!(
            fmi2DeSerializeFMUstate(other, blob.as_ptr() as *const c_char, size, &mut t),
            Status::Ok
        );
        assert_eq!(fmi2SetFMUstate(other, t), Status::Ok);
        assert_eq!(level(other), 0.5);
        let mut damaged = blob.clone();
        damaged[40] ^= 1;
        let mut u: FmuState = null_mut();
        assert_eq!(
            fmi2DeSerializeFMUstate(c, damaged.as_ptr() as *const c_char, size, &mut u),
            Status::Error
        );
        assert!(messages("rejected")[0].1.contains("checksum mismatch"));
        assert_eq!(fmi2FreeFMUstate(c, &mut s), Status::Ok);
        assert!(s.is_null());
        fmi2FreeInstance(c);
        fmi2FreeInstance(other);
    }
}

#[test]
fn debug_categories_follow_logging_on_status_categories_stay() {
    let quiet = Logger::new(
        Some(callbacks().logger.unwrap()),
        null_mut(),
        "q",
        Tank::LOG_CATEGORIES,
        false,
    );
    assert!(!quiet.enabled("logEvents"));
    assert!(quiet.enabled("logStatusError") && quiet.enabled("logStatusDiscard"));
    // Not declared: a status category is still reported, a debug category never.
    assert!(quiet.enabled("logStatusFatal") && !quiet.enabled("logSolver"));
    let mut loud = Logger::new(None, null_mut(), "l", Tank::LOG_CATEGORIES, true);
    assert!(
        !loud.enabled("logEvents"),
        "no callback, nothing is enabled"
    );
    assert!(loud.set("logEvents", false) && !loud.set("logAll", true));
}

#[test]
fn guid_text() {
    let g = fmi2_slave::guid_from_hash(*b"table");
    assert_eq!(g.len(), 38);
    assert!(g.starts_with('{') && g.ends_with('}') && g.matches('-').count() == 4);
    assert_eq!(g, fmi2_slave::guid_from_hash(*b"table"));
    assert_ne!(g, fmi2_slave::guid_from_hash(*b"tablf"));
}

/// The time's resolution, checked by the layer for every model: a step with t + h == t is
/// refused like h = 0; a step the time resolves coarsely advances by (t + h) - t, the model is
/// handed that interval, and the log says so once per instance.
#[test]
fn steps_lost_in_the_time_or_resolved_coarsely() {
    let init = |c: Component, start: f64| unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, start, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(fmi2SetReal(c, [1].as_ptr(), 1, [1.0].as_ptr()), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
    };
    let c = instantiate("resolution", "{tank}", false);
    unsafe {
        init(c, 1e15);
        assert_eq!(fmi2DoStep(c, 1e15, 1e-4, 1), Status::Error);
        let m = messages("t + h == t");
        assert_eq!(m.len(), 1);
        assert_eq!(
            m[0],
            (
                "logStatusError".into(),
                "fmi2DoStep: t + h == t in double precision (t = currentCommunicationPoint = \
                 1e15 s, h = communicationStepSize = 1e-4 s): the step is lost in the time's \
                 resolution (the doubles near t are 1.25e-1 s apart)"
                    .into()
            )
        );
        assert_eq!(level(c), 0.0);
        assert_eq!(fmi2Reset(c), Status::Ok);
        init(c, 1e12);
        let h = (1e12 + 1e-4) - 1e12;
        assert_eq!(fmi2DoStep(c, 1e12, 1e-4, 1), Status::Warning);
        assert_eq!(fmi2DoStep(c, 1e12 + h, 1e-4, 1), Status::Ok);
        let m = messages("coarsely");
        assert_eq!(m.len(), 1, "once per instance: {m:?}");
        assert_eq!(m[0].0, "logStatusWarning");
        assert!(m[0].1.contains("(t + h) - t = 1.220703125e-4 s"), "{m:?}");
        assert_eq!(
            level(c),
            2.0 * h,
            "the model integrates the represented interval"
        );
        assert_eq!(fmi2Reset(c), Status::Ok);
        init(c, 0.0);
        assert_eq!(fmi2DoStep(c, 0.0, 1e-4, 1), Status::Ok);
        assert_eq!(level(c), 1e-4);
        assert!(messages("coarsely").is_empty());
        fmi2FreeInstance(c);
    }
}
