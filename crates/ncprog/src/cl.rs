//! CL data (cutter location: tool tip and tool axis per point, as CAM writes it, source 002) →
//! axis positions through the nominal inverse kinematics → the tool-tip error the identified
//! machine errors predict along the path.
//!
//! # The CSV form ([`ClData::parse`])
//! ```text
//! # comment
//! x,y,z,i,j,k
//! 10.0,-20.5,3.25,0,0,1
//! ```
//! - `x,y,z`: the tool tip in the workpiece frame, mm; `i,j,k`: the tool axis, from the tip into
//!   the spindle (the convention of `mtcal_kinematics`), normalised on reading (a vector shorter
//!   than [`MIN_AXIS_NORM`] is an error). `i,j,k` may be left out of the header for three-axis
//!   machines: the tool axis is then +Z.
//! - The header is the first line that is not blank or a comment: `x,y,z` or `x,y,z,i,j,k`
//!   (case and blanks around names ignored). `#` starts a comment to the end of the line; blank
//!   lines are skipped; `\r\n` and a UTF-8 byte-order mark are accepted.
//! - Fields are separated by `,` and use `.` as the decimal point; every data line has as many
//!   fields as the header. Anything else (wrong field count, a `;` separator or decimal comma, a
//!   number that does not parse or is not finite, a zero tool axis, no data line) is a
//!   [`ClParseError`] naming the line, column (1-based, characters) and what was expected.
//!   Reading never panics.
//!
//! # Axis positions ([`axis_positions`])
//! Machines with rotary axes go through the closed-form inverse kinematics
//! (`mtcal_kinematics::ik::inverse_kinematics`, within the axis limits). Of its solutions the
//! first in its order is taken, with the reference set to the previous point's axis positions
//! (the first point: [`ClOptions::start`], default all axes at 0): the branch with the least
//! rotary travel from the previous point, so the path stays on one continuous branch and an
//! unlimited rotary axis is unwrapped (C goes on past 180° instead of jumping to −180°). When
//! that branch leaves the axis limits, the nearest one within them is taken: the rotary axes
//! jump (on a trunnion A changes sign and C turns by 180°), as the control would have to. At a
//! singular point (the tool axis on a rotary axis' line, e.g. a vertical tool on a trunnion at
//! A = 0) the free axis is held where the previous point had it
//! ([`ClOptions::accept_singular`], default), and the point is marked
//! ([`AxisPoint::singular`]). Three-axis machines (no rotary axis) take the linear axes directly
//! (`mtcal_kinematics::ik::follow_point`) after checking the tool axis is +Z within
//! [`ClOptions::three_axis_tol_rad`]. A point outside the axis limits, unreachable, or (with
//! `accept_singular = false`) singular is a [`PointFailure`]; every point gets its own result.
//!
//! # Predicted errors ([`predicted_errors`], [`summarize`])
//! At each point's `q`, `MachineModel::pose_error` (`[p − p₀; log(R R₀ᵀ)]`, workpiece frame):
//! the tool-tip error `p − p₀` (µm), its magnitude, the rotation vector (µrad) and the tool-axis
//! tilt, the angle between the actual tool axis `exp(ρ)·v₀` and the nominal one `v₀` (µrad; a
//! turn about the tool axis itself does not tilt it). The summary gives the max of `|error|`
//! and where, the RMS, the P90 (nearest rank: the `⌈0.9 n⌉`-th smallest) and the largest tilt.

use mtcal_kinematics::ik::{IkError, IkOptions, LimitViolation, follow_point, inverse_kinematics};
use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use nalgebra::{Rotation3, Vector3};
use std::fmt;

/// Tool-axis vectors shorter than this (as written, before normalising) are rejected as zero.
pub const MIN_AXIS_NORM: f64 = 1e-6;

/// One CL point.
#[derive(Clone, Debug, PartialEq)]
pub struct ClPoint {
    /// 1-based line number in the file.
    pub line: usize,
    /// Tool tip in the workpiece frame, mm (as read).
    pub tip_mm: Vector3<f64>,
    /// Unit tool axis, from the tip into the spindle (+Z when the file has no `i,j,k`).
    pub axis: Vector3<f64>,
}

impl ClPoint {
    /// The tool tip in metres.
    pub fn tip_m(&self) -> Vector3<f64> {
        self.tip_mm * 1e-3
    }
}

/// A CL file: its points in order.
#[derive(Clone, Debug, PartialEq)]
pub struct ClData {
    /// Whether the file gave tool axes (`x,y,z,i,j,k`).
    pub has_axis: bool,
    pub points: Vec<ClPoint>,
}

/// Where and why a CL file could not be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line}, column {column}: expected {expected}, found {found}")]
pub struct ClParseError {
    /// 1-based line number.
    pub line: usize,
    /// 1-based column (characters).
    pub column: usize,
    pub expected: &'static str,
    pub found: String,
}

const HEADER: &str = "the header `x,y,z` or `x,y,z,i,j,k`";

impl ClData {
    /// Reads the CSV form of the module doc.
    pub fn parse(text: &str) -> Result<ClData, ClParseError> {
        let mut header: Option<bool> = None;
        let mut points = Vec::new();
        let mut last = 0;
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        for (i, raw) in text.lines().enumerate() {
            let n = i + 1;
            last = n;
            let body = raw.split('#').next().unwrap_or("");
            if body.trim().is_empty() {
                continue;
            }
            let fields = split_fields(body);
            match header {
                None => header = Some(parse_header(n, &fields)?),
                Some(has_axis) => points.push(parse_point(n, body, &fields, has_axis)?),
            }
        }
        let Some(has_axis) = header else {
            return Err(ClParseError {
                line: last + 1,
                column: 1,
                expected: HEADER,
                found: "the end of the file".into(),
            });
        };
        if points.is_empty() {
            return Err(ClParseError {
                line: last + 1,
                column: 1,
                expected: "at least one data line",
                found: "the end of the file".into(),
            });
        }
        Ok(ClData { has_axis, points })
    }
}

/// The fields of a line: trimmed text and the 1-based character column where it starts (of its
/// first non-blank character, or where the field starts if it is empty).
fn split_fields(body: &str) -> Vec<(&str, usize)> {
    let mut out = Vec::new();
    let mut col = 1;
    for part in body.split(',') {
        let lead = part.chars().take_while(|c| c.is_whitespace()).count();
        let trimmed = part.trim();
        let at = if trimmed.is_empty() { col } else { col + lead };
        out.push((trimmed, at));
        col += part.chars().count() + 1;
    }
    out
}

fn parse_header(n: usize, fields: &[(&str, usize)]) -> Result<bool, ClParseError> {
    let names = ["x", "y", "z", "i", "j", "k"];
    for (k, (name, col)) in fields.iter().enumerate() {
        if k >= names.len() || !name.eq_ignore_ascii_case(names[k]) {
            return Err(ClParseError {
                line: n,
                column: *col,
                expected: HEADER,
                found: format!("`{name}`"),
            });
        }
    }
    match fields.len() {
        3 => Ok(false),
        6 => Ok(true),
        _ => Err(ClParseError {
            line: n,
            column: fields.last().map_or(1, |f| f.1 + f.0.chars().count()),
            expected: HEADER,
            found: format!("{} column names", fields.len()),
        }),
    }
}

fn parse_point(
    n: usize,
    body: &str,
    fields: &[(&str, usize)],
    has_axis: bool,
) -> Result<ClPoint, ClParseError> {
    if let Some(pos) = body.chars().position(|c| c == ';') {
        return Err(ClParseError {
            line: n,
            column: pos + 1,
            expected: "`,` between fields and `.` as the decimal point (no `;`, no decimal comma)",
            found: "`;`".into(),
        });
    }
    let want = if has_axis { 6 } else { 3 };
    if fields.len() != want {
        let (expected, column) = if fields.len() > want {
            (
                if has_axis {
                    "6 fields as in the header (a decimal comma?)"
                } else {
                    "3 fields as in the header (a decimal comma?)"
                },
                fields[want].1,
            )
        } else {
            (
                if has_axis {
                    "6 fields as in the header"
                } else {
                    "3 fields as in the header"
                },
                body.trim_end().chars().count() + 1,
            )
        };
        return Err(ClParseError {
            line: n,
            column,
            expected,
            found: format!("{} fields", fields.len()),
        });
    }
    let mut v = [0.0; 6];
    for (slot, (text, col)) in v.iter_mut().zip(fields) {
        let x: f64 = text.parse().map_err(|_| ClParseError {
            line: n,
            column: *col,
            expected: "a number with `.` as the decimal point",
            found: if text.is_empty() {
                "an empty field".into()
            } else {
                format!("`{text}`")
            },
        })?;
        if !x.is_finite() {
            return Err(ClParseError {
                line: n,
                column: *col,
                expected: "a finite number",
                found: format!("`{text}`"),
            });
        }
        *slot = x;
    }
    let axis = if has_axis {
        let a = Vector3::new(v[3], v[4], v[5]);
        let norm = a.norm();
        if !(norm >= MIN_AXIS_NORM && norm.is_finite()) {
            return Err(ClParseError {
                line: n,
                column: fields[3].1,
                expected: "a nonzero tool-axis vector i,j,k (tip into the spindle)",
                found: format!("({}, {}, {})", v[3], v[4], v[5]),
            });
        }
        a / norm
    } else {
        Vector3::z()
    };
    Ok(ClPoint {
        line: n,
        tip_mm: Vector3::new(v[0], v[1], v[2]),
        axis,
    })
}

/// Options of [`axis_positions`].
#[derive(Clone, Debug, PartialEq)]
pub struct ClOptions {
    /// Tolerances of the inverse kinematics (its `reference` is set per point, see the module
    /// doc, and ignored here).
    pub ik: IkOptions,
    /// Axis positions (SI, canonical order) the first point's branch is chosen nearest to;
    /// `None` (or a length other than the number of axes): all axes at 0.
    pub start: Option<Vec<f64>>,
    /// Hold the free axis at a singular point (previous position) instead of failing.
    pub accept_singular: bool,
    /// Three-axis machines: largest angle (rad) between a point's tool axis and +Z.
    pub three_axis_tol_rad: f64,
}

impl Default for ClOptions {
    fn default() -> Self {
        Self {
            ik: IkOptions::default(),
            start: None,
            accept_singular: true,
            three_axis_tol_rad: 1e-6,
        }
    }
}

/// The axis positions of one CL point.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisPoint {
    /// The CL file's line.
    pub line: usize,
    /// Axis positions, canonical order (`Machine::axes`), m and rad.
    pub q: Vec<f64>,
    /// At a singular point, the free rotary axis (held at the previous point's position).
    pub singular: Option<char>,
}

/// Why a CL point has no axis positions.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PointFailure {
    #[error("line {line}: {cause}")]
    Ik { line: usize, cause: IkError },
    #[error(
        "line {line}: the tool axis is {angle_rad:.3e} rad from +Z, but the machine has no \
         rotary axis (tolerance {tol_rad:.1e} rad)"
    )]
    NotVertical {
        line: usize,
        angle_rad: f64,
        tol_rad: f64,
    },
    #[error("line {line}: {violation}")]
    OutsideLimits {
        line: usize,
        q: Vec<f64>,
        violation: LimitViolation,
    },
}

impl PointFailure {
    /// The CL file's line of the point.
    pub fn line(&self) -> usize {
        match self {
            Self::Ik { line, .. } | Self::NotVertical { line, .. } => *line,
            Self::OutsideLimits { line, .. } => *line,
        }
    }
}

/// Axis positions of every CL point (see the module doc), one result per point in order.
pub fn axis_positions(
    machine: &Machine,
    cl: &ClData,
    opts: &ClOptions,
) -> Vec<Result<AxisPoint, PointFailure>> {
    let n = machine.n_axes();
    let rotary = machine.axes().iter().any(|a| a.kind() == AxisKind::Rotary);
    let mut previous = match &opts.start {
        Some(s) if s.len() == n => s.clone(),
        _ => vec![0.0; n],
    };
    let mut out = Vec::with_capacity(cl.points.len());
    for p in &cl.points {
        let line = p.line;
        let result = if rotary {
            five_axis(machine, p, &previous, opts)
        } else {
            three_axis(machine, p, opts)
        };
        if let Ok(a) = &result {
            previous.clone_from(&a.q);
        }
        out.push(result.map_err(|e| e.at(line)));
    }
    out
}

/// A failure before its line is known.
enum Why {
    Ik(IkError),
    NotVertical(f64, f64),
    Limits(Vec<f64>, LimitViolation),
}

impl Why {
    fn at(self, line: usize) -> PointFailure {
        match self {
            Why::Ik(source) => PointFailure::Ik {
                line,
                cause: source,
            },
            Why::NotVertical(angle_rad, tol_rad) => PointFailure::NotVertical {
                line,
                angle_rad,
                tol_rad,
            },
            Why::Limits(q, violation) => PointFailure::OutsideLimits { line, q, violation },
        }
    }
}

fn five_axis(
    machine: &Machine,
    p: &ClPoint,
    previous: &[f64],
    opts: &ClOptions,
) -> Result<AxisPoint, Why> {
    let ik = IkOptions {
        reference: Some(previous.to_vec()),
        ..opts.ik.clone()
    };
    let (sols, singular) = match inverse_kinematics(machine, &p.tip_m(), &p.axis, &ik) {
        Ok(s) => (s, None),
        Err(IkError::Singular {
            free_axis, held, ..
        }) if opts.accept_singular && !held.is_empty() => (held, Some(free_axis)),
        Err(IkError::Singular {
            free_axis,
            angle_rad,
            held_at,
            held,
        }) if held.is_empty() => {
            // Held in place the free axis leaves every solution outside the limits.
            let mut q = previous.to_vec();
            let _ = follow_point(machine, &mut q, &p.tip_m());
            return Err(match worst_violation(machine, &q, opts.ik.limit_tol) {
                Some(v) => Why::Limits(q, v),
                None => Why::Ik(IkError::Singular {
                    free_axis,
                    angle_rad,
                    held_at,
                    held,
                }),
            });
        }
        Err(IkError::OutsideLimits { nearest, violation }) => {
            return Err(Why::Limits(nearest.q, violation));
        }
        Err(e) => return Err(Why::Ik(e)),
    };
    match sols.into_iter().next() {
        Some(s) => Ok(AxisPoint {
            line: p.line,
            q: s.q,
            singular,
        }),
        None => Err(Why::Ik(IkError::Unreachable {
            tool_axis: [p.axis.x, p.axis.y, p.axis.z],
            why: "no solution".into(),
        })),
    }
}

fn three_axis(machine: &Machine, p: &ClPoint, opts: &ClOptions) -> Result<AxisPoint, Why> {
    let angle = p.axis.cross(&Vector3::z()).norm().atan2(p.axis.z);
    if angle > opts.three_axis_tol_rad {
        return Err(Why::NotVertical(angle, opts.three_axis_tol_rad));
    }
    let mut q = vec![0.0; machine.n_axes()];
    follow_point(machine, &mut q, &p.tip_m()).map_err(Why::Ik)?;
    if let Some(v) = worst_violation(machine, &q, opts.ik.limit_tol) {
        return Err(Why::Limits(q, v));
    }
    Ok(AxisPoint {
        line: p.line,
        q,
        singular: None,
    })
}

/// The largest limit violation of `q` (relative to the axis' range).
fn worst_violation(machine: &Machine, q: &[f64], tol: f64) -> Option<LimitViolation> {
    mtcal_kinematics::ik::worst_violation(machine, q, tol).map(|(_, v)| v)
}

/// Every point's axis positions, or all failures together.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "{} of {total} CL point(s) have no axis positions:\n{}",
    failures.len(),
    failures.iter().take(20).map(|f| f.to_string()).collect::<Vec<_>>().join("\n")
)]
pub struct AxisPositionsError {
    pub total: usize,
    pub failures: Vec<PointFailure>,
}

/// Tool tips in metres where mm are expected: every coordinate of every point within ±1 mm
/// (not all zero) while the machine's linear strokes all span at least 50 mm. The error points
/// at the line of the largest coordinate.
pub fn check_units(machine: &Machine, cl: &ClData) -> Result<(), ClParseError> {
    let mut strokes = Vec::new();
    for ax in machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Linear)
    {
        match ax.limits() {
            Some((lo, hi)) if hi - lo >= 0.05 => strokes.push(format!(
                "{} {} … {} mm",
                ax.letter().as_char(),
                lo * 1e3,
                hi * 1e3
            )),
            _ => return Ok(()),
        }
    }
    let Some(p) = cl
        .points
        .iter()
        .max_by(|a, b| a.tip_mm.amax().total_cmp(&b.tip_mm.amax()))
    else {
        return Ok(());
    };
    let largest = p.tip_mm.amax();
    if largest == 0.0 || largest > 1.0 || strokes.is_empty() {
        return Ok(());
    }
    Err(ClParseError {
        line: p.line,
        column: 1,
        expected: "tool tips in mm",
        found: format!(
            "every coordinate within ±1 mm (largest {largest}) while the machine's strokes are \
             {}: this looks like metres (multiply by 1000)",
            strokes.join(", ")
        ),
    })
}

/// [`axis_positions`] with every point required: the axis points, or every failure.
pub fn all_axis_positions(
    machine: &Machine,
    cl: &ClData,
    opts: &ClOptions,
) -> Result<Vec<AxisPoint>, AxisPositionsError> {
    let results = axis_positions(machine, cl, opts);
    let total = results.len();
    let (ok, failures): (Vec<_>, Vec<_>) = results.into_iter().partition(Result::is_ok);
    if failures.is_empty() {
        Ok(ok.into_iter().filter_map(Result::ok).collect())
    } else {
        Err(AxisPositionsError {
            total,
            failures: failures.into_iter().filter_map(Result::err).collect(),
        })
    }
}

/// The predicted error at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointError {
    /// Tool-tip position error `p − p₀`, µm, workpiece frame.
    pub translation_um: Vector3<f64>,
    /// Its magnitude, µm.
    pub magnitude_um: f64,
    /// Rotation vector `log(R R₀ᵀ)`, µrad, workpiece frame.
    pub rotation_urad: Vector3<f64>,
    /// Angle between the actual and the nominal tool axis, µrad.
    pub tilt_urad: f64,
}

/// The predicted error at every `q` (SI, canonical order): `MachineModel::pose_error`.
///
/// Panics if a `q` or `coeffs` does not fit the model (as `pose_error` does).
pub fn predicted_errors(model: &MachineModel, coeffs: &[f64], qs: &[Vec<f64>]) -> Vec<PointError> {
    let mut ws = model.workspace();
    qs.iter()
        .map(|q| {
            let e = model.pose_error(q, coeffs, &mut ws);
            let v0: Vector3<f64> = model
                .machine()
                .tool_in_workpiece(q)
                .r
                .column(2)
                .into_owned();
            let v = Rotation3::new(e.rotation) * v0;
            let tilt = v0.cross(&v).norm().atan2(v0.dot(&v));
            let t = e.translation * 1e6;
            PointError {
                translation_um: t,
                magnitude_um: t.norm(),
                rotation_urad: e.rotation * 1e6,
                tilt_urad: tilt * 1e6,
            }
        })
        .collect()
}

/// Statistics of [`PointError::magnitude_um`] along a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSummary {
    pub points: usize,
    /// Largest `|error|`, µm, and the index of its (first) point.
    pub max_um: f64,
    pub max_index: usize,
    pub rms_um: f64,
    /// Nearest-rank 90th percentile, µm.
    pub p90_um: f64,
    /// Largest tool-axis tilt, µrad.
    pub max_tilt_urad: f64,
}

impl fmt::Display for ErrorSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "|error| max {:.3} um (point {}), RMS {:.3} um, P90 {:.3} um; tool-axis tilt max {:.3} urad",
            self.max_um,
            self.max_index + 1,
            self.rms_um,
            self.p90_um,
            self.max_tilt_urad
        )
    }
}

/// Summary of a path's errors; `None` without points.
pub fn summarize(errors: &[PointError]) -> Option<ErrorSummary> {
    if errors.is_empty() {
        return None;
    }
    let mut max_index = 0;
    for (k, e) in errors.iter().enumerate() {
        if e.magnitude_um > errors[max_index].magnitude_um {
            max_index = k;
        }
    }
    let n = errors.len();
    let rms = (errors.iter().map(|e| e.magnitude_um.powi(2)).sum::<f64>() / n as f64).sqrt();
    let mut sorted: Vec<f64> = errors.iter().map(|e| e.magnitude_um).collect();
    sorted.sort_by(f64::total_cmp);
    let rank = (9 * n).div_ceil(10);
    Some(ErrorSummary {
        points: n,
        max_um: errors[max_index].magnitude_um,
        max_index,
        rms_um: rms,
        p90_um: sorted[rank.clamp(1, n) - 1],
        max_tilt_urad: errors.iter().map(|e| e.tilt_urad).fold(0.0, f64::max),
    })
}
