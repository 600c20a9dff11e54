//! Is the deformation the same everywhere? The homogeneity verdict (crate docs, "Verdict").

use crate::cycles::{Cycles, minutes};
use crate::stats::{AxisSpread, Instant};

const AXES: [char; 3] = ['X', 'Y', 'Z'];

/// The three outcomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The points differ by no more than the tolerance share of the mean (or than noise).
    Uniform,
    /// They differ by more.
    NotUniform,
    /// The interval straddles the tolerance.
    CannotDecide,
}

impl Verdict {
    /// `uniform`, `not uniform`, `cannot decide`.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Uniform => "uniform",
            Verdict::NotUniform => "not uniform",
            Verdict::CannotDecide => "cannot decide",
        }
    }

    /// The JSON's spelling: `uniform`, `not-uniform`, `cannot-decide`.
    pub fn key(self) -> &'static str {
        match self {
            Verdict::Uniform => "uniform",
            Verdict::NotUniform => "not-uniform",
            Verdict::CannotDecide => "cannot-decide",
        }
    }
}

/// One axis at the verdict's instant.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisVerdict {
    pub axis: char,
    pub verdict: Verdict,
    /// The field's statistics on this axis at the instant.
    pub spread: AxisSpread,
    /// How much of max − min follows the order of the visits in the cycle: the slope of the
    /// points' deformation on their visit time times the cycle's span of visits, µm (`None`
    /// with fewer than three points visited in the cycle).
    pub follows_visit_order_um: Option<f64>,
    /// Why, in words.
    pub why: String,
}

/// The verdict on the whole session.
#[derive(Debug, Clone, PartialEq)]
pub struct Homogeneity {
    pub verdict: Verdict,
    /// The instant of the largest mean deformation (index into the instants).
    pub instant: usize,
    pub t_s: f64,
    pub mean_um: [f64; 3],
    pub mean_magnitude_um: f64,
    pub mean_magnitude_interval_um: [f64; 2],
    pub tolerance_share: f64,
    pub axes: [AxisVerdict; 3],
    /// The axis the sentence is about.
    pub deciding_axis: char,
    /// What a calibration engineer reads.
    pub sentence: String,
}

/// The verdict at the instant of the largest mean deformation.
pub(crate) fn judge(cycles: &Cycles, instants: &[Instant], tolerance_share: f64) -> Homogeneity {
    let k = instants
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.mean_magnitude_um.total_cmp(&b.1.mean_magnitude_um))
        .map_or(0, |(k, _)| k);
    let at = &instants[k];
    let axes = [0, 1, 2].map(|i| axis_verdict(at, i, tolerance_share));
    let verdicts = axes.iter().map(|a| a.verdict);
    let verdict = if verdicts.clone().any(|v| v == Verdict::NotUniform) {
        Verdict::NotUniform
    } else if verdicts.clone().all(|v| v == Verdict::Uniform) {
        Verdict::Uniform
    } else {
        Verdict::CannotDecide
    };
    let deciding = deciding_axis(&axes, verdict);
    let mut h = Homogeneity {
        verdict,
        instant: k,
        t_s: at.t_s,
        mean_um: at.axes.clone().map(|a| a.mean_um),
        mean_magnitude_um: at.mean_magnitude_um,
        mean_magnitude_interval_um: at.mean_magnitude_interval_um,
        tolerance_share,
        deciding_axis: AXES[deciding],
        axes,
        sentence: String::new(),
    };
    h.sentence = sentence(&h, deciding, cycles);
    h
}

fn axis_verdict(at: &Instant, i: usize, tolerance: f64) -> AxisVerdict {
    let s = at.axes[i].clone();
    let pct = |x: f64| format!("{:.0} %", 100.0 * x);
    let (verdict, why) = match s.range_share_interval {
        _ if s.range_um <= s.range_floor_um => (
            Verdict::Uniform,
            format!(
                "max − min {:.2} µm is within what noise alone gives ({:.2} µm)",
                s.range_um, s.range_floor_um
            ),
        ),
        Some([_, hi]) if hi <= tolerance => (
            Verdict::Uniform,
            format!(
                "its share's upper end {} is within {}",
                pct(hi),
                pct(tolerance)
            ),
        ),
        Some([lo, _]) if lo > tolerance => (
            Verdict::NotUniform,
            format!(
                "its share's lower end {} is beyond {}",
                pct(lo),
                pct(tolerance)
            ),
        ),
        Some([lo, hi]) => (
            Verdict::CannotDecide,
            format!(
                "its share's interval {}–{} straddles {}",
                pct(lo),
                pct(hi),
                pct(tolerance)
            ),
        ),
        // No mean deformation at all, but points that differ beyond the noise.
        None => (
            Verdict::NotUniform,
            "the points differ beyond the noise while the mean does not move".to_string(),
        ),
    };
    AxisVerdict {
        axis: AXES[i],
        verdict,
        follows_visit_order_um: follows_order(at, i),
        spread: s,
        why,
    }
}

/// `|b|·(max − min of the offsets)`, `b` the least-squares slope of the visited points'
/// deformation on their visit time relative to the instant.
fn follows_order(at: &Instant, i: usize) -> Option<f64> {
    let pairs: Vec<(f64, f64)> = at
        .offset_s
        .iter()
        .zip(&at.points_um)
        .filter_map(|(o, d)| o.map(|o| (o, d[i])))
        .collect();
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let mt = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let md = pairs.iter().map(|p| p.1).sum::<f64>() / n;
    let stt: f64 = pairs.iter().map(|p| (p.0 - mt).powi(2)).sum();
    if stt <= 0.0 {
        return None;
    }
    let b = pairs.iter().map(|p| (p.0 - mt) * (p.1 - md)).sum::<f64>() / stt;
    let lo = pairs.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let hi = pairs.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    Some(b.abs() * (hi - lo))
}

/// The axis the sentence is about: of those with the overall verdict, the largest share.
fn deciding_axis(axes: &[AxisVerdict; 3], verdict: Verdict) -> usize {
    (0..3)
        .filter(|&i| axes[i].verdict == verdict)
        .max_by(|&a, &b| {
            let s = |i: usize| axes[i].spread.range_share.unwrap_or(f64::MAX);
            s(a).total_cmp(&s(b))
        })
        .unwrap_or(0)
}

/// The dominant direction of the mean: `mostly −Z` when one axis holds most of it.
fn direction(mean: [f64; 3]) -> String {
    let m2: f64 = mean.iter().map(|x| x * x).sum();
    let (i, v) = mean
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map_or((0, 0.0), |(i, v)| (i, *v));
    if m2 > 0.0 && v * v > 0.8 * m2 {
        let sign = if v < 0.0 { '−' } else { '+' };
        format!(", mostly {sign}{}", AXES[i])
    } else {
        String::new()
    }
}

fn sentence(h: &Homogeneity, i: usize, cycles: &Cycles) -> String {
    let a = &h.axes[i];
    let s = &a.spread;
    let pct = |x: f64| format!("{:.0}", 100.0 * x);
    let share = match (s.range_share, s.range_share_interval) {
        (Some(v), Some([lo, hi])) => format!(
            ", {} % of the mean [95 %: {}–{} %]",
            pct(v),
            pct(lo),
            pct(hi)
        ),
        _ => String::new(),
    };
    let when = format!(
        "At {:.1} h, when the mean deformation is largest ({:.1} µm{}), the points differ by \
         {:.1} µm in {}{share}",
        h.t_s / 3600.0,
        h.mean_magnitude_um,
        direction(h.mean_um),
        s.range_um,
        a.axis
    );
    let tol = pct(h.tolerance_share);
    let body = match h.verdict {
        Verdict::Uniform if s.range_um <= s.range_floor_um => format!(
            "Uniform. {when}: no more than noise alone gives ({:.1} µm). The deformation is one \
             shift everywhere: ISO 230-3's single-point assumption holds here.",
            s.range_floor_um
        ),
        Verdict::Uniform => format!(
            "Uniform. {when}, within the {tol} % tolerance. The deformation is nearly the same \
             shift everywhere: ISO 230-3's single-point assumption holds here, one or two \
             points represent the work volume."
        ),
        Verdict::NotUniform => format!(
            "Not uniform. {when}, beyond the {tol} % tolerance. The deformation differs between \
             points in size or direction: ISO 230-3's single-point assumption does not hold \
             here; a test at one or two points misstates it elsewhere in the work volume."
        ),
        Verdict::CannotDecide => format!(
            "Cannot decide. {when}, an interval that straddles the {tol} % tolerance: more \
             cycles, or a quieter head, would decide."
        ),
    };
    match a.follows_visit_order_um {
        Some(o) if o > 0.5 * s.range_um && s.range_um > s.range_floor_um => format!(
            "{body} Of that spread, {o:.1} µm follows the order of the visits in the cycle \
             ({}): a drift during the cycle would look the same; visiting the points in another \
             order in some cycles would tell the two apart.",
            minutes(cycles.span_s)
        ),
        _ => body,
    }
}
