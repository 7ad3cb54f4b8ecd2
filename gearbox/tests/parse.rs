//! The file alone (gearbox-file.md §1): what it expands to, and what it refuses, each refusal
//! naming the element, the key and the line.

use gearbox::{parse, Damping, Drive, Support};
use std::f64::consts::PI;

const PAIR: &str = r#"
name = "Pair"
[defaults]
module = 0.003
[[body]]
name = "pinion"
J = 0.01
gear = { z = 20, mount_deg = 90 }
[[body]]
name = "wheel"
J = 0.5
gear = { z = 40 }
[[mesh]]
gears = ["pinion", "wheel"]
center_angle_deg = 30
"#;

fn refusal(text: &str) -> String {
    parse(text).expect_err("refused").0
}

/// The line of the needle's last occurrence.
fn line(text: &str, needle: &str) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.contains(needle))
        .last()
        .unwrap()
        .0
        + 1
}

#[test]
fn a_pair_with_inline_gears_and_degrees() {
    let g = parse(PAIR).unwrap();
    assert_eq!(g.gears.len(), 2);
    assert_eq!(g.gears[0].name, "pinion");
    assert_eq!(g.gears[0].support, Support::Body(0));
    assert_eq!(g.gears[1].module, Some(0.003), "[defaults]");
    assert_eq!(g.gears[0].mount, Some(PI / 2.0));
    assert_eq!(g.meshes[0].name, "pinion_wheel");
    assert_eq!(g.meshes[0].center_angle, Some(30f64.to_radians()));
    assert_eq!(g.meshes[0].damping, None, "the model's default applies");
    assert_eq!(g.bodies[0].drive, Drive::Torque);
}

#[test]
fn a_planetary_set_expands_in_the_specs_order() {
    let text = r#"
name = "Set"
[defaults]
module = 0.002
chi = 20.0
[[body]]
name = "input"
J = 1.0
[[planetary]]
name = "s"
sun = { z = 21, J = 0.002 }
planet = { z = 18, J = 1e-4, m = 0.3 }
ring = { z = 57, fixed = true }
carrier = { J = 0.05 }
orbit_angles_deg = [0, 90, 180, 270]
planet_pin_errors = [[0, 1e-5], [0, 0], [0, 0], [0, 0]]
ring_meshes = { backlash = 1e-4, damping_ratio = 0.05 }
[[gear]]
name = "input_gear"
body = "input"
z = 30
[[gear]]
name = "sun2"
body = "s.sun"
z = 30
[[mesh]]
gears = ["input_gear", "sun2"]
"#;
    let g = parse(text).unwrap();
    let bodies: Vec<&str> = g.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(
        bodies,
        [
            "input",
            "s.sun",
            "s.carrier",
            "s.planet1",
            "s.planet2",
            "s.planet3",
            "s.planet4"
        ]
    );
    let meshes: Vec<&str> = g.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        meshes,
        [
            "s.sun_planet1",
            "s.sun_planet2",
            "s.sun_planet3",
            "s.sun_planet4",
            "s.planet1_ring",
            "s.planet2_ring",
            "s.planet3_ring",
            "s.planet4_ring",
            "input_gear_sun2"
        ]
    );
    let p2 = g.bodies[4].orbit.unwrap();
    assert_eq!((p2.carrier, p2.angle), (2, PI / 2.0));
    assert_eq!(g.bodies[3].orbit.unwrap().pin_error_t, Some(1e-5));
    let ring = &g.gears[g.meshes[4].gears[1]];
    assert!(ring.internal && ring.support == Support::Housing);
    assert_eq!(g.meshes[0].damping, Some(Damping::Chi(20.0)), "[defaults]");
    assert_eq!(
        g.meshes[4].damping,
        Some(Damping::Ratio(0.05)),
        "ring_meshes over [defaults]"
    );
    assert_eq!(g.meshes[4].backlash, Some(1e-4));
    // The second gear on the sun's body.
    assert_eq!(
        g.gears.iter().find(|x| x.name == "sun2").unwrap().support,
        Support::Body(1)
    );
}

#[test]
fn refusals_name_the_element_the_key_and_the_line() {
    let cases: Vec<(String, &str, &str)> = vec![
        (
            PAIR.replace("J = 0.5", "J = 0.5\nj = 1"),
            "body wheel: unknown field `j`",
            "j = 1",
        ),
        (
            PAIR.replace("gear = { z = 40 }", "gear = { z = 40, zz = 1 }"),
            "body wheel: unknown field `zz`",
            "zz = 1",
        ),
        (
            PAIR.replace("mount_deg = 90", "mount_deg = 90, mount = 1.0"),
            "gear pinion: give the angle in radians or in degrees",
            "mount = 1.0",
        ),
        (
            PAIR.replace("[\"pinion\", \"wheel\"]", "[\"pinion\", \"wheal\"]"),
            "mesh pinion_wheal: no gear named \"wheal\"",
            "gears =",
        ),
        (
            PAIR.replace("J = 0.5", "J = 0.5\nangle_start = 1.0"),
            "body wheel: angle_start belongs to the first body",
            "angle_start",
        ),
        (
            PAIR.replace("J = 0.5", "J = 0.5\ndrive = \"sped\""),
            "body wheel: drive = \"sped\"",
            "drive",
        ),
        (
            PAIR.replace("name = \"wheel\"", "name = \"pinion\""),
            "body pinion",
            "name = \"pinion\"",
        ),
        (
            PAIR.replace("name = \"wheel\"", "name = \"2wheel\""),
            "body \"2wheel\"",
            "2wheel",
        ),
        (
            PAIR.replace(
                "center_angle_deg = 30",
                "center_angle_deg = 30\nchi = 1\ndamping_ratio = 0.1",
            ),
            "mesh pinion_wheel: give chi or damping_ratio, not both",
            "chi = 1",
        ),
        (
            PAIR.replace("gear = { z = 40 }", "gear = { z = 40, internal = true }")
                .replace("[\"pinion\", \"wheel\"]", "[\"wheel\", \"pinion\"]"),
            "mesh wheel_pinion: gear wheel is internal: an internal gear is always B",
            "gears =",
        ),
        (
            PAIR.replace(
                "gear = { z = 40 }",
                "gear = { z = 40, pressure_angle_deg = 25 }",
            ),
            "mesh pinion_wheel: gear pinion (module 0.003 m, pressure angle 20",
            "gears =",
        ),
        (
            PAIR.replace("module = 0.003", "width = 0.02"),
            "gear pinion: module is required",
            "gear = { z = 20",
        ),
        (
            PAIR.replace("gear = { z = 40 }", "gear = { z = 40, module = nan }"),
            "gear wheel: module = NaN: must be a positive length",
            "module = nan",
        ),
    ];
    for (text, start, at) in cases {
        let e = refusal(&text);
        assert!(e.starts_with(start), "{e}\n does not start with: {start}");
        assert!(
            e.ends_with(&format!("(line {})", line(&text, at))),
            "{e}: expected the line of {at:?}"
        );
    }
}

#[test]
fn a_missing_name_or_key_points_at_the_header() {
    let text = PAIR.replace("name = \"wheel\"\n", "");
    let header = line(&text, "J = 0.5") - 1;
    assert_eq!(
        refusal(&text),
        format!("[[body]] number 2 (line {header}): name is required")
    );
    // A mesh that does not name two gears.
    let text = PAIR.replace("[\"pinion\", \"wheel\"]", "[\"pinion\"]");
    let header = line(&text, "[[mesh]]");
    let e = refusal(&text);
    assert_eq!(
        e,
        format!("[[mesh]] number 1 (line {header}): gears = [\"A\", \"B\"] names its two gears")
    );
    // A key left out: the element's header.
    let text = PAIR.replace("J = 0.5\n", "");
    let header = line(&text, "name = \"wheel\"") - 1;
    let e = refusal(&text);
    assert_eq!(
        e,
        format!("body wheel: J (its moment of inertia, kg.m2) is required (line {header})")
    );
}

#[test]
fn planetary_refusals() {
    let set = r#"
name = "Set"
[[planetary]]
name = "s"
sun = { z = 21, J = 0.002, module = 0.002 }
planet = { z = 18, J = 1e-4, module = 0.002 }
ring = { z = 57, fixed = true, module = 0.002 }
carrier = { J = 0.05 }
planets = 3
"#;
    assert!(parse(set).is_ok());
    let cases = [
        (
            set.replace("fixed = true,", "fixed = true, J = 1.0,"),
            "gear s.ring: J: a fixed ring is part of the housing",
        ),
        (
            set.replace(
                "sun = { z = 21, J = 0.002,",
                "sun = { z = 21, fixed = true,",
            ),
            "planetary s: the sun and the ring cannot both be fixed",
        ),
        (
            set.replace("planets = 3", "planets = 3\norbit_angles = [0, 1, 2]"),
            "planetary s: give the planets as",
        ),
        (
            set.replace(
                "planets = 3",
                "planets = 3\nplanet_pin_errors = [[0, 1e-5]]",
            ),
            "planetary s: planet_pin_errors needs one",
        ),
        (
            set.replace("ring = { z = 57,", "ring = { z = 57, internal = false,"),
            "gear s.ring: a ring is internal",
        ),
        (
            set.replace("carrier = { J = 0.05 }\n", ""),
            "planetary s: carrier = { ... } is required",
        ),
    ];
    for (text, start) in cases {
        let e = refusal(&text);
        assert!(e.starts_with(start), "{e}\n does not start with: {start}");
        assert!(e.contains("(line "), "{e}");
    }
}
