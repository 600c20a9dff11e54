//! The artefact set-up: loading, the measurement model and its analytic derivatives.

use mtcal_instrument::config::{self, Number, Vec3, expected, required};
use mtcal_instrument::{
    At, Channel, LabelError, Nuisance, ReadingError, RunData, Setup, SetupContext, SetupError,
    SetupFormat, Touches, Unit,
};
use mtcal_kinematics::{AxisKind, Machine};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Deserializer};

/// Default standard deviation of one measured coordinate, µm.
pub const DEFAULT_SIGMA_UM: f64 = 1.0;

/// Every key a set-up table may have.
pub const SETUP_KEYS: &[&str] = &[
    "features",
    "placements",
    "origin",
    "rotation_deg",
    "flipped",
    "sigma_um",
    "feature_sigma_um",
    "feature_errors",
];

/// Every key a placement table may have.
pub const PLACEMENT_KEYS: &[&str] = &["origin", "rotation_deg", "flipped", "free"];

/// The name of the one placement of a set-up written without `placements`.
pub const DEFAULT_PLACEMENT: &str = "p1";

/// Largest departure (m) of the nominal tool point from "workpiece coordinates = axis
/// coordinates + a constant" accepted when loading on a machine.
const FRAME_TOL: f64 = 1e-9;

/// A set-up table as written ([`SETUP_KEYS`], in that order). Features and placements are
/// keyed by their names: each is read once its name is known to be valid.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Keys {
    #[serde(default, deserialize_with = "features_table")]
    features: Option<toml::Table>,
    #[serde(default, deserialize_with = "placements_table")]
    placements: Option<toml::Table>,
    origin: Option<Vec3>,
    rotation_deg: Option<Number>,
    flipped: Option<bool>,
    sigma_um: Option<Number>,
    feature_sigma_um: Option<Number>,
    feature_errors: Option<bool>,
}

fn features_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table of features, e.g. { h1 = [0.0, 0.0] }").map(Some)
}

fn placements_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table of placements, e.g. { p1 = { origin = [..] } }").map(Some)
}

/// A placement written in `placements` ([`PLACEMENT_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlacementKeys {
    origin: Option<Vec3>,
    rotation_deg: Option<Number>,
    flipped: Option<bool>,
    free: Option<bool>,
}

/// One placement of the plate on the table.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    pub name: String,
    /// Where the plate's origin sits, machine (axis) coordinates, mm.
    pub origin_mm: [f64; 3],
    /// Turn of the plate about +Z, degrees.
    pub rotation_deg: f64,
    /// Turned over about the plate's own X axis (y → −y, z → −z).
    pub flipped: bool,
    /// Whether the placement's deviation from nominal is estimated (default) or held.
    pub free: bool,
    /// Nominal rotation `Rz(rotation)·Flip`, plate frame → axis frame.
    r0: Matrix3<f64>,
    origin_m: Vector3<f64>,
}

impl Placement {
    fn new(name: &str, origin_mm: [f64; 3], rotation_deg: f64, flipped: bool, free: bool) -> Self {
        let (s, c) = rotation_deg.to_radians().sin_cos();
        let rz = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let flip = if flipped {
            Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
        } else {
            Matrix3::identity()
        };
        Self {
            name: name.to_string(),
            origin_mm,
            rotation_deg,
            flipped,
            free,
            r0: rz * flip,
            origin_m: Vector3::from(origin_mm) * 1e-3,
        }
    }

    /// Nominal position (axis coordinates, m) of a point `p` (plate frame, m).
    pub fn place(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.origin_m + self.r0 * p
    }

    fn to_value(&self) -> toml::Value {
        let mut t = toml::Table::new();
        t.insert("origin".into(), arr(&self.origin_mm));
        t.insert("rotation_deg".into(), self.rotation_deg.into());
        t.insert("flipped".into(), self.flipped.into());
        t.insert("free".into(), self.free.into());
        toml::Value::Table(t)
    }
}

fn arr(v: &[f64]) -> toml::Value {
    toml::Value::Array(v.iter().map(|&x| x.into()).collect())
}

/// A feature name must make a clean label and nuisance name.
pub fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.')
}

/// A loaded artefact set-up (crate docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ArtefactSetup {
    /// Feature names (sorted) and calibrated positions, plate frame, mm (z = 0 on a 2-D plate).
    features: Vec<(String, [f64; 3])>,
    features_m: Vec<Vector3<f64>>,
    /// 2 for a plate whose features are `[x, y]`, 3 for `[x, y, z]`.
    dim: usize,
    placements: Vec<Placement>,
    /// Whether `placements` was written (else the top-level keys describe the one placement).
    sigma_um: f64,
    feature_sigma_um: Option<f64>,
    feature_errors: bool,
    /// Nominal tool point in the workpiece frame at q = 0 (m): workpiece = axis + this.
    c: Vector3<f64>,
    /// Indices of X, Y, Z in the machine's axis order, and the number of axes.
    xyz: [usize; 3],
    n_axes: usize,
    channels: Vec<Channel>,
    nuisance: Vec<Nuisance>,
}

/// Nuisance parameters per placement: `dx, dy, rz` (2-D) or `dx, dy, dz, rx, ry, rz` (3-D).
fn placement_nuis(dim: usize) -> &'static [(&'static str, Unit)] {
    if dim == 2 {
        &[("dx", Unit::Um), ("dy", Unit::Um), ("rz", Unit::Urad)]
    } else {
        &[
            ("dx", Unit::Um),
            ("dy", Unit::Um),
            ("dz", Unit::Um),
            ("rx", Unit::Urad),
            ("ry", Unit::Urad),
            ("rz", Unit::Urad),
        ]
    }
}

const FEATURE_NUIS: [&str; 3] = ["ex", "ey", "ez"];

impl ArtefactSetup {
    /// Feature names (sorted) and their calibrated positions, mm, plate frame.
    pub fn features(&self) -> &[(String, [f64; 3])] {
        &self.features
    }
    pub fn placements(&self) -> &[Placement] {
        &self.placements
    }
    /// 2 or 3.
    pub fn dim(&self) -> usize {
        self.dim
    }
    /// Nominal axis positions (SI, X Y Z) at which feature `k` of placement `j` is probed.
    pub fn nominal_xyz(&self, j: usize, k: usize) -> Vector3<f64> {
        self.placements[j].place(&self.features_m[k])
    }
    /// The label number of (placement `j`, feature `k`).
    pub fn label(&self, j: usize, k: usize) -> u32 {
        (j * self.features.len() + k) as u32
    }
    /// The label text of (placement `j`, feature `k`): `feature` with one placement,
    /// `placement/feature` otherwise.
    pub fn label_text(&self, j: usize, k: usize) -> String {
        if self.placements.len() == 1 {
            self.features[k].0.clone()
        } else {
            format!("{}/{}", self.placements[j].name, self.features[k].0)
        }
    }
    fn n_place_nuis(&self) -> usize {
        placement_nuis(self.dim).len()
    }
    fn feature_nuis_start(&self) -> usize {
        self.placements.len() * self.n_place_nuis()
    }
    /// The nuisance index of placement `j`'s first parameter.
    pub fn placement_nuis_index(&self, j: usize) -> usize {
        j * self.n_place_nuis()
    }
    /// The nuisance index of feature `k`'s first error component, if feature errors are modelled.
    pub fn feature_nuis_index(&self, k: usize) -> Option<usize> {
        self.feature_errors
            .then(|| self.feature_nuis_start() + k * self.dim)
    }

    /// The placement rotation `Rn` for nuisance angles and its three partial derivatives (by
    /// rx, ry, rz; 2-D: only rz is used, the others are zero matrices).
    fn rotation(&self, ang: [f64; 3]) -> (Matrix3<f64>, [Matrix3<f64>; 3]) {
        let [a, b, g] = ang;
        let (sa, ca) = a.sin_cos();
        let (sb, cb) = b.sin_cos();
        let (sg, cg) = g.sin_cos();
        let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, ca, -sa, 0.0, sa, ca);
        let ry = Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
        let rz = Matrix3::new(cg, -sg, 0.0, sg, cg, 0.0, 0.0, 0.0, 1.0);
        let drx = Matrix3::new(0.0, 0.0, 0.0, 0.0, -sa, -ca, 0.0, ca, -sa);
        let dry = Matrix3::new(-sb, 0.0, cb, 0.0, 0.0, 0.0, -cb, 0.0, -sb);
        let drz = Matrix3::new(-sg, -cg, 0.0, cg, -sg, 0.0, 0.0, 0.0, 0.0);
        (rz * ry * rx, [rz * ry * drx, rz * dry * rx, drz * ry * rx])
    }

    /// Splits a label number into (placement, feature).
    fn split(&self, label: u32) -> (usize, usize) {
        let nf = self.features.len();
        let l = (label as usize).min(nf * self.placements.len() - 1);
        (l / nf, l % nf)
    }

    /// Placement `j`'s nuisance: translation (m) and angles (rad).
    fn placement_dev(&self, j: usize, nuis: &[f64]) -> (Vector3<f64>, [f64; 3]) {
        let i = self.placement_nuis_index(j);
        if self.dim == 2 {
            (
                Vector3::new(nuis[i], nuis[i + 1], 0.0),
                [0.0, 0.0, nuis[i + 2]],
            )
        } else {
            (
                Vector3::new(nuis[i], nuis[i + 1], nuis[i + 2]),
                [nuis[i + 3], nuis[i + 4], nuis[i + 5]],
            )
        }
    }

    /// Feature `k`'s actual position in the plate frame (m): calibrated + its error.
    fn feature_actual(&self, k: usize, nuis: &[f64]) -> Vector3<f64> {
        let mut f = self.features_m[k];
        if let Some(i) = self.feature_nuis_index(k) {
            for c in 0..self.dim {
                f[c] += nuis[i + c];
            }
        }
        f
    }

    /// The modelled reading (measured centre minus probed axis position, SI) of every channel.
    fn model(&self, at: &At<'_>, nuis: &[f64]) -> Vector3<f64> {
        let (j, k) = self.split(at.label);
        let p = &self.placements[j];
        let (dt, ang) = self.placement_dev(j, nuis);
        let (rn, _) = self.rotation(ang);
        let v = p.r0 * self.feature_actual(k, nuis);
        // The feature in the workpiece frame minus the actual tool point. The nominal part
        // (c + origin + R0·f) is formed apart from the small ones so that a nominal pose reads 0
        // to rounding: (Rn − I)·v is computed as such.
        let nominal = self.c + p.origin_m + v;
        (nominal - at.w_t_t.t) + dt + (rn - Matrix3::identity()) * v
    }
}

/// Reads a list of 2 or 3 numbers; errors name `key`.
fn point(v: &toml::Value, key: &str) -> Result<(usize, [f64; 3]), SetupError> {
    let bad = || SetupError::new(key, expected("a position [x, y] or [x, y, z] in mm", v));
    let a = v.as_array().ok_or_else(bad)?;
    if !(a.len() == 2 || a.len() == 3) {
        return Err(bad());
    }
    let mut out = [0.0; 3];
    for (o, x) in out.iter_mut().zip(a) {
        *o = config::number(x).ok_or_else(bad)?;
    }
    Ok((a.len(), out))
}

fn positive(key: &str, v: Option<f64>) -> Result<Option<f64>, SetupError> {
    match v {
        Some(x) if x <= 0.0 => Err(SetupError::new(key, format!("must be > 0 (µm), found {x}"))),
        v => Ok(v),
    }
}

/// A placement from its keys as written (the defaults for those left out).
fn placement(name: &str, keys: PlacementKeys) -> Placement {
    Placement::new(
        name,
        keys.origin.map_or([0.0; 3], <[f64; 3]>::from),
        keys.rotation_deg.map_or(0.0, f64::from),
        keys.flipped.unwrap_or(false),
        keys.free.unwrap_or(true),
    )
}

/// Reads the `placements` table: every entry a valid name and a table of placement keys.
fn load_placements(pt: &toml::Table) -> Result<Vec<Placement>, SetupError> {
    if pt.is_empty() {
        return Err(SetupError::new("placements", "no placements"));
    }
    let mut pn: Vec<&String> = pt.keys().collect();
    pn.sort();
    let mut out = Vec::new();
    for name in pn {
        let key = format!("placements.{name}");
        if !valid_name(name) {
            return Err(SetupError::new(key, "not a valid placement name"));
        }
        let t = match &pt[name.as_str()] {
            toml::Value::Table(t) => t,
            v => {
                return Err(SetupError::new(
                    key,
                    expected("a table { origin = [..], rotation_deg = .. }", v),
                ));
            }
        };
        let keys =
            config::read(t).map_err(|e| SetupError::new(format!("{key}.{}", e.key), e.message))?;
        out.push(placement(name, keys));
    }
    Ok(out)
}

/// Where X, Y, Z sit in the machine's axis order, and the nominal tool point at q = 0, if the
/// machine has linear X, Y, Z axes that move the nominal tool point along the workpiece frame's
/// X, Y, Z (the other axes at 0).
pub fn frame_of(machine: &Machine) -> Result<([usize; 3], Vector3<f64>), String> {
    let mut xyz = [0; 3];
    for (i, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        let k = machine
            .axis_index(l)
            .ok_or_else(|| format!("the machine has no {l} axis"))?;
        if machine.axes()[k].kind() != AxisKind::Linear {
            return Err(format!("the machine's {l} axis is not linear"));
        }
        xyz[i] = k;
    }
    let n = machine.n_axes();
    let zero = vec![0.0; n];
    let c = machine.tool_in_workpiece(&zero).t;
    for (i, &k) in xyz.iter().enumerate() {
        let mut q = zero.clone();
        q[k] = 0.1;
        let moved = machine.tool_in_workpiece(&q).t - c;
        let mut want = Vector3::zeros();
        want[i] = 0.1;
        if (moved - want).norm() > FRAME_TOL {
            return Err(format!(
                "moving {} by 100 mm moves the nominal tool point by {:?} mm in the workpiece \
                 frame; the artefact model needs machine coordinates along the workpiece axes",
                ['X', 'Y', 'Z'][i],
                (moved * 1e3).as_slice()
            ));
        }
    }
    Ok((xyz, c))
}

/// Loads an artefact set-up table (keys in the crate documentation).
pub fn load(table_: &toml::Table, ctx: &SetupContext<'_>) -> Result<ArtefactSetup, SetupError> {
    let keys: Keys = config::read(table_)?;
    let ft = required(
        keys.features.as_ref(),
        "features",
        "the features, e.g. { h1 = [0.0, 0.0] }",
    )?;
    if ft.is_empty() {
        return Err(SetupError::new("features", "the plate has no features"));
    }
    let mut names: Vec<&String> = ft.keys().collect();
    names.sort();
    let mut dim = None;
    let mut features = Vec::new();
    for name in names {
        let key = format!("features.{name}");
        if !valid_name(name) {
            return Err(SetupError::new(
                key,
                "a feature name must be non-empty and use only ASCII letters, digits, `_`, `-`, `.`",
            ));
        }
        let (d, p) = point(&ft[name.as_str()], &key)?;
        if *dim.get_or_insert(d) != d {
            return Err(SetupError::new(
                key,
                "every feature must have the same number of coordinates ([x, y] on a 2-D plate, \
                 [x, y, z] on a 3-D one)",
            ));
        }
        features.push((name.clone(), p));
    }
    let dim = dim.unwrap_or(2);
    let top_level = PlacementKeys {
        origin: keys.origin,
        rotation_deg: keys.rotation_deg,
        flipped: keys.flipped,
        free: None,
    };
    let placements = match &keys.placements {
        Some(pt) => {
            let written = [
                ("origin", top_level.origin.is_some()),
                ("rotation_deg", top_level.rotation_deg.is_some()),
                ("flipped", top_level.flipped.is_some()),
            ];
            if let Some((k, _)) = written.iter().find(|(_, given)| *given) {
                return Err(SetupError::new(
                    *k,
                    "give the placement either at the top level or in `placements`, not both",
                ));
            }
            load_placements(pt)?
        }
        None => vec![placement(DEFAULT_PLACEMENT, top_level)],
    };
    let sigma_um = positive("sigma_um", keys.sigma_um.map(f64::from))?.unwrap_or(DEFAULT_SIGMA_UM);
    let feature_sigma_um = positive("feature_sigma_um", keys.feature_sigma_um.map(f64::from))?;
    let feature_errors = keys.feature_errors.unwrap_or(true);
    let (xyz, c) = frame_of(ctx.machine).map_err(|m| SetupError::new("features", m))?;
    let mut setup = ArtefactSetup {
        features_m: features
            .iter()
            .map(|(_, p)| Vector3::from(*p) * 1e-3)
            .collect(),
        features,
        dim,
        placements,
        sigma_um,
        feature_sigma_um,
        feature_errors,
        c,
        xyz,
        n_axes: ctx.machine.n_axes(),
        channels: Vec::new(),
        nuisance: Vec::new(),
    };
    setup.channels = ["x", "y", "z"][..dim]
        .iter()
        .map(|n| Channel {
            name: n.to_string(),
            unit: Unit::Mm,
            sigma: sigma_um * 1e-6,
        })
        .collect();
    let held = setup.datum_held();
    let mut nuisance = Vec::new();
    for p in &setup.placements {
        for (n, unit) in placement_nuis(dim) {
            nuisance.push(Nuisance {
                name: format!("{}_{n}", p.name),
                unit: *unit,
                free: p.free,
                prior_sigma: None,
            });
        }
    }
    if feature_errors {
        for (k, (name, _)) in setup.features.iter().enumerate() {
            for (c, n) in FEATURE_NUIS[..dim].iter().enumerate() {
                nuisance.push(Nuisance {
                    name: format!("{name}_{n}"),
                    unit: Unit::Um,
                    free: !held.contains(&(k, c)),
                    prior_sigma: feature_sigma_um.map(|s| s * 1e-6),
                });
            }
        }
    }
    setup.nuisance = nuisance;
    Ok(setup)
}

impl ArtefactSetup {
    /// The feature error components held at zero to fix the plate's own frame (its datum) when
    /// the plate's errors are free without a prior: otherwise a rigid motion of all features is
    /// the same as a move of every placement. `(feature, component)` pairs:
    /// - the first feature (name order), every component;
    /// - the feature farthest from it: the components across the line between them except the
    ///   one the line is least along (2-D: one; 3-D: two);
    /// - (3-D) the feature farthest from that line: the one component along the normal of the
    ///   plane of the three.
    ///
    /// Empty with a prior (`feature_sigma_um`) or without feature errors, or with one feature.
    pub fn datum_held(&self) -> Vec<(usize, usize)> {
        if !self.feature_errors || self.feature_sigma_um.is_some() || self.features.len() < 2 {
            return Vec::new();
        }
        let f = &self.features_m;
        let mut held: Vec<(usize, usize)> = (0..self.dim).map(|c| (0, c)).collect();
        let far = (1..f.len())
            .max_by(|&a, &b| (f[a] - f[0]).norm().total_cmp(&(f[b] - f[0]).norm()))
            .expect("two features");
        let line = f[far] - f[0];
        let along = line.iamax();
        for c in 0..self.dim {
            if c != along {
                held.push((far, c));
            }
        }
        if self.dim == 3 && f.len() > 2 {
            let u = line.normalize();
            let off = |k: usize| {
                let d = f[k] - f[0];
                (d - u * u.dot(&d)).norm()
            };
            let third = (0..f.len())
                .filter(|&k| k != 0 && k != far)
                .max_by(|&a, &b| off(a).total_cmp(&off(b)))
                .expect("three features");
            let normal = line.cross(&(f[third] - f[0]));
            // The rotation about the line moves the third feature along the normal; hold its
            // component along the normal's largest direction, unless already held.
            let c = normal.iamax();
            held.push((third, c));
        }
        held
    }
}

/// The plugin's loader (boxes [`load`]).
pub fn load_setup(
    table: &toml::Table,
    ctx: &SetupContext<'_>,
) -> Result<Box<dyn Setup>, SetupError> {
    Ok(Box::new(load(table, ctx)?))
}

impl Setup for ArtefactSetup {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    // A feature is probed with the machine standing: the probing cycle reports where it touched.
    fn reads_at_standstill(&self) -> bool {
        true
    }

    fn touches(&self) -> Touches {
        Touches {
            position: true,
            orientation: false,
        }
    }

    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let d = self.model(at, nuis);
        out[..self.dim].copy_from_slice(&d.as_slice()[..self.dim]);
    }

    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let nc = self.dim;
        let nn = self.nuisance.len();
        d_pose[..nc * 6].fill(0.0);
        d_nuis[..nc * nn].fill(0.0);
        let (j, k) = self.split(at.label);
        let p = &self.placements[j];
        let (_, ang) = self.placement_dev(j, nuis);
        let (rn, drot) = self.rotation(ang);
        let v = p.r0 * self.feature_actual(k, nuis);
        let ip = self.placement_nuis_index(j);
        for c in 0..nc {
            // The reading falls as the tool point moves: ∂/∂δt = −I; no orientation.
            d_pose[c * 6 + c] = -1.0;
            // Placement translation.
            d_nuis[c * nn + ip + c] = 1.0;
        }
        // Placement rotations.
        let rot_cols: &[(usize, usize)] = if self.dim == 2 {
            &[(2, 2)]
        } else {
            &[(3, 0), (4, 1), (5, 2)]
        };
        for &(off, which) in rot_cols {
            let dv = drot[which] * v;
            for c in 0..nc {
                d_nuis[c * nn + ip + off] = dv[c];
            }
        }
        // Feature errors: ∂/∂Δf = Rn·R0 (plate frame components).
        if let Some(i) = self.feature_nuis_index(k) {
            let m = rn * p.r0;
            for c in 0..nc {
                for e in 0..self.dim {
                    d_nuis[c * nn + i + e] = m[(c, e)];
                }
            }
        }
        true
    }
}

impl SetupFormat for ArtefactSetup {
    fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        let feats: toml::Table = self
            .features
            .iter()
            .map(|(n, p)| (n.clone(), arr(&p[..self.dim])))
            .collect();
        t.insert("features".into(), toml::Value::Table(feats));
        let pl: toml::Table = self
            .placements
            .iter()
            .map(|p| (p.name.clone(), p.to_value()))
            .collect();
        t.insert("placements".into(), toml::Value::Table(pl));
        t.insert("sigma_um".into(), self.sigma_um.into());
        if let Some(s) = self.feature_sigma_um {
            t.insert("feature_sigma_um".into(), s.into());
        }
        t.insert("feature_errors".into(), self.feature_errors.into());
        t
    }

    fn label_columns(&self) -> &[&'static str] {
        &["feature"]
    }

    fn resolve_label(&self, values: &[&str]) -> Result<u32, LabelError> {
        let v = values.first().copied().unwrap_or("").trim();
        let refused = |message: String| LabelError {
            value: v.to_string(),
            message,
        };
        let (pname, fname) = match v.split_once('/') {
            Some((p, f)) => (Some(p), f),
            None => (None, v),
        };
        let j = match pname {
            Some(pn) => self
                .placements
                .iter()
                .position(|p| p.name == pn)
                .ok_or_else(|| {
                    refused(format!(
                        "unknown placement `{pn}` in `{v}`; the set-up has {}",
                        self.placements
                            .iter()
                            .map(|p| p.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })?,
            None if self.placements.len() == 1 => 0,
            None => {
                return Err(refused(format!(
                    "`{v}`: the set-up has {} placements; write `<placement>/<feature>`",
                    self.placements.len()
                )));
            }
        };
        let k = self
            .features
            .binary_search_by(|(n, _)| n.as_str().cmp(fname))
            .map_err(|_| {
                let known: Vec<&str> = self.features.iter().map(|(n, _)| n.as_str()).collect();
                let shown = if known.len() > 12 {
                    format!("{} … ({} features)", known[..12].join(", "), known.len())
                } else {
                    known.join(", ")
                };
                refused(format!("unknown feature `{fname}`; the plate has {shown}"))
            })?;
        Ok(self.label(j, k))
    }
    /// The file holds measured centres in machine coordinates; the model reads the measured
    /// centre minus the axis position where the feature was probed (crate docs).
    fn prepare_readings(
        &self,
        run: &RunData<'_>,
        readings: &mut [f64],
    ) -> Result<(), ReadingError> {
        let nc = self.dim;
        if run.q.len() % self.n_axes != 0 || readings.len() / nc != run.q.len() / self.n_axes {
            return Err(ReadingError {
                row: None,
                column: "x".into(),
                message: "readings and axis positions have different numbers of samples".into(),
            });
        }
        for (row, q) in readings
            .chunks_exact_mut(nc)
            .zip(run.q.chunks_exact(self.n_axes))
        {
            for c in 0..nc {
                row[c] -= q[self.xyz[c]];
            }
        }
        Ok(())
    }

    fn record_readings(&self, run: &RunData<'_>, readings: &mut [f64]) -> Result<(), ReadingError> {
        let nc = self.dim;
        if run.q.len() % self.n_axes != 0 || readings.len() / nc != run.q.len() / self.n_axes {
            return Err(ReadingError {
                row: None,
                column: "x".into(),
                message: "readings and axis positions have different numbers of samples".into(),
            });
        }
        for (row, q) in readings
            .chunks_exact_mut(nc)
            .zip(run.q.chunks_exact(self.n_axes))
        {
            for c in 0..nc {
                row[c] += q[self.xyz[c]];
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<Keys>(), Some(SETUP_KEYS));
        assert_eq!(config::keys_of::<PlacementKeys>(), Some(PLACEMENT_KEYS));
    }
}
