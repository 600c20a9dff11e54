//! Compensation export: what a controller needs to cancel the errors of an identified machine.
//!
//! Two kinds of tables are made from a [`MachineModel`] and its coefficient vector (as
//! `mtcal_machine::params::load_params` reads it):
//!
//! - **Per-axis pitch tables** ([`pitch_table`]): for one linear axis, the positioning error
//!   along the axis' own direction at nodes over its stroke, every other axis held still.
//!   Written as a LinuxCNC compensation file ([`write_linuxcnc_comp`], `COMP_FILE_TYPE = 1`)
//!   or a plain CSV ([`write_pitch_csv`]); read back by [`read_linuxcnc_comp`] and
//!   [`read_pitch_csv`]; interpolated linearly by [`PitchTable::correction_at_um`].
//! - **3-D error grids** ([`error_grid`]): the tool-point error vector (and, on request, the
//!   orientation error) at every node of a grid over the X/Y/Z strokes, for controllers that
//!   interpolate a grid trilinearly. Written and read as CSV ([`write_grid_csv`],
//!   [`read_grid_csv`]); interpolated by [`ErrorGrid::error_at_um`].
//!
//! # Conventions
//!
//! - **Error** is the model's pose error `[p − p₀; log(R R₀ᵀ)]` (ARCHITECTURE.md, "Conventions"):
//!   the actual tool pose relative to the workpiece minus the nominal one, translations in the
//!   workpiece frame (for the shipped machines with the rotary axes at zero this frame is
//!   parallel to the machine's X, Y, Z), evaluated exactly ([`MachineModel::pose_error`]), set-up
//!   parameters (`TOOL_*`, `WP_*`) included as the coefficient vector gives them.
//! - **Compensation (correction)** is what the controller **adds to the command** so that the
//!   tool lands where it was commanded: `compensation = −error`. Pitch tables and LinuxCNC files
//!   store compensations; the 3-D grid stores **errors** (its columns are named `dx_um` …; a
//!   controller subtracts them, [`ErrorGrid::compensation_at_um`] gives the negated value).
//! - **Along the axis**: a pitch table's error is the pose error projected on the nominal
//!   direction in which a positive command of that axis moves the tool relative to the
//!   workpiece (CNC convention), evaluated at the held positions of the other axes. The
//!   components across the axis (straightness, and the Abbe effects of angular errors across
//!   it) and orientation errors are ignored by a pitch table: use the 3-D grid for them.
//! - **Positions** are the axis (joint) positions of the model, in **mm** in every file (SI m
//!   inside). Errors and compensations are in **µm** in CSV files, in **mm** (machine units) in
//!   LinuxCNC files. Orientation errors are in **µrad**.
//! - **Nodes**: from the lower axis limit in steps of the user's `spacing_mm`, plus the upper
//!   limit when the stroke is not a whole number of steps (the last interval is then shorter).
//!   Files may hold any strictly increasing positions.
//! - **Held axes** ([`default_hold`]): every linear axis at mid-stroke (the ISO 230-2
//!   measuring line through the middle of the working volume), every rotary axis at 0. A
//!   pitch table overwrites its own axis; a grid overwrites X, Y and Z.
//! - **Between nodes** tables are interpolated linearly, grids trilinearly; outside the
//!   nodes the end values are held (clamped), as LinuxCNC does.
//! - **Direction of travel**: the kinematic model is direction-free, so a unidirectional
//!   table is its compensation. A bidirectional table ([`PitchTable::with_reversal_um`])
//!   takes the model's compensation for forward (positive) travel and adds the signed ISO
//!   230-2 reversal value `B = x̄↑ − x̄↓` (µm; mean positional deviation approaching in the
//!   positive direction minus that in the negative direction) for reverse travel:
//!   `reverse = forward + B`. A pure lost motion `b` gives `B = −b`. `B` is the user's
//!   (`Settings::reversal_um`) or an identification's ([`Settings::reversals`]: a `reversal`
//!   discovery of the axis, which may change along the stroke, [`Reversal`]); the card says
//!   which.
//!
//! # Formats
//!
//! ## LinuxCNC axis compensation file (`COMP_FILE_TYPE = 1`)
//! One triplet per line, whitespace-separated: `nominal forward_trim reverse_trim`, all in
//! machine units (mm). `nominal` is the commanded joint position; the trims are LinuxCNC's
//! "correction for forward/reverse movement", which the motion controller adds to the
//! commanded position while the joint travels in the positive/negative direction. The file
//! therefore holds **compensations**, `−error` (LinuxCNC's type 0 holds actual positions
//! instead and converts them as `trim = nominal − actual`, the same sign). LinuxCNC stops
//! reading at the first line that is not a triplet, so the writer puts no header or comment
//! in the file ([`read_linuxcnc_comp`] accepts `#` comments and blank lines). Positions
//! ascend; LinuxCNC holds at most 256 entries per joint (`EMCMOT_COMP_SIZE`), which the
//! writer enforces. In the INI file: `[JOINT_n] COMP_FILE = x.comp`, `COMP_FILE_TYPE = 1`,
//! and no `BACKLASH` (the file replaces it). The numbers assume `LINEAR_UNITS = mm` and that
//! the model's axis position is LinuxCNC's joint position (same zero); otherwise
//! [`PitchTable::shifted_mm`] (`--joint-offset-mm`) moves the nodes into joint coordinates.
//!
//! ## CSV pitch table
//! `#` lines are comments (the writer names the axis, the machine and the held positions).
//! The header is `position_mm,compensation_um` (unidirectional) or
//! `position_mm,forward_um,reverse_um` (bidirectional, both compensations), then one row per
//! node with ascending positions.
//!
//! ## CSV error grid
//! `#` comment lines, then the header `X,Y,Z,dx_um,dy_um,dz_um` or
//! `X,Y,Z,dx_um,dy_um,dz_um,da_urad,db_urad,dc_urad`. `X,Y,Z` are the axis positions in mm;
//! `dx_um …` the **error** of the tool point (not the compensation) in the workpiece frame,
//! `da_urad …` the orientation error (rotation vector) in the workpiece frame. Rows run over
//! the full grid with X slowest and Z fastest; each axis' node positions ascend.
//!
//! Every number is written with 6 decimals in its file unit (1 pm in µm files, 1 nm in mm
//! positions, 1 pm in LinuxCNC trims at 9 decimals), so a reload reproduces the model to
//! far better than 0.1 µm.
//!
//! ## Error-parameter files: ISG CSV (Beckhoff TF5280) and Etalon Exchange
//! For controllers that model the machine themselves (the ISG kernel's volumetric
//! compensation, `file_format ISG_CSV` or `ETALON_EXCHANGE`), [`error_parameters`] gives the
//! identified ISO 230-1 **errors** themselves, [`write_error_parameters`] writes them and
//! [`read_error_parameters`] reads them back; [`ErrorParameters::model`] builds the model a
//! controller builds from them (tables interpolated linearly). Conventions, all explicit:
//! - **Errors, not compensations**: the controller computes and applies `−error` itself (leave
//!   its `negate` parameter empty).
//! - **Names**: component errors as ISO 230-1 (`EXX`, `EYX` … `ECC`); location errors without
//!   the leading `E`, as ISG lists them (`C0Y`, `B0Z`, `A0Z` squareness; `X0C`, `Y0C`, `A0C`,
//!   `B0C` rotary-axis location). ISG's own kinematic parameters (`P0X`, `PXA`, `VXX`…) are
//!   not written: the controller's nominal kinematics are its own.
//! - **Units**: values in **mm** (translations) and **rad** (rotations); table arguments in
//!   **mm** (linear axes) and **degrees** (rotary axes; 0…360 for an axis without limits).
//! - **Signs**: mtcal's, which are ISO 230-1's (ARCHITECTURE.md, "Conventions"). Squareness
//!   `C0Y > 0` rotates Y's motion about +Z, opening the angle between +X and +Y beyond 90°;
//!   likewise `B0Z` (Z's motion about +Y) and `A0Z` (about +X).
//! - **Workpiece/tool split**: component errors are *functional*, the motion of the tool
//!   relative to the workpiece that the axis causes, in machine X/Y/Z, whichever side the axis
//!   is on. The file's header comment lists the workpiece-side and tool-side axes; the
//!   controller's list file must say the same (`workpiece_axes`, `chain`). For a controller
//!   that expects the error motion of the moving part relative to the frame instead, every
//!   error of a workpiece-side axis changes sign (angular errors refer to the joint origin).
//! - **Position-only vs orientation**: the file carries all six component errors of each axis
//!   and every location error; whether the controller corrects the tool orientation too (five
//!   axes) or only the tool point is its own setting. Angular errors are needed either way:
//!   through their Abbe arms they move the tool point.
//! - **Set-up offsets** (`TOOL_*`, `WP_*`) are left out: they belong to the tool and workpiece
//!   set-up (tool length, work offset), not the machine.
//!
//! *ISG CSV*: `//` starts a comment; a block is a header line and data lines, fields
//! separated by blanks; a line `#` ends a block (ISG's "file break"). A component-error block's
//! header is the argument (the axis letter) and the names of that axis' errors, then one row
//! per node: argument, values. The location-error block's header is the names, then one row of
//! values. *Etalon*: `//` comments; each parameter is a block `[NAME]` followed by
//! `VALUE = v` (location errors) or `Gridpoints = {` … `}` with one `argument value` row per
//! node (component errors).
//!
//! ## LinuxCNC table-table pivots (`xyzac-trt-kins`, `xyzbc-trt-kins`)
//! [`trt_pivots`] gives the rotary pivot parameters of LinuxCNC's table-table kinematics for
//! the identified machine (where the actual C and A/B lines pass, in joint coordinates, mm),
//! and [`trt_hal_text`] writes them as HAL `setp` commands with the nominal values and the
//! identified errors these kinematics cannot hold (axis-line tilts, linear-axis errors) in
//! comments. Conventions in the `trt` module's documentation.
//!
//! ## The controls' own formats
//! Each in its module, whose documentation cites the manual pages it follows, says what the
//! control does with the file and lists what mtcal had to assume where no public page says:
//! - `fanuc`: Fanuc pitch error compensation (parameters 3620–3627 and the pitch data as a
//!   parameter record, incremental corrections in detection units × magnification; the rotary
//!   positioning table of `rotary` for rotary axes).
//! - `siemens`: SINUMERIK 840D sl leadscrew/encoder compensation (`%_N_AX_EEC_INI`) and
//!   sag/cross compensation (`%_N_NC_CEC_INI`), errors in mm at equidistant points.
//! - `siemens_carr`: CYCLE800 swivel data (`$TC_CARR`) from the identified rotary-axis lines.
//! - `heidenhain`: nonlinear axis error tables (`.COM` assigned by a `.CMA`) and
//!   KinematicsComp's ISO 230-1 listing.
//!
//! Every file carries a convention card ([`ConventionCard`]: errors or corrections, sign,
//! squareness, rotary direction, axis mapping, units, what the control will do), in its
//! comments (ASCII) or, for formats without comments, in a file beside it. Every format but
//! the HAL settings has a reader, and [`check_compensation`] reads a file back and checks it
//! against its control's limits; the tests apply each control's file the way its documentation
//! says the control does and find the modelled error cancelled at the nodes.
//!
//! # One file as the command line asks for it
//! Each format is registered ([`ControlFormat`], [`Registered`], one module of `formats/`
//! each): its name as typed after `--format`, its line of help, the `--axis` it takes, its own
//! options ([`ControlOptions`]), its writer and its reader and check. A [`Request`] (a format
//! found by name with [`find_format`], and its `--axis`) writes the file with its
//! [`Settings`] and says what it wrote ([`Exported`], [`Written`]), or reads one back and
//! checks it ([`Checked`]); [`control_formats`] lists them all. [`write_compensation`] and
//! [`check_compensation`] do the same for the built-in files named by type ([`Compensation`]).
//! A format registered outside this crate is as good as a built-in one
//! (`tests/stub_format.rs`).
//!
//! # Errors
//! Files are written atomically (`mtcal_machine::write_atomically`). A bad file gives a
//! [`CompensateError::Parse`] naming the file, line and column (1-based) and what was
//! expected; nothing here panics on bad input.

mod check;
mod exported;
mod fanuc;
mod formats;
mod grid;
mod heidenhain;
mod output;
mod parameters;
mod pitch;
mod registry;
mod rotary;
mod settings;
mod siemens;
mod siemens_carr;
mod text;
mod trt;

pub use check::check_compensation;
pub use exported::{Checked, Exported, Written};
pub use fanuc::{
    AXIS_POINTS_SOURCE, FanucAxis, FanucControl, FanucConversion, FanucError, FanucLayout,
    FanucRequest, FanucReverse, FanucSeries, FanucTable, IncrementSystem, fanuc_card, fanuc_export,
    fanuc_from_pitch, fanuc_from_rotary, fanuc_parameter_text, fanuc_pitch_table, fanuc_values_csv,
    read_fanuc_parameters, validate_fanuc, write_fanuc,
};
pub use grid::{ErrorGrid, GridSpec, error_grid, read_grid_csv, write_grid_csv};
pub use heidenhain::{
    COM_RESOLUTION_MM, ComLimits, ComSet, ComTable, HeidenhainLimit, KcEntry, KcKey, KcLimits,
    KcTable, KcValue, KinematicsComp, SpacingRule, card_path, heidenhain_com_card,
    heidenhain_com_set, kinematics_comp, kinematics_comp_card, kinematics_comp_cma, read_com_table,
    read_heidenhain_com, read_kinematics_comp, validate_heidenhain_com, validate_kinematics_comp,
    write_heidenhain_com, write_kinematics_comp,
};
pub use mtcal_machine::card::{
    AxisMap, ConventionCard, Quantity, ROTARY_RIGHT_HAND, SQUARENESS_ISO,
};
pub use output::{Compensation, write_compensation};
pub use parameters::{
    ErrorParameter, ErrorParameters, ParameterFormat, ParameterValue, error_parameters,
    read_error_parameters, write_error_parameters,
};
pub use pitch::{
    AxisReversal, LINUXCNC_MAX_TRIPLETS, PitchFormat, PitchTable, Reversal, Travel, pitch_table,
    read_linuxcnc_comp, read_pitch_csv, travel_direction, write_linuxcnc_comp, write_pitch_csv,
};
pub use registry::{
    ControlFormat, ControlOption, Registered, Request, control_formats, find_format,
};
pub use rotary::{RotaryTable, rotary_table, rotation_direction};
pub use settings::{ControlOptions, Settings};
pub use siemens::{
    CEC_FILE_NAME, CecDirection, CecTable, EEC_FILE_NAME, EecReference, EecTable,
    SIEMENS_DEFAULT_CEC_TABLES, SIEMENS_DEFAULT_MAX_VALUE, SIEMENS_DEFAULT_POINTS, SiemensError,
    SiemensLimits, cec_card, eec_card, eec_from_pitch, equidistant_nodes_mm, read_siemens_cec,
    read_siemens_cec_str, read_siemens_eec, read_siemens_eec_str, siemens_axis_names,
    siemens_cec_table, siemens_cec_tables, siemens_cec_text, siemens_eec_rotary_table,
    siemens_eec_table, siemens_eec_tables, siemens_eec_text, siemens_note, write_siemens_cec,
    write_siemens_eec,
};
pub use siemens_carr::{
    CARR_CHAIN_TOL_MM, CARR_MAX_NAME, CARR_MAX_OFFSET_MM, CarrData, CarrError, CarrKind, carr_card,
    carr_data, carr_text, read_carr, write_carr,
};
pub use trt::{TrtKind, TrtPivots, trt_hal_text, trt_pivots, trt_pivots_with_nominal};

use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use mtcal_machine::Location;
use std::path::PathBuf;

/// mm per m.
const MM: f64 = 1e3;
/// µm (µrad) per m (rad).
const UM: f64 = 1e6;
/// Most nodes one table or grid may have: a guard against a spacing typed in the wrong unit.
pub const MAX_NODES: usize = 10_000_000;

/// Why a table could not be made, written or read.
#[derive(Debug, thiserror::Error)]
pub enum CompensateError {
    #[error("the machine has no axis {letter} (it has {letters})")]
    NoSuchAxis { letter: char, letters: String },
    #[error("axis {letter} is rotary; pitch tables and grids are for linear axes")]
    NotLinear { letter: char },
    #[error("axis {letter} is linear; a rotary positioning table is for rotary axes")]
    NotRotary { letter: char },
    #[error(
        "the node spacing must be finite and positive, got {spacing_mm} (mm, or degrees for rotary axes)"
    )]
    BadSpacing { spacing_mm: f64 },
    #[error("{got} axis positions given; the machine has {expected} axes ({letters})")]
    HoldLength {
        got: usize,
        expected: usize,
        letters: String,
    },
    #[error("the held position of axis {letter} is not finite ({value})")]
    HoldNotFinite { letter: char, value: f64 },
    #[error("{got} coefficients given; the error model has {expected}")]
    CoeffsLength { got: usize, expected: usize },
    #[error("{what}: {nodes} nodes, at most {max} allowed (is the spacing in mm?)")]
    TooManyNodes {
        what: String,
        nodes: usize,
        max: usize,
    },
    #[error("a 3-D error grid needs linear axes X, Y and Z; the machine has {letters}")]
    NotXyz { letters: String },
    /// A file other than a table or grid (the HAL settings) could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// The file's contents are wrong at `at`; `message` says what was expected.
    #[error("{at}: {message}")]
    Parse { at: Location, message: String },
    /// A SINUMERIK table the control would refuse or misread (see [`SiemensError`]).
    #[error(transparent)]
    Siemens(#[from] SiemensError),
    /// A Fanuc pitch error compensation table the control would refuse or misread.
    #[error(transparent)]
    Fanuc(#[from] FanucError),
    /// A file that reads but breaks a limit of its control (`cause` names what, without the
    /// file).
    #[error("{}: {cause}", file.display())]
    Invalid {
        file: PathBuf,
        cause: Box<CompensateError>,
    },
    /// A format mtcal writes but has no reader for.
    #[error("mtcal cannot read {format} files back")]
    NoReader { format: &'static str },
    /// Parameters read from a file do not make a model of the machine.
    #[error("the parameters do not fit the machine: {message}")]
    Model { message: String },
    /// A control's kinematic model cannot describe the machine (`format` names the model).
    #[error("{format} cannot describe this machine: {message}")]
    CannotDescribe {
        format: &'static str,
        message: String,
    },
    /// A CYCLE800 swivel data record the control would refuse or misread.
    #[error(transparent)]
    Carr(#[from] CarrError),
    /// A Heidenhain control would refuse or misread the tables (its limits).
    #[error(transparent)]
    Heidenhain(#[from] HeidenhainLimit),
    /// No control format is registered under `name`; `expected` names those that are.
    #[error("--format `{name}`: expected {expected}")]
    UnknownFormat { name: String, expected: String },
    /// The format does not take the `--axis` use asked for; the message says what to do.
    #[error("{0}")]
    AxisUse(String),
    /// A `--control-option` key the format does not declare.
    #[error("--format {format} takes no control option `{key}` (it takes {takes})")]
    UnknownOption {
        format: &'static str,
        key: String,
        takes: String,
    },
    /// A `--control-option` that does not read (`message` says why).
    #[error("--control-option `{given}`: {message}")]
    BadOption { given: String, message: String },
}

/// The default held positions (SI): linear axes at mid-stroke, rotary axes at 0.
pub fn default_hold(machine: &Machine) -> Vec<f64> {
    machine
        .axes()
        .iter()
        .map(|a| match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some((lo, hi))) => 0.5 * (lo + hi),
            _ => 0.0,
        })
        .collect()
}

/// Checks a coefficient vector and held positions against the model.
fn check_inputs(
    model: &MachineModel,
    coeffs: &[f64],
    hold_q: &[f64],
) -> Result<(), CompensateError> {
    let machine = model.machine();
    if coeffs.len() != model.n_coeffs() {
        return Err(CompensateError::CoeffsLength {
            got: coeffs.len(),
            expected: model.n_coeffs(),
        });
    }
    if hold_q.len() != machine.n_axes() {
        return Err(CompensateError::HoldLength {
            got: hold_q.len(),
            expected: machine.n_axes(),
            letters: machine.letters(),
        });
    }
    for (a, &value) in machine.axes().iter().zip(hold_q) {
        if !value.is_finite() {
            let letter = a.letter().as_char();
            return Err(CompensateError::HoldNotFinite { letter, value });
        }
    }
    Ok(())
}

/// Index and stroke (m) of linear axis `letter`.
/// Linear axis `letter`'s limits, mm (the stroke a [`Reversal`] along the stroke spans).
pub(crate) fn stroke_mm(machine: &Machine, letter: char) -> Result<(f64, f64), CompensateError> {
    let (_, lo, hi) = linear_axis(machine, letter)?;
    Ok((lo * 1e3, hi * 1e3))
}

fn linear_axis(machine: &Machine, letter: char) -> Result<(usize, f64, f64), CompensateError> {
    let i = machine
        .axis_index(letter)
        .ok_or_else(|| CompensateError::NoSuchAxis {
            letter,
            letters: machine.letters(),
        })?;
    match (machine.axes()[i].kind(), machine.axes()[i].limits()) {
        (AxisKind::Linear, Some((lo, hi))) => Ok((i, lo, hi)),
        _ => Err(CompensateError::NotLinear { letter }),
    }
}

/// Node positions (mm) over `[lo_m, hi_m]` with `spacing_mm`: `lo + i·spacing` and the upper
/// end when the stroke is no whole number of steps.
fn nodes_mm(
    lo_m: f64,
    hi_m: f64,
    spacing_mm: f64,
    what: &str,
) -> Result<Vec<f64>, CompensateError> {
    nodes_in(lo_m * MM, hi_m * MM, spacing_mm, what)
}

/// Nodes over `[lo, hi]` `spacing` apart in one unit (mm or degrees), as [`nodes_mm`].
fn nodes_in(lo: f64, hi: f64, spacing_mm: f64, what: &str) -> Result<Vec<f64>, CompensateError> {
    if !(spacing_mm.is_finite() && spacing_mm > 0.0) {
        return Err(CompensateError::BadSpacing { spacing_mm });
    }
    // A node closer than this to the upper end is the upper end (mm or degrees).
    const SNAP_MM: f64 = 1e-6;
    let steps = ((hi - lo + SNAP_MM) / spacing_mm).floor();
    if steps + 2.0 > MAX_NODES as f64 {
        return Err(CompensateError::TooManyNodes {
            what: what.to_string(),
            nodes: steps as usize,
            max: MAX_NODES,
        });
    }
    let mut nodes: Vec<f64> = (0..=steps as usize)
        .map(|i| lo + spacing_mm * i as f64)
        .collect();
    let last = nodes.last_mut().expect("at least one node");
    if hi - *last > SNAP_MM {
        nodes.push(hi);
    } else {
        *last = hi;
    }
    Ok(nodes)
}

/// Index `i` of the interval `[nodes[i], nodes[i+1]]` holding `x` and the weight of
/// `nodes[i+1]`, clamped to the ends. `nodes` ascends and is not empty.
fn bracket(nodes: &[f64], x: f64) -> (usize, f64) {
    let n = nodes.len();
    if n == 1 || x <= nodes[0] {
        return (0, 0.0);
    }
    if x >= nodes[n - 1] {
        return (n - 2, 1.0);
    }
    let i = nodes.partition_point(|&v| v <= x) - 1;
    (i, (x - nodes[i]) / (nodes[i + 1] - nodes[i]))
}

/// Value at `(i, t)` of [`bracket`] from samples `v` (one per node).
fn lerp(v: &[f64], (i, t): (usize, f64)) -> f64 {
    if t == 0.0 {
        v[i]
    } else if t == 1.0 {
        v[i + 1]
    } else {
        v[i] + t * (v[i + 1] - v[i])
    }
}

fn write_file(path: &std::path::Path, text: &str) -> Result<(), CompensateError> {
    mtcal_machine::write_atomically(path, text.as_bytes()).map_err(|source| CompensateError::Io {
        path: path.to_path_buf(),
        cause: source,
    })
}

fn read_file(path: &std::path::Path) -> Result<String, CompensateError> {
    std::fs::read_to_string(path).map_err(|source| CompensateError::Io {
        path: path.to_path_buf(),
        cause: source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_cover_the_stroke_with_a_short_last_interval() {
        let n = nodes_mm(-0.27, 0.27, 100.0, "x").unwrap();
        assert_eq!(n, vec![-270.0, -170.0, -70.0, 30.0, 130.0, 230.0, 270.0]);
        let n = nodes_mm(-0.3, 0.3, 100.0, "x").unwrap();
        assert_eq!(n.len(), 7);
        assert_eq!(*n.last().unwrap(), 300.0);
        assert!(nodes_mm(0.0, 1.0, 0.0, "x").is_err());
        assert!(nodes_mm(0.0, 1.0, f64::NAN, "x").is_err());
        assert!(nodes_mm(0.0, 1.0, 1e-9, "x").is_err());
    }

    #[test]
    fn bracket_clamps_and_interpolates() {
        let nodes = [0.0, 1.0, 3.0];
        assert_eq!(bracket(&nodes, -1.0), (0, 0.0));
        assert_eq!(bracket(&nodes, 5.0), (1, 1.0));
        assert_eq!(bracket(&nodes, 2.0), (1, 0.5));
        assert_eq!(lerp(&[0.0, 2.0, 6.0], bracket(&nodes, 2.0)), 4.0);
        assert_eq!(bracket(&[2.0], 7.0), (0, 0.0));
    }
}
