//! The tolerance specification file (TOML; format in the crate docs and docs/TOLERANCE.md).
//!
//! Every error names the file, line and column of the offending key or value and says what was
//! expected; nothing here panics on bad input.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use mtcal_kinematics::{AxisKind, Direction, Machine, ParamName};
use mtcal_located::Location;
use mtcal_located::toml::{Problem, SerdeMessages, problem};
use nalgebra::Vector3;
use serde::Deserialize;
use toml::Spanned;

/// The `schema` value of version 1 of this format.
pub const SCHEMA: &str = "mtcal.tolerances/1";

/// Default sensitivity levels: each tolerance alone scaled by these factors.
pub const DEFAULT_LEVELS: [f64; 4] = [0.0, 0.5, 1.5, 2.0];

/// Why a specification was rejected.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    #[error("{}: cannot read the tolerance specification: {cause}", path.display())]
    Read {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// The contents are wrong at `at`; `message` says what was expected.
    #[error("{at}: {message}")]
    Invalid { at: Location, message: String },
}

impl SpecError {
    /// Where in the file the problem is (None for read failures).
    pub fn position(&self) -> Option<&Location> {
        match self {
            SpecError::Read { .. } => None,
            SpecError::Invalid { at, .. } => Some(at),
        }
    }
}

/// How a tolerance's random variable `X` is drawn; the sampled error is `tolerance · X`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Distribution {
    /// `X` uniform on `[−1, 1]`: the tolerance is a bound.
    Uniform,
    /// `X` normal with σ = 1/2: the tolerance is 2σ.
    Normal,
    /// `|X| = 1` (random sign): every part at the tolerance limit.
    Limit,
}

/// Which guide direction a rail straightness tolerance is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RailDirection {
    /// Along the mounting-surface normal `n`.
    Vertical,
    /// Along the lateral direction `l = n × a`.
    Horizontal,
}

/// The course of a directly toleranced component error over the stroke, `ξ ∈ [0, 1]` from the
/// stroke's start to its end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shape {
    /// `ξ`: zero at the start, the tolerance at the end (a scale error).
    Linear,
    /// `4ξ(1 − ξ)`: zero at both ends, the tolerance in the middle.
    Bow,
    /// `1` everywhere.
    Constant,
}

impl Shape {
    pub fn at(self, xi: f64) -> f64 {
        match self {
            Shape::Linear => xi,
            Shape::Bow => 4.0 * xi * (1.0 - xi),
            Shape::Constant => 1.0,
        }
    }
}

/// What a tolerance applies to. Axes are 0 = X, 1 = Y, 2 = Z.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// Straightness of both rails' mounting surfaces of an axis (one independent profile each).
    Rail {
        axis: usize,
        direction: RailDirection,
    },
    /// Parallelism of the four block pads of an axis' carriage (normal direction).
    Pads { axis: usize },
    /// A component error of a linear axis with a course over the stroke.
    Component {
        axis: usize,
        direction: Direction,
        shape: Shape,
    },
    /// A squareness error: 0 = EC0Y, 1 = EB0Z, 2 = EA0Z.
    Squareness { which: usize },
}

/// One toleranced quantity.
#[derive(Clone, Debug, PartialEq)]
pub struct Tolerance {
    /// A name for reports (the `label` key, or one made from the target).
    pub label: String,
    pub target: Target,
    /// The tolerance in SI units (m or rad): a zone width for rails, a bound / 2σ otherwise.
    pub value: f64,
    pub distribution: Distribution,
}

impl Tolerance {
    /// Whether the value is an angle (µrad in files) rather than a length (µm).
    pub fn is_angle(&self) -> bool {
        match self.target {
            Target::Component { direction, .. } => direction.is_rotation(),
            Target::Squareness { .. } => true,
            Target::Rail { .. } | Target::Pads { .. } => false,
        }
    }
}

/// The guide of one axis as the file gives it (SI units).
#[derive(Clone, Debug, PartialEq)]
pub struct GuideSpec {
    pub normal: Vector3<f64>,
    pub rail_spacing: f64,
    pub block_pitch: f64,
    pub stiffness: [f64; 4],
    pub lateral_stiffness: [f64; 4],
    pub load: f64,
    pub lateral_load: f64,
    pub modes: usize,
    pub decay: f64,
}

/// A checked specification.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    pub tolerances: Vec<Tolerance>,
    /// Per linear axis X, Y, Z: its guide, if the file describes it.
    pub guides: [Option<GuideSpec>; 3],
    /// Sensitivity scale factors (each tolerance alone; 1 is the baseline and left out).
    pub levels: Vec<f64>,
    pub samples: Option<usize>,
    pub seed: Option<u64>,
    pub grid: Option<Vec<usize>>,
}

/// Reads and checks the specification at `path` for `machine`.
pub fn load_spec(path: &Path, machine: &Machine) -> Result<Spec, SpecError> {
    let text = std::fs::read_to_string(path).map_err(|source| SpecError::Read {
        path: path.to_path_buf(),
        cause: source,
    })?;
    parse_spec(&text, path, machine)
}

/// Parses a specification (`file` names it in errors) and checks it against `machine`.
pub fn parse_spec(text: &str, file: &Path, machine: &Machine) -> Result<Spec, SpecError> {
    let invalid = |span: Range<usize>, message: String| SpecError::Invalid {
        at: Location::of_offset(file, text, span.start),
        message,
    };
    let raw: RawSpec = mtcal_located::toml::from_str(text, &SerdeMessages)
        .map_err(|p| invalid(p.span, p.message))?;
    check(raw, machine).map_err(|p| invalid(p.span, p.message))
}

// ---------------------------------------------------------------------------------------------
// The file as serde reads it

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpec {
    schema: Option<Spanned<String>>,
    monte_carlo: Option<RawMonteCarlo>,
    sensitivity: Option<RawSensitivity>,
    #[serde(default)]
    axis: BTreeMap<Spanned<String>, Spanned<RawAxis>>,
    #[serde(default)]
    tolerance: Vec<Spanned<RawTolerance>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMonteCarlo {
    samples: Option<Spanned<i64>>,
    seed: Option<Spanned<i64>>,
    grid: Option<Spanned<Vec<Spanned<i64>>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSensitivity {
    levels: Spanned<Vec<Spanned<f64>>>,
}

#[derive(Deserialize)]
#[serde(
    untagged,
    expecting = "a number (N/µm, every block) or an array of 4 numbers (blocks 1–4)"
)]
enum RawStiffness {
    One(f64),
    Four([f64; 4]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAxis {
    normal: Spanned<String>,
    rail_spacing_mm: Spanned<f64>,
    block_pitch_mm: Spanned<f64>,
    stiffness_n_per_um: Option<Spanned<RawStiffness>>,
    lateral_stiffness_n_per_um: Option<Spanned<RawStiffness>>,
    load_n: Option<Spanned<f64>>,
    lateral_load_n: Option<Spanned<f64>>,
    modes: Option<Spanned<i64>>,
    decay: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTolerance {
    kind: Spanned<String>,
    label: Option<String>,
    axis: Option<Spanned<String>>,
    direction: Option<Spanned<String>>,
    name: Option<Spanned<String>>,
    shape: Option<Spanned<String>>,
    tolerance_um: Option<Spanned<f64>>,
    tolerance_urad: Option<Spanned<f64>>,
    distribution: Option<Spanned<String>>,
}

/// Default block stiffness, N/µm (a size-25 roller block is of this order; only ratios matter
/// without loads).
pub const DEFAULT_STIFFNESS_N_PER_UM: f64 = 500.0;
/// Default number of profile harmonics.
pub const DEFAULT_MODES: usize = 8;
/// Default spectral decay of the profile harmonics.
pub const DEFAULT_DECAY: f64 = 1.0;

// ---------------------------------------------------------------------------------------------
// Checks

type Checked<T> = Result<T, Problem>;

fn check(raw: RawSpec, machine: &Machine) -> Checked<Spec> {
    if let Some(s) = &raw.schema
        && s.get_ref() != SCHEMA
    {
        return Err(problem(
            s.span(),
            format!(
                "schema \"{}\" is not supported: this version of mtcal reads \"{SCHEMA}\"",
                s.get_ref()
            ),
        ));
    }
    let mut guides: [Option<GuideSpec>; 3] = Default::default();
    for (key, axis) in &raw.axis {
        let l = axis_letter(key)?;
        guides[l] = Some(check_guide(axis, l, machine)?);
    }
    let mut tolerances = Vec::new();
    for t in &raw.tolerance {
        let tol = check_tolerance(t)?;
        if let Target::Rail { axis, .. } | Target::Pads { axis } = tol.target
            && guides[axis].is_none()
        {
            let letter = ['X', 'Y', 'Z'][axis];
            return Err(problem(
                t.get_ref().kind.span(),
                format!(
                    "a {} tolerance of axis {letter} needs the guide geometry: add an [axis.{letter}] \
                     table with normal, rail_spacing_mm and block_pitch_mm",
                    t.get_ref().kind.get_ref()
                ),
            ));
        }
        tolerances.push(tol);
    }
    let (samples, seed, grid) = check_monte_carlo(raw.monte_carlo.as_ref())?;
    let levels = match &raw.sensitivity {
        None => DEFAULT_LEVELS.to_vec(),
        Some(s) => {
            let mut out = Vec::new();
            for v in s.levels.get_ref() {
                let x = *v.get_ref();
                if !(x.is_finite() && x >= 0.0) {
                    return Err(problem(
                        v.span(),
                        "a sensitivity level is a scale factor: a finite number >= 0",
                    ));
                }
                if x != 1.0 && !out.contains(&x) {
                    out.push(x);
                }
            }
            out
        }
    };
    Ok(Spec {
        tolerances,
        guides,
        levels,
        samples,
        seed,
        grid,
    })
}

type MonteCarlo = (Option<usize>, Option<u64>, Option<Vec<usize>>);

fn check_monte_carlo(mc: Option<&RawMonteCarlo>) -> Checked<MonteCarlo> {
    let Some(mc) = mc else {
        return Ok((None, None, None));
    };
    let samples = match &mc.samples {
        Some(s) if *s.get_ref() < 1 => {
            return Err(problem(s.span(), "samples must be a positive integer"));
        }
        Some(s) => Some(*s.get_ref() as usize),
        None => None,
    };
    let seed = match &mc.seed {
        Some(s) if *s.get_ref() < 0 => {
            return Err(problem(s.span(), "seed must be an integer >= 0"));
        }
        Some(s) => Some(*s.get_ref() as u64),
        None => None,
    };
    let grid = match &mc.grid {
        None => None,
        Some(g) => {
            if g.get_ref().len() != 3 {
                return Err(problem(
                    g.span(),
                    "grid must list the points on X, Y and Z, e.g. [11, 11, 11]",
                ));
            }
            let mut out = Vec::new();
            for n in g.get_ref() {
                if !(3..=10_000).contains(n.get_ref()) {
                    return Err(problem(
                        n.span(),
                        "a grid count must be an integer from 3 to 10000",
                    ));
                }
                out.push(*n.get_ref() as usize);
            }
            Some(out)
        }
    };
    Ok((samples, seed, grid))
}

fn axis_letter(s: &Spanned<String>) -> Checked<usize> {
    match s.get_ref().as_str() {
        "X" => Ok(0),
        "Y" => Ok(1),
        "Z" => Ok(2),
        other => Err(problem(
            s.span(),
            format!("`{other}` is not a linear axis of the analysis; expected X, Y or Z"),
        )),
    }
}

fn positive(v: &Spanned<f64>, what: &str) -> Checked<f64> {
    let x = *v.get_ref();
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(problem(
            v.span(),
            format!("{what} must be a positive number"),
        ))
    }
}

fn stiffness(v: Option<&Spanned<RawStiffness>>, what: &str) -> Checked<[f64; 4]> {
    let Some(v) = v else {
        return Ok([DEFAULT_STIFFNESS_N_PER_UM * 1e6; 4]);
    };
    let k = match v.get_ref() {
        RawStiffness::One(k) => [*k; 4],
        RawStiffness::Four(k) => *k,
    };
    if k.iter().all(|k| k.is_finite() && *k > 0.0) {
        Ok(k.map(|k| k * 1e6))
    } else {
        Err(problem(v.span(), format!("{what} must be positive (N/µm)")))
    }
}

fn check_guide(axis: &Spanned<RawAxis>, l: usize, machine: &Machine) -> Checked<GuideSpec> {
    let a = axis.get_ref();
    let normal = parse_direction(&a.normal)?;
    if let Some(i) = machine.axis_index(['X', 'Y', 'Z'][l]) {
        let ax = &machine.axes()[i];
        if ax.kind() == AxisKind::Linear {
            let dir = ax.zero_rotation() * ax.direction();
            if dir.dot(&normal).abs() > 1e-9 {
                return Err(problem(
                    a.normal.span(),
                    format!(
                        "the rail normal `{}` must be perpendicular to the direction of axis {} \
                         (machine [{:.3}, {:.3}, {:.3}])",
                        a.normal.get_ref(),
                        ['X', 'Y', 'Z'][l],
                        dir.x,
                        dir.y,
                        dir.z
                    ),
                ));
            }
        }
    }
    let finite = |v: Option<&Spanned<f64>>, what: &str| match v {
        Some(v) if !v.get_ref().is_finite() => {
            Err(problem(v.span(), format!("{what} must be a finite number")))
        }
        Some(v) => Ok(*v.get_ref()),
        None => Ok(0.0),
    };
    let modes = match &a.modes {
        Some(m) if !(1..=64).contains(m.get_ref()) => {
            return Err(problem(m.span(), "modes must be an integer from 1 to 64"));
        }
        Some(m) => *m.get_ref() as usize,
        None => DEFAULT_MODES,
    };
    let decay = match &a.decay {
        Some(d) if !(d.get_ref().is_finite() && (0.0..=4.0).contains(d.get_ref())) => {
            return Err(problem(d.span(), "decay must be a number from 0 to 4"));
        }
        Some(d) => *d.get_ref(),
        None => DEFAULT_DECAY,
    };
    Ok(GuideSpec {
        normal,
        rail_spacing: positive(&a.rail_spacing_mm, "rail_spacing_mm")? * 1e-3,
        block_pitch: positive(&a.block_pitch_mm, "block_pitch_mm")? * 1e-3,
        stiffness: stiffness(a.stiffness_n_per_um.as_ref(), "stiffness_n_per_um")?,
        lateral_stiffness: stiffness(
            a.lateral_stiffness_n_per_um.as_ref(),
            "lateral_stiffness_n_per_um",
        )?,
        load: finite(a.load_n.as_ref(), "load_n")?,
        lateral_load: finite(a.lateral_load_n.as_ref(), "lateral_load_n")?,
        modes,
        decay,
    })
}

fn parse_direction(s: &Spanned<String>) -> Checked<Vector3<f64>> {
    let text = s.get_ref().trim();
    let (sign, letter) = match text.strip_prefix('-') {
        Some(rest) => (-1.0, rest),
        None => (1.0, text.strip_prefix('+').unwrap_or(text)),
    };
    let v = match letter {
        "X" => Vector3::x(),
        "Y" => Vector3::y(),
        "Z" => Vector3::z(),
        _ => {
            return Err(problem(
                s.span(),
                format!(
                    "`{}` is not a machine direction; expected one of +X, -X, +Y, -Y, +Z, -Z",
                    s.get_ref()
                ),
            ));
        }
    };
    Ok(v * sign)
}

const KINDS: &str = "\"rail\", \"pads\" or \"component\"";

fn check_tolerance(t: &Spanned<RawTolerance>) -> Checked<Tolerance> {
    let r = t.get_ref();
    let kind = r.kind.get_ref().as_str();
    // Which optional keys each kind takes.
    let (allowed, needs_axis): (&[&str], bool) = match kind {
        "rail" => (&["axis", "direction"], true),
        "pads" => (&["axis"], true),
        "component" => (&["name", "shape"], false),
        other => {
            return Err(problem(
                r.kind.span(),
                format!("unknown tolerance kind \"{other}\"; expected {KINDS}"),
            ));
        }
    };
    let given: [(&str, Option<Range<usize>>); 4] = [
        ("axis", r.axis.as_ref().map(Spanned::span)),
        ("direction", r.direction.as_ref().map(Spanned::span)),
        ("name", r.name.as_ref().map(Spanned::span)),
        ("shape", r.shape.as_ref().map(Spanned::span)),
    ];
    for (key, span) in given {
        if let Some(span) = span
            && !allowed.contains(&key)
        {
            return Err(problem(
                span,
                format!(
                    "`{key}` does not apply to a \"{kind}\" tolerance; it takes {}",
                    allowed.join(", ")
                ),
            ));
        }
    }
    let axis = if needs_axis {
        match &r.axis {
            Some(a) => Some(axis_letter(a)?),
            None => {
                return Err(problem(
                    t.span(),
                    format!("a \"{kind}\" tolerance needs `axis` (X, Y or Z)"),
                ));
            }
        }
    } else {
        None
    };
    let target = match (kind, axis) {
        ("rail", Some(axis)) => {
            let Some(d) = &r.direction else {
                return Err(problem(
                    t.span(),
                    "a \"rail\" tolerance needs `direction` (\"vertical\" or \"horizontal\")",
                ));
            };
            let direction = match d.get_ref().as_str() {
                "vertical" => RailDirection::Vertical,
                "horizontal" => RailDirection::Horizontal,
                other => {
                    return Err(problem(
                        d.span(),
                        format!("direction \"{other}\": expected \"vertical\" or \"horizontal\""),
                    ));
                }
            };
            Target::Rail { axis, direction }
        }
        ("pads", Some(axis)) => Target::Pads { axis },
        _ => component_target(t)?,
    };
    let angle = match &target {
        Target::Component { direction, .. } => direction.is_rotation(),
        Target::Squareness { .. } => true,
        _ => false,
    };
    let (value, unit_key) = match (&r.tolerance_um, &r.tolerance_urad, angle) {
        (Some(v), None, false) => (v, "tolerance_um"),
        (None, Some(v), true) => (v, "tolerance_urad"),
        (Some(v), None, true) => {
            return Err(problem(
                v.span(),
                "this tolerance is an angle: give it as tolerance_urad",
            ));
        }
        (None, Some(v), false) => {
            return Err(problem(
                v.span(),
                "this tolerance is a length: give it as tolerance_um",
            ));
        }
        (Some(_), Some(v), _) => {
            return Err(problem(
                v.span(),
                "give either tolerance_um or tolerance_urad, not both",
            ));
        }
        (None, None, _) => {
            return Err(problem(
                t.span(),
                format!(
                    "the tolerance needs its value: {}",
                    if angle {
                        "tolerance_urad"
                    } else {
                        "tolerance_um"
                    }
                ),
            ));
        }
    };
    let x = *value.get_ref();
    if !(x.is_finite() && x >= 0.0) {
        return Err(problem(
            value.span(),
            format!("{unit_key} must be a finite number >= 0"),
        ));
    }
    let default = if matches!(target, Target::Rail { .. }) {
        Distribution::Limit
    } else {
        Distribution::Uniform
    };
    let distribution = match &r.distribution {
        None => default,
        Some(d) => match d.get_ref().as_str() {
            "uniform" => Distribution::Uniform,
            "normal" => Distribution::Normal,
            "limit" => Distribution::Limit,
            other => {
                return Err(problem(
                    d.span(),
                    format!(
                        "distribution \"{other}\": expected \"uniform\", \"normal\" or \"limit\""
                    ),
                ));
            }
        },
    };
    let label = r.label.clone().unwrap_or_else(|| default_label(&target));
    Ok(Tolerance {
        label,
        target,
        value: x * 1e-6,
        distribution,
    })
}

fn component_target(t: &Spanned<RawTolerance>) -> Checked<Target> {
    let r = t.get_ref();
    let Some(name) = &r.name else {
        return Err(problem(
            t.span(),
            "a \"component\" tolerance needs `name`: a component error such as \"EXX\" or a \
             squareness \"EC0Y\", \"EB0Z\", \"EA0Z\"",
        ));
    };
    let parsed: ParamName = name
        .get_ref()
        .parse()
        .map_err(|e| problem(name.span(), format!("`{}`: {e}", name.get_ref())))?;
    match parsed {
        ParamName::Component { direction, axis } => {
            let l = match axis.as_char() {
                'X' => 0,
                'Y' => 1,
                'Z' => 2,
                c => {
                    return Err(problem(
                        name.span(),
                        format!("{parsed}: axis {c} is not one of the analysis' X, Y, Z"),
                    ));
                }
            };
            let Some(shape) = &r.shape else {
                return Err(problem(
                    t.span(),
                    format!(
                        "the component tolerance {parsed} needs `shape`: \"linear\", \"bow\" or \
                         \"constant\""
                    ),
                ));
            };
            let shape = match shape.get_ref().as_str() {
                "linear" => Shape::Linear,
                "bow" => Shape::Bow,
                "constant" => Shape::Constant,
                other => {
                    return Err(problem(
                        shape.span(),
                        format!("shape \"{other}\": expected \"linear\", \"bow\" or \"constant\""),
                    ));
                }
            };
            Ok(Target::Component {
                axis: l,
                direction,
                shape,
            })
        }
        _ => {
            let which = ["EC0Y", "EB0Z", "EA0Z"]
                .iter()
                .position(|s| *s == parsed.to_string());
            match (which, &r.shape) {
                (Some(_), Some(s)) => Err(problem(
                    s.span(),
                    "a squareness is a constant: it takes no `shape`",
                )),
                (Some(which), None) => Ok(Target::Squareness { which }),
                (None, _) => Err(problem(
                    name.span(),
                    format!(
                        "{parsed} cannot be toleranced here; expected a component error of X, Y \
                         or Z (EXX … ECZ) or a squareness EC0Y, EB0Z, EA0Z"
                    ),
                )),
            }
        }
    }
}

fn default_label(t: &Target) -> String {
    let letter = |a: usize| ['X', 'Y', 'Z'][a];
    match t {
        Target::Rail { axis, direction } => {
            let d = match direction {
                RailDirection::Vertical => "vertical",
                RailDirection::Horizontal => "horizontal",
            };
            format!("{} rails {d} straightness", letter(*axis))
        }
        Target::Pads { axis } => format!("{} pad parallelism", letter(*axis)),
        Target::Component {
            axis,
            direction,
            shape,
        } => {
            let s = match shape {
                Shape::Linear => "linear",
                Shape::Bow => "bow",
                Shape::Constant => "constant",
            };
            format!("E{}{} {s}", direction.letter(), letter(*axis))
        }
        Target::Squareness { which } => ["EC0Y", "EB0Z", "EA0Z"][*which].to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_machine::topology::Reading;

    fn machine() -> Machine {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/three-axis/machine/zfyx.urdf"
        );
        mtcal_machine::load_machine(path, Reading::FromTool)
            .unwrap()
            .machine
    }

    const GOOD: &str = r#"schema = "mtcal.tolerances/1"

[monte_carlo]
samples = 100
seed = 7
grid = [5, 5, 4]

[sensitivity]
levels = [0, 1, 2]

[axis.X]
normal = "+Z"
rail_spacing_mm = 400
block_pitch_mm = 250.0
stiffness_n_per_um = [400, 500, 600, 700]

[[tolerance]]
kind = "rail"
axis = "X"
direction = "vertical"
tolerance_um = 30

[[tolerance]]
kind = "component"
name = "EXX"
shape = "linear"
tolerance_um = 10
distribution = "normal"

[[tolerance]]
kind = "component"
name = "EC0Y"
tolerance_urad = 20
label = "XY squareness"
"#;

    #[test]
    fn a_good_spec_reads() {
        let s = parse_spec(GOOD, Path::new("t.toml"), &machine()).unwrap();
        assert_eq!(s.samples, Some(100));
        assert_eq!(s.seed, Some(7));
        assert_eq!(s.grid, Some(vec![5, 5, 4]));
        assert_eq!(s.levels, vec![0.0, 2.0]);
        let g = s.guides[0].as_ref().unwrap();
        assert_eq!(g.stiffness, [4e8, 5e8, 6e8, 7e8]);
        assert_eq!(g.lateral_stiffness, [5e8; 4]);
        assert!((g.rail_spacing - 0.4).abs() < 1e-15 && g.normal == Vector3::z());
        assert_eq!(s.tolerances.len(), 3);
        assert_eq!(s.tolerances[0].label, "X rails vertical straightness");
        assert_eq!(s.tolerances[0].distribution, Distribution::Limit);
        assert!((s.tolerances[0].value - 30e-6).abs() < 1e-18);
        assert_eq!(s.tolerances[1].distribution, Distribution::Normal);
        assert_eq!(s.tolerances[2].target, Target::Squareness { which: 0 });
        assert_eq!(s.tolerances[2].label, "XY squareness");
    }

    /// `(replace, with)` in GOOD must fail at `line:column` with a message containing `says`.
    fn check(replace: &str, with: &str, line: usize, column: usize, says: &str) {
        assert!(GOOD.contains(replace), "{replace}");
        let text = GOOD.replacen(replace, with, 1);
        let e = parse_spec(&text, Path::new("bad.toml"), &machine()).unwrap_err();
        let at = e.position().unwrap();
        assert_eq!(
            (at.line, at.column),
            (line, column),
            "{replace} → {with}: {e}"
        );
        let msg = e.to_string();
        assert!(
            msg.starts_with(&format!("bad.toml:{line}:{column}: ")),
            "{msg}"
        );
        assert!(msg.contains(says), "{replace} → {with}: {msg}");
    }

    #[test]
    fn bad_specs_name_the_place_and_what_was_expected() {
        check("seed = 7", "seeds = 7", 5, 1, "unknown field `seeds`");
        check("samples = 100", "samples = 0", 4, 11, "positive integer");
        check("samples = 100", "samples = \"many\"", 4, 11, "expected i64");
        check(
            "grid = [5, 5, 4]",
            "grid = [5, 2, 4]",
            6,
            12,
            "from 3 to 10000",
        );
        check("levels = [0, 1, 2]", "levels = [0, -1]", 9, 14, ">= 0");
        check("[axis.X]", "[axis.Q]", 11, 7, "expected X, Y or Z");
        check(
            "normal = \"+Z\"",
            "normal = \"+X\"",
            12,
            10,
            "perpendicular",
        );
        check("normal = \"+Z\"", "normal = \"up\"", 12, 10, "+X, -X");
        check(
            "rail_spacing_mm = 400",
            "rail_spacing_mm = -4",
            13,
            19,
            "positive",
        );
        check(
            "[400, 500, 600, 700]",
            "[400, 500]",
            15,
            22,
            "array of 4 numbers",
        );
        check(
            "kind = \"rail\"",
            "kind = \"rails\"",
            18,
            8,
            "expected \"rail\"",
        );
        check(
            "direction = \"vertical\"",
            "direction = \"up\"",
            20,
            13,
            "\"vertical\" or",
        );
        check(
            "tolerance_um = 30",
            "tolerance_urad = 30",
            21,
            18,
            "a length",
        );
        check(
            "tolerance_um = 30",
            "tolerance_um = nan",
            21,
            16,
            "finite number >= 0",
        );
        check("name = \"EXX\"", "name = \"EQX\"", 25, 8, "EQX");
        check(
            "name = \"EXX\"",
            "name = \"EX0C\"",
            25,
            8,
            "cannot be toleranced",
        );
        check(
            "shape = \"linear\"",
            "shape = \"cubic\"",
            26,
            9,
            "\"linear\", \"bow\"",
        );
        check(
            "distribution = \"normal\"",
            "distribution = \"gauss\"",
            28,
            16,
            "\"uniform\"",
        );
        check(
            "tolerance_urad = 20",
            "tolerance_um = 20",
            33,
            16,
            "an angle",
        );
        check(
            "label = \"XY squareness\"",
            "axis = \"X\"",
            34,
            8,
            "does not apply",
        );
        check(
            "schema = \"mtcal.tolerances/1\"",
            "schema = \"v2\"",
            1,
            10,
            "not supported",
        );
        check("[monte_carlo]", "[monte_carlo", 3, 13, "expected `]`");
    }

    #[test]
    fn a_rail_tolerance_without_its_guide_is_an_error() {
        let text = GOOD.replace("axis = \"X\"\ndirection", "axis = \"Y\"\ndirection");
        let e = parse_spec(&text, Path::new("bad.toml"), &machine()).unwrap_err();
        assert!(e.to_string().contains("[axis.Y]"), "{e}");
        assert_eq!(e.position().unwrap().line, 18);
    }

    #[test]
    fn a_missing_file_is_a_read_error() {
        let e = load_spec(Path::new("/no/such/spec.toml"), &machine()).unwrap_err();
        assert!(matches!(e, SpecError::Read { .. }) && e.position().is_none());
        assert!(e.to_string().contains("/no/such/spec.toml"));
    }
}
