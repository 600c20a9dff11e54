//! How each axis moves in each run: the side it arrived from, its reversals, and where the
//! fitted samples stand.

use super::*;

/// How one axis moves during one run. Its per-sample series ([`SessionView::direction`],
/// [`SessionView::velocity`], [`SessionView::travel`], [`SessionView::since_turn`]) follow from
/// the samples where it reverses: kept per sample they would take 17 bytes a sample and axis.
///
/// # The state before a run's first motion
/// A run's file holds no approach move, so the side an axis arrived from is a guess: a linear
/// axis is taken to have come straight from where the previous run (in time) left it (the
/// controller's positioning move between two runs), or — if it did not move between them — to
/// keep the direction it last moved in. A rotary axis that turns without limit may have gone
/// either way round for a move of half a turn or more (a controller unwinds or takes the short
/// way: [`AxisView::turns_either_way`]), and the session's first run has no previous one:
/// there the direction is 0 (unknown: the mean of the two sides, a backlash `±B/2` reads 0)
/// until the axis first moves. Where the guess is wrong the run's first samples
/// carry the difference, which the residuals show.
#[derive(Clone, Debug, Default)]
pub struct AxisMotion {
    /// The side the axis arrived from ±1 (0: unknown; see above).
    pub(super) arrived: i8,
    /// Direction of the axis' first motion in the run, ±1 (0 if it never moves).
    pub(super) first_direction: i8,
    /// The sample of the first step (`step_direction` ≠ 0); the run's length if it never
    /// moves. Before it the direction is unknown (0).
    pub(super) first_motion: usize,
    /// The samples at which the axis reverses, increasing: the direction flips there, and the
    /// travel counts from the sample before (the turning point).
    pub(super) reversals: Vec<usize>,
    /// Whether the axis moves in both directions in this run.
    pub reverses: bool,
    /// Whether the axis moves at all.
    pub moves: bool,
    /// Median step between moving samples (SI): the finest detail the run resolves.
    pub step: f64,
    /// Range of positions (SI).
    pub range: (f64, f64),
}

impl AxisMotion {
    /// Reversals at or before sample `i`.
    pub(super) fn reversals_to(&self, i: usize) -> usize {
        self.reversals.partition_point(|&j| j <= i)
    }

    /// Direction of the last motion at sample `i`, ±1; before the axis' first motion in the
    /// run, the side it arrived from (0 if unknown).
    pub fn direction(&self, i: usize) -> i8 {
        let start = if self.arrived != 0 {
            self.arrived
        } else {
            self.first_direction
        };
        if i < self.first_motion && self.arrived == 0 {
            0
        } else if self.reversals_to(i) % 2 == 0 {
            start
        } else {
            -start
        }
    }

    /// Whether the direction at sample `i` was reached by a reversal: within the run, or on
    /// its first motion against the side the axis arrived from (where that side is known).
    pub fn reversed(&self, i: usize) -> bool {
        self.reversals_to(i) > 0
    }

    /// The sample the travel at sample `i` counts from: the turning point of the last
    /// reversal; on the run's first motion, the last sample before it (where the axis stood);
    /// before any motion, `i` itself.
    pub(super) fn anchor(&self, i: usize) -> usize {
        match self.reversals_to(i) {
            0 if self.arrived != 0 => 0,
            0 => self.first_motion.saturating_sub(1).min(i),
            k => self.reversals[k - 1].saturating_sub(1),
        }
    }
}

/// A run whose readings before an axis' first motion depend on the side it was approached
/// from, which is not known ([`SessionView::start_states`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StartState {
    pub run: usize,
    /// The side taken from the previous run (±1; 0 unknown): where the fit starts.
    pub guess: i8,
    /// The run's name.
    pub name: String,
}

/// way round, arrive from an unknown side.
/// Per axis, the span of its positions over the fitted runs' samples (its stroke where none).
pub(super) fn fitted_ranges(axes: &[AxisView], runs: &[RunView]) -> Vec<(f64, f64)> {
    (0..axes.len())
        .map(|a| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for run in runs.iter().filter(|r| r.fit) {
                for i in 0..run.len() {
                    let q = run.q.get(i, a);
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
            }
            if lo <= hi { (lo, hi) } else { axes[a].stroke }
        })
        .collect()
}

/// Every run's motion of every axis. Each run's linear axes arrive in the state the previous
/// run (in time) left them in ([`AxisMotion`]: the guess about the approach the file does not
/// hold); the session's first run, and a rotary axis after a move that may have gone either
pub(super) fn motions(
    axes: &[AxisView],
    runs: &[RunView],
    order: &[usize],
) -> Vec<Vec<AxisMotion>> {
    let na = axes.len();
    let mut motion: Vec<Vec<AxisMotion>> = vec![Vec::new(); runs.len()];
    let mut last_direction: Vec<i8> = vec![0; na];
    // The previous run (in time) and its last sample.
    let mut last: Option<(usize, usize)> = None;
    for &r in order {
        let run = &runs[r];
        if run.is_empty() {
            motion[r] = (0..na).map(|_| AxisMotion::default()).collect();
            continue;
        }
        motion[r] = (0..na)
            .map(|a| {
                let first = run.q.get(0, a);
                let arrived = match last.map(|(p, i)| runs[p].q.get(i, a)) {
                    Some(prev) if (first - prev).abs() > STANDING => {
                        if axes[a].turns_either_way(first - prev) {
                            0
                        } else if first > prev {
                            1
                        } else {
                            -1
                        }
                    }
                    _ => last_direction[a],
                };
                axis_motion(run.q.column(a), arrived)
            })
            .collect();
        for (a, d) in last_direction.iter_mut().enumerate() {
            let end = motion[r][a].direction(run.len() - 1);
            if end != 0 {
                *d = end;
            }
        }
        last = Some((r, run.len() - 1));
    }
    motion
}

/// The direction of the step to sample `i` of `q` (±1; 0 standing, and at the first sample).
pub(super) fn step_direction(q: &Column, i: usize) -> i8 {
    if i == 0 {
        return 0;
    }
    let d = q.get(i) - q.get(i - 1);
    match d.abs() > STANDING {
        true if d > 0.0 => 1,
        true => -1,
        false => 0,
    }
}

/// How an axis moves along its positions `q` (one run's), having arrived at its first position
/// moving in direction `arrived` (±1; 0: unknown).
pub(super) fn axis_motion(q: &Column, arrived: i8) -> AxisMotion {
    let n = q.len();
    if n == 0 {
        return AxisMotion::default();
    }
    let steps: Vec<f64> = (1..n)
        .filter(|&i| step_direction(q, i) != 0)
        .map(|i| (q.get(i) - q.get(i - 1)).abs())
        .collect();
    let moves = !steps.is_empty();
    let (first_motion, first_direction) = (1..n)
        .map(|i| (i, step_direction(q, i)))
        .find(|&(_, d)| d != 0)
        .unwrap_or((n, 0));
    let mut current = if arrived != 0 {
        arrived
    } else {
        first_direction
    };
    let mut reversals = Vec::new();
    for i in first_motion..n {
        let raw = step_direction(q, i);
        if raw != 0 && raw != current {
            // A reversal: the turning point is the previous sample (the run's first when the
            // axis arrived from the other side).
            reversals.push(i);
            current = raw;
        }
    }
    let mut steps = steps;
    steps.sort_by(f64::total_cmp);
    let step = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let (lo, hi) = (0..n).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
        (lo.min(q.get(i)), hi.max(q.get(i)))
    });
    AxisMotion {
        arrived,
        first_direction,
        first_motion,
        reverses: !reversals.is_empty(),
        reversals,
        moves,
        step,
        range: (lo, hi),
    }
}
