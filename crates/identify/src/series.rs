//! The location errors cycle by cycle: source 000's R-test sets repeated between load cycles
//! (§5.5) read as a time series of each rotary axis' location errors and the squareness, with
//! the identified model's value beside each — what a thermal model of a location error
//! (`thermal-location`) says against what each set measured on its own.
//!
//! # Cycles
//! Only for a session whose runs overlap in time (one run per ball, visited cycle after
//! cycle: docs/VOLUMETRIC.md). Every sample of every run with readings (validation runs
//! too), in time order, is cut where the pause before it is longer than
//! [`CYCLE_PAUSE_FACTOR`] times the median pause: the load or rest phases between the
//! measuring cycles. At least [`MIN_CYCLES`] cycles.
//!
//! # Each cycle's own value
//! The fit's model (machine, set-ups and effects at the identified values) predicts every
//! reading of the cycle; the location errors the fit estimates are then corrected by least
//! squares on the cycle's whitened residuals alone, everything else held: the cycle's value
//! is the model's value plus that correction. Its 95 % interval comes from the cycle's own
//! residual scatter (Student's t with the cycle's degrees of freedom), not from the stated σ;
//! a location error the cycle cannot separate from the others (no ball turned about that
//! line in it) gets no number. The model's value is the fit's constant plus what its effects
//! add to that error ([`mtcal_effects::Target::Location`]), averaged over the cycle's samples.
//! The visits of one ball within a cycle share some of their noise (the head's seating), so
//! the interval is a little optimistic where they do.

use crate::fit::{SampleEval, prepared_effects};
use crate::study::Study;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, DiscreteCDF, StudentsT};

/// A pause longer than this many median pauses separates two cycles.
pub const CYCLE_PAUSE_FACTOR: f64 = 5.0;
/// The fewest cycles a series is given for.
pub const MIN_CYCLES: usize = 3;
/// The family-wise level at which a series departs from its model.
pub const DEPARTS_ALPHA: f64 = 0.01;

/// One location error's series.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LocationSeries {
    /// `EY0A`.
    pub parameter: String,
    /// `um` or `urad`.
    pub unit: String,
    pub cycles: Vec<CycleValue>,
    /// Cycles whose own value lies within its 95 % interval of the model's value.
    pub within_model: usize,
    /// Cycles with a value.
    pub determined: usize,
    /// Whether an effect of the model changes this error (a `thermal-location`).
    pub modelled: bool,
    /// Whether more cycles fall outside their interval of the model's value than a 95 %
    /// interval allows, family-wise at [`DEPARTS_ALPHA`] over the series: the error changes
    /// in a way the model does not say.
    pub departs: bool,
}

impl LocationSeries {
    /// How its cycles agree with the model, in words: `the model (a thermal model) within the
    /// interval in 15 of 16 cycles`.
    pub fn agreement(&self) -> String {
        format!(
            "the model{} within the interval in {} of {} cycles{}",
            if self.modelled {
                " (a thermal model)"
            } else {
                ""
            },
            self.within_model,
            self.determined,
            if self.departs {
                " — it changes in a way the model does not say"
            } else {
                ""
            }
        )
    }
}

/// One cycle's value of a location error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CycleValue {
    /// 1-based, in time order.
    pub cycle: usize,
    /// The cycle's first and last sample, h on the session's clock.
    pub t_first_h: f64,
    pub t_last_h: f64,
    /// Whether the cycle is a validation cycle (its runs not fitted).
    pub validation: bool,
    /// The cycle's own change of the error from the fit's constant and its 95 % half-width
    /// (`None`, absent from the JSON: the cycle cannot separate it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u95: Option<f64>,
    /// The identified model's change over the cycle (what its effects add).
    pub model: f64,
}

/// A sample of the timeline: its time, run and index.
#[derive(Clone, Copy)]
struct At {
    t: f64,
    run: usize,
    i: usize,
}

/// The series of every location error the fit estimates, at parameters `x`; empty for a
/// session whose runs do not overlap in time, with fewer than [`MIN_CYCLES`] cycles, or where
/// no error is separated in that many.
pub fn location_series(study: &Study, x: &[f64]) -> Vec<LocationSeries> {
    let locations = study.locations();
    if locations.is_empty() || !study.view().runs_overlap() {
        return Vec::new();
    }
    let cycles = cut_cycles(study);
    if cycles.len() < MIN_CYCLES {
        return Vec::new();
    }
    // Each location's coefficient in the fit model.
    let fit_coeffs = study.layout().fit_coeffs();
    let Some(columns) = locations
        .iter()
        .map(|&(_, k)| fit_coeffs.iter().position(|&f| f == k))
        .collect::<Option<Vec<usize>>>()
    else {
        return Vec::new();
    };
    let prepared = prepared_effects(study, x);
    let nl = locations.len();
    let mut evals: Vec<Option<SampleEval<'_>>> = (0..study.runs.len()).map(|_| None).collect();
    let mut per_cycle: Vec<Vec<CycleValue>> = vec![Vec::new(); nl];
    for (c, members) in cycles.iter().enumerate() {
        let mut sums = CycleSums::new(nl);
        let mut previous: Vec<Option<Visit>> = vec![None; study.runs.len()];
        for at in members {
            let eval = evals[at.run]
                .get_or_insert_with(|| SampleEval::new(study, at.run, x, prepared.clone()));
            eval.at(at.i, true);
            let visit = Visit::of(study, eval, at, &columns);
            sums.add(study, &visit, previous[at.run].as_ref());
            for (j, m) in sums.model.iter_mut().enumerate() {
                *m += eval.location_change(j);
            }
            sums.validation &= !study.runs[at.run].fit;
            previous[at.run] = Some(visit);
        }
        let n = members.len().max(1) as f64;
        let (first, last) = (members[0].t, members[members.len() - 1].t);
        let solved = solve_cycle(&sums.jtj, &sums.jtr, sums.rtr, sums.rows);
        for (j, series) in per_cycle.iter_mut().enumerate() {
            // Changes from the fit's constant (which may be part of a combination the runs
            // cannot separate; its changes are determined all the same).
            let model = sums.model[j] / n;
            let own = solved
                .as_ref()
                .and_then(|(delta, half)| half[j].map(|h| (model + delta[j], h)));
            series.push(CycleValue {
                cycle: c + 1,
                t_first_h: first / 3600.0,
                t_last_h: last / 3600.0,
                validation: sums.validation,
                value: own.map(|o| o.0),
                u95: own.map(|o| o.1),
                model,
            });
        }
    }
    let modelled = |name: &mtcal_kinematics::ParamName| {
        study.effects().iter().any(|e| {
            e.terms()
                .iter()
                .any(|t| t.target == mtcal_effects::Target::Location(*name))
        })
    };
    // Runs that only look as if they overlap (each run's clock starting at zero) give cycles
    // of a sample or two: no error is separated in enough of them to be a series.
    let separated = |cycles: &Vec<CycleValue>| cycles.iter().filter(|v| v.value.is_some()).count();
    if per_cycle.iter().all(|c| separated(c) < MIN_CYCLES) {
        return Vec::new();
    }
    locations
        .iter()
        .zip(per_cycle)
        .map(|(&(name, _), cycles)| {
            let unit = name.unit();
            let per_si = 1e6;
            let cycles: Vec<CycleValue> = cycles
                .into_iter()
                .map(|v| CycleValue {
                    value: v.value.map(|x| x * per_si),
                    u95: v.u95.map(|x| x * per_si),
                    model: v.model * per_si,
                    ..v
                })
                .collect();
            let determined = cycles.iter().filter(|v| v.value.is_some()).count();
            let within_model = cycles
                .iter()
                .filter(
                    |v| matches!((v.value, v.u95), (Some(x), Some(u)) if (x - v.model).abs() <= u),
                )
                .count();
            LocationSeries {
                parameter: name.to_string(),
                unit: unit.to_string(),
                cycles,
                within_model,
                determined,
                modelled: modelled(&name),
                departs: improbable(determined - within_model, determined, nl),
            }
        })
        .collect()
}

/// Whether `outside` of `n` values outside their 95 % intervals is improbable by chance,
/// family-wise at [`DEPARTS_ALPHA`] over `family` series: `P(X ≥ outside)`, `X` binomial
/// `(n, 0.05)`, below `DEPARTS_ALPHA / family`.
fn improbable(outside: usize, n: usize, family: usize) -> bool {
    if outside == 0 || n == 0 {
        return false;
    }
    let tail = statrs::distribution::Binomial::new(0.05, n as u64)
        .map(|b| 1.0 - b.cdf(outside as u64 - 1))
        .unwrap_or(1.0);
    tail < DEPARTS_ALPHA / family.max(1) as f64
}

/// One sample's whitened residual and location rows, per channel (the stated σ times the
/// noise model's scale; not yet prewhitened along the ball's visits).
#[derive(Clone)]
struct Visit {
    run: usize,
    channels: Vec<(f64, Vec<f64>)>,
}

impl Visit {
    fn of(study: &Study, eval: &SampleEval<'_>, at: &At, columns: &[usize]) -> Self {
        let readings = study.runs[at.run]
            .readings
            .as_ref()
            .expect("runs with readings only");
        let n_fit = study.fit_model.n_coeffs();
        let channels = (0..eval.n_channels())
            .map(|ch| {
                let r = (readings.get(at.i, ch) - eval.pred[ch]) * eval.inv_sigma[ch];
                let row = columns
                    .iter()
                    .map(|&f| eval.jacobian()[ch * n_fit + f])
                    .collect();
                (r, row)
            })
            .collect();
        Visit {
            run: at.run,
            channels,
        }
    }
}

/// One cycle's normal equations of the location errors on its residuals, and the model's
/// change summed over its samples.
struct CycleSums {
    jtj: DMatrix<f64>,
    jtr: DVector<f64>,
    rtr: f64,
    rows: usize,
    model: Vec<f64>,
    /// Whether every sample so far is a validation run's.
    validation: bool,
}

impl CycleSums {
    fn new(n: usize) -> Self {
        CycleSums {
            jtj: DMatrix::zeros(n, n),
            jtr: DVector::zeros(n),
            rtr: 0.0,
            rows: 0,
            model: vec![0.0; n],
            validation: true,
        }
    }

    /// Adds `visit`'s rows, prewhitened after the same ball's `previous` visit in the cycle
    /// with the fit's AR(1) coefficient (Prais–Winsten, as the fit does).
    fn add(&mut self, study: &Study, visit: &Visit, previous: Option<&Visit>) {
        let setup = study.runs[visit.run].setup;
        let noise = study.changes().noise.as_ref();
        for (ch, (r, row)) in visit.channels.iter().enumerate() {
            let phi = noise.map_or(0.0, |n| n.of(setup, ch).phi);
            let (r, row): (f64, Vec<f64>) = match previous {
                Some(p) if phi != 0.0 => {
                    let k = 1.0 / (1.0 - phi * phi).sqrt();
                    let (r0, row0) = &p.channels[ch];
                    let row = row.iter().zip(row0).map(|(a, b)| (a - phi * b) * k);
                    ((r - phi * r0) * k, row.collect())
                }
                _ => (*r, row.clone()),
            };
            for a in 0..row.len() {
                self.jtr[a] += row[a] * r;
                for b in 0..row.len() {
                    self.jtj[(a, b)] += row[a] * row[b];
                }
            }
            self.rtr += r * r;
            self.rows += 1;
        }
    }
}

/// Every sample of the runs with readings in time order, cut where a point comes again or at
/// a long pause.
fn cut_cycles(study: &Study) -> Vec<Vec<At>> {
    let mut all: Vec<At> = Vec::new();
    for (run, slot) in study.runs.iter().enumerate() {
        if slot.readings.is_none() {
            continue;
        }
        all.extend((0..slot.len()).map(|i| At {
            t: slot.t.get(i),
            run,
            i,
        }));
    }
    all.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.run.cmp(&b.run)));
    let mut pauses: Vec<f64> = all
        .windows(2)
        .map(|w| w[1].t - w[0].t)
        .filter(|d| *d > 0.0)
        .collect();
    if pauses.is_empty() {
        return Vec::new();
    }
    pauses.sort_by(f64::total_cmp);
    let limit = CYCLE_PAUSE_FACTOR * pauses[pauses.len() / 2];
    // A point is a ball (a run) at its commanded rotary positions (µrad: what a controller
    // writes differs in the last digits only).
    let rotary: Vec<usize> = (0..study.model.machine().n_axes())
        .filter(|&a| study.model.machine().axes()[a].kind() == mtcal_kinematics::AxisKind::Rotary)
        .collect();
    let mut q = vec![0.0; study.model.machine().n_axes()];
    let mut point = |at: &At| {
        study.runs[at.run].q.row_into(at.i, &mut q);
        let angles: Vec<i64> = rotary
            .iter()
            .map(|&a| (q[a] * 1e6).round() as i64)
            .collect();
        (at.run, angles)
    };
    let mut cycles: Vec<Vec<At>> = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    let mut last_t = f64::NEG_INFINITY;
    for at in all {
        let key = point(&at);
        if cycles.is_empty() || at.t - last_t > limit || seen.contains(&key) {
            cycles.push(Vec::new());
            seen.clear();
        }
        seen.insert(key);
        last_t = at.t;
        cycles.last_mut().expect("a cycle was started").push(at);
    }
    cycles
}

/// The least-squares correction of one cycle and each parameter's 95 % half-width (`None`
/// where the cycle's normal matrix leaves it undetermined); `None` with no degrees of freedom.
fn solve_cycle(
    jtj: &DMatrix<f64>,
    jtr: &DVector<f64>,
    rtr: f64,
    rows: usize,
) -> Option<(DVector<f64>, Vec<Option<f64>>)> {
    let n = jtj.nrows();
    let eig = jtj.clone().symmetric_eigen();
    let top = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
    if top <= 0.0 {
        return None;
    }
    let kept: Vec<usize> = (0..n)
        .filter(|&k| eig.eigenvalues[k] > 1e-10 * top)
        .collect();
    let dof = rows.checked_sub(kept.len()).filter(|&d| d > 0)?;
    // The pseudo-inverse over the determined directions.
    let mut cov = DMatrix::<f64>::zeros(n, n);
    for &k in &kept {
        let v = eig.eigenvectors.column(k);
        cov += (v * v.transpose()) / eig.eigenvalues[k];
    }
    let delta = &cov * jtr;
    let scatter = ((rtr - delta.dot(jtr)).max(0.0) / dof as f64).sqrt();
    let t95 = StudentsT::new(0.0, 1.0, dof as f64)
        .map(|t| t.inverse_cdf(0.975))
        .unwrap_or(1.96);
    let half = (0..n)
        .map(|j| {
            // A parameter with weight in an undetermined direction has no value of its own.
            let loose: f64 = (0..n)
                .filter(|k| !kept.contains(k))
                .map(|k| eig.eigenvectors[(j, k)].powi(2))
                .sum();
            (loose < 1e-6).then(|| t95 * scatter * cov[(j, j)].max(0.0).sqrt())
        })
        .collect();
    Some((delta, half))
}

/// The series on the screen: a line per location error a model effect changes or whose
/// cycles depart from the model ([`LocationSeries::departs`]), the others named on one line;
/// every cycle with `verbose`.
pub fn summary(series: &[LocationSeries], verbose: bool) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let Some(first) = series.first() else {
        return s;
    };
    let _ = writeln!(
        s,
        "\nlocation errors cycle by cycle ({} cycles; each cycle's own change from the fit's constant ± 95 %, beside the model's):",
        first.cycles.len()
    );
    let mut steady = Vec::new();
    for l in series {
        if !(l.modelled || l.departs || verbose) {
            steady.push(l.parameter.clone());
            continue;
        }
        let values: Vec<f64> = l.cycles.iter().filter_map(|v| v.value).collect();
        let (lo, hi) = values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let span = if values.is_empty() {
            "no cycle separates it".to_string()
        } else {
            format!("{lo:.2} … {hi:.2} {}", l.unit)
        };
        let _ = writeln!(s, "  {:<6} {span}; {}", l.parameter, l.agreement());
        if verbose {
            for v in &l.cycles {
                let own = match (v.value, v.u95) {
                    (Some(x), Some(u)) => format!("{x:>9.3} ± {u:.3}"),
                    _ => "   not separated".to_string(),
                };
                let _ = writeln!(
                    s,
                    "         cycle {:>3} {:>6.2}–{:<6.2} h {own}   model {:>9.3}{}",
                    v.cycle,
                    v.t_first_h,
                    v.t_last_h,
                    v.model,
                    if v.validation { "  (validation)" } else { "" }
                );
            }
        }
    }
    if !steady.is_empty() {
        let _ = writeln!(
            s,
            "  as the model says (within their intervals, but for what chance allows): {}",
            steady.join(", ")
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cycle_that_cannot_separate_an_error_gives_it_no_number() {
        // Rows along the first error only: the second has no value, the first its least
        // squares value with a t interval from the scatter.
        let rows = [(1.0, 2.0), (2.0, 4.1), (1.0, 1.9), (3.0, 6.0)];
        let mut jtj = DMatrix::zeros(2, 2);
        let mut jtr = DVector::zeros(2);
        let mut rtr = 0.0;
        for (a, r) in rows {
            jtj[(0, 0)] += a * a;
            jtr[0] += a * r;
            rtr += r * r;
        }
        let (delta, half) = solve_cycle(&jtj, &jtr, rtr, rows.len()).unwrap();
        assert!((delta[0] - 2.0).abs() < 0.05, "{delta}");
        assert!(half[0].is_some_and(|h| h > 0.0 && h < 0.3), "{half:?}");
        assert_eq!(half[1], None);
        // No degrees of freedom: nothing.
        assert!(solve_cycle(&jtj, &jtr, rtr, 1).is_none());
    }

    #[test]
    fn a_series_departs_only_beyond_what_chance_allows() {
        // One of sixteen outside a 95 % interval is chance; eight are not, even over eleven
        // series; three of sixteen are not improbable enough over eleven.
        assert!(!improbable(1, 16, 11));
        assert!(!improbable(3, 16, 11));
        assert!(improbable(8, 16, 11));
        assert!(!improbable(0, 16, 1));
    }
}
