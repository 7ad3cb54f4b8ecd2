pub mod variables;
