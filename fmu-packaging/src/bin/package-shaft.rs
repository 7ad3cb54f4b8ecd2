//! Builds target/fmu/TorsionalShaft.fmu: the release binary of shaft-fmu/, modelDescription.xml
//! from that crate's variable table, and documentation/index.html with the law, the sign
//! conventions and every variable.
//!
//! With `FMU_WINDOWS_DIR` set (tools/windows.sh) it also carries `binaries/win64/<id>.dll`.
//!
//! Usage: `cargo run -q --release -p fmu-packaging --bin package-shaft`; prints the path.

use torsional_shaft::variables::{model_description_xml, MODEL_NAME};

fn main() {
    let doc = documentation();
    let extra: [(&str, &[u8]); 1] = [("documentation/index.html", doc.as_bytes())];
    let path = fmu_packaging::package(
        "torsional_shaft",
        MODEL_NAME,
        &model_description_xml(),
        &extra,
    );
    println!("{}", path.display());
}

/// documentation/index.html.
fn documentation() -> String {
    let mut h = String::new();
    h.push_str(&fmu_packaging::html_head("TorsionalShaft"));
    h.push_str(concat!(
        "<h1>TorsionalShaft</h1>\n",
        "<p>A massless linear torsional spring-damper between two shaft ends, <i>a</i> and <i>b</i>, on one axis: ",
        "the coupling element of a drivetrain built from separate FMUs (for example two gear FMUs joined by a compliant ",
        "shaft). FMI 2.0 Co-Simulation.</p>\n",
        "<h2>Law</h2>\n",
        "<p><code>tau_b = -tau_a = k (theta_a - theta_b + twist_start) + d (w_a - w_b)</code></p>\n",
        "<ul>\n",
        "<li><b>Signs.</b> Every angle, speed and torque is <b>forward positive</b> at its end, and both ends have the same ",
        "forward sense (the sense does not flip along a shaft). <code>tau_a</code> and <code>tau_b</code> are the torques ",
        "the shaft <i>applies</i> to ends a and b: add them to the torques on the bodies at those ends.</li>\n",
        "<li>End a ahead of end b (<code>theta_a &gt; theta_b</code>) or faster (<code>w_a &gt; w_b</code>) twists the shaft ",
        "forward: it drives b forward (<code>tau_b &gt; 0</code>) and holds a back (<code>tau_a &lt; 0</code>). The shaft is ",
        "massless, so the two torques are equal and opposite at every instant.</li>\n",
        "<li><code>twist_start</code> is a pre-twist: the spring is relaxed where <code>theta_a - theta_b = -twist_start</code>. ",
        "It may have either sign. With <code>theta_a = theta_b = 0</code> at the start it is the start twist, as in ",
        "SpurGearTrain's <code>shaft[j].twist_start</code>, whose <code>tau</code> is this model's <code>tau_b</code>.</li>\n",
        "</ul>\n",
        "<h2>Co-simulation</h2>\n",
        "<p>The shaft has no state. Its outputs are a <b>direct feedthrough</b> of its four inputs, declared in ",
        "ModelStructure (each output depends on <code>theta_a</code>, <code>w_a</code>, <code>theta_b</code>, <code>w_b</code>): ",
        "<code>tau_a</code> and <code>tau_b</code> are computed from the inputs and parameters set last whenever they are read, ",
        "also in initialization mode. <code>fmi2DoStep</code> only advances the time. A master must therefore set the inputs ",
        "at a communication point before it reads the outputs (or solve the algebraic loop if the bodies at the ends take ",
        "their torques as direct feedthrough too). The parameters are tunable and act at once.</p>\n",
        "<h2>Bad input</h2>\n",
        "<p><code>fmi2SetReal</code> refuses, with fmi2Error and a message naming the variable (category ",
        "<code>logStatusError</code>), a NaN or infinite value of any variable, <code>k &lt; 0</code>, <code>d &lt; 0</code>, ",
        "and values that would make the torque overflow; none of the values in that call is applied. Setting an output ",
        "is an error, and so is every call in a state where the standard does not allow it. FMU states can be got, set and ",
        "serialized; a serialized state is checked as <code>fmi2SetReal</code> checks values.</p>\n",
        "<h2>Variables</h2>\n",
    ));
    h.push_str(&fmu_packaging::variables_table(include_str!(
        "../../../shaft-fmu/variables.toml"
    )));
    h.push_str("</body></html>\n");
    h
}
