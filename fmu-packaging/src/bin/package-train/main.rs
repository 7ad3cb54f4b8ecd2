//! Builds target/fmu/SpurGearTrain.fmu (FMI 2.0 Co-Simulation and Model Exchange) and
//! SpurGearTrain-fmi3.fmu (FMI 3.0, both interfaces, the same binary): the release binary of
//! train-fmu/, modelDescription.xml from the same expanded table as its value references, and
//! documentation/index.html with the topology rules, a drawing of the default train
//! (docs/train-layout.png, made by tools/train_layout.py from the same defaults) and a section on
//! planetary sets with a drawing of the simple set (docs/planetary-layout.png, made by
//! tools/train_layout.py from scenes/train/planetary-simple.toml).
//!
//! With `FMU_WINDOWS_DIR` set (tools/windows.sh), both also carry binaries/win64/ and
//! binaries/x86_64-windows/SpurGearTrain.dll.
//!
//! Usage: `cargo run -q --release -p fmu-packaging --bin package-train`; prints the path.
//! With `-- --gearbox FILE`, the FMU of the gearbox in FILE instead (`gearbox_fmu.rs`).

mod gearbox_fmu;
mod layout;

use model_description::{model_description_xml, model_description_xml3, train, Table};

const LAYOUT_PNG: &[u8] = include_bytes!("../../../../docs/train-layout.png");
const PLANETARY_PNG: &[u8] = include_bytes!("../../../../docs/planetary-layout.png");

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.as_slice() {
        [] => {}
        [flag, file] if flag == "--gearbox" => {
            let path = gearbox_fmu::package(file, &train::load());
            println!("{}", path.display());
            return;
        }
        _ => {
            eprintln!("usage: package-train [--gearbox FILE]");
            std::process::exit(2);
        }
    }
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
        ("documentation/planetary-layout.png", PLANETARY_PNG),
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
        ("documentation/planetary-layout.png", PLANETARY_PNG),
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

/// documentation/index.html: the elements, the topology rules, the frames, the default train,
/// planetary sets (body 0, carriers, the assembly condition, the simple set's drawing) and the
/// variables of the train as a whole and of element 1 of each kind.
fn documentation(t: &Table) -> String {
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>SpurGearTrain</title>\n<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}th{background:#eee}code{background:#f4f4f4}</style></head><body>\n");
    h.push_str("<h1>SpurGearTrain</h1>\n");
    h.push_str(&format!("<p>{}</p>\n", esc(&t.model.description)));
    h.push_str(concat!(
        "<h2>Elements</h2>\n<ul>\n",
        "<li><b>Bodies</b> <code>body[i]</code>, i = 1..n_bodies (at most 16): rigid rotors about fixed axes of the housing, ",
        "or of a carrier (planets, below), ",
        "with inertia <code>J</code>, viscous drag <code>c</code>, start speed <code>w_start</code> and an input torque <code>tau</code>. ",
        "A body carries any number of gears.</li>\n",
        "<li><b>Shafts</b> <code>shaft[j]</code>, j = 1..n_shafts (at most 15): linear torsional spring-dampers between bodies ",
        "<code>a</code> and <code>b</code> on one axis, transmitting <code>tau = k (theta_a - theta_b + twist_start) + d (w_a - w_b)</code>.</li>\n",
        "<li><b>Meshes</b> <code>mesh[m]</code>, m = 1..n_meshes (at most 16): a spur gear pair between a gear on body ",
        "<code>A</code> and a gear on body <code>B</code>, each exactly the SpurGearMesh model: every pair parameter of SpurGearMesh ",
        "exists per mesh under the same name (<code>mesh[2].zA</code>, <code>mesh[1].backlash</code>, ...), and so do its outputs ",
        "(<code>mesh[m].dte</code>, <code>mesh[m].F_fwd</code>, ...). <code>center_angle</code> is the direction of O_A -&gt; O_B in the ",
        "housing frame; <code>mount_A</code>, <code>mount_B</code> turn each gear's tooth 0 from its body's reference. ",
        "<code>mesh[m].internal = true</code> makes gear B a ring with internal teeth around gear A (standard geometry); ",
        "<code>mesh[m].center_distance_error</code> moves the axes apart from the nominal operating distance, and the pair's ",
        "pressure angle, contact segment and backlash follow (<code>mesh[m].center_distance</code>, <code>mesh[m].backlash_actual</code>).</li>\n</ul>\n",
        "<h2>Topology rules</h2>\n<ul>\n",
        "<li>Shafts and meshes are the edges of a graph on the bodies and the housing (body 0). It must be connected (carrier ties count), ",
        "and it may close loops, as planetary sets do (below). A loop whose forward senses conflict, or a body that no rigid rolling ",
        "of the meshes lets turn (three external gears in a triangle, a planetary set with sun and ring both fixed), is refused.</li>\n",
        "<li>No element joins a body to itself; every index lies in 1..n_bodies, and a mesh or shaft end may be 0, the housing.</li>\n",
        "<li>Rigid contact (<code>contact_model = 2</code>) and the slider exist only in the two-wheel SpurGearMesh; a train refuses them. ",
        "The lumped mesh (<code>contact_model = 4</code>: <code>mesh[m].k_lumped</code>, <code>c_lumped</code>, <code>k_lumped_varies</code>) ",
        "works on any mesh.</li>\n",
        "<li>Elements beyond the counts keep their start values, are not evaluated, and their outputs read 0.</li>\n",
        "<li>A violation is reported at fmi2ExitInitializationMode with fmi2Error and a message naming the elements.</li>\n</ul>\n",
        "<h2>Senses and frames</h2>\n",
        "<p>Body 1 turns clockwise when the train is driven forward; across an external mesh the sense flips, across an internal mesh or a shaft it stays; ",
        "a part the walk from body 1 does not reach (a carrier tied to the rest only through its planets) turns clockwise at its lowest index. ",
        "Every angle, speed and torque is <b>forward positive</b>; all <code>theta</code> start at 0. Each mesh lives in its own paper frame ",
        "(O_A at the origin, O_B on the x axis, at (-d, 0) for a ring, A turning clockwise), mirrored when its A body turns counter-clockwise. ",
        "In a tree, body 1 starts at <code>body[1].angle_start</code>; every other body is placed along the tree so that each mesh starts at its ",
        "<code>dte_start</code>, with the placed gear's tooth 0 within half a pitch of its reference (with loops: the placing walk below). ",
        "<code>mesh[m].dte = rAb theta_A - rBb theta_B + dte_start</code> is the forward penetration of its tooth pairs.</p>\n",
        "<h2>The default train</h2>\n<p>A two-stage reducer: pinion body 1 (22 teeth) drives wheel body 2 (33 teeth), ",
        "which drives pinion body 3 through a compliant shaft (k = 1e5 N.m/rad), which drives wheel body 4 (33 teeth) against a viscous load.</p>\n",
        "<p><img src=\"train-layout.png\" alt=\"default train layout\" style=\"max-width:100%\"></p>\n",
        "<h2>Planetary sets</h2>\n<ul>\n",
        "<li><b>Body 0 is the housing.</b> A mesh with <code>B = 0</code> is a gear fixed in the housing (a fixed ring), one with ",
        "<code>A = 0</code> a fixed external gear (a fixed sun); a shaft with an end at 0 is a torsional mount (a ring on a torque arm). ",
        "The output <code>housing.tau</code> is the torque the meshes and shafts apply to the housing, each about its own axis, ",
        "counter-clockwise positive. <code>housing.Fx</code>, <code>housing.Fy</code> are the resultant force on the housing, and ",
        "<code>body[i].Fx</code>, <code>body[i].Fy</code> the force each body's bearing exerts on it: in the housing frame, or for a planet ",
        "radial (outwards) and tangential (counter-clockwise) at its pin in the carrier's frame. The centres are held, so a bearing balances ",
        "its body's mesh forces and a planet's pin also moves it on its orbit. They are computed when read.</li>\n",
        "<li><b>Lateral bodies.</b> <code>body[i].lateral = true</code> lets the body's centre move in the plane on its bearing: ",
        "<code>k_x</code>, <code>k_y</code> [N/m] and <code>c_x</code>, <code>c_y</code> [N.s/m] (0 stiffness: floating, held by its meshes), ",
        "mass <code>body[i].m</code> &gt; 0, start <code>x_start</code>, <code>y_start</code>, <code>vx_start</code>, <code>vy_start</code>. ",
        "A planet's coordinates are zeta (radial) and eta (tangential) at its pin, in its carrier's frame, with the Coriolis, centrifugal and ",
        "Euler terms of a turning carrier. Every pair's penetration gains the centres' displacement along its line of action ",
        "(<code>mesh[m].delta_lat</code>; <code>dte</code> stays the rotational part); a lateral body's bearing force is its spring and damper. ",
        "Outputs <code>body[i].x</code>, <code>y</code>, <code>vx</code>, <code>vy</code>. At most 48 coordinates: one rotation per body and two ",
        "translations per lateral body. A direction that nothing holds, a lateral carrier on rigid pins, m = 0 or a negative stiffness ",
        "is refused, naming the body (docs/lateral.md).</li>\n",
        "<li><b>Carriers.</b> <code>body[i].carrier = c</code> (Integer; 0: the housing holds the axis) puts body i's axis in body c: ",
        "i is a planet, c its carrier, which turns about a housing-fixed axis (no planet carries another). The carrier starts at 0, and the planet's axis ",
        "lies at <code>body[i].orbit_angle</code> about the carrier's axis, at the orbit radius R: the nominal operating centre distance of its ",
        "lowest-index mesh with a central member (the sun or the ring, on the carrier's axis). <code>body[i].pin_error_r</code> and ",
        "<code>pin_error_t</code> move the axis radially and tangentially (counter-clockwise). A mesh in the carrier's frame takes its centre distance ",
        "and direction from these positions (plus its <code>center_distance_error</code>; its <code>center_angle</code> must be 0), works with ",
        "speeds relative to the carrier, and the carrier takes minus the sum of its torques on the two gears (the planet's bearing carries the mesh force). ",
        "<code>body[i].m</code> adds the orbital inertia m R<sup>2</sup> to the carrier (a lateral planet's mass moves on its own); a planet's drag acts on its speed relative to the carrier.</li>\n",
        "<li><b>The placing walk.</b> Breadth-first from the housing if any element names it (then <code>body[1].angle_start</code> is not used), ",
        "otherwise from body 1; the queue starts with the carriers in ascending index; at each body its meshes in index order, then its shafts. ",
        "Each body is placed once, by the first element that reaches it. Every other mesh <b>closes a loop</b>: it takes the tooth pairing whose ",
        "forward penetration lies nearest -backlash/2, and its <code>dte</code> at t = 0 shows the preload or gap left; its <code>dte_start</code> is not used.</li>\n",
        "<li><b>The assembly condition.</b> A loop-closing mesh more than 1 % of its base pitch into its teeth on either flank cannot be assembled, ",
        "and initialization fails with the numbers. For a simple set, <code>(z_sun + z_ring) (psi_n - psi_1) / (2 pi)</code> must be an integer for ",
        "each planet n at orbit angle psi_n; the message gives this value. Equally spaced planets assemble when (z_sun + z_ring) / N is an integer. ",
        "The housing-fixed axes placed along the meshes, shafts and carriers must also close within 1 µm (\"the axes do not close\").</li>\n",
        "</ul>\n",
        "<p>The simple set of <code>scenes/train/planetary-simple.toml</code>: sun 21 teeth (body 1), carrier (body 2), three planets of 18 teeth ",
        "(bodies 3-5) at 0, 120 and 240 degrees, a ring of 57 teeth fixed in the housing (meshes 4-6 with B = 0); (21 + 57)/3 = 26. ",
        "The walk starts at the housing: the ring's meshes place the planets, planet 3 places the sun, and meshes 2 and 3 close loops.</p>\n",
        "<p><img src=\"planetary-layout.png\" alt=\"a simple planetary set\" style=\"max-width:100%\"></p>\n",
        "<h2>Interfaces</h2>\n<ul>\n",
        "<li><b>Co-Simulation</b> (pick it unless your tool needs Model Exchange): the FMU integrates with the method of <code>solver</code> ",
        "at <code>rel_tol</code> and locates every mesh's events inside <code>fmi2DoStep</code>.</li>\n",
        "<li><b>Model Exchange</b>: the master integrates 34 continuous states: <code>W_ext</code>, <code>W_loss</code>, then ",
        "<code>coordinate[k].value</code> and <code>coordinate[k].rate</code> for k = 1..16, one per body. The coordinates are, in order, the angles ",
        "of the lowest-numbered bodies that complete the others to a basis (body 1 in most trains), then every mesh's dte that is independent ",
        "of those before it (the placing walk's meshes first), then the shafts' twists. ",
        "A train whose lateral bodies take it past 16 coordinates (up to 48: <code>coordinate[17..48]</code> are locals) is refused at the master's first state call: ",
        "it runs in Co-Simulation, or in Model Exchange as a gearbox FMU, which declares its own states. ",
        "A mesh that closes a loop has its dte from the meshes' coordinates alone: every penetration keeps full precision however far the bodies turn. ",
        "Each mesh's 32 event functions are event indicators (512 in all); ",
        "<code>fmi2NewDiscreteStates</code> handles the crossed ones as Co-Simulation does. ",
        "Use a master with root finding (CVode); the nominals carry each state's scale (micrometres for a dte). ",
        "Directional derivatives (<code>fmi2GetDirectionalDerivative</code>) linearize the train over all 48 coordinates, for natural frequencies ",
        "(<code>tools/modes.py</code>).</li>\n",
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
