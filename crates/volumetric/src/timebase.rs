//! Deformations and the common time base (crate docs, "Deformation", "Cycles and the common
//! time base"): each point's value at each instant as a linear combination of its readings,
//! and that combination's variance under the estimated noise.

use crate::cycles::{Cycles, minutes};
use crate::noise::Noise;
use crate::points::{Point, SetupSequence, Visits};
use crate::{K95, VolumetricError};

/// How each point's deformation is brought to the instants.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TimeBase {
    /// Linear in time between the point's visits around the instant (the default).
    #[default]
    Interpolated,
    /// The point's visit in the instant's cycle: the cycle taken as one instant.
    Cycle,
}

impl TimeBase {
    /// `interpolated`, `cycle`.
    pub fn as_str(self) -> &'static str {
        match self {
            TimeBase::Interpolated => "interpolated",
            TimeBase::Cycle => "cycle",
        }
    }

    /// The command line's spelling.
    pub fn parse(text: &str) -> Result<TimeBase, VolumetricError> {
        match text {
            "interpolated" => Ok(TimeBase::Interpolated),
            "cycle" => Ok(TimeBase::Cycle),
            other => Err(VolumetricError::Options(format!(
                "--time-base: expected interpolated or cycle, found `{other}`"
            ))),
        }
    }
}

/// The time base used, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeBaseChoice {
    pub method: TimeBase,
    pub why: String,
}

/// The time base in words, with the cycles' timing.
pub(crate) fn choose(method: TimeBase, cycles: &Cycles) -> TimeBaseChoice {
    let timing = match cycles.between_s {
        Some(b) => format!(
            "cycles {} from first to last visit, {} between them",
            minutes(cycles.span_s),
            minutes(b)
        ),
        None => format!("one cycle of {}", minutes(cycles.span_s)),
    };
    let why = match method {
        TimeBase::Interpolated => format!(
            "each point linear in time between its visits around each cycle's midpoint, less \
             its value at the first cycle's midpoint ({timing})"
        ),
        TimeBase::Cycle => format!(
            "each point's visit in the cycle, the cycle taken as one instant, from its first \
             visit ({timing})"
        ),
    };
    TimeBaseChoice { method, why }
}

/// A point's deformation at one time: value and 95 % uncertainty per axis, µm.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesValue {
    pub t_s: f64,
    /// The cycle (0-based) of the visit.
    pub cycle: usize,
    pub deformation_um: [f64; 3],
    pub u95_um: [f64; 3],
}

/// A point's deformation at each of its visits.
#[derive(Debug, Clone, PartialEq)]
pub struct PointSeries {
    pub point: String,
    pub values: Vec<SeriesValue>,
}

/// A deformation as a combination of the point's readings: `Σ c_v·r_v`, `(visit, c)`.
type Combination = Vec<(usize, f64)>;

/// `d = r(reference) − r(now)`, each a weighted sum of the point's readings.
fn difference(reference: &[(usize, f64)], now: &[(usize, f64)]) -> Combination {
    let mut c: Combination = reference.to_vec();
    for &(v, w) in now {
        match c.iter_mut().find(|(u, _)| *u == v) {
            Some(e) => e.1 -= w,
            None => c.push((v, -w)),
        }
    }
    c
}

fn value_of(point: &Point, c: &Combination) -> [f64; 3] {
    [0, 1, 2].map(|i| {
        c.iter()
            .map(|&(v, w)| w * point.visits[v].reading_um[i])
            .sum()
    })
}

/// The covariance per axis of two points' combinations, µm², under AR(1) noise along
/// their set-up's visits (`ia`, `ib`: the set-up sequence's index of each point's visits).
fn covariance_of(
    noise: &Noise,
    (ca, ia): (&Combination, &[usize]),
    (cb, ib): (&Combination, &[usize]),
) -> [f64; 3] {
    [0, 1, 2].map(|i| {
        let mut s = 0.0;
        for &(a, wa) in ca {
            for &(b, wb) in cb {
                s += wa * wb * noise.covariance(i, ia[a].abs_diff(ib[b]));
            }
        }
        s
    })
}

fn variance_of(noise: &Noise, c: &Combination, index: &[usize]) -> [f64; 3] {
    covariance_of(noise, (c, index), (c, index)).map(|v| v.max(0.0))
}

/// Each point's deformation at each of its visits, with its uncertainty.
pub(crate) fn series(visits: &Visits, cycles: &Cycles, noise: &Noise) -> Vec<PointSeries> {
    let seq = SetupSequence::of(visits);
    visits
        .points
        .iter()
        .enumerate()
        .map(|(j, p)| PointSeries {
            point: p.name.clone(),
            values: (0..p.visits.len())
                .map(|v| {
                    let c = difference(&[(0, 1.0)], &[(v, 1.0)]);
                    let var = variance_of(noise, &c, &seq.index[j]);
                    SeriesValue {
                        t_s: p.visits[v].t_s,
                        cycle: cycles.cycle_of[j][v],
                        deformation_um: value_of(p, &c),
                        u95_um: var.map(|x| K95 * x.sqrt()),
                    }
                })
                .collect(),
        })
        .collect()
}

/// The noise of the points of one set-up at an instant: they share the head's seating on
/// their ball, so their values are correlated.
#[derive(Debug, Clone)]
pub(crate) struct NoiseBlock {
    pub points: Vec<usize>,
    /// Per axis, the covariance of those points' values, µm².
    pub cov_um2: [Vec<Vec<f64>>; 3],
}

/// Every point's deformation at every instant.
#[derive(Debug, Clone)]
pub(crate) struct AtInstants {
    /// `[instant][point]`, µm.
    pub d_um: Vec<Vec<[f64; 3]>>,
    /// Its variance, µm².
    pub var_um2: Vec<Vec<[f64; 3]>>,
    /// `[instant]`: the set-ups' blocks of the noise's covariance.
    pub blocks: Vec<Vec<NoiseBlock>>,
    /// The point's visit time in the instant's cycle minus the instant's, s (`None`: no
    /// visit in that cycle).
    pub offset_s: Vec<Vec<Option<f64>>>,
}

/// An instant: its time and the cycle it belongs to (whose visits [`TimeBase::Cycle`] takes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct At {
    pub t_s: f64,
    pub cycle: usize,
}

/// The points' values at `times` by `method`, each from its value at the first cycle's
/// instant on the same time base (with the cycle's own visits, its first visit): points
/// visited at different times of the first cycle then share one reference instant.
pub(crate) fn at_times(
    visits: &Visits,
    cycles: &Cycles,
    noise: &Noise,
    method: TimeBase,
    times: &[At],
) -> AtInstants {
    let seq = SetupSequence::of(visits);
    let n = times.len();
    let mut out = AtInstants {
        d_um: Vec::with_capacity(n),
        var_um2: Vec::with_capacity(n),
        blocks: Vec::with_capacity(n),
        offset_s: Vec::with_capacity(n),
    };
    let first = At {
        t_s: cycles.mid_s[0],
        cycle: 0,
    };
    let reference: Vec<_> = (0..visits.points.len())
        .map(|j| weights(visits, cycles, method, j, first))
        .collect();
    for &at in times {
        let combos: Vec<Combination> = (0..visits.points.len())
            .map(|j| difference(&reference[j], &weights(visits, cycles, method, j, at)))
            .collect();
        let of = |j: usize| (&combos[j], seq.index[j].as_slice());
        out.d_um.push(
            visits
                .points
                .iter()
                .zip(&combos)
                .map(|(p, c)| value_of(p, c))
                .collect(),
        );
        out.var_um2.push(
            (0..combos.len())
                .map(|j| covariance_of(noise, of(j), of(j)))
                .collect(),
        );
        out.blocks.push(noise_blocks(&seq, noise, &of));
        out.offset_s.push(
            visits
                .points
                .iter()
                .enumerate()
                .map(|(j, p)| own_visit(cycles, j, at.cycle).map(|v| p.visits[v].t_s - at.t_s))
                .collect(),
        );
    }
    out
}

/// Point `j`'s visit in `cycle`.
fn own_visit(cycles: &Cycles, j: usize, cycle: usize) -> Option<usize> {
    cycles.cycle_of[j].iter().position(|&c| c == cycle)
}

/// The weights of point `j`'s readings that give its value at `at`.
fn weights(
    visits: &Visits,
    cycles: &Cycles,
    method: TimeBase,
    j: usize,
    at: At,
) -> Vec<(usize, f64)> {
    let p = &visits.points[j];
    match (method, own_visit(cycles, j, at.cycle)) {
        (TimeBase::Cycle, Some(v)) => vec![(v, 1.0)],
        (TimeBase::Cycle, None) => between(p, at.t_s, false),
        (TimeBase::Interpolated, _) => between(p, at.t_s, true),
    }
}

/// The covariance of the points' values, set-up by set-up.
fn noise_blocks<'a>(
    seq: &SetupSequence,
    noise: &Noise,
    of: &dyn Fn(usize) -> (&'a Combination, &'a [usize]),
) -> Vec<NoiseBlock> {
    seq.groups
        .iter()
        .map(|g| NoiseBlock {
            points: g.clone(),
            cov_um2: [0, 1, 2].map(|i| {
                g.iter()
                    .map(|&a| {
                        g.iter()
                            .map(|&b| covariance_of(noise, of(a), of(b))[i])
                            .collect()
                    })
                    .collect()
            }),
        })
        .collect()
}

/// Weights of the linear interpolation of the point's visits at `t`; beyond its first or last
/// visit along the nearest two (`extrapolate`) or held at that visit.
fn between(p: &Point, t: f64, extrapolate: bool) -> Vec<(usize, f64)> {
    let n = p.visits.len();
    let after = p.visits.partition_point(|v| v.t_s <= t);
    let (a, b) = match after {
        0 if !extrapolate => return vec![(0, 1.0)],
        k if k == n && !extrapolate => return vec![(n - 1, 1.0)],
        0 => (0, 1),
        k if k == n => (n - 2, n - 1),
        k => (k - 1, k),
    };
    let (ta, tb) = (p.visits[a].t_s, p.visits[b].t_s);
    let w = (t - ta) / (tb - ta);
    vec![(a, 1.0 - w), (b, w)]
}
