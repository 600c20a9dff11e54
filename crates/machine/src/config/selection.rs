//! Which parameters a configuration selects: the keyword sets, the names listed per class,
//! the exclusions.

use super::*;

/// The three kinds of names, each listed under its own key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Class {
    Component,
    Location,
    Setup,
}

impl Class {
    pub(super) fn of(name: &ParamName) -> Self {
        match name {
            ParamName::Component { .. } => Class::Component,
            ParamName::Location { .. } => Class::Location,
            ParamName::Setup(_) => Class::Setup,
        }
    }

    pub(super) fn noun(self) -> &'static str {
        match self {
            Class::Component => "a component error",
            Class::Location => "a location error",
            Class::Setup => "a set-up parameter",
        }
    }

    fn key(self) -> &'static str {
        match self {
            Class::Component => "components",
            Class::Location => "locations",
            Class::Setup => "setup",
        }
    }
}

/// One of the keys that select parameters.
pub(super) struct SetKey {
    class: Class,
    keywords: &'static [&'static str],
    default: &'static str,
    expected: &'static str,
}

pub(super) const SETS: [SetKey; 3] = [
    SetKey {
        class: Class::Component,
        keywords: &["all", "none"],
        default: "all",
        expected: "\"all\", \"none\" or a list of component error names such as [\"EXX\", \"EYX\"]",
    },
    SetKey {
        class: Class::Location,
        keywords: &["iso", "none"],
        default: "iso",
        expected: "\"iso\", \"none\" or a list of location error names such as [\"EX0C\", \"EC0Y\"]",
    },
    SetKey {
        class: Class::Setup,
        keywords: &["none"],
        default: "none",
        expected: "\"none\" or a list of set-up parameter names such as [\"TOOL_DZ\", \"WP_DX\"]",
    },
];

/// The parameters `components`, `locations` and `setup` select, less `exclude`; each with the
/// span that selected it.
pub(super) fn read_selection(top: &DeTable, machine: &Machine) -> Parsed<Vec<At<ParamName>>> {
    let mut out = Vec::new();
    for set in &SETS {
        out.extend(read_set(top, set, machine)?);
    }
    apply_exclude(top, out, machine)
}

pub(super) fn keyword_set(keyword: &str, machine: &Machine) -> Vec<ParamName> {
    match keyword {
        "all" => machine
            .axes()
            .iter()
            .flat_map(|ax| Direction::ALL.map(|d| ParamName::component(d, ax.letter())))
            .collect(),
        "iso" => iso_location_names(machine),
        _ => Vec::new(),
    }
}

pub(super) fn read_set(
    top: &DeTable,
    set: &SetKey,
    machine: &Machine,
) -> Parsed<Vec<At<ParamName>>> {
    let key = set.class.key();
    let (keyword, span) = match top.get(key) {
        None => (set.default, 0..0),
        Some(item) => match item.get_ref() {
            DeValue::Array(list) => return read_names(list, set.class, machine),
            DeValue::String(s) if set.keywords.iter().any(|k| k == s) => (s.as_ref(), item.span()),
            DeValue::String(s) => {
                let msg = format!(
                    "{key} = \"{s}\" is not understood: expected {}",
                    set.expected
                );
                return Err(problem(item.span(), msg));
            }
            _ => return Err(read::wrong_type(item, &format!("`{key}`"), set.expected)),
        },
    };
    let names = keyword_set(keyword, machine);
    Ok(names
        .into_iter()
        .map(|value| At {
            value,
            span: span.clone(),
        })
        .collect())
}

pub(super) fn read_names(
    list: &[Item],
    class: Class,
    machine: &Machine,
) -> Parsed<Vec<At<ParamName>>> {
    let key = class.key();
    let mut out: Vec<At<ParamName>> = Vec::new();
    for item in list {
        let name = read::name_item(item, key)?;
        let span = item.span();
        let found = Class::of(&name);
        if found != class {
            let msg = format!(
                "{name} is {}; list it under `{}`",
                found.noun(),
                found.key()
            );
            return Err(problem(span, msg));
        }
        check_axis(&name, &span, machine)?;
        if out.iter().any(|a| a.value == name) {
            return Err(problem(span, format!("{name} is listed twice in `{key}`")));
        }
        out.push(At { value: name, span });
    }
    Ok(out)
}

/// The machine has the axis the name belongs to (the model's own message otherwise).
pub(super) fn check_axis(name: &ParamName, span: &Span, machine: &Machine) -> Parsed<()> {
    match name.axis() {
        Some(axis) if machine.axis_index(axis.as_char()).is_none() => {
            let e = ModelError::NoSuchAxis {
                name: name.to_string(),
                axis: axis.as_char(),
                axes: machine.letters(),
            };
            Err(problem(span.clone(), e.to_string()))
        }
        _ => Ok(()),
    }
}

pub(super) fn apply_exclude(
    top: &DeTable,
    mut selected: Vec<At<ParamName>>,
    machine: &Machine,
) -> Parsed<Vec<At<ParamName>>> {
    let Some(item) = top.get("exclude") else {
        return Ok(selected);
    };
    let list = read::array(item, "`exclude`", "a list of parameter names")?;
    let mut removed = Vec::new();
    for entry in list {
        let name = read::name_item(entry, "exclude")?;
        if removed.contains(&name) {
            return Err(problem(
                entry.span(),
                format!("{name} is listed twice in `exclude`"),
            ));
        }
        let Some(i) = selected.iter().position(|s| s.value == name) else {
            let msg = format!(
                "cannot exclude {name}: `components`, `locations` and `setup` do not select it \
                 on this machine (axes {}); remove it from `exclude`",
                machine.letters()
            );
            return Err(problem(entry.span(), msg));
        };
        selected.remove(i);
        removed.push(name);
    }
    Ok(selected)
}
