//! Every instrument plugin of mtcal, linked.
//!
//! A plugin registers its descriptor with `inventory`; the registration lives in the plugin's
//! crate and vanishes from a binary that never names that crate. This crate names them all, and
//! whoever looks plugins up does so through its [`plugins`] and [`find`] (the identification
//! core, the planner, the command line), so anything that links them sees every plugin without
//! naming a plugin crate itself. A new plugin crate gets a `use … as _;` line here (and its
//! dependency in this crate's manifest). The tools that handle runs by what they are rather
//! than by instrument ask for a [`capability`] through here too, so the plugins that declare it
//! are linked.

use mtcal_artefact as _;
use mtcal_ballbar as _;
use mtcal_displacement as _;
use mtcal_laser as _;
use mtcal_rtest as _;
use mtcal_tracer as _;

pub use mtcal_instrument::{capability, find, plugins};

/// "unknown instrument `x`; known: a, b, …": the message for a name no plugin has.
pub fn unknown(name: &str) -> String {
    format!("unknown instrument `{name}`; known: {}", names().join(", "))
}

/// The names of every registered plugin, sorted.
pub fn names() -> Vec<&'static str> {
    plugins().iter().map(|p| p.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One plugin per crate linked above (a crate that registers none, or two, or two crates
    /// under one name, fail here), each found by its name.
    #[test]
    fn every_plugin_is_registered_exactly_once() {
        let linked = include_str!("lib.rs")
            .lines()
            .filter(|l| l.starts_with("use mtcal_") && l.ends_with(" as _;"))
            .count();
        let mut unique = names();
        unique.dedup();
        assert_eq!(unique.len(), names().len(), "{:?}", names());
        assert_eq!(names().len(), linked, "{:?}", names());
        assert!(names().contains(&"rtest"), "{:?}", names());
        for name in names() {
            assert_eq!(find(name).map(|p| p.name), Some(name));
            assert!(!find(name).expect("registered").about.is_empty());
        }
    }

    /// Each capability is declared by the plugins listed (a tool writing such runs needs
    /// exactly one), under the name they are registered by.
    #[test]
    fn every_capability_is_declared_by_its_plugins() {
        use capability::{
            Capability, CircleRuns, PointVisits, PolarSection, PositioningRuns, declared,
        };
        fn by<C: Capability>() -> Vec<&'static str> {
            let all: Vec<_> = declared::<C>().iter().map(|c| c.instrument()).collect();
            assert!(all.iter().all(|name| find(name).is_some()), "{all:?}");
            all
        }
        assert_eq!(by::<PositioningRuns>(), ["laser"]);
        assert_eq!(by::<CircleRuns>(), ["ballbar"]);
        assert_eq!(by::<PointVisits>(), ["rtest"]);
        assert_eq!(by::<PolarSection>(), ["ballbar"]);
    }
}
