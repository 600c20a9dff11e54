//! The laser set-up: loading, the measurement model and its analytic derivatives.

use crate::env::{Environment, compensate, uncompensate};
pub use crate::mode::Mode;
use mtcal_instrument::config::{self, Number, Vec3, expected, required};
use mtcal_instrument::{
    At, Channel, Nuisance, ReadingError, RunData, Setup, SetupContext, SetupError, SetupFormat,
    Touches, Unit,
};
use mtcal_kinematics::Machine;
use mtcal_kinematics::rigid::{left_jacobian_inverse, log_so3};
use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

/// Default standard deviation of one length reading (linear, straightness, diagonal), µm.
pub const DEFAULT_SIGMA_UM: f64 = 0.5;
/// Default standard deviation of one angular reading, µrad.
pub const DEFAULT_SIGMA_URAD: f64 = 1.0;
/// Default standard deviation of the prior on each beam tilt angle, µrad.
pub const DEFAULT_TILT_PRIOR_URAD: f64 = 100.0;
/// How far from perpendicular (|cos|) `sense` or `about` may be to `direction`.
pub const PERPENDICULAR_TOL: f64 = 1e-6;

/// Every key a set-up table may have.
pub const SETUP_KEYS: &[&str] = &[
    "mode",
    "direction",
    "sense",
    "about",
    "optic",
    "optic_offset",
    "origin",
    "sigma_um",
    "sigma_urad",
    "offset_free",
    "tilt_free",
    "tilt_prior_urad",
    "slope_free",
    "wavelength_compensated",
    "assumed_index",
    "wavelength_nm",
    "air_temperature_c",
    "air_pressure_hpa",
    "air_humidity_pct",
    "material_temperature_c",
    "expansion_ppm_per_k",
];

/// A set-up table as written ([`SETUP_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Keys {
    mode: Option<Mode>,
    direction: Option<Direction>,
    sense: Option<Direction>,
    about: Option<Direction>,
    optic: Option<Optic>,
    optic_offset: Option<Vec3>,
    origin: Option<Vec3>,
    sigma_um: Option<Number>,
    sigma_urad: Option<Number>,
    offset_free: Option<bool>,
    tilt_free: Option<bool>,
    tilt_prior_urad: Option<Number>,
    slope_free: Option<bool>,
    wavelength_compensated: Option<bool>,
    assumed_index: Option<Number>,
    wavelength_nm: Option<Number>,
    air_temperature_c: Option<Number>,
    air_pressure_hpa: Option<Number>,
    air_humidity_pct: Option<Number>,
    material_temperature_c: Option<Number>,
    expansion_ppm_per_k: Option<Number>,
}

impl Keys {
    /// The environment keys as written.
    fn environment(&self) -> Environment {
        let number = |n: Option<Number>| n.map(f64::from);
        Environment {
            wavelength_compensated: self.wavelength_compensated,
            assumed_index: number(self.assumed_index),
            wavelength_nm: number(self.wavelength_nm),
            air_temperature_c: number(self.air_temperature_c),
            air_pressure_hpa: number(self.air_pressure_hpa),
            air_humidity_pct: number(self.air_humidity_pct),
            material_temperature_c: number(self.material_temperature_c),
            expansion_ppm_per_k: number(self.expansion_ppm_per_k),
        }
    }
}

/// Where the moving optic sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub enum Optic {
    /// Moving optic on the tool side; laser and fixed optic on the table (the beam is fixed in
    /// the workpiece frame).
    Tool,
    /// Moving optic on the table; laser and fixed optic on the tool side (the beam turns with
    /// the tool).
    Table,
}

impl TryFrom<String> for Optic {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        match value.as_str() {
            "tool" => Ok(Optic::Tool),
            "table" => Ok(Optic::Table),
            s => Err(format!(
                "unknown optic `{s}`; expected \"tool\" or \"table\""
            )),
        }
    }
}

/// A direction as written in the set-up: a signed axis letter or a vector (workpiece frame).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(try_from = "toml::Value")]
pub struct Direction {
    value: toml::Value,
    unit: Vector3<f64>,
}

impl TryFrom<toml::Value> for Direction {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        let unit = match &value {
            toml::Value::String(s) => parse_letter(s).ok_or_else(|| {
                format!(
                    "unknown direction `{s}`; expected an axis letter \"X\", \"Y\", \"Z\" \
                     (optionally signed, \"-X\") or a vector [x, y, z]"
                )
            })?,
            toml::Value::Array(_) => {
                let v3 = config::vec3(&value)
                    .map(Vector3::from)
                    .ok_or_else(|| expected("three numbers [x, y, z]", &value))?;
                let norm = v3.norm();
                if !(norm.is_finite() && norm > 0.0) {
                    return Err(format!(
                        "the vector {value} has no usable length; it must be nonzero"
                    ));
                }
                v3 / norm
            }
            _ => {
                return Err(expected(
                    "a direction: an axis letter (\"X\", \"-Y\") or a vector [x, y, z]",
                    &value,
                ));
            }
        };
        Ok(Self { value, unit })
    }
}

impl Direction {
    /// The unit vector, workpiece frame.
    pub fn unit(&self) -> Vector3<f64> {
        self.unit
    }

    /// The value as written.
    pub fn value(&self) -> &toml::Value {
        &self.value
    }
}

fn parse_letter(s: &str) -> Option<Vector3<f64>> {
    let (sign, rest) = match s.as_bytes().first() {
        Some(b'-') => (-1.0, &s[1..]),
        Some(b'+') => (1.0, &s[1..]),
        _ => (1.0, s),
    };
    let i = match rest {
        "X" => 0,
        "Y" => 1,
        "Z" => 2,
        _ => return None,
    };
    let mut v = Vector3::zeros();
    v[i] = sign;
    Some(v)
}

/// Two unit vectors completing `n` to a right-handed orthonormal basis `(n, e1, e2)`:
/// `e1` is the workpiece axis least aligned with `n` (ties to the first of X, Y, Z) with its
/// part along `n` removed, normalised; `e2 = n × e1`. For `n = +X`: `e1 = +Y`, `e2 = +Z`; for
/// `+Y`: `e1 = +X`, `e2 = −Z`; for `+Z`: `e1 = +X`, `e2 = +Y`.
pub fn perpendicular_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let a = n.abs();
    let k = if a.x <= a.y && a.x <= a.z {
        Vector3::x()
    } else if a.y <= a.z {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let e1 = (k - n * n.dot(&k)).normalize();
    let e2 = n.cross(&e1);
    (e1, e2)
}

/// A loaded laser set-up.
#[derive(Clone, Debug)]
pub struct LaserSetup {
    mode: Mode,
    direction: Direction,
    sense: Option<Direction>,
    about: Option<Direction>,
    optic: Optic,
    optic_offset_mm: Option<[f64; 3]>,
    /// A point on the beam, workpiece frame, mm (key `origin`).
    origin_mm: Option<[f64; 3]>,
    sigma_um: Option<f64>,
    sigma_urad: Option<f64>,
    offset_free: bool,
    tilt_free: bool,
    tilt_prior_urad: f64,
    slope_free: bool,
    env: Environment,
    /// The nominal machine (for the nominal pose at `q`).
    machine: Machine,
    /// Unit beam direction (workpiece frame).
    n: Vector3<f64>,
    /// The nominal measuring direction `m₀`: the beam for length modes, the sense for
    /// straightness, the rotation axis for angular.
    m0: Vector3<f64>,
    /// The two directions the measuring direction tilts towards (µrad nuisance parameters):
    /// `e1`, `e2` perpendicular to the beam for length modes; for straightness `e1 = −n`
    /// (the reference line's slope) and `e2` unused.
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    /// Optic offset, tool frame, m.
    a: Vector3<f64>,
    /// The point the measuring direction tilts about (workpiece frame, m): `origin`, or the
    /// workpiece origin.
    b: Vector3<f64>,
    channels: Vec<Channel>,
    nuisance: Vec<Nuisance>,
}

impl PartialEq for LaserSetup {
    fn eq(&self, other: &Self) -> bool {
        self.to_toml() == other.to_toml()
    }
}

impl LaserSetup {
    pub fn mode(&self) -> Mode {
        self.mode
    }
    /// The beam direction as written.
    pub fn direction(&self) -> &Direction {
        &self.direction
    }
    pub fn optic(&self) -> Optic {
        self.optic
    }
    /// Unit beam direction, workpiece frame.
    pub fn beam(&self) -> Vector3<f64> {
        self.n
    }
    /// The nominal measuring direction (beam, sense or rotation axis), workpiece frame.
    pub fn measuring_direction(&self) -> Vector3<f64> {
        self.m0
    }
    /// The optic offset, tool frame, m.
    pub fn optic_offset_m(&self) -> Vector3<f64> {
        self.a
    }
    /// The environmental compensation settings.
    pub fn environment(&self) -> &Environment {
        &self.env
    }
    /// The nominal machine the set-up was loaded for.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The nominal position of the moving optic at `q`, workpiece frame, m.
    pub fn nominal_optic(&self, q: &[f64]) -> Vector3<f64> {
        let p0 = self.machine.tool_in_workpiece(q);
        p0.t + p0.r * self.a
    }

    /// The commanded travel along the beam at `q`: `n · p₀(q)`, m (the nominal optic
    /// position projected on the beam, from the workpiece origin).
    pub fn travel(&self, q: &[f64]) -> f64 {
        self.n.dot(&self.nominal_optic(q))
    }

    /// The measuring direction tilted by the nuisance angles, and its derivatives by them:
    /// `m = (m₀ + α e1 + β e2)/k`, `k = √(1 + α² + β²)`. Exact: `m₀ ⟂ e1 ⟂ e2`.
    fn tilted(&self, alpha: f64, beta: f64) -> [Vector3<f64>; 3] {
        let k2 = 1.0 + alpha * alpha + beta * beta;
        let k = k2.sqrt();
        let v = self.m0 + self.e1 * alpha + self.e2 * beta;
        let m = v / k;
        // ∂m/∂α = e1/k − v α/k³ = (e1 − m α)/k.
        let da = (self.e1 - m * alpha) / k;
        let db = (self.e2 - m * beta) / k;
        [m, da, db]
    }

    /// `m − m₀`, formed without cancellation: `m₀ (1/k − 1) + (α e1 + β e2)/k`.
    fn tilt_change(&self, alpha: f64, beta: f64) -> Vector3<f64> {
        let s = alpha * alpha + beta * beta;
        let k = (1.0 + s).sqrt();
        self.m0 * (-s / (k * (1.0 + k))) + (self.e1 * alpha + self.e2 * beta) / k
    }

    fn angles(&self, nuis: &[f64]) -> (f64, f64) {
        match self.mode {
            Mode::Angular => (0.0, 0.0),
            Mode::Straightness => (nuis[1], 0.0),
            _ => (nuis[1], nuis[2]),
        }
    }
}

fn positive(key: &str, v: Option<f64>, what: &str) -> Result<Option<f64>, SetupError> {
    match v {
        Some(x) if x <= 0.0 => Err(SetupError::new(
            key,
            format!("{what} must be > 0, found {x}"),
        )),
        v => Ok(v),
    }
}

/// A perpendicular direction (`sense`, `about`): required in its mode, rejected elsewhere,
/// perpendicular to the beam.
fn perpendicular(
    given: Option<Direction>,
    key: &str,
    needed: bool,
    mode: Mode,
    n: &Vector3<f64>,
    what: &str,
) -> Result<Option<Direction>, SetupError> {
    match (given, needed) {
        (None, false) => Ok(None),
        (None, true) => Err(SetupError::new(key, format!("missing: {what}"))),
        (Some(d), needed) => {
            if !needed {
                return Err(SetupError::new(
                    key,
                    format!("not used in mode \"{}\"", mode.as_str()),
                ));
            }
            let c = d.unit.dot(n);
            if c.abs() > PERPENDICULAR_TOL {
                return Err(SetupError::new(
                    key,
                    format!("must be perpendicular to `direction` (cos = {c:.3e}); {what}"),
                ));
            }
            Ok(Some(d))
        }
    }
}

/// Loads a laser set-up table (keys in the crate documentation).
pub fn load(table: &toml::Table, ctx: &SetupContext<'_>) -> Result<LaserSetup, SetupError> {
    let keys: Keys = config::read(table)?;
    let environment = keys.environment();
    let mode = required(
        keys.mode,
        "mode",
        "linear, straightness, angular, diagonal or step-diagonal",
    )?;
    let direction = required(
        keys.direction,
        "direction",
        "the beam direction (axis letter or vector, workpiece frame)",
    )?;
    let n = direction.unit;
    let sense = perpendicular(
        keys.sense,
        "sense",
        mode == Mode::Straightness,
        mode,
        &n,
        "the direction in which the straightness deviation is read, perpendicular to the beam",
    )?;
    let about = perpendicular(
        keys.about,
        "about",
        mode == Mode::Angular,
        mode,
        &n,
        "the axis of the rotation read (pitch or yaw), perpendicular to the beam",
    )?;
    let optic = keys.optic.unwrap_or(Optic::Tool);
    let optic_offset_mm = keys.optic_offset.map(<[f64; 3]>::from);
    let origin_mm = keys.origin.map(<[f64; 3]>::from);
    let sigma_um = positive(
        "sigma_um",
        keys.sigma_um.map(f64::from),
        "the standard deviation of a reading",
    )?;
    let sigma_urad = positive(
        "sigma_urad",
        keys.sigma_urad.map(f64::from),
        "the standard deviation of a reading",
    )?;
    let angular = mode == Mode::Angular;
    if angular && sigma_um.is_some() {
        return Err(SetupError::new(
            "sigma_um",
            "an angular reading's standard deviation is `sigma_urad`",
        ));
    }
    if !angular && sigma_urad.is_some() {
        return Err(SetupError::new(
            "sigma_urad",
            "a length reading's standard deviation is `sigma_um`",
        ));
    }
    let offset_free = keys.offset_free.unwrap_or(true);
    let tilt_free = keys.tilt_free;
    let tilt_prior = positive(
        "tilt_prior_urad",
        keys.tilt_prior_urad.map(f64::from),
        "the prior's standard deviation",
    )?;
    let slope_free = keys.slope_free;
    if !mode.is_length() {
        for (key, given) in [
            ("tilt_free", tilt_free.is_some()),
            ("tilt_prior_urad", tilt_prior.is_some()),
        ] {
            if given {
                return Err(SetupError::new(
                    key,
                    format!(
                        "the beam tilt is a nuisance of length modes only, not \"{}\"",
                        mode.as_str()
                    ),
                ));
            }
        }
    }
    if mode != Mode::Straightness && slope_free.is_some() {
        return Err(SetupError::new(
            "slope_free",
            "the reference slope is a nuisance of mode \"straightness\" only",
        ));
    }
    let env = environment.checked(mode)?;
    let a = optic_offset_mm.map_or_else(Vector3::zeros, |v| Vector3::from(v) * 1e-3);
    let b = origin_mm.map_or_else(Vector3::zeros, |v| Vector3::from(v) * 1e-3);
    let (m0, e1, e2) = match mode {
        Mode::Straightness => {
            let s = sense.as_ref().expect("required").unit;
            // Orthogonalised exactly (the loader allows |cos| up to PERPENDICULAR_TOL).
            let s = (s - n * n.dot(&s)).normalize();
            (s, -n, Vector3::zeros())
        }
        Mode::Angular => {
            let w = about.as_ref().expect("required").unit;
            (w, Vector3::zeros(), Vector3::zeros())
        }
        _ => {
            let (e1, e2) = perpendicular_basis(&n);
            (n, e1, e2)
        }
    };
    let (unit, sigma) = if angular {
        (Unit::Urad, sigma_urad.unwrap_or(DEFAULT_SIGMA_URAD))
    } else {
        (Unit::Um, sigma_um.unwrap_or(DEFAULT_SIGMA_UM))
    };
    let channels = vec![Channel {
        name: "d".into(),
        unit,
        sigma: sigma * 1e-6,
    }];
    let tilt_free_v = tilt_free.unwrap_or(true);
    let tilt_prior_urad = tilt_prior.unwrap_or(DEFAULT_TILT_PRIOR_URAD);
    let slope_free_v = slope_free.unwrap_or(true);
    let mut nuisance = vec![Nuisance {
        name: "zero".into(),
        unit,
        free: offset_free,
        prior_sigma: None,
    }];
    match mode {
        Mode::Angular => {}
        Mode::Straightness => nuisance.push(Nuisance {
            name: "slope".into(),
            unit: Unit::Urad,
            free: slope_free_v,
            prior_sigma: None,
        }),
        _ => {
            for name in ["tilt_1", "tilt_2"] {
                nuisance.push(Nuisance {
                    name: name.into(),
                    unit: Unit::Urad,
                    free: tilt_free_v,
                    prior_sigma: Some(tilt_prior_urad * 1e-6),
                });
            }
        }
    }
    Ok(LaserSetup {
        mode,
        direction,
        sense,
        about,
        optic,
        optic_offset_mm,
        origin_mm,
        sigma_um,
        sigma_urad,
        offset_free,
        tilt_free: tilt_free_v,
        tilt_prior_urad,
        slope_free: slope_free_v,
        env,
        machine: ctx.machine.clone(),
        n,
        m0,
        e1,
        e2,
        a,
        b,
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

/// What a sample needs: the nominal pose's rotation, the optic's lever in the workpiece frame,
/// and the optic's displacement from nominal.
struct Geometry {
    /// `R·R₀ᵀ` (the tool's rotation relative to nominal).
    rel: Matrix3<f64>,
    /// `R·a`: the optic's lever from the tool point, workpiece frame.
    lever: Vector3<f64>,
    /// `p − p₀`: the optic's displacement from its nominal position.
    dp: Vector3<f64>,
    /// `p₀ − b`: the optic's nominal position from the point the beam tilts about.
    arm: Vector3<f64>,
}

impl LaserSetup {
    fn geometry(&self, at: &At<'_>) -> Geometry {
        let nominal = self.machine.tool_in_workpiece(at.q);
        let lever = at.w_t_t.r * self.a;
        let lever0 = nominal.r * self.a;
        Geometry {
            rel: at.w_t_t.r * nominal.r.transpose(),
            dp: (at.w_t_t.t - nominal.t) + (lever - lever0),
            lever,
            arm: nominal.t + lever0 - self.b,
        }
    }
}

impl Setup for LaserSetup {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    // Positioning (ISO 230-2), straightness and angular runs and diagonals (ISO 230-6) read
    // with the axes standing at each target.
    fn reads_at_standstill(&self) -> bool {
        true
    }

    fn touches(&self) -> Touches {
        match self.mode {
            Mode::Angular => Touches {
                position: false,
                orientation: true,
            },
            _ => Touches {
                position: true,
                orientation: self.optic == Optic::Table || self.a != Vector3::zeros(),
            },
        }
    }

    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let g = self.geometry(at);
        if self.mode == Mode::Angular {
            out[0] = self.m0.dot(&log_so3(&g.rel)) + nuis[0];
            return;
        }
        let (alpha, beta) = self.angles(nuis);
        let m = self.tilted(alpha, beta)[0];
        let u = match self.optic {
            Optic::Tool => m,
            Optic::Table => g.rel * m,
        };
        out[0] = u.dot(&g.dp) + self.tilt_change(alpha, beta).dot(&g.arm) + nuis[0];
    }

    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let g = self.geometry(at);
        let nn = self.nuisance.len();
        d_nuis[..nn].fill(0.0);
        d_nuis[0] = 1.0;
        if self.mode == Mode::Angular {
            // φ = log(R R₀ᵀ); under R ← exp(δθ)R, φ ← φ + J_l(φ)⁻¹ δθ.
            let phi = log_so3(&g.rel);
            let row = left_jacobian_inverse(&phi).transpose() * self.m0;
            d_pose[..3].fill(0.0);
            d_pose[3..6].copy_from_slice(row.as_slice());
            return true;
        }
        let (alpha, beta) = self.angles(nuis);
        let [m, dm_a, dm_b] = self.tilted(alpha, beta);
        let (u, du_a, du_b) = match self.optic {
            Optic::Tool => (m, dm_a, dm_b),
            Optic::Table => (g.rel * m, g.rel * dm_a, g.rel * dm_b),
        };
        // p = t + R a moves by δt + δθ × (R a): ∂(u·dp) = u·δt + δθ·((R a) × u).
        let mut w = g.lever.cross(&u);
        if self.optic == Optic::Table {
            // u = R R₀ᵀ m turns too: δu = δθ × u, so u·dp changes by δθ·(u × dp).
            w += u.cross(&g.dp);
        }
        d_pose[..3].copy_from_slice(u.as_slice());
        d_pose[3..6].copy_from_slice(w.as_slice());
        // ∂d/∂α = ∂u/∂α·dp + ∂m/∂α·p₀ (the change m − m₀ has the derivative of m).
        d_nuis[1] = du_a.dot(&g.dp) + dm_a.dot(&g.arm);
        if nn > 2 {
            d_nuis[2] = du_b.dot(&g.dp) + dm_b.dot(&g.arm);
        }
        true
    }
}

impl SetupFormat for LaserSetup {
    fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert("mode".into(), self.mode.as_str().into());
        t.insert("direction".into(), self.direction.value.clone());
        if let Some(s) = &self.sense {
            t.insert("sense".into(), s.value.clone());
        }
        if let Some(a) = &self.about {
            t.insert("about".into(), a.value.clone());
        }
        t.insert(
            "optic".into(),
            match self.optic {
                Optic::Tool => "tool",
                Optic::Table => "table",
            }
            .into(),
        );
        if let Some(o) = self.optic_offset_mm {
            t.insert(
                "optic_offset".into(),
                toml::Value::Array(o.iter().map(|&x| x.into()).collect()),
            );
        }
        if let Some(o) = self.origin_mm {
            t.insert(
                "origin".into(),
                toml::Value::Array(o.iter().map(|&x| x.into()).collect()),
            );
        }
        if self.mode == Mode::Angular {
            t.insert(
                "sigma_urad".into(),
                self.sigma_urad.unwrap_or(DEFAULT_SIGMA_URAD).into(),
            );
        } else {
            t.insert(
                "sigma_um".into(),
                self.sigma_um.unwrap_or(DEFAULT_SIGMA_UM).into(),
            );
        }
        t.insert("offset_free".into(), self.offset_free.into());
        if self.mode.is_length() {
            t.insert("tilt_free".into(), self.tilt_free.into());
            t.insert("tilt_prior_urad".into(), self.tilt_prior_urad.into());
        }
        if self.mode == Mode::Straightness {
            t.insert("slope_free".into(), self.slope_free.into());
        }
        self.env.write(&mut t);
        t
    }

    fn prepare_readings(
        &self,
        run: &RunData<'_>,
        readings: &mut [f64],
    ) -> Result<(), ReadingError> {
        if !self.env.active() {
            return Ok(());
        }
        let n_axes = self.machine.n_axes();
        let travel: Vec<f64> = run.q.chunks_exact(n_axes).map(|q| self.travel(q)).collect();
        compensate(&self.env, run, &travel, readings)
    }

    fn record_readings(&self, run: &RunData<'_>, readings: &mut [f64]) -> Result<(), ReadingError> {
        if !self.env.active() {
            return Ok(());
        }
        let n_axes = self.machine.n_axes();
        let travel: Vec<f64> = run.q.chunks_exact(n_axes).map(|q| self.travel(q)).collect();
        uncompensate(&self.env, run, &travel, readings)
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
