//! Pose correction of a program: every commanded pose is replaced by the axis positions at
//! which the erroneous machine puts the tool where the nominal machine would have put it.

use crate::gcode::{
    AXIS_LETTERS, Decimals, MM_PER_INCH, Modal, Motion, Program, format_fixed, rewrite_line,
};
use mtcal_kinematics::{AxisKind, MachineModel, Workspace};
use nalgebra::{DMatrix, DVector, Vector3};
use std::fmt;

/// Options of [`correct_program`].
#[derive(Clone, Debug, PartialEq)]
pub struct CorrectOptions {
    /// Decimals of the written axis words.
    pub decimals: Decimals,
    /// Match the tool axis too (machines with rotary axes). `false`: rotary axes stay as
    /// commanded and only the tool point is matched with the linear axes.
    pub match_tool_axis: bool,
    /// Newton iterations per pose before it counts as not converged.
    pub max_iterations: usize,
    /// Converged when the tool point is this close to the target (m)…
    pub tol_position_m: f64,
    /// …and the tool axis this close (rad).
    pub tol_axis_rad: f64,
    /// Singular values of the Newton system below this fraction of the largest count as zero;
    /// with the tool axis matched, a rank-deficient system is reported as singular (near a
    /// rotary axis parallel to the tool axis the tilt it would need cannot be produced).
    pub rank_tol: f64,
    /// Largest correction of any axis (m or rad) before the pose is reported instead of
    /// written: corrections are the size of the errors (µm, µrad), a larger one means a
    /// near-singular pose.
    pub max_correction: f64,
}

impl Default for CorrectOptions {
    fn default() -> Self {
        Self {
            decimals: Decimals::default(),
            match_tool_axis: true,
            max_iterations: 12,
            tol_position_m: 1e-11,
            tol_axis_rad: 1e-11,
            rank_tol: 1e-4,
            max_correction: 1e-3,
        }
    }
}

/// One corrected motion line.
#[derive(Clone, Debug, PartialEq)]
pub struct CorrectedPose {
    /// 1-based line number.
    pub line: usize,
    /// The commanded axis positions (m, rad; canonical order).
    pub q_cmd: Vec<f64>,
    /// The corrected ones, before rounding to the written decimals.
    pub q: Vec<f64>,
    pub iterations: usize,
    /// Remaining tool-point and tool-axis misfit (m, rad) at `q`.
    pub residual_position_m: f64,
    pub residual_axis_rad: f64,
}

/// A pose that could not be corrected.
#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    pub line: usize,
    pub q_cmd: Vec<f64>,
    /// The rank of the Newton system at the last iterate (full: the number of unknowns).
    pub rank: usize,
    pub unknowns: usize,
    pub residual_position_m: f64,
    pub residual_axis_rad: f64,
    /// Largest axis correction when it exceeded [`CorrectOptions::max_correction`], else 0.
    pub correction: f64,
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let why = if self.rank < self.unknowns {
            format!("singular (rank {} of {})", self.rank, self.unknowns)
        } else if self.correction > 0.0 {
            format!(
                "correction {:.3e} (m or rad) too large, near-singular",
                self.correction
            )
        } else {
            "not converged".to_string()
        };
        write!(
            f,
            "line {}: {why}, q = {:?}, misfit {:.3e} µm / {:.3e} µrad",
            self.line,
            self.q_cmd,
            self.residual_position_m * 1e6,
            self.residual_axis_rad * 1e6
        )
    }
}

/// Why a program was not corrected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CorrectError {
    #[error(
        "line {line}: incremental mode (G91) is not corrected; convert the program to G90 \
         (absolute) first"
    )]
    Incremental { line: usize },
    #[error("line {line}: arcs (G2/G3) are not corrected; linearise them into G1 moves")]
    Arc { line: usize },
    #[error("line {line}: axis words without a motion mode; give G0 or G1 first")]
    NoMotionMode { line: usize },
    #[error(
        "line {line}: G{code} with axis words is not corrected (machine coordinates, reference \
         returns, offsets); remove it or correct it by hand"
    )]
    NonModal { line: usize, code: u32 },
    #[error("line {line}: axis word {letter}, but the machine has axes {letters}")]
    UnknownAxis {
        line: usize,
        letter: char,
        letters: String,
    },
    #[error("the machine has axes {letters}; programs address only X Y Z A B C")]
    UnsupportedMachine { letters: String },
    #[error("line {line}: axis {letter} has no position yet; give every axis on the first move")]
    MissingAxis { line: usize, letter: char },
    #[error(
        "line {line}, column {column}: expected {letter} within the axis limits {lo} … {hi} \
         {unit}, found {value} {unit}"
    )]
    BeyondLimit {
        line: usize,
        column: usize,
        letter: char,
        value: f64,
        lo: f64,
        hi: f64,
        unit: &'static str,
    },
    #[error(
        "line {line}, column {column}: every linear position of the program lies within \
         ±{METRES_LIKE_MM} mm (largest {letter} = {value} mm) while the strokes are {strokes}: \
         this looks like metres; expected mm (G21) or inches (G20)"
    )]
    LooksLikeMetres {
        line: usize,
        column: usize,
        letter: char,
        value: f64,
        strokes: String,
    },
    #[error("the program has no motion: expected G0/G1 lines with axis words")]
    NoMotion,
    #[error(
        "{} pose(s) could not be corrected (nothing written):\n{}",
        failures.len(),
        failures.iter().take(20).map(|f| f.to_string()).collect::<Vec<_>>().join("\n")
    )]
    Poses { failures: Vec<Failure> },
}

impl CorrectError {
    /// The program line (1-based) and column the error is about, when it is about one place;
    /// its text then starts with `line L, column C: ` or `line L: `, which a caller that knows
    /// the file replaces by `file:L:C: ` ([`CorrectError::message`]).
    pub fn location(&self) -> Option<(usize, Option<usize>)> {
        match self {
            CorrectError::Incremental { line }
            | CorrectError::Arc { line }
            | CorrectError::NoMotionMode { line }
            | CorrectError::NonModal { line, .. }
            | CorrectError::UnknownAxis { line, .. }
            | CorrectError::MissingAxis { line, .. } => Some((*line, None)),
            CorrectError::BeyondLimit { line, column, .. }
            | CorrectError::LooksLikeMetres { line, column, .. } => Some((*line, Some(*column))),
            CorrectError::UnsupportedMachine { .. }
            | CorrectError::NoMotion
            | CorrectError::Poses { .. } => None,
        }
    }

    /// The text without its leading location (the whole text when it has none).
    pub fn message(&self) -> String {
        let text = self.to_string();
        match self.location() {
            Some(_) => text
                .split_once(": ")
                .map_or(text.clone(), |(_, rest)| rest.to_string()),
            None => text,
        }
    }
}

/// The corrected program and every corrected pose.
#[derive(Clone, Debug, PartialEq)]
pub struct Correction {
    pub text: String,
    pub poses: Vec<CorrectedPose>,
}

/// Corrects every motion line of `program` for the machine errors `coeffs` of `model`.
///
/// A motion line (`G0`/`G1` in effect, at least one axis word) commands `q_cmd`, its modal axis
/// positions (mm → m, degrees → rad). The corrected `q` solves `actual(q) = nominal(q_cmd)` for
/// the tool point and, when rotary axes exist and [`CorrectOptions::match_tool_axis`], the tool
/// axis (Gauss–Newton on [`MachineModel::tool_jacobian`], truncated SVD). The line's axis words
/// get `q`; a missing word is added when its written value differs from the corrected modal
/// value in effect. Every other line is copied byte for byte. All poses are solved before
/// anything is written: failures (singular or not converged) are all reported together.
pub fn correct_program(
    model: &MachineModel,
    coeffs: &[f64],
    program: &Program,
    opts: &CorrectOptions,
) -> Result<Correction, CorrectError> {
    let machine = model.machine();
    let axis_of: Vec<usize> = machine
        .axes()
        .iter()
        .map(|a| AXIS_LETTERS.iter().position(|&l| l == a.letter().as_char()))
        .collect::<Option<_>>()
        .ok_or_else(|| CorrectError::UnsupportedMachine {
            letters: machine.letters(),
        })?;
    let mut solver = Solver::new(model, coeffs, opts);
    let mut modal = Modal::default();
    let (mut poses, mut failures) = (Vec::new(), Vec::new());
    let mut motion_lines = Vec::new();
    let mut metres = MetresCheck::default();
    for (i, line) in program.lines.iter().enumerate() {
        modal = modal.step(line);
        if !line.has_axis_word() {
            continue;
        }
        check_line(line, &modal, i + 1, &axis_of, &machine.letters())?;
        let q_cmd = commanded(&modal, &axis_of, machine, i + 1)?;
        check_limits(line, &q_cmd, machine, i + 1)?;
        metres.add(line, &q_cmd, machine, i + 1);
        match solver.solve(&q_cmd, i + 1) {
            Ok(p) => poses.push(p),
            Err(f) => failures.push(f),
        }
        motion_lines.push((i, modal.inch));
    }
    if motion_lines.is_empty() {
        return Err(CorrectError::NoMotion);
    }
    metres.check(machine)?;
    if !failures.is_empty() {
        return Err(CorrectError::Poses { failures });
    }
    let text = write_corrected(program, &poses, &motion_lines, &axis_of, machine, opts);
    Ok(Correction { text, poses })
}

fn check_line(
    line: &crate::gcode::Line,
    modal: &Modal,
    n: usize,
    axis_of: &[usize],
    letters: &str,
) -> Result<(), CorrectError> {
    for code in [10u32, 28, 30, 53, 92] {
        if line.has_g(code as f64) {
            return Err(CorrectError::NonModal { line: n, code });
        }
    }
    if !modal.absolute {
        return Err(CorrectError::Incremental { line: n });
    }
    match modal.motion {
        None => return Err(CorrectError::NoMotionMode { line: n }),
        Some(Motion::Arc) => return Err(CorrectError::Arc { line: n }),
        _ => {}
    }
    for w in &line.words {
        if let Some(a) = AXIS_LETTERS.iter().position(|&l| l == w.letter)
            && !axis_of.contains(&a)
        {
            return Err(CorrectError::UnknownAxis {
                line: n,
                letter: w.letter,
                letters: letters.to_string(),
            });
        }
    }
    Ok(())
}

/// A program whose linear positions all lie within ±this many mm looks like metres ...
pub const METRES_LIKE_MM: f64 = 1.0;
/// ... when the machine's linear strokes span at least this many mm.
const LONG_STROKE_MM: f64 = 50.0;
/// How far beyond an axis limit a commanded position may be: mm, or degrees on rotary axes.
pub const LIMIT_TOLERANCE: f64 = 0.01;

/// 1-based character column of the word with `letter` on `line` (1 if the line has none).
fn column_of(line: &crate::gcode::Line, letter: char) -> usize {
    line.word(letter)
        .map_or(1, |w| line.text[..w.span.start].chars().count() + 1)
}

/// Every commanded position within the axis limits (with [`LIMIT_TOLERANCE`]).
fn check_limits(
    line: &crate::gcode::Line,
    q: &[f64],
    machine: &mtcal_kinematics::Machine,
    n: usize,
) -> Result<(), CorrectError> {
    for (ax, &v) in machine.axes().iter().zip(q) {
        let Some((lo, hi)) = ax.limits() else {
            continue;
        };
        let (f, unit): (fn(f64) -> f64, _) = match ax.kind() {
            AxisKind::Linear => (|x| x * 1e3, "mm"),
            AxisKind::Rotary => (f64::to_degrees, "degrees"),
        };
        let (v, lo, hi) = (f(v), f(lo), f(hi));
        if v < lo - LIMIT_TOLERANCE || v > hi + LIMIT_TOLERANCE {
            let letter = ax.letter().as_char();
            return Err(CorrectError::BeyondLimit {
                line: n,
                column: column_of(line, letter),
                letter,
                value: (v * 1e6).round() / 1e6,
                lo,
                hi,
                unit,
            });
        }
    }
    Ok(())
}

/// The largest linear position of the program, to tell metres from mm.
#[derive(Default)]
struct MetresCheck {
    /// |value| mm, line, column, letter, value mm.
    largest: Option<(f64, usize, usize, char, f64)>,
}

impl MetresCheck {
    fn add(
        &mut self,
        line: &crate::gcode::Line,
        q: &[f64],
        machine: &mtcal_kinematics::Machine,
        n: usize,
    ) {
        for (ax, &v) in machine.axes().iter().zip(q) {
            let mm = v * 1e3;
            if ax.kind() == AxisKind::Linear && self.largest.is_none_or(|(m, ..)| mm.abs() > m) {
                let letter = ax.letter().as_char();
                let column = column_of(line, letter);
                self.largest = Some((mm.abs(), n, column, letter, mm));
            }
        }
    }

    fn check(&self, machine: &mtcal_kinematics::Machine) -> Result<(), CorrectError> {
        let Some((m, line, column, letter, value)) = self.largest else {
            return Ok(());
        };
        if m == 0.0 || m > METRES_LIKE_MM {
            return Ok(());
        }
        let mut strokes = Vec::new();
        for ax in machine
            .axes()
            .iter()
            .filter(|a| a.kind() == AxisKind::Linear)
        {
            match ax.limits() {
                Some((lo, hi)) if (hi - lo) * 1e3 >= LONG_STROKE_MM => strokes.push(format!(
                    "{} {} … {} mm",
                    ax.letter().as_char(),
                    lo * 1e3,
                    hi * 1e3
                )),
                _ => return Ok(()),
            }
        }
        Err(CorrectError::LooksLikeMetres {
            line,
            column,
            letter,
            value: (value * 1e6).round() / 1e6,
            strokes: strokes.join(", "),
        })
    }
}

/// The modal pose in SI units, canonical machine order.
fn commanded(
    modal: &Modal,
    axis_of: &[usize],
    machine: &mtcal_kinematics::Machine,
    n: usize,
) -> Result<Vec<f64>, CorrectError> {
    axis_of
        .iter()
        .zip(machine.axes())
        .map(|(&a, ax)| {
            let v = modal.axes[a].ok_or(CorrectError::MissingAxis {
                line: n,
                letter: AXIS_LETTERS[a],
            })?;
            Ok(ax.kind().from_file(v))
        })
        .collect()
}

fn write_corrected(
    program: &Program,
    poses: &[CorrectedPose],
    motion_lines: &[(usize, bool)],
    axis_of: &[usize],
    machine: &mtcal_kinematics::Machine,
    opts: &CorrectOptions,
) -> String {
    let mut written: [Option<String>; 6] = Default::default();
    let mut rewritten = vec![None; program.lines.len()];
    for (pose, &(i, inch)) in poses.iter().zip(motion_lines) {
        let line = &program.lines[i];
        let mut values = Vec::new();
        for ((&a, ax), &q) in axis_of.iter().zip(machine.axes()).zip(&pose.q) {
            let v = match ax.kind() {
                AxisKind::Linear if inch => q * 1e3 / MM_PER_INCH,
                AxisKind::Linear => q * 1e3,
                AxisKind::Rotary => q.to_degrees(),
            };
            let word = line.word(AXIS_LETTERS[a]);
            let s = format_fixed(v, opts.decimals.for_axis(a, inch, word));
            if word.is_some() || written[a].as_deref() != Some(s.as_str()) {
                values.push((a, s.clone()));
            }
            written[a] = Some(s);
        }
        rewritten[i] = Some(rewrite_line(line, &values));
    }
    let mut out = String::new();
    for (line, new) in program.lines.iter().zip(rewritten) {
        out.push_str(new.as_deref().unwrap_or(&line.text));
        out.push_str(&line.eol);
    }
    out
}

/// Gauss–Newton on the axis Jacobian, with its buffers.
struct Solver<'a> {
    model: &'a MachineModel,
    coeffs: &'a [f64],
    opts: &'a CorrectOptions,
    ws: Workspace,
    jac: Vec<f64>,
    /// Machine indices of the axes that move (all, or the linear ones).
    free: Vec<usize>,
    /// Rows: 3 (tool point) or 6 (and tool axis).
    rows: usize,
}

impl<'a> Solver<'a> {
    fn new(model: &'a MachineModel, coeffs: &'a [f64], opts: &'a CorrectOptions) -> Self {
        let axes = model.machine().axes();
        let has_rotary = axes.iter().any(|a| a.kind() == AxisKind::Rotary);
        let orient = has_rotary && opts.match_tool_axis;
        let free = (0..axes.len())
            .filter(|&i| orient || axes[i].kind() == AxisKind::Linear)
            .collect();
        Self {
            model,
            coeffs,
            opts,
            ws: model.workspace(),
            jac: vec![0.0; 6 * axes.len()],
            free,
            rows: if orient { 6 } else { 3 },
        }
    }

    fn solve(&mut self, q_cmd: &[f64], line: usize) -> Result<CorrectedPose, Failure> {
        let target = self.model.machine().tool_in_workpiece(q_cmd);
        let (p0, v0) = (target.t, target.r.column(2).into_owned());
        let mut q = q_cmd.to_vec();
        let mut rank = self.free.len();
        for it in 0..=self.opts.max_iterations {
            let pose = self
                .model
                .tool_jacobian(&q, self.coeffs, &mut self.ws, &mut self.jac);
            let v: Vector3<f64> = pose.r.column(2).into_owned();
            let (rp, rv) = (pose.t - p0, v - v0);
            let (ep, ev) = (rp.norm(), if self.rows == 6 { rv.norm() } else { 0.0 });
            let change = q
                .iter()
                .zip(q_cmd)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            if change > self.opts.max_correction {
                let mut f = self.failure(line, q_cmd, rank, ep, ev);
                f.correction = change;
                return Err(f);
            }
            if ep <= self.opts.tol_position_m && ev <= self.opts.tol_axis_rad {
                return Ok(CorrectedPose {
                    line,
                    q_cmd: q_cmd.to_vec(),
                    q,
                    iterations: it,
                    residual_position_m: ep,
                    residual_axis_rad: rv.norm(),
                });
            }
            if it == self.opts.max_iterations {
                return Err(self.failure(line, q_cmd, rank, ep, ev));
            }
            let (a, r) = self.system(&v, &rp, &rv);
            let (dq, rk) = self.step(a, r);
            rank = rk;
            if rank < self.free.len() && self.rows == 6 {
                return Err(self.failure(line, q_cmd, rank, ep, ev));
            }
            for (k, &i) in self.free.iter().enumerate() {
                q[i] -= dq[k];
            }
        }
        unreachable!("the loop returns at its last iteration")
    }

    fn failure(&self, line: usize, q_cmd: &[f64], rank: usize, ep: f64, ev: f64) -> Failure {
        Failure {
            line,
            q_cmd: q_cmd.to_vec(),
            rank,
            unknowns: self.free.len(),
            residual_position_m: ep,
            residual_axis_rad: ev,
            correction: 0.0,
        }
    }

    /// The Newton system: ∂p/∂q and ∂v/∂q = ω × v for the free axes, and the residual.
    fn system(
        &self,
        v: &Vector3<f64>,
        rp: &Vector3<f64>,
        rv: &Vector3<f64>,
    ) -> (DMatrix<f64>, DVector<f64>) {
        let mut a = DMatrix::zeros(self.rows, self.free.len());
        for (k, &i) in self.free.iter().enumerate() {
            let col = &self.jac[6 * i..6 * i + 6];
            let w = Vector3::new(col[3], col[4], col[5]);
            let dv = w.cross(v);
            for r in 0..3 {
                a[(r, k)] = col[r];
                if self.rows == 6 {
                    a[(3 + r, k)] = dv[r];
                }
            }
        }
        let mut r = DVector::zeros(self.rows);
        for c in 0..3 {
            r[c] = rp[c];
            if self.rows == 6 {
                r[3 + c] = rv[c];
            }
        }
        (a, r)
    }

    /// Least-squares step `A⁺ r` by truncated SVD, and the rank.
    fn step(&self, a: DMatrix<f64>, r: DVector<f64>) -> (DVector<f64>, usize) {
        let svd = a.svd(true, true);
        let smax = svd.singular_values.max();
        let eps = self.opts.rank_tol * smax;
        let rank = svd.singular_values.iter().filter(|&&s| s > eps).count();
        let dq = svd
            .solve(&r, eps)
            .unwrap_or_else(|_| DVector::zeros(self.free.len()));
        (dq, rank)
    }
}
