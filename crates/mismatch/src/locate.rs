//! The search: every test on every run, channel and variable, Holm's correction over each
//! family, and the spans of what remains.

use crate::MismatchError;
use crate::groups::{brown_forsythe, welch_anova};
use crate::input::{RunResiduals, first_duplicate};
use crate::options::{Family, Options};
use crate::periodogram::{Scratch, lomb_scargle_with};
use crate::report::{Analysis, Location, Mismatch, Skipped, TestKind, TestRecord};
use crate::span::{excess_span, whole_span};
use crate::stats::{Outcome, chi_square, cusum, ljung_box, runs_test};

/// What a test was ordered or grouped by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Along {
    Nothing,
    Context(usize),
    Split(usize),
}

/// Where a test record came from, kept beside the public records.
#[derive(Debug, Clone, Copy)]
struct Source {
    run: usize,
    channel: usize,
    along: Along,
}

/// Records and their sources, filled run by run.
#[derive(Default)]
struct Collected {
    records: Vec<TestRecord>,
    sources: Vec<Source>,
    skipped: Vec<Skipped>,
}

impl Collected {
    fn push(&mut self, run: &RunResiduals<'_>, source: Source, test: TestKind, outcome: Outcome) {
        let along = match source.along {
            Along::Nothing => None,
            Along::Context(i) => Some(run.context[i].name.to_owned()),
            Along::Split(i) => Some(run.splits[i].name.to_owned()),
        };
        self.records.push(TestRecord {
            run: run.run.to_owned(),
            channel: run.channels[source.channel].name.to_owned(),
            test,
            along,
            statistic: outcome.statistic,
            p_value: outcome.p_value,
            adjusted_p: outcome.p_value,
            rejected: false,
            detail: outcome.detail,
        });
        self.sources.push(source);
    }

    fn append(&mut self, mut other: Collected) {
        self.records.append(&mut other.records);
        self.sources.append(&mut other.sources);
        self.skipped.append(&mut other.skipped);
    }
}

/// Is there a mismatch between model and recordings, and where?
///
/// Runs every test on every run and channel (see the crate docs), corrects for multiple testing
/// with Holm's method over each [`Family`], and reports the spans that carry the excess χ².
/// Errors name the run, channel and variable of the first bad input; nothing is tested then.
pub fn locate(runs: &[RunResiduals<'_>], options: &Options) -> Result<Analysis, MismatchError> {
    options.validate()?;
    if let Some(name) = first_duplicate(runs.iter().map(|r| r.run)) {
        let what = "run";
        return Err(MismatchError::DuplicateName {
            run: name.to_owned(),
            name: name.to_owned(),
            what,
        });
    }
    for run in runs {
        run.validate(options.min_samples)?;
    }
    let mut collected = Collected::default();
    for per_run in test_runs(runs, options) {
        collected.append(per_run);
    }
    holm(&mut collected, options);
    let locations = locations(runs, &collected);
    Ok(Analysis {
        mismatch: Mismatch {
            detected: !locations.is_empty(),
            locations,
        },
        tests: collected.records,
        skipped: collected.skipped,
        options: options.clone(),
    })
}

/// Every run's tests, the runs spread over the available cores; in run order.
fn test_runs(runs: &[RunResiduals<'_>], options: &Options) -> Vec<Collected> {
    let mut out: Vec<Collected> = runs.iter().map(|_| Collected::default()).collect();
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(runs.len())
        .max(1);
    let queue = std::sync::Mutex::new(out.iter_mut().enumerate());
    let worker = || {
        loop {
            // A poisoned queue means another worker panicked: its panic is re-raised at join.
            let Ok(Some((index, collected))) = queue.lock().map(|mut q| q.next()) else {
                return;
            };
            test_run(index, &runs[index], options, collected);
        }
    };
    std::thread::scope(|s| {
        for _ in 1..threads {
            s.spawn(worker);
        }
        worker();
    });
    out
}

/// Sample indices sorted by value (stable: ties keep sample order, which depends on the context
/// alone, so white noise stays white in the new order). `None` for a constant variable.
fn sort_order(values: &[f64]) -> Option<Vec<usize>> {
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if lo >= hi {
        return None;
    }
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    Some(order)
}

/// The sort order of a split's labels and the sample ranges (in that order) of the groups large
/// enough to test.
fn split_groups(labels: &[i32], min_group: usize) -> (Vec<usize>, Vec<std::ops::Range<usize>>) {
    let mut order: Vec<usize> = (0..labels.len()).collect();
    order.sort_by_key(|&i| labels[i]);
    let mut ranges = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let label = labels[order[start]];
        let len = order[start..]
            .iter()
            .take_while(|&&i| labels[i] == label)
            .count();
        if len >= min_group {
            ranges.push(start..start + len);
        }
        start += len;
    }
    (order, ranges)
}

/// Reorders `source` by `order` into `target` without reallocating it.
fn gather(target: &mut Vec<f64>, source: &[f64], order: &[usize]) {
    target.clear();
    target.extend(order.iter().map(|&i| source[i]));
}

/// All tests of one run.
fn test_run(run_index: usize, run: &RunResiduals<'_>, options: &Options, out: &mut Collected) {
    let orders: Vec<Option<Vec<usize>>> =
        run.context.iter().map(|v| sort_order(v.values)).collect();
    for (variable, order) in run.context.iter().zip(&orders) {
        if order.is_none() {
            out.skipped
                .push(skipped(run, variable.name, "constant: nothing to order by"));
        }
    }
    let splits: Vec<_> = run
        .splits
        .iter()
        .map(|s| split_groups(s.labels, options.min_group_samples))
        .collect();
    for (split, (_, ranges)) in run.splits.iter().zip(&splits) {
        if ranges.len() < 2 {
            let why = format!(
                "fewer than two groups with at least {} samples",
                options.min_group_samples
            );
            out.skipped.push(skipped(run, split.name, &why));
        }
    }
    let mut buffers = Buffers::default();
    for (channel_index, channel) in run.channels.iter().enumerate() {
        let source = |along| Source {
            run: run_index,
            channel: channel_index,
            along,
        };
        out.push(
            run,
            source(Along::Nothing),
            TestKind::ChiSquare,
            chi_square(channel.residuals),
        );
        for (i, order) in orders.iter().enumerate() {
            let Some(order) = order else { continue };
            gather(&mut buffers.residuals, channel.residuals, order);
            gather(&mut buffers.values, run.context[i].values, order);
            let Buffers {
                residuals,
                values,
                scratch,
            } = &mut buffers;
            for (test, outcome) in ordered_tests(residuals, values, scratch, options) {
                out.push(run, source(Along::Context(i)), test, outcome);
            }
        }
        for (i, (order, ranges)) in splits.iter().enumerate() {
            if ranges.len() < 2 {
                continue;
            }
            gather(&mut buffers.residuals, channel.residuals, order);
            let groups: Vec<&[f64]> = ranges
                .iter()
                .map(|r| &buffers.residuals[r.clone()])
                .collect();
            out.push(
                run,
                source(Along::Split(i)),
                TestKind::WelchMeans,
                welch_anova(&groups),
            );
            out.push(
                run,
                source(Along::Split(i)),
                TestKind::BrownForsythe,
                brown_forsythe(&groups),
            );
        }
    }
}

fn skipped(run: &RunResiduals<'_>, along: &str, why: &str) -> Skipped {
    Skipped {
        run: run.run.to_owned(),
        along: along.to_owned(),
        why: why.to_owned(),
    }
}

/// Reused per run: residuals and variable values in the current order, periodogram scratch.
#[derive(Default)]
struct Buffers {
    residuals: Vec<f64>,
    values: Vec<f64>,
    scratch: Scratch,
}

/// The tests along one sorted variable.
fn ordered_tests(
    r: &[f64],
    x: &[f64],
    scratch: &mut Scratch,
    options: &Options,
) -> [(TestKind, Outcome); 4] {
    let change = cusum(r);
    let mut cusum_outcome = change.outcome;
    cusum_outcome.detail = x[change.change_index];
    let mut periodic = lomb_scargle_with(x, r, &options.lomb_scargle, scratch);
    periodic.detail = if periodic.detail > 0.0 {
        1.0 / periodic.detail
    } else {
        f64::INFINITY
    };
    [
        (TestKind::Runs, runs_test(r)),
        (TestKind::LjungBox, ljung_box(r, options.ljung_box_lags)),
        (TestKind::Cusum, cusum_outcome),
        (TestKind::LombScargle, periodic),
    ]
}

/// Holm's step-down correction within each family: sort the m p-values, multiply the k-th
/// smallest by (m − k + 1), and make the sequence non-decreasing. Valid under any dependence
/// between the tests (which is strong here: the same residuals in several orders).
fn holm(collected: &mut Collected, options: &Options) {
    let key = |s: &Source| match options.family {
        Family::Run => s.run,
        Family::All => 0,
    };
    let mut families: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (i, source) in collected.sources.iter().enumerate() {
        families.entry(key(source)).or_default().push(i);
    }
    for members in families.values_mut() {
        let records = &mut collected.records;
        members.sort_by(|&a, &b| records[a].p_value.total_cmp(&records[b].p_value));
        let m = members.len();
        let mut running = 0.0_f64;
        for (k, &i) in members.iter().enumerate() {
            running = running.max(((m - k) as f64 * records[i].p_value).min(1.0));
            records[i].adjusted_p = running;
            records[i].rejected = running <= options.alpha;
        }
    }
}

/// One location per run, channel and variable with a rejected test, strongest first within the
/// run and channel; a χ²-only location where nothing else was rejected.
fn locations(runs: &[RunResiduals<'_>], collected: &Collected) -> Vec<Location> {
    // (run, channel) → [(along, index of its rejected record with the smallest adjusted p)]
    let mut found: std::collections::BTreeMap<(usize, usize), Vec<(Along, usize)>> =
        Default::default();
    let records = &collected.records;
    for (index, (record, source)) in records.iter().zip(&collected.sources).enumerate() {
        if !record.rejected {
            continue;
        }
        let entry = found.entry((source.run, source.channel)).or_default();
        match entry.iter_mut().find(|(along, _)| *along == source.along) {
            Some((_, best)) if records[*best].adjusted_p <= record.adjusted_p => {}
            Some((_, best)) => *best = index,
            None => entry.push((source.along, index)),
        }
    }
    let mut out = Vec::new();
    for ((run, channel), mut alongs) in found {
        if alongs.iter().any(|(a, _)| *a != Along::Nothing) {
            alongs.retain(|(a, _)| *a != Along::Nothing);
        }
        alongs.sort_by(|a, b| records[a.1].adjusted_p.total_cmp(&records[b.1].adjusted_p));
        for (along, strongest) in alongs {
            out.push(location(&runs[run], channel, along, &records[strongest]));
        }
    }
    out
}

/// The span and share along one variable or split, given the strongest rejected test along it.
fn location(
    run: &RunResiduals<'_>,
    channel_index: usize,
    along: Along,
    strongest: &TestRecord,
) -> Location {
    let channel = &run.channels[channel_index];
    let mut location = Location {
        run: run.run.to_owned(),
        channel: channel.name.to_owned(),
        along: None,
        from: None,
        to: None,
        share: 1.0,
    };
    let (name, values): (&str, Vec<f64>) = match along {
        Along::Nothing => return location,
        Along::Context(i) => (run.context[i].name, run.context[i].values.to_vec()),
        Along::Split(i) => (
            run.splits[i].name,
            run.splits[i].labels.iter().map(|&l| f64::from(l)).collect(),
        ),
    };
    // Constant variables were never tested, so a rejected one has an order.
    let order = sort_order(&values).unwrap_or_else(|| (0..values.len()).collect());
    let (mut r, mut x) = (Vec::new(), Vec::new());
    gather(&mut r, channel.residuals, &order);
    gather(&mut x, &values, &order);
    let span = if is_periodic(strongest, &x) {
        whole_span(&x, &r)
    } else {
        excess_span(&x, &r)
    };
    if let Some(span) = span {
        location.from = Some(span.from);
        location.to = Some(span.to);
        location.share = span.share;
    }
    location.along = Some(name.to_owned());
    location
}

/// Whether the strongest evidence along a variable is a periodicity that repeats at least twice
/// over its range. Such an effect is everywhere along the variable; a segment search would cut
/// out one bump of it.
fn is_periodic(strongest: &TestRecord, sorted_values: &[f64]) -> bool {
    let range = sorted_values.last().unwrap_or(&0.0) - sorted_values.first().unwrap_or(&0.0);
    strongest.test == TestKind::LombScargle && strongest.detail < 0.5 * range
}
