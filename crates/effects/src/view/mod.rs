//! What an effect sees of a session: its runs in time order (the *timeline*: thermal states
//! carry over from one run to the next), every run's commanded positions and context columns,
//! the set-ups' channels and nuisance parameters, the machine's axes and error model, and the
//! series derived from them (direction of motion, velocity, travel since a reversal; inputs
//! and their lags, cached).
//!
//! # Memory
//! A session of 10⁷ samples must fit where its identification does (README, "Scale"). The runs'
//! samples are the study's compact columns ([`mtcal_session::Column`], shared, not copied: they
//! give back the same bits as plain vectors), and what is derived per sample is computed when
//! asked: direction and travel from each axis' reversals (a few per run, found once), velocity
//! from the neighbouring samples, times from the runs' columns. Only an input and its lags
//! ([`SessionView::input`], [`SessionView::lag`]) are kept per timeline sample, on request.

use crate::lag::{LagSeries, first_order_lag_over};
use mtcal_instrument::{Channel, Nuisance};
use mtcal_kinematics::ParamName;
use mtcal_session::{Column, Columns, Scale};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

mod motion;
mod parts;
#[cfg(test)]
mod tests;
mod timeline;

use motion::*;
pub use motion::{AxisMotion, StartState};
pub use parts::{AxisView, BasisOrder, Input, ModelParamView, RunView, SetupView};
pub use timeline::Timeline;
use timeline::*;

/// Below this (m or rad) an axis is standing between two samples.
const STANDING: f64 = 1e-9;

/// What the cache of lag series may hold (bytes; a lag and its derivative by τ take 16 bytes
/// per timeline sample, 160 MB each at 10⁷ samples): a series several effects use is computed
/// once, while the cache does not keep alive what no effect holds any more (a fit refining τ
/// asks for a new one at every evaluation). The search scores candidates in passes within the
/// same budget (`SearchOptions::cache_bytes` of `mtcal-identify`).
const LAG_CACHE_BYTES: usize = 256 << 20;

/// Time constant (s) of the zero-phase smoothing a recorded temperature is read through: a
/// machine's thermal state does not change within half a minute, a sensor's reading does (its
/// noise and resolution), and an error fitted to that noise through a gain is noise in every
/// sample.
const TEMPERATURE_SMOOTHING_S: f64 = 10.0;

/// `values` (at the non-decreasing times `time(k)`) smoothed by a first-order filter run
/// forwards and then backwards (zero phase: no lag), exact for any spacing of the samples and
/// continuous in the times (a sample a little earlier or later changes the result a little).
fn smoothed(values: &[f64], time: impl Fn(usize) -> f64, tau_s: f64) -> Vec<f64> {
    let n = values.len();
    let mut out = values.to_vec();
    if n < 2 || tau_s <= 0.0 {
        return out;
    }
    let weight = |k: usize| (-(time(k) - time(k - 1)).max(0.0) / tau_s).exp();
    for k in 1..n {
        let a = weight(k);
        out[k] = a * out[k - 1] + (1.0 - a) * out[k];
    }
    for k in (1..n).rev() {
        let a = weight(k);
        out[k - 1] = a * out[k] + (1.0 - a) * out[k - 1];
    }
    out
}

/// prepared effects of a fit.
/// A session as effects see it. Build it with [`SessionView::new`]; it is shared (`Arc`) by the
#[derive(Debug)]
pub struct SessionView {
    pub axes: Vec<AxisView>,
    pub setups: Vec<SetupView>,
    pub runs: Vec<RunView>,
    /// Every parameter of the machine's full error model.
    pub model: Vec<ModelParamView>,
    /// The location errors (rotary axes' lines, linear axes' squareness) the fit estimates,
    /// one coefficient each: what a [`crate::Target::Location`] can act on, in slot order
    /// ([`crate::Slot::Location`]).
    pub locations: Vec<ParamName>,
    /// The effects already in the model (families may propose refinements of them).
    pub current: Vec<crate::EffectInfo>,
    /// How far the tool point travels in the machine frame over the fitted samples, along the
    /// machine's X, Y and Z (m, max − min; zero where nobody said): the lever arms a turn of
    /// the tool side acts through ([`crate::Target::ToolTurn`]).
    pub tool_reach_m: [f64; 3],
    /// The middle of that travel (m, machine frame).
    pub tool_middle_m: [f64; 3],
    /// Per axis, the span of the positions it stands at over the fitted samples (SI; its
    /// stroke where no fitted sample has it).
    fitted_range: Vec<(f64, f64)>,
    /// Runs in time order, and where each starts in the timeline (per run, and per place in
    /// time order).
    order: Vec<usize>,
    start: Vec<usize>,
    starts_in_order: Vec<usize>,
    /// Samples in the timeline.
    samples: usize,
    /// The timeline's samples in the order of their times, where it differs from the timeline
    /// (runs that overlap in time: the balls of a volumetric test, each a run over the whole
    /// session). Inputs and their lags evolve in time, not run after run.
    chronological: Option<Vec<usize>>,
    /// The timeline's first and last time, and its median interval (s).
    first_time: Option<f64>,
    last_time: Option<f64>,
    median_interval: f64,
    motion: Vec<Vec<AxisMotion>>,
    cache: Arc<SeriesCache>,
}

/// The inputs and lag series computed from a session's runs ([`SessionView::input`],
/// [`SessionView::lag`]). They depend on the runs alone, so the views of one session's studies
/// can share one ([`SessionView::with_series_cache`]): a search rebuilds its study for every
/// candidate it refits, and a joint thermal model's lags would otherwise be computed again for
/// each.
#[derive(Debug, Default)]
pub struct SeriesCache {
    inputs: Mutex<HashMap<Input, Arc<Vec<f64>>>>,
    lags: Mutex<HashMap<(Input, u64), Arc<LagSeries>>>,
}

impl SessionView {
    /// Builds the view and each run's motion of each axis.
    pub fn new(
        axes: Vec<AxisView>,
        setups: Vec<SetupView>,
        runs: Vec<RunView>,
        model: Vec<ModelParamView>,
    ) -> Self {
        let mut order: Vec<usize> = (0..runs.len()).collect();
        order.sort_by(|&a, &b| {
            let ta = runs[a].first_time().unwrap_or(0.0);
            let tb = runs[b].first_time().unwrap_or(0.0);
            ta.total_cmp(&tb).then(a.cmp(&b))
        });
        let mut start = vec![0; runs.len()];
        let mut starts_in_order = Vec::with_capacity(runs.len());
        let mut samples = 0;
        for &r in &order {
            start[r] = samples;
            starts_in_order.push(samples);
            samples += runs[r].len();
        }
        let motion = motions(&axes, &runs, &order);
        let fitted_range = fitted_ranges(&axes, &runs);
        let first_time = order.iter().find_map(|&r| runs[r].first_time());
        let last_time = order.iter().rev().find_map(|&r| runs[r].last_time());
        let mut view = Self {
            axes,
            setups,
            runs,
            model,
            locations: Vec::new(),
            current: Vec::new(),
            tool_reach_m: [0.0; 3],
            tool_middle_m: [0.0; 3],
            fitted_range,
            order,
            start,
            starts_in_order,
            samples,
            chronological: None,
            first_time,
            last_time,
            median_interval: 1.0,
            motion,
            cache: Arc::default(),
        };
        view.chronological = view.chronological_order();
        let timeline = view.timeline();
        // The recording's interval: between samples next to each other in time.
        let median = match &view.chronological {
            None => median_of_positive(|| timeline.intervals()),
            Some(order) => {
                let times: Vec<f64> = order.iter().map(|&k| timeline.get(k)).collect();
                median_of_positive(|| times.windows(2).map(|w| w[1] - w[0]))
            }
        };
        if let Some(m) = median {
            view.median_interval = m;
        }
        view
    }

    /// The view reading and keeping its inputs and lag series in `cache`, which must hold only
    /// series of views over the same runs (a study and its rebuilds).
    pub fn with_series_cache(mut self, cache: Arc<SeriesCache>) -> Self {
        self.cache = cache;
        self
    }

    /// Whether runs overlap in time (the balls of a volumetric test, each a run over the whole
    /// session): the timeline's samples are then not in time order run after run.
    pub fn runs_overlap(&self) -> bool {
        self.chronological.is_some()
    }

    /// The view with `locations` as the location errors a term can act on
    /// ([`SessionView::locations`]).
    pub fn with_locations(mut self, locations: Vec<ParamName>) -> Self {
        self.locations = locations;
        self
    }

    /// The view with `current` as the effects already in the model.
    pub fn with_current(mut self, current: Vec<crate::EffectInfo>) -> Self {
        self.current = current;
        self
    }

    /// The view with the tool point's travel in the machine frame, its least and greatest
    /// coordinates (m; [`Self::tool_reach_m`], [`Self::tool_middle_m`]).
    pub fn with_tool_travel(mut self, lo_m: [f64; 3], hi_m: [f64; 3]) -> Self {
        self.tool_reach_m = std::array::from_fn(|k| (hi_m[k] - lo_m[k]).max(0.0));
        self.tool_middle_m = std::array::from_fn(|k| {
            let m = 0.5 * (lo_m[k] + hi_m[k]);
            if m.is_finite() { m } else { 0.0 }
        });
        self
    }

    /// Whether an effect of this label is in the model.
    pub fn has_current(&self, label: &str) -> bool {
        self.current.iter().any(|e| e.label == label)
    }

    /// Every sample's time in timeline order (runs in time order; [`Self::timeline_index`]).
    pub fn timeline(&self) -> Timeline<'_> {
        Timeline { view: self }
    }

    /// Time of the session's first sample (s).
    pub fn t0(&self) -> f64 {
        self.first_time.unwrap_or(0.0)
    }

    /// Duration of the session, first to last sample (s).
    pub fn duration(&self) -> f64 {
        match (self.first_time, self.last_time) {
            (Some(a), Some(b)) => (b - a).max(0.0),
            _ => 0.0,
        }
    }

    /// Median interval between consecutive samples (s; 1 without any).
    pub fn median_interval(&self) -> f64 {
        self.median_interval
    }

    /// Where sample `i` of run `r` sits in the timeline.
    pub fn timeline_index(&self, r: usize, i: usize) -> usize {
        self.start[r] + i
    }

    /// Runs in time order.
    pub fn runs_in_time_order(&self) -> &[usize] {
        &self.order
    }

    /// How axis `a` moves in run `r`.
    pub fn motion(&self, r: usize, a: usize) -> &AxisMotion {
        &self.motion[r][a]
    }

    /// Direction of axis `a`'s last motion at sample `i` of run `r` ([`AxisMotion::direction`]).
    pub fn direction(&self, r: usize, a: usize, i: usize) -> i8 {
        self.motion[r][a].direction(i)
    }

    /// Whether sample `i` of run `r` comes before axis `a`'s first motion in the run: where
    /// its state is the approach's, which the file does not hold.
    pub fn before_first_motion(&self, r: usize, a: usize, i: usize) -> bool {
        i < self.motion[r][a].first_motion
    }

    /// The fitted runs (in time order) whose side of axis `a`'s play before its first motion
    /// is fitted ([`StartState`]): every run in which the axis moves — the approach move is
    /// not in the file, and the guess from the previous run ([`AxisMotion`]) is only a guess:
    /// a ball bar's feed-in arc or an R-test's approach from a safe position leaves either
    /// side, and a wrong guess reads the whole play at the run's first samples — and the runs
    /// in which it stands, arrived at from an unknown side (the session's first, or after a
    /// turn that may have gone either way round), with at least `min_samples` fitted samples.
    /// A run in which the axis stands and whose side has a guess keeps the guess: a free side
    /// there would let a reversal explain any offset of the run as the play's.
    pub fn start_states(&self, a: usize, min_samples: usize) -> Vec<StartState> {
        self.order
            .iter()
            .filter(|&&r| self.runs[r].fit)
            .filter_map(|&r| {
                let m = &self.motion[r][a];
                let samples = m.first_motion.min(self.runs[r].len());
                let unknown = m.moves || (m.arrived == 0 && samples >= min_samples);
                (unknown && samples > 0).then(|| StartState {
                    run: r,
                    name: self.runs[r].name.clone(),
                    guess: m.direction(0),
                })
            })
            .collect()
    }

    /// The fitted runs (in time order) in which axis `a` moves: whether its first motion was
    /// a reversal is unknown (the approach is not in the file; the previous run's side is
    /// only a guess), which decides a transient after it ([`StartState`]).
    pub fn unknown_first_turns(&self, a: usize) -> Vec<StartState> {
        self.order
            .iter()
            .filter(|&&r| self.runs[r].fit && self.motion[r][a].moves)
            .map(|&r| StartState {
                run: r,
                name: self.runs[r].name.clone(),
                guess: self.motion[r][a].arrived,
            })
            .collect()
    }

    /// Whether axis `a` reversed within run `r` by sample `i`: after its first motion, not on
    /// it (the turn from the side it arrived from is the approach's, [`Self::reversed`]).
    pub fn reversed_in_run(&self, r: usize, a: usize, i: usize) -> bool {
        let m = &self.motion[r][a];
        let arrival_turn = usize::from(m.reversals.first() == Some(&m.first_motion));
        m.reversals_to(i) > arrival_turn
    }

    /// Velocity of axis `a` at sample `i` of run `r` (SI per second), central differences
    /// (one-sided at the run's ends; 0 where no time passes, and in a run whose set-up reads
    /// with the axes standing: [`SetupView::at_standstill`]).
    pub fn velocity(&self, r: usize, a: usize, i: usize) -> f64 {
        let run = &self.runs[r];
        if self.read_at_standstill(r) {
            return 0.0;
        }
        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(run.len() - 1));
        let dt = run.t.get(hi) - run.t.get(lo);
        if hi == lo || dt <= 0.0 {
            0.0
        } else {
            (run.q.get(hi, a) - run.q.get(lo, a)) / dt
        }
    }

    /// Whether run `r`'s set-up reads with the axes standing ([`SetupView::at_standstill`]).
    pub fn read_at_standstill(&self, r: usize) -> bool {
        self.setups
            .get(self.runs[r].setup)
            .is_some_and(|s| s.at_standstill)
    }

    /// Distance axis `a` travelled since its last reversal (or since its first motion in run
    /// `r`) at sample `i` (SI; 0 before it first moves).
    pub fn travel(&self, r: usize, a: usize, i: usize) -> f64 {
        let q = self.runs[r].q.column(a);
        (q.get(i) - q.get(self.motion[r][a].anchor(i))).abs()
    }

    /// Time since axis `a` left its last turning point (or, before it reversed in run `r`,
    /// the position it first moved from) at sample `i` (s; 0 before it first moves). A dwell
    /// at the turning point does not count: the time runs from the last sample there.
    pub fn since_turn(&self, r: usize, a: usize, i: usize) -> f64 {
        let t = &self.runs[r].t;
        t.get(i) - t.get(self.motion[r][a].anchor(i))
    }

    /// Whether axis `a`'s direction at sample `i` of run `r` was reached by a reversal
    /// ([`AxisMotion::reversed`]).
    pub fn reversed(&self, r: usize, a: usize, i: usize) -> bool {
        self.motion[r][a].reversed(i)
    }

    /// The middle of the positions axis `a` stands at over the fitted samples (SI): where a
    /// scale change moves the readings least, so that it says how they differ between
    /// positions and leaves their common shift to an offset.
    pub fn fitted_middle(&self, a: usize) -> f64 {
        let (lo, hi) = self.fitted_range[a];
        0.5 * (lo + hi)
    }

    /// The lowest and highest positions axis `a` stands at over the fitted samples (SI; its
    /// stroke where no fitted sample has it): what the fitted runs say about the axis, and
    /// nothing beyond.
    pub fn fitted_range(&self, a: usize) -> (f64, f64) {
        self.fitted_range[a]
    }

    /// Commanded position of axis `a` at sample `i` of run `r` (SI).
    pub fn q(&self, r: usize, i: usize, a: usize) -> f64 {
        self.runs[r].q.get(i, a)
    }

    /// The axis with this letter.
    pub fn axis_index(&self, letter: char) -> Option<usize> {
        self.axes.iter().position(|a| a.letter == letter)
    }

    /// Whether any set-up has a channel that reads the tool pose (effects through the axes
    /// can show).
    pub fn any_pose_reading(&self) -> bool {
        self.setups.iter().any(|s| s.reads_pose.iter().any(|&b| b))
    }

    /// Whether some run has the context column `name` with more than one value.
    pub fn has_varying_column(&self, name: &str) -> bool {
        let mut first: Option<f64> = None;
        for run in self.runs.iter() {
            if let Some(v) = run.context_column(name) {
                for x in (0..v.len()).map(|i| v.get(i)) {
                    match first {
                        None => first = Some(x),
                        Some(f) if f != x => return true,
                        _ => {}
                    }
                }
            }
        }
        false
    }

    /// The names of the temperature columns (`T_*`) that vary, sorted.
    pub fn temperature_columns(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .runs
            .iter()
            .flat_map(|r| r.context.iter().map(|(n, _)| n.clone()))
            .filter(|n| n.starts_with("T_"))
            .collect();
        names.sort();
        names.dedup();
        names.retain(|n| self.has_varying_column(n));
        names
    }

    /// The input's value at every timeline sample. Runs without the column hold the last
    /// value before them (the first value in the session before it is ever recorded; 0 for a
    /// speed never recorded). A temperature is read through a zero-phase smoothing of 10 s
    /// ([`TEMPERATURE_SMOOTHING_S`]); a spindle speed as recorded (it steps).
    pub fn input(&self, input: &Input) -> Arc<Vec<f64>> {
        let mut cache = self.cache.inputs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = cache.get(input) {
            return Arc::clone(s);
        }
        let series = Arc::new(self.build_input(input));
        cache.insert(input.clone(), Arc::clone(&series));
        series
    }

    fn build_input(&self, input: &Input) -> Vec<f64> {
        let column = input.column();
        // Each timeline sample's recorded value, if its run records the column.
        let mut recorded: Vec<Option<f64>> = Vec::with_capacity(self.samples);
        for &r in &self.order {
            let run = &self.runs[r];
            match run.context_column(column) {
                Some(v) => recorded.extend((0..run.len()).map(|i| (i < v.len()).then(|| v.get(i)))),
                None => recorded.extend(std::iter::repeat_n(None, run.len())),
            }
        }
        let in_time = self.in_time_order();
        let first_value = in_time.iter().find_map(|&k| recorded[k]);
        let (offset, scale) = match input {
            Input::Speed | Input::SpeedSquared => (0.0, 1e-3),
            Input::Context(_) => (first_value.unwrap_or(0.0), 1.0),
        };
        let mut held = match input {
            Input::Speed | Input::SpeedSquared => 0.0,
            Input::Context(_) => first_value.unwrap_or(0.0),
        };
        let mut out = vec![0.0; self.samples];
        for &k in in_time.iter() {
            if let Some(x) = recorded[k] {
                held = x;
            }
            out[k] = (held - offset) * scale;
        }
        if *input == Input::SpeedSquared {
            out.iter_mut().for_each(|x| *x *= *x);
        }
        if let Input::Context(_) = input {
            let timeline = self.timeline();
            let values: Vec<f64> = in_time.iter().map(|&k| out[k]).collect();
            let smooth = smoothed(
                &values,
                |j| timeline.get(in_time[j]),
                TEMPERATURE_SMOOTHING_S,
            );
            for (&k, v) in in_time.iter().zip(smooth) {
                out[k] = v;
            }
        }
        out
    }

    /// The timeline's samples in time order ([`Self::chronological`]; the timeline itself
    /// where runs follow one another).
    fn in_time_order(&self) -> std::borrow::Cow<'_, [usize]> {
        match &self.chronological {
            Some(order) => std::borrow::Cow::Borrowed(order),
            None => std::borrow::Cow::Owned((0..self.samples).collect()),
        }
    }

    /// The timeline's samples sorted by time (ties in timeline order), if that differs from
    /// the timeline.
    fn chronological_order(&self) -> Option<Vec<usize>> {
        let timeline = self.timeline();
        let times: Vec<f64> = timeline.iter().collect();
        if times.windows(2).all(|w| w[0] <= w[1]) {
            return None;
        }
        let mut order: Vec<usize> = (0..times.len()).collect();
        order.sort_by(|&a, &b| times[a].total_cmp(&times[b]).then(a.cmp(&b)));
        Some(order)
    }

    /// The first-order lag of `input` with time constant `tau_s`, over the timeline (cached).
    pub fn lag(&self, input: &Input, tau_s: f64) -> Arc<LagSeries> {
        let key = (input.clone(), tau_s.to_bits());
        if let Some(s) = self
            .cache
            .lags
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&key)
        {
            return Arc::clone(s);
        }
        let u = self.input(input);
        let series = Arc::new(match &self.chronological {
            None => first_order_lag_over(&u, self.timeline().iter(), tau_s),
            Some(order) => {
                // In time order, then back to the timeline's.
                let timeline = self.timeline();
                let values: Vec<f64> = order.iter().map(|&k| u[k]).collect();
                let lag =
                    first_order_lag_over(&values, order.iter().map(|&k| timeline.get(k)), tau_s);
                let mut y = vec![0.0; u.len()];
                let mut dy_dtau = vec![0.0; u.len()];
                for (j, &k) in order.iter().enumerate() {
                    y[k] = lag.y[j];
                    dy_dtau[k] = lag.dy_dtau[j];
                }
                crate::lag::LagSeries { y, dy_dtau }
            }
        });
        let mut cache = self.cache.lags.lock().unwrap_or_else(|e| e.into_inner());
        let limit = (LAG_CACHE_BYTES / (16 * self.samples.max(1))).clamp(1, 257);
        if cache.len() >= limit {
            cache.clear();
        }
        cache.insert(key, Arc::clone(&series));
        series
    }

    /// Drops the cached inputs and lag series (after scoring a batch of candidates; effects
    /// prepared before keep theirs).
    pub fn clear_caches(&self) {
        self.cache
            .lags
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clear();
        self.cache
            .inputs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clear();
    }
}
