//! A fixed `[[run]]` of a planning file, read into typed keys with the planner's wording.

use mtcal_located::toml::{Found, Messages, from_table};
use serde::Deserialize;

/// The keys a fixed `[[run]]` may have.
pub(crate) const RUN_KEYS: &[&str] = &["name", "instrument", "setup", "path", "use", "feed_mm_min"];

/// A fixed run as written; `setup` is a set-up's name or its own table, matched by the planner.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FixedRunKeys {
    pub name: String,
    pub instrument: Option<String>,
    pub setup: Option<toml::Value>,
    #[serde(default)]
    pub path: toml::Table,
    #[serde(rename = "use", default = "fit")]
    pub use_: String,
    pub feed_mm_min: Option<f64>,
}

fn fit() -> String {
    "fit".to_string()
}

/// Only the name, read first so that every later message can name the run.
#[derive(Deserialize)]
struct NameKey {
    name: String,
}

/// Reads a fixed run's table; an error is the message to locate at the run.
pub(crate) fn read(table: &toml::Table) -> Result<FixedRunKeys, String> {
    let name = from_table::<NameKey>(table, &RunMessages)
        .map_err(|_| "a [[run]] needs `name = \"…\"`".to_string())?
        .name;
    from_table(table, &RunMessages).map_err(|p| format!("run `{name}`: {}", p.message))
}

/// The planning format's wording of a run's unknown keys and wrong types.
struct RunMessages;

impl Messages for RunMessages {
    fn unknown_key(&self, _: &str, key: &str, _: &[&str]) -> Option<String> {
        Some(format!(
            "unknown key `{key}`; a run has {}",
            RUN_KEYS.join(", ")
        ))
    }

    fn wrong_type(&self, path: &str, found: &Found, _: &str) -> Option<String> {
        let v = found.value.as_deref().unwrap_or(found.noun);
        let message = match path {
            "instrument" => "missing `instrument`".to_string(),
            "path" => "`path` must be a table".to_string(),
            "use" => format!("`use` must be \"fit\" or \"validate\", found {v}"),
            "feed_mm_min" => format!("`feed_mm_min` must be a number (mm/min), found {v}"),
            _ => return None,
        };
        Some(message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(text: &str) -> Result<FixedRunKeys, String> {
        read(&toml::from_str(text).unwrap())
    }

    #[test]
    fn a_full_run_reads_into_its_keys() {
        let k = keys(
            "name = \"r\"\ninstrument = \"rtest\"\nsetup = \"s\"\npath = { kind = \"xyc\" }\n\
             use = \"validate\"\nfeed_mm_min = 2000",
        )
        .unwrap();
        assert_eq!(
            (k.name.as_str(), k.instrument.as_deref()),
            ("r", Some("rtest"))
        );
        assert_eq!(k.setup, Some(toml::Value::String("s".into())));
        assert_eq!(k.path.get("kind").and_then(|v| v.as_str()), Some("xyc"));
        assert_eq!((k.use_.as_str(), k.feed_mm_min), ("validate", Some(2000.0)));
        let k = keys("name = \"r\"").unwrap();
        assert_eq!(
            (k.use_.as_str(), k.path.len(), k.feed_mm_min),
            ("fit", 0, None)
        );
    }

    /// The messages the planner gave when it read these keys by hand, and the two wrong types
    /// it used to take for their defaults.
    #[test]
    fn every_problem_names_the_run_and_the_key() {
        let cases = [
            (
                "instrument = \"rtest\"",
                "a [[run]] needs `name = \"…\"`".to_string(),
            ),
            ("name = 3", "a [[run]] needs `name = \"…\"`".to_string()),
            (
                "name = \"r\"\ncolour = 1",
                format!(
                    "run `r`: unknown key `colour`; a run has {}",
                    RUN_KEYS.join(", ")
                ),
            ),
            (
                "name = \"r\"\ninstrument = 3",
                "run `r`: missing `instrument`".to_string(),
            ),
            (
                "name = \"r\"\npath = 3",
                "run `r`: `path` must be a table".to_string(),
            ),
            (
                "name = \"r\"\nuse = 1",
                "run `r`: `use` must be \"fit\" or \"validate\", found 1".to_string(),
            ),
            (
                "name = \"r\"\nfeed_mm_min = \"fast\"",
                "run `r`: `feed_mm_min` must be a number (mm/min), found \"fast\"".to_string(),
            ),
        ];
        for (text, want) in cases {
            assert_eq!(keys(text).unwrap_err(), want, "{text}");
        }
    }
}
