//! Per-axis pitch tables: positioning compensation along one linear axis, LinuxCNC and CSV.

use crate::text::{Field, Source, csv_fields, data_lines, ws_fields};
use crate::{
    CompensateError, MM, UM, bracket, check_inputs, lerp, linear_axis, nodes_mm, read_file,
    write_file,
};
use mtcal_kinematics::{Machine, MachineModel};
use mtcal_machine::card::{AxisMap, ConventionCard, Quantity};
use nalgebra::Vector3;
use std::fmt::Write as _;
use std::path::Path;

/// Most triplets LinuxCNC holds for one joint (`EMCMOT_COMP_SIZE` in its motion controller).
pub const LINUXCNC_MAX_TRIPLETS: usize = 256;

const HEADER_UNI: [&str; 2] = ["position_mm", "compensation_um"];
const HEADER_BI: [&str; 3] = ["position_mm", "forward_um", "reverse_um"];

/// Direction of travel of an axis: forward is towards increasing positions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Travel {
    Forward,
    Reverse,
}

/// A pitch table of one linear axis: compensations (µm, what the controller adds to the
/// command, `−error` along the axis) at ascending positions (mm).
#[derive(Clone, Debug, PartialEq)]
pub struct PitchTable {
    /// Axis letter (`X`).
    pub axis: char,
    pub positions_mm: Vec<f64>,
    /// Compensation for forward travel; for both directions when `reverse_um` is `None`.
    pub forward_um: Vec<f64>,
    /// Compensation for reverse travel of a bidirectional table.
    pub reverse_um: Option<Vec<f64>>,
    /// Comment lines the CSV writer puts above the header (machine, held axes); not read back.
    pub note: String,
}

/// A linear axis' reversal for a bidirectional table: the signed ISO 230-2 reversal value
/// `B = x̄↑ − x̄↓` (µm) at the middle of a span of the axis' positions and its change from
/// there to the span's positive end (lost motion that grows along the stroke, a worn screw):
/// `B(x) = middle + change·û`, `û = (2x − lo − hi)/(hi − lo)` over the span — the form of
/// mtcal's `reversal` effect along the stroke. The span is what was measured (`span_mm`), or
/// the axis' limits; beyond a measured span `B` holds its value at the nearer end: a line
/// through a measured stretch says nothing about the rest of the stroke, and carried on it
/// would compensate a lost motion nobody saw. An axis that lags by half its backlash `b`
/// behind the command in the direction it last moved has `x̄↑ = −b/2`, `x̄↓ = +b/2`: `B = −b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reversal {
    pub middle_um: f64,
    pub change_um: f64,
    /// The positions `middle_um` and `change_um` are given over (mm); `None`: the stroke.
    pub span_mm: Option<(f64, f64)>,
}

impl Reversal {
    /// The same reversal value everywhere.
    pub fn constant(b_um: f64) -> Self {
        Reversal {
            middle_um: b_um,
            change_um: 0.0,
            span_mm: None,
        }
    }

    /// `B` at axis position `x_mm` of an axis whose stroke is `stroke_mm` (mm).
    pub fn at_um(&self, x_mm: f64, stroke_mm: (f64, f64)) -> f64 {
        if self.change_um == 0.0 {
            return self.middle_um;
        }
        let (lo, hi) = self.span_mm.unwrap_or(stroke_mm);
        let u = ((2.0 * x_mm - lo - hi) / (hi - lo)).clamp(-1.0, 1.0);
        self.middle_um + self.change_um * u
    }
}

/// A reversal of one axis found by an identification (a `reversal` discovery of the physics
/// search), for the bidirectional tables of that axis, and the words that say where it came
/// from (the card and the screen).
#[derive(Clone, Debug, PartialEq)]
pub struct AxisReversal {
    pub axis: char,
    pub reversal: Reversal,
    pub source: String,
}

impl PitchTable {
    /// The table in the controller's joint coordinates when its zero differs from the model's
    /// axis zero: every node position plus `joint_offset_mm` (LinuxCNC's joint position minus
    /// mtcal's axis position, e.g. from a home offset). The compensations stay as they are.
    pub fn shifted_mm(mut self, joint_offset_mm: f64) -> Self {
        if joint_offset_mm != 0.0 {
            for p in &mut self.positions_mm {
                *p += joint_offset_mm;
            }
            self.note.push_str(&format!(
                "\npositions shifted by {joint_offset_mm} mm to joint coordinates"
            ));
        }
        self
    }

    /// The bidirectional table: forward as now, reverse = forward + `reversal_um`, the signed
    /// ISO 230-2 reversal value `B = x̄↑ − x̄↓` in µm (a lost motion `b` is `B = −b`).
    pub fn with_reversal_um(self, reversal_um: f64) -> Self {
        self.with_reversal(&Reversal::constant(reversal_um), (0.0, 1.0))
    }

    /// The bidirectional table of a reversal that may change along the stroke: reverse =
    /// forward + `B(x)` at each node ([`Reversal::at_um`]; `stroke_mm` the axis' limits, the
    /// nodes' positions still mtcal's axis positions).
    pub fn with_reversal(mut self, reversal: &Reversal, stroke_mm: (f64, f64)) -> Self {
        self.reverse_um = Some(
            self.positions_mm
                .iter()
                .zip(&self.forward_um)
                .map(|(&x, f)| f + reversal.at_um(x, stroke_mm))
                .collect(),
        );
        self
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.positions_mm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions_mm.is_empty()
    }

    /// The compensations for `travel` at the nodes.
    pub fn compensation_um(&self, travel: Travel) -> &[f64] {
        match (travel, &self.reverse_um) {
            (Travel::Reverse, Some(r)) => r,
            _ => &self.forward_um,
        }
    }

    /// Compensation (µm) at `position_mm` for `travel`: linear between nodes, the end values
    /// outside them.
    pub fn correction_at_um(&self, position_mm: f64, travel: Travel) -> f64 {
        lerp(
            self.compensation_um(travel),
            bracket(&self.positions_mm, position_mm),
        )
    }
}

/// Unit vector (workpiece frame) in which a positive command of linear axis `axis` (index)
/// moves the tool relative to the workpiece on the nominal machine at positions `q` (SI).
pub fn travel_direction(machine: &Machine, q: &[f64], axis: usize) -> Vector3<f64> {
    // Any step works for a linear axis; 1 m keeps the difference exact to rounding.
    let mut q1 = q.to_vec();
    q1[axis] += 1.0;
    let d = machine.tool_in_workpiece(&q1).t - machine.tool_in_workpiece(q).t;
    d.normalize()
}

/// The pitch table of linear axis `axis` (letter): compensation `−error·direction` (µm) at
/// nodes from the lower limit in steps of `spacing_mm`, plus the upper limit; the other axes
/// held at `hold_q` (SI, every axis in canonical order; `crate::default_hold` gives linear
/// axes at mid-stroke and rotary axes at 0), the table's own entry ignored. Unidirectional;
/// see [`PitchTable::with_reversal_um`].
pub fn pitch_table(
    model: &MachineModel,
    coeffs: &[f64],
    axis: char,
    spacing_mm: f64,
    hold_q: &[f64],
) -> Result<PitchTable, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let machine = model.machine();
    let (i, lo, hi) = linear_axis(machine, axis)?;
    let positions_mm = nodes_mm(lo, hi, spacing_mm, &format!("pitch table of axis {axis}"))?;
    let mut q = hold_q.to_vec();
    let dir = travel_direction(machine, &q, i);
    let mut ws = model.workspace();
    let mut forward_um = Vec::with_capacity(positions_mm.len());
    for &p in &positions_mm {
        q[i] = p / MM;
        let e = model.pose_error(&q, coeffs, &mut ws);
        forward_um.push(-e.translation.dot(&dir) * UM);
    }
    Ok(PitchTable {
        axis,
        positions_mm,
        forward_um,
        reverse_um: None,
        note: hold_note(machine, hold_q, i),
    })
}

/// `machine: …` and `held: Y = … mm, A = … deg` comment text.
fn hold_note(machine: &Machine, hold_q: &[f64], skip: usize) -> String {
    let mut held = Vec::new();
    for (k, (a, &v)) in machine.axes().iter().zip(hold_q).enumerate() {
        if k == skip {
            continue;
        }
        let letter = a.letter();
        if letter.is_rotary() {
            held.push(format!("{} = {:.6} deg", letter.as_char(), v.to_degrees()));
        } else {
            held.push(format!("{} = {:.6} mm", letter.as_char(), v * MM));
        }
    }
    format!("machine: {}\nheld: {}", machine.name(), held.join(", "))
}

/// Writes `table` as a LinuxCNC `COMP_FILE_TYPE = 1` file (mm; see the crate doc),
/// atomically. A unidirectional table writes its compensation in both columns.
pub fn write_linuxcnc_comp(path: &Path, table: &PitchTable) -> Result<(), CompensateError> {
    if table.len() > LINUXCNC_MAX_TRIPLETS {
        return Err(CompensateError::TooManyNodes {
            what: format!("LinuxCNC compensation file for axis {}", table.axis),
            nodes: table.len(),
            max: LINUXCNC_MAX_TRIPLETS,
        });
    }
    let reverse = table.compensation_um(Travel::Reverse);
    let mut text = String::with_capacity(48 * table.len());
    for ((p, f), r) in table
        .positions_mm
        .iter()
        .zip(&table.forward_um)
        .zip(reverse)
    {
        let _ = writeln!(text, "{p:.6} {:.9} {:.9}", f / MM, r / MM);
    }
    write_file(path, &text)
}

/// Reads a LinuxCNC `COMP_FILE_TYPE = 1` file (triplets in mm) as the pitch table of `axis`.
/// The table is unidirectional when both columns agree at every node.
pub fn read_linuxcnc_comp(path: &Path, axis: char) -> Result<PitchTable, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let mut rows = Rows::default();
    for (n, line) in data_lines(&text, true) {
        let fields = ws_fields(line);
        src.expect_fields(n, line, &fields, 3, "nominal forward reverse, in mm")?;
        rows.push(&src, n, &fields, MM)?;
    }
    rows.finish(&src, &text, axis)
}

/// Writes `table` as a CSV pitch table (see the crate doc), atomically.
pub fn write_pitch_csv(path: &Path, table: &PitchTable) -> Result<(), CompensateError> {
    let mut text = format!(
        "# mtcal pitch table, axis {}: compensation (um) = what the controller adds to the \
         command = -(positioning error along the axis)\n",
        table.axis
    );
    for l in table.note.lines() {
        let _ = writeln!(text, "# {l}");
    }
    let cols = |h: &[&str]| h.join(",");
    match &table.reverse_um {
        None => {
            let _ = writeln!(text, "{}", cols(&HEADER_UNI));
            for (p, f) in table.positions_mm.iter().zip(&table.forward_um) {
                let _ = writeln!(text, "{p:.6},{f:.6}");
            }
        }
        Some(rev) => {
            let _ = writeln!(text, "{}", cols(&HEADER_BI));
            for ((p, f), r) in table.positions_mm.iter().zip(&table.forward_um).zip(rev) {
                let _ = writeln!(text, "{p:.6},{f:.6},{r:.6}");
            }
        }
    }
    write_file(path, &text)
}

/// Reads a CSV pitch table (either header) as the table of `axis`.
pub fn read_pitch_csv(path: &Path, axis: char) -> Result<PitchTable, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let mut lines = data_lines(&text, true);
    let Some((hn, header)) = lines.next() else {
        return Err(src.error(1, 1, "expected the header `position_mm,compensation_um`"));
    };
    let names: Vec<&str> = csv_fields(header).iter().map(|f| f.text.trim()).collect();
    let bidirectional = names == HEADER_BI;
    if !bidirectional && names != HEADER_UNI {
        let msg = format!(
            "expected the header `{}` or `{}`",
            HEADER_UNI.join(","),
            HEADER_BI.join(",")
        );
        return Err(src.error(hn, 1, msg));
    }
    let mut rows = Rows::default();
    for (n, line) in lines {
        let fields = csv_fields(line);
        if bidirectional {
            src.expect_fields(n, line, &fields, 3, "position_mm,forward_um,reverse_um")?;
            rows.push(&src, n, &fields, 1.0)?;
        } else {
            src.expect_fields(n, line, &fields, 2, "position_mm,compensation_um")?;
            let both = [fields[0], fields[1], fields[1]];
            rows.push(&src, n, &both, 1.0)?;
        }
    }
    let mut table = rows.finish(&src, &text, axis)?;
    if bidirectional && table.reverse_um.is_none() {
        table.reverse_um = Some(table.forward_um.clone());
    }
    Ok(table)
}

/// Rows read so far: position (mm), forward and reverse compensation (µm).
#[derive(Default)]
struct Rows {
    positions_mm: Vec<f64>,
    forward_um: Vec<f64>,
    reverse_um: Vec<f64>,
}

impl Rows {
    /// Adds `fields` = position, forward, reverse; compensations in file units, `um_per_unit`
    /// µm each.
    fn push(
        &mut self,
        src: &Source<'_>,
        n: usize,
        fields: &[Field<'_>],
        um_per_unit: f64,
    ) -> Result<(), CompensateError> {
        let p = src.number(n, fields[0])?;
        if let Some(&prev) = self.positions_mm.last()
            && p <= prev
        {
            let msg = format!("positions must ascend: {p} mm follows {prev} mm");
            return Err(src.error(n, fields[0].column, msg));
        }
        self.positions_mm.push(p);
        self.forward_um
            .push(src.number(n, fields[1])? * um_per_unit);
        self.reverse_um
            .push(src.number(n, fields[2])? * um_per_unit);
        Ok(())
    }

    fn finish(
        self,
        src: &Source<'_>,
        text: &str,
        axis: char,
    ) -> Result<PitchTable, CompensateError> {
        if self.positions_mm.is_empty() {
            let line = text.lines().count() + 1;
            return Err(src.error(line, 1, "expected at least one row, found none"));
        }
        let reverse_um = (self.reverse_um != self.forward_um).then_some(self.reverse_um);
        Ok(PitchTable {
            axis,
            positions_mm: self.positions_mm,
            forward_um: self.forward_um,
            reverse_um,
            note: String::new(),
        })
    }
}

/// The file format of a pitch table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PitchFormat {
    /// LinuxCNC's `COMP_FILE_TYPE = 1` ([`crate::write_linuxcnc_comp`]).
    LinuxCnc,
    /// The CSV pitch table ([`crate::write_pitch_csv`]).
    Csv,
}

impl PitchFormat {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PitchFormat::LinuxCnc => "linuxcnc",
            PitchFormat::Csv => "csv",
        }
    }
}

const LINEAR_ONLY: &str = "not applicable: a linear axis' table";
const NO_SQUARENESS: &str = "not held: a pitch table holds positioning along its own axis only (use the grid or the error \
     parameters for squareness)";

/// The card of a pitch table of `axis`.
pub(crate) fn card(
    format: PitchFormat,
    axis: char,
    joint_offset_mm: f64,
    reversal_source: Option<&str>,
) -> ConventionCard {
    let control = if joint_offset_mm == 0.0 {
        format!("{axis} (same zero)")
    } else {
        format!("{axis} (joint position = axis position {joint_offset_mm:+} mm)")
    };
    let mut card = ConventionCard {
        made_from: Vec::new(),
        format: String::new(),
        quantity: Quantity::Correction,
        sign: String::new(),
        squareness: NO_SQUARENESS.into(),
        rotary_direction: LINEAR_ONLY.into(),
        axis_mapping: vec![AxisMap {
            mtcal: axis,
            control,
        }],
        units: String::new(),
        control_will: Vec::new(),
    };
    match format {
        PitchFormat::Csv => {
            card.format = "mtcal CSV pitch table".into();
            card.sign = "compensation = −(positioning error along the axis): added to the \
                         command, the tool lands where it was commanded"
                .into();
            card.units = "positions mm, compensations µm".into();
            card.control_will
                .push("interpolate linearly between nodes and hold the end values outside".into());
        }
        PitchFormat::LinuxCnc => {
            card.format = "LinuxCNC axis compensation file, COMP_FILE_TYPE = 1".into();
            card.sign = "LinuxCNC adds the trim to the commanded joint position: column 2 while \
                         the joint moves forward, column 3 in reverse"
                .into();
            card.units = "machine units: positions and trims in mm (LINEAR_UNITS = mm)".into();
            card.control_will.extend([
                "read it from [JOINT_n] COMP_FILE with COMP_FILE_TYPE = 1 after a restart; \
                 remove BACKLASH (the file replaces it)"
                    .into(),
                "interpolate linearly between the ≤ 256 triplets and hold the end values outside"
                    .into(),
                "stop reading at the first line that is not a triplet, so this card is written \
                 beside the file (FILE.card.txt), not in it"
                    .into(),
            ]);
        }
    }
    if let Some(source) = reversal_source {
        card.control_will.push(format!(
            "use the forward values while the axis moves in +, the reverse values in −: \
             reverse = forward + B (ISO 230-2 reversal value B = x̄↑ − x̄↓), from {source}"
        ));
    }
    card
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lost motion growing along the stroke (mtcal's `reversal` along the stroke: `B` at the
    /// middle, `ΔB` to the positive end) gives each node its own reverse offset, linear in the
    /// position over the axis' limits — not over the table's nodes, which may not reach them.
    #[test]
    fn a_reversal_measured_over_part_of_the_stroke_holds_its_ends_beyond_it() {
        let r = Reversal {
            middle_um: -3.0,
            change_um: -1.0,
            span_mm: Some((10.0, 30.0)),
        };
        let stroke = (-200.0, 200.0);
        // Over the span: the line through it (−3 at 20 mm, −4 at 30 mm).
        for (x, want) in [(10.0, -2.0), (20.0, -3.0), (25.0, -3.5), (30.0, -4.0)] {
            assert!((r.at_um(x, stroke) - want).abs() < 1e-12, "at {x} mm");
        }
        // Beyond it: the nearer end's value, not the line carried on (−22 µm at 200 mm).
        for (x, want) in [(-200.0, -2.0), (0.0, -2.0), (31.0, -4.0), (200.0, -4.0)] {
            assert_eq!(r.at_um(x, stroke), want, "at {x} mm");
        }
    }

    #[test]
    fn a_reversal_along_the_stroke_gives_each_node_its_own_offset() {
        let table = PitchTable {
            axis: 'X',
            positions_mm: vec![-100.0, 0.0, 50.0, 100.0],
            forward_um: vec![1.0, 2.0, 3.0, 4.0],
            reverse_um: None,
            note: String::new(),
        };
        let r = Reversal {
            middle_um: -3.0,
            change_um: -1.0,
            span_mm: None,
        };
        let bi = table.with_reversal(&r, (-200.0, 200.0));
        let reverse = bi.reverse_um.clone().unwrap();
        for ((x, f), rev) in bi.positions_mm.iter().zip(&bi.forward_um).zip(&reverse) {
            let want = f - 3.0 - x / 200.0;
            assert!((rev - want).abs() < 1e-12, "at {x} mm: {rev}, want {want}");
        }
        // A constant one is the old bidirectional table.
        let constant = PitchTable {
            reverse_um: None,
            ..bi.clone()
        }
        .with_reversal_um(-2.5);
        assert_eq!(constant.reverse_um.unwrap(), vec![-1.5, -0.5, 0.5, 1.5]);
    }
}
