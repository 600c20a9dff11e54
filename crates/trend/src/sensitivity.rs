//! The linear sensitivity of a parameter to temperature.

use serde::Serialize;

use crate::error::TrendError;
use crate::line::fit_line;
use crate::point::{Point, check_point};
use crate::scatter::Scatter;

/// The linear sensitivity of a parameter to temperature.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Sensitivity {
    /// Points fitted.
    pub n: usize,
    /// Change of the parameter per kelvin, its unit per K (µm/K, µrad/K…).
    pub per_kelvin: f64,
    /// Its expanded uncertainty.
    pub u95_per_kelvin: f64,
    /// The weighted mean temperature, where level and sensitivity are uncorrelated.
    pub reference_temperature_c: f64,
    /// The fitted value there and its expanded uncertainty.
    pub value_at_reference: f64,
    pub value_at_reference_u95: f64,
    /// Scatter about the line (dof = n − 2).
    pub scatter: Scatter,
    /// `|per_kelvin| > u95_per_kelvin`.
    pub significant: bool,
}

/// The weighted line of value against temperature; `None` when no point carries one.
///
/// Errors when only some points carry a temperature, fewer than 3 do, or all are equal. It is
/// a static sensitivity: a structure that lags behind its temperature sensor shows a smaller
/// slope and a larger scatter (see [`Scatter`]).
pub fn temperature_sensitivity(points: &[Point]) -> Result<Option<Sensitivity>, TrendError> {
    const WHAT: &str = "a temperature sensitivity";
    for (index, p) in points.iter().enumerate() {
        check_point(index, p)?;
    }
    let temperatures: Vec<f64> = points.iter().filter_map(|p| p.temperature_c).collect();
    if temperatures.is_empty() {
        return Ok(None);
    }
    if temperatures.len() < points.len() {
        return Err(TrendError::PartialTemperature {
            with: temperatures.len(),
            n: points.len(),
        });
    }
    if points.len() < 3 {
        return Err(TrendError::TooFewPoints {
            what: WHAT,
            needed: 3,
            found: points.len(),
        });
    }
    if temperatures.iter().all(|&t| t == temperatures[0]) {
        return Err(TrendError::IdenticalTemperatures {
            n: points.len(),
            temperature_c: temperatures[0],
        });
    }
    let values: Vec<f64> = points.iter().map(|p| p.value).collect();
    let sigma: Vec<f64> = points.iter().map(Point::sigma).collect();
    let line =
        fit_line(&temperatures, &values, &sigma).ok_or(TrendError::OutOfRange { what: WHAT })?;
    let scatter = Scatter::new(line.chi2, points.len() - 2);
    let u95_per_kelvin = scatter.expansion() * line.sd_slope;
    Ok(Some(Sensitivity {
        n: points.len(),
        per_kelvin: line.slope,
        u95_per_kelvin,
        reference_temperature_c: line.x_ref,
        value_at_reference: line.level,
        value_at_reference_u95: scatter.expansion() * line.sd_level,
        scatter,
        significant: line.slope.abs() > u95_per_kelvin,
    }))
}
