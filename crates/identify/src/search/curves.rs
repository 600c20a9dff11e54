//! Whether a component error is one a machine could have, judged by its whole curve over the
//! axis' stroke rather than coefficient by coefficient ([`implausible_curves`]). The generic
//! range of a machine parameter (a millimetre) holds a single coefficient; but a ball-bar or a
//! short artefact barely tells a Legendre basis' coefficients apart, and a refit that raises a
//! component's order can trade them off into a curve of hundreds of micrometres that no
//! guideway has, each coefficient still "in range". Used by the step (a candidate may not drive
//! a plausible curve beyond its range) and by what the final model keeps (a component given
//! more orders must remain a plausible curve).

use crate::K95;
use crate::ids::{CoeffId, ParamId};
use crate::study::Study;
use mtcal_kinematics::{ParamName, Term};
use mtcal_solve::Solution;
use std::collections::BTreeMap;

/// Plausible peak of a translational component error (positioning, straightness) over an
/// axis' stroke, per metre of stroke: ten times what ISO 230-1 acceptance tolerances of a
/// machine tool allow, a machine worn out of any specification.
const TRANSLATION_PER_M: f64 = 100e-6;
/// The floor of that range on a short stroke.
const TRANSLATION_FLOOR: f64 = 30e-6;
/// Plausible peak of an angular component error (pitch, yaw, roll) over the stroke.
const ROTATION: f64 = 500e-6;
/// Points of the stroke at which a curve is evaluated.
const GRID: usize = 201;

/// A component error's curve over its axis' stroke in a fit.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Curve {
    /// The component, `EZX`.
    pub component: String,
    /// Largest magnitude over the stroke (SI).
    pub peak: f64,
    /// Its 95 % uncertainty in the fit (SI).
    pub peak_u95: f64,
    /// The widest 95 % uncertainty of the curve anywhere over the stroke (SI).
    pub widest_u95: f64,
    /// The plausible range of that magnitude (SI).
    pub range: f64,
    /// Reporting unit and its factor from SI.
    pub unit: String,
    pub per_si: f64,
}

impl Curve {
    /// Beyond its range by more than its own uncertainty: a curve the data barely pin down
    /// (coefficients that a ball-bar trades off) is not blamed for where its value wanders.
    pub(super) fn implausible(&self) -> bool {
        self.peak - self.peak_u95 > self.range
    }

    /// Not an identification: somewhere over the stroke its interval is wider than the range.
    pub(super) fn undetermined(&self) -> bool {
        self.widest_u95 > self.range
    }

    pub(super) fn describe(&self) -> String {
        format!(
            "{} reaches {:.1} ± {:.1} {} over its axis' stroke, beyond a plausible ±{:.1} {}",
            self.component,
            self.peak * self.per_si,
            self.peak_u95 * self.per_si,
            self.unit,
            self.range * self.per_si,
            self.unit
        )
    }
}

/// Every Legendre component error of a linear axis in `study` whose coefficients the fit
/// `solution` all determines, with its curve's peak and plausible range. A component with a
/// coefficient in the null space has no value to judge.
pub(super) fn component_curves(study: &Study, solution: &Solution) -> Vec<Curve> {
    // component → (degree, index)
    let mut by_component: BTreeMap<String, Vec<(usize, usize)>> = BTreeMap::new();
    for i in 0..study.layout().n_x() {
        if let ParamId::Machine(CoeffId {
            param: param @ ParamName::Component { .. },
            term: Some(Term::Legendre(degree)),
        }) = study.param_id(i)
        {
            by_component
                .entry(param.to_string())
                .or_default()
                .push((degree, i));
        }
    }
    let axes = &study.view().axes;
    by_component
        .into_iter()
        .filter_map(|(component, coefficients)| {
            if coefficients
                .iter()
                .any(|&(_, i)| solution.sigma[i].is_none())
            {
                return None;
            }
            let letters: Vec<char> = component.chars().collect();
            let axis = axes.iter().find(|a| !a.rotary && a.letter == letters[2])?;
            let stroke_m = (axis.stroke.1 - axis.stroke.0).abs();
            let angular = matches!(letters[1], 'A' | 'B' | 'C');
            let range = if angular {
                ROTATION
            } else {
                (TRANSLATION_PER_M * stroke_m).max(TRANSLATION_FLOOR)
            };
            let info = study.param_info(coefficients[0].1);
            let values: Vec<(usize, f64)> = coefficients
                .iter()
                .map(|&(k, i)| (k, solution.x[i]))
                .collect();
            let (peak, at) = peak(&values);
            let top = coefficients.iter().map(|&(k, _)| k).max().unwrap_or(0);
            let u95 = |u: f64| {
                let p = legendre(u, top);
                let mut variance = 0.0;
                for &(k, i) in &coefficients {
                    for &(l, j) in &coefficients {
                        variance += p[k] * p[l] * solution.cov(i, j);
                    }
                }
                K95 * variance.max(0.0).sqrt()
            };
            let widest_u95 = (0..GRID)
                .map(|g| u95(-1.0 + 2.0 * g as f64 / (GRID - 1) as f64))
                .fold(0.0, f64::max);
            Some(Curve {
                peak,
                peak_u95: u95(at),
                widest_u95,
                range,
                unit: info.unit,
                per_si: info.per_si,
                component,
            })
        })
        .collect()
}

/// The curves of `after` that are implausible while they were not in `before` (a component
/// already implausible before is not the candidate's doing).
pub(super) fn newly_implausible(before: &[Curve], after: &[Curve]) -> Option<Curve> {
    after
        .iter()
        .filter(|c| c.implausible())
        .find(|c| {
            before
                .iter()
                .find(|b| b.component == c.component)
                .is_none_or(|b| !b.implausible())
        })
        .cloned()
}

/// Largest `|Σ c_k P_k(u)|` over `u ∈ [−1, 1]` and where it is.
fn peak(coefficients: &[(usize, f64)]) -> (f64, f64) {
    let top = coefficients.iter().map(|&(k, _)| k).max().unwrap_or(0);
    (0..GRID)
        .map(|g| {
            let u = -1.0 + 2.0 * g as f64 / (GRID - 1) as f64;
            let p = legendre(u, top);
            let value: f64 = coefficients.iter().map(|&(k, c)| c * p[k]).sum();
            (value.abs(), u)
        })
        .fold((0.0, 0.0), |best, v| if v.0 > best.0 { v } else { best })
}

/// `P_0(u) … P_top(u)` (Bonnet's recurrence).
fn legendre(u: f64, top: usize) -> Vec<f64> {
    let mut p = vec![0.0; top + 1];
    p[0] = 1.0;
    if top >= 1 {
        p[1] = u;
    }
    for n in 1..top {
        p[n + 1] = ((2 * n + 1) as f64 * u * p[n] - n as f64 * p[n - 1]) / (n + 1) as f64;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peak_of_legendre_sums_matches_their_closed_forms() {
        // P3(u) = (5u³ − 3u)/2 peaks at 1 on [−1, 1]; 2·P1 + P3 = 2u + (5u³ − 3u)/2 reaches
        // 3 at u = 1.
        assert!((peak(&[(3, 1.0)]).0 - 1.0).abs() < 1e-12);
        assert!((peak(&[(1, 2.0), (3, 1.0)]).0 - 3.0).abs() < 1e-12);
        // P2 − P0 = (3u² − 1)/2 − 1 is −1.5 at u = 0 and 0 at u = ±1.
        assert!((peak(&[(0, -1.0), (2, 1.0)]).0 - 1.5).abs() < 1e-12);
        // P4(u) = (35u⁴ − 30u² + 3)/8, brute force on a fine grid.
        let brute = (0..=20_000)
            .map(|g| {
                let u = -1.0 + g as f64 / 10_000.0;
                (0.5 * (35.0 * u.powi(4) - 30.0 * u * u + 3.0) / 4.0 - 0.7 * u).abs()
            })
            .fold(0.0, f64::max);
        assert!((peak(&[(4, 1.0), (1, -0.7)]).0 - brute).abs() < 1e-3);
    }

    #[test]
    fn a_curve_is_blamed_only_beyond_its_range_by_more_than_its_uncertainty() {
        let curve = |peak: f64, peak_u95: f64| Curve {
            component: "EZX".into(),
            peak,
            peak_u95,
            widest_u95: peak_u95,
            range: 75e-6,
            unit: "um".into(),
            per_si: 1e6,
        };
        assert!(curve(447e-6, 185e-6).implausible());
        assert!(!curve(150e-6, 100e-6).implausible());
        assert!(!curve(70e-6, 0.0).implausible());
        // Only a curve that was plausible before the candidate is the candidate's doing.
        assert!(newly_implausible(&[curve(70e-6, 0.0)], &[curve(200e-6, 10e-6)]).is_some());
        assert!(newly_implausible(&[curve(200e-6, 0.0)], &[curve(300e-6, 10e-6)]).is_none());
        assert!(newly_implausible(&[], &[curve(300e-6, 10e-6)]).is_some());
    }
}
