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

/// One machine axis.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisView {
    pub letter: char,
    pub rotary: bool,
    /// The stroke (SI) the error model spans: limits, or ±π for an unlimited rotary axis.
    pub stroke: (f64, f64),
}

impl SetupView {
    /// The view of a loaded set-up named `name` of instrument `instrument`.
    pub fn of(name: &str, instrument: &str, setup: &dyn mtcal_instrument::Setup) -> SetupView {
        SetupView {
            name: name.to_string(),
            instrument: instrument.to_string(),
            channels: setup.channels().to_vec(),
            reads_pose: (0..setup.channels().len())
                .map(|c| setup.reads_pose(c))
                .collect(),
            field_like: vec![false; setup.nuisance().len()],
            nuisance: setup.nuisance().to_vec(),
        }
    }
}

impl AxisView {
    /// Whether a positioning move of `delta` between two recorded positions could have gone
    /// either way round: on an axis that turns without limit, a move of half a turn or more
    /// (a control that unwinds goes by `delta`, one that takes the short way the other way).
    /// A tilt axis within its limits, a linear axis, and a move shorter than half a turn go
    /// one way only.
    pub fn turns_either_way(&self, delta: f64) -> bool {
        let unlimited = self.stroke.1 - self.stroke.0 >= std::f64::consts::TAU - 1e-6;
        self.rotary && unlimited && delta.abs() >= std::f64::consts::PI - 1e-6
    }

    /// Every axis of `machine`, in its axis order.
    pub fn of_machine(machine: &mtcal_kinematics::Machine) -> Vec<AxisView> {
        machine
            .axes()
            .iter()
            .enumerate()
            .map(|(a, ax)| AxisView {
                letter: ax.letter().as_char(),
                rotary: ax.kind() == mtcal_kinematics::AxisKind::Rotary,
                stroke: ax
                    .limits()
                    .filter(|(lo, hi)| hi > lo)
                    .unwrap_or_else(|| mtcal_kinematics::model::default_stroke(machine, a)),
            })
            .collect()
    }
}

/// One set-up: an instrument's channels and nuisance parameters.
#[derive(Clone, Debug)]
pub struct SetupView {
    pub name: String,
    pub instrument: String,
    pub channels: Vec<Channel>,
    /// Per channel: whether its reading depends on the tool pose (`Setup::reads_pose`).
    pub reads_pose: Vec<bool>,
    pub nuisance: Vec<Nuisance>,
    /// Per nuisance parameter: whether, at every pose the set-up is seen at in the fitted runs,
    /// it moves the readings as a fixed shift of the tool in the machine frame does (a ball of
    /// a volumetric test visited at one place; its height when only a table turning about Z
    /// takes it elsewhere). Its drift is then the machine's field there by another name. False
    /// where nobody said (a planned session).
    pub field_like: Vec<bool>,
}

/// One run. Its numbers are columns ([`Column`]: a study shares its own, a planned run's
/// vectors are kept as columns by [`RunView::from_vectors`]), read sample by sample.
#[derive(Clone, Debug)]
pub struct RunView {
    pub name: String,
    /// Index into [`SessionView::setups`].
    pub setup: usize,
    /// Fitted (`true`) or a validation run.
    pub fit: bool,
    /// Seconds since the session started, increasing.
    pub t: Column,
    /// Commanded positions, SI (`get` converts), `samples × axes`.
    pub q: Columns,
    /// Context columns (`T_<name>` in °C, `S` in rpm, `F` in mm/min) in file units.
    pub context: Vec<(String, Column)>,
}

impl RunView {
    /// A run from plain vectors: times, positions (SI, row-major `samples × axes`) and context
    /// columns, kept as columns bit for bit.
    pub fn from_vectors(
        name: impl Into<String>,
        setup: usize,
        fit: bool,
        t: &[f64],
        q: &[f64],
        context: &[(String, Vec<f64>)],
    ) -> Self {
        let axes = q.len().checked_div(t.len()).unwrap_or(0);
        assert_eq!(axes * t.len(), q.len(), "positions are samples × axes");
        Self {
            name: name.into(),
            setup,
            fit,
            t: Column::new(t),
            q: Columns::from_row_major(q, &vec![Scale::One; axes]),
            context: context
                .iter()
                .map(|(n, v)| (n.clone(), Column::new(v)))
                .collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Time of the first sample (s).
    pub fn first_time(&self) -> Option<f64> {
        (!self.t.is_empty()).then(|| self.t.get(0))
    }
    /// Time of the last sample (s).
    pub fn last_time(&self) -> Option<f64> {
        self.len().checked_sub(1).map(|i| self.t.get(i))
    }
    pub fn context_column(&self, name: &str) -> Option<&Column> {
        self.context.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }
}

/// How a parameter of the machine's full error model is parametrised, as far as the
/// model-change families need to know.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BasisOrder {
    /// Legendre polynomials up to this degree.
    Legendre(usize),
    /// Fourier series up to this harmonic.
    Fourier(usize),
    /// A table, a spline or a single coefficient: no order to raise.
    Other,
}

/// One parameter of the machine's full error model.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelParamView {
    pub name: ParamName,
    /// Whether the current fit estimates it.
    pub estimated: bool,
    /// Whether some coefficient of it is held near its start (the runs cannot determine it:
    /// `mtcal_identify::base`).
    pub held: bool,
    pub order: BasisOrder,
}

/// What an input to a thermal node is.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Input {
    /// Spindle speed `S` per 1000 rpm.
    Speed,
    /// `(S / 1000 rpm)²`: heat from friction that grows faster than the speed.
    SpeedSquared,
    /// A context column (`T_spindle`) minus its first value in the session, in its file unit.
    Context(String),
}

impl Input {
    /// The column the input is read from (`S`, `T_spindle`).
    pub fn column(&self) -> &str {
        match self {
            Input::Speed | Input::SpeedSquared => "S",
            Input::Context(name) => name,
        }
    }

    /// The driver name FORMATS.md writes (`S`, `S^2`, `T_spindle`).
    pub fn driver(&self) -> String {
        match self {
            Input::Speed => "S".into(),
            Input::SpeedSquared => "S^2".into(),
            Input::Context(name) => name.clone(),
        }
    }
}

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
    arrived: i8,
    /// Direction of the axis' first motion in the run, ±1 (0 if it never moves).
    first_direction: i8,
    /// The sample of the first step (`step_direction` ≠ 0); the run's length if it never
    /// moves. Before it the direction is unknown (0).
    first_motion: usize,
    /// The samples at which the axis reverses, increasing: the direction flips there, and the
    /// travel counts from the sample before (the turning point).
    reversals: Vec<usize>,
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
    fn reversals_to(&self, i: usize) -> usize {
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
    fn anchor(&self, i: usize) -> usize {
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

/// Every sample's time in timeline order (runs in time order; [`SessionView::timeline_index`]),
/// read from the runs' columns.
#[derive(Clone, Copy, Debug)]
pub struct Timeline<'v> {
    view: &'v SessionView,
}

impl<'v> Timeline<'v> {
    pub fn len(&self) -> usize {
        self.view.samples
    }

    pub fn is_empty(&self) -> bool {
        self.view.samples == 0
    }

    /// The time of timeline sample `k` (s).
    pub fn get(&self, k: usize) -> f64 {
        let v = self.view;
        // The last run (in time order) starting at or before `k`: an empty run starts where
        // the next one does, so this is the one that holds `k`.
        let j = v.starts_in_order.partition_point(|&s| s <= k) - 1;
        v.runs[v.order[j]].t.get(k - v.starts_in_order[j])
    }

    /// The times in timeline order.
    pub fn iter(&self) -> impl Iterator<Item = f64> + 'v {
        let v = self.view;
        v.order.iter().flat_map(move |&r| {
            let t = &v.runs[r].t;
            (0..t.len()).map(move |i| t.get(i))
        })
    }

    /// The intervals between consecutive samples (s), in timeline order.
    fn intervals(&self) -> impl Iterator<Item = f64> + 'v {
        let mut times = self.iter();
        let mut prev = times.next().unwrap_or(0.0);
        times.map(move |t| {
            let d = t - prev;
            prev = t;
            d
        })
    }
}

/// The median of the positive values `values()` yields (the upper one of an even count, as
/// `sorted[n / 2]`), without keeping them: positive floats order as their bit patterns, so the
/// median's bits are found 16 at a time, one counting pass each (five passes in all).
fn median_of_positive<I: Iterator<Item = f64>>(values: impl Fn() -> I) -> Option<f64> {
    let n = values().filter(|v| *v > 0.0).count();
    if n == 0 {
        return None;
    }
    let mut rank = n / 2;
    let mut bits: u64 = 0;
    let mut counts = vec![0usize; 1 << 16];
    for shift in [48u32, 32, 16, 0] {
        // The values whose higher bits are the median's so far, by their next 16 bits.
        let known = if shift == 48 {
            0
        } else {
            u64::MAX << (shift + 16)
        };
        counts.fill(0);
        for v in values().filter(|v| *v > 0.0) {
            let b = v.to_bits();
            if b & known == bits {
                counts[((b >> shift) & 0xffff) as usize] += 1;
            }
        }
        for (digit, &c) in counts.iter().enumerate() {
            if rank < c {
                bits |= (digit as u64) << shift;
                break;
            }
            rank -= c;
        }
    }
    Some(f64::from_bits(bits))
}

/// A session as effects see it. Build it with [`SessionView::new`]; it is shared (`Arc`) by the
/// prepared effects of a fit.
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
    /// Per axis, the middle of the positions it stands at over the fitted samples (SI; the
    /// middle of its stroke where no fitted sample has it).
    fitted_middle: Vec<f64>,
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
        let fitted_middle = fitted_middles(&axes, &runs);
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
            fitted_middle,
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
    /// (one-sided at the run's ends; 0 where no time passes).
    pub fn velocity(&self, r: usize, a: usize, i: usize) -> f64 {
        let run = &self.runs[r];
        let (lo, hi) = (i.saturating_sub(1), (i + 1).min(run.len() - 1));
        let dt = run.t.get(hi) - run.t.get(lo);
        if hi == lo || dt <= 0.0 {
            0.0
        } else {
            (run.q.get(hi, a) - run.q.get(lo, a)) / dt
        }
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
        self.fitted_middle[a]
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

/// Every run's motion of every axis. Each run's linear axes arrive in the state the previous
/// run (in time) left them in ([`AxisMotion`]: the guess about the approach the file does not
/// hold); the session's first run, and a rotary axis after a move that may have gone either
/// way round, arrive from an unknown side.
/// Per axis, the middle of its positions over the fitted runs' samples (the middle of its
/// stroke where none).
fn fitted_middles(axes: &[AxisView], runs: &[RunView]) -> Vec<f64> {
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
            if lo <= hi {
                0.5 * (lo + hi)
            } else {
                0.5 * (axes[a].stroke.0 + axes[a].stroke.1)
            }
        })
        .collect()
}

fn motions(axes: &[AxisView], runs: &[RunView], order: &[usize]) -> Vec<Vec<AxisMotion>> {
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
fn step_direction(q: &Column, i: usize) -> i8 {
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
fn axis_motion(q: &Column, arrived: i8) -> AxisMotion {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn run(name: &str, t: Vec<f64>, q: Vec<f64>, context: Vec<(String, Vec<f64>)>) -> RunView {
        RunView::from_vectors(name, 0, true, &t, &q, &context)
    }

    fn directions(v: &SessionView, r: usize) -> Vec<i8> {
        (0..v.runs[r].len()).map(|i| v.direction(r, 0, i)).collect()
    }

    fn view(runs: Vec<RunView>) -> SessionView {
        SessionView::new(
            vec![AxisView {
                letter: 'X',
                rotary: false,
                stroke: (-0.5, 0.5),
            }],
            vec![],
            runs,
            vec![],
        )
    }

    #[test]
    fn motion_follows_reversals_with_hysteresis() {
        // Up, stand, down, stand, down.
        let q = vec![0.0, 0.001, 0.002, 0.002, 0.0015, 0.0015, 0.001];
        let t: Vec<f64> = (0..q.len()).map(|i| i as f64).collect();
        let v = view(vec![run("a", t, q, vec![])]);
        let m = v.motion(0, 0);
        // Standing at the first sample: the side it came from is unknown.
        assert_eq!(directions(&v, 0), vec![0, 1, 1, 1, -1, -1, -1]);
        assert!(m.reverses && m.moves);
        // Travel restarts at the turning point (0.002).
        assert!((v.travel(0, 0, 6) - 0.001).abs() < 1e-15);
        assert!((v.travel(0, 0, 2) - 0.002).abs() < 1e-15);
        assert!((v.velocity(0, 0, 1) - 0.001).abs() < 1e-15);
    }

    #[test]
    fn the_fitted_middle_is_where_the_fitted_samples_stand() {
        // Two balls' heights in the fitted runs; a validation run far away does not count.
        let fitted = |name: &str, q: f64| run(name, vec![0.0, 1.0], vec![q, q], vec![]);
        let mut far = fitted("validation", 0.45);
        far.fit = false;
        let v = view(vec![fitted("low", -0.40), fitted("high", -0.24), far]);
        assert!((v.fitted_middle(0) + 0.32).abs() < 1e-15);
        // No fitted sample: the middle of the stroke.
        let mut only = fitted("validation", 0.45);
        only.fit = false;
        assert_eq!(view(vec![only]).fitted_middle(0), 0.0);
    }

    #[test]
    fn inputs_hold_across_runs_in_time_order() {
        // The second run in the file comes first in time and has no S column.
        let a = run(
            "late",
            vec![10.0, 11.0],
            vec![0.0, 0.0],
            vec![("S".into(), vec![2000.0, 3000.0])],
        );
        let b = run("early", vec![0.0, 1.0], vec![0.0, 0.0], vec![]);
        let v = view(vec![a, b]);
        assert_eq!(v.runs_in_time_order(), &[1, 0]);
        assert_eq!(v.timeline_index(0, 0), 2);
        assert_eq!(*v.input(&Input::Speed), vec![0.0, 0.0, 2.0, 3.0]);
        assert_eq!(*v.input(&Input::SpeedSquared), vec![0.0, 0.0, 4.0, 9.0]);
        let c = run(
            "t",
            vec![20.0, 21.0],
            vec![0.0, 0.0],
            vec![("T_bed".into(), vec![21.5, 22.0])],
        );
        let v = view(vec![run("x", vec![0.0, 1.0], vec![0.0, 0.0], vec![]), c]);
        // Before the column is first recorded it holds its first value (zero change), then
        // the readings go through the zero-phase smoothing.
        assert_eq!(
            *v.input(&Input::Context("T_bed".into())),
            smoothed(
                &[0.0, 0.0, 0.0, 0.5],
                |k| [0.0, 1.0, 20.0, 21.0][k],
                TEMPERATURE_SMOOTHING_S
            )
        );
        assert_eq!(v.temperature_columns(), vec!["T_bed".to_string()]);
    }

    #[test]
    fn temperatures_are_smoothed_without_lag_and_continuously_in_time() {
        // Noise is averaged away, a slow rise is kept where it is (no lag), and moving a
        // sample's time a little changes the result a little.
        let t: Vec<f64> = (0..400).map(|k| k as f64).collect();
        let rise: Vec<f64> = t.iter().map(|&x| x / 400.0).collect();
        let noisy: Vec<f64> = rise
            .iter()
            .enumerate()
            .map(|(k, v)| v + if k % 2 == 0 { 0.02 } else { -0.02 })
            .collect();
        let s = smoothed(&noisy, |k| t[k], TEMPERATURE_SMOOTHING_S);
        for k in 50..350 {
            assert!(
                (s[k] - rise[k]).abs() < 2e-3,
                "{k}: {} vs {}",
                s[k],
                rise[k]
            );
        }
        let mut t2 = t.clone();
        t2[200] += 1e-6;
        let s2 = smoothed(&noisy, |k| t2[k], TEMPERATURE_SMOOTHING_S);
        assert!(s.iter().zip(&s2).all(|(a, b)| (a - b).abs() < 1e-7));
    }

    #[test]
    fn a_linear_axis_arrives_from_where_the_previous_run_left_it() {
        // Run "a" ends at X = 0.01 after moving up; run "b" starts at 0.02, stands, then moves
        // down: it arrived moving up (from 0.01), so its first motion is a reversal.
        let a = run("a", vec![0.0, 1.0], vec![0.0, 0.01], vec![]);
        let b = run(
            "b",
            vec![5.0, 6.0, 7.0, 8.0, 9.0],
            vec![0.02, 0.02, 0.015, 0.01, 0.012],
            vec![],
        );
        let v = view(vec![a, b]);
        assert_eq!(directions(&v, 1), vec![1, 1, -1, -1, 1]);
        assert!(v.motion(1, 0).moves && v.motion(1, 0).reverses);
        assert_eq!(
            (0..5).map(|i| v.reversed(1, 0, i)).collect::<Vec<_>>(),
            vec![false, false, true, true, true]
        );
        // Travel and time count from the run's start, then from each turning point (sample 1,
        // 0.02; sample 3, 0.01).
        let travel: Vec<f64> = (0..5).map(|i| v.travel(1, 0, i)).collect();
        let expected = [0.0, 0.0, 0.005, 0.01, 0.002];
        assert!(
            travel
                .iter()
                .zip(expected)
                .all(|(a, b)| (a - b).abs() < 1e-15)
        );
        let since: Vec<f64> = (0..5).map(|i| v.since_turn(1, 0, i)).collect();
        assert_eq!(since, vec![0.0, 1.0, 1.0, 2.0, 1.0]);
        // Started where the last run ended: keeps its last direction.
        let a = run("a", vec![0.0, 1.0], vec![0.0, 0.01], vec![]);
        let b = run("b", vec![5.0, 6.0], vec![0.01, 0.02], vec![]);
        let v = view(vec![a, b]);
        assert_eq!(directions(&v, 1), vec![1, 1]);
        assert!(!v.motion(1, 0).reverses);
    }

    #[test]
    fn the_first_runs_state_before_its_first_motion_is_unknown() {
        // Moving one way only: unknown (0) until the first step, which is no reversal.
        let c = run("c", vec![0.0, 1.0, 2.0], vec![0.01, 0.02, 0.03], vec![]);
        let v = view(vec![c]);
        assert_eq!(directions(&v, 0), vec![0, 1, 1]);
        assert!(!v.motion(0, 0).reverses && !v.reversed(0, 0, 2));
        // Never moving: unknown all through.
        let d = run("d", vec![0.0, 1.0, 2.0], vec![0.01; 3], vec![]);
        let v = view(vec![d]);
        assert_eq!(directions(&v, 0), vec![0, 0, 0]);
        assert!(!v.motion(0, 0).moves && !v.motion(0, 0).reverses);
        assert_eq!(v.travel(0, 0, 2), 0.0);
    }

    /// Direction, velocity and travel of one axis in one run as they were kept before they
    /// were computed on demand (per sample, from plain vectors): the reference.
    fn stored_motion(t: &[f64], q: &[f64], arrived: i8) -> (Vec<i8>, Vec<f64>, Vec<f64>) {
        let n = q.len();
        let mut raw = vec![0i8; n];
        for (i, dir) in raw.iter_mut().enumerate().skip(1) {
            let d = q[i] - q[i - 1];
            if d.abs() > STANDING {
                *dir = if d > 0.0 { 1 } else { -1 };
            }
        }
        let mut direction = vec![0i8; n];
        let mut travel = vec![0.0; n];
        // From the side it arrived from; unknown (0) until the first motion when that is not
        // known, and then the first motion is no reversal.
        let mut current = arrived;
        let mut anchor = q[0];
        for i in 0..n {
            if raw[i] != 0 && current == 0 {
                current = raw[i];
                anchor = q[i - 1];
            } else if raw[i] != 0 && raw[i] != current {
                current = raw[i];
                anchor = q[i.saturating_sub(1)];
            }
            direction[i] = current;
            travel[i] = (q[i] - anchor).abs();
        }
        let velocity = (0..n)
            .map(|i| {
                let (lo, hi) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let dt = t[hi] - t[lo];
                if hi == lo || dt <= 0.0 {
                    0.0
                } else {
                    (q[hi] - q[lo]) / dt
                }
            })
            .collect();
        (direction, velocity, travel)
    }

    #[test]
    fn motion_on_demand_is_the_stored_motion_bit_for_bit() {
        // A wobbling path with plateaus, steps below the standing threshold, repeated times and
        // recorded decimals; the second run starts below where the first ended (it arrives
        // moving down).
        let path = |n: usize, phase: f64| -> Vec<f64> {
            (0..n)
                .map(|i| {
                    let x = i as f64 * 0.37 + phase;
                    let v = 0.01 * x.sin() + 0.004 * (3.1 * x).cos();
                    if i % 11 < 3 {
                        (v * 1e4).round() / 1e4
                    } else {
                        v
                    }
                })
                .collect()
        };
        let times = |n: usize, t0: f64| -> Vec<f64> {
            (0..n)
                .map(|i| t0 + 0.001 * (i - i % 5 / 4) as f64)
                .collect()
        };
        let (qa, qb) = (path(500, 0.0), path(300, 2.0));
        let (ta, tb) = (times(500, 0.0), times(300, 10.0));
        let v = view(vec![
            run("a", ta.clone(), qa.clone(), vec![]),
            run("b", tb.clone(), qb.clone(), vec![]),
        ]);
        let down = if qb[0] < qa[qa.len() - 1] { -1 } else { 1 };
        for (r, t, q, arrived) in [(0, &ta, &qa, 0), (1, &tb, &qb, down)] {
            let (direction, velocity, travel) = stored_motion(t, q, arrived);
            assert!(v.motion(r, 0).reverses);
            for i in 0..q.len() {
                assert_eq!(v.direction(r, 0, i), direction[i], "run {r} sample {i}");
                assert_eq!(v.velocity(r, 0, i).to_bits(), velocity[i].to_bits());
                assert_eq!(v.travel(r, 0, i).to_bits(), travel[i].to_bits());
            }
        }
    }

    /// Runs that overlap in time (the balls of a volumetric test, visited in turn over the
    /// whole session): a temperature and its lags evolve in time, as over one run holding
    /// every sample in time order — not run after run, which would start each run's lag
    /// where the previous run ended, hours later.
    #[test]
    fn inputs_of_runs_that_overlap_in_time_follow_time() {
        let temperature =
            |t: f64| 20.0 + 5.0 * (1.0 - (-t / 3000.0).exp()) + 0.3 * (t / 700.0).sin();
        let times: Vec<f64> = (0..300).map(|k| 37.0 * k as f64).collect();
        let column = |ts: &[f64]| {
            vec![(
                "T_x".to_string(),
                ts.iter().map(|&t| temperature(t)).collect(),
            )]
        };
        // Three runs taking every third sample in turn.
        let parts: Vec<Vec<f64>> = (0..3)
            .map(|j| times.iter().copied().skip(j).step_by(3).collect())
            .collect();
        let runs = parts
            .iter()
            .enumerate()
            .map(|(j, ts)| {
                run(
                    &format!("ball{j}"),
                    ts.clone(),
                    vec![0.0; ts.len()],
                    column(ts),
                )
            })
            .collect();
        let overlapping = view(runs);
        let whole = view(vec![run(
            "all",
            times.clone(),
            vec![0.0; times.len()],
            column(&times),
        )]);
        let input = Input::Context("T_x".into());
        assert_eq!(overlapping.median_interval(), whole.median_interval());
        let (u, w) = (overlapping.input(&input), whole.input(&input));
        let (lu, lw) = (overlapping.lag(&input, 900.0), whole.lag(&input, 900.0));
        for (j, ts) in parts.iter().enumerate() {
            for i in 0..ts.len() {
                let k = overlapping.timeline_index(j, i);
                let m = 3 * i + j;
                assert!(
                    (u[k] - w[m]).abs() < 1e-12,
                    "ball{j} {i}: {} vs {}",
                    u[k],
                    w[m]
                );
                assert!((lu.y[k] - lw.y[m]).abs() < 1e-12, "lag ball{j} {i}");
                assert!(
                    (lu.dy_dtau[k] - lw.dy_dtau[m]).abs() < 1e-15,
                    "dlag ball{j} {i}"
                );
            }
        }
    }

    #[test]
    fn the_timeline_reads_the_runs_in_time_order() {
        let a = run("late", vec![10.0, 10.5, 11.0], vec![0.0; 3], vec![]);
        let empty = run("empty", vec![], vec![], vec![]);
        let b = run("early", vec![0.0, 1.0], vec![0.0; 2], vec![]);
        let v = view(vec![a, empty, b]);
        let expected = [0.0, 1.0, 10.0, 10.5, 11.0];
        let timeline = v.timeline();
        assert_eq!(timeline.iter().collect::<Vec<_>>(), expected);
        assert_eq!(timeline.len(), 5);
        for (k, &t) in expected.iter().enumerate() {
            assert_eq!(timeline.get(k), t);
        }
        assert_eq!((v.t0(), v.duration()), (0.0, 11.0));
        // Intervals 1, 9, 0.5, 0.5: the upper median.
        assert_eq!(v.median_interval(), 1.0);
    }

    #[test]
    fn the_median_without_a_copy_is_the_sorted_one() {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for n in [1usize, 2, 3, 10, 1001] {
            let values: Vec<f64> = (0..n)
                .map(|_| match next() % 5 {
                    0 => 0.001,
                    1 => -0.5,
                    2 => 0.0,
                    _ => (next() % 1_000_000) as f64 * 1e-7 + 1e-9,
                })
                .collect();
            let mut positive: Vec<f64> = values.iter().copied().filter(|v| *v > 0.0).collect();
            positive.sort_by(f64::total_cmp);
            let expected = positive.get(positive.len() / 2).copied();
            assert_eq!(
                median_of_positive(|| values.iter().copied()),
                expected,
                "{n}"
            );
        }
        assert_eq!(median_of_positive(|| [f64::NAN, -1.0].into_iter()), None);
    }
}
