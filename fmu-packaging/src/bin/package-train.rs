//! Builds target/fmu/SpurGearTrain.fmu (FMI 2.0 Co-Simulation and Model Exchange) and
//! SpurGearTrain-fmi3.fmu (FMI 3.0, both interfaces, the same binary): the release binary of
//! train-fmu/, modelDescription.xml from the same expanded table as its value references, and
//! documentation/index.html with the topology rules and a drawing of the default train
//! (docs/train-layout.png, made by tools/train_layout.py from the same defaults).
//!
//! With `FMU_WINDOWS_DIR` set (tools/windows.sh), both also carry binaries/win64/ and
//! binaries/x86_64-windows/SpurGearTrain.dll.
//!
//! Usage: `cargo run -q --release -p fmu-packaging --bin package-train`; prints the path.

use model_description::{model_description_xml, model_description_xml3, train, Table};

const LAYOUT_PNG: &[u8] = include_bytes!("../../../docs/train-layout.png");

fn main() {
    let so = fmu_packaging::release_binary("spur_gear_train");
    let dll = fmu_packaging::windows_binary("spur_gear_train");
    let table = train::load();
    let xml = model_description_xml(&table, env!("CARGO_PKG_VERSION"));
    let doc = documentation(&table);
    let mut files: Vec<(&str, &[u8])> = vec![
        ("modelDescription.xml", xml.as_bytes()),
        ("binaries/linux64/SpurGearTrain.so", &so),
        ("documentation/index.html", doc.as_bytes()),
        ("documentation/train-layout.png", LAYOUT_PNG),
    ];
    if let Some(dll) = &dll {
        files.push(("binaries/win64/SpurGearTrain.dll", dll));
    }
    let path = fmu_packaging::write_fmu("SpurGearTrain", &files);
    let xml3 = model_description_xml3(&table, env!("CARGO_PKG_VERSION"));
    let mut files3: Vec<(&str, &[u8])> = vec![
        ("modelDescription.xml", xml3.as_bytes()),
        ("binaries/x86_64-linux/SpurGearTrain.so", &so),
        ("documentation/index.html", doc.as_bytes()),
        ("documentation/train-layout.png", LAYOUT_PNG),
    ];
    if let Some(dll) = &dll {
        files3.push(("binaries/x86_64-windows/SpurGearTrain.dll", dll));
    }
    let path3 = fmu_packaging::write_fmu("SpurGearTrain-fmi3", &files3);
    eprintln!("FMI 3.0: {}", path3.display());
    println!("{}", path.display());
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// documentation/index.html: the elements, the topology rules, the frames, the default train
/// and the variables of the train as a whole and of element 1 of each kind.
fn documentation(t: &Table) -> String {
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>SpurGearTrain</title>\n<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}th{background:#eee}code{background:#f4f4f4}</style></head><body>\n");
    h.push_str("<h1>SpurGearTrain</h1>\n");
    h.push_str(&format!("<p>{}</p>\n", esc(&t.model.description)));
    h.push_str(concat!(
        "<h2>Elements</h2>\n<ul>\n",
        "<li><b>Bodies</b> <code>body[i]</code>, i = 1..n_bodies (at most 8): rigid rotors about fixed axes of the housing, ",
        "with inertia <code>J</code>, viscous drag <code>c</code>, start speed <code>w_start</code> and an input torque <code>tau</code>. ",
        "A body carries any number of gears.</li>\n",
        "<li><b>Shafts</b> <code>shaft[j]</code>, j = 1..n_shafts (at most 7): linear torsional spring-dampers between bodies ",
        "<code>a</code> and <code>b</code> on one axis, transmitting <code>tau = k (theta_a - theta_b + twist_start) + d (w_a - w_b)</code>.</li>\n",
        "<li><b>Meshes</b> <code>mesh[m]</code>, m = 1..n_meshes (at most 6): a spur gear pair between a gear on body ",
        "<code>A</code> and a gear on body <code>B</code>, each exactly the SpurGearMesh model: every pair parameter of SpurGearMesh ",
        "exists per mesh under the same name (<code>mesh[2].zA</code>, <code>mesh[1].backlash</code>, ...), and so do its outputs ",
        "(<code>mesh[m].dte</code>, <code>mesh[m].F_fwd</code>, ...). <code>center_angle</code> is the direction of O_A -&gt; O_B in the ",
        "housing frame; <code>mount_A</code>, <code>mount_B</code> turn each gear's tooth 0 from its body's reference. ",
        "<code>mesh[m].internal = true</code> makes gear B a ring with internal teeth around gear A (standard geometry); ",
        "<code>mesh[m].center_distance_error</code> moves the axes apart from the nominal operating distance, and the pair's ",
        "pressure angle, contact segment and backlash follow (<code>mesh[m].center_distance</code>, <code>mesh[m].backlash_actual</code>).</li>\n</ul>\n",
        "<h2>Topology rules</h2>\n<ul>\n",
        "<li>Shafts and meshes are the edges of a graph on the bodies, which must be a <b>tree</b>: connected, no cycle, ",
        "n_shafts + n_meshes = n_bodies - 1. A cycle of meshes over-constrains rigid rotation (planetary sets are out of scope).</li>\n",
        "<li>No element joins a body to itself; every index lies in 1..n_bodies.</li>\n",
        "<li>Rigid contact (<code>contact_model = 2</code>) and the slider exist only in the two-wheel SpurGearMesh; a train refuses them.</li>\n",
        "<li>Elements beyond the counts keep their start values, are not evaluated, and their outputs read 0.</li>\n",
        "<li>A violation is reported at fmi2ExitInitializationMode with fmi2Error and a message naming the elements.</li>\n</ul>\n",
        "<h2>Senses and frames</h2>\n",
        "<p>Body 1 turns clockwise when the train is driven forward; across an external mesh the sense flips, across an internal mesh or a shaft it stays. ",
        "Every angle, speed and torque is <b>forward positive</b>; all <code>theta</code> start at 0. Each mesh lives in its own paper frame ",
        "(O_A at the origin, O_B on the x axis, at (-d, 0) for a ring, A turning clockwise), mirrored when its A body turns counter-clockwise. ",
        "Body 1 starts at <code>body[1].angle_start</code>; every other body is placed along the tree so that each mesh starts at its ",
        "<code>dte_start</code>, with the placed gear's tooth 0 within half a pitch of its reference. ",
        "<code>mesh[m].dte = rAb theta_A - rBb theta_B + dte_start</code> is the forward penetration of its tooth pairs.</p>\n",
        "<h2>The default train</h2>\n<p>A two-stage reducer: pinion body 1 (22 teeth) drives wheel body 2 (33 teeth), ",
        "which drives pinion body 3 through a compliant shaft (k = 1e5 N.m/rad), which drives wheel body 4 (33 teeth) against a viscous load.</p>\n",
        "<p><img src=\"train-layout.png\" alt=\"default train layout\" style=\"max-width:100%\"></p>\n",
        "<h2>Interfaces</h2>\n<ul>\n",
        "<li><b>Co-Simulation</b> (pick it unless your tool needs Model Exchange): the FMU integrates with the method of <code>solver</code> ",
        "at <code>rel_tol</code> and locates every mesh's events inside <code>fmi2DoStep</code>.</li>\n",
        "<li><b>Model Exchange</b>: the master integrates 30 continuous states for the full capacity, in this order: ",
        "<code>body[1].theta</code>, <code>body[1].w</code>, <code>W_ext</code>, <code>W_loss</code>, then <code>shaft[j].twist</code> and ",
        "<code>shaft[j].twist_rate</code> for j = 1..7, then <code>mesh[m].dte</code> and <code>mesh[m].dte_rate</code> for m = 1..6. ",
        "The relative coordinates keep each penetration to full precision however far the bodies turn. ",
        "Elements not in use read 0 and have rate 0. Each mesh's 32 event functions are event indicators, ",
        "<code>mesh[m].z_*</code> (192 in all); <code>fmi2NewDiscreteStates</code> handles the crossed ones as Co-Simulation does. ",
        "Use a master with root finding (CVode); the nominals carry each state's scale (micrometres for a dte).</li>\n",
        "<li><b>FMI 3.0</b> (<code>SpurGearTrain-fmi3.fmu</code>): the same two interfaces from the same binary.</li>\n</ul>\n",
    ));
    h.push_str("<h2>Variables</h2>\n<p>The train's own, and those of element 1 of each kind (every other index has the same).</p>\n<table><tr><th>name</th><th>causality</th><th>unit</th><th>start</th><th>description</th></tr>\n");
    for v in &t.vars {
        let first = !v.name.contains('[') || v.name.contains("[1].");
        if !first {
            continue;
        }
        let start = match &v.start {
            Some(toml::Value::Float(f)) => f.to_string(),
            Some(toml::Value::Integer(i)) => i.to_string(),
            Some(toml::Value::Boolean(b)) => b.to_string(),
            Some(toml::Value::String(s)) => format!("\"{s}\""),
            _ => String::new(),
        };
        h.push_str(&format!(
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            esc(&v.name),
            v.causality,
            v.unit.as_deref().unwrap_or(""),
            esc(&start),
            esc(&v.description)
        ));
    }
    h.push_str("</table>\n</body></html>\n");
    h
}
