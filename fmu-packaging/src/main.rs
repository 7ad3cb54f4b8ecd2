//! Builds target/fmu/SpurGearMesh.fmu (FMI 2.0) and target/fmu/SpurGearMesh-fmi3.fmu (FMI
//! 3.0): the same release binary, which exports both versions' functions, with
//! modelDescription.xml of each version (from the same variable table as the binary's value
//! references) and documentation/index.html with a figure of the mesh geometry drawn from the
//! model's own geometry code.
//!
//! With `FMU_WINDOWS_DIR` set (tools/windows.sh), both FMUs also carry the Windows DLL:
//! binaries/win64/SpurGearMesh.dll and binaries/x86_64-windows/SpurGearMesh.dll.
//!
//! Usage: `cargo run -p fmu-packaging --release` (from anywhere in the workspace; the default
//! binary of the package, beside `package-controller`). It prints the FMI 2.0 FMU's path on
//! stdout (scripts read it) and the FMI 3.0 one's on stderr.

use model_description::{load, model_description_xml, model_description_xml3, Table};
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::variables::Params;

fn main() {
    let so = fmu_packaging::release_binary("spur_gear_mesh");
    let dll = fmu_packaging::windows_binary("spur_gear_mesh");
    let table = load();
    let xml = model_description_xml(&table, env!("CARGO_PKG_VERSION"));
    let doc = documentation(&table);
    let mut files: Vec<(&str, &[u8])> = vec![
        ("modelDescription.xml", xml.as_bytes()),
        ("binaries/linux64/SpurGearMesh.so", &so),
        ("documentation/index.html", doc.as_bytes()),
    ];
    if let Some(dll) = &dll {
        files.push(("binaries/win64/SpurGearMesh.dll", dll));
    }
    let path = fmu_packaging::write_fmu("SpurGearMesh", &files);
    let xml3 = model_description_xml3(&table, env!("CARGO_PKG_VERSION"));
    let mut files3: Vec<(&str, &[u8])> = vec![
        ("modelDescription.xml", xml3.as_bytes()),
        ("binaries/x86_64-linux/SpurGearMesh.so", &so),
        ("documentation/index.html", doc.as_bytes()),
    ];
    if let Some(dll) = &dll {
        files3.push(("binaries/x86_64-windows/SpurGearMesh.dll", dll));
    }
    let path3 = fmu_packaging::write_fmu("SpurGearMesh-fmi3", &files3);
    eprintln!("FMI 3.0: {}", path3.display());
    println!("{}", path.display());
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// documentation/index.html: what the model is, a figure, and the variables by causality.
fn documentation(t: &Table) -> String {
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>SpurGearMesh</title>\n<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}th{background:#eee}code{background:#f4f4f4}</style></head><body>\n");
    h.push_str("<h1>SpurGearMesh</h1>\n");
    h.push_str(&format!("<p>{}</p>\n", esc(&t.model.description)));
    h.push_str(
        "<p>Two rigid wheels A (driving) and B turn about fixed axes. Their teeth meet on the line of action \
         K<sub>A</sub>K<sub>B</sub>, tangent to both base circles. Each tooth pair in mesh is tracked by a contact object \
         (f1, f2 on the forward flanks, b1, b2 on the backward flanks) whose contact point s<sub>A</sub> moves along the \
         line; a pair carries load only on the segment ab between the tip circles. Every pair on a flank has the same \
         penetration: <code>dte</code> on the forward flank, <code>-backlash - dte</code> on the backward flank. \
         The normal force per unit width follows Johnson's line-contact law \
         <code>delta = N/(pi E*) [ln(4 pi E* (rho_A+rho_B)/N) - 1]</code>, solved in closed form with the lower branch \
         of the Lambert W function. Hunt-Crossley damping <code>(1 + chi d(delta)/dt)</code> and regularized Coulomb \
         friction <code>mu tanh(v_s/v_reg)</code> are added. All angles, speeds and torques are positive in the forward \
         drive sense. Inside <code>fmi2DoStep</code> an adaptive integrator (explicit Dormand-Prince 5(4), implicit \
         BDF from diffsol, or explicit DOP853 for tight tolerances, parameter <code>solver</code>) locates every tooth-pair switch, contact onset, separation and \
         release, so the right-hand side is smooth inside each internal step.</p>\n\
         <p>The defaults run the paper's rig: drive <code>tau_A</code> = 100 N.m, load <code>c_load</code> = 2 N.m.s/rad, \
         running start at 100 rad/s, light damping <code>chi</code> = 10 s/m. A run with no start values shows the mesh at \
         work; set <code>chi</code> = 0 for the paper's undamped mesh.</p>\n",
    );
    h.push_str(
        "<h2>Which interface</h2>\n<ul>\
         <li><b>Co-Simulation</b> (pick it unless your tool needs Model Exchange): the FMU integrates \
         itself and locates every event inside the step, at <code>rel_tol</code>; any communication step \
         gives the same accuracy.</li>\
         <li><b>Model Exchange</b>: the master integrates the eight continuous states and locates the \
         events on the 32 event indicators (the mesh's event functions, positive until they cross). The \
         mesh vibration is stiff (about 3e4 rad/s on the paper rig): use an implicit variable-step solver \
         with root finding such as CVODE's BDF, at the tolerance the scene needs (1e-10 with impacts \
         across the backlash); <code>rel_tol</code> and <code>solver</code> have no effect. Explicit fixed \
         steps are stable only below 2 zeta/omega of the mesh vibration (about 1e-6 s with \
         <code>chi</code> = 10 s/m).</li>\
         <li><b>FMI 2.0 and 3.0</b> (<code>SpurGearMesh.fmu</code>, <code>SpurGearMesh-fmi3.fmu</code>): the \
         same binary and variables; FMI 3.0 declares <code>time</code> and the event indicators \
         <code>z_*</code> as variables, has no event mode in Co-Simulation and no input derivatives.</li></ul>\n",
    );
    h.push_str(
        "<h2>Which contact model</h2>\n<ul>\
         <li><code>contact_model = 1</code> (Johnson, the default): the paper's compliant mesh. Pick it for gear \
         dynamics: the transmission error, the mesh vibration and its excitation by the stiffness change at every \
         pair switch, tooth forces with their dynamic peaks, rattle and impacts through the backlash.</li>\
         <li><code>contact_model = 2</code> (rigid): the teeth as a unilateral constraint (paper section 6.2). Locked \
         on a flank the wheels roll as one body and the contact force is the constraint force, shared equally by the \
         gated pairs; across the backlash the wheels fly free and hit with Newton's law (<code>restitution</code>); a \
         rebound that would return within 1e-6 s locks. Pick it for drivetrain-level studies that do not need the mesh \
         vibration: its force is the cycle average of the compliant one, and a run costs several times less \
         (<code>dte</code> is 0 or <code>-backlash</code>).</li>\
         <li><code>contact_model = 3</code> (standard geometry, <code>geometry = 2</code>): the teeth's bending, shear \
         and compression and the wheel bodies' fillet-foundation in series with Weber's local contact. Pick it for a real \
         gear's mesh stiffness and transmission error: the contact-only mesh of model 1 is 2-3 times stiffer than \
         ISO 6336-1; model 3 is 0.8-1.0 times ISO. Each pair's stiffness depends on where it sits (<code>k_mesh</code>, \
         <code>load_share</code>).</li></ul>\n\
         <h2>Shape deviations</h2>\n<p>Off by default. Each adds a length along the line of action to one pair's \
         penetration, so pairs on a flank no longer share it: each carries at its own penetration and has its own \
         onset, separation and release events. <code>tip_relief_A</code>/<code>_B</code> over \
         <code>tip_relief_length_A</code>/<code>_B</code> from each wheel's tip (<code>tip_relief_shape</code> 1 linear, \
         2 parabolic; where the relief starts is an event); <code>ecc_A</code>, <code>ecc_B</code> with \
         <code>ecc_phase_A</code>, <code>ecc_phase_B</code> (runout); <code>pitch_errors_A</code>, \
         <code>pitch_errors_B</code>: one number per tooth [m], comma-separated, positive for a tooth ahead of its place. \
         Teeth are numbered in each wheel's forward sense; at t = 0 the object f1 holds teeth A0/B0, f2 A1/B1 and b1 \
         A1/B0. A bad entry is an error naming its position. Deviations need a compliant contact model (1 or 3).</p>\n\
         <p>The rest of the paper's rig: <code>slider_stiffness</code> &gt; 0 mounts B's bearing on the slider S along \
         O<sub>A</sub>O<sub>B</sub> (output <code>x_slider</code>); the inputs <code>alpha_housing</code> and \
         <code>a_housing_x</code> move the housing; <code>F_B_x</code>, <code>F_B_y</code> are the mesh force on B in the \
         paper frame, what a housing or bearing model couples to. For a very stiff slider with rigid contact use the \
         implicit solver (<code>solver = 2</code>).</p>\n",
    );
    h.push_str("<p>Source: I. I. Kosenko, I. K. Gusev, <i>Computer model of the spur involute gear mesh dynamics in gearboxes</i>, Rus. J. Nonlin. Dyn. 8(4), 2012, 713-734.</p>\n");
    h.push_str(&figure());
    for (title, causality) in [
        ("Inputs", "input"),
        ("Outputs", "output"),
        ("Parameters", "parameter"),
        ("Calculated parameters", "calculatedParameter"),
    ] {
        h.push_str(&format!("<h2>{title}</h2>\n<table><tr><th>name</th><th>type</th><th>unit</th><th>start</th><th>variability</th><th>description</th></tr>\n"));
        for v in t.vars.iter().filter(|v| v.causality == causality) {
            let start = v.start.as_ref().map(|s| s.to_string()).unwrap_or_default();
            h.push_str(&format!(
                "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                v.name,
                v.ty,
                esc(v.unit.as_deref().unwrap_or("")),
                esc(&start),
                v.variability,
                esc(&v.description)
            ));
        }
        h.push_str("</table>\n");
    }
    h.push_str("</body></html>\n");
    h
}

/// SVG of the paper geometry: base and tip circles, the line of action and the segment ab.
fn figure() -> String {
    let g = Geometry::new(&Params::default()).expect("the default parameters are valid");
    let (cw, ch) = (760.0, 460.0);
    let scale = 620.0 / (g.d + g.r_tip_a + g.r_tip_b);
    let ox = 70.0 + g.r_tip_a * scale;
    let oy = ch / 2.0;
    let px = |x: f64| ox + x * scale;
    let py = |y: f64| oy - y * scale;
    let (c, s) = (g.alpha_w.cos(), g.alpha_w.sin());
    // Paper frame: K_A = rAb (cos a, sin a), K_B = O_B - rBb (cos a, sin a); the line runs K_A -> K_B.
    let ka = (g.r_ab * c, g.r_ab * s);
    let kb = (g.d - g.r_bb * c, -g.r_bb * s);
    let (ux, uy) = ((kb.0 - ka.0) / g.l, (kb.1 - ka.1) / g.l);
    let at = |s_: f64| (ka.0 + s_ * ux, ka.1 + s_ * uy);
    let (a, b) = (at(g.s_a), at(g.s_b));
    let circle = |x: f64, r: f64, style: &str| {
        format!(
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"{:.1}\" {style}/>\n",
            px(x),
            py(0.0),
            r * scale
        )
    };
    let line = |p: (f64, f64), q: (f64, f64), style: &str| {
        format!(
            "<line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" {style}/>\n",
            px(p.0),
            py(p.1),
            px(q.0),
            py(q.1)
        )
    };
    let label = |p: (f64, f64), dx: f64, dy: f64, text: &str| {
        format!(
            "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"14\">{text}</text>\n",
            px(p.0) + dx,
            py(p.1) + dy
        )
    };
    let mut svg = format!("<h2>Geometry (paper defaults)</h2>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{cw}\" height=\"{ch}\" viewBox=\"0 0 {cw} {ch}\">\n");
    svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    svg += &circle(0.0, g.r_ab, "fill=\"none\" stroke=\"#1f77b4\"");
    svg += &circle(
        0.0,
        g.r_tip_a,
        "fill=\"none\" stroke=\"#1f77b4\" stroke-dasharray=\"4 3\"",
    );
    svg += &circle(g.d, g.r_bb, "fill=\"none\" stroke=\"#d62728\"");
    svg += &circle(
        g.d,
        g.r_tip_b,
        "fill=\"none\" stroke=\"#d62728\" stroke-dasharray=\"4 3\"",
    );
    svg += &line((0.0, 0.0), (g.d, 0.0), "stroke=\"#999\"");
    svg += &line(ka, kb, "stroke=\"black\"");
    svg += &line(a, b, "stroke=\"#2ca02c\" stroke-width=\"5\"");
    svg += &label(
        (0.0, 0.0),
        -20.0,
        18.0,
        "O<tspan font-size=\"10\">A</tspan>",
    );
    svg += &label((g.d, 0.0), 4.0, 18.0, "O<tspan font-size=\"10\">B</tspan>");
    svg += &label(ka, -28.0, -4.0, "K<tspan font-size=\"10\">A</tspan>");
    svg += &label(kb, 6.0, 12.0, "K<tspan font-size=\"10\">B</tspan>");
    svg += &label(a, -14.0, -8.0, "a");
    svg += &label(b, 8.0, 4.0, "b");
    svg += &format!(
        "<text x=\"10\" y=\"{:.0}\" font-size=\"13\">solid: base circles (r_Ab = {:.4} m, r_Bb = {:.4} m); dashed: tip circles; \
         black: line of action (L = {:.4} m); green: contact segment ab (contact ratio {:.2}); alpha_w = {:.4} rad</text>\n",
        ch - 12.0,
        g.r_ab,
        g.r_bb,
        g.l,
        g.eps,
        g.alpha_w
    );
    svg + "</svg>\n"
}
