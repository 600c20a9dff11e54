//! The R-test set-up: loading, the measurement model and its analytic derivatives.

use mtcal_instrument::config::{self, Number, Vec3, required};
use mtcal_instrument::{At, Channel, Nuisance, Setup, SetupContext, SetupError, SetupFormat, Unit};
use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

/// Default standard deviation of one reading, µm.
pub const DEFAULT_SIGMA_UM: f64 = 0.5;
/// Default measuring range of each reading, ±µm: the ±2 mm of the common R-test probes
/// (a reading beyond it is a unit mistake or a crash, never a measurement).
pub const DEFAULT_RANGE_UM: f64 = 2000.0;
/// The reading channels: the ball centre minus the nest centre along the nest's axes, µm.
pub const READINGS: [&str; 3] = ["dx", "dy", "dz"];
/// Default ball diameter of the three-sensor head, mm (the MT-Check's Ø22 mm ball).
pub const DEFAULT_BALL_DIAMETER_MM: f64 = 22.0;

/// Default sensor elevation, degrees: `asin(1/√3)` ≈ 35.26°, where the three sensor directions
/// at 120° are mutually orthogonal.
pub fn default_sensor_elevation_deg() -> f64 {
    (1.0 / 3.0f64.sqrt()).asin().to_degrees()
}

/// Every key a set-up table may have.
pub const SETUP_KEYS: &[&str] = &[
    "ball",
    "mount",
    "head",
    "sigma_um",
    "range_um",
    "ball_free",
    "tool_length_free",
    "ball_diameter_mm",
    "sensor_elevation_deg",
    "sensor_geometry_free",
    "sensor_gain_u_ppm",
    "sensor_angle_u_urad",
];

/// A set-up table as written ([`SETUP_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Keys {
    ball: Option<Vec3>,
    mount: Option<Mount>,
    head: Option<HeadKind>,
    sigma_um: Option<Number>,
    range_um: Option<Number>,
    ball_free: Option<bool>,
    tool_length_free: Option<bool>,
    ball_diameter_mm: Option<Number>,
    sensor_elevation_deg: Option<Number>,
    sensor_geometry_free: Option<bool>,
    sensor_gain_u_ppm: Option<Number>,
    sensor_angle_u_urad: Option<Number>,
}

impl Keys {
    /// The keys only the three-sensor head takes, and whether each is written.
    fn three_sensor_keys(&self) -> [(&'static str, bool); 5] {
        [
            ("ball_diameter_mm", self.ball_diameter_mm.is_some()),
            ("sensor_elevation_deg", self.sensor_elevation_deg.is_some()),
            ("sensor_geometry_free", self.sensor_geometry_free.is_some()),
            ("sensor_gain_u_ppm", self.sensor_gain_u_ppm.is_some()),
            ("sensor_angle_u_urad", self.sensor_angle_u_urad.is_some()),
        ]
    }
}

/// Sensor azimuths about the head's z axis, degrees.
pub const SENSOR_AZIMUTHS_DEG: [f64; 3] = [0.0, 120.0, 240.0];

/// Which part of the R-test sits where (set-up key `mount`).
///
/// The default is [`Mount::BallOnTable`]: FORMATS.md v1 defined the readings for that
/// arrangement (source 000's MT-Check), so a file without `mount` means it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub enum Mount {
    /// The ball is fixed to the table at `ball` (workpiece frame) and turns with it; the
    /// sensor nest is in the spindle, centred on the tool point, its axes the tool frame's.
    #[default]
    BallOnTable,
    /// The ball is on the tool point; the nest is fixed to the table, centred at `ball`, its
    /// axes the workpiece axes (the IBS R-test, Weikert's R-test).
    BallInSpindle,
}

impl Mount {
    /// Both mounts, the default first.
    pub const ALL: [Mount; 2] = [Mount::BallOnTable, Mount::BallInSpindle];

    /// The set-up value: `"ball-on-table"` or `"ball-in-spindle"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Mount::BallOnTable => "ball-on-table",
            Mount::BallInSpindle => "ball-in-spindle",
        }
    }

    /// Parses a set-up value; the error names the key `mount` and both allowed values.
    pub fn parse(value: &str) -> Result<Self, SetupError> {
        Mount::ALL
            .into_iter()
            .find(|m| m.as_str() == value)
            .ok_or_else(|| {
                SetupError::new(
                    "mount",
                    format!(
                        "unknown mount `{value}`; expected \"ball-on-table\" or \"ball-in-spindle\""
                    ),
                )
            })
    }

    /// `+1` when the sensors sit below the ball's equator pointing up (the nest on the table),
    /// `−1` when they hang above it pointing down (the nest in the spindle).
    fn z_sign(self) -> f64 {
        match self {
            Mount::BallOnTable => -1.0,
            Mount::BallInSpindle => 1.0,
        }
    }
}

impl TryFrom<String> for Mount {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        Mount::parse(&value).map_err(|e| e.message)
    }
}

/// Which head model converts the ball displacement into readings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub enum HeadKind {
    /// The readings are the ball-centre displacement itself.
    Ideal,
    /// Three flat-contact sensors at 120°, converted with the nominal directions.
    ThreeSensor,
}

impl HeadKind {
    pub fn as_str(self) -> &'static str {
        match self {
            HeadKind::Ideal => "ideal",
            HeadKind::ThreeSensor => "three-sensor",
        }
    }
}

impl TryFrom<String> for HeadKind {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        match value.as_str() {
            "ideal" => Ok(HeadKind::Ideal),
            "three-sensor" => Ok(HeadKind::ThreeSensor),
            other => Err(format!(
                "unknown head model `{other}`; expected \"ideal\" or \"three-sensor\""
            )),
        }
    }
}

/// The nominal sensor geometry of the three-sensor head.
#[derive(Clone, Debug, PartialEq)]
pub struct ThreeSensor {
    pub ball_diameter_mm: f64,
    pub elevation_deg: f64,
    pub geometry_free: bool,
    pub gain_u_ppm: Option<f64>,
    pub angle_u_urad: Option<f64>,
    /// Nominal measuring directions `nᵢ` (from sensor i towards the ball centre), head frame.
    n: [Vector3<f64>; 3],
    /// `∂nᵢ/∂azimuth`, unit: the direction an azimuth error turns `nᵢ`.
    u: [Vector3<f64>; 3],
    /// `∂nᵢ/∂elevation`: the direction an elevation error turns `nᵢ`.
    v: [Vector3<f64>; 3],
    /// `N_nom⁻¹` (rows of `N_nom` are the `nᵢ`): what the instrument converts with.
    n_inv: Matrix3<f64>,
}

/// Nominal sensor directions (rows, nest frame) for an elevation in degrees: sensor i sits at
/// azimuth `SENSOR_AZIMUTHS_DEG[i]` and elevation `e` away from the ball's equator and points
/// at the ball centre. On the table (`ball-in-spindle`) the nest holds its sensors below the
/// equator, `nᵢ = (−cos e·cos φᵢ, −cos e·sin φᵢ, sin e)`; hanging from the spindle
/// (`ball-on-table`) above it, the same mirrored in z, `nᵢ = (−cos e·cos φᵢ, −cos e·sin φᵢ,
/// −sin e)`.
pub fn sensor_directions(elevation_deg: f64, mount: Mount) -> [Vector3<f64>; 3] {
    let (se, ce) = elevation_deg.to_radians().sin_cos();
    let zs = mount.z_sign();
    SENSOR_AZIMUTHS_DEG.map(|phi| {
        let (sp, cp) = phi.to_radians().sin_cos();
        Vector3::new(-ce * cp, -ce * sp, zs * se)
    })
}

impl ThreeSensor {
    fn new(
        mount: Mount,
        ball_diameter_mm: f64,
        elevation_deg: f64,
        geometry_free: bool,
        gain_u_ppm: Option<f64>,
        angle_u_urad: Option<f64>,
    ) -> Result<Self, SetupError> {
        let n = sensor_directions(elevation_deg, mount);
        let (se, ce) = elevation_deg.to_radians().sin_cos();
        // The elevation error turns nᵢ away from the equator; mirrored with nᵢ.
        let zs = mount.z_sign();
        let u = SENSOR_AZIMUTHS_DEG.map(|phi| {
            let (sp, cp) = phi.to_radians().sin_cos();
            Vector3::new(sp, -cp, 0.0)
        });
        let v = SENSOR_AZIMUTHS_DEG.map(|phi| {
            let (sp, cp) = phi.to_radians().sin_cos();
            Vector3::new(se * cp, se * sp, zs * ce)
        });
        let nn = Matrix3::from_rows(&[n[0].transpose(), n[1].transpose(), n[2].transpose()]);
        let n_inv = nn
            .try_inverse()
            .filter(|_| nn.determinant().abs() > 1e-6)
            .ok_or_else(|| {
                SetupError::new(
                    "sensor_elevation_deg",
                    format!(
                        "{elevation_deg}° makes the three sensor directions (nearly) coplanar; \
                         the head cannot resolve the ball position"
                    ),
                )
            })?;
        Ok(Self {
            ball_diameter_mm,
            elevation_deg,
            geometry_free,
            gain_u_ppm,
            angle_u_urad,
            n,
            u,
            v,
            n_inv,
        })
    }

    /// The nominal measuring directions `nᵢ`.
    pub fn directions(&self) -> &[Vector3<f64>; 3] {
        &self.n
    }

    /// The actual direction of sensor i for direction errors `a` (azimuth) and `b` (elevation),
    /// rad, and its derivatives with respect to them: `n' = (n + a·u + b·v)/√(1 + a² + b²)`.
    #[inline]
    fn actual(&self, i: usize, a: f64, b: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let s = (1.0 + a * a + b * b).sqrt();
        let np = (self.n[i] + self.u[i] * a + self.v[i] * b) / s;
        let da = (self.u[i] - np * a) / s;
        let db = (self.v[i] - np * b) / s;
        (np, da, db)
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Head {
    Ideal,
    ThreeSensor(Box<ThreeSensor>),
}

/// A loaded R-test set-up.
///
/// Nuisance parameters, in order: `ball_x, ball_y, ball_z` (µm, where the table-side part —
/// the ball on `ball-on-table`, the nest on `ball-in-spindle` — really is relative to `ball`),
/// `tool_length` (µm, positive = a longer tool), and for the
/// three-sensor head, per sensor i = 1, 2, 3: `sensor<i>_gain` (ppm), `sensor<i>_azimuth` and
/// `sensor<i>_elevation` (µrad, direction errors towards increasing azimuth and elevation).
#[derive(Clone, Debug, PartialEq)]
pub struct RTest {
    mount: Mount,
    ball_mm: [f64; 3],
    ball_m: Vector3<f64>,
    sigma_um: f64,
    range_um: f64,
    ball_free: bool,
    tool_length_free: bool,
    head: Head,
    channels: Vec<Channel>,
    nuisance: Vec<Nuisance>,
}

/// Index of `tool_length` in the nuisance vector.
const TOOL_LENGTH: usize = 3;
/// Index of the first sensor-geometry nuisance.
const SENSORS: usize = 4;

impl RTest {
    /// Nominal centre of the table-side part (the ball on `ball-on-table`, the nest on
    /// `ball-in-spindle`; both centres coincide nominally) in the workpiece frame, mm, as
    /// written in the set-up.
    pub fn ball_mm(&self) -> [f64; 3] {
        self.ball_mm
    }

    /// [`RTest::ball_mm`] in m.
    pub fn ball_m(&self) -> Vector3<f64> {
        self.ball_m
    }

    /// Which part sits where.
    pub fn mount(&self) -> Mount {
        self.mount
    }

    pub fn head_kind(&self) -> HeadKind {
        match self.head {
            Head::Ideal => HeadKind::Ideal,
            Head::ThreeSensor(_) => HeadKind::ThreeSensor,
        }
    }

    /// The three-sensor geometry, if the head is the three-sensor one.
    pub fn three_sensor(&self) -> Option<&ThreeSensor> {
        match &self.head {
            Head::Ideal => None,
            Head::ThreeSensor(t) => Some(t),
        }
    }

    /// The ball centre minus the nest centre along the nest's axes (m): what the ideal head
    /// reads.
    #[inline]
    fn displacement(&self, at: &At<'_>, nuis: &[f64]) -> Vector3<f64> {
        let (r, t) = (&at.w_t_t.r, &at.w_t_t.t);
        let table_part = self.ball_m + Vector3::new(nuis[0], nuis[1], nuis[2]);
        let l = nuis[TOOL_LENGTH];
        match self.mount {
            // Ball at t − δℓ·R·ẑ, nest at the table part; the nest's axes are the workpiece's.
            Mount::BallInSpindle => t - r.column(2) * l - table_part,
            // Ball at the table part, nest at n = t − δℓ·R·ẑ with the tool's axes:
            // Rᵀ·(B − n) = Rᵀ·(B − t) + δℓ·ẑ.
            Mount::BallOnTable => {
                let mut d = r.tr_mul(&(table_part - t));
                d.z += l;
                d
            }
        }
    }

    /// `∂reading/∂(ball − head)`: identity for the ideal head, `N_nom⁻¹·diag(1+g)·N_act` for
    /// the three-sensor head.
    #[inline]
    fn conversion(&self, nuis: &[f64]) -> Matrix3<f64> {
        match &self.head {
            Head::Ideal => Matrix3::identity(),
            Head::ThreeSensor(h) => {
                let mut rows = Matrix3::zeros();
                for i in 0..3 {
                    let p = &nuis[SENSORS + 3 * i..SENSORS + 3 * i + 3];
                    let (np, _, _) = h.actual(i, p[1], p[2]);
                    rows.set_row(i, &(np * (1.0 + p[0])).transpose());
                }
                h.n_inv * rows
            }
        }
    }
}

/// `[v]×`, the cross-product matrix: `[v]×·w = v × w`.
#[inline]
fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

fn um(name: &str, free: bool) -> Nuisance {
    Nuisance {
        name: name.into(),
        unit: Unit::Um,
        free,
        prior_sigma: None,
    }
}

/// Loads an R-test set-up table (keys in the crate documentation).
pub fn load(table: &toml::Table, ctx: &SetupContext<'_>) -> Result<RTest, SetupError> {
    let _ = ctx;
    let keys: Keys = config::read(table)?;
    let ball_mm = required(
        keys.ball,
        "ball",
        "the nominal centre of the table-side part (ball or nest) [x, y, z], mm, in the \
         workpiece frame",
    )?
    .0;
    let mount = keys.mount.unwrap_or_default();
    let head_kind = keys.head.unwrap_or(HeadKind::Ideal);
    let positive = |key: &str, v: Option<Number>| -> Result<Option<f64>, SetupError> {
        match v.map(f64::from) {
            Some(x) if x <= 0.0 => Err(SetupError::new(key, format!("must be > 0, found {x}"))),
            v => Ok(v),
        }
    };
    let sigma_um = positive("sigma_um", keys.sigma_um)?.unwrap_or(DEFAULT_SIGMA_UM);
    let range_um = positive("range_um", keys.range_um)?.unwrap_or(DEFAULT_RANGE_UM);
    let ball_free = keys.ball_free.unwrap_or(true);
    let tool_length_free = keys.tool_length_free.unwrap_or(true);

    let head = match head_kind {
        HeadKind::Ideal => {
            if let Some((key, _)) = keys.three_sensor_keys().iter().find(|(_, given)| *given) {
                return Err(SetupError::new(
                    *key,
                    "only for head = \"three-sensor\" (this set-up has the ideal head)",
                ));
            }
            Head::Ideal
        }
        HeadKind::ThreeSensor => {
            let diameter = positive("ball_diameter_mm", keys.ball_diameter_mm)?
                .unwrap_or(DEFAULT_BALL_DIAMETER_MM);
            let elevation = keys
                .sensor_elevation_deg
                .map_or_else(default_sensor_elevation_deg, f64::from);
            if elevation <= 0.0 || elevation >= 90.0 {
                return Err(SetupError::new(
                    "sensor_elevation_deg",
                    format!("must lie strictly between 0 and 90°, found {elevation}"),
                ));
            }
            let geometry_free = keys.sensor_geometry_free.unwrap_or(false);
            let gain_u = positive("sensor_gain_u_ppm", keys.sensor_gain_u_ppm)?;
            let angle_u = positive("sensor_angle_u_urad", keys.sensor_angle_u_urad)?;
            if !geometry_free {
                for (key, v) in [
                    ("sensor_gain_u_ppm", gain_u),
                    ("sensor_angle_u_urad", angle_u),
                ] {
                    if v.is_some() {
                        return Err(SetupError::new(
                            key,
                            "a prior for the sensor geometry needs sensor_geometry_free = true",
                        ));
                    }
                }
            }
            Head::ThreeSensor(Box::new(ThreeSensor::new(
                mount,
                diameter,
                elevation,
                geometry_free,
                gain_u,
                angle_u,
            )?))
        }
    };

    let channels = READINGS
        .iter()
        .map(|name| Channel {
            name: (*name).into(),
            unit: Unit::Um,
            sigma: sigma_um * 1e-6,
        })
        .collect();
    let mut nuisance = vec![
        um("ball_x", ball_free),
        um("ball_y", ball_free),
        um("ball_z", ball_free),
        um("tool_length", tool_length_free),
    ];
    if let Head::ThreeSensor(h) = &head {
        for i in 1..=3 {
            nuisance.push(Nuisance {
                name: format!("sensor{i}_gain"),
                unit: Unit::Ppm,
                free: h.geometry_free,
                prior_sigma: h.gain_u_ppm.map(|s| s * 1e-6),
            });
            for what in ["azimuth", "elevation"] {
                nuisance.push(Nuisance {
                    name: format!("sensor{i}_{what}"),
                    unit: Unit::Urad,
                    free: h.geometry_free,
                    prior_sigma: h.angle_u_urad.map(|s| s * 1e-6),
                });
            }
        }
    }
    Ok(RTest {
        mount,
        ball_mm,
        ball_m: Vector3::from(ball_mm) * 1e-3,
        sigma_um,
        range_um,
        ball_free,
        tool_length_free,
        head,
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

impl Setup for RTest {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let d = self.displacement(at, nuis);
        let r = match self.head {
            Head::Ideal => d,
            Head::ThreeSensor(_) => self.conversion(nuis) * d,
        };
        out[..3].copy_from_slice(r.as_slice());
    }

    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let d = self.displacement(at, nuis);
        let a = self.conversion(nuis);
        let l = nuis[TOOL_LENGTH];
        let (r, t) = (&at.w_t_t.r, &at.w_t_t.t);
        // Left perturbation t ← t + δt, R ← exp([δθ]×)·R; `d` the ideal reading.
        let (a_trans, a_rot, a_ball, a_len) = match self.mount {
            Mount::BallInSpindle => {
                // d = t − δℓ·R·ẑ − B: ∂/∂δt = I; R·ẑ ← R·ẑ + δθ × R·ẑ gives
                // ∂/∂δθ = δℓ·[R·ẑ]×; ∂/∂δb = −I; ∂/∂δℓ = −R·ẑ.
                let z = r.column(2).into_owned();
                (a, a * skew(&z) * l, -a, -(a * z))
            }
            Mount::BallOnTable => {
                // d = Rᵀ·(B − t) + δℓ·ẑ: ∂/∂δt = −Rᵀ; Rᵀ ← Rᵀ·(I − [δθ]×) gives
                // −Rᵀ·[δθ]×·(B − t) = Rᵀ·[B − t]×·δθ; ∂/∂δb = Rᵀ; ∂/∂δℓ = ẑ.
                let ar = a * r.transpose();
                let b = self.ball_m + Vector3::new(nuis[0], nuis[1], nuis[2]);
                (-ar, ar * skew(&(b - t)), ar, a.column(2).into_owned())
            }
        };
        let nn = self.nuisance.len();
        for c in 0..3 {
            for j in 0..3 {
                d_pose[c * 6 + j] = a_trans[(c, j)];
                d_pose[c * 6 + 3 + j] = a_rot[(c, j)];
                d_nuis[c * nn + j] = a_ball[(c, j)];
            }
            d_nuis[c * nn + TOOL_LENGTH] = a_len[c];
        }
        if let Head::ThreeSensor(h) = &self.head {
            for i in 0..3 {
                let p = &nuis[SENSORS + 3 * i..SENSORS + 3 * i + 3];
                let (np, da, db) = h.actual(i, p[1], p[2]);
                let col = h.n_inv.column(i);
                let dg = np.dot(&d);
                let dda = (1.0 + p[0]) * da.dot(&d);
                let ddb = (1.0 + p[0]) * db.dot(&d);
                for c in 0..3 {
                    let k = c * nn + SENSORS + 3 * i;
                    d_nuis[k] = col[c] * dg;
                    d_nuis[k + 1] = col[c] * dda;
                    d_nuis[k + 2] = col[c] * ddb;
                }
            }
        }
        true
    }
}

impl SetupFormat for RTest {
    fn reading_range(&self, _channel: usize) -> Option<f64> {
        Some(self.range_um * 1e-6)
    }

    fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert(
            "ball".into(),
            toml::Value::Array(self.ball_mm.iter().map(|&v| v.into()).collect()),
        );
        t.insert("mount".into(), self.mount.as_str().into());
        t.insert("head".into(), self.head_kind().as_str().into());
        t.insert("sigma_um".into(), self.sigma_um.into());
        t.insert("range_um".into(), self.range_um.into());
        t.insert("ball_free".into(), self.ball_free.into());
        t.insert("tool_length_free".into(), self.tool_length_free.into());
        if let Head::ThreeSensor(h) = &self.head {
            t.insert("ball_diameter_mm".into(), h.ball_diameter_mm.into());
            t.insert("sensor_elevation_deg".into(), h.elevation_deg.into());
            t.insert("sensor_geometry_free".into(), h.geometry_free.into());
            if let Some(u) = h.gain_u_ppm {
                t.insert("sensor_gain_u_ppm".into(), u.into());
            }
            if let Some(u) = h.angle_u_urad {
                t.insert("sensor_angle_u_urad".into(), u.into());
            }
        }
        t
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
