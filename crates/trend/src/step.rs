//! The single step change that best splits a history, and how likely so good a split is by
//! chance.

use serde::Serialize;

use crate::error::TrendError;
use crate::null::{LineBasis, NullTest, Ratios, Split, best_split, null_test};
use crate::point::{Point, check_series};
use crate::scatter::Scatter;

/// Settings of the step test.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StepOptions {
    /// Fewest points on each side of a step (a single last result that changed is
    /// [`consecutive_changes`](crate::consecutive_changes)' question).
    pub min_segment: usize,
    /// Simulated no-change series for the p-value (at least 19, so that p can reach 5 %).
    pub simulations: usize,
    /// Seed of the simulations: the same series gives the same p-value.
    pub seed: u64,
    /// Significance level: a step is reported significant when `p < alpha`.
    pub alpha: f64,
}

impl Default for StepOptions {
    fn default() -> Self {
        StepOptions {
            min_segment: 2,
            simulations: 1999,
            seed: 22,
            alpha: 0.05,
        }
    }
}

/// The best single step: constant before, another constant after.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StepChange {
    /// Position of the first point after the step.
    pub index: usize,
    /// Time of the last point before the step.
    pub time_before_s: f64,
    /// Time of the first point after it.
    pub time_after_s: f64,
    /// Weighted mean before the step and its expanded uncertainty.
    pub level_before: f64,
    pub level_before_u95: f64,
    /// Weighted mean after the step and its expanded uncertainty.
    pub level_after: f64,
    pub level_after_u95: f64,
    /// `level_after − level_before`.
    pub shift: f64,
    /// Its expanded uncertainty, given the step's place (the search for the place is what the
    /// p-value accounts for).
    pub shift_u95: f64,
    /// Probability that a series without a change splits at least this well somewhere.
    pub p_value: f64,
    /// `p_value < alpha`.
    pub significant: bool,
    /// Probability that a series without a change shows a drift or a step at least this
    /// strong (min-p of the step's and the straight line's statistics on the same
    /// simulations): the test of [`prefer`](crate::prefer), whose false alarms stay at `alpha`
    /// although it looks for two kinds of change.
    pub any_change_p_value: f64,
    /// `any_change_p_value < alpha`.
    pub any_change: bool,
    /// Scatter about the two levels.
    pub scatter: Scatter,
    /// Simulations behind the p-value.
    pub simulations: usize,
}

/// The single step change that best splits the series, and its p-value.
///
/// Every place between two different times with at least `min_segment` points each side is
/// tried; the best is the one with the smallest χ² about the two weighted means. The test
/// statistic is `R = max (χ²₀ − χ²_k)/χ²₀` (χ²₀ about the one weighted mean), which depends on
/// neither the level nor a common factor on all uncertainties. Its distribution under "no
/// change" is therefore the same for every constant series whose true uncertainties are the
/// stated ones times any factor, and is simulated exactly: `simulations` series of independent
/// normal values with the stated relative uncertainties, seeded. `p = (1 + #{R_sim ≥ R})/(N + 1)`
/// is a valid p-value (`P(p ≤ α) ≤ α` under no change). The same simulations give the
/// straight line's share of χ² and so [`StepChange::any_change_p_value`] (see `null.rs`).
pub fn find_step(points: &[Point], options: &StepOptions) -> Result<StepChange, TrendError> {
    check_options(options)?;
    let needed = (2 * options.min_segment).max(3);
    check_series(points, needed, "a step test")?;
    let splits = allowed_splits(points, options.min_segment);
    if splits.is_empty() {
        return Err(TrendError::NoSplit {
            min_segment: options.min_segment,
        });
    }
    let weighted = Weighted::of(points).ok_or(TrendError::OutOfRange {
        what: "a step test",
    })?;
    let best = best_split(&weighted.y, &weighted.w, &splits, &mut Vec::new());
    let days: Vec<f64> = points
        .iter()
        .map(|p| (p.time_s - points[0].time_s) / 86_400.0)
        .collect();
    // A split exists, so there are two different times and the line has a slope.
    let line = LineBasis::new(&days, &weighted.w).ok_or(TrendError::OutOfRange {
        what: "a step test",
    })?;
    let observed = Ratios {
        step: best.ratio,
        line: line.ratio(&weighted.y, &weighted.w),
    };
    let w = &weighted.w;
    let test = null_test(
        observed,
        w,
        &splits,
        &line,
        options.simulations,
        options.seed,
    );
    Ok(weighted.step(points, &best, test, options))
}

fn check_options(options: &StepOptions) -> Result<(), TrendError> {
    let bad = |what, value: usize, expected| TrendError::BadSetting {
        what,
        value: value as f64,
        expected,
    };
    if options.min_segment < 1 {
        return Err(bad("min_segment", options.min_segment, "at least 1"));
    }
    if options.simulations < 19 {
        return Err(bad("simulations", options.simulations, "at least 19"));
    }
    if !(options.alpha > 0.0 && options.alpha < 1.0) {
        return Err(TrendError::BadSetting {
            what: "alpha",
            value: options.alpha,
            expected: "between 0 and 1",
        });
    }
    Ok(())
}

/// The positions `k` (first point after the step) with `min_segment` points each side and a
/// time difference across the step.
fn allowed_splits(points: &[Point], min_segment: usize) -> Vec<usize> {
    let n = points.len();
    (min_segment..=n.saturating_sub(min_segment))
        .filter(|&k| k > 0 && k < n && points[k].time_s > points[k - 1].time_s)
        .collect()
}

/// The series in units of its smallest standard uncertainty `s`, centred on its weighted
/// mean: weights `w = (s/σ)²` and values `y = (value − mean)/s`, so that the sums stay in
/// range whatever the unit.
struct Weighted {
    s: f64,
    mean: f64,
    w: Vec<f64>,
    y: Vec<f64>,
}

impl Weighted {
    fn of(points: &[Point]) -> Option<Weighted> {
        let s = points
            .iter()
            .map(Point::sigma)
            .fold(f64::INFINITY, f64::min);
        let w: Vec<f64> = points.iter().map(|p| (s / p.sigma()).powi(2)).collect();
        let sw: f64 = w.iter().sum();
        let mean = points.iter().zip(&w).map(|(p, w)| w * p.value).sum::<f64>() / sw;
        let y: Vec<f64> = points.iter().map(|p| (p.value - mean) / s).collect();
        let finite = y.iter().chain(&w).all(|v| v.is_finite()) && mean.is_finite();
        finite.then_some(Weighted { s, mean, w, y })
    }

    /// The step at `best` in the parameter's units.
    fn step(
        &self,
        points: &[Point],
        best: &Split,
        test: NullTest,
        options: &StepOptions,
    ) -> StepChange {
        let k = best.index;
        let (w1, w2) = (best.w_before, best.w_after);
        let scatter = Scatter::new(best.chi2_step, points.len() - 2);
        let e = scatter.expansion() * self.s;
        let level_before = self.mean + self.s * best.sum_before / w1;
        let level_after = self.mean + self.s * best.sum_after / w2;
        StepChange {
            index: k,
            time_before_s: points[k - 1].time_s,
            time_after_s: points[k].time_s,
            level_before,
            level_before_u95: e / w1.sqrt(),
            level_after,
            level_after_u95: e / w2.sqrt(),
            shift: level_after - level_before,
            shift_u95: e * (1.0 / w1 + 1.0 / w2).sqrt(),
            p_value: test.step,
            significant: test.step < options.alpha,
            any_change_p_value: test.any,
            any_change: test.any < options.alpha,
            scatter,
            simulations: options.simulations,
        }
    }
}
