//! The FMU of a gearbox (gearbox-file.md §2) as its binary runs it: instantiated from
//! `resources/gearbox.toml` with its own GUID, it runs SpurGearTrain's model on every train
//! scene with the same traces as SpurGearTrain given the scene's values, a gear's key moves
//! every mesh of the gear, and a missing or damaged file is refused at instantiation.

use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::{Logger, Slave};
use spur_gear_train::fmu::{guid, TrainFmu, RESOURCE};
use spur_gear_train::gearbox::{params, start_values};
use spur_gear_train::gearbox_vars::Target;
use spur_gear_train::instance::SpurGearTrain;
use spur_gear_train::variables::{Causality, VarType, GUID};
use std::path::{Path, PathBuf};

fn silent() -> Logger {
    let categories = <TrainFmu as Slave>::LOG_CATEGORIES;
    Logger::new(None, std::ptr::null_mut(), "gearbox", categories, false)
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A resources directory holding `text` as the gearbox file.
fn resources(text: &str, tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gearbox-fmu-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(RESOURCE), text).unwrap();
    dir
}

fn instantiate(text: &str, tag: &str) -> Result<TrainFmu, String> {
    TrainFmu::instantiate(Some(&resources(text, tag)), &guid(text))
}

fn gearbox_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("scenes/train/gearbox"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .chain([root().join("scenes/gearbox/planetary-simple.toml")])
        .collect();
    files.sort();
    files
}

/// Runs both instances side by side over `steps` communication steps and compares every
/// gearbox variable that is one train variable with that variable of the train, at the start
/// and after every step. Both are the same model with the same values: equal to the bit.
fn in_lockstep(gearbox: &mut TrainFmu, train: &mut SpurGearTrain, steps: usize, h: f64) -> usize {
    let fmu = gearbox.gearbox_fmu().expect("a gearbox FMU").clone();
    let log = silent();
    gearbox.setup_experiment(None, 0.0, None).unwrap();
    train.setup_experiment(None, 0.0, None).unwrap();
    gearbox.exit_initialization().unwrap();
    train.exit_initialization().unwrap();
    let mut compared = 0;
    for k in 0..=steps {
        if k > 0 {
            let t = (k - 1) as f64 * h;
            gearbox.do_step(t, h, &log).unwrap();
            train.do_step(t, h, &log).unwrap();
        }
        for (i, v) in fmu.vars.iter().enumerate() {
            let (vr, info) = (i as u32 + 1, v.train.info());
            let same = match (v.target, info.ty) {
                (Target::Train, VarType::Real) => {
                    let (a, b) = (gearbox.get_real(vr), train.get_real(info.vr));
                    a.unwrap().to_bits() == b.unwrap().to_bits()
                }
                (Target::Train, VarType::Integer) => {
                    gearbox.get_integer(vr).unwrap() == train.get_integer(info.vr).unwrap()
                }
                (Target::Load { bwd }, _) => {
                    let f =
                        train.get_real(info.vr).unwrap() + train.get_real(bwd.info().vr).unwrap();
                    gearbox.get_real(vr).unwrap() == f
                }
                _ => continue,
            };
            assert!(same, "{} ({}) at step {k}", v.name, info.name);
            compared += 1;
        }
    }
    compared
}

/// Every train scene's gearbox file, as a gearbox FMU, runs as SpurGearTrain with the values
/// the file stands for: every output, local and parameter the gearbox FMU shows equals the
/// train's, bit for bit, at every communication point.
#[test]
fn a_gearbox_fmu_runs_as_spur_gear_train_on_every_scene() {
    let files = gearbox_files();
    assert!(files.len() >= 12, "{files:?}");
    for path in &files {
        let text = std::fs::read_to_string(path).unwrap();
        let mut gearbox = instantiate(&text, "scenes").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(gearbox.instance_guid(), guid(&text));
        assert_ne!(gearbox.instance_guid(), GUID);
        // The file fixes the structure: no counts, ends, carriers or front ends to set.
        let fmu = gearbox.gearbox_fmu().unwrap().clone();
        for v in &fmu.vars {
            let field = v.name.rsplit('.').next().unwrap();
            let structural = ["A", "B", "a", "b", "carrier", "geometry", "internal"];
            assert!(!structural.contains(&field), "{}", v.name);
            let counts = ["n_bodies", "n_shafts", "n_meshes"];
            assert!(
                !counts.contains(&v.name.as_str()) && !v.name.contains("mesh["),
                "{}",
                v.name
            );
        }
        let g = gearbox::parse(&text).unwrap();
        let (p, inputs) = params(&start_values(&g).unwrap()).unwrap();
        let mut train = SpurGearTrain::fresh();
        (train.snap.params, train.snap.inputs) = (p, inputs);
        let compared = in_lockstep(&mut gearbox, &mut train, 20, 2e-4);
        assert!(compared > 20 * 10, "{}: {compared}", path.display());
    }
}

/// Model Exchange declares exactly the gearbox's states (two work accounts and a value and a
/// rate per body) and event indicators (each mesh's), and they are the train's first ones.
#[test]
fn model_exchange_has_exactly_the_gearbox_states() {
    let path = root().join("scenes/train/gearbox/two-stage.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let mut a = instantiate(&text, "me").unwrap();
    let fmu = a.gearbox_fmu().unwrap().clone();
    let (nb, nm) = (fmu.gearbox.bodies.len(), fmu.gearbox.meshes.len());
    assert_eq!(a.n_states(), 2 + 2 * nb);
    assert_eq!(
        a.n_event_indicators(),
        nm * (SpurGearTrain::N_EVENT_INDICATORS / 16)
    );
    assert_eq!(a.event_indicator_vr0() as usize, fmu.vars.len() + 1);
    a.setup_experiment(None, 0.0, None).unwrap();
    a.me_exit_initialization().unwrap();
    let mut x = vec![0.0; a.n_states()];
    a.me_states(&mut x).unwrap();
    let mut full = vec![0.0; SpurGearTrain::N_STATES];
    a.train.me_states(&mut full).unwrap();
    assert_eq!(x[..], full[..x.len()]);
    assert!(full[x.len()..].iter().all(|&v| v == 0.0), "{full:?}");
    x[2] += 1e-3;
    a.me_set_states(&x).unwrap();
    let mut dx = vec![0.0; a.n_states()];
    a.me_derivatives(&mut dx).unwrap();
    a.me_states(&mut full[..x.len()]).unwrap();
    assert_eq!(full[2], x[2]);
    let mut z = vec![0.0; a.n_event_indicators()];
    a.me_event_indicators(&mut z).unwrap();
    assert!(z.iter().all(|v| v.is_finite()));
}

/// A speed-driven body's rate is its input, not a state: the spec's example (the generator
/// speed-driven) has one state fewer than two per body, the driven coordinate's rate (the
/// train's state 3: the driven angle is its first coordinate) is the one left out, and a
/// master's set of the states leaves it at the input.
#[test]
fn a_speed_drive_rate_is_not_a_model_exchange_state() {
    let text = std::fs::read_to_string(root().join("scenes/gearbox/nrel-stage1.toml")).unwrap();
    let mut a = instantiate(&text, "me-speed").unwrap();
    let nb = a.gearbox_fmu().unwrap().gearbox.bodies.len();
    assert_eq!(a.n_states(), 2 + 2 * nb - 1);
    let kept: Vec<usize> = (0..2 + 2 * nb).filter(|&i| i != 3).collect();
    assert_eq!(a.gearbox_fmu().unwrap().states, kept);
    assert_eq!(a.state_name(2), "coordinate[1].value");
    assert_eq!(a.state_name(3), "coordinate[2].value");
    a.setup_experiment(None, 0.0, None).unwrap();
    a.me_exit_initialization().unwrap();
    let mut full = vec![0.0; SpurGearTrain::N_STATES];
    a.train.me_states(&mut full).unwrap();
    // The generator's input speed, 18.75 rad/s in the file.
    let w_in = full[3];
    assert!((w_in - 18.75).abs() <= 1e-12 * 18.75, "{w_in}");
    let mut x = vec![0.0; a.n_states()];
    a.me_states(&mut x).unwrap();
    let picked: Vec<f64> = kept.iter().map(|&i| full[i]).collect();
    assert_eq!(x, picked);
    x[4] += 1e-3;
    a.me_set_states(&x).unwrap();
    a.train.me_states(&mut full).unwrap();
    assert_eq!((full[3], full[5]), (w_in, x[4]));
    let mut dx = vec![0.0; a.n_states()];
    a.me_derivatives(&mut dx).unwrap();
    assert!(dx.iter().all(|v| v.is_finite()));
}

/// A gear's key is one variable; setting it sets the pair parameter of every mesh of the gear
/// (the wheel of two-stage meshes once, a planet of planetary-simple twice), and a refused
/// value leaves everything as it was, with the gear's name in the message.
#[test]
fn a_gear_key_sets_every_mesh_of_the_gear() {
    let path = root().join("scenes/gearbox/planetary-simple.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let mut a = instantiate(&text, "gear").unwrap();
    let fmu = a.gearbox_fmu().unwrap().clone();
    let vr = |name: &str| {
        1 + fmu
            .vars
            .iter()
            .position(|v| v.name == name)
            .unwrap_or_else(|| panic!("no {name}")) as u32
    };
    let planet = &fmu
        .gearbox
        .gears
        .iter()
        .find(|g| g.name.ends_with("planet1"))
        .unwrap()
        .name;
    let e = vr(&format!("{planet}.E"));
    a.set_real(&[e], &[1.9e11], false).unwrap();
    assert_eq!(a.get_real(e).unwrap(), 1.9e11);
    let meshes: Vec<usize> = fmu
        .gearbox
        .meshes
        .iter()
        .enumerate()
        .filter(|(_, m)| {
            m.gears
                .iter()
                .any(|&k| &fmu.gearbox.gears[k].name == planet)
        })
        .map(|(i, _)| i + 1)
        .collect();
    assert_eq!(meshes.len(), 2, "a planet meshes with the sun and the ring");
    for m in &meshes {
        let side = |s: &str| spur_gear_train::build::var(&format!("mesh[{m}].E_{s}"));
        let on = [side("A"), side("B")].map(|v| a.train.get_real(v.info().vr).unwrap());
        assert!(on.contains(&1.9e11), "mesh {m}: {on:?}");
    }
    let before = a.get_real(e).unwrap();
    let err = a.set_real(&[e], &[-1.0], false).unwrap_err();
    assert!(
        err.message.contains(&format!("{planet}.E")),
        "{}",
        err.message
    );
    assert!(!err.message.contains("mesh["), "{}", err.message);
    assert_eq!(a.get_real(e).unwrap(), before);
    // A gear's tooth count: fixed once initialized.
    let z = vr(&format!("{planet}.z"));
    a.setup_experiment(None, 0.0, None).unwrap();
    a.exit_initialization().unwrap();
    let err = a.set_integer(&[z], &[20], true).unwrap_err();
    assert!(
        err.message.contains(&format!("{planet}.z")),
        "{}",
        err.message
    );
}

/// Types, unknown value references and outputs are refused in the gearbox's terms.
#[test]
fn wrong_references_are_refused_by_the_gearbox_names() {
    let path = root().join("scenes/train/gearbox/two-stage.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let mut a = instantiate(&text, "refs").unwrap();
    let fmu = a.gearbox_fmu().unwrap().clone();
    let n = fmu.vars.len() as u32;
    let err = a.get_real(n + 1).unwrap_err();
    assert!(
        err.message
            .contains(&format!("unknown value reference {}", n + 1)),
        "{}",
        err.message
    );
    let (k, v) = fmu
        .vars
        .iter()
        .enumerate()
        .find(|(_, v)| v.causality == Causality::Output && v.train.info().ty == VarType::Real)
        .unwrap();
    let err = a.set_real(&[k as u32 + 1], &[1.0], false).unwrap_err();
    assert!(err.message.contains(&v.name), "{}", err.message);
    let err = a.get_integer(k as u32 + 1).unwrap_err();
    assert!(err.message.contains(&v.name), "{}", err.message);
}

/// A missing, damaged or foreign gearbox file fails the instantiation with a message that says
/// which and where; SpurGearTrain's own GUID needs no file.
#[test]
fn a_missing_or_damaged_gearbox_file_is_refused() {
    let text = std::fs::read_to_string(root().join("scenes/train/gearbox/two-stage.toml")).unwrap();
    let g = guid(&text);
    let err = TrainFmu::instantiate(None, &g).unwrap_err();
    assert!(err.contains("no resource location"), "{err}");
    let empty = std::env::temp_dir().join(format!("gearbox-fmu-{}-empty", std::process::id()));
    std::fs::create_dir_all(&empty).unwrap();
    let err = TrainFmu::instantiate(Some(&empty), &g).unwrap_err();
    assert!(
        err.contains("cannot be read") && err.contains(RESOURCE),
        "{err}"
    );
    let damaged = text.replace("J = 0.004", "J = -0.004");
    let err = TrainFmu::instantiate(Some(&resources(&damaged, "damaged")), &g).unwrap_err();
    assert!(err.contains("wheel1") && err.contains("line"), "{err}");
    let cut = &text[..text.len() / 2];
    let err = TrainFmu::instantiate(Some(&resources(cut, "cut")), &g);
    // Half a file may still parse; then it is another gearbox, whose GUID is not this one.
    if let Ok(other) = err {
        assert_ne!(other.instance_guid(), g);
    }
    let plain = TrainFmu::instantiate(None, GUID).unwrap();
    assert_eq!(plain.instance_guid(), GUID);
    assert_eq!(plain.n_states(), SpurGearTrain::N_STATES);
    assert!(plain.gearbox_fmu().is_none());
}

/// An FMU state of a gearbox instance keeps the gears as set, and continues bit for bit.
#[test]
fn a_gearbox_fmu_state_keeps_its_gears() {
    let text = std::fs::read_to_string(root().join("scenes/train/gearbox/two-stage.toml")).unwrap();
    let mut a = instantiate(&text, "state").unwrap();
    let fmu = a.gearbox_fmu().unwrap().clone();
    let mount = 1 + fmu
        .vars
        .iter()
        .position(|v| v.name == "wheel1.mount")
        .unwrap() as u32;
    a.set_real(&[mount], &[0.01], false).unwrap();
    let log = silent();
    a.setup_experiment(None, 0.0, None).unwrap();
    a.exit_initialization().unwrap();
    a.do_step(0.0, 1e-3, &log).unwrap();
    let mut w = Writer::default();
    a.encode(&mut w);
    let bytes = w.into_bytes();
    let fresh = instantiate(&text, "state2").unwrap();
    let mut r = Reader::new(&bytes);
    let mut b = fresh.decode_for(&mut r).unwrap();
    assert!(r.rest().is_empty());
    assert_eq!(b.get_real(mount).unwrap(), 0.01);
    a.do_step(1e-3, 1e-3, &log).unwrap();
    b.do_step(1e-3, 1e-3, &log).unwrap();
    for vr in 1..=fmu.vars.len() as u32 {
        if let (Ok(x), Ok(y)) = (a.get_real(vr), b.get_real(vr)) {
            assert_eq!(
                x.to_bits(),
                y.to_bits(),
                "{}",
                fmu.vars[vr as usize - 1].name
            );
        }
    }
}

// ---- Random call sequences through the exported C functions ---------------------------------

mod fuzz {
    use super::*;
    use fmi2_slave::{CallbackFunctions, Component, LoggerFn, Status};
    use proptest::prelude::*;
    use spur_gear_train::exports::*;
    use std::ffi::CString;
    use std::os::raw::{c_char, c_int, c_void};

    /// A logger that keeps nothing (the FMU passes no variadic arguments: see tests/fmi.rs).
    unsafe extern "C" fn quiet(
        _env: *mut c_void,
        _instance: *const c_char,
        _status: c_int,
        _category: *const c_char,
        _message: *const c_char,
    ) {
    }

    #[derive(Clone, Debug)]
    enum Call {
        SetReal(u32, f64),
        SetInt(u32, i32),
        GetReal(u32),
        Init,
        Step(f64),
        Reset,
        SaveRestore,
    }

    fn call(n: u32) -> impl Strategy<Value = Call> {
        let vr = 0..n + 40;
        let value = prop_oneof![
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(-1.0),
            Just(0.0),
            -1e3..1e3f64,
            1e-9..1e12f64,
        ];
        prop_oneof![
            (vr.clone(), value).prop_map(|(r, x)| Call::SetReal(r, x)),
            (vr.clone(), -2..40i32).prop_map(|(r, x)| Call::SetInt(r, x)),
            vr.prop_map(Call::GetReal),
            Just(Call::Init),
            prop_oneof![Just(-1e-4), Just(0.0), Just(f64::NAN), 1e-6..2e-3f64].prop_map(Call::Step),
            Just(Call::Reset),
            Just(Call::SaveRestore),
        ]
    }

    /// The planetary set's gearbox FMU, its resources as a file: URI.
    fn setup() -> (String, CString, u32) {
        let text =
            std::fs::read_to_string(root().join("scenes/gearbox/planetary-simple.toml")).unwrap();
        let dir = resources(&text, "fuzz");
        let n = instantiate(&text, "fuzz-n")
            .unwrap()
            .gearbox_fmu()
            .unwrap()
            .vars
            .len() as u32;
        (
            guid(&text),
            CString::new(format!("file://{}", dir.display())).unwrap(),
            n,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

        /// Whatever the sequence on a gearbox FMU (any value reference, NaN and infinite
        /// values, steps before initialization, resets, FMU states): statuses are Ok, Warning,
        /// Discard or Error, never a crash or a panic across the boundary, and a value read
        /// with fmi2OK is finite.
        #[test]
        fn random_calls_on_a_gearbox_fmu_never_crash(calls in prop::collection::vec(call(setup().2), 1..25)) {
            let (g, uri, _) = setup();
            let callbacks = CallbackFunctions {
                logger: Some(unsafe {
                    std::mem::transmute::<
                        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char),
                        LoggerFn,
                    >(quiet)
                }),
                allocate_memory: None,
                free_memory: None,
                step_finished: None,
                component_environment: std::ptr::null_mut(),
            };
            let (name, g) = (CString::new("gearbox").unwrap(), CString::new(g).unwrap());
            let c: Component = unsafe {
                fmi2Instantiate(name.as_ptr(), 1, g.as_ptr(), uri.as_ptr(), &callbacks, 0, 0)
            };
            prop_assert!(!c.is_null());
            let mut t = 0.0;
            for call in calls {
                let status = unsafe {
                    match call {
                        Call::SetReal(r, x) => fmi2SetReal(c, &r, 1, &x),
                        Call::SetInt(r, x) => fmi2SetInteger(c, &r, 1, &x),
                        Call::GetReal(r) => {
                            let mut x = 0.0;
                            let s = fmi2GetReal(c, &r, 1, &mut x);
                            if s == Status::Ok {
                                prop_assert!(x.is_finite(), "vr {r} = {x}");
                            }
                            s
                        }
                        Call::Init => {
                            t = 0.0;
                            fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
                            fmi2EnterInitializationMode(c);
                            fmi2ExitInitializationMode(c)
                        }
                        Call::Step(h) => {
                            let s = fmi2DoStep(c, t, h, 1);
                            if s == Status::Ok {
                                t += h;
                            }
                            s
                        }
                        Call::Reset => {
                            t = 0.0;
                            fmi2Reset(c)
                        }
                        Call::SaveRestore => {
                            let mut s = std::ptr::null_mut();
                            let mut size = 0usize;
                            let mut status = fmi2GetFMUstate(c, &mut s);
                            if status == Status::Ok {
                                fmi2SerializedFMUstateSize(c, s, &mut size);
                                let mut bytes = vec![0 as c_char; size];
                                fmi2SerializeFMUstate(c, s, bytes.as_mut_ptr(), size);
                                let mut back = std::ptr::null_mut();
                                status = fmi2DeSerializeFMUstate(c, bytes.as_ptr(), size, &mut back);
                                if status == Status::Ok {
                                    status = fmi2SetFMUstate(c, back);
                                    fmi2FreeFMUstate(c, &mut back);
                                }
                                fmi2FreeFMUstate(c, &mut s);
                            }
                            status
                        }
                    }
                };
                prop_assert!(matches!(status, Status::Ok | Status::Warning | Status::Discard | Status::Error), "{status:?}");
            }
            unsafe { fmi2FreeInstance(c) };
        }
    }
}

/// A mesh with `damping_ratio` shows its chi as a calculated parameter: read, with the value
/// the file's ratio gives (train-fmu/tests/damping_ratio.rs checks what it means), and never
/// set; a mesh with `chi` keeps it tunable.
#[test]
fn damping_ratio_shows_chi_as_a_calculated_parameter() {
    let path = root().join("scenes/train/gearbox/two-stage.toml");
    let text = std::fs::read_to_string(path).unwrap().replace(
        "center_angle = 0.6\n",
        "center_angle = 0.6\ndamping_ratio = 0.05\n",
    );
    let mut a = instantiate(&text, "ratio").unwrap_or_else(|e| panic!("{e}"));
    let fmu = a.gearbox_fmu().unwrap().clone();
    let want = start_values(&fmu.gearbox).unwrap();
    let mut seen = 0;
    for (k, v) in fmu.vars.iter().enumerate() {
        if !v.name.ends_with(".chi") {
            continue;
        }
        let vr = k as u32 + 1;
        let m = fmu
            .gearbox
            .meshes
            .iter()
            .position(|m| v.name == format!("{}.chi", m.name));
        let ratio = matches!(
            fmu.gearbox.meshes[m.unwrap()].damping,
            Some(gearbox::Damping::Ratio(_))
        );
        if !ratio {
            assert_eq!(v.causality, Causality::Parameter, "{}", v.name);
            continue;
        }
        seen += 1;
        assert_eq!(v.causality, Causality::CalculatedParameter, "{}", v.name);
        let chi = a.get_real(vr).unwrap();
        let given = want
            .iter()
            .find(|(n, _)| *n == format!("mesh[{}].chi", m.unwrap() + 1))
            .map(|(_, s)| s.clone());
        assert_eq!(
            given,
            Some(spur_gear_train::gearbox::Start::Real(chi)),
            "{}",
            v.name
        );
        assert!(chi > 0.0 && chi.is_finite());
        let e = a.set_real(&[vr], &[1.0], false).unwrap_err();
        assert!(
            e.message.contains(&v.name) && e.message.contains("calculated"),
            "{}",
            e.message
        );
        assert_eq!(
            a.get_real(vr).unwrap(),
            chi,
            "a refused set changes nothing"
        );
    }
    assert!(seen > 0, "a mesh with damping_ratio");
}
