//! A joint thermal model: one target following many inputs at once, each through first-order
//! thermal nodes at a ladder of time constants, fitted with a ridge prior instead of being
//! chosen one column at a time.
//!
//! # Why a bank
//! A machine's thermal state has several heat sources and several time constants, and the
//! recorded temperatures are many near-equivalent views of it. Chosen greedily, one (input, τ)
//! column at a time, the pick flips between look-alike columns from one data set to the next
//! and extrapolates wrongly; a single nonlinear τ per node slides onto its neighbour's (two
//! amplitudes growing without bound in opposite directions) or to infinity (a straight line).
//! A bank fits every column at once with a Gaussian prior on each column's contribution — a
//! ridge on the standardised columns — and lets the data decide how far to trust them: the
//! prior's width is chosen by cross-validation over whole runs (the search's
//! [`crate::Effect::prior_ladder`]). Its columns and their meaning:
//! - [`BankColumn::Rise`]: `1 − exp(−(t − t₀)/τ)`, a node warming from the session's start
//!   (a drift in time of any smooth shape is a sum of these);
//! - [`BankColumn::Static`]: an input as recorded (`T − T₀` in K, `S` in krpm);
//! - [`BankColumn::Lag`]: its first-order lag at τ ([`crate::lag`]).
//!
//! # The prior
//! Column `j` has a prior standard deviation `width / size_j` on its amplitude, `size_j` the
//! RMS over the fitted samples of an input column's departure from the reference state (a
//! temperature from its first reading, the speed from standstill; every input column is zero
//! there), a rise's spread about its mean: every column may add about `width` to the
//! target's thermal displacement before the data must insist.
//!
//! An input's size is taken from the reference state, not about the column's mean, because
//! the displacement a thermal model predicts is the departure from that state: a temperature that
//! drifted steadily through the fitted runs wiggles little about its mean, and scaled by its
//! wiggle its gain could carry the whole drift many times over — and take it further when a
//! new load drives the temperature beyond anything fitted (on the real 46-hour spindle test,
//! the speed steps heat the motor 1.5 K above the fitted cycles: ch5's error there went from
//! 2.2 to 1.2 µm, ch3's from 1.1 to 0.7). A rise is a function of time alone, bounded by 1 and
//! ended where the fitted runs end it: nothing new drives it beyond them, and its size is its
//! spread about its mean over the fitted samples.

use crate::lag::LagSeries;
use crate::view::{Input, SessionView};
use crate::{Effect, EffectInfo, Features, ParamDef, ParamKind, Target, Term};
use std::sync::Arc;

/// One column of a bank.
#[derive(Clone, Debug, PartialEq)]
pub enum BankColumn {
    /// A node warming from the session's start: `1 − exp(−(t − t₀)/τ)`, τ in s.
    Rise(f64),
    /// The input as recorded.
    Static(Input),
    /// Its first-order lag at τ (s).
    Lag(Input, f64),
}

impl BankColumn {
    /// A name for the column's gain: `rise_600s`, `T_t5`, `T_t5_lag600s`, `S_lag600s`,
    /// `S2_lag600s`.
    fn name(&self) -> String {
        let input = |i: &Input| match i {
            Input::Speed => "S".to_string(),
            Input::SpeedSquared => "S2".to_string(),
            Input::Context(c) => c.clone(),
        };
        match self {
            BankColumn::Rise(tau) => format!("rise_{tau:.0}s"),
            BankColumn::Static(i) => input(i),
            BankColumn::Lag(i, tau) => format!("{}_lag{tau:.0}s", input(i)),
        }
    }

    /// The unit of the column's value and its factor from the column's numbers.
    fn per_unit(&self) -> &'static str {
        match self {
            BankColumn::Rise(_) => "",
            BankColumn::Static(Input::Speed) | BankColumn::Lag(Input::Speed, _) => "/krpm",
            BankColumn::Static(Input::SpeedSquared) | BankColumn::Lag(Input::SpeedSquared, _) => {
                "/krpm²"
            }
            BankColumn::Static(Input::Context(_)) | BankColumn::Lag(Input::Context(_), _) => "/K",
        }
    }

    /// The column's values over the session's timeline.
    fn series(&self, view: &SessionView) -> Series {
        match self {
            BankColumn::Rise(tau) if view.timeline().len() <= RISE_KEPT_SAMPLES => {
                Series::Input(Arc::new(rise(view, *tau)))
            }
            BankColumn::Rise(tau) => Series::Rise {
                t0: view.t0(),
                tau: *tau,
            },
            BankColumn::Static(input) => Series::Input(view.input(input)),
            BankColumn::Lag(input, tau) => Series::Lag(view.lag(input, *tau)),
        }
    }
}

/// A column's values: a rise computed from each sample's time (kept, it would take 8 bytes a
/// sample for every column of every candidate scored at once), an input or its lag as the
/// view keeps them over the timeline (shared, not copied).
enum Series {
    /// `1 − exp(−(t − t₀)/τ)`, computed at each call (a session longer than
    /// [`RISE_KEPT_SAMPLES`]).
    Rise {
        t0: f64,
        tau: f64,
    },
    /// Values per timeline sample (an input, or a rise computed once: an exponential per
    /// sample and pass was a twentieth of a thermal search).
    Input(Arc<Vec<f64>>),
    Lag(Arc<LagSeries>),
}

/// A rise column is kept over the timeline for a session of at most this many samples (0.8 MB
/// a column); a longer one computes it at each call, so that a search's memory does not grow
/// by a column per sample (`tests/scale_memory.rs`).
const RISE_KEPT_SAMPLES: usize = 100_000;

impl Series {
    /// The value at sample `i` of run `r`.
    fn at(&self, view: &SessionView, r: usize, i: usize) -> f64 {
        match self {
            Series::Rise { t0, tau } => 1.0 - (-(view.runs[r].t.get(i) - t0) / tau).exp(),
            Series::Input(s) => s[view.timeline_index(r, i)],
            Series::Lag(s) => s.y[view.timeline_index(r, i)],
        }
    }
}

/// `1 − exp(−(t − t₀)/τ)` at every timeline sample, `t₀` the session's start.
fn rise(view: &SessionView, tau: f64) -> Vec<f64> {
    let t0 = view.t0();
    let mut out = vec![0.0; view.timeline().len()];
    for (r, run) in view.runs.iter().enumerate() {
        for i in 0..run.len() {
            out[view.timeline_index(r, i)] = 1.0 - (-(run.t.get(i) - t0) / tau).exp();
        }
    }
    out
}

/// A bank of columns acting on one target (see the module documentation).
#[derive(Clone, Debug)]
pub struct Bank {
    info: EffectInfo,
    params: Vec<ParamDef>,
    terms: Vec<Term>,
    columns: Vec<BankColumn>,
    /// Per column, its size over the fitted samples ([`fitted_size`]; the column's own units).
    size: Vec<f64>,
    /// The prior's width: what one column may contribute to the target (SI).
    width: f64,
    /// The target in words (`channel d_ch1`, `Z`).
    target_words: String,
    /// The target's unit and its factor from SI.
    unit: (String, f64),
}

/// Prior widths the search tries (SI): what one standardised column may contribute, from
/// 30 nm to 100 µm in half decades.
pub const WIDTHS: [f64; 8] = [3e-8, 1e-7, 3e-7, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4];

impl Bank {
    /// A bank of `columns` on `target` (`unit`: the target's unit and factor from SI) with a
    /// prior of `width` per standardised column. Columns that do not vary over the fitted
    /// samples are left out.
    pub fn new(
        info: EffectInfo,
        target: Target,
        target_words: String,
        unit: (String, f64),
        columns: Vec<BankColumn>,
        view: &SessionView,
        width: f64,
    ) -> Self {
        let mut kept = Vec::new();
        let mut size = Vec::new();
        for c in columns {
            let s = fitted_size(&c.series(view), view, !matches!(c, BankColumn::Rise(_)));
            if s > 0.0 && s.is_finite() {
                kept.push(c);
                size.push(s);
            }
        }
        let terms = (0..kept.len())
            .map(|j| Term {
                amplitude: j,
                target: target.clone(),
            })
            .collect();
        let mut bank = Bank {
            info,
            params: Vec::new(),
            terms,
            columns: kept,
            size,
            width,
            target_words,
            unit,
        };
        bank.define();
        bank
    }

    /// The parameters and terms from the columns, sizes and width.
    fn define(&mut self) {
        let (u, k) = (self.unit.0.clone(), self.unit.1);
        self.params = self
            .columns
            .iter()
            .zip(&self.size)
            .map(|(c, s)| ParamDef {
                name: format!("{}_{u}{}", c.name(), c.per_unit().replace('/', "_per_")),
                unit: format!("{u}{}", c.per_unit()),
                per_si: k,
                kind: ParamKind::Amplitude,
                initial: 0.0,
                bounds: None,
                // A column contributing a millimetre is not a thermal effect.
                scale: 1e-3 / s,
                prior: Some(self.width / s),
                nuisance: false,
            })
            .collect();
    }

    /// The columns.
    pub fn columns(&self) -> &[BankColumn] {
        &self.columns
    }

    /// The prior's width (SI).
    pub fn width(&self) -> f64 {
        self.width
    }
}

/// The size of `series` over the fitted runs' samples: with `from_reference`, the RMS of its
/// departure from the reference state (its value; every input column is zero there), else
/// its RMS about its mean; 0 when it does not vary (a column the fitted runs cannot tell from
/// the offsets).
fn fitted_size(series: &Series, view: &SessionView, from_reference: bool) -> f64 {
    let (mut n, mut sum, mut sum2) = (0usize, 0.0, 0.0);
    for (r, run) in view.runs.iter().enumerate() {
        if !run.fit {
            continue;
        }
        for i in 0..run.len() {
            let v = series.at(view, r, i);
            n += 1;
            sum += v;
            sum2 += v * v;
        }
    }
    if n < 2 {
        return 0.0;
    }
    let mean = sum / n as f64;
    let spread = (sum2 / n as f64 - mean * mean).max(0.0);
    if spread <= 1e-12 * (sum2 / n as f64) {
        0.0
    } else if from_reference {
        (sum2 / n as f64).sqrt()
    } else {
        spread.sqrt()
    }
}

impl Effect for Bank {
    fn info(&self) -> &EffectInfo {
        &self.info
    }

    fn params(&self) -> &[ParamDef] {
        &self.params
    }

    fn terms(&self) -> &[Term] {
        &self.terms
    }

    fn prepare(&self, view: &Arc<SessionView>, _shape: &[f64]) -> Box<dyn Features> {
        Box::new(BankFeatures {
            view: Arc::clone(view),
            series: self.columns.iter().map(|c| c.series(view)).collect(),
        })
    }

    fn describe(&self, values: &[f64], u95: &[Option<f64>]) -> String {
        // The largest contributions (gain × size), in the target's unit.
        let (u, k) = (&self.unit.0, self.unit.1);
        let mut parts: Vec<(f64, String)> = self
            .columns
            .iter()
            .zip(&self.size)
            .zip(values.iter().zip(u95))
            .map(|((c, s), (v, u95))| {
                let size = v * s * k;
                let sure = u95.is_some_and(|w| w * s * k < size.abs());
                (
                    size.abs(),
                    format!(
                        "{} {:+.2} {u}{}",
                        c.name(),
                        size,
                        if sure {
                            ""
                        } else {
                            " (within its interval of 0)"
                        }
                    ),
                )
            })
            .collect();
        parts.sort_by(|a, b| b.0.total_cmp(&a.0));
        let inputs = describe_inputs(&self.columns);
        format!(
            "a joint thermal model of {}: {} columns ({inputs}), each a first-order response, \
             fitted together with a prior of {}; the largest contributions over \
             the fitted runs: {}",
            self.target_words,
            self.columns.len(),
            self.prior_words().unwrap_or_default(),
            parts
                .iter()
                .take(4)
                .map(|p| p.1.clone())
                .collect::<Vec<_>>()
                .join(", ")
        )
    }

    fn cached_series(&self) -> Vec<String> {
        self.columns
            .iter()
            .filter_map(|c| match c {
                BankColumn::Lag(i, tau) => Some(format!("{i:?}/{tau}")),
                _ => None,
            })
            .collect()
    }

    fn prior_words(&self) -> Option<String> {
        Some(format!(
            "{:.2} {} per column",
            self.width * self.unit.1,
            self.unit.0
        ))
    }

    fn prior_ladder(&self) -> Vec<Arc<dyn Effect>> {
        WIDTHS
            .iter()
            .map(|&w| {
                let mut b = self.clone();
                b.width = w;
                b.define();
                Arc::new(b) as Arc<dyn Effect>
            })
            .collect()
    }
}

/// `time` or the inputs and the τ range, in words.
fn describe_inputs(columns: &[BankColumn]) -> String {
    let mut inputs: Vec<String> = Vec::new();
    let mut taus: Vec<f64> = Vec::new();
    for c in columns {
        let name = match c {
            BankColumn::Rise(tau) => {
                taus.push(*tau);
                "time".to_string()
            }
            BankColumn::Static(i) => i.driver(),
            BankColumn::Lag(i, tau) => {
                taus.push(*tau);
                i.driver()
            }
        };
        if !inputs.contains(&name) {
            inputs.push(name);
        }
    }
    let (lo, hi) = taus
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &t| (a.min(t), b.max(t)));
    let list = if inputs.len() > 4 {
        format!("{} and {} more", inputs[..3].join(", "), inputs.len() - 3)
    } else {
        inputs.join(", ")
    };
    if taus.is_empty() {
        list
    } else {
        format!("{list}; τ {:.0} s to {:.0} s", lo, hi)
    }
}

struct BankFeatures {
    view: Arc<SessionView>,
    series: Vec<Series>,
}

impl Features for BankFeatures {
    fn eval(&self, r: usize, i: usize, f: &mut [f64], _df: &mut [f64]) {
        for (v, s) in f.iter_mut().zip(&self.series) {
            *v = s.at(&self.view, r, i);
        }
    }
}
