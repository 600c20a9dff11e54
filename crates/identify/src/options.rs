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
        if let Some(i) = mtcal_located::toml::index_in(path, "effect") {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The key and message of reading `text` as `[identify]` into `T`.
    fn problem<T: serde::de::DeserializeOwned + std::fmt::Debug>(text: &str) -> (String, String) {
        let table: toml::Table = toml::from_str(text).unwrap();
        let p = from_table::<T>(&table, &IdentifyMessages).unwrap_err();
        let key = p.key.split(['.', '[']).next().unwrap().to_string();
        (key, p.message)
    }

    #[test]
    fn the_studys_keys_are_worded_at_their_key() {
        let unknown = format!("unknown key; [identify] knows {}", IDENTIFY_KEYS.join(", "));
        let cases = [
            ("parameter = 1", "parameter", unknown.as_str()),
            (
                "parameters = 3",
                "parameters",
                "expected a list of ISO 230-1 names, found 3",
            ),
            (
                "parameters = [\"EXX\", 3]",
                "parameters",
                "expected a name in quotes, found 3",
            ),
            (
                "start = 3",
                "start",
                "expected a parameter file name, found 3",
            ),
            (
                "effect = 3",
                "effect",
                "expected a list of [[identify.effect]] tables",
            ),
            ("effect = [{}, 3]", "effect", "effect 2 is not a table"),
            (
                "held_prior = \"x\"",
                "held_prior",
                "expected a positive number (µm or µrad), found \"x\"",
            ),
        ];
        for (text, key, message) in cases {
            let got = problem::<StudyOptions>(text);
            assert_eq!(got, (key.to_string(), message.to_string()), "{text}");
        }
    }

    #[test]
    fn the_search_keys_are_left_to_the_search() {
        let table: toml::Table = toml::from_str("heldout = 3\nfolds = \"x\"").unwrap();
        assert!(from_table::<StudyOptions>(&table, &IdentifyMessages).is_ok());
        let (key, message) = problem::<SearchKeys>("heldout = 3");
        assert_eq!(key, "heldout");
        assert_eq!(
            message,
            "expected \"blocks\", \"runs\" or \"timeline\", found 3"
        );
        let (key, message) = problem::<SearchKeys>("folds = 2.5");
        assert_eq!(key, "folds");
        assert_eq!(message, "expected a whole number ≥ 2, found 2.5");
    }
}
