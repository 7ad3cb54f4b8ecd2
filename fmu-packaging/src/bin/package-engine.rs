//! Builds target/fmu/EngineTorque.fmu: the release binary of engine-fmu/, modelDescription.xml
//! from that crate's variable table, and documentation/index.html with the law and every
//! variable.
//!
//! With `FMU_WINDOWS_DIR` set (tools/windows.sh) it also carries `binaries/win64/<id>.dll`.
//!
//! Usage: `cargo run -q --release -p fmu-packaging --bin package-engine`; prints the path.

use engine_torque::variables::{model_description_xml, MODEL_NAME};

fn main() {
    let doc = documentation();
    let extra: [(&str, &[u8]); 1] = [("documentation/index.html", doc.as_bytes())];
    let path = fmu_packaging::package(
        "engine_torque",
        MODEL_NAME,
        &model_description_xml(),
        &extra,
    );
    println!("{}", path.display());
}

/// documentation/index.html.
fn documentation() -> String {
    let mut h = fmu_packaging::html_head("EngineTorque");
    h.push_str(concat!(
        "<h1>EngineTorque</h1>\n",
        "<p>An engine's torque at its crank: a mean torque with the <b>firing-order ripple</b> of the cylinders' ",
        "pulses, locked to the crank angle. The drive of a drivetrain built from separate FMUs. FMI 2.0 Co-Simulation.</p>\n",
        "<h2>Law</h2>\n",
        "<p><code>tau = tau_mean + tau_ripple sin(order theta + phase)</code></p>\n",
        "<ul>\n",
        "<li><code>theta</code> is the crank angle, forward positive: connect the angle of the body the torque drives ",
        "(SpurGearMesh's <code>theta_A</code>, with <code>tau</code> into its <code>tau_A</code>). The crank's inertia belongs ",
        "to that body.</li>\n",
        "<li><code>order</code> is the engine order: torque pulses per crank revolution, 2 for a four-stroke four-cylinder ",
        "engine (one firing every half turn), 1.5 for three cylinders, 3 for six. At crank speed <code>w</code> the ripple's ",
        "frequency is <code>order w / (2 pi)</code>.</li>\n",
        "<li>SpurGearTrain has the same law on each body (<code>body[i].tau</code> with <code>body[i].tau_ripple</code>, ",
        "<code>ripple_order</code>, <code>ripple_phase</code>, on the body's angle since the start), so a drivetrain of separate ",
        "FMUs driven by this FMU has a monolithic reference. Where the crank angle does not start at 0, shift ",
        "<code>phase</code> by <code>order theta(0)</code>.</li>\n",
        "</ul>\n",
        "<h2>Co-simulation</h2>\n",
        "<p>The engine has no state. Its torque is a <b>direct feedthrough</b> of <code>theta</code>, declared in ",
        "ModelStructure: it is computed from the angle and parameters set last whenever it is read, also in initialization ",
        "mode. <code>fmi2DoStep</code> only advances the time. A master that holds the torque over a communication step ",
        "<code>h</code> makes an error of order <code>tau_ripple order w h</code> in it; pick <code>h</code> well below ",
        "one ripple period.</p>\n",
        "<h2>Bad input</h2>\n",
        "<p><code>fmi2SetReal</code> refuses, with fmi2Error and a message naming the variable (category ",
        "<code>logStatusError</code>), a NaN or infinite value of any variable, <code>order &lt; 0</code>, and values that ",
        "would make the torque overflow; none of the values in that call is applied. Setting the output is an error, and so ",
        "is every call in a state where the standard does not allow it. FMU states can be got, set and serialized; a ",
        "serialized state is checked as <code>fmi2SetReal</code> checks values.</p>\n",
        "<h2>Variables</h2>\n",
    ));
    h.push_str(&fmu_packaging::variables_table(include_str!(
        "../../../engine-fmu/variables.toml"
    )));
    h.push_str("</body></html>\n");
    h
}
