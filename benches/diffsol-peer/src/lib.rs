//! diffsol 0.18.0 as a peer of SpurGearMesh's hand-written integrators: a wrapper of diffsol's
//! solvers behind a small method trait, the gear-mesh model connected to it, and an event loop
//! that works like the FMU's driver. The benchmark is `src/main.rs`; the results and their
//! meaning are in docs/integrators.md.

pub mod diffsol_method;
pub mod method;
pub mod peer;
