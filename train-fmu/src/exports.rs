//! The exported FMI 2.0 functions for SpurGearTrain's `Slave`.
#![allow(non_snake_case, clippy::missing_safety_doc)]

fmi2_slave::export_fmi2!(super::instance::SpurGearTrain);
