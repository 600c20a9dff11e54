//! Measuring-system error compensation (MSEC/LEC) tables, file `%_N_AX_EEC_INI`.

use super::ini::{self, Kind, Place};
use super::{
    Blame, Grid, SiemensError, SiemensLimits, any_rotary, control_name, equidistant_nodes_mm,
    mapping_for, min_max_step, positions_from,
};
use crate::text::{Field, Source};
use crate::{
    AxisMap, CompensateError, ConventionCard, MM, PitchTable, Quantity, ROTARY_RIGHT_HAND,
    check_inputs, linear_axis, read_file, travel_direction, write_file,
};
use mtcal_kinematics::{AxisKind, MachineModel};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The name line of the file.
pub const EEC_FILE_NAME: &str = "%_N_AX_EEC_INI";
const MACHINE_DATA: &str = "MD38000 $MA_MM_ENC_COMP_MAX_POINTS";

/// One axis' MSEC table: the values of `$AA_ENC_COMP[e,N,axis]` at equidistant positions.
#[derive(Clone, Debug, PartialEq)]
pub struct EecTable {
    /// The control's machine axis name (`X1`, `AX1`): the `AXi` of `$AA_ENC_COMP[e,N,AXi]`.
    pub axis: String,
    /// The measuring system `e`: 0 for the first, 1 for the second.
    pub encoder: usize,
    /// Interpolation-point positions, ascending and equidistant: mm on a linear axis, degrees
    /// on a rotary axis.
    pub positions: Vec<f64>,
    /// The compensation values as the control reads them: the axis' error at each point
    /// (actual − commanded along its positive direction), mm (degrees on a rotary axis).
    pub values: Vec<f64>,
    /// `$AA_ENC_COMP_IS_MODULO`: the table repeats with period MAX − MIN (rotary axes).
    pub is_modulo: bool,
    /// Where the table was made zero ([`EecTable::relative_to`]); `None` for the absolute
    /// error (and for a table read from a file, which does not say).
    pub reference: Option<EecReference>,
}

/// Where an EEC table is zero and what that removed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EecReference {
    /// The reference point: mm on a linear axis, degrees on a rotary axis.
    pub position: f64,
    /// The table's value there before, subtracted from every point (mm or degrees).
    pub removed: f64,
}

impl EecTable {
    /// The table of the first measuring system of `axis` (control name) with errors `values`
    /// at `positions`, as a rotary positioning table or a pitch table gives them.
    pub fn new(
        axis: impl Into<String>,
        positions: Vec<f64>,
        values: Vec<f64>,
        is_modulo: bool,
    ) -> Self {
        EecTable {
            axis: axis.into(),
            encoder: 0,
            positions,
            values,
            is_modulo,
            reference: None,
        }
    }

    /// The table's name in messages: `$AA_ENC_COMP[0,N,X1]`.
    pub fn name(&self) -> String {
        format!("$AA_ENC_COMP[{},N,{}]", self.encoder, self.axis)
    }

    fn grid<'a>(&'a self, name: &'a str) -> Grid<'a> {
        Grid {
            name,
            positions: &self.positions,
            values: &self.values,
            is_modulo: self.is_modulo,
        }
    }

    /// Checks the table against the control's limits: axis name, measuring system, at most
    /// MD38000 points, ascending, equidistant, finite, values within the bound, equal end
    /// values when modulo.
    pub fn check(&self, limits: &SiemensLimits) -> Result<(), SiemensError> {
        super::check_axis_name(&self.axis)?;
        let name = self.name();
        if self.encoder > 1 {
            let (table, encoder) = (name, self.encoder);
            return Err(SiemensError::Encoder { table, encoder });
        }
        self.grid(&name).check(
            limits.enc_comp_max_points,
            MACHINE_DATA,
            limits.max_abs_value,
        )
    }

    /// The value the control applies at `position` (mm or degrees): linear between points,
    /// the end values held beyond them, repeated when modulo. The table must not be empty.
    pub fn value_at(&self, position: f64) -> f64 {
        self.grid("").value_at(position)
    }

    /// The table minus its value at `position` (e.g. the reference point, where K3 recommends
    /// a zero value so that the axis does not jump when compensation starts). This shifts the
    /// axis by a constant, which the work offset absorbs.
    pub fn relative_to(mut self, position: f64) -> Self {
        let at = self.value_at(position);
        for v in &mut self.values {
            *v -= at;
        }
        let removed = at + self.reference.map_or(0.0, |r| r.removed);
        self.reference = Some(EecReference { position, removed });
        self
    }
}

/// The EEC table of linear axis `axis` (mtcal letter): its error along its own positive
/// travel direction (mm) at equidistant points over its stroke ([`equidistant_nodes_mm`] with
/// `spacing_mm`), the other axes at `hold_q` (SI, every axis; see [`crate::default_hold`]),
/// named by `names` (see [`super::siemens_axis_names`]).
pub fn siemens_eec_table(
    model: &MachineModel,
    coeffs: &[f64],
    axis: char,
    spacing_mm: f64,
    hold_q: &[f64],
    names: &[AxisMap],
) -> Result<EecTable, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let machine = model.machine();
    let (i, lo, hi) = linear_axis(machine, axis)?;
    let control = control_name(names, axis)?;
    let what = format!("Siemens EEC table of axis {axis}");
    let positions = equidistant_nodes_mm(lo, hi, spacing_mm, &what)?;
    let dir = travel_direction(machine, hold_q, i);
    let mut q = hold_q.to_vec();
    let mut ws = model.workspace();
    let values = positions
        .iter()
        .map(|&p| {
            q[i] = p / MM;
            model.pose_error(&q, coeffs, &mut ws).translation.dot(&dir) * MM
        })
        .collect();
    Ok(EecTable::new(control, positions, values, false))
}

/// The EEC table of rotary axis `axis`: its angular positioning error about its own positive
/// turn direction (degrees; the error `−compensation` of [`crate::rotary_table`]) at equidistant
/// points, the largest step not above `spacing_deg` that divides the range (0…360° for an axis
/// without limits, then a modulo table whose end values are the same point's), the other axes
/// at `hold_q`.
pub fn siemens_eec_rotary_table(
    model: &MachineModel,
    coeffs: &[f64],
    axis: char,
    spacing_deg: f64,
    hold_q: &[f64],
    names: &[AxisMap],
) -> Result<EecTable, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let (i, lo_deg, hi_deg, full_turn) = crate::rotary::rotary_axis(model.machine(), axis)?;
    let control = control_name(names, axis)?;
    if !(spacing_deg.is_finite() && spacing_deg > 0.0) {
        return Err(CompensateError::BadSpacing {
            spacing_mm: spacing_deg,
        });
    }
    let steps = ((hi_deg - lo_deg) / spacing_deg - 1e-9).ceil().max(1.0) as usize;
    let step = (hi_deg - lo_deg) / steps as f64;
    let positions: Vec<f64> = (0..=steps).map(|k| lo_deg + step * k as f64).collect();
    let table = crate::rotary::rotary_table_at(model, coeffs, i, positions, hold_q, full_turn);
    let mut values: Vec<f64> = table
        .compensation_urad
        .iter()
        .map(|c| (-c / crate::UM).to_degrees())
        .collect();
    if full_turn {
        // 0° and 360° are one position: one value, so the modulo table closes exactly.
        values[steps] = values[0];
    }
    Ok(EecTable::new(
        control,
        table.positions_deg,
        values,
        full_turn,
    ))
}

/// [`siemens_eec_table`] of every linear axis, in the machine's axis order.
pub fn siemens_eec_tables(
    model: &MachineModel,
    coeffs: &[f64],
    spacing_mm: f64,
    hold_q: &[f64],
    names: &[AxisMap],
) -> Result<Vec<EecTable>, CompensateError> {
    model
        .machine()
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Linear)
        .map(|a| {
            siemens_eec_table(
                model,
                coeffs,
                a.letter().as_char(),
                spacing_mm,
                hold_q,
                names,
            )
        })
        .collect()
}

/// The EEC table of a unidirectional pitch table whose nodes are equidistant: values are
/// `−compensation` in mm (Siemens' table holds the error). `control_axis` is the machine axis
/// name. A bidirectional table is refused ([`SiemensError::Bidirectional`]), and so is one
/// whose last interval is shorter ([`SiemensError::UnequalSteps`]).
pub fn eec_from_pitch(table: &PitchTable, control_axis: &str) -> Result<EecTable, CompensateError> {
    if table.reverse_um.is_some() {
        return Err(SiemensError::Bidirectional { axis: table.axis }.into());
    }
    let values = table.forward_um.iter().map(|c| -c / 1e3).collect();
    let eec = EecTable::new(control_axis, table.positions_mm.clone(), values, false);
    super::check_axis_name(&eec.axis)?;
    let name = eec.name();
    eec.grid(&name)
        .check(usize::MAX, MACHINE_DATA, f64::INFINITY)?;
    Ok(eec)
}

/// Checks every table and that no axis' measuring system has two.
fn check_eec(tables: &[EecTable], limits: &SiemensLimits) -> Result<(), SiemensError> {
    for (k, t) in tables.iter().enumerate() {
        t.check(limits)?;
        let twice = tables[..k]
            .iter()
            .any(|u| u.axis == t.axis && u.encoder == t.encoder);
        if twice {
            return Err(SiemensError::DuplicateTable { table: t.name() });
        }
    }
    Ok(())
}

/// The convention card of an EEC file of `tables`, axes named by `names`.
pub fn eec_card(tables: &[EecTable], names: &[AxisMap]) -> ConventionCard {
    let used = || tables.iter().map(|t| t.axis.as_str());
    let rotary = any_rotary(names, used());
    ConventionCard {
        made_from: Vec::new(),
        format: format!(
            "SINUMERIK 840D sl measuring system error compensation (MSEC/LEC), {EEC_FILE_NAME}"
        ),
        quantity: Quantity::Error,
        sign: "$AA_ENC_COMP[e,N,AXi] is the axis' error at point N along its own positive \
               direction (actual − commanded position of the tool relative to the workpiece); \
               K3: the control modifies the axis' actual value by it and a positive value moves \
               the axis in its negative direction"
            .into(),
        squareness: "not carried: an EEC table acts along its own axis only; squareness and \
                     straightness need CEC tables (siemens-cec)"
            .into(),
        rotary_direction: if rotary {
            ROTARY_RIGHT_HAND.into()
        } else {
            "no rotary axis in this file".into()
        },
        axis_mapping: mapping_for(names, used()),
        units: "positions ($AA_ENC_COMP_MIN, _MAX, _STEP) and values in mm (degrees on a rotary \
                axis), values to 1 nm; e = 0 is the first measuring system"
            .into(),
        control_will: vec![
            "interpolate linearly between the equidistant points MIN + N × STEP, hold the first \
             value below MIN and the last above MAX (a table with _IS_MODULO = 1 repeats \
             instead), and move the axis by −value"
                .into(),
            "accept the file only while MD32700 $MA_ENC_COMP_ENABLE[e] = 0 (with 1 the table is \
             write-protected, alarm 17070) and MD38000 $MA_MM_ENC_COMP_MAX_POINTS ≥ the points \
             of each table (changing MD38000 reformats the static user memory at the next power \
             on: back it up first)"
                .into(),
            referenced(tables, names),
            "not hold errors across the axis, squareness, angular errors except through their \
             Abbe offsets at the held positions (comment `held`), nor a difference between the \
             directions of travel"
                .into(),
        ],
    }
}

/// What the card says of the tables' reference points: K3 (leadscrew/encoder error
/// compensation) asks for the value 0 at the reference point, so that the axis does not jump
/// when compensation starts.
fn referenced(tables: &[EecTable], names: &[AxisMap]) -> String {
    let start = "compensate after MD32700 = 1, power on and referencing the axis; K3 wants the \
                 value 0 at the reference point (no jump at activation)";
    let points: Option<Vec<String>> = tables
        .iter()
        .map(|t| {
            let r = t.reference?;
            let (unit, small) = if any_rotary(names, std::iter::once(t.axis.as_str())) {
                ("deg", "mdeg")
            } else {
                ("mm", "um")
            };
            Some(format!(
                "{} zero at {} {unit} ({:+.3} {small} removed)",
                t.name(),
                r.position,
                r.removed * 1e3
            ))
        })
        .collect();
    match points {
        Some(p) if !p.is_empty() => format!(
            "{start}: each table is referenced so — {} — and the constant removed shifts the \
             axis, which the work offset absorbs",
            p.join("; ")
        ),
        _ => format!(
            "{start}: this file holds the absolute modelled error (the work offset absorbs \
             the constant; `compensate --reference-mm` references each table)"
        ),
    }
}

/// The file text of `tables` with `card` and `note` (e.g. [`super::siemens_note`]) as comments,
/// after checking them against `limits`.
pub fn siemens_eec_text(
    tables: &[EecTable],
    card: &ConventionCard,
    note: &str,
    limits: &SiemensLimits,
) -> Result<String, CompensateError> {
    check_eec(tables, limits)?;
    let mut out = String::new();
    let title = "mtcal: SINUMERIK measuring system error compensation tables";
    ini::preamble(&mut out, EEC_FILE_NAME, title, card, note);
    for t in tables {
        table_text(&mut out, t);
    }
    out.push_str("M17\n");
    Ok(out)
}

fn table_text(out: &mut String, t: &EecTable) {
    let (min, max, step) = min_max_step(&t.positions);
    let (e, ax) = (t.encoder, &t.axis);
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
    for (k, v) in t.values.iter().enumerate() {
        // A modulo table's ends agree to 1e-9; the same text keeps them equal after rounding.
        let v = if t.is_modulo && k + 1 == n {
            t.values[0]
        } else {
            *v
        };
        let _ = writeln!(out, "$AA_ENC_COMP[{e},{k},{ax}]={}", ini::real_text(v, 6));
    }
    let _ = writeln!(
        out,
        "$AA_ENC_COMP_STEP[{e},{ax}]={}",
        ini::real_text(step, 9)
    );
    let _ = writeln!(out, "$AA_ENC_COMP_MIN[{e},{ax}]={}", ini::real_text(min, 9));
    let _ = writeln!(out, "$AA_ENC_COMP_MAX[{e},{ax}]={}", ini::real_text(max, 9));
    let _ = writeln!(
        out,
        "$AA_ENC_COMP_IS_MODULO[{e},{ax}]={}",
        u8::from(t.is_modulo)
    );
}

/// Writes [`siemens_eec_text`] to `path` atomically.
pub fn write_siemens_eec(
    path: &Path,
    tables: &[EecTable],
    card: &ConventionCard,
    note: &str,
    limits: &SiemensLimits,
) -> Result<(), CompensateError> {
    write_file(path, &siemens_eec_text(tables, card, note, limits)?)
}

/// Reads an EEC file, checking every table against `limits`; errors name file, line, column.
pub fn read_siemens_eec(
    path: &Path,
    limits: &SiemensLimits,
) -> Result<Vec<EecTable>, CompensateError> {
    read_siemens_eec_str(&read_file(path)?, path, limits)
}

/// [`read_siemens_eec`] of `text`, naming `file` in errors.
pub fn read_siemens_eec_str(
    text: &str,
    file: &Path,
    limits: &SiemensLimits,
) -> Result<Vec<EecTable>, CompensateError> {
    let src = Source { file };
    let statements = ini::statements(&src, text)?;
    let body = ini::frame(&src, text, &statements, EEC_FILE_NAME)?;
    let mut accs: Vec<Acc> = Vec::new();
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
    // One accumulator per axis and measuring system: no table can come twice.
    accs.iter().map(|a| a.table(&src, limits)).collect()
}

/// What the file assigns to one axis' table, with places.
struct Acc {
    encoder: usize,
    axis: String,
    first: Place,
    values: BTreeMap<usize, (f64, Place)>,
    step: Option<(f64, Place)>,
    min: Option<(f64, Place)>,
    max: Option<(f64, Place)>,
    modulo: Option<(bool, Place)>,
}

/// Adds one assignment to the accumulator of its table.
fn assign(
    src: &Source<'_>,
    accs: &mut Vec<Acc>,
    at: Place,
    name: Field<'_>,
    args: &[Field<'_>],
    value: Field<'_>,
) -> Result<(), CompensateError> {
    let line = at.0;
    let (n_args, form) = match name.text {
        "$AA_ENC_COMP" => (3, "[e,N,axis]"),
        "$AA_ENC_COMP_STEP"
        | "$AA_ENC_COMP_MIN"
        | "$AA_ENC_COMP_MAX"
        | "$AA_ENC_COMP_IS_MODULO" => (2, "[e,axis]"),
        other => {
            let msg = format!(
                "`{other}` is no EEC table variable (expected $AA_ENC_COMP, \
                 $AA_ENC_COMP_STEP, _MIN, _MAX or _IS_MODULO)"
            );
            return Err(src.error(line, name.column, msg));
        }
    };
    ini::expect_args(src, line, name, args, n_args, form)?;
    let encoder = ini::index(src, line, args[0])?;
    if encoder > 1 {
        let msg = format!("measuring system index {encoder}; it must be 0 or 1");
        return Err(src.error(line, args[0].column, msg));
    }
    let axis = ini::axis(src, line, args[n_args - 1])?;
    let k = match accs
        .iter()
        .position(|a| a.encoder == encoder && a.axis == axis)
    {
        Some(k) => k,
        None => {
            accs.push(Acc::new(encoder, axis, at));
            accs.len() - 1
        }
    };
    let acc = &mut accs[k];
    let place = (line, value.column);
    let twice = |first: Place| {
        let msg = format!(
            "`{}` is assigned twice (first on line {})",
            name.text, first.0
        );
        src.error(line, name.column, msg)
    };
    match name.text {
        "$AA_ENC_COMP" => {
            let n = ini::index(src, line, args[1])?;
            let v = ini::real(src, line, value)?;
            if let Some((_, first)) = acc.values.insert(n, (v, place)) {
                return Err(twice(first));
            }
        }
        "$AA_ENC_COMP_IS_MODULO" => {
            let v = ini::flag(src, line, value)?;
            if let Some((_, first)) = acc.modulo.replace((v, place)) {
                return Err(twice(first));
            }
        }
        _ => {
            let v = ini::real(src, line, value)?;
            let slot = match name.text {
                "$AA_ENC_COMP_STEP" => &mut acc.step,
                "$AA_ENC_COMP_MIN" => &mut acc.min,
                _ => &mut acc.max,
            };
            if let Some((_, first)) = slot.replace((v, place)) {
                return Err(twice(first));
            }
        }
    }
    Ok(())
}

impl Acc {
    fn new(encoder: usize, axis: String, first: Place) -> Self {
        Acc {
            encoder,
            axis,
            first,
            values: BTreeMap::new(),
            step: None,
            min: None,
            max: None,
            modulo: None,
        }
    }

    fn name(&self) -> String {
        format!("$AA_ENC_COMP[{},N,{}]", self.encoder, self.axis)
    }

    /// The table, or the located reason the control would refuse or misread it.
    fn table(&self, src: &Source<'_>, limits: &SiemensLimits) -> Result<EecTable, CompensateError> {
        let name = self.name();
        let at_first = |msg: String| src.error(self.first.0, self.first.1, msg);
        let missing = |var: &str| {
            at_first(format!(
                "{name}: `{var}[{},{}]` is not assigned (the control would keep an earlier value)",
                self.encoder, self.axis
            ))
        };
        let (step, step_at) = self.step.ok_or_else(|| missing("$AA_ENC_COMP_STEP"))?;
        let (min, _) = self.min.ok_or_else(|| missing("$AA_ENC_COMP_MIN"))?;
        let (max, max_at) = self.max.ok_or_else(|| missing("$AA_ENC_COMP_MAX"))?;
        let (is_modulo, _) = self
            .modulo
            .ok_or_else(|| missing("$AA_ENC_COMP_IS_MODULO"))?;
        let values = super::complete_values(src, &name, &self.values, self.first)?;
        let place = |blame: Blame| match blame {
            Blame::Value(i) => self.values.get(&i).map_or(self.first, |v| v.1),
            Blame::Step => step_at,
            Blame::Max => max_at,
            Blame::Mult | Blame::Table => self.first,
        };
        let located = |e: SiemensError| {
            let (line, column) = place(e.blame());
            src.error(line, column, e.to_string())
        };
        if values.len() > limits.enc_comp_max_points {
            let e = SiemensError::TooManyPoints {
                table: name.clone(),
                points: values.len(),
                max: limits.enc_comp_max_points,
                machine_data: MACHINE_DATA,
            };
            return Err(located(e));
        }
        let positions = positions_from(&name, min, max, step, values.len()).map_err(located)?;
        let table = EecTable {
            axis: self.axis.clone(),
            encoder: self.encoder,
            positions,
            values,
            is_modulo,
            reference: None,
        };
        table.check(limits).map_err(located)?;
        Ok(table)
    }
}
