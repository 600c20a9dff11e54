//! The settings of one compensation file ([`Settings`]): the node spacings, held axes and
//! reversals every format may use, the built-in controls' typed limits, and each format's own
//! options by name ([`ControlOptions`]), so that a new format needs no field here.

use crate::CompensateError;
use mtcal_kinematics::Machine;
use std::collections::BTreeMap;
use std::str::FromStr;

/// The settings of a compensation file; each kind uses those it needs.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Node spacing of linear axes (pitch tables, grids, parameter tables), mm.
    pub spacing_mm: f64,
    /// Node spacing of rotary axes' parameter tables, degrees.
    pub spacing_deg: f64,
    /// Pitch tables: the controller's joint position minus mtcal's axis position, mm.
    pub joint_offset_mm: f64,
    /// Pitch tables: the signed ISO 230-2 reversal value B, µm (a bidirectional table), as the
    /// user gave it: it applies to the table's axis (Fanuc: every linear axis written) and
    /// takes the place of a reversal in `reversals`.
    pub reversal_um: Option<f64>,
    /// Reversals an identification found, per axis: each bidirectional pitch table (LinuxCNC,
    /// CSV, Fanuc) of such an axis holds its reversal, and its card says where it came from.
    pub reversals: Vec<crate::AxisReversal>,
    /// What the numbers were made from (an identification's account of what went in and what
    /// it left out), for every card: [`mtcal_machine::card::ConventionCard::made_from`].
    pub made_from: Vec<String>,
    /// Positions (SI) of the axes a pitch table or grid does not move ([`crate::default_hold`]
    /// with the user's changes).
    pub hold_q: Vec<f64>,
    /// SINUMERIK tables: the control's limits (MD38000, MD18342).
    pub siemens: crate::SiemensLimits,
    /// SINUMERIK EEC: the reference point where each linear axis' table is zero (mm, mtcal's
    /// axis coordinates; a rotary axis' table is zero at 0°), as K3 asks (no jump when the
    /// compensation starts).
    pub reference_mm: f64,
    /// Fanuc pitch error compensation: the series, increment system and limits.
    pub fanuc: crate::FanucControl,
    /// Heidenhain `.COM` tables: the control's limits (TNC 4xx or MANUALplus 620).
    pub heidenhain: crate::ComLimits,
    /// A format's own settings by name (`--control-option KEY=VALUE`): the keys it declares
    /// ([`crate::ControlFormat::options`]), read and checked by the format itself.
    pub control_options: ControlOptions,
}

impl Settings {
    /// The settings of a plain file of `machine`: nodes `spacing_mm` and `spacing_deg` apart,
    /// the other axes at [`crate::default_hold`], no joint offset and no reversal, nothing said
    /// of where the numbers came from, EEC tables zero at 0 mm, a Fanuc Series 30i with IS-C,
    /// a TNC 4xx, the SINUMERIK defaults and no format options. Change the fields a file needs.
    pub fn new(machine: &Machine, spacing_mm: f64, spacing_deg: f64) -> Self {
        Settings {
            spacing_mm,
            spacing_deg,
            joint_offset_mm: 0.0,
            reversal_um: None,
            reversals: Vec::new(),
            made_from: Vec::new(),
            hold_q: crate::default_hold(machine),
            siemens: crate::SiemensLimits::default(),
            reference_mm: 0.0,
            fanuc: crate::FanucControl::new(
                crate::FanucSeries::Series30i,
                crate::IncrementSystem::IsC,
            ),
            heidenhain: crate::ComLimits::tnc_4xx(),
            control_options: ControlOptions::default(),
        }
    }

    /// The reversal a bidirectional table of `axis` holds and where it comes from: the user's
    /// `reversal_um`, else the one an identification found for the axis.
    pub(crate) fn reversal_of(&self, axis: char) -> Option<(crate::Reversal, String)> {
        if let Some(b) = self.reversal_um {
            return Some((
                crate::Reversal::constant(b),
                format!("the reversal value given ({b:+} µm)"),
            ));
        }
        self.reversals
            .iter()
            .find(|r| r.axis == axis)
            .map(|r| (r.reversal, r.source.clone()))
    }
}

/// A format's own settings, `KEY=VALUE` by key as the user gave them; the format declares its
/// keys ([`crate::ControlFormat::options`]) and parses the values ([`ControlOptions::parsed`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ControlOptions(BTreeMap<String, String>);

impl ControlOptions {
    /// Reads `KEY=VALUE` texts (`--control-option`, repeated); a text without `=`, with an
    /// empty key or a key given twice is refused by name.
    pub fn from_pairs<'a>(
        pairs: impl IntoIterator<Item = &'a str>,
    ) -> Result<Self, CompensateError> {
        let mut map = BTreeMap::new();
        for pair in pairs {
            let bad = |message: &str| CompensateError::BadOption {
                given: pair.to_string(),
                message: message.to_string(),
            };
            let (key, value) = pair
                .split_once('=')
                .ok_or_else(|| bad("expected KEY=VALUE"))?;
            let key = key.trim();
            if key.is_empty() {
                return Err(bad("expected KEY=VALUE, the key is empty"));
            }
            if map
                .insert(key.to_string(), value.trim().to_string())
                .is_some()
            {
                return Err(bad("the key is given twice"));
            }
        }
        Ok(ControlOptions(map))
    }

    /// Sets `key` to `value` (a library caller's way to what `--control-option` gives).
    pub fn set(&mut self, key: &str, value: &str) {
        self.0.insert(key.to_string(), value.to_string());
    }

    /// The value given for `key`, as typed.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.0.get(key).map(String::as_str)
    }

    /// The keys given, sorted.
    pub fn keys(&self) -> impl Iterator<Item = &str> {
        self.0.keys().map(String::as_str)
    }

    /// The value of `key` read as a `T`, `None` when not given; a value that does not read
    /// is refused naming the key, the value and why.
    pub fn parsed<T>(&self, key: &str) -> Result<Option<T>, CompensateError>
    where
        T: FromStr,
        T::Err: std::fmt::Display,
    {
        let Some(value) = self.get(key) else {
            return Ok(None);
        };
        value
            .parse()
            .map(Some)
            .map_err(|e: T::Err| CompensateError::BadOption {
                given: format!("{key}={value}"),
                message: e.to_string(),
            })
    }
}
