//! ISO 230-1 error parameters for controllers that model the machine themselves: the
//! ISG/Beckhoff TF5280 `ISG_CSV` format and the Etalon Exchange Format (`ETALON_EXCHANGE`).
//!
//! Such a controller does not take a table of compensations; it takes the machine's *errors*
//! (component errors as look-up tables over their axis, location errors as constants) and
//! computes the compensation of every pose through its own kinematic model. The conventions
//! are in the crate documentation ("Error-parameter files"); in short: values in mm and rad,
//! arguments in mm and degrees, names as ISO 230-1 without the location errors' leading `E`
//! (`EXX`, `C0Y`, `X0C`), mtcal's sign conventions (which are ISO 230-1's), errors (not
//! compensations), set-up offsets left out.

use crate::text::{Field, Source, ws_fields};
use crate::{CompensateError, MM, read_file, write_file};
use mtcal_kinematics::model::Role;
use mtcal_kinematics::model::default_stroke;
use mtcal_kinematics::{AxisKind, Basis, Machine, MachineModel, ParamConfig, ParamName};
use mtcal_machine::card::{ConventionCard, Quantity, ROTARY_RIGHT_HAND, SQUARENESS_ISO};
use std::fmt::Write as _;
use std::path::Path;

/// Most rows one table may have (a guard against a spacing typed in the wrong unit).
const MAX_TABLE_ROWS: usize = 100_000;

/// The value of one error parameter, in file units: mm for translations, rad for rotations.
#[derive(Clone, Debug, PartialEq)]
pub enum ParameterValue {
    /// A location error (squareness, position or orientation of a rotary axis).
    Constant(f64),
    /// A component error sampled over its own axis: `args` ascend (mm for linear axes,
    /// degrees for rotary axes), one value per argument.
    Table { args: Vec<f64>, values: Vec<f64> },
}

/// One named error parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorParameter {
    pub name: ParamName,
    pub value: ParameterValue,
}

/// A machine's error parameters as a controller file holds them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ErrorParameters {
    pub params: Vec<ErrorParameter>,
}

/// Which controller file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParameterFormat {
    /// Beckhoff TF5280 / ISG kernel tabular format (`file_format ISG_CSV`).
    IsgCsv,
    /// Etalon Exchange Format, "Vendor" variant (`file_format ETALON_EXCHANGE`).
    Etalon,
}

/// The error parameters of `model` with coefficients `coeffs` (SI, as `load_params` gives):
/// every component error sampled at nodes `spacing_mm` apart over a linear axis' stroke, or
/// `spacing_deg` apart over a rotary axis' (0…360° for an axis without limits); every
/// location error as a constant. Set-up parameters (`TOOL_*`, `WP_*`) belong to the set-up,
/// not the machine, and are left out.
pub fn error_parameters(
    model: &MachineModel,
    coeffs: &[f64],
    spacing_mm: f64,
    spacing_deg: f64,
) -> Result<ErrorParameters, CompensateError> {
    if coeffs.len() != model.n_coeffs() {
        return Err(CompensateError::CoeffsLength {
            got: coeffs.len(),
            expected: model.n_coeffs(),
        });
    }
    let machine = model.machine();
    let mut params = Vec::new();
    for p in model.errors().params() {
        let c = &coeffs[p.offset..p.offset + p.len];
        let scale = if p.name.direction().is_rotation() {
            1.0
        } else {
            MM
        };
        let value = match &p.role {
            Role::Component { axis, basis, .. } => {
                let args = argument_nodes(machine, *axis, spacing_mm, spacing_deg, &p.name)?;
                let si = si_per_argument(machine, *axis);
                let values = args.iter().map(|&a| basis.value(a * si, c) * scale);
                ParameterValue::Table {
                    values: values.collect(),
                    args,
                }
            }
            Role::Location { .. } => ParameterValue::Constant(c[0] * scale),
            Role::ToolOffset(_) | Role::WorkpieceOffset(_) => continue,
        };
        params.push(ErrorParameter {
            name: p.name,
            value,
        });
    }
    Ok(ErrorParameters { params })
}

/// SI units (m or rad) per file argument unit (mm or degree) of axis `axis`.
fn si_per_argument(machine: &Machine, axis: usize) -> f64 {
    match machine.axes()[axis].kind() {
        AxisKind::Linear => 1.0 / MM,
        AxisKind::Rotary => 1f64.to_radians(),
    }
}

/// Argument nodes of a component error of axis `axis`, in file units.
fn argument_nodes(
    machine: &Machine,
    axis: usize,
    spacing_mm: f64,
    spacing_deg: f64,
    name: &ParamName,
) -> Result<Vec<f64>, CompensateError> {
    let ax = &machine.axes()[axis];
    let what = format!("table of {name}");
    match (ax.kind(), ax.limits()) {
        (AxisKind::Linear, _) => {
            let (lo, hi) = default_stroke(machine, axis);
            crate::nodes_mm(lo, hi, spacing_mm, &what)
        }
        (AxisKind::Rotary, Some((lo, hi))) => {
            crate::nodes_in(lo.to_degrees(), hi.to_degrees(), spacing_deg, &what)
        }
        (AxisKind::Rotary, None) => crate::nodes_in(0.0, 360.0, spacing_deg, &what),
    }
}

impl ErrorParameters {
    /// The machine model a controller builds from these parameters: each component error a
    /// piecewise-linear table over its nodes (held at the end values outside them), each
    /// location error a constant, on `machine`'s nominal geometry. Returns the model and its
    /// coefficients (SI). Errors if a parameter does not fit the machine.
    pub fn model(&self, machine: &Machine) -> Result<(MachineModel, Vec<f64>), CompensateError> {
        let mut config = Vec::with_capacity(self.params.len());
        let mut coeffs = Vec::new();
        for p in &self.params {
            let scale = if p.name.direction().is_rotation() {
                1.0
            } else {
                1.0 / MM
            };
            let basis = match &p.value {
                ParameterValue::Constant(v) => {
                    coeffs.push(v * scale);
                    None
                }
                ParameterValue::Table { args, values } => {
                    let axis = p.name.axis().map(|a| a.as_char()).unwrap_or('?');
                    let i =
                        machine
                            .axis_index(axis)
                            .ok_or_else(|| CompensateError::NoSuchAxis {
                                letter: axis,
                                letters: machine.letters(),
                            })?;
                    let si = si_per_argument(machine, i);
                    let knots = args.iter().map(|a| a * si).collect();
                    coeffs.extend(values.iter().map(|v| v * scale));
                    Some(
                        Basis::table(knots, false, false).map_err(|e| CompensateError::Model {
                            message: format!("{}: {e}", p.name),
                        })?,
                    )
                }
            };
            config.push(ParamConfig {
                name: p.name,
                basis,
            });
        }
        let model =
            MachineModel::new(machine.clone(), &config).map_err(|e| CompensateError::Model {
                message: e.to_string(),
            })?;
        Ok((model, coeffs))
    }

    fn constants(&self) -> impl Iterator<Item = (&ParamName, f64)> {
        self.params.iter().filter_map(|p| match p.value {
            ParameterValue::Constant(v) => Some((&p.name, v)),
            ParameterValue::Table { .. } => None,
        })
    }
}

/// The name as the controller files spell it: component errors as ISO 230-1 (`EXY`),
/// location errors without the leading `E` (`C0Y`, `X0C`).
fn file_name(name: &ParamName) -> String {
    match name {
        ParamName::Location { .. } => name.to_string()[1..].to_string(),
        _ => name.to_string(),
    }
}

/// Parses a controller-file name: `EXY` (component) or `C0Y` (location). Set-up and ISG's
/// own kinematic parameters (`P0X`, `PXA`, `VXX`…) are not error parameters here.
fn parse_file_name(text: &str) -> Option<ParamName> {
    let b = text.as_bytes();
    if b.len() != 3 || !text.is_ascii() {
        return None;
    }
    let name: ParamName = if b[1] == b'0' {
        format!("E{text}").parse().ok()?
    } else if b[0] == b'E' {
        text.parse().ok()?
    } else {
        return None;
    };
    matches!(
        name,
        ParamName::Component { .. } | ParamName::Location { .. }
    )
    .then_some(name)
}

/// A value in its file unit, enough decimals to reproduce the model far below 0.1 µm.
fn value_text(name: &ParamName, v: f64) -> String {
    if name.direction().is_rotation() {
        format!("{v:.12}")
    } else {
        format!("{v:.9}")
    }
}

/// The comment lines every file starts with (`//`).
fn header(machine: &Machine, format: &str) -> String {
    let (work, tool): (Vec<_>, Vec<_>) = machine
        .axes()
        .iter()
        .partition(|a| a.side() == mtcal_kinematics::Side::Workpiece);
    let letters = |v: Vec<&mtcal_kinematics::machine::Axis>| {
        v.iter()
            .map(|a| a.letter().as_char().to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    format!(
        "// mtcal error parameters ({format}), machine {}\n\
         // ERRORS (not compensations) in the ISO 230-1 sign convention; the controller negates\n\
         // them itself. Values: mm (translations), rad (rotations). Arguments: mm (linear axes),\n\
         // degrees (rotary axes). Component errors are functional: the motion of the tool\n\
         // relative to the workpiece the axis causes, in machine X/Y/Z. Squareness C0Y > 0 opens\n\
         // the angle between +X and +Y beyond 90 deg.\n\
         // Workpiece-side axes: {}; tool-side axes: {} (the list file's workpiece_axes = {}).\n",
        machine.name(),
        if work.is_empty() {
            "none".to_string()
        } else {
            letters(work.clone())
        },
        letters(tool),
        work.len(),
    )
}

/// Writes `params` in `format` to `path`, atomically.
pub fn write_error_parameters(
    path: &Path,
    machine: &Machine,
    params: &ErrorParameters,
    format: ParameterFormat,
    made_from: &[String],
) -> Result<(), CompensateError> {
    for p in &params.params {
        if let ParameterValue::Table { args, .. } = &p.value
            && args.len() > MAX_TABLE_ROWS
        {
            return Err(CompensateError::TooManyNodes {
                what: format!("table of {}", p.name),
                nodes: args.len(),
                max: MAX_TABLE_ROWS,
            });
        }
    }
    let mut text = match format {
        ParameterFormat::IsgCsv => isg_text(machine, params),
        ParameterFormat::Etalon => etalon_text(machine, params),
    };
    let card = ConventionCard {
        made_from: made_from.to_vec(),
        ..card(machine, format)
    };
    text.push_str(&card.file_lines("// "));
    write_file(path, &text)
}

/// A component-error table: its name, arguments and values.
type Table<'a> = (&'a ParamName, &'a [f64], &'a [f64]);

/// ISG CSV: one block per axis (`X EXX EYX …` then rows), one block of location errors (a
/// header of names and one row), blocks separated by a `#` line ("file break").
fn isg_text(machine: &Machine, params: &ErrorParameters) -> String {
    let mut text = header(machine, "ISG_CSV");
    let mut blocks = Vec::new();
    for ax in machine.axes() {
        let letter = ax.letter();
        let tables: Vec<Table<'_>> = params
            .params
            .iter()
            .filter_map(|p| match &p.value {
                ParameterValue::Table { args, values } if p.name.axis() == Some(letter) => {
                    Some((&p.name, args.as_slice(), values.as_slice()))
                }
                _ => None,
            })
            .collect();
        // Tables of one axis share one argument column when their nodes agree; otherwise
        // each gets its own block.
        let mut groups: Vec<Vec<Table<'_>>> = Vec::new();
        for t in tables {
            match groups.iter_mut().find(|g| g[0].1 == t.1) {
                Some(g) => g.push(t),
                None => groups.push(vec![t]),
            }
        }
        for g in groups {
            let mut b = String::new();
            let names: Vec<String> = g.iter().map(|t| file_name(t.0)).collect();
            let _ = writeln!(b, "{} {}", letter.as_char(), names.join(" "));
            for (i, arg) in g[0].1.iter().enumerate() {
                let _ = write!(b, "{arg:.6}");
                for t in &g {
                    let _ = write!(b, " {}", value_text(t.0, t.2[i]));
                }
                b.push('\n');
            }
            blocks.push(b);
        }
    }
    let constants: Vec<_> = params.constants().collect();
    if !constants.is_empty() {
        let names: Vec<String> = constants.iter().map(|(n, _)| file_name(n)).collect();
        let values: Vec<String> = constants.iter().map(|(n, v)| value_text(n, *v)).collect();
        blocks.push(format!("{}\n{}\n", names.join(" "), values.join(" ")));
    }
    text.push_str(&blocks.join("#\n"));
    text
}

/// Etalon Exchange ("Vendor"): `[NAME]` then `VALUE = v` or `Gridpoints = {` rows `}`.
fn etalon_text(machine: &Machine, params: &ErrorParameters) -> String {
    let mut text = header(machine, "ETALON_EXCHANGE, Vendor variant");
    for p in &params.params {
        let name = file_name(&p.name);
        let _ = writeln!(text, "[{name}]");
        match &p.value {
            ParameterValue::Constant(v) => {
                let _ = writeln!(text, "VALUE = {}", value_text(&p.name, *v));
            }
            ParameterValue::Table { args, values } => {
                text.push_str("Gridpoints = {\n");
                for (a, v) in args.iter().zip(values) {
                    let _ = writeln!(text, "    {a:.6} {}", value_text(&p.name, *v));
                }
                let _ = writeln!(text, "}} // end of {name}");
            }
        }
    }
    text
}

/// Reads an error-parameter file in `format`. Every problem names the file, line and column.
pub fn read_error_parameters(
    path: &Path,
    format: ParameterFormat,
) -> Result<ErrorParameters, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let params = match format {
        ParameterFormat::IsgCsv => parse_isg(&src, &text)?,
        ParameterFormat::Etalon => parse_etalon(&src, &text)?,
    };
    check_unique(&src, &params)?;
    Ok(ErrorParameters {
        params: params.into_iter().map(|(_, p)| p).collect(),
    })
}

/// Lines with their 1-based numbers, `//` comments and line ends removed, blank lines dropped.
fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter_map(|(i, l)| {
        let l = l.strip_suffix('\r').unwrap_or(l);
        let l = l.find("//").map_or(l, |k| &l[..k]);
        (!l.trim().is_empty()).then_some((i + 1, l))
    })
}

/// A parameter read from a file and the line it started on.
type Located = (usize, ErrorParameter);

fn name_at(src: &Source<'_>, n: usize, f: Field<'_>) -> Result<ParamName, CompensateError> {
    parse_file_name(f.text).ok_or_else(|| {
        src.error(
            n,
            f.column,
            format!(
                "expected an ISO 230-1 error parameter name such as EXX (component) or C0Y, X0C \
                 (location), found `{}`",
                f.text
            ),
        )
    })
}

fn parse_isg(src: &Source<'_>, text: &str) -> Result<Vec<Located>, CompensateError> {
    let mut out = Vec::new();
    let mut block: Vec<(usize, &str)> = Vec::new();
    for (n, line) in content_lines(text) {
        if line.trim() == "#" {
            parse_isg_block(src, &block, &mut out)?;
            block.clear();
        } else {
            block.push((n, line));
        }
    }
    parse_isg_block(src, &block, &mut out)?;
    Ok(out)
}

fn parse_isg_block(
    src: &Source<'_>,
    block: &[(usize, &str)],
    out: &mut Vec<Located>,
) -> Result<(), CompensateError> {
    let Some(&(hn, header)) = block.first() else {
        return Ok(());
    };
    let head = ws_fields(header);
    let argument = head[0].text;
    let is_argument = argument.len() == 1 && "XYZABCUVW".contains(argument);
    if !is_argument {
        // A block of constants: a header of names and exactly one row of values.
        let names = head
            .iter()
            .map(|&f| {
                let name = name_at(src, hn, f)?;
                match name {
                    ParamName::Location { .. } => Ok(name),
                    _ => Err(src.error(
                        hn,
                        f.column,
                        format!(
                            "{} is a component error: its table needs an argument column \
                             (e.g. `{} {}`)",
                            f.text,
                            name.axis().map_or('X', |a| a.as_char()),
                            f.text
                        ),
                    )),
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let Some(&(n, row)) = block.get(1) else {
            return Err(src.error(hn + 1, 1, "expected one row of values under the names"));
        };
        if let Some(&(extra, _)) = block.get(2) {
            return Err(src.error(
                extra,
                1,
                "expected one row of location-error values, found another (a table needs an \
                 argument column)",
            ));
        }
        let fields = ws_fields(row);
        src.expect_fields(n, row, &fields, names.len(), "one value per name")?;
        for (name, f) in names.into_iter().zip(fields) {
            let value = ParameterValue::Constant(src.number(n, f)?);
            out.push((hn, ErrorParameter { name, value }));
        }
        return Ok(());
    }
    let names = head[1..]
        .iter()
        .map(|&f| {
            let name = name_at(src, hn, f)?;
            match name {
                ParamName::Component { axis, .. } if axis.as_char().to_string() == argument => {
                    Ok(name)
                }
                _ => Err(src.error(
                    hn,
                    f.column,
                    format!(
                        "expected a component error of axis {argument} (E?{argument}) under the \
                         argument {argument}, found `{}`",
                        f.text
                    ),
                )),
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    if names.is_empty() {
        return Err(src.error(
            hn,
            header.len() + 1,
            format!("expected parameter names after the argument {argument}"),
        ));
    }
    let mut args = Vec::new();
    let mut columns = vec![Vec::new(); names.len()];
    for &(n, row) in &block[1..] {
        let fields = ws_fields(row);
        src.expect_fields(
            n,
            row,
            &fields,
            names.len() + 1,
            "the argument and one value per name",
        )?;
        let a = src.number(n, fields[0])?;
        check_ascending(src, n, fields[0], args.last().copied(), a)?;
        args.push(a);
        for (col, f) in columns.iter_mut().zip(&fields[1..]) {
            col.push(src.number(n, *f)?);
        }
    }
    if args.is_empty() {
        return Err(src.error(hn + 1, 1, "expected at least one row under the header"));
    }
    for (name, values) in names.into_iter().zip(columns) {
        let value = ParameterValue::Table {
            args: args.clone(),
            values,
        };
        out.push((hn, ErrorParameter { name, value }));
    }
    Ok(())
}

fn check_ascending(
    src: &Source<'_>,
    n: usize,
    f: Field<'_>,
    prev: Option<f64>,
    a: f64,
) -> Result<(), CompensateError> {
    match prev {
        Some(p) if a <= p => Err(src.error(
            n,
            f.column,
            format!("arguments must ascend: {a} follows {p}"),
        )),
        _ => Ok(()),
    }
}

fn parse_etalon(src: &Source<'_>, text: &str) -> Result<Vec<Located>, CompensateError> {
    let mut out = Vec::new();
    let mut current: Option<(usize, ParamName)> = None;
    let mut grid: Option<(usize, Vec<f64>, Vec<f64>)> = None;
    for (n, line) in content_lines(text) {
        let t = line.trim();
        let indent = line.len() - line.trim_start().len() + 1;
        if let Some((gn, args, values)) = grid.as_mut() {
            if t == "}" {
                let (gn, args, values) = grid.take().expect("open grid");
                let Some((_, name)) = current.take() else {
                    unreachable!("a grid is only opened inside a block")
                };
                if args.is_empty() {
                    return Err(src.error(gn, 1, "expected at least one grid point, found none"));
                }
                let value = ParameterValue::Table { args, values };
                out.push((gn, ErrorParameter { name, value }));
                continue;
            }
            let fields = ws_fields(line);
            src.expect_fields(n, line, &fields, 2, "argument value, or `}`")?;
            let a = src.number(n, fields[0])?;
            check_ascending(src, n, fields[0], args.last().copied(), a)?;
            args.push(a);
            values.push(src.number(n, fields[1])?);
            let _ = gn;
            continue;
        }
        if let Some(inner) = t.strip_prefix('[') {
            let Some(name_text) = inner.strip_suffix(']') else {
                return Err(src.error(n, indent + t.len(), "expected `]` closing the name"));
            };
            if let Some((open, name)) = current {
                return Err(src.error(
                    n,
                    indent,
                    format!(
                        "block [{}] from line {open} has no VALUE or Gridpoints",
                        file_name(&name)
                    ),
                ));
            }
            let field = Field {
                text: name_text.trim(),
                column: indent + 1,
            };
            current = Some((n, name_at(src, n, field)?));
            continue;
        }
        let Some((key, rest)) = t.split_once('=') else {
            return Err(src.error(
                n,
                indent,
                "expected `[NAME]`, `VALUE = number` or `Gridpoints = {`",
            ));
        };
        let Some((open, name)) = current else {
            return Err(src.error(n, indent, "expected `[NAME]` before a value"));
        };
        let value_col = indent + key.len() + 1 + (rest.len() - rest.trim_start().len());
        match key.trim() {
            k if k.eq_ignore_ascii_case("VALUE") => {
                if !matches!(name, ParamName::Location { .. }) {
                    return Err(src.error(
                        n,
                        indent,
                        format!(
                            "{} is a component error: expected `Gridpoints = {{` (a table over \
                             its axis)",
                            file_name(&name)
                        ),
                    ));
                }
                let f = Field {
                    text: rest.trim(),
                    column: value_col,
                };
                let value = ParameterValue::Constant(src.number(n, f)?);
                out.push((open, ErrorParameter { name, value }));
                current = None;
            }
            k if k.eq_ignore_ascii_case("Gridpoints") => {
                if rest.trim() != "{" {
                    return Err(src.error(n, value_col, "expected `{` after `Gridpoints =`"));
                }
                if !matches!(name, ParamName::Component { .. }) {
                    return Err(src.error(
                        n,
                        indent,
                        format!(
                            "{} is a location error: expected `VALUE = number`",
                            file_name(&name)
                        ),
                    ));
                }
                grid = Some((open, Vec::new(), Vec::new()));
            }
            other => {
                return Err(src.error(
                    n,
                    indent,
                    format!("expected VALUE or Gridpoints, found `{other}`"),
                ));
            }
        }
    }
    let end = text.lines().count() + 1;
    if let Some((gn, ..)) = grid {
        return Err(src.error(
            end,
            1,
            format!("expected `}}` closing the Gridpoints of line {gn}"),
        ));
    }
    if let Some((open, name)) = current {
        return Err(src.error(
            open,
            1,
            format!("block [{}] has no VALUE or Gridpoints", file_name(&name)),
        ));
    }
    Ok(out)
}

fn check_unique(src: &Source<'_>, params: &[Located]) -> Result<(), CompensateError> {
    for (k, (n, p)) in params.iter().enumerate() {
        if let Some((first, _)) = params[..k].iter().find(|(_, q)| q.name == p.name) {
            return Err(src.error(
                *n,
                1,
                format!(
                    "{} is given twice (first on line {first})",
                    file_name(&p.name)
                ),
            ));
        }
    }
    Ok(())
}

impl ParameterFormat {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ParameterFormat::IsgCsv => "isg",
            ParameterFormat::Etalon => "etalon",
        }
    }
}

/// The card of the ISG CSV or Etalon error parameters.
pub(crate) fn card(machine: &Machine, format: ParameterFormat) -> ConventionCard {
    let name = match format {
        ParameterFormat::IsgCsv => "Beckhoff TF5280 / ISG volumetric compensation, ISG_CSV",
        ParameterFormat::Etalon => "Etalon Exchange Format (Vendor), ETALON_EXCHANGE",
    };
    ConventionCard {
        made_from: Vec::new(),
        format: name.into(),
        quantity: Quantity::Error,
        sign: "ISO 230-1: functional errors of the tool relative to the workpiece in machine \
               X/Y/Z; leave the controller's `negate` empty"
            .into(),
        squareness: SQUARENESS_ISO.replace("; µrad", "; rad in this file"),
        rotary_direction: ROTARY_RIGHT_HAND.into(),
        axis_mapping: ConventionCard::same_letters(machine),
        units: "values mm and rad; table arguments mm (linear) and degrees (rotary)".into(),
        control_will: vec![
            "build its own error model from the tables (linear between nodes) and apply −error"
                .into(),
            "need the list file's workpiece_axes and chain to match the header's axis sides".into(),
            "correct the tool point only, unless its orientation compensation is configured".into(),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_spelled_as_the_controllers_spell_them() {
        for (text, back) in [
            ("EXY", "EXY"),
            ("C0Y", "EC0Y"),
            ("X0C", "EX0C"),
            ("ECC", "ECC"),
        ] {
            let name = parse_file_name(text).unwrap();
            assert_eq!(name.to_string(), back);
            assert_eq!(file_name(&name), text);
        }
        for bad in ["P0X", "PXA", "VXX", "EX", "EXOC", "TOOL_DX", "X0"] {
            assert!(parse_file_name(bad).is_none(), "{bad}");
        }
    }
}
