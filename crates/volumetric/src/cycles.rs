//! The visits cut into measuring cycles: one visit of each point per cycle.
//!
//! In time order, a visit starts a new cycle when its point was already visited in the current
//! one (the program came round again), or when the pause before it is longer than
//! [`crate::PAUSE_FACTOR`] × the median pause between visits (a load or rest phase). The
//! second rule keeps a cycle that misses a visit from taking the next cycle's first visit.
//! The point order inside a cycle is free (a program may run forwards and backwards).

use crate::PAUSE_FACTOR;
use crate::points::Visits;

/// A cycle that misses points.
#[derive(Debug, Clone, PartialEq)]
pub struct IncompleteCycle {
    /// 1-based.
    pub cycle: usize,
    pub missing: Vec<String>,
}

/// How many cycles each rule started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CycleCut {
    /// A point came again.
    pub by_return: usize,
    /// A pause longer than [`PAUSE_FACTOR`] × the median (and no point came again).
    pub by_pause: usize,
}

/// The cycles found.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycles {
    /// Per cycle, its visits `(point, visit index)` in time order.
    pub visits: Vec<Vec<(usize, usize)>>,
    /// Per point, the cycle (0-based) of each of its visits.
    pub cycle_of: Vec<Vec<usize>>,
    /// Per cycle, the midpoint of its first and last visit, s: the instant it stands for.
    pub mid_s: Vec<f64>,
    pub complete: Vec<bool>,
    pub incomplete: Vec<IncompleteCycle>,
    pub cut: CycleCut,
    /// The median pause between two visits, s.
    pub median_pause_s: f64,
    /// The median time from a cycle's first visit to its last, s (complete cycles).
    pub span_s: f64,
    /// The median pause between a cycle's last visit and the next one's first, s (`None`
    /// with one cycle).
    pub between_s: Option<f64>,
    /// Whether most pauses between cycles are phases: longer than half a cycle's span.
    pub phases_between: bool,
}

/// The cycles of `visits` (module docs).
pub(crate) fn cut(visits: &Visits) -> Cycles {
    let order = visits.in_time_order();
    let pauses: Vec<f64> = order
        .windows(2)
        .map(|w| visits.visit(w[1]).t_s - visits.visit(w[0]).t_s)
        .collect();
    let median_pause_s = median(&pauses).unwrap_or(0.0);
    let n_points = visits.points.len();
    let mut cycle_of: Vec<Vec<usize>> = visits
        .points
        .iter()
        .map(|p| vec![0; p.visits.len()])
        .collect();
    let mut cycles: Vec<Vec<(usize, usize)>> = Vec::new();
    let mut seen = vec![false; n_points];
    let mut cut = CycleCut::default();
    for (k, &(j, v)) in order.iter().enumerate() {
        let long_pause = k > 0 && pauses[k - 1] > PAUSE_FACTOR * median_pause_s;
        let start = match cycles.last() {
            None => true,
            Some(_) if seen[j] => {
                cut.by_return += 1;
                true
            }
            Some(_) if long_pause => {
                cut.by_pause += 1;
                true
            }
            Some(_) => false,
        };
        if start {
            cycles.push(Vec::new());
            seen.iter_mut().for_each(|s| *s = false);
        }
        seen[j] = true;
        cycle_of[j][v] = cycles.len() - 1;
        cycles.last_mut().expect("a cycle").push((j, v));
    }
    summarise(visits, cycles, cycle_of, cut, median_pause_s)
}

fn summarise(
    visits: &Visits,
    cycles: Vec<Vec<(usize, usize)>>,
    cycle_of: Vec<Vec<usize>>,
    cut: CycleCut,
    median_pause_s: f64,
) -> Cycles {
    let n_points = visits.points.len();
    let t = |c: &[(usize, usize)], k: usize| visits.visit(c[k]).t_s;
    let mid_s: Vec<f64> = cycles
        .iter()
        .map(|c| 0.5 * (t(c, 0) + t(c, c.len() - 1)))
        .collect();
    let complete: Vec<bool> = cycles.iter().map(|c| c.len() == n_points).collect();
    let incomplete = cycles
        .iter()
        .enumerate()
        .filter(|(_, c)| c.len() < n_points)
        .map(|(k, c)| IncompleteCycle {
            cycle: k + 1,
            missing: visits
                .points
                .iter()
                .enumerate()
                .filter(|(j, _)| !c.iter().any(|(i, _)| i == j))
                .map(|(_, p)| p.name.clone())
                .collect(),
        })
        .collect();
    let spans: Vec<f64> = cycles
        .iter()
        .zip(&complete)
        .filter(|(_, full)| **full)
        .map(|(c, _)| t(c, c.len() - 1) - t(c, 0))
        .collect();
    let span_s = median(&spans).unwrap_or(0.0);
    let between: Vec<f64> = cycles
        .windows(2)
        .map(|w| t(&w[1], 0) - t(&w[0], w[0].len() - 1))
        .collect();
    let phases = between.iter().filter(|&&b| b > 0.5 * span_s).count();
    Cycles {
        phases_between: !between.is_empty() && 2 * phases >= between.len(),
        between_s: median(&between),
        visits: cycles,
        cycle_of,
        mid_s,
        complete,
        incomplete,
        cut,
        median_pause_s,
        span_s,
    }
}

/// The median, `None` of nothing.
pub(crate) fn median(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(match n % 2 {
        1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    })
}

impl Cycles {
    pub fn len(&self) -> usize {
        self.visits.len()
    }

    pub fn is_empty(&self) -> bool {
        self.visits.is_empty()
    }

    /// Complete cycles.
    pub fn complete_count(&self) -> usize {
        self.complete.iter().filter(|&&c| c).count()
    }

    /// What was found, in a sentence.
    pub fn describe(&self, points: usize) -> String {
        let n = self.len();
        let complete = self.complete_count();
        let all = match complete == n {
            true => "all complete".to_string(),
            false => format!("{complete} complete"),
        };
        let between = match self.between_s {
            Some(b) => format!(", {} between them", minutes(b)),
            None => String::new(),
        };
        format!(
            "{n} cycles of {points} points ({all}), each {} from first to last visit{between}; \
             cut where a point came again ({}) or after a pause over {PAUSE_FACTOR}× the median \
             {:.0} s ({})",
            minutes(self.span_s),
            self.cut.by_return,
            self.median_pause_s,
            self.cut.by_pause
        )
    }

    /// Notes on cycles that miss points.
    pub(crate) fn notes(&self) -> Vec<String> {
        self.incomplete
            .iter()
            .take(5)
            .map(|c| {
                format!(
                    "cycle {} misses {}: their values at its instant are interpolated between \
                     their neighbouring visits",
                    c.cycle,
                    c.missing.join(", ")
                )
            })
            .chain(
                (self.incomplete.len() > 5)
                    .then(|| format!("and {} more cycles miss points", self.incomplete.len() - 5)),
            )
            .collect()
    }
}

/// `4.3 min` or `35 s`.
pub(crate) fn minutes(s: f64) -> String {
    if s >= 120.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{s:.0} s")
    }
}
