//! Parameter-value files: the values of a model's error parameters, by their ISO 230-1 names.
//!
//! A parameter file fills the coefficient vector of an [`ErrorModel`]: the "truth" of a
//! simulation, identified values to compensate with, or a starting point. Parameters the file
//! does not mention are zero. A name the model does not include is an error, never dropped
//! silently: which parameters a model includes is the business of the error-model
//! configuration (`crate::config`), not of this file.
//!
//! # Format
//!
//! Translations are in **µm** (`um`), rotations in **µrad** (`urad`); positions along an axis in
//! **mm** on linear axes and **degrees** on rotary ones (mtcal works in m and rad inside).
//!
//! ```toml
//! schema = "mtcal.params/1"   # optional: the version of this format
//!
//! [values]                    # parameters with a single value: locations, squareness, set-up
//! EX0C = 12.0                 # um
//! EC0Y = 8.5                  # urad
//! TOOL_DZ = -3.0              # um
//!
//! [component.EXX]             # a component error: one of coefficients, samples or function
//! coefficients = [4.0, -1.5, 0.3]     # um, in the order of the model's basis: here P1, P2, P3
//!
//! [component.EYX]             # [position mm, value um], fitted onto the model's basis
//! samples = [[-300.0, 0.0], [-100.0, 1.2], [100.0, 2.0], [300.0, 1.1]]
//!
//! [component.ECC]             # urad: 5 sin(angle + 30 deg)
//! function = { kind = "sine", amplitude = 5.0, harmonic = 1, phase_deg = 30.0 }
//! ```
//!
//! ## `[values]`
//! One number per location error (`EX0C`, `EXOC` is accepted), squareness error (`EC0Y`) or
//! set-up parameter (`TOOL_DZ`, `WP_DA`).
//!
//! ## `[component.<name>]`
//! A component error `e(q) = Σ cᵢ fᵢ(q)` of its axis position `q`, given by exactly one of:
//! - `coefficients`: the `cᵢ` in µm or µrad, as many as the model's basis has functions, in its
//!   order. Legendre `P1, P2, …` (by degree); table `K1, K2, …` (the value at knot `i`; pinned
//!   knots have none); B-spline `B1, …` (control-point values); Fourier `C1, S1, C2, S2, …`
//!   (`cos kq`, `sin kq`). [`write_params`] writes each component's basis and labels in a
//!   comment above its coefficients.
//! - `samples`: `[position, value]` pairs, fitted by least squares. The model's bases leave out
//!   what other parameters carry (the constant of a positioning error, the constant and slope
//!   of a straightness error…, see `crate::config`); those terms are fitted along and dropped.
//!   So a positioning error may be given relative to any position and a straightness error with
//!   its slope: the model keeps the rest. The samples must lie within the basis' stroke and
//!   determine the fit: at least as many samples, spread over the stroke (every knot interval
//!   of a table), as the basis has functions plus the terms it leaves out.
//! - `function`: for a Fourier basis (rotary axes), a sine term
//!   `{ kind = "sine", amplitude = A, harmonic = k, phase_deg = φ }` meaning `A·sin(k·q + φ)`
//!   (`phase_deg` defaults to 0), or a list of such terms, which are added.
//!
//! ## Errors
//! A [`ParamsError`] names the file, the line and the column of the offending key or value, and
//! says what to fix.

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};

use mtcal_kinematics::model::{Param, Role};
use mtcal_kinematics::{Basis, BasisError, ErrorModel, ParamName};
use nalgebra::{DMatrix, DVector};
use toml::de::{DeTable, DeValue};

use crate::config::read::{self, Item, Parsed, Problem, Span, problem};
use crate::config::{MAX_HARMONICS, Unit};
use mtcal_located::Location;

/// The `schema` value of version 1 of this format.
pub const SCHEMA: &str = "mtcal.params/1";

/// File units (µm, µrad) per SI unit (m, rad).
const MICRO: f64 = 1e6;

/// Singular values below this fraction of the largest count as zero in a fit of samples (as in
/// `Basis::fit`).
const RANK_RELATIVE_TOLERANCE: f64 = 1e-10;

/// Why a parameter file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum ParamsError {
    #[error("{}: cannot read the parameter file: {cause}", path.display())]
    Read { path: PathBuf, cause: io::Error },
    /// The file's contents are wrong at `at`; `message` says what to fix.
    #[error("{at}: {message}")]
    Invalid { at: Location, message: String },
}

impl ParamsError {
    /// Where in the file the problem is (None for read failures).
    pub fn position(&self) -> Option<&Location> {
        match self {
            ParamsError::Read { .. } => None,
            ParamsError::Invalid { at, .. } => Some(at),
        }
    }

    fn invalid(file: &Path, text: &str, p: Problem) -> Self {
        ParamsError::Invalid {
            at: Location::of_offset(file, text, p.span.start),
            message: p.message,
        }
    }
}

/// Reads the parameter file at `path` into a coefficient vector of `model` (SI units).
pub fn load_params(path: &Path, model: &ErrorModel) -> Result<Vec<f64>, ParamsError> {
    let text = std::fs::read_to_string(path).map_err(|source| ParamsError::Read {
        path: path.to_path_buf(),
        cause: source,
    })?;
    parse_params(&text, path, model)
}

/// Parses a parameter file (`file` names it in errors) into a coefficient vector of `model`:
/// length `model.n_coeffs()`, SI units (m, rad), zero for parameters the file does not mention.
pub fn parse_params(text: &str, file: &Path, model: &ErrorModel) -> Result<Vec<f64>, ParamsError> {
    read_params(text, model).map_err(|p| ParamsError::invalid(file, text, p))
}

/// Writes every parameter of `model` in this format: `[values]` for single-value parameters,
/// `[component.<name>] coefficients` for component errors, in file units and with enough digits
/// that [`parse_params`] gives `coeffs` back. Non-finite coefficients are written as `nan` or
/// `inf`, which [`parse_params`] rejects.
///
/// # Panics
/// If `coeffs.len() != model.n_coeffs()`: the vector belongs to another model.
pub fn write_params(model: &ErrorModel, coeffs: &[f64]) -> String {
    assert_eq!(
        coeffs.len(),
        model.n_coeffs(),
        "write_params: {} coefficients for a model of {}",
        coeffs.len(),
        model.n_coeffs()
    );
    let mut out = String::from(
        "# mtcal parameter values: translations in um, rotations in urad;\n\
         # positions in mm (linear axes) or deg (rotary axes).\n",
    );
    out.push_str(&format!("schema = \"{SCHEMA}\"\n"));
    let (components, singles): (Vec<&Param>, Vec<&Param>) = model
        .params()
        .iter()
        .partition(|p| matches!(p.role, Role::Component { .. }));
    if !singles.is_empty() {
        out.push_str("\n[values]\n");
    }
    for p in singles {
        let value = toml_float(coeffs[p.offset] * MICRO);
        out.push_str(&format!("{} = {value}  # {}\n", p.name, p.name.unit()));
    }
    for p in components {
        if let Role::Component { basis, .. } = &p.role {
            let values = &coeffs[p.offset..p.offset + p.len];
            out.push_str(&component_section(&p.name, basis, values));
        }
    }
    out
}

fn component_section(name: &ParamName, basis: &Basis, values: &[f64]) -> String {
    let list: Vec<String> = values.iter().map(|c| toml_float(c * MICRO)).collect();
    format!(
        "\n[component.{name}]\n# {}\n# {} in {}\ncoefficients = [{}]\n",
        describe(basis, position_unit(name)),
        basis.labels().join(", "),
        name.unit(),
        list.join(", ")
    )
}

/// A float as TOML writes it, with all the digits needed to read it back exactly.
fn toml_float(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{v:?}")
    }
}

/// The basis in words, with its stroke in file units.
fn describe(basis: &Basis, unit: Unit) -> String {
    let u = unit.suffix();
    let at = |v: f64| {
        let rounded = (unit.to_file(v) * 1e9).round() / 1e9;
        format!("{rounded}")
    };
    match basis {
        Basis::Legendre {
            lo,
            hi,
            min_degree,
            max_degree,
        } => format!(
            "Legendre degrees {min_degree}..{max_degree} over [{}, {}] {u}",
            at(*lo),
            at(*hi)
        ),
        Basis::Table { knots, .. } => {
            let list: Vec<String> = knots.iter().map(|&k| at(k)).collect();
            format!("table, knots K0.. at [{}] {u}", list.join(", "))
        }
        Basis::BSpline { lo, hi, n_ctrl, .. } => format!(
            "cubic B-spline, control points B0..B{} over [{}, {}] {u}",
            n_ctrl - 1,
            at(*lo),
            at(*hi)
        ),
        Basis::Fourier {
            min_harmonic,
            max_harmonic,
        } => format!(
            "Fourier harmonics {min_harmonic}..{max_harmonic} of the angle (C = cos, S = sin)"
        ),
    }
}

/// mm for the positions of linear axes, degrees for rotary ones.
fn position_unit(name: &ParamName) -> Unit {
    match name.axis() {
        Some(axis) if axis.is_rotary() => Unit::Deg,
        _ => Unit::Mm,
    }
}

// ---------------------------------------------------------------------------------------------
// Reading

/// The coefficient vector being filled, and which parameters have been given where.
struct Filled {
    coeffs: Vec<f64>,
    seen: BTreeMap<ParamName, Span>,
}

impl Filled {
    fn set(&mut self, name: ParamName, span: Span, offset: usize, values: &[f64]) -> Parsed<()> {
        if self.seen.insert(name, span.clone()).is_some() {
            return Err(problem(span, format!("{name} is given twice; keep one")));
        }
        if let Some(slot) = self.coeffs.get_mut(offset..offset + values.len()) {
            slot.copy_from_slice(values);
        }
        Ok(())
    }
}

fn read_params(text: &str, model: &ErrorModel) -> Parsed<Vec<f64>> {
    let doc = read::document(text)?;
    read::check_keys(&doc, &["schema", "values", "component"], "at the top level")?;
    read::check_schema(&doc, SCHEMA)?;
    let mut filled = Filled {
        coeffs: vec![0.0; model.n_coeffs()],
        seen: BTreeMap::new(),
    };
    if let Some(item) = doc.get("values") {
        read_values(item, model, &mut filled)?;
    }
    if let Some(item) = doc.get("component") {
        read_components(item, model, &mut filled)?;
    }
    Ok(filled.coeffs)
}

/// The model's parameter of this name, or why the file may not name it.
fn lookup<'m>(model: &'m ErrorModel, name: &ParamName, span: &Span) -> Parsed<&'m Param> {
    model.find(name).ok_or_else(|| {
        let msg = format!(
            "{name} is not in this machine's error model; add it to the machine's error-model \
             configuration (<stem>.errors.toml beside its URDF) or remove it here"
        );
        problem(span.clone(), msg)
    })
}

fn read_values(item: &Item, model: &ErrorModel, filled: &mut Filled) -> Parsed<()> {
    let table = read::table(item, "`values`")?;
    for (key, span, value) in read::entries(table) {
        let name = read::name(key, &span)?;
        if let ParamName::Component { axis, .. } = name {
            let msg = format!(
                "{name} is a component error (a function of the position of {axis}): give it in \
                 a [component.{name}] section with `coefficients`, `samples` or `function`"
            );
            return Err(problem(span, msg));
        }
        let param = lookup(model, &name, &span)?;
        let v = read::number(value, &format!("`{key}`"))?;
        filled.set(name, span, param.offset, &[v / MICRO])?;
    }
    Ok(())
}

fn read_components(item: &Item, model: &ErrorModel, filled: &mut Filled) -> Parsed<()> {
    let table = read::table(item, "`component`")?;
    for (key, span, value) in read::entries(table) {
        let name = read::name(key, &span)?;
        if !matches!(name, ParamName::Component { .. }) {
            let msg = format!(
                "{name} has a single value, not a function of an axis position: give it under \
                 [values] as `{name} = …`"
            );
            return Err(problem(span, msg));
        }
        let param = lookup(model, &name, &span)?;
        let Role::Component { basis, .. } = &param.role else {
            return Err(problem(span, format!("{name} has no basis in this model")));
        };
        let section = read::table(value, &format!("[component.{key}]"))?;
        let coeffs = read_component(section, value.span(), &name, basis)?;
        filled.set(name, span, param.offset, &coeffs)?;
    }
    Ok(())
}

/// The coefficients (SI) of one `[component.<name>]` section.
fn read_component(
    section: &DeTable,
    span: Span,
    name: &ParamName,
    basis: &Basis,
) -> Parsed<Vec<f64>> {
    const KEYS: [&str; 3] = ["coefficients", "samples", "function"];
    read::check_keys(section, &KEYS, &format!("in [component.{name}]"))?;
    match read::entries(section).as_slice() {
        [] => Err(problem(
            span,
            format!("[component.{name}] needs one of `coefficients`, `samples` or `function`"),
        )),
        [("coefficients", _, item)] => read_coefficients(item, name, basis),
        [("samples", _, item)] => read_samples(item, name, basis),
        [(_, _, item)] => read_function(item, name, basis),
        [(first, _, _), (second, span, _), ..] => Err(problem(
            span.clone(),
            format!("give either `{first}` or `{second}` in [component.{name}], not both"),
        )),
    }
}

fn read_coefficients(item: &Item, name: &ParamName, basis: &Basis) -> Parsed<Vec<f64>> {
    let list = read::array(item, "`coefficients`", "a list of numbers")?;
    let labels = basis.labels();
    if list.len() != labels.len() {
        // `[4,0, -1,5]`: TOML reads decimal commas as twice as many whole numbers.
        let commas = list.len() == 2 * labels.len()
            && list
                .iter()
                .all(|c| matches!(c.get_ref(), DeValue::Integer(_)));
        let hint = if commas {
            "; these look like numbers written with decimal commas (`1,5` is two numbers \
             in TOML): write `1.5`"
        } else {
            ""
        };
        let msg = format!(
            "{name} has {} coefficients in this model ({}: {}), got {}{hint}",
            labels.len(),
            labels.join(", "),
            describe(basis, position_unit(name)),
            list.len()
        );
        return Err(problem(item.span(), msg));
    }
    let what = format!("a coefficient of {name}");
    list.iter()
        .map(|c| read::number(c, &what).map(|v| v / MICRO))
        .collect()
}

fn read_samples(item: &Item, name: &ParamName, basis: &Basis) -> Parsed<Vec<f64>> {
    let list = read::array(item, "`samples`", "a list of [position, value] pairs")?;
    let samples = list
        .iter()
        .map(|s| read_sample(s, name, basis))
        .collect::<Parsed<Vec<_>>>()?;
    check_not_metres(list, &samples, name, basis)?;
    fit_in_model(basis, &samples).map_err(|e| {
        let unit = position_unit(name);
        let left_out = match left_out(basis).map_or(0, |b| b.len()) {
            0 => String::new(),
            1 => " together with the constant it leaves out".to_string(),
            2 => " together with the constant and slope it leaves out".to_string(),
            n => format!(" together with the {n} terms it leaves out"),
        };
        let msg = format!(
            "{name}: the samples do not determine the model's basis ({}){left_out}: {e}",
            describe(basis, unit)
        );
        problem(item.span(), msg)
    })
}

/// Sample positions of a linear axis that all lie within ±1 mm while its stroke spans at
/// least 50 mm were written in metres: say so at the largest.
fn check_not_metres(
    list: &[Item],
    samples: &[(f64, f64)],
    name: &ParamName,
    basis: &Basis,
) -> Parsed<()> {
    let (Unit::Mm, Some((lo, hi))) = (position_unit(name), basis.stroke()) else {
        return Ok(());
    };
    let Some((i, largest)) = samples
        .iter()
        .map(|(q, _)| q.abs())
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return Ok(());
    };
    if hi - lo < 0.05 || largest == 0.0 || largest > 1e-3 || samples.len() < 2 {
        return Ok(());
    }
    let msg = format!(
        "every sample position of {name} lies within ±1 mm (largest {} mm) while its stroke is \
         [{}, {}] mm: this looks like metres; expected mm (multiply by 1000)",
        samples[i].0 * 1e3,
        lo * 1e3,
        hi * 1e3
    );
    Err(problem(list[i].span(), msg))
}

/// One `[position, value]` pair in SI, checked to lie within the basis' stroke.
fn read_sample(item: &Item, name: &ParamName, basis: &Basis) -> Parsed<(f64, f64)> {
    let unit = position_unit(name);
    let u = unit.suffix();
    let expected = format!("[position {u}, value {}]", name.unit());
    let pair = read::array(item, "a sample", &expected)?;
    let [q, v] = pair else {
        let msg = format!("a sample must be {expected}, got {} values", pair.len());
        return Err(problem(item.span(), msg));
    };
    let position = read::number(q, "a sample position")?;
    let value = read::number(v, "a sample value")?;
    let q_si = unit.to_si(position);
    if let Some((lo, hi)) = basis.stroke() {
        let tol = 1e-9 * (hi - lo);
        if q_si < lo - tol || q_si > hi + tol {
            let msg = format!(
                "the sample at {position} {u} lies outside {name}'s stroke [{}, {}] {u}; the \
                 model holds the end value beyond it, so drop the sample or widen the stroke in \
                 the error-model configuration",
                unit.to_file(lo),
                unit.to_file(hi)
            );
            return Err(problem(q.span(), msg));
        }
    }
    Ok((q_si, value / MICRO))
}

/// The functions the model's basis leaves out of the complete family (a Legendre series'
/// lower degrees, a Fourier series' lower harmonics, the constant and slope that pinned table
/// or spline ends remove). None if it leaves out nothing.
fn left_out(basis: &Basis) -> Option<Basis> {
    let pinned = |first: bool, last: bool| usize::from(first) + usize::from(last);
    match *basis {
        Basis::Legendre {
            lo, hi, min_degree, ..
        } if min_degree > 0 => Basis::legendre(lo, hi, 0, min_degree - 1).ok(),
        Basis::Fourier { min_harmonic, .. } if min_harmonic > 0 => {
            Basis::fourier(0, min_harmonic - 1).ok()
        }
        Basis::Table {
            pin_first,
            pin_last,
            ..
        }
        | Basis::BSpline {
            pin_first,
            pin_last,
            ..
        } if pin_first || pin_last => {
            let (lo, hi) = basis.stroke()?;
            Basis::legendre(lo, hi, 0, pinned(pin_first, pin_last) - 1).ok()
        }
        _ => None,
    }
}

/// Least-squares coefficients of `basis` for the samples, fitting the terms it leaves out
/// along and dropping them.
fn fit_in_model(basis: &Basis, samples: &[(f64, f64)]) -> Result<Vec<f64>, BasisError> {
    let Some(extra) = left_out(basis) else {
        return basis.fit(samples);
    };
    let (n, total) = (basis.len(), basis.len() + extra.len());
    if samples.len() < total {
        return Err(BasisError::TooFewSamples {
            samples: samples.len(),
            coefficients: total,
        });
    }
    let mut design = DMatrix::zeros(samples.len(), total);
    let mut row = vec![0.0; total];
    for (r, &(q, _)) in samples.iter().enumerate() {
        basis.eval(q, &mut row[..n]);
        extra.eval(q, &mut row[n..]);
        for (c, &value) in row.iter().enumerate() {
            design[(r, c)] = value;
        }
    }
    let rhs = DVector::from_iterator(samples.len(), samples.iter().map(|&(_, v)| v));
    let svd = design.svd(true, true);
    let tolerance = RANK_RELATIVE_TOLERANCE * svd.singular_values.max();
    let rank = svd
        .singular_values
        .iter()
        .filter(|&&s| s > tolerance)
        .count();
    let deficient = BasisError::RankDeficient {
        independent: rank,
        coefficients: total,
    };
    if rank < total {
        return Err(deficient);
    }
    let solution = svd.solve(&rhs, tolerance).map_err(|_| deficient)?;
    Ok(solution.as_slice()[..n].to_vec())
}

fn read_function(item: &Item, name: &ParamName, basis: &Basis) -> Parsed<Vec<f64>> {
    let expected = "a sine term such as { kind = \"sine\", amplitude = 5.0, harmonic = 1 }, \
                    or a list of them";
    let terms: Vec<&Item> = match item.get_ref() {
        DeValue::Table(_) => vec![item],
        DeValue::Array(list) => list.iter().collect(),
        _ => return Err(read::wrong_type(item, "`function`", expected)),
    };
    if !matches!(basis, Basis::Fourier { .. }) {
        let msg = format!(
            "`function` needs a Fourier basis, but {name}'s is a {}; give `coefficients` or \
             `samples` instead",
            describe(basis, position_unit(name))
        );
        return Err(problem(item.span(), msg));
    }
    let labels = basis.labels();
    let mut coeffs = vec![0.0; labels.len()];
    for term in terms {
        add_sine(term, name, &labels, &mut coeffs)?;
    }
    Ok(coeffs)
}

/// Adds `A·sin(k·q + φ) = A·sin φ·cos kq + A·cos φ·sin kq` to Fourier coefficients (SI).
fn add_sine(term: &Item, name: &ParamName, labels: &[String], coeffs: &mut [f64]) -> Parsed<()> {
    let table = read::table(term, "a `function` term")?;
    read::check_keys(
        table,
        &["kind", "amplitude", "harmonic", "phase_deg"],
        "in a sine term",
    )?;
    let required = |key: &str| {
        table.get(key).ok_or_else(|| {
            let msg = "a sine term needs `kind = \"sine\"`, `amplitude` and `harmonic`";
            problem(term.span(), msg)
        })
    };
    let kind = required("kind")?;
    if read::string(kind, "`kind`", "\"sine\"")? != "sine" {
        return Err(problem(
            kind.span(),
            "unknown function kind: expected \"sine\"",
        ));
    }
    let amplitude = read::number(required("amplitude")?, "`amplitude`")? / MICRO;
    let harmonic_item = required("harmonic")?;
    let k = read::count(harmonic_item, "`harmonic`", 0..=MAX_HARMONICS)?;
    let phase = match table.get("phase_deg") {
        Some(p) => read::number(p, "`phase_deg`")?.to_radians(),
        None => 0.0,
    };
    let index = |label: String| labels.iter().position(|l| *l == label);
    let (cos, sin) = (index(format!("C{k}")), index(format!("S{k}")));
    match (cos, sin) {
        (Some(c), Some(s)) => {
            coeffs[c] += amplitude * phase.sin();
            coeffs[s] += amplitude * phase.cos();
        }
        (Some(c), None) if k == 0 => coeffs[c] += amplitude * phase.sin(),
        _ => {
            let msg = format!(
                "harmonic {k} is not in {name}'s basis ({}); the error-model configuration sets \
                 its harmonics",
                labels.join(", ")
            );
            return Err(problem(harmonic_item.span(), msg));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tests::{cases, five_axis, three_axis};
    use crate::config::{default_config, parse_config};
    use mtcal_kinematics::Machine;
    use proptest::prelude::*;

    fn model_of(m: &Machine, config: &str) -> ErrorModel {
        let list = parse_config(config, Path::new("m.errors.toml"), m).unwrap();
        ErrorModel::new(m, &list).unwrap()
    }

    fn default_model() -> ErrorModel {
        let m = five_axis();
        ErrorModel::new(&m, &default_config(&m)).unwrap()
    }

    fn file() -> &'static Path {
        Path::new("truth.toml")
    }

    /// The coefficients of one parameter after parsing `input`.
    fn coeffs_of(model: &ErrorModel, input: &str, name: &str) -> Vec<f64> {
        let all = parse_params(input, file(), model).unwrap();
        let p = model.find(&name.parse().unwrap()).unwrap();
        all[p.offset..p.offset + p.len].to_vec()
    }

    fn assert_close(got: &[f64], expect: &[f64], rel: f64) {
        assert_eq!(got.len(), expect.len(), "{got:?} vs {expect:?}");
        let scale = expect.iter().fold(1e-300_f64, |m, v| m.max(v.abs()));
        for (g, e) in got.iter().zip(expect) {
            assert!((g - e).abs() <= rel * scale, "{got:?} vs {expect:?}");
        }
    }

    /// `expect` is the start of the error message after the file name: "line:column: message".
    fn check(model: &ErrorModel, input: &str, expect: &str) {
        let got = match parse_params(input, file(), model) {
            Ok(c) => format!("ok: {} coefficients", c.len()),
            Err(e) => e.to_string().replacen("truth.toml:", "", 1),
        };
        assert!(
            got.starts_with(expect),
            "input:\n{input}\nexpected: {expect}\ngot:      {got}"
        );
    }

    /// The ```toml block of this module's documentation.
    fn doc_example() -> String {
        let src = include_str!("params.rs");
        let start = src.find("//! ```toml\n").unwrap() + "//! ```toml\n".len();
        let end = start + src[start..].find("//! ```\n").unwrap();
        src[start..end]
            .lines()
            .map(|l| l.strip_prefix("//!").unwrap_or(l).trim_start_matches(' '))
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn values_are_converted_to_si() {
        let model = default_model();
        let text = "[values]\nEX0C = 12.0\nEC0Y = 8.5\nEYOC = -3\n[component.EXX]\n\
                    coefficients = [4.0, -1.5, 0.3]\n";
        let all = parse_params(text, file(), &model).unwrap();
        assert_eq!(all.len(), model.n_coeffs());
        assert_close(&coeffs_of(&model, text, "EX0C"), &[12e-6], 1e-15);
        assert_close(&coeffs_of(&model, text, "EC0Y"), &[8.5e-6], 1e-15);
        assert_close(&coeffs_of(&model, text, "EY0C"), &[-3e-6], 1e-15);
        assert_close(
            &coeffs_of(&model, text, "EXX"),
            &[4e-6, -1.5e-6, 0.3e-6],
            1e-15,
        );
        let nonzero = all.iter().filter(|c| **c != 0.0).count();
        assert_eq!(nonzero, 6, "parameters not mentioned are zero");
    }

    #[test]
    fn set_up_values() {
        let m = five_axis();
        let model = model_of(&m, "setup = [\"TOOL_DZ\", \"WP_DA\"]");
        let text = "[values]\nTOOL_DZ = -3.0\nWP_DA = 2";
        assert_close(&coeffs_of(&model, text, "TOOL_DZ"), &[-3e-6], 1e-15);
        assert_close(&coeffs_of(&model, text, "WP_DA"), &[2e-6], 1e-15);
    }

    #[test]
    fn doc_example_parses() {
        let model = model_of(&five_axis(), "setup = [\"TOOL_DZ\"]");
        let text = doc_example();
        let ecc = coeffs_of(&model, &text, "ECC");
        let phase = 30f64.to_radians();
        assert_close(
            &ecc,
            &[5e-6 * phase.sin(), 5e-6 * phase.cos(), 0.0, 0.0],
            1e-14,
        );
        assert_eq!(coeffs_of(&model, &text, "EYX").len(), 2);
    }

    /// Samples of `f` at `positions` (file units) as a TOML array.
    fn samples_toml(positions: &[f64], unit: Unit, f: impl Fn(f64) -> f64) -> String {
        let rows: Vec<String> = positions
            .iter()
            .map(|&p| format!("[{p:?}, {:?}]", f(unit.to_si(p)) * MICRO))
            .collect();
        format!("samples = [{}]", rows.join(", "))
    }

    #[test]
    fn samples_in_the_basis_are_fitted_exactly() {
        let model = default_model();
        let positions: Vec<f64> = (0..9).map(|i| -350.0 + 87.5 * i as f64).collect();
        // EXX: Legendre P1..P3; EYX: P2..P3; EAX: P0..P3 (angular, nothing left out).
        for (name, truth) in [
            ("EXX", vec![2e-6, -1e-6, 0.5e-6]),
            ("EYX", vec![1.5e-6, -0.7e-6]),
            ("EAX", vec![3e-6, 1e-6, -2e-6, 0.25e-6]),
        ] {
            let p = model.find(&name.parse().unwrap()).unwrap();
            let Role::Component { basis, .. } = &p.role else {
                panic!()
            };
            let text = format!(
                "[component.{name}]\n{}",
                samples_toml(&positions, Unit::Mm, |q| basis.value(q, &truth))
            );
            assert_close(&coeffs_of(&model, &text, name), &truth, 1e-9);
        }
    }

    #[test]
    fn samples_may_carry_the_terms_the_model_leaves_out() {
        let m = five_axis();
        let model = model_of(
            &m,
            "[component.EXX]\nkind = \"table\"\nknots = 5\n\
             [component.EYX]\nkind = \"bspline\"\ncontrol_points = 6\n",
        );
        let positions: Vec<f64> = (0..29).map(|i| -350.0 + 25.0 * i as f64).collect();
        for (name, truth, offset, slope) in [
            ("EYY", vec![1e-6, 2e-6, -1e-6], 3e-6, 0.0),
            ("EZY", vec![1e-6, -0.5e-6], 3e-6, 4e-6),
            ("EXX", vec![1e-6, 3e-6, -2e-6, 0.5e-6], -2e-6, 0.0),
            ("EYX", vec![1e-6, 3e-6, -2e-6, 0.5e-6], 5e-6, -6e-6),
        ] {
            let p = model.find(&name.parse().unwrap()).unwrap();
            let Role::Component { basis, .. } = &p.role else {
                panic!()
            };
            let (lo, hi) = basis.stroke().unwrap();
            let inside: Vec<f64> = positions
                .iter()
                .copied()
                .filter(|&x| x / 1e3 >= lo - 1e-12 && x / 1e3 <= hi + 1e-12)
                .collect();
            let f = |q: f64| basis.value(q, &truth) + offset + slope * q;
            let text = format!("[component.{name}]\n{}", samples_toml(&inside, Unit::Mm, f));
            assert_close(&coeffs_of(&model, &text, name), &truth, 1e-9);
        }
    }

    #[test]
    fn rotary_samples_are_in_degrees() {
        let model = default_model();
        // EXC: Fourier C1, S1, C2, S2; a constant offset is left out.
        let truth = [1e-6, -2e-6, 0.5e-6, 0.25e-6];
        let p = model.find(&"EXC".parse().unwrap()).unwrap();
        let Role::Component { basis, .. } = &p.role else {
            panic!()
        };
        let positions: Vec<f64> = (0..12).map(|i| -180.0 + 30.0 * i as f64).collect();
        let f = |q: f64| basis.value(q, &truth) + 7e-6;
        let text = format!(
            "[component.EXC]\n{}",
            samples_toml(&positions, Unit::Deg, f)
        );
        assert_close(&coeffs_of(&model, &text, "EXC"), &truth, 1e-9);
    }

    #[test]
    fn sine_functions_add_up() {
        let model = default_model();
        let text = "[component.ECC]\nfunction = [\
                    { kind = \"sine\", amplitude = 2.0, harmonic = 2, phase_deg = 90 },\
                    { kind = \"sine\", amplitude = 1.0, harmonic = 1 }]";
        assert_close(
            &coeffs_of(&model, text, "ECC"),
            &[0.0, 1e-6, 2e-6, 0.0],
            1e-14,
        );
    }

    /// Error cases on the five-axis ISO model: TOML input, then `=> line:column: start of the
    /// message`, separated by `----` lines.
    const ERROR_CASES: &str = r#"
[valuse]
EX0C = 1
=> 1:2: unknown key `valuse` at the top level; expected one of: schema, values, component
----
[values]
EX0C = 1
EX0C = 2
=> 3:1: this is not valid TOML: duplicate key
----
schema = "mtcal.params/2"
=> 1:10: schema "mtcal.params/2" is not supported
----
[values]
EX0A = 1
=> 2:1: EX0A is not in this machine's error model; add it to the machine's error-model configuration
----
[values]
EQX = 1
=> 2:1: `EQX` is not an error parameter name
----
[values]
EXX = 1
=> 2:1: EXX is a component error (a function of the position of X): give it in a [component.EXX] section
----
[values]
EX0C = "a"
=> 2:8: `EX0C` must be a number, found a string
----
[values]
EX0C = nan
=> 2:8: `EX0C` must be a finite number
----
[values]
EX0C = 1
EXOC = 2
=> 3:1: EX0C is given twice
----
values = 3
=> 1:10: `values` must be a table, found an integer
----
[component.EX0C]
coefficients = [1]
=> 1:12: EX0C has a single value, not a function of an axis position: give it under [values]
----
[component.EXU]
coefficients = [1]
=> 1:12: EXU is not in this machine's error model
----
[component.EXX]
coefficients = [1, 2]
=> 2:16: EXX has 3 coefficients in this model (P1, P2, P3: Legendre degrees 1..3 over [-350, 350] mm), got 2
----
[component.EXX]
coefficients = [1, 2, inf]
=> 2:23: a coefficient of EXX must be a finite number
----
[component.EXX]
coefficients = [1, 2, 3]
samples = [[0, 0]]
=> 3:1: give either `coefficients` or `samples` in [component.EXX], not both
----
[component.EXX]
=> 1:1: [component.EXX] needs one of `coefficients`, `samples` or `function`
----
[component.EXX]
colour = 1
=> 2:1: unknown key `colour` in [component.EXX]; expected one of: coefficients, samples, function
----
[component.EXX]
samples = [[0, 0], [10, 1]]
=> 2:11: EXX: the samples do not determine the model's basis (Legendre degrees 1..3 over [-350, 350] mm) together with the constant it leaves out: fit needs at least as many independent samples as coefficients: 2 samples for 4 coefficients
----
[component.EXX]
samples = [[0, 0], [0, 1], [0, 2], [0, 3]]
=> 2:11: EXX: the samples do not determine the model's basis
----
[component.EAX]
samples = [[0, 0]]
=> 2:11: EAX: the samples do not determine the model's basis (Legendre degrees 0..3 over [-350, 350] mm): fit needs
----
[component.EXX]
samples = [[0, 0], [500, 1]]
=> 2:21: the sample at 500 mm lies outside EXX's stroke [-350, 350] mm
----
[component.EXX]
samples = [[0, 0, 1]]
=> 2:12: a sample must be [position mm, value um], got 3 values
----
[component.EXX]
samples = [1, 2]
=> 2:12: a sample must be [position mm, value um], found an integer
----
[component.EAX]
samples = [["a", 2]]
=> 2:13: a sample position must be a number, found a string
----
[component.EXX]
function = { kind = "sine", amplitude = 1, harmonic = 1 }
=> 2:12: `function` needs a Fourier basis, but EXX's is a Legendre degrees 1..3
----
[component.ECC]
function = 3
=> 2:12: `function` must be a sine term
----
[component.ECC]
function = { kind = "sine", amplitude = 1, harmonic = 3 }
=> 2:55: harmonic 3 is not in ECC's basis (C1, S1, C2, S2)
----
[component.ECC]
function = { kind = "cosine", amplitude = 1, harmonic = 1 }
=> 2:21: unknown function kind: expected "sine"
----
[component.ECC]
function = { kind = "sine", harmonic = 1 }
=> 2:12: a sine term needs `kind = "sine"`, `amplitude` and `harmonic`
----
[component.ECC]
function = { kind = "sine", amplitude = 1, harmonic = 1, phase = 3 }
=> 2:58: unknown key `phase` in a sine term
"#;

    #[test]
    fn errors_point_at_the_problem() {
        let model = default_model();
        for (input, expect) in cases(ERROR_CASES) {
            check(&model, &input, &expect);
        }
    }

    #[test]
    fn writes_a_readable_file() {
        let m = three_axis();
        let model = model_of(
            &m,
            "setup = [\"TOOL_DZ\"]\n[component.EXX]\nkind = \"table\"\nknots = 3\n",
        );
        let mut coeffs = vec![0.0; model.n_coeffs()];
        coeffs[0] = 1.25e-6;
        let text = write_params(&model, &coeffs);
        assert!(text.contains("schema = \"mtcal.params/1\""), "{text}");
        assert!(text.contains("\n[values]\nEC0Y = 0.0  # urad\n"), "{text}");
        assert!(text.contains("TOOL_DZ = 0.0  # um\n"), "{text}");
        assert!(
            text.contains(
                "[component.EXX]\n# table, knots K0.. at [-300, 0, 300] mm\n# K1, K2 in um\n\
                 coefficients = [1.25, 0.0]\n"
            ),
            "{text}"
        );
        assert_eq!(parse_params(&text, file(), &model).unwrap(), coeffs);
    }

    #[test]
    fn load_reads_files_and_names_missing_ones() {
        let model = default_model();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("truth.params.toml");
        let coeffs: Vec<f64> = (0..model.n_coeffs()).map(|i| i as f64 * 1e-7).collect();
        std::fs::write(&path, write_params(&model, &coeffs)).unwrap();
        assert_close(&load_params(&path, &model).unwrap(), &coeffs, 1e-15);
        let missing = dir.path().join("missing.toml");
        let err = load_params(&missing, &model).unwrap_err();
        assert!(
            err.to_string().contains("missing.toml: cannot read"),
            "{err}"
        );
        assert!(err.position().is_none());
    }

    fn magnitude() -> impl Strategy<Value = f64> {
        (-1.0f64..1.0, -12i32..-2).prop_map(|(m, e)| m * 10f64.powi(e))
    }

    proptest! {
        #[test]
        fn write_then_parse_gives_the_coefficients_back(
            seed in proptest::collection::vec(magnitude(), 64),
        ) {
            let model = default_model();
            let coeffs: Vec<f64> = (0..model.n_coeffs()).map(|i| seed[i % seed.len()] * (1.0 + i as f64)).collect();
            let text = write_params(&model, &coeffs);
            let back = parse_params(&text, file(), &model).unwrap();
            for (a, b) in coeffs.iter().zip(&back) {
                prop_assert!((a - b).abs() <= 1e-12 * a.abs(), "{a} -> {b}");
            }
        }
    }
}
