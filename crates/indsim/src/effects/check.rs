//! Checks of an effect's plan values (finite, positive, unit directions, known axes and columns),
//! each failing with a message naming the effect and the key.

use super::*;

/// The spindle speed programme of the plan, if any (at most one).
pub(super) fn spindle_programme(effects: &[Effect]) -> Result<Option<Vec<(f64, f64)>>, SimError> {
    let mut found = None;
    for e in effects {
        if let Effect::SpindleSpeed { rpm } = e {
            if found.is_some() {
                return Err(plan_error("the plan has two SpindleSpeed effects".into()));
            }
            let Programme::Steps(steps) = rpm else {
                return Err(plan_error(
                    "SpindleSpeed: the speed is a Programme::Steps of rpm".into(),
                ));
            };
            check_steps("rpm", steps).map_err(|m| plan_error(format!("SpindleSpeed: {m}")))?;
            found = Some(steps.clone());
        }
    }
    Ok(found)
}

pub(super) fn kind_name(e: &Effect) -> &'static str {
    match e {
        Effect::Backlash { .. } => "backlash",
        Effect::Thermal { .. } => "thermal",
        Effect::ScrewError { .. } => "screw-error",
        Effect::ThermalScale { .. } => "thermal-scale",
        Effect::Twist { .. } => "twist",
        Effect::Sag { .. } => "sag",
        Effect::BallBarThermal { .. } => "ballbar-thermal",
        Effect::SetupCreep { .. } => "setup-creep",
        Effect::ServoLag { .. } => "servo-lag",
        Effect::SpindleSpeed { .. } => "spindle-speed",
        Effect::LostMotion { .. } => "lost-motion",
        Effect::LateralPlay { .. } => "lateral-play",
        Effect::ReversalSpike { .. } => "reversal-spike",
        Effect::StickSlip { .. } => "stick-slip",
        Effect::GuidewayBump { .. } => "guideway-bump",
        Effect::SpindleGrowth { .. } => "spindle-growth",
        Effect::HeadRotationX { .. } => "head-rotation-x",
        Effect::AmbientStep { .. } => "ambient-step",
        Effect::AxisLineDrift { .. } => "axis-line-drift",
        Effect::TemperatureSensor { .. } => "temperature-sensor",
    }
}

/// The instrument of the plan's set-up `name`.
pub(super) fn instrument_of<'p>(
    setups: &'p [SetupPlan],
    name: &str,
) -> Result<&'p Instrument, String> {
    setups
        .iter()
        .find(|s| s.name == name)
        .map(|s| &s.instrument)
        .ok_or_else(|| format!("no set-up {name}"))
}

pub(super) fn axis_index(machine: &Machine, letter: char) -> Result<usize, String> {
    machine.index(letter).ok_or_else(|| {
        format!(
            "no axis {letter}: the machine's axes are {}",
            machine.letters()
        )
    })
}

pub(super) fn linear_axis(machine: &Machine, letter: char, what: &str) -> Result<usize, String> {
    let i = axis_index(machine, letter)?;
    match machine.joints[i].kind {
        JointKind::Linear => Ok(i),
        JointKind::Rotary => Err(format!(
            "{what} needs a linear axis {letter}; {letter} is rotary here"
        )),
    }
}

/// A direction's unit vector (machine directions), or why it is none.
pub(super) fn unit(name: &str, v: &[f64; 3]) -> Result<Vector3<f64>, String> {
    let d = Vector3::from(*v);
    if d.iter().all(|x| x.is_finite()) && d.norm() > 0.0 {
        Ok(d.normalize())
    } else {
        Err(format!("{name} {v:?} is not a direction"))
    }
}

pub(super) fn finite(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} = {v} is not a finite number"))
    }
}

pub(super) fn positive(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{name} = {v}: expected a positive number"))
    }
}

pub(super) fn finite_at_least(name: &str, v: f64, min: f64) -> Result<(), String> {
    if v.is_finite() && v >= min {
        Ok(())
    } else {
        Err(format!("{name} = {v}: expected a finite number ≥ {min}"))
    }
}

pub(super) fn check_steps(name: &str, steps: &[(f64, f64)]) -> Result<(), String> {
    if steps.iter().any(|s| !(s.0.is_finite() && s.1.is_finite())) {
        return Err(format!("{name}: every step time and value is finite"));
    }
    if steps.windows(2).any(|w| w[1].0 <= w[0].0) {
        return Err(format!("{name}: step times must increase strictly"));
    }
    Ok(())
}

/// FORMATS.md's temperature columns: `T_<name>`, a name of letters, digits and `_`.
/// The rotary axis and the direction across it of location error `name` (`EY0A`).
pub(super) fn line_location(machine: &Machine, name: &str) -> Result<(usize, usize), String> {
    const DIRECTIONS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];
    let c: Vec<char> = name.chars().collect();
    let found = (c.len() == 4 && c[0] == 'E' && c[2] == '0')
        .then(|| {
            (
                DIRECTIONS.iter().position(|&x| x == c[1]),
                machine.index(c[3]),
            )
        })
        .and_then(|(d, i)| Some((i?, d?)));
    let (i, d) = found.ok_or_else(|| {
        format!("an axis line drift: `{name}` is not a location error (EY0A) of this machine")
    })?;
    let j = &machine.joints[i];
    if j.kind != JointKind::Rotary || d % 3 == j.own_direction() {
        return Err(format!(
            "an axis line drift: `{name}` is not a location error across a rotary axis"
        ));
    }
    Ok((i, d))
}

pub(super) fn check_temperature_column(name: &str) -> Result<(), String> {
    let ok = name.strip_prefix("T_").is_some_and(|rest| {
        !rest.is_empty() && rest.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    });
    if ok {
        Ok(())
    } else {
        Err(format!(
            "column {name:?}: a temperature column is T_<name> (letters, digits, _)"
        ))
    }
}
