//! What an instrument's runs are, declared by its plugin for the tools that handle runs by what
//! they are rather than by who took them.
//!
//! An importer writes an axis' positioning deviations or a circle's radius deviations read from
//! a vendor's file; the volumetric test reads visits of fixed points; the report draws runs with
//! a polar view in a section of their own. None of them names an instrument: each asks for the
//! capability ([`declared_once`], [`declared_some`]) and gets the plugin's own vocabulary with it —
//! its name for the manifest's `instrument`, its set-up keys, its reading columns. A plugin
//! submits each capability it has with `inventory::submit!` beside its [`InstrumentPlugin`]
//! (`instrument` is that registration's `name`).
//!
//! [`InstrumentPlugin`]: crate::InstrumentPlugin

/// A capability a plugin may declare.
pub trait Capability: inventory::Collect {
    /// The capability in words, for messages: `positioning runs`.
    const WHAT: &'static str;
    /// The plugin (its registered name) that declared it.
    fn instrument(&self) -> &'static str;
}

/// Every declaration of `C`, sorted by instrument. As with the plugins, only the declarations
/// of plugin crates the binary links are here (`mtcal-plugins` links them all).
pub fn declared<C: Capability>() -> Vec<&'static C> {
    let mut all: Vec<&'static C> = inventory::iter::<C>.into_iter().collect();
    all.sort_by_key(|c| c.instrument());
    all
}

/// The one declaration of `C`: a tool that writes such runs must know which instrument's they
/// are, so none or several is an error.
pub fn declared_once<C: Capability>() -> Result<&'static C, CapabilityError> {
    match declared::<C>().as_slice() {
        [one] => Ok(one),
        all => Err(CapabilityError {
            what: C::WHAT,
            instruments: all.iter().map(|c| c.instrument()).collect(),
        }),
    }
}

/// Every declaration of `C`, at least one: a tool that reads such runs needs a plugin that
/// records them.
pub fn declared_some<C: Capability>() -> Result<Vec<&'static C>, CapabilityError> {
    let all = declared::<C>();
    if all.is_empty() {
        return Err(CapabilityError {
            what: C::WHAT,
            instruments: Vec::new(),
        });
    }
    Ok(all)
}

/// No plugin declares a capability a tool needs, or several declare one it needs once.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}", self.message())]
pub struct CapabilityError {
    pub what: &'static str,
    /// The instruments that declare it (none, or several).
    pub instruments: Vec<&'static str>,
}

impl CapabilityError {
    fn message(&self) -> String {
        if self.instruments.is_empty() {
            format!(
                "no instrument plugin records {}: the plugin that does is not linked",
                self.what
            )
        } else {
            format!(
                "several instrument plugins record {} ({}): expected one",
                self.what,
                self.instruments.join(", ")
            )
        }
    }
}

/// Runs of an axis' positioning deviation along its travel (ISO 230-2), one reading per
/// position: what a laser interferometer's linear exports hold.
#[derive(Debug)]
pub struct PositioningRuns {
    pub instrument: &'static str,
    /// The reading column: the deviation along the axis, µm.
    pub reading: &'static str,
    /// The run's own set-up measuring along the linear axis `axis` (its letter).
    pub setup: fn(axis: char) -> toml::Table,
}

/// Runs of a circle's radius deviation about a pivot (ISO 230-4), one reading per angle: what a
/// ball-bar's exports hold.
#[derive(Debug)]
pub struct CircleRuns {
    pub instrument: &'static str,
    /// The reading column: the radius minus its nominal, µm.
    pub reading: &'static str,
    /// The measuring range (±, µm): a reading beyond it is no deviation.
    pub range_um: f64,
    /// The set-up of a circle of radius `radius_mm` about `pivot_mm` (workpiece frame, mm).
    pub setup: fn(pivot_mm: [f64; 3], radius_mm: f64) -> toml::Table,
}

/// Runs whose rows are visits of fixed points on the table: each row the displacement between
/// the point and the tool side along three axes, µm (an R-test's ball visits, docs/VOLUMETRIC.md).
#[derive(Debug)]
pub struct PointVisits {
    pub instrument: &'static str,
    /// The three reading columns, along X, Y and Z.
    pub readings: [&'static str; 3],
    /// The set-up key of the point: `[x, y, z]`, mm, workpiece frame.
    pub point_key: &'static str,
    /// The set-up key of the readings' measuring range (±, µm), and the range without it.
    pub range_key: &'static str,
    pub default_range_um: f64,
    /// The set-up under which the readings are along the machine's axes.
    pub machine_axes: MachineAxes,
}

/// A set-up key whose default value makes readings along the machine's axes, and that
/// arrangement in words (`the nest in the spindle`).
#[derive(Debug)]
pub struct MachineAxes {
    pub key: &'static str,
    pub value: &'static str,
    pub words: &'static str,
}

/// The identification report's section of the runs an instrument draws on a circle
/// ([`InstrumentPlugin::polar_view`](crate::InstrumentPlugin::polar_view)); its id is the
/// instrument's name.
#[derive(Debug)]
pub struct PolarSection {
    pub instrument: &'static str,
    pub heading: &'static str,
    /// What the section says when the session has no such run.
    pub none: &'static str,
}

inventory::collect!(PositioningRuns);
inventory::collect!(CircleRuns);
inventory::collect!(PointVisits);
inventory::collect!(PolarSection);

impl Capability for PositioningRuns {
    const WHAT: &'static str = "positioning runs";
    fn instrument(&self) -> &'static str {
        self.instrument
    }
}

impl Capability for CircleRuns {
    const WHAT: &'static str = "circle runs";
    fn instrument(&self) -> &'static str {
        self.instrument
    }
}

impl Capability for PointVisits {
    const WHAT: &'static str = "point visits";
    fn instrument(&self) -> &'static str {
        self.instrument
    }
}

impl Capability for PolarSection {
    const WHAT: &'static str = "a report section of polar views";
    fn instrument(&self) -> &'static str {
        self.instrument
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    inventory::submit! {
        PointVisits {
            instrument: "b-head",
            readings: ["dx", "dy", "dz"],
            point_key: "ball",
            range_key: "range_um",
            default_range_um: 1.0,
            machine_axes: MachineAxes { key: "mount", value: "on-table", words: "a head" },
        }
    }
    inventory::submit! {
        PointVisits {
            instrument: "a-head",
            readings: ["dx", "dy", "dz"],
            point_key: "ball",
            range_key: "range_um",
            default_range_um: 1.0,
            machine_axes: MachineAxes { key: "mount", value: "on-table", words: "a head" },
        }
    }

    /// Declarations come sorted by instrument; a tool that needs one is told who declares it
    /// when none or several do.
    #[test]
    fn a_capability_is_found_by_what_it_is() {
        let names: Vec<_> = declared::<PointVisits>()
            .iter()
            .map(|c| c.instrument)
            .collect();
        assert_eq!(names, ["a-head", "b-head"]);
        let several = declared_once::<PointVisits>().unwrap_err();
        assert_eq!(
            several.to_string(),
            "several instrument plugins record point visits (a-head, b-head): expected one"
        );
        assert_eq!(declared_some::<PointVisits>().unwrap().len(), 2);
        let none = declared_some::<CircleRuns>().unwrap_err();
        assert_eq!(declared_once::<CircleRuns>().unwrap_err(), none);
        assert_eq!(
            none.to_string(),
            "no instrument plugin records circle runs: the plugin that does is not linked"
        );
    }
}
