//! Pipeline stages as the CLI runs them: each maps the scenario to the stage's library call,
//! writes the stage's files and returns its summary section.

pub mod field;
pub mod patterns;
pub mod segmentation;
pub mod simulation;
pub mod validation;
