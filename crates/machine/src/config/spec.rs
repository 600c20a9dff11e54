//! Each selected parameter's basis as the file asks for it: kinds, units, sizes, defaults and
//! overrides per axis, read and checked.

use super::*;

/// A basis family as the file names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Legendre,
    Fourier,
    Table,
    BSpline,
}

impl Kind {
    const ALL: [Kind; 4] = [Kind::Legendre, Kind::Fourier, Kind::Table, Kind::BSpline];

    pub(super) fn name(self) -> &'static str {
        match self {
            Kind::Legendre => "legendre",
            Kind::Fourier => "fourier",
            Kind::Table => "table",
            Kind::BSpline => "bspline",
        }
    }

    /// The key that gives the number of functions.
    pub(super) fn count_key(self) -> &'static str {
        match self {
            Kind::Legendre => "degree",
            Kind::Fourier => "harmonics",
            Kind::Table => "knots",
            Kind::BSpline => "control_points",
        }
    }

    pub(super) fn count_range(self) -> RangeInclusive<usize> {
        match self {
            Kind::Legendre => 0..=MAX_DEGREE,
            Kind::Fourier => 0..=MAX_HARMONICS,
            Kind::Table => 2..=MAX_POINTS,
            Kind::BSpline => 4..=MAX_POINTS,
        }
    }

    /// The keys this kind takes, in the order the module docs list them.
    pub(super) fn keys(self, unit: Unit, scope: Scope) -> Vec<String> {
        let u = unit.suffix();
        let mut keys = vec!["kind".to_string(), self.count_key().to_string()];
        if self == Kind::Table {
            keys.push(format!("spacing_{u}"));
        }
        if scope == Scope::Component {
            match self {
                Kind::Legendre => keys.push("min_degree".into()),
                Kind::Fourier => keys.push("min_harmonic".into()),
                Kind::Table => keys.push(format!("knots_{u}")),
                Kind::BSpline => {}
            }
            if matches!(self, Kind::Table | Kind::BSpline) {
                keys.extend(["pin_first".to_string(), "pin_last".to_string()]);
            }
            if self != Kind::Fourier {
                keys.push(format!("stroke_{u}"));
            }
        }
        keys
    }
}

/// Units of positions in the file: mm for linear axes, degrees for rotary ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Unit {
    Mm,
    Deg,
}

impl Unit {
    pub(crate) fn of(kind: AxisKind) -> Self {
        match kind {
            AxisKind::Linear => Unit::Mm,
            AxisKind::Rotary => Unit::Deg,
        }
    }

    pub(crate) fn suffix(self) -> &'static str {
        match self {
            Unit::Mm => "mm",
            Unit::Deg => "deg",
        }
    }

    /// File units to SI (m or rad).
    pub(crate) fn to_si(self, v: f64) -> f64 {
        match self {
            Unit::Mm => v / 1e3,
            Unit::Deg => v.to_radians(),
        }
    }

    /// SI (m or rad) to file units.
    pub(crate) fn to_file(self, v: f64) -> f64 {
        match self {
            Unit::Mm => v * 1e3,
            Unit::Deg => v.to_degrees(),
        }
    }

    pub(super) fn other(self) -> Self {
        match self {
            Unit::Mm => Unit::Deg,
            Unit::Deg => Unit::Mm,
        }
    }

    pub(super) fn axes(self) -> &'static str {
        match self {
            Unit::Mm => "linear",
            Unit::Deg => "rotary",
        }
    }
}

/// Where a basis is described: an axis-kind default or one component's section.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scope {
    Default,
    Component,
}

/// How many functions, as the file says it (in SI once read).
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Size {
    Count(usize),
    Spacing(f64),
    Knots(Vec<f64>),
}

/// A basis description as read, with where each part was said.
#[derive(Clone, Debug)]
pub(super) struct Spec {
    pub(super) kind: At<Kind>,
    pub(super) size: Option<At<Size>>,
    pub(super) min: Option<At<usize>>,
    pub(super) pin_first: Option<At<bool>>,
    pub(super) pin_last: Option<At<bool>>,
    pub(super) stroke: Option<At<(f64, f64)>>,
}

impl Spec {
    pub(super) fn new(kind: At<Kind>) -> Self {
        Spec {
            kind,
            size: None,
            min: None,
            pin_first: None,
            pin_last: None,
            stroke: None,
        }
    }

    /// The built-in default of an axis kind.
    pub(super) fn builtin(unit: Unit) -> Self {
        let (kind, count) = match unit {
            Unit::Mm => (Kind::Legendre, DEFAULT_DEGREE),
            Unit::Deg => (Kind::Fourier, DEFAULT_HARMONICS),
        };
        let mut spec = Spec::new(At {
            value: kind,
            span: 0..0,
        });
        spec.size = Some(At {
            value: Size::Count(count),
            span: 0..0,
        });
        spec
    }

    /// Where a problem with the number of functions is best shown.
    pub(super) fn size_span(&self) -> Span {
        self.size
            .as_ref()
            .map_or(self.kind.span.clone(), |s| s.span.clone())
    }
}

/// The default bases of linear and rotary axes.
pub(super) struct Defaults {
    pub(super) linear: Spec,
    pub(super) rotary: Spec,
}

impl Defaults {
    pub(super) fn of(&self, kind: AxisKind) -> &Spec {
        match kind {
            AxisKind::Linear => &self.linear,
            AxisKind::Rotary => &self.rotary,
        }
    }
}

/// What `read_spec` needs besides the table.
pub(super) struct SpecContext<'a> {
    pub(super) unit: Unit,
    pub(super) scope: Scope,
    /// The spec this one starts from (the axis default, or the built-in default).
    pub(super) inherited: &'a Spec,
    /// How messages name the table, e.g. `[component.EXX]`.
    pub(super) place: String,
}

pub(super) fn read_defaults(top: &DeTable) -> Parsed<Defaults> {
    let mut defaults = Defaults {
        linear: Spec::builtin(Unit::Mm),
        rotary: Spec::builtin(Unit::Deg),
    };
    let Some(item) = top.get("basis") else {
        return Ok(defaults);
    };
    let table = read::table(item, "`basis`")?;
    read::check_keys(table, &["linear", "rotary"], "in [basis]")?;
    for (unit, slot) in [
        (Unit::Mm, &mut defaults.linear),
        (Unit::Deg, &mut defaults.rotary),
    ] {
        let key = if unit == Unit::Mm { "linear" } else { "rotary" };
        if let Some(item) = table.get(key) {
            let cx = SpecContext {
                unit,
                scope: Scope::Default,
                inherited: &Spec::builtin(unit),
                place: format!("[basis.{key}]"),
            };
            *slot = read_spec(item, &cx)?;
        }
    }
    Ok(defaults)
}

/// The `[component.<name>]` sections, checked against the selection.
pub(super) fn read_overrides(
    top: &DeTable,
    machine: &Machine,
    selected: &[At<ParamName>],
    defaults: &Defaults,
) -> Parsed<BTreeMap<ParamName, Spec>> {
    let mut out = BTreeMap::new();
    let Some(item) = top.get("component") else {
        return Ok(out);
    };
    let table = read::table(item, "`component`")?;
    for (key, span, value) in read::entries(table) {
        let name = read::name(key, &span)?;
        let axis = override_axis(&name, &span, machine, selected)?;
        let unit = Unit::of(axis);
        let cx = SpecContext {
            unit,
            scope: Scope::Component,
            inherited: defaults.of(axis),
            place: format!("[component.{key}]"),
        };
        let spec = read_spec(value, &cx)?;
        if out.insert(name, spec).is_some() {
            return Err(problem(
                span,
                format!("{name} has two [component] sections"),
            ));
        }
    }
    Ok(out)
}

/// The kind of the axis a `[component.<name>]` section belongs to, if the name may have one.
pub(super) fn override_axis(
    name: &ParamName,
    span: &Span,
    machine: &Machine,
    selected: &[At<ParamName>],
) -> Parsed<AxisKind> {
    let class = Class::of(name);
    if class != Class::Component {
        let msg = format!(
            "{name} is {} with a single value and no basis; only component errors \
             (such as EXX) have a [component.<name>] section",
            class.noun()
        );
        return Err(problem(span.clone(), msg));
    }
    check_axis(name, span, machine)?;
    if !selected.iter().any(|s| s.value == *name) {
        let msg = format!(
            "{name} is not in the model (`components` and `exclude` leave it out); \
             add it to `components` or remove this section"
        );
        return Err(problem(span.clone(), msg));
    }
    let axis = name.axis().and_then(|a| machine.axis_index(a.as_char()));
    Ok(axis.map_or(AxisKind::Linear, |i| machine.axes()[i].kind()))
}

pub(super) fn read_spec(item: &Item, cx: &SpecContext) -> Parsed<Spec> {
    let table = read::table(item, &cx.place)?;
    let mut spec = start_spec(table, cx)?;
    let mut size_key: Option<&str> = None;
    for (key, span, value) in read::entries(table) {
        if key == "kind" {
            continue;
        }
        let kind = spec.kind.value;
        if !kind.keys(cx.unit, cx.scope).iter().any(|k| k == key) {
            let inherited = !table.contains_key("kind");
            return Err(problem(span, unknown_key(key, kind, inherited, cx)));
        }
        if let Some(size) = read_size(key, value, kind, cx.unit)? {
            if let Some(first) = size_key {
                let msg = format!("`{first}` and `{key}` both set the size; keep one of them");
                return Err(problem(span, msg));
            }
            size_key = Some(key);
            spec.size = Some(size);
        } else {
            read_option(&mut spec, key, value, cx.unit)?;
        }
    }
    check_spec(&spec, item.span(), cx)?;
    Ok(spec)
}

/// The spec a table starts from: the inherited one when it keeps the kind, else a fresh one.
pub(super) fn start_spec(table: &DeTable, cx: &SpecContext) -> Parsed<Spec> {
    let Some(item) = table.get("kind") else {
        return Ok(cx.inherited.clone());
    };
    let kind = At {
        value: read_kind(item, cx.unit)?,
        span: item.span(),
    };
    if kind.value == cx.inherited.kind.value {
        let mut spec = cx.inherited.clone();
        spec.kind = kind;
        Ok(spec)
    } else {
        Ok(Spec::new(kind))
    }
}

pub(super) fn read_kind(item: &Item, unit: Unit) -> Parsed<Kind> {
    let expected = "one of \"legendre\", \"table\", \"bspline\", \"fourier\" (rotary axes)";
    let text = read::string(item, "`kind`", expected)?;
    let Some(kind) = Kind::ALL.into_iter().find(|k| k.name() == text) else {
        let msg = format!("unknown basis kind \"{text}\": expected {expected}");
        return Err(problem(item.span(), msg));
    };
    if kind == Kind::Fourier && unit == Unit::Mm {
        let msg = "a Fourier series is periodic in the angle and needs a rotary axis; \
                   for a linear axis use \"legendre\", \"table\" or \"bspline\"";
        return Err(problem(item.span(), msg));
    }
    Ok(kind)
}

/// Says why `key` does not belong in this table and what would.
pub(super) fn unknown_key(key: &str, kind: Kind, inherited: bool, cx: &SpecContext) -> String {
    let unit = cx.unit;
    let here = kind.keys(unit, cx.scope);
    let other = unit.other().suffix();
    if let Some(stem) = key.strip_suffix(&format!("_{other}")) {
        let fixed = format!("{stem}_{}", unit.suffix());
        if kind.keys(unit, Scope::Component).contains(&fixed) {
            return format!(
                "`{key}` is for {} axes; {} is for {} axes: use `{fixed}`",
                unit.other().axes(),
                cx.place,
                unit.axes()
            );
        }
    }
    if cx.scope == Scope::Default && kind.keys(unit, Scope::Component).iter().any(|k| k == key) {
        return format!(
            "`{key}` can only be set for one component error, in its [component.<name>] section"
        );
    }
    let from = if inherited {
        " (the axis default; set `kind` to change it)"
    } else {
        ""
    };
    let owner = Kind::ALL
        .into_iter()
        .find(|k| k.keys(unit, Scope::Component).iter().any(|x| x == key));
    match owner {
        Some(k) => format!(
            "`{key}` belongs to a {} basis, but this one is {}{from}; a {} basis takes: {}",
            k.name(),
            kind.name(),
            kind.name(),
            here.join(", ")
        ),
        None => format!(
            "unknown key `{key}` in {}; a {} basis takes: {}",
            cx.place,
            kind.name(),
            here.join(", ")
        ),
    }
}

/// Reads `key` if it sets the number of functions.
pub(super) fn read_size(
    key: &str,
    item: &Item,
    kind: Kind,
    unit: Unit,
) -> Parsed<Option<At<Size>>> {
    let u = unit.suffix();
    let what = format!("`{key}`");
    let size = if key == kind.count_key() {
        Size::Count(read::count(item, &what, kind.count_range())?)
    } else if key == format!("spacing_{u}") {
        Size::Spacing(unit.to_si(read::positive(item, &what)?))
    } else if key == format!("knots_{u}") {
        Size::Knots(read_knots(item, &what, unit)?)
    } else {
        return Ok(None);
    };
    Ok(Some(At {
        value: size,
        span: item.span(),
    }))
}

pub(super) fn read_knots(item: &Item, what: &str, unit: Unit) -> Parsed<Vec<f64>> {
    let list = read::array(item, what, "a list of knot positions")?;
    if list.len() < 2 || list.len() > MAX_POINTS {
        let msg = format!(
            "{what} must list 2 to {MAX_POINTS} knots, got {}",
            list.len()
        );
        return Err(problem(item.span(), msg));
    }
    let mut knots: Vec<f64> = Vec::with_capacity(list.len());
    for entry in list {
        let v = read::number(entry, &format!("a knot of {what}"))?;
        if let Some(&last) = knots.last()
            && unit.to_si(v) <= last
        {
            let msg = format!(
                "{what} must increase strictly: {v} follows {}",
                unit.to_file(last)
            );
            return Err(problem(entry.span(), msg));
        }
        knots.push(unit.to_si(v));
    }
    Ok(knots)
}

pub(super) fn read_option(spec: &mut Spec, key: &str, item: &Item, unit: Unit) -> Parsed<()> {
    let what = format!("`{key}`");
    let span = item.span();
    match key {
        "min_degree" | "min_harmonic" => {
            let range = spec.kind.value.count_range();
            let value = read::count(item, &what, range)?;
            spec.min = Some(At { value, span });
        }
        "pin_first" | "pin_last" => {
            let value = read::boolean(item, &what)?;
            let slot = if key == "pin_first" {
                &mut spec.pin_first
            } else {
                &mut spec.pin_last
            };
            *slot = Some(At { value, span });
        }
        _ => {
            let value = read_stroke(item, &what, unit)?;
            spec.stroke = Some(At { value, span });
        }
    }
    Ok(())
}

pub(super) fn read_stroke(item: &Item, what: &str, unit: Unit) -> Parsed<(f64, f64)> {
    let expected = "[lo, hi] with lo < hi";
    let list = read::array(item, what, expected)?;
    let [lo, hi] = list else {
        let msg = format!("{what} must be {expected}, got {} values", list.len());
        return Err(problem(item.span(), msg));
    };
    let lo = read::number(lo, what)?;
    let hi = read::number(hi, what)?;
    if lo >= hi {
        let msg = format!("{what} must be {expected}, got [{lo}, {hi}]");
        return Err(problem(item.span(), msg));
    }
    Ok((unit.to_si(lo), unit.to_si(hi)))
}

/// What a spec needs as a whole: a size for tables and splines, no stroke beside knot positions.
pub(super) fn check_spec(spec: &Spec, table_span: Span, cx: &SpecContext) -> Parsed<()> {
    let u = cx.unit.suffix();
    let needs = match spec.kind.value {
        Kind::Table if cx.scope == Scope::Component => {
            format!("one of `knots`, `spacing_{u}` or `knots_{u}`")
        }
        Kind::Table => format!("`knots` or `spacing_{u}`"),
        Kind::BSpline => "`control_points`".to_string(),
        Kind::Legendre | Kind::Fourier => String::new(),
    };
    if spec.size.is_none() && !needs.is_empty() {
        let msg = format!(
            "{}: a {} basis needs {needs}",
            cx.place,
            spec.kind.value.name()
        );
        return Err(problem(table_span, msg));
    }
    if let (
        Some(stroke),
        Some(At {
            value: Size::Knots(_),
            ..
        }),
    ) = (&spec.stroke, &spec.size)
    {
        let msg = format!("`knots_{u}` sets the stroke already; remove `stroke_{u}`");
        return Err(problem(stroke.span.clone(), msg));
    }
    Ok(())
}
