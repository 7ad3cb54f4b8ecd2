//! The exported functions: all of FMI 2.0 (`fmi2_slave::export_fmi2!`) and of FMI 3.0
//! (`fmi3_slave::export_fmi3!`) for SpurGearTrain's `Slave`; the FMI 2.0 and the FMI 3.0 FMU
//! carry the same binary.
#![allow(non_snake_case, clippy::missing_safety_doc)]

fmi2_slave::export_fmi2!(super::instance::SpurGearTrain);
fmi3_slave::export_fmi3!(super::instance::SpurGearTrain);
