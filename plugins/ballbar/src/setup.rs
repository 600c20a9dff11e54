//! The ball-bar set-up: its manifest keys, nuisance parameters and measurement model.

use mtcal_instrument::config::{self, Number, Vec3, required};
use mtcal_instrument::{At, Channel, Nuisance, Setup, SetupError, SetupFormat, Touches, Unit};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Every key a ball-bar set-up table may hold.
pub const SETUP_KEYS: &[&str] = &[
    "pivot",
    "length",
    "sigma_um",
    "pivot_free",
    "length_free",
    "length_u_um",
    "tool_length_free",
];

/// A set-up table as written ([`SETUP_KEYS`], in that order); [`BallbarConfig::to_table`]
/// writes one too.
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct Keys {
    pivot: Option<Vec3>,
    length: Option<Number>,
    sigma_um: Option<Number>,
    pivot_free: Option<bool>,
    length_free: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    length_u_um: Option<Number>,
    tool_length_free: Option<bool>,
}

/// Index of each nuisance parameter in [`BallbarSetup::nuisance`] (and in `nuis` slices).
pub mod nuis {
    pub const PIVOT_X: usize = 0;
    pub const PIVOT_Y: usize = 1;
    pub const PIVOT_Z: usize = 2;
    pub const LENGTH: usize = 3;
    pub const TOOL_LENGTH: usize = 4;
    /// How many there are.
    pub const COUNT: usize = 5;
}

/// A ball-bar set-up table as written in the manifest, validated; file units (mm, µm).
#[derive(Clone, Debug, PartialEq)]
pub struct BallbarConfig {
    /// Nominal table-side ball centre in the workpiece frame, mm.
    pub pivot_mm: [f64; 3],
    /// Nominal (calibrated) bar length, mm.
    pub length_mm: f64,
    /// Standard deviation of one `dr` reading, µm.
    pub sigma_um: f64,
    pub pivot_free: bool,
    pub length_free: bool,
    /// Prior standard deviation of the bar-length error when it is free, µm.
    pub length_u_um: Option<f64>,
    pub tool_length_free: bool,
}

impl BallbarConfig {
    /// Reads and validates a set-up table; unknown keys are rejected.
    pub fn from_table(table: &toml::Table) -> Result<Self, SetupError> {
        let keys: Keys = config::read(table)?;
        let pivot_mm = required(
            keys.pivot,
            "pivot",
            "the nominal table-side ball centre [x, y, z] in mm, workpiece frame",
        )?
        .0;
        let length_mm = required(keys.length, "length", "the nominal bar length in mm")?.0;
        if length_mm <= 0.0 {
            return Err(SetupError::new(
                "length",
                format!("the bar length must be positive (mm), found {length_mm}"),
            ));
        }
        if length_mm > config::MAX_SETUP_MM {
            return Err(SetupError::new(
                "length",
                format!(
                    "{length_mm:e} mm lies beyond any machine's reach: a set-up's lengths are \
                     within {:e} mm (a kilometre)",
                    config::MAX_SETUP_MM
                ),
            ));
        }
        let sigma_um = keys.sigma_um.map_or(1.0, f64::from);
        if sigma_um <= 0.0 {
            return Err(SetupError::new(
                "sigma_um",
                format!("the reading's standard deviation must be positive (µm), found {sigma_um}"),
            ));
        }
        let length_free = keys.length_free.unwrap_or(false);
        let length_u_um = keys.length_u_um.map(f64::from);
        if let Some(u) = length_u_um {
            if u <= 0.0 {
                return Err(SetupError::new(
                    "length_u_um",
                    format!(
                        "the bar-length prior must be a positive standard deviation (µm), found {u}"
                    ),
                ));
            }
            if !length_free {
                return Err(SetupError::new(
                    "length_u_um",
                    "a prior on the bar length needs `length_free = true` (a held length is calibrated)",
                ));
            }
        }
        Ok(Self {
            pivot_mm,
            length_mm,
            sigma_um,
            pivot_free: keys.pivot_free.unwrap_or(true),
            length_free,
            length_u_um,
            tool_length_free: keys.tool_length_free.unwrap_or(true),
        })
    }

    /// The table again (every key written, defaults included).
    pub fn to_table(&self) -> toml::Table {
        let keys = Keys {
            pivot: Some(Vec3(self.pivot_mm)),
            length: Some(Number(self.length_mm)),
            sigma_um: Some(Number(self.sigma_um)),
            pivot_free: Some(self.pivot_free),
            length_free: Some(self.length_free),
            length_u_um: self.length_u_um.map(Number),
            tool_length_free: Some(self.tool_length_free),
        };
        toml::Table::try_from(keys).expect("numbers and flags make a table")
    }

    /// Nominal pivot, m.
    pub fn pivot(&self) -> Vector3<f64> {
        Vector3::from(self.pivot_mm) * 1e-3
    }

    /// Nominal bar length, m.
    pub fn length(&self) -> f64 {
        self.length_mm * 1e-3
    }
}

/// A loaded ball-bar set-up: one channel `dr`, five nuisance parameters
/// (`pivot_x`, `pivot_y`, `pivot_z`, `length`, `tool_length`; see the crate docs).
#[derive(Clone, Debug)]
pub struct BallbarSetup {
    config: BallbarConfig,
    pivot: Vector3<f64>,
    length: f64,
    channels: [Channel; 1],
    nuisance: [Nuisance; nuis::COUNT],
}

impl BallbarSetup {
    pub fn new(config: BallbarConfig) -> Self {
        let um = |name: &str, free: bool, prior: Option<f64>| Nuisance {
            name: name.to_string(),
            unit: Unit::Um,
            free,
            prior_sigma: prior,
        };
        let nuisance = [
            um("pivot_x", config.pivot_free, None),
            um("pivot_y", config.pivot_free, None),
            um("pivot_z", config.pivot_free, None),
            um(
                "length",
                config.length_free,
                config.length_u_um.map(|u| u * 1e-6),
            ),
            um("tool_length", config.tool_length_free, None),
        ];
        Self {
            pivot: config.pivot(),
            length: config.length(),
            channels: [Channel {
                name: READING.to_string(),
                unit: Unit::Um,
                sigma: config.sigma_um * 1e-6,
            }],
            nuisance,
            config,
        }
    }

    pub fn config(&self) -> &BallbarConfig {
        &self.config
    }

    /// The tool ball and the actual pivot (m, workpiece frame) for nuisance values `nuis`.
    #[inline]
    fn ends(&self, at: &At<'_>, nuis: &[f64]) -> (Vector3<f64>, Vector3<f64>) {
        let pose = at.w_t_t;
        let ball = pose.t - pose.r.column(2) * nuis[nuis::TOOL_LENGTH];
        let pivot = self.pivot
            + Vector3::new(
                nuis[nuis::PIVOT_X],
                nuis[nuis::PIVOT_Y],
                nuis[nuis::PIVOT_Z],
            );
        (ball, pivot)
    }
}

/// The reading channel: the bar length minus its nominal `length`, µm.
pub const READING: &str = "dr";

/// The measuring range of `dr`, m: ±1 mm, that of the usual telescopic bars (Renishaw QC20-W).
pub(crate) const RANGE_M: f64 = 1e-3;

impl Setup for BallbarSetup {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    fn touches(&self) -> Touches {
        // Orientation enters through the tool-length offset along the tool axis.
        Touches {
            position: true,
            orientation: true,
        }
    }

    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let (ball, pivot) = self.ends(at, nuis);
        out[0] = (ball - pivot).norm() - (self.length + nuis[nuis::LENGTH]);
    }

    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let (ball, pivot) = self.ends(at, nuis);
        let d = ball - pivot;
        let norm = d.norm();
        // Direction of the bar from pivot to tool ball; arbitrary (zero) if the balls coincide.
        let n = if norm > 0.0 {
            d / norm
        } else {
            Vector3::zeros()
        };
        // The ball sits at o = (0, 0, −δℓ) in the tool frame: it moves by δt + δθ × (R·o), so
        // d(dr) = n·δt + δθ·((R·o) × n).
        let r_o = at.w_t_t.r.column(2) * -nuis[nuis::TOOL_LENGTH];
        let rot = r_o.cross(&n);
        d_pose[..3].copy_from_slice(n.as_slice());
        d_pose[3..6].copy_from_slice(rot.as_slice());
        d_nuis[nuis::PIVOT_X] = -n.x;
        d_nuis[nuis::PIVOT_Y] = -n.y;
        d_nuis[nuis::PIVOT_Z] = -n.z;
        d_nuis[nuis::LENGTH] = -1.0;
        d_nuis[nuis::TOOL_LENGTH] = -n.dot(&at.w_t_t.r.column(2));
        true
    }
}

impl SetupFormat for BallbarSetup {
    fn reading_range(&self, _channel: usize) -> Option<f64> {
        Some(RANGE_M)
    }

    fn to_toml(&self) -> toml::Table {
        self.config.to_table()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<Keys>(), Some(SETUP_KEYS));
    }
}
