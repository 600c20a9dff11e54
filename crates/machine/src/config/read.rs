//! Typed access to a parsed TOML document that keeps every key's and value's position, so that
//! errors can point at them: the located TOML reader (`mtcal-located`) and what this crate adds
//! to it, values with their place and parameter names written as keys or strings. Shared with
//! `params`.

use mtcal_kinematics::ParamName;
pub(crate) use mtcal_located::toml::*;

/// A value and where the file says it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct At<T> {
    pub(crate) value: T,
    pub(crate) span: Span,
}

/// A parameter name written as a key.
pub(crate) fn name(text: &str, span: &Span) -> Parsed<ParamName> {
    text.parse()
        .map_err(|e: mtcal_kinematics::names::ParseNameError| problem(span.clone(), e.to_string()))
}

/// A parameter name written as a string in the list under `key`.
pub(crate) fn name_item(item: &Item, key: &str) -> Parsed<ParamName> {
    let what = format!("entries of `{key}`");
    let text = string(item, &what, "parameter names (strings) such as \"EXX\"")?;
    name(text, &item.span())
}
