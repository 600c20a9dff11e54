//! NC programs for mtcal: read and write G-code, correct every commanded pose for identified
//! machine errors, and source 004's "zero point" (a constant offset chosen over a grid) with the
//! postprocessor that applies it.
//!
//! # The G-code dialect ([`gcode`])
//! The one mtcal writes (`mtcal_instrument::program`) and CAM postprocessors commonly emit,
//! programmed in **machine axis positions** (no tool-centre-point control: `X` is the X axis'
//! position, CNC convention, as in source 002's "coordinates in the machine system"):
//! - A line is a sequence of *words*, a letter (either case, stored upper case) immediately
//!   followed by a number `[+-]digits[.digits]` or `[+-].digits`; blanks between words;
//!   comments `( … )` (not nested, closed on the same line) and `; …` to the end of the line;
//!   `%` and block delete `/` are skipped. Anything else is a [`ParseError`] naming the line,
//!   column (1-based, characters) and what was expected, as is a UTF-8 byte-order mark (many
//!   controllers read it as text). Reading never panics.
//! - Modal words ([`Modal`]): `G0`/`G1` (`G2`/`G3` arcs), `G90`/`G91` absolute/incremental,
//!   `G20`/`G21` inch/mm; defaults `G90 G21`, no motion mode. Axis words `X Y Z` (mm or inch)
//!   and `A B C` (degrees) are modal: an axis not on a line keeps its position. `G53`, `G92`,
//!   `G28`, `G30` lines do not set the modal position. Every other word (`N F S M T G94 I J K`…)
//!   passes through untouched.
//! - Writing keeps every line not changed byte for byte (line terminators `\n`/`\r\n` too, so
//!   read → write reproduces the file, [`Program::text`]); a changed line keeps its order of
//!   words, comments, `N` numbers and other words, with only the changed axis numbers replaced
//!   in place and missing axis words inserted after its last axis word ([`rewrite_line`]).
//!   Changed numbers have a fixed number of decimals, [`Decimals`]: by default 4 for mm
//!   (0.1 µm), 5 for inches, 4 for degrees (1.7 µrad); or as many as the replaced word had.
//!   Never `-0.0000`.
//!
//! # Pose correction ([`correct_program`])
//! Refused before anything is solved: a commanded position beyond its axis' limits by more
//! than [`correct::LIMIT_TOLERANCE`] (mm or degrees), a program whose linear positions all lie
//! within ±1 mm while the machine's strokes span 50 mm or more (metres where mm are expected),
//! and a program without motion.
//! Each motion line's modal pose `q_cmd` (mm → m, degrees → rad) is where the programmer meant
//! the tool to be on the nominal machine: target `p₀, v₀` = nominal tool point and tool axis
//! (`Machine::tool_in_workpiece`). The corrected `q` solves `p(q) = p₀` (three linear axes) and
//! also `v(q) = v₀` when the machine has rotary axes ([`CorrectOptions::match_tool_axis`]) with
//! `p, v` from `MachineModel::tool_pose` (every error inserted): Gauss–Newton from `q_cmd` on
//! `[∂p/∂q; ω × v]` of `MachineModel::tool_jacobian` (3 × 3 or 6 × 5, least squares by SVD),
//! converged when the misfit is below 1e-11 m and 1e-11 rad (usually 2–3 steps). A pose where the
//! system is rank-deficient (a rotary axis parallel to the tool axis, e.g. a trunnion at A = 0
//! with the tool along C: the tilt the errors need cannot be made), the correction exceeds
//! 1 mm / 1 mrad, or Newton does not converge is reported ([`CorrectError::Poses`], all of them,
//! with line numbers) and nothing is written. `match_tool_axis = false` corrects the tool point
//! with the linear axes only, which works at those poses. Only lines with axis words change;
//! `G91` (incremental), arcs, and axis words with `G10/G28/G30/G53/G92` are refused with an
//! error naming the line: convert to absolute linear moves first.
//!
//! # Zero point ([`zero_point`], source 004 §4.1–4.3)
//! With `d_i` the translation errors (µm, workpiece frame) of the volumetric map at the grid
//! points (source 004: 21 × 22 × 22 = 10,164, `Grid::source004`), the zero point is
//! `k* = argmin_k Σ_i ‖d_i − d_k‖` (ties: smallest k), the offset `−d_k*` makes the error at
//! `k*` vanish and leaves `d_i − d_k*` elsewhere. [`zero_point::zero_point`] is the exact search
//! over flat arrays with two exact prunings (see its doc; it equals the O(N²) reference
//! [`zero_point::zero_point_naive`] bit for bit); [`zero_point::geometric_median`] is the
//! continuous optimum (Weiszfeld), whose sum is never larger. [`offset_program`] is the
//! postprocessor: the offset added to every absolute X/Y/Z word (µm / 1000 = mm).
//!
//! # CL data → predicted path error ([`cl`], source 002)
//! CL data as CAM writes it (tool tip in the workpiece frame, mm, and the tool axis per point) in
//! a documented CSV form ([`ClData::parse`]: header `x,y,z[,i,j,k]`, errors located by line and
//! column), turned into axis positions by the nominal closed-form inverse kinematics
//! ([`axis_positions`]: the branch continuous with the previous point; three-axis machines
//! directly, with the tool axis checked to be +Z; limits, unreachable and singular points
//! reported per point), and the error the identified machine makes there
//! ([`predicted_errors`]: tool-tip error in µm and tool-axis tilt in µrad from
//! `MachineModel::pose_error`; [`summarize`]: max, RMS, P90).

pub mod cl;
pub mod correct;
mod files;
pub mod gcode;
pub mod offset;
mod path_error;
pub mod zero_point;

pub use cl::{
    AxisPoint, AxisPositionsError, ClData, ClOptions, ClParseError, ClPoint, ErrorSummary,
    PointError, PointFailure, all_axis_positions, axis_positions, check_units, predicted_errors,
    summarize,
};
pub use correct::{
    CorrectError, CorrectOptions, CorrectedPose, Correction, Failure, correct_program,
};
pub use files::{FileError, correct_file, offset_file, read_cl, read_program};
pub use gcode::{Decimals, Line, Modal, Motion, ParseError, Program, Word, rewrite_line};
pub use offset::{OffsetError, offset_program};
pub use path_error::{PathErrors, along_mm};
pub use zero_point::{
    ErrorVectors, GeometricMedian, ModelZeroPoint, ZeroPoint, geometric_median, model_zero_point,
};
