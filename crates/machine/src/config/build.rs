//! Building the bases: the exclusion rules that leave out what other parameters carry, the
//! knots and counts, and a basis error said where the file asked for it.

use super::*;

/// The terms the model leaves out of a component's basis, as `BasisChoice::build` decides them.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rule {
    min_degree: usize,
    min_harmonic: usize,
    pin_first: bool,
    pin_last: bool,
    /// Why, for messages.
    why: &'static str,
}

/// Reads the exclusion rules off `BasisChoice::build`, so that they have one home.
pub(super) fn exclusion_rule(kind: AxisKind, own: usize, direction: Direction) -> Rule {
    let probe = |choice: BasisChoice| choice.build(kind, own, direction, (0.0, 1.0)).ok();
    let min_degree = match probe(BasisChoice::Legendre { degree: 20 }) {
        Some(Basis::Legendre { min_degree, .. }) => min_degree,
        _ => 0,
    };
    let (pin_first, pin_last) = match probe(BasisChoice::Table { knots: 20 }) {
        Some(Basis::Table {
            pin_first,
            pin_last,
            ..
        }) => (pin_first, pin_last),
        _ => (false, false),
    };
    let min_harmonic = match probe(BasisChoice::Fourier { harmonics: 20 }) {
        Some(Basis::Fourier { min_harmonic, .. }) => min_harmonic,
        _ => 0,
    };
    let along = !direction.is_rotation() && direction.cartesian() == own;
    let why = match (kind, direction.is_rotation(), along) {
        (AxisKind::Rotary, _, _) => {
            "the model leaves out the constant of a rotary axis' component errors \
             (location and set-up parameters carry it)"
        }
        (AxisKind::Linear, true, _) => "",
        (AxisKind::Linear, false, true) => {
            "the model leaves out the constant of a positioning error (the set-up carries it)"
        }
        (AxisKind::Linear, false, false) => {
            "the model leaves out the constant and the slope of a straightness error \
             (the set-up and the squareness or location errors carry them)"
        }
    };
    Rule {
        min_degree,
        min_harmonic,
        pin_first,
        pin_last,
        why,
    }
}

pub(super) fn configure(
    machine: &Machine,
    selected: &At<ParamName>,
    defaults: &Defaults,
    overrides: &BTreeMap<ParamName, Spec>,
) -> Parsed<(ParamConfig, Span)> {
    let name = selected.value;
    let basis = match name {
        ParamName::Component { direction, axis } => {
            let a = machine.axis_index(axis.as_char()).ok_or_else(|| {
                let msg = format!("{name}: the machine has no axis {axis}");
                problem(selected.span.clone(), msg)
            })?;
            let kind = machine.axes()[a].kind();
            let spec = overrides.get(&name).unwrap_or(defaults.of(kind));
            Some(component_basis(machine, a, direction, &name, spec)?)
        }
        _ => None,
    };
    Ok((ParamConfig { name, basis }, selected.span.clone()))
}

pub(super) fn component_basis(
    machine: &Machine,
    a: usize,
    direction: Direction,
    name: &ParamName,
    spec: &Spec,
) -> Parsed<Basis> {
    let axis = &machine.axes()[a];
    let rule = exclusion_rule(axis.kind(), axis.own_cartesian(), direction);
    let (lo, hi) = spec
        .stroke
        .as_ref()
        .map_or_else(|| default_stroke(machine, a), |s| s.value);
    let min = |default: usize| spec.min.as_ref().map_or(default, |m| m.value);
    let pin_first = spec.pin_first.as_ref().map_or(rule.pin_first, |p| p.value);
    let pin_last = spec.pin_last.as_ref().map_or(rule.pin_last, |p| p.value);
    let size = spec.size.as_ref().map(|s| &s.value);
    let unit = Unit::of(axis.kind());
    let result = match (spec.kind.value, size) {
        (Kind::Legendre, size) => Basis::legendre(lo, hi, min(rule.min_degree), count(size, 3)),
        (Kind::Fourier, size) => Basis::fourier(min(rule.min_harmonic), count(size, 2)),
        (Kind::BSpline, size) => Basis::bspline(lo, hi, count(size, 4), pin_first, pin_last),
        (Kind::Table, Some(Size::Knots(knots))) => Basis::table(knots.clone(), pin_first, pin_last),
        (Kind::Table, Some(Size::Spacing(s))) => {
            let n = spacing_knots((lo, hi), *s, unit, spec)?;
            Basis::table(equal_knots((lo, hi), n), pin_first, pin_last)
        }
        (Kind::Table, size) => {
            Basis::table(equal_knots((lo, hi), count(size, 2)), pin_first, pin_last)
        }
    };
    result.map_err(|e| basis_problem(name, &e, spec, &rule))
}

pub(super) fn count(size: Option<&Size>, default: usize) -> usize {
    match size {
        Some(Size::Count(n)) => *n,
        _ => default,
    }
}

/// `n` equally spaced knots over the stroke, ends included (as `BasisChoice::Table` does).
pub(super) fn equal_knots((lo, hi): (f64, f64), n: usize) -> Vec<f64> {
    let n = n.max(2);
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// How many knots a spacing gives: as many equal intervals as fit at that spacing.
pub(super) fn spacing_knots(
    (lo, hi): (f64, f64),
    spacing: f64,
    unit: Unit,
    spec: &Spec,
) -> Parsed<usize> {
    let intervals = ((hi - lo) / spacing * (1.0 + 1e-9)).floor();
    let u = unit.suffix();
    if intervals < 1.0 {
        let msg = format!(
            "spacing_{u} = {} is longer than the stroke ({} {u}): a table needs at least 2 knots; \
             use a spacing of at most the stroke, or `knots = N`",
            unit.to_file(spacing),
            unit.to_file(hi - lo)
        );
        return Err(problem(spec.size_span(), msg));
    }
    if intervals >= MAX_POINTS as f64 {
        let msg = format!("spacing_{u} gives more than {MAX_POINTS} knots; use a larger spacing");
        return Err(problem(spec.size_span(), msg));
    }
    Ok(intervals as usize + 1)
}

/// A basis that cannot be built, explained in the file's terms.
pub(super) fn basis_problem(name: &ParamName, e: &BasisError, spec: &Spec, rule: &Rule) -> Problem {
    let explicit_min = spec.min.as_ref();
    let ((key, noun), min, max) = match *e {
        BasisError::EmptyDegreeRange { min, max } => (("degree", "degree"), min, max),
        BasisError::EmptyHarmonicRange { min, max } => (("harmonics", "harmonic"), min, max),
        BasisError::NoFunctions => {
            let msg = format!(
                "{name}: {e}; {}, so the table is pinned to zero at {}",
                rule.why,
                if rule.pin_last {
                    "both ends"
                } else {
                    "its start"
                }
            );
            return problem(spec.size_span(), msg);
        }
        _ => return problem(spec.size_span(), format!("{name}: {e}")),
    };
    if let Some(m) = explicit_min {
        let msg = format!("{name}: min_{noun} = {min} is above {key} = {max}; lower it");
        return problem(m.span.clone(), msg);
    }
    let msg = format!(
        "{name}: {key} = {max} leaves no functions: {}, so its series starts at {noun} {min}; \
         use {key} >= {min}, or exclude {name}",
        rule.why
    );
    problem(spec.size_span(), msg)
}
