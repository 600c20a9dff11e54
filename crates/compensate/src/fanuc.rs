//! Fanuc pitch error compensation (Series 0i, 16/18, 30i): the parameters 3620–3627 and the
//! per-point values of one or more axes, as a parameter record the control reads through its
//! reader/puncher interface or memory card, and the same numbers as a CSV table.
//!
//! # What the control does (sources)
//! - *Series 0i-PB parameter manual* B-63980EN/01, pp. 99–100 (parameters 3620–3625, worked
//!   examples); *FANUC Series 16i/18i-MA/TA bidirectional pitch error compensation*, technical
//!   report A-77810E (3605#0, 3626, 3627); cnc.wiki "fanuc-pitch-error-compensation"
//!   (secondary: power-off, reference return, "incremental as viewed from the negative
//!   direction"); the record format from the Series 15i parameter manual B-63330EN/03 p. 25
//!   (`%` … `%`, `N` parameter number, `A` axis, `P` value, one block per line, "when parameters
//!   and pitch error compensation data are collected into a single file, the file begins and
//!   ends with %") and the Series 30i parameter manual B-63950EN/02 §3.3 (`Q1` marks parameter
//!   data). The shared research note (`shared/research/controllers.md`) agrees with these.
//! - The table is a row of **compensation points** numbered from a pool the axes share (1024
//!   points, 0…1023, on 16/18). Point `k` lies at `reference + (k − 3620)·3624`; its value is
//!   the **increment** of the compensation over the interval that *ends* at point `k`, viewed
//!   from the negative direction (B-63980EN's linear example numbers the intervals of a stroke
//!   from −400 mm at 50 mm 33, 34, … with the reference, 0 mm, as point 40: 3621 = 3620 −
//!   (negative stroke / interval) + 1, so point 40 holds the interval −50…0 mm and point 41 the
//!   interval 0…50 mm, and 3622 = 3620 + positive stroke / interval). The compensation at
//!   the reference position is 0; moving away from it the control outputs each interval's
//!   value as the axis passes through that interval ("the compensation value is output at the
//!   compensation position No. corresponding to each section"), so at a point the total is the
//!   sum of the values between the reference and that point, with a minus sign on the negative
//!   side.
//! - Values are in **detection units × magnification** (3623). A rotary axis with a travel per
//!   revolution (3625) has 3621 = 3620 and 3622 = 3620 + 3625/3624; the values of points
//!   3620+1 … 3622 must sum to 0 or the error accumulates turn by turn, and point 3620 carries
//!   the same value as point 3622 (B-63980EN example 2).
//! - Bidirectional (A-77810E): with 3605#0 = 1 a second set of points, from 3626, is used while
//!   the axis moves in the negative direction; 3627 is the total compensation at the reference
//!   position of the set for the direction opposite to the reference return.
//!
//! # What mtcal writes
//! For each axis a [`FanucTable`]: the compensation (`−error`, the pitch table's or rotary
//! table's values) relative to its value at the reference position (which a pitch table
//! cannot hold: it is a shift of the reference position, reported as
//! [`FanucConversion::reference_compensation`] and on the card), **rounded at each node** to
//! detection units × magnification and then differenced, so rounding never accumulates: the
//! total at every point is within half a step of the model. On a full revolution the last
//! node *is* the first one, so the increments sum to exactly 0 by construction.
//!
//! The parameter record, one line per block (LF; the manuals' `;`):
//! ```text
//! %
//! N03620A1P40A2P100          (Series 30i: N03620Q1A1P40A2P100)
//! N03621A1P33A2P100
//! N03622A1P56A2P108
//! N03623A1P1A2P1
//! N03624A1P50000A2P45000     (Series 30i: real, N03624Q1A1P50.000A2P45.000)
//! N03625A2P360000            (rotary axes with a revolution only)
//! N03626A1P200               (bidirectional only)
//! N03627A1P-3                (bidirectional only)
//! N10033P2                   (pitch data: N = 10000 + point; Series 30i: N10033Q0P2)
//! …
//! %
//! ```
//! (IS-B, a linear axis 1 and a rotary axis 2; the parentheses are explanations, not part
//! of the file).
//!
//! Blocks end with LF, the end of block of ISO code (B-63950EN p.12: "LF is used for the ISO
//! code"). A control with NCR (parameter 0100 bit 3) punches LF CR CR instead (B-63524EN
//! p.649); the reader takes both, so a record punched by the control reads back.
//!
//! # Assumptions (no reachable source documents them; each is said on the card)
//! - The pitch-data block `N(10000 + point)P(value)` follows the parameter blocks' pattern;
//!   the 30i's `Q0` marker for pitch data is inferred from its `Q1` for parameter data. The
//!   file carries no comments (no manual read says the control skips them): the convention
//!   card goes into the CSV table instead.
//! - Series 0i-A/B/C and 16/18 take 3624/3625 as integers in the least input increment (taken
//!   to equal the detection unit: metric machine, command multiplier 1) and 3627 in detection
//!   units; Series 30i (and 0i-D/F) take 3624/3625 as real mm or degrees. Per-point range:
//!   ±7 on 16/18 (the range usually given for the older series; no manual page stating it
//!   was reachable), ±32767 assumed on 30i; a pool of 1024 points on both (the research note
//!   gives it for 16/18); at most 128 points per axis from 3621 to 3622 (cnc.wiki, a secondary
//!   source that names no series: [`AXIS_POINTS_SOURCE`]). All are settings ([`FanucControl`]),
//!   and the card states the per-axis limit with its source.
//! - 3605 is not written: it is a bit parameter whose other bits belong to other functions,
//!   and the manuals read disagree on the digit order of bit data on tape. The card tells the
//!   user to set 3605#0.
//! - The negative-direction set mirrors the positive one (3626 + (3620 − 3621) is its reference
//!   point) and is incremental the same way; 3627 is in detection units, so a bidirectional
//!   table needs magnification 1 (the unit of 3627 under 3623 is not documented in what was
//!   read).
//! - Beyond the farthest points the control adds nothing more (the total holds).

use crate::rotary::{TURN_DEG, held_note, rotary_axis, rotary_table_at};
use crate::text::Source;
use crate::{
    AxisMap, CompensateError, ConventionCard, MAX_NODES, MM, PitchTable, Quantity,
    ROTARY_RIGHT_HAND, RotaryTable, Travel, UM, check_inputs, linear_axis, read_file,
    travel_direction, write_file,
};
use mtcal_kinematics::MachineModel;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

/// Two positions closer than this (mm or degrees) are the same.
const POS_TOL: f64 = 1e-7;
/// Largest magnification (3623) the manuals allow.
const MAX_MAGNIFICATION: u32 = 100;
/// Pitch data blocks are numbered 10000 + point number.
const PITCH_BASE: u32 = 10_000;
/// The parameters this module writes and reads.
const PARAMETERS: [u32; 8] = [3620, 3621, 3622, 3623, 3624, 3625, 3626, 3627];

/// The control family: how parameters are written and what their defaults are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FanucSeries {
    /// Series 0i-A/B/C, 16/18, 16i/18i/21i: `N03620A1P40`, 3624 in detection units.
    Series16,
    /// Series 0i-D/F, 30i/31i/32i: `N03620Q1A1P40`, 3624 real (mm or degrees).
    Series30i,
}

impl FanucSeries {
    pub fn name(self) -> &'static str {
        match self {
            FanucSeries::Series16 => "Series 0i-A/B/C, 16/18, 16i/18i/21i",
            FanucSeries::Series30i => "Series 0i-D/F, 30i/31i/32i",
        }
    }

    /// Largest |value| of one point (detection units × magnification): 7 on 16/18, 32767
    /// (assumed, a signed word) on 30i.
    pub fn default_value_limit(self) -> i64 {
        match self {
            FanucSeries::Series16 => 7,
            FanucSeries::Series30i => 32767,
        }
    }

    /// Points in the pool all axes share (numbers 0 to this − 1).
    pub fn default_pool_size(self) -> u32 {
        1024
    }

    /// Most points of one axis between its farthest points (3621 … 3622): 128, the limit a
    /// public summary of the parameters gives ([`AXIS_POINTS_SOURCE`]) without naming a
    /// series; no Fanuc manual read states it, so it is a setting and the card says so.
    pub fn default_axis_points(self) -> u32 {
        128
    }

    fn parameter_marker(self) -> &'static str {
        match self {
            FanucSeries::Series16 => "",
            FanucSeries::Series30i => "Q1",
        }
    }

    fn pitch_marker(self) -> &'static str {
        match self {
            FanucSeries::Series16 => "",
            FanucSeries::Series30i => "Q0",
        }
    }

    /// Whether 3624/3625 are real numbers in mm or degrees (else integers in detection units).
    fn real_intervals(self) -> bool {
        self == FanucSeries::Series30i
    }
}

/// The increment system: the detection unit of linear (mm) and rotary (degree) axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IncrementSystem {
    /// 0.001 mm, 0.001°.
    IsB,
    /// 0.0001 mm, 0.0001°.
    IsC,
}

impl IncrementSystem {
    /// One detection unit in mm (linear axes) or degrees (rotary axes).
    pub fn detection_unit(self) -> f64 {
        match self {
            IncrementSystem::IsB => 1e-3,
            IncrementSystem::IsC => 1e-4,
        }
    }

    /// Decimals of one detection unit.
    pub fn decimals(self) -> usize {
        match self {
            IncrementSystem::IsB => 3,
            IncrementSystem::IsC => 4,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            IncrementSystem::IsB => "IS-B",
            IncrementSystem::IsC => "IS-C",
        }
    }
}

/// Where the per-axis point limit comes from, as the card and the error say it.
pub const AXIS_POINTS_SOURCE: &str = "cnc.wiki \"fanuc-pitch-error-compensation\" (a secondary \
     source: \"maximum of 128 compensation points between extremes\"; no Fanuc manual read \
     states the limit, which may differ by series)";

/// The control: its series, increment system and limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FanucControl {
    pub series: FanucSeries,
    pub increment: IncrementSystem,
    /// Largest |value| of one point, in detection units × magnification.
    pub value_limit: i64,
    /// Points in the shared pool (numbers 0 to `pool_size − 1`).
    pub pool_size: u32,
    /// Most points of one axis from its farthest negative point to its farthest positive one
    /// (3621 … 3622): [`FanucSeries::default_axis_points`].
    pub axis_points: u32,
}

impl FanucControl {
    /// The control with its series' documented (or assumed, see the module doc) limits.
    pub fn new(series: FanucSeries, increment: IncrementSystem) -> Self {
        FanucControl {
            series,
            increment,
            value_limit: series.default_value_limit(),
            pool_size: series.default_pool_size(),
            axis_points: series.default_axis_points(),
        }
    }
}

/// One mtcal axis as the control knows it: what the parameter record does not say.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FanucAxis {
    /// mtcal's axis letter.
    pub letter: char,
    /// The control's axis number (1 = first controlled axis), written after `A`.
    pub number: u32,
    pub rotary: bool,
    /// Where the control's reference position (its machine zero) is, in mtcal's axis
    /// coordinates: mm, or degrees for a rotary axis.
    pub reference_position: f64,
    /// Direction of the reference position return (Fanuc's default: positive).
    pub reference_return: Travel,
}

impl FanucAxis {
    /// Axis `letter` as control axis `number`, its reference position at mtcal's 0, returned
    /// to in the positive direction.
    pub fn new(letter: char, number: u32, rotary: bool) -> Self {
        FanucAxis {
            letter,
            number,
            rotary,
            reference_position: 0.0,
            reference_return: Travel::Forward,
        }
    }

    /// Unit of positions and totals: mm or degrees.
    pub fn unit(&self) -> &'static str {
        if self.rotary { "deg" } else { "mm" }
    }

    /// Unit of one thousandth of [`Self::unit`], for compensations: µm or millidegrees.
    fn milli_unit(&self) -> &'static str {
        if self.rotary { "mdeg" } else { "µm" }
    }
}

/// Where an axis' points go in the pool, and their magnification.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FanucLayout {
    /// Lowest point number of the axis' positive-direction set (3621, or 3620 when the
    /// reference is the first node); `None`: 0 (or, in [`fanuc_export`], after the previous
    /// axis).
    pub first_point: Option<u32>,
    /// Lowest point number of the negative-direction set; `None`: right after the positive set.
    pub reverse_first_point: Option<u32>,
    /// 3623; `None`: the smallest of 1…100 that keeps every value within the control's range.
    pub magnification: Option<u32>,
}

/// The negative-direction set of a bidirectional table (3605#0 = 1).
#[derive(Clone, Debug, PartialEq)]
pub struct FanucReverse {
    /// 3626: number of its farthest negative point.
    pub first_point: u32,
    /// 3627: total (detection units) at the reference position of the set for the direction
    /// opposite to the reference return.
    pub opposite_at_reference_units: i64,
    /// Values of points 3626, 3626 + 1, … (as many as the positive set).
    pub values: Vec<i64>,
}

/// One axis' pitch error compensation as the control holds it.
#[derive(Clone, Debug, PartialEq)]
pub struct FanucTable {
    pub axis: FanucAxis,
    pub increment: IncrementSystem,
    /// 3620.
    pub reference_point: u32,
    /// 3621.
    pub first_point: u32,
    /// 3622.
    pub last_point: u32,
    /// 3623.
    pub magnification: u32,
    /// 3624, in detection units.
    pub interval_units: i64,
    /// 3625, in detection units: travel per revolution of a rotary axis, `None` otherwise.
    pub revolution_units: Option<i64>,
    /// Values of points 3621 … 3622 (detection units × magnification).
    pub values: Vec<i64>,
    pub reverse: Option<FanucReverse>,
}

impl FanucTable {
    /// The interval (3624) in mm or degrees.
    pub fn interval(&self) -> f64 {
        self.interval_units as f64 * self.increment.detection_unit()
    }

    pub fn is_bidirectional(&self) -> bool {
        self.reverse.is_some()
    }

    /// Point numbers of the nodes: 3621 − 1 … 3622 (a point is the end of its interval).
    pub fn node_points(&self) -> std::ops::RangeInclusive<i64> {
        self.first_point as i64 - 1..=self.last_point as i64
    }

    /// Positions of the nodes in mtcal's axis coordinates (mm or degrees).
    pub fn positions(&self) -> Vec<f64> {
        self.node_points()
            .map(|k| {
                let steps = (k - self.reference_point as i64) * self.interval_units;
                self.axis.reference_position + steps as f64 * self.increment.detection_unit()
            })
            .collect()
    }

    /// Total compensation (detection units) at each node while the axis travels `travel`:
    /// the set's values × magnification summed from the reference position, where the total
    /// is 0, or 3627 for the set opposite to the reference return.
    pub fn cumulative_units(&self, travel: Travel) -> Vec<i64> {
        let (values, start) = match (&self.reverse, travel) {
            (Some(r), Travel::Reverse) => (&r.values, self.start_units(Travel::Reverse)),
            _ => (&self.values, self.start_units(Travel::Forward)),
        };
        let r = self.reference_point as i64 + 1 - self.first_point as i64;
        totals(values, r.clamp(0, values.len() as i64) as usize)
            .into_iter()
            .map(|t| t * self.magnification as i64 + start)
            .collect()
    }

    /// [`Self::cumulative_units`] in mm or degrees.
    pub fn compensation(&self, travel: Travel) -> Vec<f64> {
        let du = self.increment.detection_unit();
        self.cumulative_units(travel)
            .into_iter()
            .map(|u| u as f64 * du)
            .collect()
    }

    /// Total at the reference position of the set for `set`: 3627 for the set opposite to the
    /// reference return of a bidirectional table, else 0.
    fn start_units(&self, set: Travel) -> i64 {
        match &self.reverse {
            Some(r) if set != self.axis.reference_return => r.opposite_at_reference_units,
            _ => 0,
        }
    }

    /// Point ranges the table occupies in the pool (the reference point counts), with the
    /// direction of each set.
    fn blocks(&self) -> Vec<(i64, i64, Travel)> {
        let (first, last, reference) = (
            self.first_point as i64,
            self.last_point as i64,
            self.reference_point as i64,
        );
        let mut out = vec![(first.min(reference), last, Travel::Forward)];
        if let Some(r) = &self.reverse {
            let rf = r.first_point as i64;
            let rr = rf + (reference - first);
            out.push((rf.min(rr), rf + (last - first), Travel::Reverse));
        }
        out
    }
}

/// Totals at nodes 0 ..= n of the increments `values` (value `i` is the step from node `i` to
/// node `i + 1`), 0 at node `r`.
fn totals(values: &[i64], r: usize) -> Vec<i64> {
    let mut out = vec![0; values.len() + 1];
    for i in r + 1..out.len() {
        out[i] = out[i - 1] + values[i - 1];
    }
    for i in (0..r).rev() {
        out[i] = out[i + 1] - values[i];
    }
    out
}

/// A table made from mtcal's model, and what it leaves out.
#[derive(Clone, Debug, PartialEq)]
pub struct FanucConversion {
    pub table: FanucTable,
    /// The compensation at the reference position (reference-return direction; mm or
    /// degrees): Fanuc's total is 0 there by definition, so the table holds every other
    /// compensation relative to it. It is a shift of the reference position.
    pub reference_compensation: f64,
    /// Where the numbers came from (machine, held axes), for the values table.
    pub note: String,
    /// Where a bidirectional table's reversal came from, for the card (the user's value, an
    /// identification's discovery).
    pub reversal_source: Option<String>,
}

/// Why the control would refuse or misread a table.
#[derive(Clone, Debug, thiserror::Error)]
pub enum FanucError {
    #[error("axis {axis}: a Fanuc table needs at least two nodes, got {nodes}")]
    TooFewNodes { axis: char, nodes: usize },
    #[error("axis {axis}: positions must ascend: {position} follows {previous}")]
    Unsorted {
        axis: char,
        position: f64,
        previous: f64,
    },
    #[error(
        "axis {axis}: Fanuc needs one constant interval (3624), but node {index} lies {found} \
         {unit} after the one before it and the first interval is {expected} {unit}"
    )]
    IrregularInterval {
        axis: char,
        index: usize,
        found: f64,
        expected: f64,
        unit: &'static str,
    },
    #[error(
        "axis {axis}: the interval {interval} {unit} is not a whole number of detection units \
         ({detection_unit} {unit})"
    )]
    IntervalNotWhole {
        axis: char,
        interval: f64,
        detection_unit: f64,
        unit: &'static str,
    },
    #[error(
        "axis {axis}: the reference position {reference} {unit} is not on a node (nodes every \
         {interval} {unit} from {first} to {last} {unit}); Fanuc counts the points from it"
    )]
    ReferenceOffNode {
        axis: char,
        reference: f64,
        interval: f64,
        first: f64,
        last: f64,
        unit: &'static str,
    },
    #[error(
        "axis {axis}: a revolution of {revolution_units} detection units is no whole number of \
         intervals of {interval_units}"
    )]
    RevolutionNotWhole {
        axis: char,
        interval_units: i64,
        revolution_units: i64,
    },
    #[error(
        "axis {axis}: the rotary table is not periodic: {start_urad} µrad at its first node, \
         {end_urad} µrad one revolution later"
    )]
    NotPeriodic {
        axis: char,
        start_urad: f64,
        end_urad: f64,
    },
    #[error(
        "axis {axis}, point {point}: value {value} is outside the control's range ±{limit} \
         (detection units × magnification {magnification})"
    )]
    ValueOutOfRange {
        axis: char,
        point: i64,
        value: i64,
        limit: i64,
        magnification: u32,
    },
    #[error(
        "axis {axis}: no magnification (3623) up to {max} keeps every value within ±{limit}: \
         the largest increment is {largest} detection units; use a shorter interval"
    )]
    NoMagnification {
        axis: char,
        largest: i64,
        limit: i64,
        max: u32,
    },
    #[error("axis {axis}: the magnification (3623) must be 1 to 100, got {magnification}")]
    BadMagnification { axis: char, magnification: u32 },
    #[error(
        "axis {axis}: a bidirectional table needs magnification 1 (got {magnification}): the \
         unit of 3627 under 3623 is not documented in the manuals read"
    )]
    BidirectionalMagnification { axis: char, magnification: u32 },
    #[error(
        "axis {axis}: the values of points {from} to {to} (one revolution) sum to {sum}, not 0: \
         the error would accumulate turn by turn"
    )]
    RevolutionSumNotZero {
        axis: char,
        from: i64,
        to: i64,
        sum: i64,
    },
    #[error(
        "axis {axis}: on a rotary axis point {reference} (3620) must carry the value of point \
         {last} (3622): got {reference_value} and {last_value}"
    )]
    RotaryEndsDiffer {
        axis: char,
        reference: i64,
        last: i64,
        reference_value: i64,
        last_value: i64,
    },
    #[error(
        "axis {axis}: {points} points from 3621 to 3622, more than the {max} per axis this \
         control is taken to hold ({AXIS_POINTS_SOURCE}); a wider interval (--spacing-mm) \
         gives fewer, or --fanuc-axis-points sets your control's limit"
    )]
    TooManyAxisPoints { axis: char, points: i64, max: u32 },
    #[error("axis {axis}: {points} points, more than the pool of {pool} holds")]
    TooManyPoints { axis: char, points: i64, pool: u32 },
    #[error("axis {axis}: points {from} to {to} run outside the pool (0 to {last})")]
    PoolOverflow {
        axis: char,
        from: i64,
        to: i64,
        last: i64,
    },
    #[error("points {from} to {to} are used twice: by {first} and by {second}")]
    PointsOverlap {
        from: i64,
        to: i64,
        first: String,
        second: String,
    },
    #[error("control axis number {number} is given to axes {first} and {second}")]
    DuplicateAxisNumber {
        number: u32,
        first: char,
        second: char,
    },
    #[error("axis {axis}: {message}")]
    Layout { axis: char, message: String },
}

/// The table of a linear axis from a pitch table whose nodes are `interval` apart with one on
/// the reference position (e.g. from [`fanuc_pitch_table`]).
pub fn fanuc_from_pitch(
    table: &PitchTable,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
) -> Result<FanucConversion, CompensateError> {
    let to_mm = |v: &[f64]| v.iter().map(|c| c / MM).collect::<Vec<f64>>();
    let samples = Samples {
        letter: table.axis,
        rotary: false,
        full_turn: false,
        positions: &table.positions_mm,
        forward: to_mm(&table.forward_um),
        reverse: table.reverse_um.as_deref().map(to_mm),
    };
    let mut c = convert(&samples, control, axis, layout)?;
    c.note = table.note.clone();
    Ok(c)
}

/// The table of a rotary axis. A full-revolution table ([`RotaryTable::full_turn`]) becomes a
/// rotary-axis table with 3625 = 360°; its nodes must divide the revolution and one of them be
/// at the reference position (modulo 360°). A table over limits becomes a table like a linear
/// axis' (no 3625).
pub fn fanuc_from_rotary(
    table: &RotaryTable,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
) -> Result<FanucConversion, CompensateError> {
    let samples = Samples {
        letter: table.axis,
        rotary: true,
        full_turn: table.full_turn,
        positions: &table.positions_deg,
        forward: table
            .compensation_urad
            .iter()
            .map(|c| (c / UM).to_degrees())
            .collect(),
        reverse: None,
    };
    let mut c = convert(&samples, control, axis, layout)?;
    c.note = table.note.clone();
    Ok(c)
}

/// A table's samples: node positions and compensations, both in mm or degrees.
struct Samples<'a> {
    letter: char,
    rotary: bool,
    full_turn: bool,
    positions: &'a [f64],
    forward: Vec<f64>,
    reverse: Option<Vec<f64>>,
}

/// Compensations at the control's nodes relative to the reference, in detection units.
struct Relative {
    forward: Vec<f64>,
    reverse: Option<Vec<f64>>,
    /// Node index of the reference position.
    reference: usize,
    /// The compensation at the reference the table does not hold (mm or degrees).
    base: f64,
    revolution_units: Option<i64>,
}

fn convert(
    s: &Samples<'_>,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
) -> Result<FanucConversion, CompensateError> {
    if s.letter != axis.letter || s.rotary != axis.rotary {
        let message = format!(
            "the table is of {} axis {} but the Fanuc axis is {} axis {}",
            kind(s.rotary),
            s.letter,
            kind(axis.rotary),
            axis.letter
        );
        return Err(FanucError::Layout {
            axis: s.letter,
            message,
        }
        .into());
    }
    let du = control.increment.detection_unit();
    let interval_units = regular_interval(s.letter, s.positions, du, axis.unit())?;
    let rel = if s.full_turn {
        relative_turn(s, axis, du, interval_units)?
    } else {
        relative_stroke(s, axis, du, interval_units)?
    };
    let table = round_table(&rel, control, axis, layout, interval_units)?;
    validate_fanuc(control, std::slice::from_ref(&table))?;
    Ok(FanucConversion {
        table,
        reference_compensation: rel.base,
        note: String::new(),
        reversal_source: None,
    })
}

fn kind(rotary: bool) -> &'static str {
    if rotary { "rotary" } else { "linear" }
}

/// The constant interval of `positions` in detection units.
fn regular_interval(
    axis: char,
    positions: &[f64],
    du: f64,
    unit: &'static str,
) -> Result<i64, FanucError> {
    if positions.len() < 2 {
        let nodes = positions.len();
        return Err(FanucError::TooFewNodes { axis, nodes });
    }
    let expected = positions[1] - positions[0];
    for (i, w) in positions.windows(2).enumerate() {
        let found = w[1] - w[0];
        if found <= 0.0 {
            let (position, previous) = (w[1], w[0]);
            return Err(FanucError::Unsorted {
                axis,
                position,
                previous,
            });
        }
        if (found - expected).abs() > POS_TOL {
            let index = i + 1;
            return Err(FanucError::IrregularInterval {
                axis,
                index,
                found,
                expected,
                unit,
            });
        }
    }
    let units = (expected / du).round();
    if (expected - units * du).abs() > POS_TOL {
        return Err(FanucError::IntervalNotWhole {
            axis,
            interval: expected,
            detection_unit: du,
            unit,
        });
    }
    Ok(units as i64)
}

/// How many intervals `x` is from `origin`, when a whole number.
fn whole_steps(x: f64, origin: f64, interval: f64) -> Option<i64> {
    let k = ((x - origin) / interval).round();
    ((x - (origin + k * interval)).abs() <= POS_TOL * 10.0).then_some(k as i64)
}

fn off_node(s: &Samples<'_>, axis: &FanucAxis, interval: f64) -> FanucError {
    FanucError::ReferenceOffNode {
        axis: s.letter,
        reference: axis.reference_position,
        interval,
        first: s.positions[0],
        last: s.positions[s.positions.len() - 1],
        unit: axis.unit(),
    }
}

/// A table over a stroke: its own nodes, the reference on one of them.
fn relative_stroke(
    s: &Samples<'_>,
    axis: &FanucAxis,
    du: f64,
    interval_units: i64,
) -> Result<Relative, FanucError> {
    let interval = interval_units as f64 * du;
    let r = whole_steps(axis.reference_position, s.positions[0], interval)
        .filter(|&k| k >= 0 && (k as usize) < s.positions.len())
        .ok_or_else(|| off_node(s, axis, interval))? as usize;
    let base = match (&s.reverse, axis.reference_return) {
        (Some(rev), Travel::Reverse) => rev[r],
        _ => s.forward[r],
    };
    let relative = |v: &Vec<f64>| v.iter().map(|c| (c - base) / du).collect();
    Ok(Relative {
        forward: relative(&s.forward),
        reverse: s.reverse.as_ref().map(relative),
        reference: r,
        base,
        revolution_units: None,
    })
}

/// A full revolution: nodes reference − interval, reference, …, reference + 360°, the values
/// taken modulo one revolution so that the last node is the first.
fn relative_turn(
    s: &Samples<'_>,
    axis: &FanucAxis,
    du: f64,
    interval_units: i64,
) -> Result<Relative, FanucError> {
    let revolution_units = (TURN_DEG / du).round() as i64;
    if revolution_units % interval_units != 0 {
        return Err(FanucError::RevolutionNotWhole {
            axis: s.letter,
            interval_units,
            revolution_units,
        });
    }
    let n = (revolution_units / interval_units) as usize;
    if s.positions.len() != n + 1 {
        let message = format!(
            "a full-revolution table needs {} nodes {} ° apart, got {}",
            n + 1,
            interval_units as f64 * du,
            s.positions.len()
        );
        return Err(FanucError::Layout {
            axis: s.letter,
            message,
        });
    }
    let (start, end) = (s.forward[0], s.forward[n]);
    // 0.001 µrad: far below any detection unit, far above the model's rounding.
    if (end - start).abs().to_radians() > 1e-9 {
        return Err(FanucError::NotPeriodic {
            axis: s.letter,
            start_urad: start.to_radians() * UM,
            end_urad: end.to_radians() * UM,
        });
    }
    let interval = interval_units as f64 * du;
    let r0 = whole_steps(axis.reference_position, s.positions[0], interval)
        .ok_or_else(|| off_node(s, axis, interval))?
        .rem_euclid(n as i64) as usize;
    let base = s.forward[r0];
    // Node j is the reference plus (j − 1) intervals: j = 0 is one interval before it.
    let forward = (0..n + 2)
        .map(|j| (s.forward[(r0 + n + j - 1) % n] - base) / du)
        .collect();
    Ok(Relative {
        forward,
        reverse: None,
        reference: 1,
        base,
        revolution_units: Some(revolution_units),
    })
}

/// Totals rounded to multiples of `m` detection units at each node.
fn rounded(rel: &[f64], m: u32) -> Vec<i64> {
    let m = m as f64;
    rel.iter().map(|x| ((x / m).round() * m) as i64).collect()
}

/// Increments (in units of `m` detection units) between successive rounded totals.
fn increments(cum: &[i64], m: u32) -> Vec<i64> {
    cum.windows(2).map(|w| (w[1] - w[0]) / m as i64).collect()
}

/// The magnification: the layout's, or the smallest that fits the control's range.
fn magnification(
    rel: &Relative,
    control: &FanucControl,
    axis: char,
    fixed: Option<u32>,
) -> Result<u32, FanucError> {
    let bidirectional = rel.reverse.is_some();
    let check = |m: u32| {
        if bidirectional && m != 1 {
            return Err(FanucError::BidirectionalMagnification {
                axis,
                magnification: m,
            });
        }
        Ok(m)
    };
    if let Some(m) = fixed {
        if !(1..=MAX_MAGNIFICATION).contains(&m) {
            return Err(FanucError::BadMagnification {
                axis,
                magnification: m,
            });
        }
        return check(m);
    }
    let largest = |m: u32| {
        let sets = std::iter::once(&rel.forward).chain(rel.reverse.as_ref());
        sets.flat_map(|v| increments(&rounded(v, m), m))
            .map(i64::abs)
            .max()
            .unwrap_or(0)
    };
    let max = if bidirectional { 1 } else { MAX_MAGNIFICATION };
    match (1..=max).find(|&m| largest(m) <= control.value_limit) {
        Some(m) => check(m),
        None => Err(FanucError::NoMagnification {
            axis,
            largest: largest(1),
            limit: control.value_limit,
            max,
        }),
    }
}

/// The table: rounded totals differenced, numbered from the layout's first point.
fn round_table(
    rel: &Relative,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
    interval_units: i64,
) -> Result<FanucTable, FanucError> {
    let m = magnification(rel, control, axis.letter, layout.magnification)?;
    let block_start = layout.first_point.unwrap_or(0);
    let r = rel.reference as u32;
    let reference_point = block_start + r.max(1) - 1;
    let first_point = reference_point + 1 - r;
    let forward = rounded(&rel.forward, m);
    let values = increments(&forward, m);
    let last_point = first_point + values.len() as u32 - 1;
    let reverse = rel.reverse.as_ref().map(|rev| {
        let cum = rounded(rev, m);
        let opposite = match axis.reference_return {
            Travel::Forward => cum[rel.reference],
            Travel::Reverse => forward[rel.reference],
        };
        let block = layout.reverse_first_point.unwrap_or(last_point + 1);
        FanucReverse {
            first_point: block + (first_point - block_start),
            opposite_at_reference_units: opposite,
            values: increments(&cum, m),
        }
    });
    Ok(FanucTable {
        axis: *axis,
        increment: control.increment,
        reference_point,
        first_point,
        last_point,
        magnification: m,
        interval_units,
        revolution_units: rel.revolution_units,
        values,
        reverse,
    })
}

/// Checks one table against the control's limits.
fn validate_table(control: &FanucControl, t: &FanucTable) -> Result<(), FanucError> {
    let axis = t.axis.letter;
    let layout = |message: String| FanucError::Layout { axis, message };
    if !(1..=MAX_MAGNIFICATION).contains(&t.magnification) {
        let magnification = t.magnification;
        return Err(FanucError::BadMagnification {
            axis,
            magnification,
        });
    }
    if t.interval_units <= 0 {
        return Err(layout(format!(
            "the interval (3624) must be positive, got {} detection units",
            t.interval_units
        )));
    }
    let (first, last, reference) = (
        t.first_point as i64,
        t.last_point as i64,
        t.reference_point as i64,
    );
    if last - first + 1 > control.axis_points as i64 {
        return Err(FanucError::TooManyAxisPoints {
            axis,
            points: last - first + 1,
            max: control.axis_points,
        });
    }
    if last < first || t.values.len() as i64 != last - first + 1 {
        return Err(layout(format!(
            "3621 = {first} to 3622 = {last} needs {} values, the table has {}",
            (last - first + 1).max(0),
            t.values.len()
        )));
    }
    if reference < first - 1 || reference > last {
        return Err(layout(format!(
            "the reference point 3620 = {reference} must lie on the table: from 3621 − 1 = {} \
             to 3622 = {last}",
            first - 1
        )));
    }
    check_values(control, t, &t.values, first)?;
    if let Some(rev) = t.revolution_units {
        check_turn(t, rev, &t.values, first)?;
    }
    if let Some(r) = &t.reverse {
        check_reverse(control, t, r)?;
    }
    for (from, to, _) in t.blocks() {
        check_pool(control, axis, from, to)?;
    }
    Ok(())
}

fn check_reverse(
    control: &FanucControl,
    t: &FanucTable,
    r: &FanucReverse,
) -> Result<(), FanucError> {
    let axis = t.axis.letter;
    if t.magnification != 1 {
        let magnification = t.magnification;
        return Err(FanucError::BidirectionalMagnification {
            axis,
            magnification,
        });
    }
    if r.values.len() != t.values.len() {
        let message = format!(
            "the negative-direction set has {} values, the positive one {}",
            r.values.len(),
            t.values.len()
        );
        return Err(FanucError::Layout { axis, message });
    }
    let first = r.first_point as i64;
    check_values(control, t, &r.values, first)?;
    if let Some(rev) = t.revolution_units {
        check_turn(t, rev, &r.values, first)?;
    }
    Ok(())
}

/// Every value within the control's range; `first` numbers `values[0]`.
fn check_values(
    control: &FanucControl,
    t: &FanucTable,
    values: &[i64],
    first: i64,
) -> Result<(), FanucError> {
    match values
        .iter()
        .enumerate()
        .find(|(_, v)| v.abs() > control.value_limit)
    {
        Some((i, &value)) => Err(FanucError::ValueOutOfRange {
            axis: t.axis.letter,
            point: first + i as i64,
            value,
            limit: control.value_limit,
            magnification: t.magnification,
        }),
        None => Ok(()),
    }
}

/// The rules of a rotary axis with a revolution (B-63980EN example 2) for one set of values
/// numbered from `first` (its reference point).
fn check_turn(
    t: &FanucTable,
    revolution: i64,
    values: &[i64],
    first: i64,
) -> Result<(), FanucError> {
    let axis = t.axis.letter;
    if revolution % t.interval_units != 0 {
        return Err(FanucError::RevolutionNotWhole {
            axis,
            interval_units: t.interval_units,
            revolution_units: revolution,
        });
    }
    let n = revolution / t.interval_units;
    if t.first_point != t.reference_point || values.len() as i64 != n + 1 {
        let message = format!(
            "on a rotary axis 3621 must equal 3620 and 3622 be 3620 + 3625/3624 = 3620 + {n}; \
             got 3620 = {}, 3621 = {}, 3622 = {}",
            t.reference_point, t.first_point, t.last_point
        );
        return Err(FanucError::Layout { axis, message });
    }
    let last = values.len() - 1;
    if values[0] != values[last] {
        return Err(FanucError::RotaryEndsDiffer {
            axis,
            reference: first,
            last: first + last as i64,
            reference_value: values[0],
            last_value: values[last],
        });
    }
    let sum: i64 = values[1..].iter().sum();
    if sum != 0 {
        return Err(FanucError::RevolutionSumNotZero {
            axis,
            from: first + 1,
            to: first + last as i64,
            sum,
        });
    }
    Ok(())
}

fn check_pool(control: &FanucControl, axis: char, from: i64, to: i64) -> Result<(), FanucError> {
    let pool = control.pool_size;
    if to - from + 1 > pool as i64 {
        let points = to - from + 1;
        return Err(FanucError::TooManyPoints { axis, points, pool });
    }
    if from < 0 || to >= pool as i64 {
        let last = pool as i64 - 1;
        return Err(FanucError::PoolOverflow {
            axis,
            from,
            to,
            last,
        });
    }
    Ok(())
}

/// Checks tables against the control: each table's limits, one control axis number per axis,
/// and no point used by two sets.
pub fn validate_fanuc(
    control: &FanucControl,
    tables: &[FanucTable],
) -> Result<(), CompensateError> {
    let mut numbers: BTreeMap<u32, char> = BTreeMap::new();
    let mut blocks = Vec::new();
    for t in tables {
        validate_table(control, t)?;
        if let Some(&first) = numbers.get(&t.axis.number) {
            return Err(FanucError::DuplicateAxisNumber {
                number: t.axis.number,
                first,
                second: t.axis.letter,
            }
            .into());
        }
        numbers.insert(t.axis.number, t.axis.letter);
        for (from, to, travel) in t.blocks() {
            let set = match travel {
                Travel::Forward => "positive-direction",
                Travel::Reverse => "negative-direction",
            };
            blocks.push((from, to, format!("axis {} ({set} set)", t.axis.letter)));
        }
    }
    blocks.sort_by_key(|b| b.0);
    for w in blocks.windows(2) {
        if w[1].0 <= w[0].1 {
            return Err(FanucError::PointsOverlap {
                from: w[1].0,
                to: w[0].1.min(w[1].1),
                first: w[0].2.clone(),
                second: w[1].2.clone(),
            }
            .into());
        }
    }
    Ok(())
}

/// `units` detection units as a decimal number with `decimals` places, exactly.
fn decimal(units: i64, decimals: usize) -> String {
    let scale = 10i64.pow(decimals as u32);
    let sign = if units < 0 { "-" } else { "" };
    let a = units.unsigned_abs();
    format!("{sign}{}.{:0decimals$}", a / scale as u64, a % scale as u64)
}

/// The parameters' values of table `t` as written: 3620 … 3627, `None` where not written.
fn parameter_texts(control: &FanucControl, t: &FanucTable) -> [(u32, Option<String>); 8] {
    let length = |units: i64| {
        if control.series.real_intervals() {
            decimal(units, control.increment.decimals())
        } else {
            units.to_string()
        }
    };
    let rev = t.reverse.as_ref();
    [
        (3620, Some(t.reference_point.to_string())),
        (3621, Some(t.first_point.to_string())),
        (3622, Some(t.last_point.to_string())),
        (3623, Some(t.magnification.to_string())),
        (3624, Some(length(t.interval_units))),
        (3625, t.revolution_units.map(length)),
        (3626, rev.map(|r| r.first_point.to_string())),
        (3627, rev.map(|r| r.opposite_at_reference_units.to_string())),
    ]
}

/// The parameter record of `tables` (see the module doc), after [`validate_fanuc`].
pub fn fanuc_parameter_text(
    control: &FanucControl,
    tables: &[FanucTable],
) -> Result<String, CompensateError> {
    validate_fanuc(control, tables)?;
    let q = control.series.parameter_marker();
    let per_table: Vec<_> = tables
        .iter()
        .map(|t| (t.axis.number, parameter_texts(control, t)))
        .collect();
    let mut text = String::from("%\n");
    for (k, number) in PARAMETERS.iter().enumerate() {
        let words: String = per_table
            .iter()
            .filter_map(|(axis, p)| p[k].1.as_ref().map(|v| format!("A{axis}P{v}")))
            .collect();
        if !words.is_empty() {
            let _ = writeln!(text, "N{number:05}{q}{words}");
        }
    }
    let mut points: Vec<(u32, i64)> = Vec::new();
    for t in tables {
        let sets = std::iter::once((t.first_point, &t.values))
            .chain(t.reverse.iter().map(|r| (r.first_point, &r.values)));
        for (first, values) in sets {
            points.extend(
                values
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (first + i as u32, v)),
            );
        }
    }
    points.sort_unstable();
    let q0 = control.series.pitch_marker();
    for (point, value) in points {
        let _ = writeln!(text, "N{}{q0}P{value}", PITCH_BASE + point);
    }
    text.push_str("%\n");
    Ok(text)
}

/// The values table: the card as `#` comments, then one row per node and set.
pub fn fanuc_values_csv(
    control: &FanucControl,
    conversions: &[FanucConversion],
    card: &ConventionCard,
) -> String {
    let mut text = String::from(
        "# mtcal Fanuc pitch error compensation values: the numbers of the parameter file\n",
    );
    text.push_str(&card.file_lines("# "));
    for c in conversions {
        let t = &c.table;
        let _ = writeln!(
            text,
            "# {} = axis {}: reference position {} {} = point {}; interval {} {}; \
             magnification {}; detection unit {} {} ({})",
            t.axis.letter,
            t.axis.number,
            t.axis.reference_position,
            t.axis.unit(),
            t.reference_point,
            t.interval(),
            t.axis.unit(),
            t.magnification,
            control.increment.detection_unit(),
            t.axis.unit(),
            control.increment.name()
        );
        for l in c.note.lines() {
            let _ = writeln!(text, "#   {l}");
        }
    }
    text.push_str(
        "# position: mm or deg, mtcal's axis coordinates; increment: the point's value \
         (detection units x magnification); cumulative: total at the position in detection \
         units; compensation: the same in um (linear) or millidegrees (rotary); the first row \
         of each set is the node where its first interval starts\n",
    );
    text.push_str("axis,direction,point,position,increment,cumulative,compensation\n");
    for c in conversions {
        value_rows(&mut text, &c.table);
    }
    text
}

/// The rows of one table: the node where its first interval starts (no increment, and no
/// point number unless it is the reference point), then every point.
fn value_rows(text: &mut String, t: &FanucTable) {
    let du = t.increment.detection_unit();
    let positions = t.positions();
    let mut sets = vec![(Travel::Forward, "+", t.first_point, &t.values)];
    if let Some(r) = &t.reverse {
        sets.push((Travel::Reverse, "-", r.first_point, &r.values));
    }
    let reference_offset = t.reference_point as i64 - t.first_point as i64;
    for (travel, sign, first, values) in sets {
        let totals = t.cumulative_units(travel);
        for (i, (p, total)) in positions.iter().zip(&totals).enumerate() {
            let k = first as i64 - 1 + i as i64;
            let (point, increment) = match i {
                0 if k == first as i64 + reference_offset => (k.to_string(), String::new()),
                0 => (String::new(), String::new()),
                _ => (k.to_string(), values[i - 1].to_string()),
            };
            let _ = writeln!(
                text,
                "{},{sign},{point},{p:.6},{increment},{total},{:.4}",
                t.axis.letter,
                *total as f64 * du * 1e3
            );
        }
    }
}

/// The convention card of a Fanuc export.
pub fn fanuc_card(control: &FanucControl, conversions: &[FanucConversion]) -> ConventionCard {
    let axis_mapping = conversions
        .iter()
        .map(|c| AxisMap {
            mtcal: c.table.axis.letter,
            control: format!(
                "axis {} (A{} in the file)",
                c.table.axis.number, c.table.axis.number
            ),
        })
        .collect();
    let references: Vec<String> = conversions
        .iter()
        .map(|c| {
            let a = &c.table.axis;
            format!("{} = {} {}", a.letter, a.reference_position, a.unit())
        })
        .collect();
    let du = control.increment.detection_unit();
    ConventionCard {
        made_from: Vec::new(),
        format: format!(
            "Fanuc pitch error compensation, {} parameter record (3620–3627 and pitch data \
             N10000 + point)",
            control.series.name()
        ),
        quantity: Quantity::Correction,
        sign: "a positive total moves the axis towards its positive direction: the control adds \
               it to the position it commands; each point's value is the increment of the \
               total over the interval ending at that point, viewed from the negative direction"
            .into(),
        squareness: "not held (a pitch table holds positioning along the axis only)".into(),
        rotary_direction: format!(
            "{ROTARY_RIGHT_HAND}; the control's positive direction is taken to be mtcal's"
        ),
        axis_mapping,
        units: format!(
            "values in detection units ({}: {du} mm or {du}°) × magnification 3623; 3624 and \
             3625 in {}; positions relative to the reference position (the control's machine \
             zero) at {} in mtcal's axis coordinates",
            control.increment.name(),
            if control.series.real_intervals() {
                "mm or degrees"
            } else {
                "detection units"
            },
            references.join(", ")
        ),
        control_will: control_will(control, conversions),
    }
}

/// The card's sentences on what the control does with the file.
fn control_will(control: &FanucControl, conversions: &[FanucConversion]) -> Vec<String> {
    let mut will = vec![
        "need power off and on after 3620–3627 change, and a reference position return after \
         the values change: the table is counted from the reference position"
            .to_string(),
        "output each point's value while the axis passes through that point's interval \
         (B-63980EN: \"the compensation value is output at the compensation position No. \
         corresponding to each section\"): the total is exact at the points (within half a \
         detection unit × magnification of the model); between two points it is not \
         interpolated to the model, so the interval bounds what is corrected between them"
            .to_string(),
        "add nothing beyond the farthest points (3621 − 1 and 3622): the strips of stroke \
         shorter than one interval beyond them keep the end total"
            .to_string(),
        format!(
            "hold at most {} points per axis from 3621 to 3622 — the limit checked here, from \
             {AXIS_POINTS_SOURCE}; --fanuc-axis-points sets your control's",
            control.axis_points
        ),
        "read pitch data blocks as N(10000 + point)P(value) and, on Series 30i, parameter \
         blocks marked Q1 (B-63950EN) and pitch data marked Q0 (assumed by analogy: check \
         against a record punched by your control before loading)"
            .to_string(),
    ];
    for c in conversions {
        let a = &c.table.axis;
        will.push(format!(
            "not hold axis {}'s compensation at its reference position, {:.3} {}: Fanuc's \
             total is 0 there, so it is a reference position shift (grid shift or work offset), \
             not part of the table",
            a.letter,
            c.reference_compensation * 1e3,
            a.milli_unit()
        ));
        if c.table.revolution_units.is_some() {
            will.push(format!(
                "repeat axis {}'s table every revolution (3625 = 360°): its values sum to 0 \
                 over a turn and point 3620 carries point 3622's value (B-63980EN)",
                a.letter
            ));
        }
        if c.table.is_bidirectional() {
            will.push(format!(
                "use axis {}'s points from 3626 while it moves in the negative direction once \
                 3605#0 = 1 (A-77810E); set 3605#0 by hand: the file does not write 3605, whose \
                 other bits belong to other functions; negative = positive + B (ISO 230-2 \
                 reversal value B = x̄↑ − x̄↓){}",
                a.letter,
                c.reversal_source
                    .as_ref()
                    .map(|s| format!(", from {s}"))
                    .unwrap_or_default()
            ));
        }
    }
    will
}

/// One axis of a Fanuc export.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FanucRequest {
    pub axis: FanucAxis,
    /// Node interval, mm or degrees (a whole number of detection units; dividing 360° on an
    /// axis without limits).
    pub interval: f64,
    pub layout: FanucLayout,
    /// Linear axes: the reversal ([`crate::Reversal`]: the signed ISO 230-2 reversal value B,
    /// µm, which may change along the stroke) for a bidirectional table.
    pub reversal: Option<crate::Reversal>,
}

/// The tables of `requests` from the model, their points laid out one axis after the other
/// where a layout leaves `first_point` open; checked together ([`validate_fanuc`]).
pub fn fanuc_export(
    model: &MachineModel,
    coeffs: &[f64],
    requests: &[FanucRequest],
    control: &FanucControl,
    hold_q: &[f64],
) -> Result<Vec<FanucConversion>, CompensateError> {
    let mut next = 0;
    let mut out = Vec::with_capacity(requests.len());
    for req in requests {
        let mut layout = req.layout;
        layout.first_point = layout.first_point.or(Some(next));
        let c = export_one(model, coeffs, req, control, &layout, hold_q)?;
        let end = c.table.blocks().iter().map(|b| b.1).max().unwrap_or(0);
        next = next.max(end as u32 + 1);
        out.push(c);
    }
    let tables: Vec<FanucTable> = out.iter().map(|c| c.table.clone()).collect();
    validate_fanuc(control, &tables)?;
    Ok(out)
}

fn export_one(
    model: &MachineModel,
    coeffs: &[f64],
    req: &FanucRequest,
    control: &FanucControl,
    layout: &FanucLayout,
    hold_q: &[f64],
) -> Result<FanucConversion, CompensateError> {
    let a = &req.axis;
    if !a.rotary {
        let table = fanuc_pitch_table(
            model,
            coeffs,
            a.letter,
            req.interval,
            a.reference_position,
            hold_q,
        )?;
        let table = match &req.reversal {
            Some(r) => table.with_reversal(r, crate::stroke_mm(model.machine(), a.letter)?),
            None => table,
        };
        return fanuc_from_pitch(&table, control, a, layout);
    }
    if req.reversal.is_some() {
        let message = "mtcal writes rotary tables unidirectional only".to_string();
        return Err(FanucError::Layout {
            axis: a.letter,
            message,
        }
        .into());
    }
    check_inputs(model, coeffs, hold_q)?;
    let (i, lo, hi, full_turn) = rotary_axis(model.machine(), a.letter)?;
    let what = format!("Fanuc table of axis {}", a.letter);
    let positions = if full_turn {
        crate::nodes_in(lo, hi, req.interval, &what)?
    } else {
        aligned_nodes(
            a.letter,
            (lo, hi),
            a.reference_position,
            req.interval,
            &what,
        )?
    };
    let table = rotary_table_at(model, coeffs, i, positions, hold_q, full_turn);
    fanuc_from_rotary(&table, control, a, layout)
}

/// Nodes `interval` apart through `reference`, within `[lo, hi]` (one unit, mm or degrees).
fn aligned_nodes(
    axis: char,
    (lo, hi): (f64, f64),
    reference: f64,
    interval: f64,
    what: &str,
) -> Result<Vec<f64>, CompensateError> {
    if !(interval.is_finite() && interval > 0.0) {
        return Err(CompensateError::BadSpacing {
            spacing_mm: interval,
        });
    }
    if !reference.is_finite() {
        let message = format!("the reference position must be finite, got {reference}");
        return Err(FanucError::Layout { axis, message }.into());
    }
    // A node this close outside the stroke is on its end (mm or degrees).
    const SNAP: f64 = 1e-6;
    let k_lo = ((lo - SNAP - reference) / interval).ceil();
    let k_hi = ((hi + SNAP - reference) / interval).floor();
    let nodes = (k_hi - k_lo + 1.0).max(0.0);
    if nodes > MAX_NODES as f64 {
        return Err(CompensateError::TooManyNodes {
            what: what.to_string(),
            nodes: nodes as usize,
            max: MAX_NODES,
        });
    }
    Ok((0..nodes as i64)
        .map(|k| reference + (k_lo + k as f64) * interval)
        .collect())
}

/// The pitch table of linear axis `axis` on the control's grid: nodes `interval_mm` apart
/// through the reference position `reference_mm` (mtcal's axis coordinates), within the
/// stroke; compensations as [`crate::pitch_table`] computes them.
pub fn fanuc_pitch_table(
    model: &MachineModel,
    coeffs: &[f64],
    axis: char,
    interval_mm: f64,
    reference_mm: f64,
    hold_q: &[f64],
) -> Result<PitchTable, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let machine = model.machine();
    let (i, lo, hi) = linear_axis(machine, axis)?;
    let what = format!("Fanuc pitch table of axis {axis}");
    let positions_mm = aligned_nodes(axis, (lo * MM, hi * MM), reference_mm, interval_mm, &what)?;
    let mut q = hold_q.to_vec();
    let dir = travel_direction(machine, &q, i);
    let mut ws = model.workspace();
    let forward_um = positions_mm
        .iter()
        .map(|p| {
            q[i] = p / MM;
            -model.pose_error(&q, coeffs, &mut ws).translation.dot(&dir) * UM
        })
        .collect();
    Ok(PitchTable {
        axis,
        positions_mm,
        forward_um,
        reverse_um: None,
        note: held_note(machine, hold_q, i),
    })
}

/// Writes the parameter record and the values table (with the card) of `conversions`,
/// atomically each; returns the card.
pub fn write_fanuc(
    parameter_path: &Path,
    values_path: &Path,
    control: &FanucControl,
    conversions: &[FanucConversion],
    made_from: &[String],
) -> Result<ConventionCard, CompensateError> {
    let tables: Vec<FanucTable> = conversions.iter().map(|c| c.table.clone()).collect();
    let record = fanuc_parameter_text(control, &tables)?;
    let card = ConventionCard {
        made_from: made_from.to_vec(),
        ..fanuc_card(control, conversions)
    };
    write_file(parameter_path, &record)?;
    write_file(values_path, &fanuc_values_csv(control, conversions, &card))?;
    Ok(card)
}

/// One word of a record (a parameter's or a point's value) and where it stands.
#[derive(Clone, Copy, Debug)]
struct Word {
    value: i64,
    line: usize,
    column: usize,
}

/// What a record holds: parameter words by (parameter, axis number), point values by point.
#[derive(Default)]
struct Record {
    params: BTreeMap<(u32, u32), Word>,
    points: BTreeMap<u32, Word>,
    /// Line of the closing `%`.
    end_line: usize,
}

/// Reads a parameter record written by [`fanuc_parameter_text`] back into the tables of
/// `axes` (what the record does not say: letters, kinds, reference positions); the control's
/// series, increment system and limits from `control`. Checks what [`validate_fanuc`] checks.
pub fn read_fanuc_parameters(
    path: &Path,
    control: &FanucControl,
    axes: &[FanucAxis],
) -> Result<Vec<FanucTable>, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let record = parse_record(&src, &text, control)?;
    let mut reading = Reading {
        src: &src,
        record: &record,
        control,
        used: BTreeSet::new(),
    };
    let tables = axes
        .iter()
        .map(|axis| reading.table_of(axis))
        .collect::<Result<Vec<_>, _>>()?;
    for (&(param, number), w) in &record.params {
        if !axes.iter().any(|a| a.number == number) {
            let given: Vec<String> = axes
                .iter()
                .map(|a| format!("A{} = {}", a.number, a.letter))
                .collect();
            let msg = format!(
                "parameter {param} is set for axis A{number}, which is not among the axes given \
                 ({})",
                given.join(", ")
            );
            return Err(src.error(w.line, w.column, msg));
        }
    }
    if let Some((p, w)) = record
        .points
        .iter()
        .find(|(p, _)| !reading.used.contains(*p))
    {
        let msg = format!("point {p} belongs to no axis' table (3621…3622 or the 3626 set)");
        return Err(src.error(w.line, w.column, msg));
    }
    validate_fanuc(control, &tables)?;
    Ok(tables)
}

/// Splits the record into its words, located.
fn parse_record(
    src: &Source<'_>,
    text: &str,
    control: &FanucControl,
) -> Result<Record, CompensateError> {
    let mut record = Record::default();
    let mut opened = false;
    let mut last_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        last_line = n;
        let line = raw.strip_suffix('\r').unwrap_or(raw).trim_end();
        if line.trim().is_empty() {
            continue;
        }
        // A control punching with NCR (parameter 0100 bit 3) ends each block LF CR CR
        // (B-63524EN p.649): the CRs open the next line.
        let lead = line.len() - line.trim_start_matches('\r').len();
        match (opened, record.end_line > 0, &line[lead..]) {
            (_, true, _) => return Err(src.error(n, 1, "expected nothing after the closing `%`")),
            (false, _, "%") => opened = true,
            (false, _, _) => {
                return Err(src.error(n, 1, "expected `%`, the start of a Fanuc record"));
            }
            (true, _, "%") => record.end_line = n,
            (true, _, _) => parse_block(src, n, line, lead, control, &mut record)?,
        }
    }
    if record.end_line == 0 {
        let what = if opened {
            "the closing `%`"
        } else {
            "`%`, the start of a Fanuc record"
        };
        return Err(src.error(
            last_line + 1,
            1,
            format!("expected {what}, found the end of the file"),
        ));
    }
    Ok(record)
}

/// A cursor over one block, for located errors.
struct Cursor<'a> {
    src: &'a Source<'a>,
    line_no: usize,
    text: &'a str,
    at: usize,
}

impl Cursor<'_> {
    fn column(&self) -> usize {
        self.at + 1
    }

    fn error(&self, message: String) -> CompensateError {
        self.src.error(self.line_no, self.column(), message)
    }

    fn found(&self) -> String {
        match self.text[self.at..].chars().next() {
            Some(c) => format!("`{c}`"),
            None => "the end of the line".to_string(),
        }
    }

    fn done(&self) -> bool {
        self.at >= self.text.len()
    }

    /// Consumes `word` (a letter or a marker such as `Q1`).
    fn expect(&mut self, word: &str, what: &str) -> Result<(), CompensateError> {
        if self.text[self.at..].starts_with(word) {
            self.at += word.len();
            return Ok(());
        }
        Err(self.error(format!("expected `{word}` {what}, found {}", self.found())))
    }

    /// An unsigned integer.
    fn digits(&mut self, what: &str) -> Result<u32, CompensateError> {
        let rest = &self.text[self.at..];
        let len = rest
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(rest.len());
        match rest[..len].parse::<u32>() {
            Ok(v) => {
                self.at += len;
                Ok(v)
            }
            Err(_) => Err(self.error(format!("expected {what}, found {}", self.found()))),
        }
    }

    /// A signed number in units of 10^−`decimals` (integers when `decimals` is 0), exactly.
    fn units(&mut self, decimals: usize, what: &str) -> Result<Word, CompensateError> {
        let (line, column) = (self.line_no, self.column());
        let rest = &self.text[self.at..];
        let len = rest
            .find(|c: char| !(c.is_ascii_digit() || "+-.".contains(c)))
            .unwrap_or(rest.len());
        let token = &rest[..len];
        let value = parse_units(token, decimals).ok_or_else(|| {
            let kind = if decimals == 0 {
                "an integer".to_string()
            } else {
                format!("a number with at most {decimals} decimals")
            };
            self.error(format!("expected {what}: {kind}, found `{token}`"))
        })?;
        self.at += len;
        Ok(Word {
            value,
            line,
            column,
        })
    }
}

/// `token` (sign, digits, optional point and at most `decimals` more digits) in units of
/// 10^−`decimals`.
fn parse_units(token: &str, decimals: usize) -> Option<i64> {
    let (negative, body) = match token.as_bytes().first()? {
        b'-' => (true, &token[1..]),
        b'+' => (false, &token[1..]),
        _ => (false, token),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if int.is_empty() || !digits(int) || !digits(frac) || frac.len() > decimals {
        return None;
    }
    let padded = format!("{int}{frac:0<decimals$}");
    let v: i64 = padded.parse().ok()?;
    Some(if negative { -v } else { v })
}

/// One block: a parameter with its axis words, or a pitch data point.
/// Block `line` (line `n`), read from byte `start` on (after the CRs of an LF CR CR ending).
fn parse_block(
    src: &Source<'_>,
    n: usize,
    line: &str,
    start: usize,
    control: &FanucControl,
    record: &mut Record,
) -> Result<(), CompensateError> {
    let mut c = Cursor {
        src,
        line_no: n,
        text: line,
        at: start,
    };
    c.expect("N", "and a parameter or pitch data number")?;
    let number_column = c.column();
    let number = c.digits("a parameter or pitch data number")?;
    if number >= PITCH_BASE {
        c.expect(control.series.pitch_marker(), "(pitch data)")?;
        c.expect("P", "and the point's value")?;
        let word = c.units(0, "the point's value")?;
        if !c.done() {
            return Err(c.error(format!(
                "expected the end of the block, found {}",
                c.found()
            )));
        }
        let point = number - PITCH_BASE;
        if record.points.insert(point, word).is_some() {
            return Err(src.error(n, number_column, format!("point {point} is given twice")));
        }
        return Ok(());
    }
    if !PARAMETERS.contains(&number) {
        let msg = format!(
            "expected one of the parameters 3620–3627 or pitch data (N10000 and up), found \
             parameter {number}"
        );
        return Err(src.error(n, number_column, msg));
    }
    c.expect(control.series.parameter_marker(), "(parameter data)")?;
    let decimals = match number {
        3624 | 3625 if control.series.real_intervals() => control.increment.decimals(),
        _ => 0,
    };
    loop {
        c.expect("A", "and an axis number")?;
        let axis_column = c.column();
        let axis = c.digits("an axis number")?;
        c.expect("P", "and the parameter's value")?;
        let word = c.units(decimals, "the parameter's value")?;
        if record.params.insert((number, axis), word).is_some() {
            let msg = format!("parameter {number} is given twice for axis A{axis}");
            return Err(src.error(n, axis_column, msg));
        }
        if c.done() {
            return Ok(());
        }
    }
}

/// A record being turned into tables: where it came from, what it holds, the control, and
/// the points the tables so far use.
struct Reading<'a> {
    src: &'a Source<'a>,
    record: &'a Record,
    control: &'a FanucControl,
    used: BTreeSet<u32>,
}

impl Reading<'_> {
    fn word(&self, p: u32, axis: &FanucAxis) -> Option<Word> {
        self.record.params.get(&(p, axis.number)).copied()
    }

    fn need(&self, p: u32, axis: &FanucAxis) -> Result<Word, CompensateError> {
        self.word(p, axis).ok_or_else(|| {
            let msg = format!(
                "expected parameter {p} for axis A{} ({}), found none in the record",
                axis.number, axis.letter
            );
            self.src.error(self.record.end_line, 1, msg)
        })
    }

    /// Word `w` of parameter `p` as a point number (or a magnification).
    fn count(&self, w: Word, p: u32) -> Result<u32, CompensateError> {
        u32::try_from(w.value).map_err(|_| {
            let msg = format!("parameter {p} must be 0 or more, got {}", w.value);
            self.src.error(w.line, w.column, msg)
        })
    }

    /// The table of `axis`; marks the points it uses.
    fn table_of(&mut self, axis: &FanucAxis) -> Result<FanucTable, CompensateError> {
        let reference_point = self.count(self.need(3620, axis)?, 3620)?;
        let first_point = self.count(self.need(3621, axis)?, 3621)?;
        let last_word = self.need(3622, axis)?;
        let last_point = self.count(last_word, 3622)?;
        let magnification = self.count(self.need(3623, axis)?, 3623)?;
        let interval_units = self.need(3624, axis)?.value;
        let revolution = self.word(3625, axis);
        if let (Some(w), false) = (revolution, axis.rotary) {
            let msg = format!(
                "3625 (travel per revolution) is for rotary axes; axis {} is linear",
                axis.letter
            );
            return Err(self.src.error(w.line, w.column, msg));
        }
        if last_point < first_point {
            let msg = format!("3622 = {last_point} must not be below 3621 = {first_point}");
            return Err(self.src.error(last_word.line, last_word.column, msg));
        }
        let count = last_point - first_point + 1;
        let values = self.point_values(axis, first_point, count, last_word)?;
        let reverse = self.reverse_of(axis, count)?;
        Ok(FanucTable {
            axis: *axis,
            increment: self.control.increment,
            reference_point,
            first_point,
            last_point,
            magnification,
            interval_units,
            revolution_units: revolution.map(|w| w.value),
            values,
            reverse,
        })
    }

    /// The negative-direction set of `axis` (3626, 3627), `count` points.
    fn reverse_of(
        &mut self,
        axis: &FanucAxis,
        count: u32,
    ) -> Result<Option<FanucReverse>, CompensateError> {
        match (self.word(3626, axis), self.word(3627, axis)) {
            (None, None) => Ok(None),
            (Some(w), None) | (None, Some(w)) => {
                let msg = "a bidirectional table needs both 3626 and 3627".to_string();
                Err(self.src.error(w.line, w.column, msg))
            }
            (Some(f), Some(o)) => {
                let first_point = self.count(f, 3626)?;
                Ok(Some(FanucReverse {
                    first_point,
                    opposite_at_reference_units: o.value,
                    values: self.point_values(axis, first_point, count, f)?,
                }))
            }
        }
    }

    /// The values of `count` points from `first`, each within the control's range; a missing
    /// point is reported at `at` (the parameter that asks for it).
    fn point_values(
        &mut self,
        axis: &FanucAxis,
        first: u32,
        count: u32,
        at: Word,
    ) -> Result<Vec<i64>, CompensateError> {
        let mut values = Vec::with_capacity(count as usize);
        for p in first..first + count {
            let Some(w) = self.record.points.get(&p) else {
                let msg = format!(
                    "expected a value for point {p} (N{}) of axis {}'s table, found none",
                    PITCH_BASE + p,
                    axis.letter
                );
                return Err(self.src.error(at.line, at.column, msg));
            };
            if w.value.abs() > self.control.value_limit {
                let msg = format!(
                    "value {} of point {p} is outside the control's range ±{}",
                    w.value, self.control.value_limit
                );
                return Err(self.src.error(w.line, w.column, msg));
            }
            if !self.used.insert(p) {
                let msg = format!("point {p} is used by two tables");
                return Err(self.src.error(w.line, w.column, msg));
            }
            values.push(w.value);
        }
        Ok(values)
    }
}
