//! The exported functions: all of FMI 2.0 (`fmi2_slave::export_fmi2!`) and of FMI 3.0
//! (`fmi3_slave::export_fmi3!`) for the train's `Slave` (`fmu::TrainFmu`: SpurGearTrain, or a gearbox's FMU); the FMI 2.0 and
//! the FMI 3.0 FMU carry the same binary.
#![allow(non_snake_case, clippy::missing_safety_doc)]

fmi2_slave::export_fmi2!(super::fmu::TrainFmu);
fmi3_slave::export_fmi3!(super::fmu::TrainFmu);
