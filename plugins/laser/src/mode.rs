//! What the optics measure: the laser's measurement modes.

use serde::Deserialize;

/// What the optics measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub enum Mode {
    /// Displacement along the beam (ISO 230-2 positioning).
    Linear,
    /// Lateral displacement along `sense`, perpendicular to the beam.
    Straightness,
    /// Rotation about `about` (pitch or yaw).
    Angular,
    /// Displacement along a beam on a face or body diagonal, the axes moving together.
    Diagonal,
    /// The same along a body diagonal, the axes moving one at a time (ISO 230-6).
    StepDiagonal,
}

impl Mode {
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "linear" => Self::Linear,
            "straightness" => Self::Straightness,
            "angular" => Self::Angular,
            "diagonal" => Self::Diagonal,
            "step-diagonal" => Self::StepDiagonal,
            _ => return None,
        })
    }
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Linear => "linear",
            Self::Straightness => "straightness",
            Self::Angular => "angular",
            Self::Diagonal => "diagonal",
            Self::StepDiagonal => "step-diagonal",
        }
    }
    /// Whether the reading is a length along the beam (linear, diagonal, step-diagonal).
    pub fn is_length(self) -> bool {
        matches!(self, Self::Linear | Self::Diagonal | Self::StepDiagonal)
    }
}

impl TryFrom<String> for Mode {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        Mode::parse(&value).ok_or_else(|| {
            format!(
                "unknown mode `{value}`; expected linear, straightness, angular, diagonal or \
                 step-diagonal"
            )
        })
    }
}
