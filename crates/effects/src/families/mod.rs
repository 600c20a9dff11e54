//! The built-in effect families, and what they share: the targets an effect can act on, the
//! grids of starting values for shape parameters, and the reading of plant tables.
//!
//! # Plant tables (`[[effect]]` in a test plan)
//! `effect = "<family>"`, the target, the family's structural keys (documented in each module)
//! and one key per parameter, named as the parameter (`tau_s`, `amplitude_um`, …) in its
//! unit. Targets:
//! - `axis = "Z"`: the axis is effectively displaced (µm, or µrad for a rotary axis);
//! - `channel = "d_ch1"` (and `instrument = "displacement"` when several instruments have a
//!   channel of that name): the reading changes (in the channel's unit);
//! - `setup = "ball-low"`, `nuisance = "ball_x"`: a set-up parameter changes (its unit).

mod axis;
mod instrument;
mod local;
mod location;
pub(crate) mod model;
mod spindle;
mod thermal;
mod tilt;

use crate::basic::AmplitudeUnit;
use crate::view::SessionView;
use crate::{Effect, EffectInfo, PlantError, Target};
use mtcal_kinematics::{AxisLetter, Direction};

/// A target with how it is named and measured.
#[derive(Clone, Debug)]
pub(crate) struct Aim {
    pub target: Target,
    /// In words: `Z`, `channel d_ch1`, `set-up ball-low's ball_x`.
    pub words: String,
    pub unit: AmplitudeUnit,
    pub axis: Option<char>,
    pub component: Option<String>,
    /// For labels: `Z`, `d_ch1`, `ball-low.ball_x`.
    pub short: String,
}

impl Aim {
    pub fn info(&self, class: &'static str, driver: Option<String>) -> EffectInfo {
        let label = match &driver {
            Some(d) => format!("{class} {} ({d})", self.short),
            None => format!("{class} {}", self.short),
        };
        EffectInfo {
            class,
            axis: self.axis,
            component: self.component.clone(),
            driver,
            label,
        }
    }
}

/// The ISO 230-1 positioning component of an axis (`EXX`, `ECC`).
pub(crate) fn positioning_name(letter: char, rotary: bool) -> Option<String> {
    let l = AxisLetter::new(letter)?;
    let d = Direction::from_parts(rotary, l.nominal_cartesian());
    Some(format!("E{}{}", d.letter(), letter))
}

/// The ISO 230-1 straightness (or, for `across == along`, positioning) component of linear
/// axis `along` in the direction of linear axis `across` (`EYX`: X's straightness along Y).
pub(crate) fn straightness_name(across: char, along: char) -> Option<String> {
    let b = AxisLetter::new(across)?;
    let d = Direction::from_parts(false, b.nominal_cartesian());
    Some(format!("E{}{along}", d.letter()))
}

/// Axis `a` as a target.
pub(crate) fn axis_aim(view: &SessionView, a: usize) -> Aim {
    let ax = &view.axes[a];
    Aim {
        target: Target::Axis(a),
        words: ax.letter.to_string(),
        unit: if ax.rotary {
            AmplitudeUnit::urad()
        } else {
            AmplitudeUnit::um()
        },
        axis: Some(ax.letter),
        component: positioning_name(ax.letter, ax.rotary),
        short: ax.letter.to_string(),
    }
}

/// The linear axes, as targets of translations (thermal growth), when some channel reads the
/// tool pose.
pub(crate) fn linear_axis_aims(view: &SessionView) -> Vec<Aim> {
    if !view.any_pose_reading() {
        return Vec::new();
    }
    (0..view.axes.len())
        .filter(|&a| !view.axes[a].rotary)
        .map(|a| axis_aim(view, a))
        .collect()
}

/// A channel (by instrument and name) as a target: every set-up of that instrument with a
/// channel of that name.
pub(crate) fn channel_aim(view: &SessionView, instrument: &str, channel: &str) -> Option<Aim> {
    let per_setup: Vec<Option<usize>> = view
        .setups
        .iter()
        .map(|s| {
            (s.instrument == instrument)
                .then(|| s.channels.iter().position(|c| c.name == channel))
                .flatten()
        })
        .collect();
    let first = view
        .setups
        .iter()
        .zip(&per_setup)
        .find_map(|(s, c)| c.map(|c| &s.channels[c]))?;
    let (unit, per_si) = (first.unit.as_str().to_string(), first.unit.per_si());
    Some(Aim {
        target: Target::Channel { per_setup },
        words: format!("channel {channel}"),
        unit: AmplitudeUnit { unit, per_si },
        axis: None,
        component: Some(format!("{instrument}.{channel}")),
        short: channel.to_string(),
    })
}

/// Channels that do not read the pose (sensors modelled on their own), one target per
/// instrument and channel name.
pub(crate) fn standalone_channel_aims(view: &SessionView) -> Vec<Aim> {
    let mut seen: Vec<(String, String)> = Vec::new();
    for s in &view.setups {
        for (c, ch) in s.channels.iter().enumerate() {
            let key = (s.instrument.clone(), ch.name.clone());
            if !s.reads_pose[c] && !seen.contains(&key) {
                seen.push(key);
            }
        }
    }
    seen.iter()
        .filter_map(|(i, c)| channel_aim(view, i, c))
        .collect()
}

/// Targets of thermal effects: linear axes and standalone channels.
pub(crate) fn thermal_aims(view: &SessionView) -> Vec<Aim> {
    let mut out = linear_axis_aims(view);
    out.extend(standalone_channel_aims(view));
    out
}

/// Starting time constants of a drift from the session's start: fractions of the session's
/// length, no shorter than five sample intervals.
pub(crate) fn drift_taus(view: &SessionView) -> Vec<f64> {
    let d = view.duration();
    let floor = 5.0 * view.median_interval();
    [1.0 / 16.0, 1.0 / 8.0, 0.25, 0.5, 1.0, 2.0]
        .iter()
        .map(|f| f * d)
        .filter(|&tau| tau >= floor && tau > 0.0)
        .collect()
}

/// Starting time constants of thermal nodes driven by an input: 5 min to about 11 h, doubling,
/// no shorter than five sample intervals and no longer than twice the session.
pub(crate) fn lag_taus(view: &SessionView) -> Vec<f64> {
    let d = view.duration();
    let floor = 5.0 * view.median_interval();
    (0..8)
        .map(|k| 300.0 * f64::from(1u32 << k))
        .filter(|&tau| tau >= floor && tau <= 2.0 * d)
        .collect()
}

/// Whether axis `a` reverses in some fitted run.
pub(crate) fn reverses(view: &SessionView, a: usize) -> bool {
    (0..view.runs.len()).any(|r| view.runs[r].fit && view.motion(r, a).reverses)
}

/// Whether axis `a` moves both ways in the fitted runs: it reverses within one, or some runs
/// move it one way and others the other (a rotary axis turned forward in one run and back in
/// the next: its backlash is a constant of each run, flipping with the run's direction).
pub(crate) fn moves_both_ways(view: &SessionView, a: usize) -> bool {
    if reverses(view, a) {
        return true;
    }
    let mut seen = [false; 2];
    for r in (0..view.runs.len()).filter(|&r| view.runs[r].fit && !view.runs[r].is_empty()) {
        match view.direction(r, a, view.runs[r].len() - 1) {
            1 => seen[0] = true,
            -1 => seen[1] = true,
            _ => {}
        }
    }
    seen[0] && seen[1]
}

/// Whether axis `a` stands at different positions over the fitted samples (by more than a
/// micrometre or microradian), within a run or between runs: a ball of a volumetric thermal
/// test at each of several places, each visited at one.
pub(crate) fn positions_vary(view: &SessionView, a: usize) -> bool {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (r, run) in view.runs.iter().enumerate().filter(|(_, r)| r.fit) {
        for i in 0..run.len() {
            let q = view.q(r, i, a);
            lo = lo.min(q);
            hi = hi.max(q);
        }
    }
    hi - lo > 1e-6
}

/// Whether axis `a` moves in some fitted run.
pub(crate) fn moves(view: &SessionView, a: usize) -> bool {
    (0..view.runs.len()).any(|r| view.runs[r].fit && view.motion(r, a).moves)
}

// ---------------------------------------------------------------------------------------------
// Plant tables

/// A string key.
pub(crate) fn string<'a>(table: &'a toml::Table, key: &str) -> Result<Option<&'a str>, PlantError> {
    match table.get(key) {
        None => Ok(None),
        Some(toml::Value::String(s)) => Ok(Some(s)),
        Some(v) => Err(PlantError::at(
            key,
            format!("`{key}` must be a string, found {v}"),
        )),
    }
}

/// The target a plant table names (`axis`, `channel` [+ `instrument`], or `setup` +
/// `nuisance`).
pub(crate) fn plant_aim(table: &toml::Table, view: &SessionView) -> Result<Aim, PlantError> {
    if let Some(letter) = string(table, "axis")? {
        let c = single_letter(letter)?;
        let a = view.axis_index(c).ok_or_else(|| {
            PlantError::at(
                "axis",
                format!(
                    "`axis = \"{letter}\"`: the machine has axes {}",
                    view.axes.iter().map(|a| a.letter).collect::<String>()
                ),
            )
        })?;
        return Ok(axis_aim(view, a));
    }
    if let Some(channel) = string(table, "channel")? {
        let instrument = match string(table, "instrument")? {
            Some(i) => i.to_string(),
            None => {
                let owners: Vec<&str> = view
                    .setups
                    .iter()
                    .filter(|s| s.channels.iter().any(|c| c.name == channel))
                    .map(|s| s.instrument.as_str())
                    .collect();
                match owners.first() {
                    None => {
                        return Err(PlantError::at(
                            "channel",
                            format!("no instrument of the plan has a channel `{channel}`"),
                        ));
                    }
                    Some(first) if owners.iter().any(|o| o != first) => {
                        return Err(PlantError::at(
                            "channel",
                            format!(
                                "several instruments have a channel `{channel}`: say which with `instrument = \"…\"`"
                            ),
                        ));
                    }
                    Some(first) => first.to_string(),
                }
            }
        };
        return channel_aim(view, &instrument, channel).ok_or_else(|| {
            PlantError::at(
                "channel",
                format!("instrument `{instrument}` has no channel `{channel}`"),
            )
        });
    }
    if let Some(setup) = string(table, "setup")? {
        let s = view
            .setups
            .iter()
            .position(|x| x.name == setup)
            .ok_or_else(|| PlantError::at("setup", format!("no set-up `{setup}` in the plan")))?;
        let name = string(table, "nuisance")?
            .ok_or_else(|| "a set-up target needs `nuisance = \"<parameter>\"`".to_string())?;
        let index = view.setups[s]
            .nuisance
            .iter()
            .position(|n| n.name == name)
            .ok_or_else(|| {
                PlantError::at(
                    "nuisance",
                    format!(
                        "set-up `{setup}` has no parameter `{name}`; it has {}",
                        view.setups[s]
                            .nuisance
                            .iter()
                            .map(|n| n.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            })?;
        return Ok(nuisance_aim(view, s, index));
    }
    Err("name a target: `axis = \"Z\"`, `channel = \"…\"` or `setup` + `nuisance`".into())
}

/// Nuisance parameter `index` of set-up `s` as a target.
pub(crate) fn nuisance_aim(view: &SessionView, s: usize, index: usize) -> Aim {
    let setup = &view.setups[s];
    let n = &setup.nuisance[index];
    Aim {
        target: Target::Nuisance { setup: s, index },
        words: format!("set-up {}'s {}", setup.name, n.name),
        unit: AmplitudeUnit {
            unit: n.unit.as_str().to_string(),
            per_si: n.unit.per_si(),
        },
        axis: None,
        component: Some(format!("{}.{}", setup.name, n.name)),
        short: format!("{}.{}", setup.name, n.name),
    }
}

pub(crate) fn single_letter(s: &str) -> Result<char, PlantError> {
    let mut chars = s.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) => Ok(c.to_ascii_uppercase()),
        _ => Err(format!("expected one axis letter, found `{s}`").into()),
    }
}

/// The parameter values (SI) of `effect` from a plant table: one key per parameter, in its
/// unit (`None` where the table has none); `structural` are the other keys the family read.
/// Unknown keys are rejected.
pub(crate) fn plant_values(
    effect: &dyn Effect,
    table: &toml::Table,
    structural: &[&str],
) -> Result<Vec<Option<f64>>, PlantError> {
    let names: Vec<&str> = effect.params().iter().map(|p| p.name.as_str()).collect();
    for key in table.keys() {
        let known = key == "effect"
            || ["axis", "channel", "instrument", "setup", "nuisance"].contains(&key.as_str())
            || structural.contains(&key.as_str())
            || names.contains(&key.as_str());
        if !known {
            return Err(PlantError::at(
                key,
                format!(
                    "unknown key `{key}`; this {} effect takes {}",
                    effect.info().class,
                    names.join(", ")
                ),
            ));
        }
    }
    effect
        .params()
        .iter()
        .map(|p| {
            let Some(v) = table.get(&p.name) else {
                return Ok(None);
            };
            let x = v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    PlantError::at(
                        &p.name,
                        format!("`{}` must be a finite number, found {v}", p.name),
                    )
                })?;
            let si = x / p.per_si;
            if let Some((lo, hi)) = p.bounds
                && !(lo..=hi).contains(&si)
            {
                return Err(PlantError::at(
                    &p.name,
                    format!(
                        "`{}` = {x} is outside {} … {} {}",
                        p.name,
                        lo * p.per_si,
                        hi * p.per_si,
                        p.unit
                    ),
                ));
            }
            Ok(Some(si))
        })
        .collect()
}

/// The shape parameter's value among `values` (for building the planted effect with it as its
/// starting value).
pub(crate) fn number(
    table: &toml::Table,
    key: &str,
    per_si: f64,
) -> Result<Option<f64>, PlantError> {
    match table.get(key) {
        None => Ok(None),
        Some(v) => v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .filter(|x| x.is_finite() && *x > 0.0)
            .map(|x| Some(x / per_si))
            .ok_or_else(|| {
                PlantError::at(key, format!("`{key}` must be a positive number, found {v}"))
            }),
    }
}

/// The candidates of an effect following temperature `column`: its static form, and — when
/// that is already in the model (is the sensor late?) — its lagged form at every starting lag
/// ([`lag_taus`]). `make(feature, tau)` builds the effect.
pub(crate) fn static_and_lagged<E: Effect>(
    view: &SessionView,
    column: &str,
    make: impl Fn(crate::basic::Feature, Option<f64>) -> E,
) -> Vec<E> {
    use crate::basic::Feature;
    let input = crate::view::Input::Context(column.to_string());
    let stat = make(Feature::Static(input.clone()), None);
    let followed = view.has_current(&stat.info().label);
    let mut out = vec![stat];
    if followed {
        out.extend(
            lag_taus(view)
                .into_iter()
                .map(|tau| make(Feature::Lag(input.clone()), Some(tau))),
        );
    }
    out
}

/// A plant table's temperature driver, `driver = "T_<name>"` (a column some run records), and
/// the feature on it: static, or lagged with the table's `tau_s`. `what` names the effect in
/// the message (`a thermal tilt`).
pub(crate) fn temperature_driver<'t>(
    table: &'t toml::Table,
    view: &SessionView,
    what: &str,
) -> Result<(&'t str, crate::basic::Feature, Option<f64>), PlantError> {
    use crate::basic::Feature;
    let column = string(table, "driver")?
        .filter(|d| d.starts_with("T_"))
        .ok_or_else(|| format!("{what} needs `driver = \"T_<column>\"`"))?;
    if !view.temperature_columns().iter().any(|c| c == column) {
        return Err(PlantError::at(
            "driver",
            format!("`driver = \"{column}\"`: no run records that temperature"),
        ));
    }
    let input = crate::view::Input::Context(column.to_string());
    Ok(match number(table, "tau_s", 1.0)? {
        Some(tau) => (column, Feature::Lag(input), Some(tau)),
        None => (column, Feature::Static(input), None),
    })
}
