//! `summary.json`: the machine-readable record of a run. Names are stable: later stages add
//! sections, nothing is renamed.

use crate::config::Config;
use crate::input::InputSummary;
use serde::Serialize;

/// Timing of one stage.
#[derive(Serialize, Clone, Debug)]
pub struct StageTime {
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Every stage that ran, in pipeline order.
#[derive(Serialize, Clone, Debug, Default)]
pub struct Stages {
    /// Reading, validating, repairing and scaling the mesh.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input: Option<StageTime>,
    /// The simulation of the filled mold.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub simulation: Option<StageTime>,
    /// The cross field.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field: Option<StageTime>,
    /// The segmentation into patches.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<StageTime>,
    /// Flattening and orientation of the patches.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flattening: Option<StageTime>,
    /// Building and writing the sewing patterns.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub patterns: Option<StageTime>,
    /// The check: the sewn mold, filled.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation: Option<StageTime>,
}

/// The whole summary.
#[derive(Serialize, Clone, Debug)]
pub struct Summary {
    /// clothcast version.
    pub version: &'static str,
    /// The target mesh as used.
    pub input: InputSummary,
    /// The resolved scenario (config file + command line).
    pub scenario: Config,
    /// Stage timings.
    pub stages: Stages,
    /// The simulation of the filled mold.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub simulation: Option<clothcast_sim::SimStats>,
    /// The cross field.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub field: Option<clothcast_field::FieldStats>,
    /// The segmentation into patches.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<clothcast_layout::SegmentationStats>,
    /// Flattening of the patches.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flattening: Option<clothcast_flatten::FlattenReport>,
    /// The sewing patterns.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub patterns: Option<crate::stages::patterns::PatternsSummary>,
    /// The check: the mold sewn from the patterns, filled.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation: Option<crate::stages::validation::ValidationOutcome>,
    /// Total wall-clock seconds.
    pub seconds_total: f64,
}
