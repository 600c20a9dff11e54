//! SINUMERIK 840D sl interpolatory compensation: measuring-system error compensation (MSEC,
//! which includes leadscrew error compensation, LEC; file `%_N_AX_EEC_INI`) and sag / angularity
//! compensation (CEC; file `%_N_NC_CEC_INI`).
//!
//! # Sources
//! SINUMERIK Function Manual *Extended Functions*, chapter K3 "Compensations", section
//! "Interpolatory compensation" (editions 09/2009 6FC5397-1BP20-0BA0 pp. 361–366 and 03/2013
//! 6FC5397-1BP40-3BA1 pp. 237–249, 264; mirrors on manual.onestart.ai and easymanua.ls), the
//! SINUMERIK 808D function manual p. 106–109 (LEC, modulo tables, MD32700 write protection),
//! the 802D sl function manual p. 222 (a complete `%_N_NC_CEC_INI` example) and the 828D
//! function manual 08/2018 p. 299 (CEC input is the base axis' *setpoint*). What follows is
//! what these pages say; where mtcal had to assume, it says so.
//!
//! # What the control does with a table (K3)
//! - A table covers `_MIN` … `_MAX` of the base axis in equidistant steps of `_STEP`: the
//!   interpolation points are `MIN + N·STEP`, `N = 0 … k`, with `MAX` the position of point `k`.
//!   Only MIN, MAX and STEP are stored, so the points **must** be equidistant.
//! - Between points the compensation value is interpolated linearly. Below `_MIN` the value of
//!   point 0, above `_MAX` the value of point `k` stays active ("the first and last compensation
//!   values remain active over the entire traversing range"), except in a modulo table, which
//!   repeats cyclically: the value at MAX is immediately followed by the value at MIN, so the
//!   two must be equal (808D: program 0° and 360° and enter both values).
//! - Every point must be assigned: an unassigned point keeps whatever an earlier table left in
//!   memory. The readers refuse gaps for that reason.
//! - **MSEC sign** (K3 4.4.2.1, 808D p. 106): the control modifies the axis' position actual value
//!   by the compensation value; "a positive compensation value causes the corresponding machine
//!   axis to move in the negative direction". An axis that overshoots by `e` (actual − commanded
//!   = `e > 0`) is brought back by the value `+e`: **the table holds the error**, not the
//!   correction (`value = −compensation` of a [`crate::PitchTable`]). The magnitude is "not
//!   limited and not monitored" by the control; mtcal refuses values beyond
//!   [`SiemensLimits::max_abs_value`] (1 mm by default) as probably µm written as mm.
//! - **CEC**: `$AN_CEC_INPUT_AXIS` is the machine axis "whose setpoint is used as the input",
//!   `$AN_CEC_OUTPUT_AXIS` the axis "to which the output of the table is applied"; all tables of
//!   one output axis are summed (with table multiplication products) into its total compensation
//!   value. *Assumption:* the pages read state the sign only for MSEC; the K3 chapter treats both
//!   as one "interpolatory compensation" with the same error-curve figure, so mtcal assumes a
//!   positive CEC value, like an MSEC value, moves the output axis in its negative direction: CEC
//!   tables hold the output axis' error too. The card says so; check it once at commissioning
//!   (one table with a constant +0.010 should move the output axis by −10 µm).
//! - **Limits**: `0 ≤ N ≤ MD38000 $MA_MM_ENC_COMP_MAX_POINTS − 1` per EEC table and
//!   `0 ≤ N ≤ MD18342 $MN_MM_CEC_MAX_POINTS[t] − 1` per CEC table. The 840D sl values are set by
//!   the machine builder (K3's own example needs MD38000 ≥ 801); the only fixed capacities the
//!   manuals state are 200 points (808D LEC, N = 0…199) and eight CEC tables of 200 points (828D),
//!   which are [`SiemensLimits::default`]. Give the machine's values.
//! - **Activation**: tables load only while the function is off (MD32700 `$MA_ENC_COMP_ENABLE`,
//!   MD32710 `$MA_CEC_ENABLE` = 0; with 1 the table is write-protected, alarm 17070), then the
//!   enable is set and the control powered on; MSEC acts once the axis is referenced. CEC also
//!   needs SD41300 `$SN_CEC_TABLE_ENABLE[t]` = 1 and the licensed option (alarm 8040 otherwise).
//!   Changing MD38000/MD18342 reformats the static user memory at the next power on.
//!
//! # File layout as written
//! The first line is the file's name line (`%_N_AX_EEC_INI`, `%_N_NC_CEC_INI`), then the
//! convention card and notes as `;` comment lines (K3's examples comment with `;`; the text is
//! transliterated to ASCII because the pages read say nothing about non-ASCII characters in NC
//! files), `CHANDATA(1)` as in K3's examples, one assignment per line (`$AA_ENC_COMP[0,N,X1]=…`
//! values first, then STEP, MIN, MAX, IS_MODULO, the order of K3's examples), and `M17` last.
//! Values are written with 6 decimals (1 nm, or 1 µ° on a rotary axis), MIN/MAX/STEP with 9, in
//! plain decimal notation (SINUMERIK writes exponents as `EX`, not `e`). Axes are machine axis
//! names (`X1` as in K3's examples, or `AX1`), CEC axes in parentheses as in the 802D example.
//!
//! # Tables made from the model
//! - EEC ([`siemens_eec_table`]): for one linear axis, the pose error of the tool relative to the
//!   workpiece along the axis' own positive travel direction at equidistant points over its
//!   stroke, every other axis at `hold_q` ([`crate::default_hold`]): the ISO 230-2 positioning
//!   error the pitch table ([`crate::pitch_table`]) negates. The step is the largest one not above
//!   the requested spacing that divides the stroke ([`equidistant_nodes_mm`]). K3 wants "the
//!   compensation value at the reference point" to be zero (so the axis does not jump when
//!   compensation starts): `compensate` writes each table less its value at the reference
//!   point ([`EecTable::relative_to`]; `Settings::reference_mm`, a rotary axis at 0°) and the
//!   card lists the constant removed — a shift of the axis the work offset absorbs.
//! - CEC ([`siemens_cec_table`]): for an input axis `i` and a different output axis `o`, the error
//!   along `o`'s travel direction while `i` moves, the other axes held, **minus its value with
//!   `i` at its held position**. The tables are therefore zero at the held point and add to the
//!   EEC tables made at the same held positions without counting the held error twice: along the
//!   axis lines through the held point, EEC + CEC together cancel the tool point's whole
//!   translation error.
//! - What neither can hold: an error that depends on two axes at once. An angular error moves
//!   the tool point through an Abbe offset that changes with the other axes; the tables hold it
//!   only at the held positions. Squareness of two linear axes is a linear term of their CEC
//!   tables (at the held positions); EEC alone carries no squareness or straightness.

mod cec;
mod eec;
mod ini;

pub use cec::{
    CEC_FILE_NAME, CecDirection, CecTable, cec_card, read_siemens_cec, read_siemens_cec_str,
    siemens_cec_table, siemens_cec_tables, siemens_cec_text, write_siemens_cec,
};
pub use eec::{
    EEC_FILE_NAME, EecReference, EecTable, eec_card, eec_from_pitch, read_siemens_eec,
    read_siemens_eec_str, siemens_eec_rotary_table, siemens_eec_table, siemens_eec_tables,
    siemens_eec_text, write_siemens_eec,
};

use crate::text::Source;
use crate::{AxisMap, CompensateError, MAX_NODES, MM, bracket, lerp};
use ini::Place;
use mtcal_kinematics::Machine;
use std::collections::BTreeMap;

/// The fixed table size the manuals state (808D LEC: N = 0…199; 828D CEC: 200 points per table).
pub const SIEMENS_DEFAULT_POINTS: usize = 200;
/// The CEC tables the 828D provides ("eight tables each with 200 interpolation points").
pub const SIEMENS_DEFAULT_CEC_TABLES: usize = 8;
/// Largest compensation value mtcal writes by default (mm, or degrees on a rotary axis): a
/// geometric error above 1 mm is far more likely µm written as mm than a real error.
pub const SIEMENS_DEFAULT_MAX_VALUE: f64 = 1.0;

/// The control's limits a table must respect; set them to the machine's machine data.
#[derive(Clone, Debug, PartialEq)]
pub struct SiemensLimits {
    /// MD38000 `$MA_MM_ENC_COMP_MAX_POINTS`: most interpolation points of one EEC table.
    pub enc_comp_max_points: usize,
    /// MD18342 `$MN_MM_CEC_MAX_POINTS[t]`: most interpolation points of a CEC table (one value
    /// for every table here).
    pub cec_max_points: usize,
    /// How many CEC tables the control provides (entries of MD18342): table indices
    /// `0 … cec_max_tables − 1`.
    pub cec_max_tables: usize,
    /// Largest |compensation value| accepted, mm (degrees on a rotary axis). Not a control
    /// limit (K3: "not limited and not monitored"): a guard against µm written as mm.
    pub max_abs_value: f64,
}

impl Default for SiemensLimits {
    fn default() -> Self {
        SiemensLimits {
            enc_comp_max_points: SIEMENS_DEFAULT_POINTS,
            cec_max_points: SIEMENS_DEFAULT_POINTS,
            cec_max_tables: SIEMENS_DEFAULT_CEC_TABLES,
            max_abs_value: SIEMENS_DEFAULT_MAX_VALUE,
        }
    }
}

/// Why a Siemens table would be refused or misread by the control.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SiemensError {
    #[error(
        "{table}: {points} interpolation points, {machine_data} allows {max} (set the limit to \
         the machine's value, or use a larger spacing)"
    )]
    TooManyPoints {
        table: String,
        points: usize,
        max: usize,
        machine_data: &'static str,
    },
    #[error("{table}: {points} interpolation point(s); a table needs at least 2")]
    TooFewPoints { table: String, points: usize },
    #[error("{table}: {positions} positions but {values} values")]
    LengthMismatch {
        table: String,
        positions: usize,
        values: usize,
    },
    #[error("{table}: {what} {index} is not a finite number")]
    NotFinite {
        table: String,
        what: &'static str,
        index: usize,
    },
    #[error("{table}: positions must ascend, point {index} at {position} follows {previous}")]
    Unsorted {
        table: String,
        index: usize,
        position: f64,
        previous: f64,
    },
    #[error(
        "{table}: interpolation points must be equidistant (the control stores only MIN, MAX \
         and STEP), point {index} is at {position}, expected {expected}"
    )]
    UnequalSteps {
        table: String,
        index: usize,
        position: f64,
        expected: f64,
    },
    #[error("{table}: STEP must be a positive number, got {step}")]
    BadStep { table: String, step: f64 },
    #[error("{table}: MAX = {max}, but MIN + STEP × (n − 1) = {implied} with n = {points} values")]
    RangeMismatch {
        table: String,
        max: f64,
        implied: f64,
        points: usize,
    },
    #[error(
        "{table}: a modulo table whose end values differ ({first} at MIN, {last} at MAX); the \
         value at MAX is followed by the value at MIN, so they must match"
    )]
    ModuloEnds {
        table: String,
        first: f64,
        last: f64,
        last_index: usize,
    },
    #[error(
        "{table}: value {index} is {value}, beyond ±{max} (mm, or degrees on a rotary axis): \
         probably µm written as mm"
    )]
    ValueTooLarge {
        table: String,
        index: usize,
        value: f64,
        max: f64,
    },
    #[error("{table}: measuring system index {encoder}; it must be 0 (first) or 1 (second)")]
    Encoder { table: String, encoder: usize },
    #[error("`{name}` is not a machine axis name (a letter, then letters, digits or `_`)")]
    BadAxisName { name: String },
    #[error("{table} is given twice")]
    DuplicateTable { table: String },
    #[error("{table}: table index {index}, but the control provides {max} CEC tables (MD18342)")]
    TableIndex {
        table: String,
        index: usize,
        max: usize,
    },
    #[error(
        "{table}: $AN_CEC_MULT_BY_TABLE = {refers} names no table of the file (table number = \
         index + 1; the file has {numbers})"
    )]
    MultByTable {
        table: String,
        refers: usize,
        numbers: String,
    },
    #[error(
        "axis {axis}: a bidirectional pitch table, but Siemens EEC is direction-free (direction-\
         dependent compensation takes two CEC tables with $AN_CEC_DIRECTION = 1 and -1, which \
         mtcal does not write)"
    )]
    Bidirectional { axis: char },
    #[error("axis {letter} has no control name in the axis mapping (it names {have})")]
    NoControlName { letter: char, have: String },
    #[error("a CEC table needs two different axes; axis {axis}'s own error is its EEC table")]
    SameAxis { axis: char },
}

/// Which statement of a table a [`SiemensError`] blames, for the readers' locations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Blame {
    Value(usize),
    Step,
    Max,
    Mult,
    Table,
}

impl SiemensError {
    fn blame(&self) -> Blame {
        use SiemensError::*;
        match self {
            TooManyPoints { max, .. } => Blame::Value(*max),
            NotFinite { index, .. } | ValueTooLarge { index, .. } => Blame::Value(*index),
            ModuloEnds { last_index, .. } => Blame::Value(*last_index),
            Unsorted { .. } | UnequalSteps { .. } | BadStep { .. } => Blame::Step,
            RangeMismatch { .. } => Blame::Max,
            MultByTable { .. } => Blame::Mult,
            _ => Blame::Table,
        }
    }
}

/// Siemens' usual machine axis names for `machine`: the mtcal letter followed by `1` (`X1`,
/// `Y1`, `Z1`, `C1`), as in K3's examples. Check them against the machine's MD10000
/// `$MN_AXCONF_MACHAX_NAME_TAB`.
pub fn siemens_axis_names(machine: &Machine) -> Vec<AxisMap> {
    machine
        .axes()
        .iter()
        .map(|a| AxisMap {
            mtcal: a.letter().as_char(),
            control: format!("{}1", a.letter().as_char()),
        })
        .collect()
}

/// `machine: …` and `held: X = … mm, C = … deg` lines for a file's comments.
pub fn siemens_note(machine: &Machine, hold_q: &[f64]) -> String {
    let held: Vec<String> = machine
        .axes()
        .iter()
        .zip(hold_q)
        .map(|(a, &v)| {
            let letter = a.letter();
            if letter.is_rotary() {
                format!("{} = {:.6} deg", letter.as_char(), v.to_degrees())
            } else {
                format!("{} = {:.6} mm", letter.as_char(), v * MM)
            }
        })
        .collect();
    format!(
        "machine: {}\nheld (every axis but a table's own input axis): {}",
        machine.name(),
        held.join(", ")
    )
}

/// Equidistant node positions (mm) over the stroke `[lo_m, hi_m]` (m): the largest step not
/// above `spacing_mm` that divides the stroke, both ends included.
pub fn equidistant_nodes_mm(
    lo_m: f64,
    hi_m: f64,
    spacing_mm: f64,
    what: &str,
) -> Result<Vec<f64>, CompensateError> {
    if !(spacing_mm.is_finite() && spacing_mm > 0.0) {
        return Err(CompensateError::BadSpacing { spacing_mm });
    }
    let (lo, hi) = (lo_m * MM, hi_m * MM);
    // The tolerance keeps a spacing that divides the stroke (up to rounding) from adding a step.
    let steps = ((hi - lo) / spacing_mm - 1e-9).ceil().max(1.0);
    if steps + 1.0 > MAX_NODES as f64 {
        return Err(CompensateError::TooManyNodes {
            what: what.to_string(),
            nodes: steps as usize,
            max: MAX_NODES,
        });
    }
    let n = steps as usize;
    let step = (hi - lo) / steps;
    Ok((0..=n)
        .map(|i| if i == n { hi } else { lo + step * i as f64 })
        .collect())
}

/// The control name of mtcal axis `letter` in `names`.
fn control_name(names: &[AxisMap], letter: char) -> Result<String, CompensateError> {
    let name = names
        .iter()
        .find(|m| m.mtcal == letter)
        .map(|m| m.control.clone())
        .ok_or_else(|| SiemensError::NoControlName {
            letter,
            have: names
                .iter()
                .map(|m| format!("{} → {}", m.mtcal, m.control))
                .collect::<Vec<_>>()
                .join(", "),
        })?;
    check_axis_name(&name)?;
    Ok(name)
}

/// The mapping rows of `names` whose control name is in `used`.
fn mapping_for<'a>(names: &[AxisMap], used: impl Iterator<Item = &'a str>) -> Vec<AxisMap> {
    let used: Vec<&str> = used.collect();
    names
        .iter()
        .filter(|m| used.contains(&m.control.as_str()))
        .cloned()
        .collect()
}

/// Whether any axis of `names` used by `used` is rotary.
fn any_rotary<'a>(names: &[AxisMap], used: impl Iterator<Item = &'a str>) -> bool {
    mapping_for(names, used)
        .iter()
        .any(|m| mtcal_kinematics::AxisLetter::new(m.mtcal).is_some_and(|l| l.is_rotary()))
}

/// A machine axis name: a letter, then letters, digits or `_`.
fn check_axis_name(name: &str) -> Result<(), SiemensError> {
    let mut chars = name.chars();
    let ok = chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_');
    if ok {
        Ok(())
    } else {
        Err(SiemensError::BadAxisName {
            name: name.to_string(),
        })
    }
}

/// One table's equidistant points and values, as every Siemens interpolatory table has them.
#[derive(Clone, Copy)]
struct Grid<'a> {
    /// The table's name in messages (`$AA_ENC_COMP[0,N,X1]`).
    name: &'a str,
    positions: &'a [f64],
    values: &'a [f64],
    is_modulo: bool,
}

/// Positions closer than this (file units) to where MIN + i·STEP puts them are equidistant.
fn position_tolerance(span: f64) -> f64 {
    1e-6 + 1e-9 * span.abs()
}

/// Modulo end values closer than this (file units) match.
const MODULO_END_TOLERANCE: f64 = 1e-9;

impl Grid<'_> {
    /// Checks what the control needs of every table: at most `max_points` (named by
    /// `machine_data`), ascending, equidistant, finite, values within `max_abs_value`, equal
    /// end values when modulo.
    fn check(
        &self,
        max_points: usize,
        machine_data: &'static str,
        max_abs_value: f64,
    ) -> Result<(), SiemensError> {
        let table = self.name.to_string();
        let (n, values) = (self.positions.len(), self.values);
        if values.len() != n {
            return Err(SiemensError::LengthMismatch {
                table,
                positions: n,
                values: values.len(),
            });
        }
        if n < 2 {
            return Err(SiemensError::TooFewPoints { table, points: n });
        }
        if n > max_points {
            let (points, max) = (n, max_points);
            return Err(SiemensError::TooManyPoints {
                table,
                points,
                max,
                machine_data,
            });
        }
        self.check_positions()?;
        self.check_values(max_abs_value)
    }

    fn check_positions(&self) -> Result<(), SiemensError> {
        let table = || self.name.to_string();
        let p = self.positions;
        if let Some(index) = p.iter().position(|v| !v.is_finite()) {
            let what = "position";
            return Err(SiemensError::NotFinite {
                table: table(),
                what,
                index,
            });
        }
        for (index, w) in p.windows(2).enumerate() {
            if w[1] <= w[0] {
                let (position, previous) = (w[1], w[0]);
                let index = index + 1;
                return Err(SiemensError::Unsorted {
                    table: table(),
                    index,
                    position,
                    previous,
                });
            }
        }
        let (first, last) = (p[0], p[p.len() - 1]);
        let step = (last - first) / (p.len() - 1) as f64;
        let tol = position_tolerance(last - first);
        for (index, &position) in p.iter().enumerate() {
            let expected = first + step * index as f64;
            if (position - expected).abs() > tol {
                return Err(SiemensError::UnequalSteps {
                    table: table(),
                    index,
                    position,
                    expected,
                });
            }
        }
        Ok(())
    }

    fn check_values(&self, max_abs_value: f64) -> Result<(), SiemensError> {
        let table = || self.name.to_string();
        for (index, &value) in self.values.iter().enumerate() {
            if !value.is_finite() {
                let what = "value";
                return Err(SiemensError::NotFinite {
                    table: table(),
                    what,
                    index,
                });
            }
            if value.abs() > max_abs_value {
                let max = max_abs_value;
                return Err(SiemensError::ValueTooLarge {
                    table: table(),
                    index,
                    value,
                    max,
                });
            }
        }
        let (first, last) = (self.values[0], self.values[self.values.len() - 1]);
        if self.is_modulo && (first - last).abs() > MODULO_END_TOLERANCE {
            let last_index = self.values.len() - 1;
            return Err(SiemensError::ModuloEnds {
                table: table(),
                first,
                last,
                last_index,
            });
        }
        Ok(())
    }

    /// The value the control applies at `position`: linear between points, the end values
    /// held outside them, or the table repeated with period MAX − MIN when modulo. The table
    /// is not empty and ascends.
    fn value_at(&self, position: f64) -> f64 {
        let p = self.positions;
        let (first, last) = (p[0], p[p.len() - 1]);
        let x = if self.is_modulo && last > first {
            first + (position - first).rem_euclid(last - first)
        } else {
            position
        };
        lerp(self.values, bracket(p, x))
    }
}

/// MIN, MAX and STEP of ascending `positions` (at least 2).
fn min_max_step(positions: &[f64]) -> (f64, f64, f64) {
    let (min, max) = (positions[0], positions[positions.len() - 1]);
    (min, max, (max - min) / (positions.len() - 1) as f64)
}

/// Positions `MIN + i·STEP` of a table of `n` points read from a file, after checking that
/// STEP is positive and MAX agrees with it.
fn positions_from(
    name: &str,
    min: f64,
    max: f64,
    step: f64,
    n: usize,
) -> Result<Vec<f64>, SiemensError> {
    let table = name.to_string();
    if !(step.is_finite() && step > 0.0) {
        return Err(SiemensError::BadStep { table, step });
    }
    if n < 2 {
        return Err(SiemensError::TooFewPoints { table, points: n });
    }
    let implied = min + step * (n - 1) as f64;
    if (implied - max).abs() > position_tolerance(max - min) {
        let points = n;
        return Err(SiemensError::RangeMismatch {
            table,
            max,
            implied,
            points,
        });
    }
    Ok((0..n)
        .map(|i| {
            if i + 1 == n {
                max
            } else {
                min + step * i as f64
            }
        })
        .collect())
}

/// The values of points 0…k of table `name` from `assigned`, or the located refusal of a gap
/// (an unassigned point keeps whatever an earlier table left in the control's memory).
fn complete_values(
    src: &Source<'_>,
    name: &str,
    assigned: &BTreeMap<usize, (f64, Place)>,
    first: Place,
) -> Result<Vec<f64>, CompensateError> {
    let Some((&last, &(_, last_at))) = assigned.iter().next_back() else {
        let msg = format!("{name}: no compensation values");
        return Err(src.error(first.0, first.1, msg));
    };
    if let Some(missing) = (0..=last).find(|k| !assigned.contains_key(k)) {
        let msg = format!(
            "{name}: point {missing} is not assigned although point {last} is (the control would \
             use whatever an earlier table left there)"
        );
        return Err(src.error(last_at.0, last_at.1, msg));
    }
    Ok(assigned.values().map(|v| v.0).collect())
}
