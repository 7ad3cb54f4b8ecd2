//! Gearbox files (gearbox-file.md §1) through SpurGearTrain's start values: every train scene
//! has a gearbox file that gives the same parameters and inputs bit for bit (so the same
//! traces), the spec's example loads as written, and refusals name the file's elements.

use gear_model::driver::train_simulation::TrainSimulation;
use gear_model::model::train::statics::static_start;
use proptest::prelude::*;
use spur_gear_train::build;
use spur_gear_train::gearbox::{params, start_values, Start};
use spur_gear_train::variables::{Var, VarType};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A scene's `[start_values]`, typed as the table declares each variable.
fn scene_values(path: &Path) -> Vec<(String, Start)> {
    let text = std::fs::read_to_string(path).unwrap();
    let scene: toml::Table = toml::from_str(&text).unwrap();
    let table = scene["start_values"].as_table().expect("[start_values]");
    table
        .iter()
        .map(|(name, x)| {
            let v = Var::from_name(name).unwrap_or_else(|| panic!("{name}"));
            let start = match (v.info().ty, x) {
                (VarType::Real, toml::Value::Float(f)) => Start::Real(*f),
                (VarType::Real, toml::Value::Integer(i)) => Start::Real(*i as f64),
                (VarType::Integer, toml::Value::Integer(i)) => Start::Integer(*i as i32),
                (VarType::Boolean, toml::Value::Boolean(b)) => Start::Boolean(*b),
                (VarType::String, toml::Value::String(s)) => Start::String(s.clone()),
                (ty, x) => panic!("{}: {name} = {x} for a {ty:?}", path.display()),
            };
            (name.clone(), start)
        })
        .collect()
}

fn gearbox_values(path: &Path) -> Result<Vec<(String, Start)>, String> {
    let g = gearbox::load(path).map_err(|e| e.0)?;
    start_values(&g)
}

/// Every scene of scenes/train has a gearbox file beside it (gearbox/NAME.toml) whose start
/// values set the train's parameters and inputs exactly as the scene's do: the same model
/// runs, so the traces are the scene's to the last bit.
#[test]
fn every_train_scene_is_a_gearbox_file() {
    let dir = root().join("scenes/train");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_str().unwrap();
            name.ends_with(".toml")
        })
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 11, "{scenes:?}");
    for scene in &scenes {
        let file = dir.join("gearbox").join(scene.file_name().unwrap());
        let (p, i) = params(&scene_values(scene)).unwrap();
        let given = gearbox_values(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let (q, j) = params(&given).unwrap();
        assert!(
            p == q,
            "{}: the parameters differ from the scene's",
            file.display()
        );
        assert!(
            i == j,
            "{}: the inputs differ from the scene's",
            file.display()
        );
    }
}

fn spec_example() -> String {
    std::fs::read_to_string(root().join("scenes/gearbox/nrel-stage1.toml")).unwrap()
}

/// scenes/gearbox/nrel-stage1.toml is the spec's example as written, and it loads: the
/// planetary shorthand's names, the gears declared once, the senses' order.
#[test]
fn the_spec_example_loads_as_written() {
    let spec = root().join("../shared/spec/gearbox-file.md");
    let text = spec_example();
    if let Ok(md) = std::fs::read_to_string(&spec) {
        let block = md
            .split("```toml\n")
            .nth(1)
            .unwrap()
            .split("```")
            .next()
            .unwrap();
        assert_eq!(
            block, text,
            "scenes/gearbox/nrel-stage1.toml is the spec's example"
        );
    }
    let g = gearbox::parse(&text).unwrap();
    let names = |v: Vec<&str>| v.join(" ");
    assert_eq!(
        names(g.bodies.iter().map(|b| b.name.as_str()).collect()),
        "stage1.sun stage1.carrier stage1.planet1 stage1.planet2 stage1.planet3 hss generator"
    );
    assert_eq!(
        names(g.meshes.iter().map(|m| m.name.as_str()).collect()),
        "stage1.sun_planet1 stage1.sun_planet2 stage1.sun_planet3 stage1.planet1_ring \
         stage1.planet2_ring stage1.planet3_ring wheel_hss"
    );
    assert_eq!(g.shafts[0].name, "hss_generator");
    // The sun's body carries two gears: its own and the wheel.
    let wheel = g.gears.iter().find(|x| x.name == "wheel").unwrap();
    assert_eq!(wheel.support, gearbox::Support::Body(0));
    assert_eq!(wheel.module, Some(0.014));
    let ring = g.gears.iter().find(|x| x.name == "stage1.ring").unwrap();
    assert!(ring.internal && ring.support == gearbox::Support::Housing);
    assert_eq!(g.meshes[3].backlash, Some(5e-4), "[defaults]");
    // The generator is speed-driven: its input's start value is its start speed.
    let v = start_values(&g).unwrap();
    assert!(v.contains(&("body[7].drive".into(), Start::Integer(1))));
    assert!(!v.iter().any(|(n, _)| n == "body[7].w_start"));
}

/// The example's start values: the speeds by rigid rolling from the carrier's, Willis's sun
/// speed w_c (1 + z_ring / z_sun) and the parallel stage's ratio 95/24 (planetary.md §6); the
/// speed-driven generator's is its input `w_in`.
#[test]
fn start_speeds_follow_rigid_rolling() {
    let text = spec_example();
    let v = start_values(&gearbox::parse(&text).unwrap()).unwrap();
    let w = |i: usize| {
        let key = if i == 7 { "w_in" } else { "w_start" };
        match v.iter().find(|(n, _)| *n == format!("body[{i}].{key}")) {
            Some((_, Start::Real(x))) => *x,
            other => panic!("{other:?}"),
        }
    };
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs();
    let sun = 1.2 * (1.0 + 56.0 / 19.0);
    assert!(close(w(2), 1.2) && close(w(1), sun), "{} {}", w(1), w(2));
    assert!(
        close(w(6), sun * 95.0 / 24.0) && close(w(7), w(6)),
        "{} {}",
        w(6),
        w(7)
    );
    // Planets relative to the carrier: z_sun (w_sun - w_c) = z_planet (w_p + w_c) in
    // forward senses (the planet turns the other way).
    for p in 3..=5 {
        assert!(
            close(19.0 * (w(1) - 1.2), 17.0 * (w(p) + 1.2)),
            "planet {p}: {}",
            w(p)
        );
    }
    // A second w_start that contradicts rolling is refused, naming the mesh.
    let wrong = text.replace("J = 20.0\n", "J = 20.0\nw_start = 20.0\n");
    let e = start_values(&gearbox::parse(&wrong).unwrap()).unwrap_err();
    assert!(
        e.contains("hss.w_start = 20") && e.contains("contradict rigid rolling"),
        "{e}"
    );
}

fn refusal(text: &str) -> String {
    match gearbox::parse(text) {
        Err(e) => e.0,
        Ok(g) => start_values(&g).expect_err("refused"),
    }
}

/// Refusals name the file's elements and lines, never `mesh[4]`.
#[test]
fn refusals_name_the_files_elements() {
    let text = spec_example().replace("drive = \"speed\"", "");
    let cases = [
        // An unknown key.
        (
            text.replace("J = 534.0", "J = 534.0\ninertia = 3.0"),
            "body generator: unknown field `inertia`",
            "inertia = 3.0",
        ),
        // A gear meshing with a gear of another module.
        (
            text.replace(
                "gear = { z = 24, module = 0.014",
                "gear = { z = 24, module = 0.016",
            ),
            "mesh wheel_hss: gear wheel (module 0.014 m",
            "gears = [\"wheel\", \"hss\"]",
        ),
        // Two internal gears in one mesh.
        (
            text.replace("z = 95\n", "z = 95\ninternal = true\n")
                .replace("z = 24, module", "z = 24, internal = true, module"),
            "mesh wheel_hss: gears wheel and hss are both internal",
            "gears = [\"wheel\", \"hss\"]",
        ),
        // A gear with too few teeth: the model's refusal in the file's names.
        (text.replace("z = 95\n", "z = 2\n"), "wheel.z = 2", "z = 2"),
    ];
    for (file, start, key_line) in cases {
        let at = file.lines().position(|l| l.contains(key_line)).unwrap() + 1;
        let e = refusal(&file);
        assert!(e.contains(&start), "{e}\n does not contain: {start}");
        assert!(e.ends_with(&format!("(line {at})")), "{e}: line {at}");
        assert!(!e.contains("mesh["), "{e}");
    }
}

/// An orbit radius that does not fit the ring, and a ring shift with the sign of the sources
/// that count a ring's teeth as negative.
#[test]
fn planetary_refusals_name_the_set() {
    let text = spec_example().replace("drive = \"speed\"", "");
    // 57 teeth: the sun-planet centre distance no longer equals the planet-ring one.
    let e = refusal(&text.replace("ring = { z = 56", "ring = { z = 57"));
    assert!(
        e.starts_with("mesh stage1.planet1_ring") && e.contains("orbit radius"),
        "{e}"
    );
    assert!(!e.contains("mesh[") && !e.contains("body["), "{e}");
    let e = refusal(&text.replace("x = 0.501", "x = -0.501"));
    assert!(e.contains("no operating pressure angle"), "{e}");
    assert!(
        e.contains("gear stage1.ring is internal with x = -0.501")
            && e.contains("x = 0.501 may be meant"),
        "{e}"
    );
    assert!(!e.contains("mesh["), "{e}");
}

/// A scene's gearbox file with its written-out running start taken out: the static start
/// finds it.
fn static_scene(name: &str) -> String {
    let text =
        std::fs::read_to_string(root().join(format!("scenes/train/gearbox/{name}.toml"))).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            !["dte_start", "twist_start", "static_start"]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .collect();
    kept.join("\n")
}

/// The train a gearbox file describes, as the FMU builds it at initialization.
fn simulation(text: &str) -> TrainSimulation {
    let v = start_values(&gearbox::parse(text).unwrap()).unwrap();
    let (p, inputs) = params(&v).unwrap();
    let loads = build::loads(&p, &inputs, &Default::default());
    let mut spec = build::spec(&p, &inputs).unwrap();
    if p.static_start {
        spec = static_start(spec, &loads).unwrap();
    }
    TrainSimulation::new(spec, loads.tau.clone(), None, 1, 0.0, 1e-9).unwrap()
}

/// The static start solves the balance the independent reference solved for the scenes'
/// running starts (tests/reference_model/train_ref.py, quasi_static_start: the rigid train's
/// loads, then each mesh's deflection under its load), so the deflections agree to the
/// reference's own solve (its general mode iterates to about 1e-10): 1e-9 of each. A wrong
/// load share, flank or pair count would move them by 1e-3 and more. Left out: `internal`,
/// whose friction the static start balances and the reference leaves out (without it they
/// agree as well), `single`, whose start places a pair on the edge of its gate, and
/// `planetary-two-stage`, refused below.
#[test]
fn static_start_is_the_reference_running_start() {
    for name in [
        "two-stage",
        "idler",
        "rattle",
        "planetary-simple",
        "planetary-pin-error",
        "planetary-mounted",
        "power-split",
    ] {
        let got = simulation(&static_scene(name));
        let (p, i) = params(&scene_values(
            &root().join(format!("scenes/train/{name}.toml")),
        ))
        .unwrap();
        let want = build::spec(&p, &i).unwrap();
        let pairs = got
            .train()
            .spec()
            .meshes
            .iter()
            .zip(&want.meshes)
            .map(|(a, b)| (a.dte_start, b.dte_start));
        let twists = got
            .train()
            .spec()
            .shafts
            .iter()
            .zip(&want.shafts)
            .map(|(a, b)| (a.twist_start, b.twist_start));
        for (k, (a, b)) in pairs.chain(twists).enumerate() {
            assert!(
                (a - b).abs() <= 1e-9 * b.abs(),
                "{name}, element {}: {a:e} against {b:e}",
                k + 1
            );
        }
    }
    let text = static_scene("internal").replace("mu = ", "# mu = ");
    let got = simulation(&text);
    let (p, i) = params(&scene_values(&root().join("scenes/train/internal.toml"))).unwrap();
    for (a, b) in got
        .train()
        .spec()
        .meshes
        .iter()
        .zip(&build::spec(&p, &i).unwrap().meshes)
    {
        let (a, b) = (a.dte_start, b.dte_start);
        assert!(
            (a - b).abs() <= 1e-9 * b.abs(),
            "internal without friction: {a:e} against {b:e}"
        );
    }
    // A loop-closing mesh whose start the mounts fix: refused, in the file's names.
    let e =
        start_values(&gearbox::parse(&static_scene("planetary-two-stage")).unwrap()).unwrap_err();
    assert!(
        e.starts_with("static start: mesh stage2.sun_planet1") && e.contains("mounts"),
        "{e}"
    );
}

/// Until the first tooth-pair switch the mesh forces of a static start stay within 1 % of
/// their value at t = 0. A start whose deflections are off by a fraction e rings at the
/// train's mesh modes from the first instant, the force swinging by about e (1 - cos w t):
/// the window holds at least 0.3 of the fastest mode's period, where that is 0.7 e, so an
/// error of 1.5 % shows. Before a switch only the contact points' slow travel along the
/// flanks changes the balance. The same trains started at zero deflection leave the band in
/// the same window (the check can fail).
#[test]
fn static_start_holds_the_mesh_forces_until_a_pair_switches() {
    let force = |sim: &TrainSimulation| -> Vec<f64> {
        let y = sim.state();
        (0..sim.train().meshes.len())
            .map(|m| {
                let r = sim.train().mesh_readout(m, &y).unwrap();
                r.flank_force[0] - r.flank_force[1]
            })
            .collect()
    };
    for name in [
        "two-stage",
        "idler",
        "rattle",
        "internal",
        "planetary-simple",
        "planetary-pin-error",
        "planetary-mounted",
        "power-split",
    ] {
        let text = static_scene(name);
        let mut sim = simulation(&text);
        let f0 = force(&sim);
        let scale = f0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let fastest = 2.0 * std::f64::consts::PI / sim.train().vibration_frequency(&sim.state());
        // The first switch, from a run of its own.
        let mut probe = sim.clone();
        let mut first = f64::INFINITY;
        probe
            .advance(20.0 * fastest, &mut |t, r| {
                if !r.smooth {
                    first = first.min(t)
                }
            })
            .unwrap();
        let window = first.min(20.0 * fastest);
        assert!(
            window >= 0.3 * fastest,
            "{name}: a switch after {window:e} s, the fastest mode's period {fastest:e} s"
        );
        let mut unbalanced = simulation(&format!("static_start = false\n{text}"));
        let mut worst = [0.0f64; 2];
        for k in 1..=100 {
            let t = window * (k as f64 / 100.0) * (1.0 - 1e-9);
            for (run, sim) in [&mut sim, &mut unbalanced].into_iter().enumerate() {
                sim.advance(t, &mut |_, _| {}).unwrap();
                for (f, g) in force(sim).iter().zip(&f0) {
                    worst[run] = worst[run].max((f - g).abs() / scale);
                }
            }
        }
        eprintln!(
            "{name}: window {window:e} s ({:.2} fastest periods), {worst:?}",
            window / fastest
        );
        assert!(
            worst[0] <= 0.01,
            "{name}: the static start's forces move by {:.3} %",
            100.0 * worst[0]
        );
        assert!(
            worst[1] > 0.1,
            "{name}: a start at zero deflection moves the forces by only {:.3} %",
            100.0 * worst[1]
        );
    }
}

/// The [[planetary]] shorthand with the static start (scenes/gearbox/planetary-simple.toml) is
/// the scene planetary-simple: the same train, its speeds by rigid rolling from the sun's, and
/// the start deflections of the scene's hand-written running start (to 1e-9, as above).
#[test]
fn the_planetary_shorthand_is_the_scene() {
    let text =
        std::fs::read_to_string(root().join("scenes/gearbox/planetary-simple.toml")).unwrap();
    let sim = simulation(&text);
    let (p, i) = params(&scene_values(
        &root().join("scenes/train/planetary-simple.toml"),
    ))
    .unwrap();
    let want = build::spec(&p, &i).unwrap();
    let got = sim.train().spec();
    assert_eq!(got.bodies.len(), want.bodies.len());
    for (a, b) in got.bodies.iter().zip(&want.bodies) {
        assert!(
            (a.w_start - b.w_start).abs() <= 1e-12 * b.w_start.abs(),
            "{} {}",
            a.w_start,
            b.w_start
        );
        assert_eq!((a.j, a.c, a.planet), (b.j, b.c, b.planet));
    }
    for (a, b) in got.meshes.iter().zip(&want.meshes) {
        assert_eq!((a.a, a.b), (b.a, b.b));
        let (x, y) = (a.dte_start, b.dte_start);
        assert!((x - y).abs() <= 1e-9 * y.abs(), "{x:e} against {y:e}");
        assert!(a.pair == b.pair, "the pair");
    }
}

/// One damage to a gearbox file.
#[derive(Clone, Debug)]
enum Damage {
    /// Leave line k out.
    Drop(usize),
    /// Write line k twice.
    Twice(usize),
    /// Put x in place of the first number on line k.
    Number(usize, f64),
    /// Put this text in place of line k.
    Line(usize, &'static str),
}

fn damage() -> impl Strategy<Value = Damage> {
    let number = prop_oneof![
        Just(0.0),
        Just(-1.0),
        Just(2.0),
        Just(1e300),
        Just(f64::NAN),
        Just(f64::INFINITY),
        -1e3..1e3f64,
    ];
    let line = prop_oneof![
        Just("[[body]]"),
        Just("[[mesh]]"),
        Just("gears = [\"wheel\", \"wheel\"]"),
        Just("carrier = \"hss\""),
        Just("planets = 0"),
        Just("x = 0.501"),
        Just("z = 3"),
        Just("name = \"stage1\""),
        Just("bodies = [\"housing\", \"housing\"]"),
        Just("static_start = false"),
        Just("= 1"),
    ];
    prop_oneof![
        (0..60usize).prop_map(Damage::Drop),
        (0..60usize).prop_map(Damage::Twice),
        (0..60usize, number).prop_map(|(k, x)| Damage::Number(k, x)),
        (0..60usize, line).prop_map(|(k, l)| Damage::Line(k, l)),
    ]
}

/// The first number of a line replaced (TOML's own spelling of the special values).
fn with_number(line: &str, x: f64) -> String {
    let text = if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        "inf".into()
    } else {
        format!("{x:?}")
    };
    let start = line.find(|c: char| c.is_ascii_digit());
    match start {
        Some(a) => {
            let end = line[a..]
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '-' || c == '+'))
                .map_or(line.len(), |e| a + e);
            format!("{}{text}{}", &line[..a], &line[end..])
        }
        None => line.to_owned(),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Whatever damage a gearbox file takes, reading it and making SpurGearTrain's start values
    /// (the train built, the static start solved) ends in values or in a refusal that says
    /// something: never a panic, never a value that is not finite.
    #[test]
    fn a_damaged_gearbox_file_is_refused_or_read(damages in prop::collection::vec(damage(), 1..4)) {
        let base = spec_example().replace("drive = \"speed\"", "");
        let mut lines: Vec<String> = base.lines().map(str::to_owned).collect();
        for d in &damages {
            let n = lines.len().max(1);
            match *d {
                Damage::Drop(k) => { if !lines.is_empty() { lines.remove(k % n); } }
                Damage::Twice(k) => { let l = lines[k % n].clone(); lines.insert(k % n, l); }
                Damage::Number(k, x) => { lines[k % n] = with_number(&lines[k % n], x); }
                Damage::Line(k, l) => { lines[k % n] = l.to_owned(); }
            }
        }
        let text = lines.join("\n");
        match gearbox::parse(&text).map_err(|e| e.0).and_then(|g| start_values(&g)) {
            Ok(v) => {
                for (name, x) in v {
                    if let Start::Real(x) = x {
                        prop_assert!(x.is_finite(), "{name} = {x}");
                    }
                }
            }
            Err(e) => prop_assert!(e.len() > 10, "{e:?}"),
        }
    }
}

/// Means over a window of a run of the spec's example: each mesh's normal force, the bodies'
/// angles travelled, `housing.tau` and the generator's drive torque.
struct Window {
    force: Vec<f64>,
    travel: Vec<f64>,
    housing: f64,
    drive: f64,
    /// The largest change of any mesh's dte in the window \[m\].
    dte_spread: f64,
}

fn run_window(text: &str, t_end: f64, samples: usize) -> Window {
    let mut sim = simulation(text);
    let n = sim.train().meshes.len();
    let y0 = sim.state();
    let (theta0, dte0): (Vec<f64>, Vec<f64>) = (
        sim.train().bodies(&y0).theta[..7].to_vec(),
        (0..n).map(|m| sim.train().dte(m, &y0)).collect(),
    );
    let mut w = Window {
        force: vec![0.0; n],
        travel: vec![],
        housing: 0.0,
        drive: 0.0,
        dte_spread: 0.0,
    };
    for k in 1..=samples {
        sim.advance(t_end * k as f64 / samples as f64, &mut |_, _| {})
            .unwrap();
        let (y, t) = (sim.state(), &sim.train());
        for m in 0..n {
            let r = t.mesh_readout(m, &y).unwrap();
            w.force[m] += (r.flank_force[0] + r.flank_force[1]) / samples as f64;
            w.dte_spread = w.dte_spread.max((t.dte(m, &y) - dte0[m]).abs());
        }
        w.housing += t.housing_torque(&y).unwrap() / samples as f64;
        w.drive += t.drive_torque(6, &y).unwrap() / samples as f64;
    }
    let theta = sim.train().bodies(&sim.state()).theta;
    w.travel = (0..7).map(|i| theta[i] - theta0[i]).collect();
    w
}

/// The spec's example runs (gearbox-file.md §1, planetary.md §6): carrier driven by its
/// torque, generator held at its speed input. Over the planetary stage's first mesh period
/// 2 pi / (z_ring w_c):
/// - Willis: the sun travels (1 + z_ring / z_sun) times the carrier's angle, and the hss 95/24
///   times the sun's. The angles leave rigid rolling by the meshes' deflection changes, at
///   most `dte_spread` over base radii of 0.16 m and more: that bounds the ratios' error.
/// - Torques: T_sun = T_c z_sun / (z_sun + z_ring) passes to the parallel stage; the ring
///   takes the rest (`housing.tau`, counter-clockwise, the carrier turning clockwise), and the
///   generator's drive holds T_c w_c / w_gen (no tooth friction: mu = 0).
/// - The static start: each mesh's force, in the mean over its first mesh period, within 1 %
///   of its static value: T_sun / (3 rb_sun) for every planet mesh (equal sharing, §6),
///   T_sun / rb_wheel for the parallel stage. The instantaneous forces vary by tens of
///   percent with the pairs in contact (the mesh stiffness's variation, the excitation the
///   model is for); started from untouched teeth instead, the means miss by far more.
#[test]
fn the_spec_example_runs_as_planetary_md_6_says() {
    let (z_s, z_r, t_c, w_c, w_gen) = (19.0, 56.0, 4.1667e6, 1.2, 18.75);
    let base = |module: f64, z: f64| module * z * 20f64.to_radians().cos() / 2.0;
    let (rb_sun, rb_wheel, rb_hss) = (base(0.045, z_s), base(0.014, 95.0), base(0.014, 24.0));
    let t_sun = t_c * z_s / (z_s + z_r);
    let planet_period = 2.0 * std::f64::consts::PI / (z_r * w_c);
    let wheel_period = 2.0 * std::f64::consts::PI / (95.0 * w_c * (1.0 + z_r / z_s));
    let text = spec_example();
    let w = run_window(&text, planet_period, 2000);
    let rel = |x: f64, want: f64| (x - want).abs() / want.abs();
    // Sun (body 1) against carrier (2): theta_s - (1 + z_r/z_s) theta_c is the sum of a sun
    // and a ring mesh's dte over rb_sun; hss (6) against sun: the parallel mesh's over rb_hss.
    let willis_tol = 2.0 * w.dte_spread / (rb_sun * w.travel[1].abs());
    let parallel_tol = w.dte_spread / (rb_hss * w.travel[0].abs());
    assert!(
        willis_tol.max(parallel_tol) < 1e-2,
        "deflections of {} m",
        w.dte_spread
    );
    let willis = w.travel[0] / w.travel[1];
    assert!(
        rel(willis, 1.0 + z_r / z_s) <= willis_tol,
        "Willis: {willis}"
    );
    let parallel = w.travel[5] / w.travel[0];
    assert!(
        rel(parallel, 95.0 / 24.0) <= parallel_tol,
        "parallel: {parallel}"
    );
    assert!(
        rel(w.travel[6], w_gen * planet_period) <= 1e-12,
        "the generator holds w_in"
    );
    for (what, x, want) in [
        ("housing.tau", w.housing, -(t_c - t_sun)),
        ("generator.tau_drive", w.drive, -t_c * w_c / w_gen),
    ] {
        assert!(rel(x, want) <= 0.01, "{what}: {x}, closed form {want}");
    }
    let want: Vec<f64> = (0..7)
        .map(|m| match m {
            6 => t_sun / rb_wheel,
            _ => t_sun / (3.0 * rb_sun),
        })
        .collect();
    let wheel = run_window(&text, wheel_period, 400);
    for m in 0..7 {
        let mean = if m == 6 { wheel.force[m] } else { w.force[m] };
        assert!(
            rel(mean, want[m]) <= 0.01,
            "mesh {m}: mean force {mean}, static {}",
            want[m]
        );
    }
    // Without the static start the same means are far off: the check sees a start transient.
    let cold = run_window(
        &text.replace("description =", "static_start = false\ndescription ="),
        wheel_period,
        400,
    );
    assert!(rel(cold.force[6], want[6]) > 0.05, "{}", cold.force[6]);
}
