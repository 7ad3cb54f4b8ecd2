//! Builds target/fmu/SpeedController.fmu: the release binary of controller-fmu/ and
//! modelDescription.xml, both from that crate's variable table.
//!
//! Usage: `cargo run -q --release -p fmu-packaging --bin package-controller`; prints the path.

use speed_controller::variables::{model_description_xml, MODEL_NAME};

fn main() {
    let so = fmu_packaging::release_binary("speed_controller");
    let binary = format!("binaries/linux64/{MODEL_NAME}.so");
    let path = fmu_packaging::write_fmu(
        MODEL_NAME,
        &[
            ("modelDescription.xml", model_description_xml().as_bytes()),
            (&binary, &so),
        ],
    );
    println!("{}", path.display());
}
