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
use spur_gear_mesh::model::pair::Pair;
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
         <code>load_share</code>).</li>\
         <li><code>contact_model = 4</code> (lumped): the classical lumped-parameter mesh of Kahraman &amp; Singh and \
         Lin &amp; Parker, one linear spring <code>k_lumped</code> [N/m] and damper <code>c_lumped</code> [N.s/m] along each \
         flank's line of action, with the backlash and no friction (<code>chi</code> and <code>mu</code> are not used). \
         With <code>k_lumped_varies</code> the stiffness is the square wave <code>k_lumped n / eps</code>, <code>n</code> \
         the pairs on the contact segment. Pick it to compare with the lumped-parameter literature or for the cheapest run \
         that still vibrates; it has no tooth contact physics of its own.</li></ul>\n\
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
    h.push_str(&figure(
        &Geometry::new(&Pair::paper()).expect("the default parameters are valid"),
        "Geometry (paper defaults)",
    ));
    h.push_str(
        "<h2>An internal pair: a pinion in a ring</h2>\n<p><code>internal = true</code> (standard geometry, \
         <code>geometry = 2</code>) makes wheel B a ring gear with internal teeth, as in internal gear pumps, hub \
         reductions and planetary sets. Both wheels turn forward clockwise, so <code>w_B = w_A rAb/rBb</code> with \
         both positive, and <code>dte</code> is still the forward penetration. The ring's flanks are concave: Johnson's \
         law takes <code>rho_B - rho_A = L - delta</code> in place of <code>rho_A + rho_B</code>. A positive \
         <code>xB</code> moves the ring's profile outwards, away from its axis (its tips move out by <code>xB m</code>). \
         A standard 20/60 pair at 20 deg with no shift is refused: the ring's tip circle reaches past K<sub>A</sub>, into \
         the pinion's root (<code>s_a</code> = -0.075 mm at m = 2 mm); <code>xB = 0.5</code> lifts the ring's tips so \
         that the contact starts 1.19 mm up the pinion's involute. Initialization also refuses a ring whose tips lie \
         on or inside its base circle, a contact ratio outside [1, 2], pointed teeth on either gear, and tip or \
         trochoid interference, found by following the pinion's tip corners through the ring's teeth (the message \
         gives the smallest clearance). <code>contact_model = 3</code> and the slider are not available for an \
         internal pair yet.</p>\n\
         <h2>The centre distance</h2>\n<p><code>center_distance_error</code> [m] puts the axes that much further apart \
         than the nominal operating distance. The gears keep their base radii, tip radii and tooth thicknesses; \
         <code>alpha_w</code>, the line of action, the contact segment and the backlash follow from the actual \
         distance <code>center_distance</code> (calculated). Moving the axes apart opens an external pair's backlash \
         and closes an internal pair's, by about <code>2 sin(alpha_w)</code> times the error; \
         <code>backlash_actual</code> is the result. An error that jams the teeth or drops the contact ratio below 1 \
         is refused with the numbers.</p>\n",
    );
    h.push_str(&figure(
        &Geometry::new(&spur_gear_mesh::table::pair(&internal_example()).unwrap())
            .expect("the worked internal pair is valid"),
        "Geometry of an internal pair (20/60, m = 2 mm, xB = 0.5)",
    ));
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

/// docs/internal-pair.md's worked internal pair: 20/60, module 2 mm, 20 deg, xB = 0.5.
fn internal_example() -> Params {
    Params {
        geometry: 2,
        internal: true,
        module: 0.002,
        zA: 20,
        zB: 60,
        xB: 0.5,
        ..Params::default()
    }
}

/// SVG of a pair's geometry in its paper frame (O_A at the origin, O_B at (d, 0) or, for a
/// ring, (-d, 0)): base and tip circles, the line of action K_A K_B and the segment ab. A ring
/// dwarfs its mesh zone, so an internal pair gets a second panel that zooms in on the line.
fn figure(g: &Geometry, title: &str) -> String {
    let (cw, ch) = (760.0, 460.0);
    let xb = g.kappa * g.d;
    let mut svg = format!("<h2>{title}</h2>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{cw}\" height=\"{ch}\" viewBox=\"0 0 {cw} {ch}\">\n");
    svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    if g.internal {
        // The whole pair (the pinion's tips reach past the ring's), then the line of action
        // from K_B to past b.
        let (left, right) = (xb - g.r_tip_b, g.r_tip_a.max(xb + g.r_tip_b));
        svg += &panel(
            g,
            (10.0, 10.0, 360.0, 400.0),
            (0.5 * (left + right), 0.0),
            340.0 / (right - left),
        );
        let (ka, u) = line_of_action(g);
        let far = g.s_b.max(g.r_ab * g.alpha_w.tan());
        let mid = 0.5 * (far - g.l);
        let centre = (ka.0 + mid * u.0, ka.1 + mid * u.1);
        svg += &panel(g, (390.0, 10.0, 360.0, 400.0), centre, 330.0 / (far + g.l));
    } else {
        let (left, right) = (-g.r_tip_a, g.d + g.r_tip_b);
        let scale = (620.0 / (right - left)).min(400.0 / (2.0 * g.r_tip_a.max(g.r_tip_b)));
        svg += &panel(
            g,
            (0.0, 0.0, cw, ch - 30.0),
            (0.5 * (left + right), 0.0),
            scale,
        );
    }
    svg += &format!(
        "<text x=\"10\" y=\"{:.0}\" font-size=\"13\">solid: base circles (r_Ab = {:.4} m, r_Bb = {:.4} m); dashed: tip circles; \
         black: line of action (L = {:.4} m);</text>\n<text x=\"10\" y=\"{:.0}\" font-size=\"13\">green: contact segment ab \
         (contact ratio {:.2}); P: pitch point; alpha_w = {:.4} rad; centre distance {:.4} m</text>\n",
        ch - 30.0,
        g.r_ab,
        g.r_bb,
        g.l,
        ch - 12.0,
        g.eps,
        g.alpha_w,
        g.d
    );
    svg + "</svg>\n"
}

/// K_A = rAb (cos a, sin a) and the unit vector u = (sin a, -cos a) from K_A towards the pitch
/// point; positions on the line are K_A + s u, and K_B is at s = L (external) or -L (ring).
fn line_of_action(g: &Geometry) -> ((f64, f64), (f64, f64)) {
    let (c, s) = (g.alpha_w.cos(), g.alpha_w.sin());
    ((g.r_ab * c, g.r_ab * s), (s, -c))
}

/// One view of the pair: a nested SVG at (x, y, width, height) of the page, `centre` of the
/// paper frame in its middle, `scale` pixels per metre (the nested SVG clips what lies outside).
fn panel(
    g: &Geometry,
    (x, y, w, h): (f64, f64, f64, f64),
    centre: (f64, f64),
    scale: f64,
) -> String {
    let xb = g.kappa * g.d;
    let px = |v: f64| 0.5 * w + (v - centre.0) * scale;
    let py = |v: f64| 0.5 * h - (v - centre.1) * scale;
    let (ka, u) = line_of_action(g);
    let at = |s_: f64| (ka.0 + s_ * u.0, ka.1 + s_ * u.1);
    let kb = at(g.kappa * g.l);
    let (a, b) = (at(g.s_a), at(g.s_b));
    let circle = |cx: f64, r: f64, style: &str| {
        format!(
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"{:.1}\" {style}/>\n",
            px(cx),
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
    let mut svg = format!(
        "<svg x=\"{x:.0}\" y=\"{y:.0}\" width=\"{w:.0}\" height=\"{h:.0}\">\n<rect width=\"100%\" height=\"100%\" fill=\"none\" stroke=\"#ddd\"/>\n"
    );
    svg += &circle(0.0, g.r_ab, "fill=\"none\" stroke=\"#1f77b4\"");
    svg += &circle(
        0.0,
        g.r_tip_a,
        "fill=\"none\" stroke=\"#1f77b4\" stroke-dasharray=\"4 3\"",
    );
    svg += &circle(xb, g.r_bb, "fill=\"none\" stroke=\"#d62728\"");
    svg += &circle(
        xb,
        g.r_tip_b,
        "fill=\"none\" stroke=\"#d62728\" stroke-dasharray=\"4 3\"",
    );
    svg += &line((0.0, 0.0), (xb, 0.0), "stroke=\"#999\"");
    // A ring's line runs on past K_A to the pitch point and the segment's end.
    let far = if g.internal {
        at(g.s_b.max(g.r_ab * g.alpha_w.tan()) * 1.15)
    } else {
        ka
    };
    svg += &line(kb, far, "stroke=\"black\"");
    svg += &line(a, b, "stroke=\"#2ca02c\" stroke-width=\"5\"");
    let p = at(g.r_ab * g.alpha_w.tan());
    svg += &format!(
        "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"black\"/>\n",
        px(p.0),
        py(p.1)
    );
    svg += &label(p, 6.0, -6.0, "P");
    svg += &label(
        (0.0, 0.0),
        -20.0,
        18.0,
        "O<tspan font-size=\"10\">A</tspan>",
    );
    svg += &label((xb, 0.0), 4.0, 18.0, "O<tspan font-size=\"10\">B</tspan>");
    svg += &label(ka, -28.0, -4.0, "K<tspan font-size=\"10\">A</tspan>");
    svg += &label(kb, 6.0, 12.0, "K<tspan font-size=\"10\">B</tspan>");
    svg += &label(a, -14.0, -8.0, "a");
    svg += &label(b, 8.0, 4.0, "b");
    svg + "</svg>\n"
}
