//! The tracer set-up: its manifest keys, nuisance parameters, measurement model and analytic
//! derivatives (equations in the crate docs).

use mtcal_instrument::config::{self, Number, Vec3, required};
use mtcal_instrument::{
    At, Channel, Nuisance, Setup, SetupContext, SetupError, SetupFormat, Touches, Unit,
};
use mtcal_kinematics::{AxisKind, Machine};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Every key a tracer set-up table may hold.
pub const SETUP_KEYS: &[&str] = &[
    "station",
    "reflector",
    "sigma_um",
    "sigma_um_per_m",
    "station_free",
    "station_u_mm",
    "dead_path_free",
];

/// A set-up table as written ([`SETUP_KEYS`], in that order); [`TracerConfig::to_table`]
/// writes one too.
#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct Keys {
    station: Option<Vec3>,
    reflector: Option<Vec3>,
    sigma_um: Option<Number>,
    sigma_um_per_m: Option<Number>,
    station_free: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    station_u_mm: Option<Number>,
    dead_path_free: Option<bool>,
}

/// Default length-independent standard deviation of one reading, µm (k = 1 from the
/// LaserTRACER's U(k = 2) = 0.2 µm + 0.3 µm/m).
pub const DEFAULT_SIGMA_UM: f64 = 0.1;
/// Default length-proportional standard deviation, µm per metre of station-to-reflector
/// distance (k = 1).
pub const DEFAULT_SIGMA_UM_PER_M: f64 = 0.15;

/// Index of each nuisance parameter in [`TracerSetup::nuisance`] (and in `nuis` slices).
pub mod nuis {
    pub const STATION_X: usize = 0;
    pub const STATION_Y: usize = 1;
    pub const STATION_Z: usize = 2;
    pub const DEAD_PATH: usize = 3;
    /// How many there are.
    pub const COUNT: usize = 4;
}

/// A tracer set-up table as written in the manifest, validated; file units (mm, µm).
#[derive(Clone, Debug, PartialEq)]
pub struct TracerConfig {
    /// Approximate station (tracer pivot) position, workpiece frame, mm.
    pub station_mm: [f64; 3],
    /// Reflector centre from the tool point, tool frame, mm.
    pub reflector_mm: [f64; 3],
    /// Length-independent standard deviation of one reading, µm.
    pub sigma_um: f64,
    /// Length-proportional standard deviation, µm per m.
    pub sigma_um_per_m: f64,
    pub station_free: bool,
    /// Prior standard deviation of the station correction, mm (none by default).
    pub station_u_mm: Option<f64>,
    pub dead_path_free: bool,
}

fn non_negative(key: &str, v: f64, what: &str) -> Result<f64, SetupError> {
    if v < 0.0 {
        return Err(SetupError::new(
            key,
            format!("{what} must be >= 0, found {v}"),
        ));
    }
    Ok(v)
}

impl TracerConfig {
    /// Reads and validates a set-up table; unknown keys are rejected.
    pub fn from_table(table: &toml::Table) -> Result<Self, SetupError> {
        let keys: Keys = config::read(table)?;
        let station_mm = required(
            keys.station,
            "station",
            "the approximate station position [x, y, z] in mm, workpiece frame",
        )?
        .0;
        let reflector_mm = keys.reflector.map_or([0.0; 3], <[f64; 3]>::from);
        let sigma_um = keys.sigma_um.map_or(DEFAULT_SIGMA_UM, f64::from);
        if sigma_um <= 0.0 {
            return Err(SetupError::new(
                "sigma_um",
                format!(
                    "the length-independent standard deviation must be positive (µm), found {sigma_um}"
                ),
            ));
        }
        let sigma_um_per_m = non_negative(
            "sigma_um_per_m",
            keys.sigma_um_per_m
                .map_or(DEFAULT_SIGMA_UM_PER_M, f64::from),
            "the length-proportional standard deviation (µm/m)",
        )?;
        let station_free = keys.station_free.unwrap_or(true);
        let station_u_mm = keys.station_u_mm.map(f64::from);
        if let Some(u) = station_u_mm {
            if u <= 0.0 {
                return Err(SetupError::new(
                    "station_u_mm",
                    format!(
                        "the station prior must be a positive standard deviation (mm), found {u}"
                    ),
                ));
            }
            if !station_free {
                return Err(SetupError::new(
                    "station_u_mm",
                    "a prior on the station needs `station_free = true` (a held station is calibrated)",
                ));
            }
        }
        let dead_path_free = keys.dead_path_free.unwrap_or(true);
        Ok(Self {
            station_mm,
            reflector_mm,
            sigma_um,
            sigma_um_per_m,
            station_free,
            station_u_mm,
            dead_path_free,
        })
    }

    /// The table again (every key written, defaults included; `station_u_mm` only if given).
    pub fn to_table(&self) -> toml::Table {
        let keys = Keys {
            station: Some(Vec3(self.station_mm)),
            reflector: Some(Vec3(self.reflector_mm)),
            sigma_um: Some(Number(self.sigma_um)),
            sigma_um_per_m: Some(Number(self.sigma_um_per_m)),
            station_free: Some(self.station_free),
            station_u_mm: self.station_u_mm.map(Number),
            dead_path_free: Some(self.dead_path_free),
        };
        toml::Table::try_from(keys).expect("numbers and flags make a table")
    }

    /// Nominal station, m.
    pub fn station(&self) -> Vector3<f64> {
        Vector3::from(self.station_mm) * 1e-3
    }

    /// Reflector offset, m, tool frame.
    pub fn reflector(&self) -> Vector3<f64> {
        Vector3::from(self.reflector_mm) * 1e-3
    }
}

/// The axis positions at the middle of every linear axis' stroke (0 without limits), rotary
/// axes at 0 clamped into their limits: where the channel's σ is evaluated.
pub fn middle_of_strokes(machine: &Machine) -> Vec<f64> {
    machine
        .axes()
        .iter()
        .map(|a| match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some((lo, hi))) => 0.5 * (lo + hi),
            (_, Some((lo, hi))) => 0.0_f64.clamp(lo, hi),
            (_, None) => 0.0,
        })
        .collect()
}

/// A loaded tracer set-up: one channel `d`, four nuisance parameters (`station_x`,
/// `station_y`, `station_z`, `dead_path`; crate docs).
#[derive(Clone, Debug)]
pub struct TracerSetup {
    config: TracerConfig,
    /// The machine, for the nominal tool pose at each sample's commanded positions.
    machine: Machine,
    station: Vector3<f64>,
    reflector: Vector3<f64>,
    /// Station-to-reflector distance at the middle of the strokes (nominal machine), m.
    typical_distance: f64,
    channels: [Channel; 1],
    nuisance: [Nuisance; nuis::COUNT],
}

impl TracerSetup {
    pub fn new(config: TracerConfig, machine: &Machine) -> Self {
        let station = config.station();
        let reflector = config.reflector();
        let mid = machine.tool_in_workpiece(&middle_of_strokes(machine));
        let typical_distance = (mid.t + mid.r * reflector - station).norm();
        let sigma_um = config.sigma_um + config.sigma_um_per_m * typical_distance;
        let sigma = sigma_um * 1e-6;
        let um = |name: &str, free: bool, prior: Option<f64>| Nuisance {
            name: name.to_string(),
            unit: Unit::Um,
            free,
            prior_sigma: prior,
        };
        let prior = config.station_u_mm.map(|u| u * 1e-3);
        let nuisance = [
            um("station_x", config.station_free, prior),
            um("station_y", config.station_free, prior),
            um("station_z", config.station_free, prior),
            um("dead_path", config.dead_path_free, None),
        ];
        Self {
            machine: machine.clone(),
            station,
            reflector,
            typical_distance,
            channels: [Channel {
                name: "d".to_string(),
                unit: Unit::Um,
                sigma,
            }],
            nuisance,
            config,
        }
    }

    pub fn config(&self) -> &TracerConfig {
        &self.config
    }

    /// The distance (m) at which the channel's σ was evaluated: station to the nominal
    /// reflector with the linear axes mid-stroke.
    pub fn typical_distance(&self) -> f64 {
        self.typical_distance
    }

    /// The nominal reflector position (m, workpiece frame) at commanded positions `q`.
    pub fn nominal_reflector(&self, q: &[f64]) -> Vector3<f64> {
        let p = self.machine.tool_in_workpiece(q);
        p.t + p.r * self.reflector
    }

    /// `(b, a − b, R·r)`: the nominal station-to-reflector vector `b = x₀ − s₀`, the change
    /// `a − b` to the actual one `a = x − s` (formed from small differences, so that it keeps
    /// its digits) and the actual reflector lever `R·r`.
    #[inline]
    fn vectors(&self, at: &At<'_>, nuis: &[f64]) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let pose = at.w_t_t;
        let nominal = self.machine.tool_in_workpiece(at.q);
        let ds = Vector3::new(
            nuis[nuis::STATION_X],
            nuis[nuis::STATION_Y],
            nuis[nuis::STATION_Z],
        );
        let r_actual = pose.r * self.reflector;
        let r_nominal = nominal.r * self.reflector;
        let b = nominal.t + r_nominal - self.station;
        let change = (pose.t - nominal.t) + (r_actual - r_nominal) - ds;
        (b, change, r_actual)
    }
}

/// The plugin's `load_setup`: a [`TracerSetup`] from a manifest table.
pub fn load_setup(
    table: &toml::Table,
    ctx: &SetupContext<'_>,
) -> Result<Box<dyn Setup>, SetupError> {
    Ok(Box::new(load(table, ctx)?))
}

/// [`load_setup`] with the concrete type.
pub fn load(table: &toml::Table, ctx: &SetupContext<'_>) -> Result<TracerSetup, SetupError> {
    Ok(TracerSetup::new(
        TracerConfig::from_table(table)?,
        ctx.machine,
    ))
}

impl Setup for TracerSetup {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    // A tracer measures each point with the machine standing at it.
    fn reads_at_standstill(&self) -> bool {
        true
    }

    fn touches(&self) -> Touches {
        Touches {
            position: true,
            // Orientation enters only through a reflector away from the tool point.
            orientation: self.reflector != Vector3::zeros(),
        }
    }

    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let (b, change, _) = self.vectors(at, nuis);
        let a = b + change;
        // |a| − |b| = (a − b)·(a + b) / (|a| + |b|): exact algebra, and no cancellation of two
        // metre-sized norms.
        let denom = a.norm() + b.norm();
        let dl = if denom > 0.0 {
            change.dot(&(a + b)) / denom
        } else {
            0.0
        };
        out[0] = dl + nuis[nuis::DEAD_PATH];
    }

    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let (b, change, r_actual) = self.vectors(at, nuis);
        let a = b + change;
        let norm = a.norm();
        // The line of sight from the station to the reflector (zero if they coincide).
        let u = if norm > 0.0 {
            a / norm
        } else {
            Vector3::zeros()
        };
        // The reflector x = t + R·r moves by δt + δθ × (R·r): d changes by u·δt + δθ·((R·r) × u).
        let lever = r_actual.cross(&u);
        d_pose[..3].copy_from_slice(u.as_slice());
        d_pose[3..6].copy_from_slice(lever.as_slice());
        d_nuis[nuis::STATION_X] = -u.x;
        d_nuis[nuis::STATION_Y] = -u.y;
        d_nuis[nuis::STATION_Z] = -u.z;
        d_nuis[nuis::DEAD_PATH] = 1.0;
        true
    }
}

impl SetupFormat for TracerSetup {
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
