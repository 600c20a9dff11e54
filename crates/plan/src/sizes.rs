//! The planning file's `[geometry]`: instrument and fixture sizes, mm. The tool side's and the
//! table's are the planner's own ([`SHARED`]); every other key belongs to the instrument whose
//! bodies take it (its plugin declares it in
//! [`Planning::sizes`](mtcal_instrument::collision::Planning)). Every key has a default; a key
//! nobody declares is an error naming it.

use mtcal_instrument::collision::{SizeKey, Sizes, ToolSide};

/// Where fixtures stand: the table top's z in the workpiece frame.
pub const TABLE_Z: SizeKey = SizeKey::finite("table_z_mm", 0.0);
/// The holder: a cylinder from the gauge point down the tool axis.
pub const HOLDER_DIAMETER: SizeKey = SizeKey::positive("holder_diameter_mm", 50.0);
pub const HOLDER_LENGTH: SizeKey = SizeKey::positive("holder_length_mm", 60.0);
/// The stem from the instrument's tool-side part up to the holder.
pub const STEM_DIAMETER: SizeKey = SizeKey::positive("stem_diameter_mm", 8.0);

/// The planner's own keys, shared by every instrument.
pub const SHARED: [SizeKey; 4] = [TABLE_Z, HOLDER_DIAMETER, HOLDER_LENGTH, STEM_DIAMETER];

/// The sizes of a planning file (`[geometry]`), mm as written, each checked by the key that
/// takes it; what it leaves out takes the key's default.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GeometryConfig {
    sizes: Sizes,
}

/// Why a `[geometry]` key was refused; the message names the key.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct SizeError {
    pub key: String,
    /// No one declares the key (else its value was refused).
    pub unknown: bool,
    pub message: String,
}

impl GeometryConfig {
    /// Reads the given sizes (mm by key): each key must be the planner's or a registered
    /// instrument's, and a value every key of that name takes.
    pub fn read<'a>(
        given: impl IntoIterator<Item = (&'a str, &'a toml::Value)>,
    ) -> Result<Self, SizeError> {
        let mut config = GeometryConfig::default();
        for (key, value) in given {
            let mm = match value {
                toml::Value::Float(x) => *x,
                toml::Value::Integer(i) => *i as f64,
                other => {
                    return Err(SizeError {
                        key: key.to_string(),
                        unknown: false,
                        message: format!("[geometry] `{key}` must be a number (mm), found {other}"),
                    });
                }
            };
            config = config.with(key, mm)?;
        }
        Ok(config)
    }

    /// With `key` set to `mm`, checked as the planning file's keys are.
    pub fn with(self, key: &str, mm: f64) -> Result<Self, SizeError> {
        let claimants = claimants(key);
        if claimants.is_empty() {
            let known: Vec<String> = every_key()
                .iter()
                .map(|k| format!("`{}`", k.name))
                .collect();
            // serde's wording, as when `[geometry]` was one typed table.
            return Err(SizeError {
                key: key.to_string(),
                unknown: true,
                message: format!(
                    "unknown field `{key}`, expected one of {}",
                    known.join(", ")
                ),
            });
        }
        for k in claimants {
            k.check(mm).map_err(|m| SizeError {
                key: key.to_string(),
                unknown: false,
                message: format!("[geometry] `{key}` {m}"),
            })?;
        }
        Ok(GeometryConfig {
            sizes: self.sizes.with(key, mm),
        })
    }

    /// The table top's z in the workpiece frame, mm.
    pub fn table_z_mm(&self) -> f64 {
        self.sizes.mm(&TABLE_Z)
    }

    /// The shared sizes of the tool side, m.
    pub fn tool_side(&self) -> ToolSide {
        ToolSide {
            table_z: self.sizes.m(&TABLE_Z),
            holder_diameter: self.sizes.m(&HOLDER_DIAMETER),
            holder_length: self.sizes.m(&HOLDER_LENGTH),
            stem_diameter: self.sizes.m(&STEM_DIAMETER),
        }
    }

    /// Every size given, for the instruments' bodies.
    pub fn sizes(&self) -> &Sizes {
        &self.sizes
    }
}

/// The planner's keys, then every registered instrument's (in the registry's order).
fn every_key() -> Vec<SizeKey> {
    let mut keys = SHARED.to_vec();
    for plugin in mtcal_plugins::plugins() {
        for key in plugin.planning.iter().flat_map(|p| p.sizes) {
            if !keys.contains(key) {
                keys.push(*key);
            }
        }
    }
    keys
}

/// Every declaration of `key` (an instrument may share a size with another: each checks it).
fn claimants(key: &str) -> Vec<SizeKey> {
    every_key().into_iter().filter(|k| k.name == key).collect()
}
