//! Cutting the R-test head's continuous stream into plateaus, one per ball visit (source 000's
//! TEVOR step).
//!
//! A *passage* is a maximal stretch of samples whose three readings are all on the ball: none
//! empty and each inside the measuring range (`|r| < range_um`; a sensor off the ball rests at
//! its end stop, at or beyond the range). Within a passage the head arrives, rests during the
//! dwell and leaves; the readings have *settled* where each lies within
//! `max(SETTLE_FLOOR_UM, SETTLE_SIGMAS · σ)` of the passage's median, σ the sensor noise
//! estimated from the median absolute difference of consecutive readings (robust to the
//! arrival and departure, which are few samples at any feed). The plateau is the longest run of
//! settled samples, bridging unsettled gaps up to `BRIDGE_S` (a spike does not split a visit);
//! it spans its first to its last settled sample. Its reading is the mean of the settled
//! samples in its middle half (by time, both ends included to within `SAME_TIME_S`) and its
//! time the midpoint (the sample's own time when one lies there), so a slow settling at either
//! end does not bias it. A passage with fewer than `MIN_PLATEAU_SAMPLES` settled
//! samples (the head brushing a ball in passing) is no visit and is only counted.

/// Every reading within this of the passage's median has settled, whatever the noise (µm).
pub const SETTLE_FLOOR_UM: f64 = 1.0;
/// … or within this many noise σ, for a noisier head.
pub const SETTLE_SIGMAS: f64 = 8.0;
/// Unsettled gaps up to this long inside a plateau are bridged (s).
pub const BRIDGE_S: f64 = 0.05;
/// A plateau has at least this many settled samples.
pub const MIN_PLATEAU_SAMPLES: usize = 8;
/// Times this close are one instant (s): files give times to the ms or µs, and a sample on the
/// middle half's boundary (a dwell of whole 8 ms at 500 Hz) must not fall out by rounding.
pub const SAME_TIME_S: f64 = 1e-6;

/// σ of white noise from the median absolute difference of consecutive samples:
/// `MAD(Δ) = 0.6745 · √2 · σ`.
const SIGMA_PER_MEDIAN_ABS_DIFF: f64 = 1.0 / (0.674_489_75 * std::f64::consts::SQRT_2);

/// One ball visit as the stream shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Plateau {
    /// Time of the first and the last settled sample, s.
    pub start_s: f64,
    pub end_s: f64,
    /// The midpoint, the visit's time, s.
    pub t_s: f64,
    /// Mean of the settled samples of the middle half, `dx, dy, dz` in µm.
    pub reading_um: [f64; 3],
    /// Settled samples in the plateau, and those averaged.
    pub settled: usize,
    pub averaged: usize,
}

impl Plateau {
    pub fn duration_s(&self) -> f64 {
        self.end_s - self.start_s
    }
}

/// What cutting a whole stream gave.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Cut {
    pub plateaus: Vec<Plateau>,
    /// Passages on a ball without a plateau (not visits).
    pub passages_without_plateau: usize,
    /// Samples read, and the times of the first and the last, s.
    pub samples: usize,
    pub first_s: f64,
    pub last_s: f64,
}

/// Cuts a stream given sample by sample in time order.
#[derive(Debug)]
pub struct Cutter {
    range_um: f64,
    passage: Vec<(f64, [f64; 3])>,
    scratch: Vec<f64>,
    cut: Cut,
}

impl Cutter {
    /// A cutter for a head whose readings are on the ball inside `±range_um`.
    pub fn new(range_um: f64) -> Self {
        Cutter {
            range_um,
            passage: Vec::new(),
            scratch: Vec::new(),
            cut: Cut::default(),
        }
    }

    /// The next sample: its time and its readings, `None` where a cell is empty.
    pub fn push(&mut self, t_s: f64, reading_um: Option<[f64; 3]>) {
        if self.cut.samples == 0 {
            self.cut.first_s = t_s;
        }
        self.cut.samples += 1;
        self.cut.last_s = t_s;
        match reading_um {
            Some(r) if r.iter().all(|v| v.abs() < self.range_um) => self.passage.push((t_s, r)),
            _ => self.close_passage(),
        }
    }

    /// The plateaus of the whole stream.
    pub fn finish(mut self) -> Cut {
        self.close_passage();
        self.cut
    }

    fn close_passage(&mut self) {
        if self.passage.is_empty() {
            return;
        }
        match plateau_of(&self.passage, &mut self.scratch) {
            Some(p) => self.cut.plateaus.push(p),
            None => self.cut.passages_without_plateau += 1,
        }
        self.passage.clear();
    }
}

/// The plateau of one passage, if it has one.
fn plateau_of(passage: &[(f64, [f64; 3])], scratch: &mut Vec<f64>) -> Option<Plateau> {
    if passage.len() < MIN_PLATEAU_SAMPLES {
        return None;
    }
    let mut centre = [0.0; 3];
    let mut tol = [0.0; 3];
    for c in 0..3 {
        scratch.clear();
        scratch.extend(passage.iter().map(|(_, r)| r[c]));
        centre[c] = median(scratch);
        scratch.clear();
        scratch.extend(passage.windows(2).map(|w| (w[1].1[c] - w[0].1[c]).abs()));
        let sigma = median(scratch) * SIGMA_PER_MEDIAN_ABS_DIFF;
        tol[c] = SETTLE_FLOOR_UM.max(SETTLE_SIGMAS * sigma);
    }
    let settled = |r: &[f64; 3]| (0..3).all(|c| (r[c] - centre[c]).abs() <= tol[c]);
    let (first, last, count) = longest_settled_run(passage, settled)?;
    if count < MIN_PLATEAU_SAMPLES {
        return None;
    }
    middle_half_mean(&passage[first..=last], settled, count)
}

/// The run of settled samples (gaps up to `BRIDGE_S` bridged) with the most settled samples:
/// the indices of its first and last, and its count.
fn longest_settled_run(
    passage: &[(f64, [f64; 3])],
    settled: impl Fn(&[f64; 3]) -> bool,
) -> Option<(usize, usize, usize)> {
    let mut best: Option<(usize, usize, usize)> = None;
    let mut run: Option<(usize, usize, usize)> = None;
    for (i, (t, r)) in passage.iter().enumerate() {
        if !settled(r) {
            continue;
        }
        run = match run {
            Some((first, last, n)) if t - passage[last].0 <= BRIDGE_S => Some((first, i, n + 1)),
            _ => {
                best = better(best, run);
                Some((i, i, 1))
            }
        };
    }
    better(best, run)
}

fn better(
    a: Option<(usize, usize, usize)>,
    b: Option<(usize, usize, usize)>,
) -> Option<(usize, usize, usize)> {
    match (a, b) {
        (Some(x), Some(y)) if y.2 > x.2 => Some(y),
        (Some(x), _) => Some(x),
        (None, y) => y,
    }
}

/// The plateau spanning `span` (its first and last samples settled): the mean of the settled
/// samples whose time lies in the middle half (its ends included), at the midpoint — the time
/// of the sample there if there is one, as the file writes it.
fn middle_half_mean(
    span: &[(f64, [f64; 3])],
    settled: impl Fn(&[f64; 3]) -> bool,
    count: usize,
) -> Option<Plateau> {
    let start_s = span.first()?.0;
    let end_s = span.last()?.0;
    let quarter_s = 0.25 * (end_s - start_s) - SAME_TIME_S;
    let mut t_s = 0.5 * (start_s + end_s);
    let mut sum = [0.0; 3];
    let mut averaged = 0usize;
    for (t, r) in span {
        if (t - t_s).abs() <= SAME_TIME_S {
            t_s = *t;
        }
        let inside = t - start_s >= quarter_s && end_s - t >= quarter_s;
        if inside && settled(r) {
            for c in 0..3 {
                sum[c] += r[c];
            }
            averaged += 1;
        }
    }
    if averaged == 0 {
        return None;
    }
    Some(Plateau {
        start_s,
        end_s,
        t_s,
        reading_um: sum.map(|s| s / averaged as f64),
        settled: count,
        averaged,
    })
}

/// The median of `values` (reordered); the lower middle of an even count.
fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let k = (values.len() - 1) / 2;
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.002;

    /// Pushes `n` samples at `value` from sample index `*k` on.
    fn hold(cutter: &mut Cutter, k: &mut usize, n: usize, value: Option<[f64; 3]>) {
        for _ in 0..n {
            cutter.push(*k as f64 * DT, value);
            *k += 1;
        }
    }

    #[test]
    fn a_visit_between_end_stops_is_its_settled_middle_half() {
        let mut cutter = Cutter::new(2000.0);
        let mut k = 0;
        hold(&mut cutter, &mut k, 10, Some([2000.0, 2000.0, -2047.0]));
        // Arrival: far from the final value, then 201 settled samples, then departure.
        hold(&mut cutter, &mut k, 5, Some([900.0, 40.0, -30.0]));
        hold(&mut cutter, &mut k, 101, Some([1.0, 2.0, 3.0]));
        hold(&mut cutter, &mut k, 101, Some([1.2, 2.0, 3.0]));
        hold(&mut cutter, &mut k, 5, Some([300.0, 0.0, 0.0]));
        hold(&mut cutter, &mut k, 10, None);
        let cut = cutter.finish();
        assert_eq!(cut.plateaus.len(), 1);
        let p = &cut.plateaus[0];
        assert!((p.duration_s() - 201.0 * DT).abs() < 1e-12);
        assert_eq!(p.settled, 202);
        // The middle half is samples 50.25 … 150.75 of the plateau: 51..=150, 50 at 1.0 and
        // 50 at 1.2.
        assert_eq!(p.averaged, 100);
        assert!((p.reading_um[0] - 1.1).abs() < 1e-12);
        assert_eq!(p.reading_um[1..], [2.0, 3.0]);
        assert!((p.t_s - (15.0 + 100.5) * DT).abs() < 1e-12);
    }

    #[test]
    fn a_dwell_of_whole_ticks_keeps_both_ends_of_its_middle_half_and_its_midpoint_sample() {
        // Times as a file writes them, in ms: 253 samples over a dwell of 0.504 s whose middle
        // half's ends (samples 63 and 189) lie on samples; only those two read 0.5. At this
        // start both ends would fall out by rounding without `SAME_TIME_S`.
        let mut cutter = Cutter::new(2000.0);
        cutter.push(8.917, None);
        let mut times = Vec::new();
        for k in 0..253 {
            let t: f64 = format!("{:.3}", 8.919 + k as f64 * DT).parse().unwrap();
            let dx = if k == 63 || k == 189 { 0.5 } else { 0.0 };
            cutter.push(t, Some([dx, 0.0, 0.0]));
            times.push(t);
        }
        cutter.push(9.425, None);
        let p = &cutter.finish().plateaus[0];
        assert_eq!(p.averaged, 127);
        assert_eq!(p.reading_um[0], 1.0 / 127.0);
        assert_eq!(p.t_s, times[126]);
    }

    #[test]
    fn a_spike_is_bridged_and_a_brush_is_no_visit() {
        let mut cutter = Cutter::new(2000.0);
        let mut k = 0;
        hold(&mut cutter, &mut k, 100, Some([0.0; 3]));
        hold(&mut cutter, &mut k, 2, Some([50.0, 0.0, 0.0]));
        hold(&mut cutter, &mut k, 100, Some([0.0; 3]));
        hold(&mut cutter, &mut k, 3, None);
        hold(&mut cutter, &mut k, 5, Some([10.0; 3]));
        let cut = cutter.finish();
        assert_eq!(cut.plateaus.len(), 1);
        assert_eq!(cut.plateaus[0].settled, 200);
        assert_eq!(cut.plateaus[0].reading_um, [0.0; 3]);
        assert_eq!(cut.passages_without_plateau, 1);
        assert_eq!(cut.samples, 210);
    }
}
