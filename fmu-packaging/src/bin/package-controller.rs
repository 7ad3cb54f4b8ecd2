//! Builds target/fmu/SpeedController.fmu: the release binary of controller-fmu/ and
//! modelDescription.xml, both from that crate's variable table.
//!
//! With `FMU_WINDOWS_DIR` set (tools/windows.sh) it also carries `binaries/win64/<id>.dll`.
//!
//! Usage: `cargo run -q --release -p fmu-packaging --bin package-controller`; prints the path.

use speed_controller::variables::{model_description_xml, MODEL_NAME};

fn main() {
    let xml = model_description_xml();
    let path = fmu_packaging::package("speed_controller", MODEL_NAME, &xml, &[]);
    println!("{}", path.display());
}
