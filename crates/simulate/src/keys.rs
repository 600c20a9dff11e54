//! The plan format's fixed-shape parts as typed structs, read through `mtcal_located::toml`
//! (serde, unknown keys rejected) and worded as the plan format words its problems. The value
//! checks serde cannot say (ranges, a run's instrument) follow in `plan` and `runs`; tables
//! handed on stay tables: set-ups and paths (the instrument plugins), `[[effect]]`
//! (`mtcal_effects::plant`), `[context]` and `[nuisance]` (keyed by column and set-up names).

use mtcal_located::toml::{Found, Messages, Number};
use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use std::collections::BTreeMap;
use std::fmt;

/// Keys of a plan's top level.
pub(crate) const PLAN_KEYS: &[&str] = &[
    "machine",
    "truth",
    "truth_errors",
    "pause_s",
    "record",
    "context",
    "effect",
    "seed",
    "interval_s",
    "identify",
    "setup",
    "nuisance",
    "run",
];

/// Keys of a plan's runs.
pub(crate) const RUN_KEYS: &[&str] = &[
    "name",
    "instrument",
    "setup",
    "use",
    "path",
    "noise",
    "readings",
    "interval_s",
    "feed_mm_min",
];

/// Keys of `[record]`.
pub(crate) const RECORD_KEYS: &[&str] = &["positions", "readings", "time", "context"];

/// A plan's top level.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PlanKeys {
    pub machine: Option<String>,
    pub truth: Option<String>,
    pub truth_errors: Option<String>,
    pub pause_s: Option<Number>,
    pub record: Option<RecordKeys>,
    pub context: Option<toml::Table>,
    pub effect: Option<Vec<toml::Table>>,
    pub seed: Option<i64>,
    pub interval_s: Option<Number>,
    /// A value that is not a table counts as none, as it always has.
    pub identify: Option<toml::Value>,
    pub setup: Option<BTreeMap<String, toml::Table>>,
    /// A value that is not a table counts as none, as it always has.
    pub nuisance: Option<toml::Value>,
    pub run: Option<Vec<toml::Table>>,
}

/// `[record]`: decimals, checked for their range by `Record`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RecordKeys {
    pub positions: Option<i64>,
    pub readings: Option<i64>,
    pub time: Option<i64>,
    pub context: Option<i64>,
}

/// A run's name, read before the rest of the run: every other problem of a run is told under
/// its name.
#[derive(Debug, Deserialize)]
pub(crate) struct RunName {
    pub name: Option<String>,
}

/// One `[[run]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RunKeys {
    /// Read first, by [`RunName`].
    #[serde(rename = "name")]
    _name: Option<de::IgnoredAny>,
    pub instrument: Option<String>,
    pub setup: Option<SetupKey>,
    /// A value that is not a string counts as none (a fitted run), as it always has.
    #[serde(rename = "use")]
    pub use_: Option<toml::Value>,
    pub path: Option<toml::Table>,
    pub noise: Option<Number>,
    pub readings: Option<bool>,
    pub interval_s: Option<Number>,
    pub feed_mm_min: Option<Number>,
}

/// A run's `setup`: the name of a shared `[setup.<name>]`, or the run's own table.
#[derive(Debug, Clone)]
pub(crate) enum SetupKey {
    Shared(String),
    Own(toml::Table),
}

impl<'de> Deserialize<'de> for SetupKey {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(SetupKeyVisitor)
    }
}

struct SetupKeyVisitor;

impl<'de> Visitor<'de> for SetupKeyVisitor {
    type Value = SetupKey;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a name or a table")
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<SetupKey, E> {
        Ok(SetupKey::Shared(v.to_string()))
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<SetupKey, A::Error> {
        let table = toml::Table::deserialize(de::value::MapAccessDeserializer::new(map))?;
        Ok(SetupKey::Own(table))
    }
}

/// The plan format's wording of unknown keys and wrong types, at the top level and in
/// `[record]`.
pub(crate) struct PlanMessages;

impl Messages for PlanMessages {
    fn unknown_key(&self, table: &str, key: &str, _: &[&str]) -> Option<String> {
        match table {
            "" => Some(format!(
                "unknown key `{key}`; a plan has {}",
                PLAN_KEYS.join(", ")
            )),
            "record" => Some(format!(
                "[record] unknown key `{key}`; it has {}",
                RECORD_KEYS.join(", ")
            )),
            _ => None,
        }
    }

    fn wrong_type(&self, path: &str, found: &Found, _: &str) -> Option<String> {
        let v = found.value.as_deref().unwrap_or(found.noun);
        if let Some(k) = path.strip_prefix("record.") {
            return Some(format!(
                "[record] `{k}` must be a number of decimals from 0 to 9, found {v}"
            ));
        }
        if let Some(k) = path.strip_prefix("setup.") {
            return Some(format!("`setup.{k}` must be a table"));
        }
        if let Some(i) = mtcal_located::toml::index_in(path, "run") {
            return Some(format!("run {} is not a table", i + 1));
        }
        if let Some(i) = mtcal_located::toml::index_in(path, "effect") {
            return Some(format!("effect {} is not a table", i + 1));
        }
        let message = match path {
            "machine" => "missing `machine = \"<file>.urdf\"` (or a topology code)".to_string(),
            "truth" | "truth_errors" => format!("`{path}` must be a file name, found {v}"),
            "seed" => format!("`seed` must be a non-negative integer, found {v}"),
            "interval_s" => format!("`interval_s` must be a positive number, found {v}"),
            "pause_s" => format!("`pause_s` must be a number ≥ 0, found {v}"),
            "record" => format!("`record` must be a table, found {v}"),
            "context" => "`context` must be a table of columns".to_string(),
            "effect" => "`effect` must be a list of [[effect]] tables".to_string(),
            "setup" => "`setup` must be a table of set-ups".to_string(),
            "run" => "no [[run]]".to_string(),
            _ => return None,
        };
        Some(message)
    }
}

/// The plan format's wording of a run's unknown keys and wrong types.
pub(crate) struct RunMessages;

impl Messages for RunMessages {
    fn unknown_key(&self, _: &str, key: &str, _: &[&str]) -> Option<String> {
        Some(format!(
            "unknown key `{key}`; a plan run has {}",
            RUN_KEYS.join(", ")
        ))
    }

    fn wrong_type(&self, path: &str, found: &Found, _: &str) -> Option<String> {
        let v = found.value.as_deref().unwrap_or(found.noun);
        let message = match path {
            "instrument" => "missing `instrument`".to_string(),
            "setup" => format!("`setup` must be a name or a table, found {v}"),
            "path" => format!("`path` must be a table, found {v}"),
            "noise" => format!("`noise` must be a number ≥ 0, found {v}"),
            "readings" => format!("`readings` must be true or false, found {v}"),
            "interval_s" => format!("`interval_s` must be > 0, found {v}"),
            "feed_mm_min" => format!("`feed_mm_min` must be > 0, found {v}"),
            _ => return None,
        };
        Some(message)
    }
}
