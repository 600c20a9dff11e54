//! Sag / angularity (cross-axis) compensation tables, file `%_N_NC_CEC_INI`.

use super::ini::{self, Kind, Place};
use super::{
    Blame, Grid, SiemensError, SiemensLimits, any_rotary, control_name, equidistant_nodes_mm,
    mapping_for, min_max_step, positions_from,
};
use crate::text::{Field, Source};
use crate::{
    AxisMap, CompensateError, ConventionCard, MM, Quantity, ROTARY_RIGHT_HAND, SQUARENESS_ISO,
    check_inputs, linear_axis, read_file, travel_direction, write_file,
};
use mtcal_kinematics::{AxisKind, MachineModel};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The name line of the file.
pub const CEC_FILE_NAME: &str = "%_N_NC_CEC_INI";
const MACHINE_DATA: &str = "MD18342 $MN_MM_CEC_MAX_POINTS";

/// In which direction of travel of the input axis a table acts (`$AN_CEC_DIRECTION`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CecDirection {
    /// 0: both directions.
    Both,
    /// 1: only while the input axis travels in its positive direction.
    Positive,
    /// −1: only while it travels in its negative direction.
    Negative,
}

impl CecDirection {
    /// The value of `$AN_CEC_DIRECTION`.
    pub fn code(self) -> i64 {
        match self {
            CecDirection::Both => 0,
            CecDirection::Positive => 1,
            CecDirection::Negative => -1,
        }
    }

    /// The direction of a `$AN_CEC_DIRECTION` value, if it is 0, 1 or −1.
    pub fn from_code(code: i64) -> Option<Self> {
        match code {
            0 => Some(CecDirection::Both),
            1 => Some(CecDirection::Positive),
            -1 => Some(CecDirection::Negative),
            _ => None,
        }
    }
}

/// One CEC table `t`: the output axis' values `$AN_CEC[t,N]` at equidistant positions of the
/// input axis.
#[derive(Clone, Debug, PartialEq)]
pub struct CecTable {
    /// The table index `t` (table number `t + 1`).
    pub index: usize,
    /// `$AN_CEC_INPUT_AXIS[t]`: the machine axis whose setpoint is the table's input.
    pub input_axis: String,
    /// `$AN_CEC_OUTPUT_AXIS[t]`: the machine axis the table's output is applied to.
    pub output_axis: String,
    /// Input-axis positions of the points, ascending and equidistant: mm (degrees on a rotary
    /// input axis).
    pub positions: Vec<f64>,
    /// The values: the output axis' error at each point, mm (degrees on a rotary output axis);
    /// see the module documentation for the sign.
    pub values: Vec<f64>,
    /// `$AN_CEC_DIRECTION[t]`.
    pub direction: CecDirection,
    /// `$AN_CEC_MULT_BY_TABLE[t]`: 0, or the number (index + 1) of the table this one's values
    /// are multiplied with (the product is added to the output).
    pub mult_by_table: usize,
    /// `$AN_CEC_IS_MODULO[t]`: the table repeats with period MAX − MIN.
    pub is_modulo: bool,
}

impl CecTable {
    /// Table `index` from `input_axis` to `output_axis` (control names) with `values` at
    /// `positions`, both directions, no multiplication, not modulo.
    pub fn new(
        index: usize,
        input_axis: impl Into<String>,
        output_axis: impl Into<String>,
        positions: Vec<f64>,
        values: Vec<f64>,
    ) -> Self {
        CecTable {
            index,
            input_axis: input_axis.into(),
            output_axis: output_axis.into(),
            positions,
            values,
            direction: CecDirection::Both,
            mult_by_table: 0,
            is_modulo: false,
        }
    }

    /// The table's name in messages: `$AN_CEC[0,N] (X1 → Z1)`.
    pub fn name(&self) -> String {
        let (t, i, o) = (self.index, &self.input_axis, &self.output_axis);
        format!("$AN_CEC[{t},N] ({i} → {o})")
    }

    fn grid<'a>(&'a self, name: &'a str) -> Grid<'a> {
        Grid {
            name,
            positions: &self.positions,
            values: &self.values,
            is_modulo: self.is_modulo,
        }
    }

    /// Checks the table against the control's limits: axis names, a table index the control
    /// provides, at most MD18342 points, ascending, equidistant, finite, values within the
    /// bound, equal end values when modulo.
    pub fn check(&self, limits: &SiemensLimits) -> Result<(), SiemensError> {
        super::check_axis_name(&self.input_axis)?;
        super::check_axis_name(&self.output_axis)?;
        let name = self.name();
        if self.index >= limits.cec_max_tables {
            let (index, max) = (self.index, limits.cec_max_tables);
            return Err(SiemensError::TableIndex {
                table: name,
                index,
                max,
            });
        }
        self.grid(&name)
            .check(limits.cec_max_points, MACHINE_DATA, limits.max_abs_value)
    }

    /// The table's own output at input position `position` (mm or degrees): linear between
    /// points, end values held beyond them, repeated when modulo; the direction and the table
    /// multiplication are not applied. The table must not be empty.
    pub fn value_at(&self, position: f64) -> f64 {
        self.grid("").value_at(position)
    }
}

/// The CEC table `index` from linear axis `input` to linear axis `output` (mtcal letters): the
/// error along `output`'s positive travel direction (mm) at equidistant points over `input`'s
/// stroke ([`equidistant_nodes_mm`] with `spacing_mm`), the other axes at `hold_q` (SI), minus
/// the same error with `input` at its held position; axes named by `names`.
#[allow(clippy::too_many_arguments)]
pub fn siemens_cec_table(
    model: &MachineModel,
    coeffs: &[f64],
    index: usize,
    input: char,
    output: char,
    spacing_mm: f64,
    hold_q: &[f64],
    names: &[AxisMap],
) -> Result<CecTable, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let machine = model.machine();
    let (i, lo, hi) = linear_axis(machine, input)?;
    let (o, _, _) = linear_axis(machine, output)?;
    if i == o {
        return Err(SiemensError::SameAxis { axis: input }.into());
    }
    let (input_axis, output_axis) = (control_name(names, input)?, control_name(names, output)?);
    let what = format!("Siemens CEC table {input} → {output}");
    let positions = equidistant_nodes_mm(lo, hi, spacing_mm, &what)?;
    let dir = travel_direction(machine, hold_q, o);
    let mut ws = model.workspace();
    let held = model
        .pose_error(hold_q, coeffs, &mut ws)
        .translation
        .dot(&dir);
    let mut q = hold_q.to_vec();
    let values = positions
        .iter()
        .map(|&p| {
            q[i] = p / MM;
            (model.pose_error(&q, coeffs, &mut ws).translation.dot(&dir) - held) * MM
        })
        .collect();
    Ok(CecTable::new(
        index,
        input_axis,
        output_axis,
        positions,
        values,
    ))
}

/// [`siemens_cec_table`] of every ordered pair of different linear axes (X → Y, X → Z, Y → X,
/// …), numbered from 0 in that order.
pub fn siemens_cec_tables(
    model: &MachineModel,
    coeffs: &[f64],
    spacing_mm: f64,
    hold_q: &[f64],
    names: &[AxisMap],
) -> Result<Vec<CecTable>, CompensateError> {
    let linear: Vec<char> = model
        .machine()
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Linear)
        .map(|a| a.letter().as_char())
        .collect();
    let mut tables = Vec::new();
    for &input in &linear {
        for &output in linear.iter().filter(|&&o| o != input) {
            let index = tables.len();
            tables.push(siemens_cec_table(
                model, coeffs, index, input, output, spacing_mm, hold_q, names,
            )?);
        }
    }
    Ok(tables)
}

/// Checks every table, that no index comes twice and that table multiplications name tables
/// of the file.
fn check_cec(tables: &[CecTable], limits: &SiemensLimits) -> Result<(), SiemensError> {
    for (k, t) in tables.iter().enumerate() {
        t.check(limits)?;
        if tables[..k].iter().any(|u| u.index == t.index) {
            return Err(SiemensError::DuplicateTable { table: t.name() });
        }
    }
    match bad_multiplication(tables) {
        Some((_, e)) => Err(e),
        None => Ok(()),
    }
}

/// The first table whose `$AN_CEC_MULT_BY_TABLE` names no table of `tables`, and why.
fn bad_multiplication(tables: &[CecTable]) -> Option<(usize, SiemensError)> {
    let numbers: Vec<usize> = tables.iter().map(|t| t.index + 1).collect();
    let k = tables
        .iter()
        .position(|t| t.mult_by_table != 0 && !numbers.contains(&t.mult_by_table))?;
    let list: Vec<String> = numbers.iter().map(|n| n.to_string()).collect();
    let e = SiemensError::MultByTable {
        table: tables[k].name(),
        refers: tables[k].mult_by_table,
        numbers: list.join(", "),
    };
    Some((k, e))
}

/// The convention card of a CEC file of `tables`, axes named by `names`.
pub fn cec_card(tables: &[CecTable], names: &[AxisMap]) -> ConventionCard {
    let used = || {
        tables
            .iter()
            .flat_map(|t| [t.input_axis.as_str(), t.output_axis.as_str()])
    };
    ConventionCard {
        made_from: Vec::new(),
        format: format!("SINUMERIK 840D sl sag / angularity compensation (CEC), {CEC_FILE_NAME}"),
        quantity: Quantity::Error,
        sign: "$AN_CEC[t,N] is the output axis' error along its positive direction (tool \
               relative to workpiece) with the input axis at point N, minus the same error \
               with the input axis at its held position; assumed to act like MSEC, a positive \
               value moving the output axis in its negative direction (K3 states the sign for \
               MSEC only: check once with a constant table of +0.010, which should move the \
               output axis by −10 µm)"
            .into(),
        squareness: format!(
            "carried as the linear part of the tables between two linear axes, at the held \
             positions (mtcal's definition: {SQUARENESS_ISO})"
        ),
        rotary_direction: if any_rotary(names, used()) {
            ROTARY_RIGHT_HAND.into()
        } else {
            "no rotary axis in this file".into()
        },
        axis_mapping: mapping_for(names, used()),
        units: "input positions ($AN_CEC_MIN, _MAX, _STEP) in mm of the input axis (degrees if \
                rotary), values in mm of the output axis, to 1 nm; table number = index t + 1"
            .into(),
        control_will: vec![
            "take the input axis' setpoint, interpolate linearly between the points \
             MIN + N × STEP, hold the end values below MIN and above MAX, sum all tables of one \
             output axis and apply the sum to that axis"
                .into(),
            "need the licensed sag compensation option (alarm 8040 without it)".into(),
            "accept the file only while MD32710 $MA_CEC_ENABLE = 0 for the output axes and \
             MD18342 $MN_MM_CEC_MAX_POINTS[t] ≥ the points of table t (changing MD18342 \
             reformats the static user memory at the next power on: back it up first)"
                .into(),
            "compensate after MD32710 $MA_CEC_ENABLE[output axis] = 1, SD41300 \
             $SN_CEC_TABLE_ENABLE[t] = 1 for every table and power on; a table that loads \
             without alarm still moves nothing if SD41300 is 0 or _INPUT_AXIS / _OUTPUT_AXIS \
             name other machine axes"
                .into(),
            "not hold errors that depend on two axes at once (an angular error's Abbe offset \
             changes with the other axes) or orientation errors; the tables are zero with the \
             input axis at its held position and add to the EEC tables made at the same held \
             positions"
                .into(),
        ],
    }
}

/// The file text of `tables` with `card` and `note` as comments, after checking them against
/// `limits`.
pub fn siemens_cec_text(
    tables: &[CecTable],
    card: &ConventionCard,
    note: &str,
    limits: &SiemensLimits,
) -> Result<String, CompensateError> {
    check_cec(tables, limits)?;
    let mut out = String::new();
    let title = "mtcal: SINUMERIK sag / angularity compensation tables";
    ini::preamble(&mut out, CEC_FILE_NAME, title, card, note);
    for t in tables {
        table_text(&mut out, t);
    }
    out.push_str("M17\n");
    Ok(out)
}

fn table_text(out: &mut String, t: &CecTable) {
    let (min, max, step) = min_max_step(&t.positions);
    let k = t.index;
    let n = t.values.len();
    ini::comment(
        out,
        &format!(
            "{}: {n} points from {} to {} every {}",
            t.name(),
            ini::real_text(min, 6),
            ini::real_text(max, 6),
            ini::real_text(step, 6)
        ),
    );
    for (j, v) in t.values.iter().enumerate() {
        // A modulo table's ends agree to 1e-9; the same text keeps them equal after rounding.
        let v = if t.is_modulo && j + 1 == n {
            t.values[0]
        } else {
            *v
        };
        let _ = writeln!(out, "$AN_CEC[{k},{j}]={}", ini::real_text(v, 6));
    }
    let _ = writeln!(out, "$AN_CEC_INPUT_AXIS[{k}]=({})", t.input_axis);
    let _ = writeln!(out, "$AN_CEC_OUTPUT_AXIS[{k}]=({})", t.output_axis);
    let _ = writeln!(out, "$AN_CEC_STEP[{k}]={}", ini::real_text(step, 9));
    let _ = writeln!(out, "$AN_CEC_MIN[{k}]={}", ini::real_text(min, 9));
    let _ = writeln!(out, "$AN_CEC_MAX[{k}]={}", ini::real_text(max, 9));
    let _ = writeln!(out, "$AN_CEC_DIRECTION[{k}]={}", t.direction.code());
    let _ = writeln!(out, "$AN_CEC_MULT_BY_TABLE[{k}]={}", t.mult_by_table);
    let _ = writeln!(out, "$AN_CEC_IS_MODULO[{k}]={}", u8::from(t.is_modulo));
}

/// Writes [`siemens_cec_text`] to `path` atomically.
pub fn write_siemens_cec(
    path: &Path,
    tables: &[CecTable],
    card: &ConventionCard,
    note: &str,
    limits: &SiemensLimits,
) -> Result<(), CompensateError> {
    write_file(path, &siemens_cec_text(tables, card, note, limits)?)
}

/// Reads a CEC file, checking every table against `limits`; errors name file, line, column.
pub fn read_siemens_cec(
    path: &Path,
    limits: &SiemensLimits,
) -> Result<Vec<CecTable>, CompensateError> {
    read_siemens_cec_str(&read_file(path)?, path, limits)
}

/// [`read_siemens_cec`] of `text`, naming `file` in errors.
pub fn read_siemens_cec_str(
    text: &str,
    file: &Path,
    limits: &SiemensLimits,
) -> Result<Vec<CecTable>, CompensateError> {
    let src = Source { file };
    let statements = ini::statements(&src, text)?;
    let body = ini::frame(&src, text, &statements, CEC_FILE_NAME)?;
    let mut accs: BTreeMap<usize, Acc> = BTreeMap::new();
    for s in body {
        match &s.kind {
            Kind::Chandata => {}
            Kind::Header(h) => {
                let msg = format!("a second name line `{h}`");
                return Err(src.error(s.at.0, s.at.1, msg));
            }
            Kind::End => unreachable!("frame ends before M17"),
            Kind::Assign { name, args, value } => {
                assign(&src, &mut accs, s.at, *name, args, *value)?;
            }
        }
    }
    let tables: Vec<CecTable> = accs
        .values()
        .map(|a| a.table(&src, limits))
        .collect::<Result<_, _>>()?;
    if let Some((k, e)) = bad_multiplication(&tables) {
        let acc = &accs[&tables[k].index];
        let (line, column) = acc.mult.map_or(acc.first, |m| m.1);
        return Err(src.error(line, column, e.to_string()));
    }
    Ok(tables)
}

/// What the file assigns to one table, with places.
struct Acc {
    index: usize,
    first: Place,
    values: BTreeMap<usize, (f64, Place)>,
    input: Option<(String, Place)>,
    output: Option<(String, Place)>,
    step: Option<(f64, Place)>,
    min: Option<(f64, Place)>,
    max: Option<(f64, Place)>,
    direction: Option<(CecDirection, Place)>,
    mult: Option<(usize, Place)>,
    modulo: Option<(bool, Place)>,
}

/// The CEC variables with one index `[t]`.
const TABLE_VARIABLES: [&str; 8] = [
    "$AN_CEC_INPUT_AXIS",
    "$AN_CEC_OUTPUT_AXIS",
    "$AN_CEC_STEP",
    "$AN_CEC_MIN",
    "$AN_CEC_MAX",
    "$AN_CEC_DIRECTION",
    "$AN_CEC_MULT_BY_TABLE",
    "$AN_CEC_IS_MODULO",
];

/// Stores `v` in `slot`, refusing a second assignment.
fn put<T>(
    src: &Source<'_>,
    slot: &mut Option<(T, Place)>,
    v: T,
    place: Place,
    name: Field<'_>,
) -> Result<(), CompensateError> {
    if let Some((_, first)) = slot.replace((v, place)) {
        let msg = format!(
            "`{}` is assigned twice (first on line {})",
            name.text, first.0
        );
        return Err(src.error(place.0, name.column, msg));
    }
    Ok(())
}

/// Adds one assignment to the accumulator of its table.
fn assign(
    src: &Source<'_>,
    accs: &mut BTreeMap<usize, Acc>,
    at: Place,
    name: Field<'_>,
    args: &[Field<'_>],
    value: Field<'_>,
) -> Result<(), CompensateError> {
    let line = at.0;
    if name.text == "$AN_CEC" {
        ini::expect_args(src, line, name, args, 2, "[t,N]")?;
    } else if TABLE_VARIABLES.contains(&name.text) {
        ini::expect_args(src, line, name, args, 1, "[t]")?;
    } else {
        let msg = format!(
            "`{}` is no CEC table variable (expected $AN_CEC, {})",
            name.text,
            TABLE_VARIABLES.join(", ")
        );
        return Err(src.error(line, name.column, msg));
    }
    let index = ini::index(src, line, args[0])?;
    let acc = accs.entry(index).or_insert_with(|| Acc::new(index, at));
    let place = (line, value.column);
    match name.text {
        "$AN_CEC" => {
            let n = ini::index(src, line, args[1])?;
            let v = ini::real(src, line, value)?;
            if let Some((_, first)) = acc.values.insert(n, (v, place)) {
                let msg = format!(
                    "`$AN_CEC[{index},{n}]` is assigned twice (first on line {})",
                    first.0
                );
                return Err(src.error(line, name.column, msg));
            }
            Ok(())
        }
        "$AN_CEC_INPUT_AXIS" => {
            let v = ini::axis_value(src, line, value)?;
            put(src, &mut acc.input, v, place, name)
        }
        "$AN_CEC_OUTPUT_AXIS" => {
            let v = ini::axis_value(src, line, value)?;
            put(src, &mut acc.output, v, place, name)
        }
        "$AN_CEC_DIRECTION" => {
            let code = ini::integer(src, line, value)?;
            let Some(d) = CecDirection::from_code(code) else {
                let msg = format!("expected 0, 1 or -1, found `{}`", value.text);
                return Err(src.error(line, value.column, msg));
            };
            put(src, &mut acc.direction, d, place, name)
        }
        "$AN_CEC_MULT_BY_TABLE" => {
            let v = ini::index(src, line, value)?;
            put(src, &mut acc.mult, v, place, name)
        }
        "$AN_CEC_IS_MODULO" => {
            let v = ini::flag(src, line, value)?;
            put(src, &mut acc.modulo, v, place, name)
        }
        var => {
            let v = ini::real(src, line, value)?;
            let slot = match var {
                "$AN_CEC_STEP" => &mut acc.step,
                "$AN_CEC_MIN" => &mut acc.min,
                _ => &mut acc.max,
            };
            put(src, slot, v, place, name)
        }
    }
}

impl Acc {
    fn new(index: usize, first: Place) -> Self {
        Acc {
            index,
            first,
            values: BTreeMap::new(),
            input: None,
            output: None,
            step: None,
            min: None,
            max: None,
            direction: None,
            mult: None,
            modulo: None,
        }
    }

    /// The table, or the located reason the control would refuse or misread it.
    fn table(&self, src: &Source<'_>, limits: &SiemensLimits) -> Result<CecTable, CompensateError> {
        let t = self.index;
        let name = format!("$AN_CEC[{t},N]");
        let missing = |var: &str| {
            let msg = format!(
                "{name}: `{var}[{t}]` is not assigned (the control would keep an earlier value)"
            );
            src.error(self.first.0, self.first.1, msg)
        };
        let (input_axis, _) = self
            .input
            .clone()
            .ok_or_else(|| missing(TABLE_VARIABLES[0]))?;
        let (output_axis, _) = self
            .output
            .clone()
            .ok_or_else(|| missing(TABLE_VARIABLES[1]))?;
        let (step, step_at) = self.step.ok_or_else(|| missing(TABLE_VARIABLES[2]))?;
        let (min, _) = self.min.ok_or_else(|| missing(TABLE_VARIABLES[3]))?;
        let (max, max_at) = self.max.ok_or_else(|| missing(TABLE_VARIABLES[4]))?;
        let (direction, _) = self.direction.ok_or_else(|| missing(TABLE_VARIABLES[5]))?;
        let (mult_by_table, mult_at) = self.mult.ok_or_else(|| missing(TABLE_VARIABLES[6]))?;
        let (is_modulo, _) = self.modulo.ok_or_else(|| missing(TABLE_VARIABLES[7]))?;
        let values = super::complete_values(src, &name, &self.values, self.first)?;
        let place = |blame: Blame| match blame {
            Blame::Value(i) => self.values.get(&i).map_or(self.first, |v| v.1),
            Blame::Step => step_at,
            Blame::Max => max_at,
            Blame::Mult => mult_at,
            Blame::Table => self.first,
        };
        let located = |e: SiemensError| {
            let (line, column) = place(e.blame());
            src.error(line, column, e.to_string())
        };
        if values.len() > limits.cec_max_points {
            let e = SiemensError::TooManyPoints {
                table: name.clone(),
                points: values.len(),
                max: limits.cec_max_points,
                machine_data: MACHINE_DATA,
            };
            return Err(located(e));
        }
        let positions = positions_from(&name, min, max, step, values.len()).map_err(located)?;
        let table = CecTable {
            index: t,
            input_axis,
            output_axis,
            positions,
            values,
            direction,
            mult_by_table,
            is_modulo,
        };
        table.check(limits).map_err(located)?;
        Ok(table)
    }
}
