//! Builds target/fmu/SpeedController.fmu: the release binary of controller-fmu/ and
//! modelDescription.xml, both from that crate's variable table.
//!
//! With `FMU_WINDOWS_DIR` set (tools/windows.sh) it also carries `binaries/win64/<id>.dll`.
//!
//! Usage: `cargo run -q --release -p fmu-packaging --bin package-controller`; prints the path.

use speed_controller::variables::{model_description_xml, MODEL_NAME};

fn main() {
    let so = fmu_packaging::release_binary("speed_controller");
    let binary = format!("binaries/linux64/{MODEL_NAME}.so");
    let dll = fmu_packaging::windows_binary("speed_controller");
    let win = format!("binaries/win64/{MODEL_NAME}.dll");
    let xml = model_description_xml();
    let mut files: Vec<(&str, &[u8])> =
        vec![("modelDescription.xml", xml.as_bytes()), (&binary, &so)];
    if let Some(dll) = &dll {
        files.push((&win, dll));
    }
    let path = fmu_packaging::write_fmu(MODEL_NAME, &files);
    println!("{}", path.display());
}
