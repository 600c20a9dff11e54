//! `[context]`: the programmes of the context columns (spindle speed, temperatures, air) over
//! session time.

use crate::SimulateError;
use std::path::Path;

/// A context column's programme over session time.
#[derive(Debug, Clone)]
pub(crate) struct Schedule {
    /// `(time s, value)`, increasing in time.
    points: Vec<(f64, f64)>,
    /// Steps (spindle speed, feed: the value holds until the next point) or linear
    /// interpolation (temperatures).
    steps: bool,
}

impl Schedule {
    /// The value at session time `t`.
    pub(crate) fn at(&self, t: f64) -> f64 {
        let p = &self.points;
        let k = p.partition_point(|(ti, _)| *ti <= t);
        if k == 0 {
            return p[0].1;
        }
        if self.steps || k == p.len() {
            return p[k - 1].1;
        }
        let ((t0, v0), (t1, v1)) = (p[k - 1], p[k]);
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    }
}

/// The plan's `[context]` table (`None`: none): per column a list of `[time_s, value]`
/// points.
pub(crate) fn context_schedules(
    context: Option<&toml::Table>,
    file: &Path,
) -> Result<Vec<(String, Schedule)>, SimulateError> {
    let err = |message: String| SimulateError::Plan {
        file: file.to_path_buf(),
        message,
    };
    let Some(table) = context else {
        return Ok(Vec::new());
    };
    table
        .iter()
        .map(|(name, v)| Ok((name.clone(), schedule(name, v).map_err(err)?)))
        .collect()
}

/// Column `name`'s programme from its list of `[time_s, value]` points, or what is wrong.
fn schedule(name: &str, v: &toml::Value) -> Result<Schedule, String> {
    let steps = match name {
        "S" | "F" => true,
        n if ["T_", "P_", "H_"].iter().any(|p| n.starts_with(p)) && n.len() > 2 => false,
        _ => {
            return Err(format!(
                "[context] `{name}`: context columns are S, F, T_<name> (°C), P_<name> \
                 (hPa) and H_<name> (% RH)"
            ));
        }
    };
    let bad = || {
        format!("[context] `{name}` must be a list of [time_s, value] pairs, increasing in time")
    };
    let num = |x: &toml::Value| {
        x.as_float()
            .or_else(|| x.as_integer().map(|i| i as f64))
            .filter(|x| x.is_finite())
    };
    let list = v.as_array().ok_or_else(bad)?;
    let mut points: Vec<(f64, f64)> = Vec::with_capacity(list.len());
    for item in list {
        let pair = item.as_array().filter(|a| a.len() == 2).ok_or_else(bad)?;
        let (t, value) = (
            num(&pair[0]).ok_or_else(bad)?,
            num(&pair[1]).ok_or_else(bad)?,
        );
        if points.last().is_some_and(|(tp, _)| *tp >= t) {
            return Err(bad());
        }
        points.push((t, value));
    }
    if points.is_empty() {
        return Err(bad());
    }
    Ok(Schedule { points, steps })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_hold_and_temperatures_interpolate() {
        let points = vec![(0.0, 20.0), (10.0, 22.0)];
        let temperature = Schedule {
            points: points.clone(),
            steps: false,
        };
        let speed = Schedule {
            points,
            steps: true,
        };
        assert_eq!(temperature.at(-1.0), 20.0);
        assert_eq!(temperature.at(5.0), 21.0);
        assert_eq!(temperature.at(20.0), 22.0);
        assert_eq!(speed.at(5.0), 20.0);
        assert_eq!(speed.at(10.0), 22.0);
    }

    #[test]
    fn a_context_column_must_be_a_known_kind_with_increasing_times() {
        let table: toml::Table = toml::from_str("T_bed = [[0.0, 20.0], [0.0, 21.0]]").unwrap();
        let e = context_schedules(Some(&table), Path::new("p.toml")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.toml: [context] `T_bed` must be a list of [time_s, value] pairs, increasing in time"
        );
        let table: toml::Table = toml::from_str("X = [[0.0, 1.0]]").unwrap();
        let e = context_schedules(Some(&table), Path::new("p.toml")).unwrap_err();
        assert!(e.to_string().contains("context columns are S, F"), "{e}");
    }
}
