//! The displacement set-up: loading, the measurement model and its analytic derivatives.

use mtcal_instrument::config::{self, Number, Vec3, expected, required};
use mtcal_instrument::{
    At, Channel, Nuisance, Setup, SetupContext, SetupError, SetupFormat, Touches, Unit,
};
use nalgebra::Vector3;
use serde::{Deserialize, Deserializer};

/// Default standard deviation of one reading, µm.
pub const DEFAULT_SIGMA_UM: f64 = 0.5;

/// Every key a set-up table may have.
pub const SETUP_KEYS: &[&str] = &["position", "sigma_um", "offset_free", "sensors"];

/// Every key a sensor written as a table may have.
pub const SENSOR_KEYS: &[&str] = &["direction", "sigma_um", "at"];

/// A set-up table as written ([`SETUP_KEYS`], in that order). The sensors are keyed by their
/// names: each is read once its name is known to be valid ([`load_sensor`]).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Keys {
    position: Option<Vec3>,
    sigma_um: Option<Number>,
    offset_free: Option<bool>,
    #[serde(default, deserialize_with = "sensors_table")]
    sensors: Option<toml::Table>,
}

fn sensors_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table of sensors, e.g. { x1 = \"X\", ch5 = {} }").map(Some)
}

/// A sensor written as a table ([`SENSOR_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorKeys {
    direction: Option<SensorDirection>,
    sigma_um: Option<Number>,
    at: Option<Vec3>,
}

/// A sensor's measuring direction as the set-up gives it: the direction, in the workpiece frame,
/// in which a displacement of the touched point reads positive.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(try_from = "toml::Value")]
pub enum SensorDirection {
    /// Along a workpiece-frame axis: `axis` 0, 1, 2 for X, Y, Z; `negative` for `"-X"`.
    Axis { axis: usize, negative: bool },
    /// A vector as written in the set-up (normalised when used, written back as given so the
    /// round trip reproduces the same unit vector bit for bit).
    Vector([f64; 3]),
}

impl SensorDirection {
    /// Parses `"X"`, `"+Y"`, `"-Z"`.
    pub fn parse_letter(s: &str) -> Option<Self> {
        let (negative, rest) = match s.as_bytes().first() {
            Some(b'-') => (true, &s[1..]),
            Some(b'+') => (false, &s[1..]),
            _ => (false, s),
        };
        let axis = match rest {
            "X" => 0,
            "Y" => 1,
            "Z" => 2,
            _ => return None,
        };
        Some(Self::Axis { axis, negative })
    }

    /// The unit direction in the workpiece frame.
    pub fn unit(&self) -> Vector3<f64> {
        match *self {
            Self::Axis { axis, negative } => {
                let mut n = Vector3::zeros();
                n[axis] = if negative { -1.0 } else { 1.0 };
                n
            }
            Self::Vector(v) => Vector3::from(v) / Vector3::from(v).norm(),
        }
    }

    /// The manifest value: `"X"` / `"-X"` (a `"+"` is not written), or the vector as given.
    pub fn to_value(&self) -> toml::Value {
        match *self {
            Self::Axis { axis, negative } => {
                let letter = ["X", "Y", "Z"][axis];
                if negative {
                    format!("-{letter}").into()
                } else {
                    letter.into()
                }
            }
            Self::Vector(v) => toml::Value::Array(v.iter().map(|&x| x.into()).collect()),
        }
    }
}

/// A letter string or a nonzero vector of three finite numbers.
impl TryFrom<toml::Value> for SensorDirection {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        match &value {
            toml::Value::String(s) => Self::parse_letter(s).ok_or_else(|| {
                format!(
                    "unknown direction `{s}`; expected an axis letter \"X\", \"Y\", \"Z\" \
                     (optionally signed, \"-X\") or a vector [x, y, z]"
                )
            }),
            toml::Value::Array(_) => {
                // A direction, not a point: its length is normalised away (no reach bound).
                let v3 = config::vec3(&value)
                    .ok_or_else(|| expected("three numbers [x, y, z]", &value))?;
                let norm = Vector3::from(v3).norm();
                if !(norm.is_finite() && norm > 0.0) {
                    return Err(format!(
                        "the direction vector {value} has no usable length (|v| = {norm}); it \
                         must be nonzero"
                    ));
                }
                Ok(Self::Vector(v3))
            }
            _ => Err(expected(
                "a direction: an axis letter (\"X\", \"-Y\") or a vector [x, y, z]",
                &value,
            )),
        }
    }
}

/// One sensor of a set-up, as written (file units) and as used (SI).
#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    name: String,
    direction: Option<SensorDirection>,
    sigma_um: Option<f64>,
    at_mm: Option<[f64; 3]>,
    /// Unit direction, workpiece frame; zero for a sensor without one.
    n: Vector3<f64>,
    /// Where along the mandrel the sensor touches, tool frame, m (zero by default).
    a: Vector3<f64>,
}

impl Sensor {
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The measuring direction, `None` for a sensor modelled on its own.
    pub fn direction(&self) -> Option<SensorDirection> {
        self.direction
    }
    /// The sensor's own `sigma_um`, if it has one (otherwise the set-up's applies).
    pub fn sigma_um(&self) -> Option<f64> {
        self.sigma_um
    }
    /// The `at` offset as written, mm, tool frame.
    pub fn at_mm(&self) -> Option<[f64; 3]> {
        self.at_mm
    }
    /// The unit measuring direction in the workpiece frame (zero without a direction).
    pub fn unit_direction(&self) -> Vector3<f64> {
        self.n
    }
    /// The `at` offset in metres, tool frame (zero by default).
    pub fn at_m(&self) -> Vector3<f64> {
        self.a
    }

    /// The manifest value: the bare direction when that is all there is, else a table.
    fn to_value(&self) -> toml::Value {
        if let (Some(d), None, None) = (&self.direction, self.sigma_um, self.at_mm) {
            return d.to_value();
        }
        let mut t = toml::Table::new();
        if let Some(d) = &self.direction {
            t.insert("direction".into(), d.to_value());
        }
        if let Some(s) = self.sigma_um {
            t.insert("sigma_um".into(), s.into());
        }
        if let Some(a) = self.at_mm {
            t.insert(
                "at".into(),
                toml::Value::Array(a.iter().map(|&x| x.into()).collect()),
            );
        }
        toml::Value::Table(t)
    }
}

/// A sensor name must make a clean CSV column `d_<name>` and nuisance name `<name>_offset`.
fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Prefixes the key of an error from a read inside sensor `name`'s table.
fn in_sensor(name: &str) -> impl Fn(SetupError) -> SetupError + '_ {
    move |e| SetupError::new(format!("sensors.{name}.{}", e.key), e.message)
}

fn positive(key: &str, v: Option<f64>) -> Result<Option<f64>, SetupError> {
    match v {
        Some(x) if x <= 0.0 => Err(SetupError::new(
            key,
            format!("the standard deviation of a reading must be > 0 (µm), found {x}"),
        )),
        v => Ok(v),
    }
}

/// Reads one entry of the `sensors` table.
fn load_sensor(name: &str, v: &toml::Value) -> Result<Sensor, SetupError> {
    let key = format!("sensors.{name}");
    if !valid_name(name) {
        return Err(SetupError::new(
            &key,
            "a sensor name must be non-empty and use only ASCII letters, digits, `_` and `-` \
             (it becomes the column d_<name>)",
        ));
    }
    let (direction, sigma_um, at_mm) = match v {
        toml::Value::Table(t) => {
            let keys: SensorKeys = config::read(t).map_err(in_sensor(name))?;
            let sigma = positive(&format!("{key}.sigma_um"), keys.sigma_um.map(f64::from))?;
            let at = keys.at.map(<[f64; 3]>::from);
            if at.is_some() && keys.direction.is_none() {
                // Its reading does not depend on the pose, so where it touches would be ignored:
                // more likely a forgotten `direction` than a deliberate choice.
                return Err(SetupError::new(
                    format!("{key}.at"),
                    "`at` needs a `direction`: a sensor without one reads only its own offset",
                ));
            }
            (keys.direction, sigma, at)
        }
        other => {
            let direction =
                SensorDirection::try_from(other.clone()).map_err(|m| SetupError::new(&key, m))?;
            (Some(direction), None, None)
        }
    };
    Ok(Sensor {
        name: name.to_string(),
        n: direction.map_or_else(Vector3::zeros, |d| d.unit()),
        a: at_mm.map_or_else(Vector3::zeros, |a| Vector3::from(a) * 1e-3),
        direction,
        sigma_um,
        at_mm,
    })
}

/// A loaded displacement set-up.
///
/// Channels `d_<sensor>` and nuisance parameters `<sensor>_offset` (µm), both in sorted
/// sensor-name order (see the crate docs).
#[derive(Clone, Debug, PartialEq)]
pub struct DisplacementSetup {
    position_mm: [f64; 3],
    position_m: Vector3<f64>,
    sigma_um: f64,
    offset_free: bool,
    sensors: Vec<Sensor>,
    channels: Vec<Channel>,
    nuisance: Vec<Nuisance>,
}

impl DisplacementSetup {
    /// Nominal tool point where the sensors touch, mm, workpiece frame.
    pub fn position_mm(&self) -> [f64; 3] {
        self.position_mm
    }
    /// Nominal tool point, m, workpiece frame.
    pub fn position_m(&self) -> Vector3<f64> {
        self.position_m
    }
    /// The sensors in channel order (sorted by name).
    pub fn sensors(&self) -> &[Sensor] {
        &self.sensors
    }
    pub fn offset_free(&self) -> bool {
        self.offset_free
    }
    /// The set-up's standard deviation of one reading, µm (sensors may have their own).
    pub fn sigma_um(&self) -> f64 {
        self.sigma_um
    }
}

/// Loads a displacement set-up table (keys in the crate documentation).
pub fn load(table: &toml::Table, ctx: &SetupContext<'_>) -> Result<DisplacementSetup, SetupError> {
    // The model sees the machine only through the tool pose; the path checks the set-up
    // against the machine's nominal geometry.
    let _ = ctx;
    let keys: Keys = config::read(table)?;
    let position_mm = keys.position.map_or([0.0; 3], <[f64; 3]>::from);
    let sigma_um = positive("sigma_um", keys.sigma_um.map(f64::from))?.unwrap_or(DEFAULT_SIGMA_UM);
    let offset_free = keys.offset_free.unwrap_or(true);
    let sensors_table = required(
        keys.sensors.as_ref(),
        "sensors",
        "the sensors, e.g. [setup.<name>.sensors] x1 = \"X\"",
    )?;
    if sensors_table.is_empty() {
        return Err(SetupError::new("sensors", "the set-up has no sensors"));
    }
    // Sorted explicitly: whether toml keeps insertion order depends on a cargo feature that
    // any crate in a build may switch on, and the channel order must not change with it.
    let mut names: Vec<&String> = sensors_table.keys().collect();
    names.sort();
    let sensors = names
        .into_iter()
        .map(|name| load_sensor(name, &sensors_table[name.as_str()]))
        .collect::<Result<Vec<_>, _>>()?;
    let channels = sensors
        .iter()
        .map(|s| Channel {
            name: format!("d_{}", s.name),
            unit: Unit::Um,
            sigma: s.sigma_um.unwrap_or(sigma_um) * 1e-6,
        })
        .collect();
    let nuisance = sensors
        .iter()
        .map(|s| Nuisance {
            name: format!("{}_offset", s.name),
            unit: Unit::Um,
            free: offset_free,
            prior_sigma: None,
        })
        .collect();
    Ok(DisplacementSetup {
        position_mm,
        position_m: Vector3::from(position_mm) * 1e-3,
        sigma_um,
        offset_free,
        sensors,
        channels,
        nuisance,
    })
}

/// The plugin's loader (boxes [`load`]).
pub fn load_setup(
    table: &toml::Table,
    ctx: &SetupContext<'_>,
) -> Result<Box<dyn Setup>, SetupError> {
    Ok(Box::new(load(table, ctx)?))
}

impl Setup for DisplacementSetup {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    fn touches(&self) -> Touches {
        let directed = || self.sensors.iter().filter(|s| s.direction.is_some());
        Touches {
            position: directed().next().is_some(),
            // Orientation enters only through a touched point away from the tool point.
            orientation: directed().any(|s| s.a != Vector3::zeros()),
        }
    }

    fn reads_pose(&self, channel: usize) -> bool {
        self.sensors
            .get(channel)
            .is_some_and(|s| s.direction.is_some())
    }

    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let pose = at.w_t_t;
        // Shared by every sensor: how far the tool point is from where the set-up puts it.
        let dt = pose.t - self.position_m;
        for (i, s) in self.sensors.iter().enumerate() {
            out[i] = nuis[i];
            if s.direction.is_some() {
                // Touched point t + R·a against its nominal position + a (nominal tool frame
                // aligned with the workpiece frame, crate docs); R·a − a is formed apart from
                // dt so that a nominal pose reads 0 to rounding of the small terms.
                let moved = dt + (pose.r * s.a - s.a);
                out[i] += s.n.dot(&moved);
            }
        }
    }

    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let _ = nuis;
        let ns = self.sensors.len();
        d_nuis[..ns * ns].fill(0.0);
        for (i, s) in self.sensors.iter().enumerate() {
            let row = &mut d_pose[i * 6..i * 6 + 6];
            // The touched point x = t + R·a is fixed to the tool: under the left perturbation it
            // moves by δt + δθ × (R·a), so n·x changes by n·δt + δθ·((R·a) × n). A sensor
            // without a direction has zero rows (n = 0).
            let lever = (at.w_t_t.r * s.a).cross(&s.n);
            row[..3].copy_from_slice(s.n.as_slice());
            row[3..].copy_from_slice(lever.as_slice());
            d_nuis[i * ns + i] = 1.0;
        }
        true
    }
}

impl SetupFormat for DisplacementSetup {
    fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert(
            "position".into(),
            toml::Value::Array(self.position_mm.iter().map(|&v| v.into()).collect()),
        );
        t.insert("sigma_um".into(), self.sigma_um.into());
        t.insert("offset_free".into(), self.offset_free.into());
        let sensors: toml::Table = self
            .sensors
            .iter()
            .map(|s| (s.name.clone(), s.to_value()))
            .collect();
        t.insert("sensors".into(), toml::Value::Table(sensors));
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<Keys>(), Some(SETUP_KEYS));
        assert_eq!(config::keys_of::<SensorKeys>(), Some(SENSOR_KEYS));
    }
}
