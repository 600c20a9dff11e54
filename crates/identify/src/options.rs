//! The session manifest's `[identify]` table as typed structs, read through
//! `mtcal_located::toml::from_table` and worded as `[identify]` words its problems, each at its
//! key (`Session::identify_location`). The study reads its keys ([`StudyOptions`], every key
//! known); the search reads its own when it runs ([`SearchKeys`]).

use crate::IdentifyError;
use mtcal_located::toml::{Found, KeyProblem, Messages, Number, from_table};
use mtcal_session::Session;
use serde::Deserialize;
use serde::de::IgnoredAny;

/// Keys of the manifest's `[identify]` table.
pub const IDENTIFY_KEYS: &[&str] = &[
    "parameters",
    "start",
    "effect",
    "heldout",
    "folds",
    "held_prior",
];

/// `[identify]` as the study reads it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct StudyOptions {
    /// ISO 230-1 names of the parameters to estimate (default: all).
    pub parameters: Option<Vec<String>>,
    /// Parameter file of the starting values, relative to the session.
    pub start: Option<String>,
    /// `[[identify.effect]]` tables, handed to `mtcal_effects::configure`.
    pub effect: Option<Vec<toml::Table>>,
    /// Prior σ of the coefficients the runs cannot determine, µm or µrad.
    pub held_prior: Option<Number>,
    /// The search's ([`SearchKeys`]).
    #[serde(rename = "heldout")]
    _heldout: Option<IgnoredAny>,
    #[serde(rename = "folds")]
    _folds: Option<IgnoredAny>,
}

/// The search's keys of `[identify]` (the others are the study's).
#[derive(Debug, Deserialize)]
pub(crate) struct SearchKeys {
    /// `"blocks"`, `"runs"` or `"timeline"`.
    pub heldout: Option<String>,
    pub folds: Option<i64>,
}

impl StudyOptions {
    pub(crate) fn read(session: &Session) -> Result<StudyOptions, IdentifyError> {
        from_table(&session.identify, &IdentifyMessages).map_err(|p| key_error(session, p))
    }
}

impl SearchKeys {
    pub(crate) fn read(session: &Session) -> Result<SearchKeys, IdentifyError> {
        from_table(&session.identify, &IdentifyMessages).map_err(|p| key_error(session, p))
    }
}

/// A problem at `[identify]` key `key`.
pub(crate) fn identify_key(session: &Session, key: &str, message: &str) -> IdentifyError {
    IdentifyError::Options {
        at: session.identify_location(key),
        key: key.to_string(),
        message: message.to_string(),
    }
}

/// A problem found reading the table, at its top-level key (`parameters[2]` is told at
/// `parameters`).
fn key_error(session: &Session, problem: KeyProblem) -> IdentifyError {
    let key = problem.key.split(['.', '[']).next().unwrap_or_default();
    identify_key(session, key, &problem.message)
}

/// `[identify]`'s wording of unknown keys and wrong types.
struct IdentifyMessages;

impl Messages for IdentifyMessages {
    fn unknown_key(&self, _: &str, _: &str, _: &[&str]) -> Option<String> {
        Some(format!(
            "unknown key; [identify] knows {}",
            IDENTIFY_KEYS.join(", ")
        ))
    }

    fn wrong_type(&self, path: &str, found: &Found, _: &str) -> Option<String> {
        let v = found.value.as_deref().unwrap_or(found.noun);
        if path.starts_with("parameters[") {
            return Some(format!("expected a name in quotes, found {v}"));
        }
        if let Some(i) = index_in(path, "effect") {
            return Some(format!("effect {} is not a table", i + 1));
        }
        let message = match path {
            "parameters" => format!("expected a list of ISO 230-1 names, found {v}"),
            "start" => format!("expected a parameter file name, found {v}"),
            "effect" => "expected a list of [[identify.effect]] tables".to_string(),
            "held_prior" => format!("expected a positive number (µm or µrad), found {v}"),
            "heldout" => format!("expected \"blocks\", \"runs\" or \"timeline\", found {v}"),
            "folds" => format!("expected a whole number ≥ 2, found {v}"),
            _ => return None,
        };
        Some(message)
    }
}

/// `i` of a path `<list>[i]`.
fn index_in(path: &str, list: &str) -> Option<usize> {
    path.strip_prefix(list)?
        .strip_prefix('[')?
        .strip_suffix(']')?
        .parse()
        .ok()
}
