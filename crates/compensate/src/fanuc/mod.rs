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

use crate::Travel;

// Tables into pitch data, the control's limits, the record's text and card, the export from a
// model, the reader: each uses the types below, and only `export` uses its siblings.
mod convert;
mod export;
mod read;
mod text;
mod validate;

pub use convert::{fanuc_from_pitch, fanuc_from_rotary};
pub use export::{FanucRequest, fanuc_export, fanuc_pitch_table, write_fanuc};
pub use read::read_fanuc_parameters;
pub use text::{fanuc_card, fanuc_parameter_text, fanuc_values_csv};
pub use validate::validate_fanuc;

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
