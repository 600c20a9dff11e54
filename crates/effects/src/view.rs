//! What an effect sees of a session: its runs in time order (the *timeline*: thermal states
//! carry over from one run to the next), every run's commanded positions and context columns,
//! the set-ups' channels and nuisance parameters, the machine's axes and error model, and the
//! series derived from them once (direction of motion, velocity, travel since a reversal;
//! inputs and their lags, cached).

use crate::lag::{LagSeries, first_order_lag};
use mtcal_instrument::{Channel, Nuisance};
use mtcal_kinematics::ParamName;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Below this (m or rad) an axis is standing between two samples.
const STANDING: f64 = 1e-9;

/// Time constant (s) of the zero-phase smoothing a recorded temperature is read through: a
/// machine's thermal state does not change within half a minute, a sensor's reading does (its
/// noise and resolution), and an error fitted to that noise through a gain is noise in every
/// sample.
const TEMPERATURE_SMOOTHING_S: f64 = 10.0;

/// `values` (at the non-decreasing `times`) smoothed by a first-order filter run forwards and
/// then backwards (zero phase: no lag), exact for any spacing of the samples and continuous in
/// the times (a sample a little earlier or later changes the result a little).
fn smoothed(values: &[f64], times: &[f64], tau_s: f64) -> Vec<f64> {
    let n = values.len();
    let mut out = values.to_vec();
    if n < 2 || tau_s <= 0.0 {
        return out;
    }
    let weight = |k: usize| (-(times[k] - times[k - 1]).max(0.0) / tau_s).exp();
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

/// One set-up: an instrument's channels and nuisance parameters.
#[derive(Clone, Debug)]
pub struct SetupView {
    pub name: String,
    pub instrument: String,
    pub channels: Vec<Channel>,
    /// Per channel: whether its reading depends on the tool pose (`Setup::reads_pose`).
    pub reads_pose: Vec<bool>,
    pub nuisance: Vec<Nuisance>,
}

/// One run.
#[derive(Clone, Debug)]
pub struct RunView {
    pub name: String,
    /// Index into [`SessionView::setups`].
    pub setup: usize,
    /// Fitted (`true`) or a validation run.
    pub fit: bool,
    /// Seconds since the session started, increasing.
    pub t: Vec<f64>,
    /// Commanded positions, SI, row-major `samples × axes`.
    pub q: Vec<f64>,
    /// Context columns (`T_<name>` in °C, `S` in rpm, `F` in mm/min) in file units.
    pub context: Vec<(String, Vec<f64>)>,
}

impl RunView {
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    pub fn context_column(&self, name: &str) -> Option<&[f64]> {
        self.context
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
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

/// How one axis moves during one run.
#[derive(Clone, Debug, Default)]
pub struct AxisMotion {
    /// Direction of the last motion at each sample, ±1 (0 while the axis has neither moved in
    /// the run nor arrived from a known side). Before the first motion: the side the axis
    /// arrived from ([`SessionView::new`]: a linear axis from the previous run's last position;
    /// otherwise the side of its first motion).
    pub direction: Vec<i8>,
    /// Velocity (SI per second), central differences.
    pub velocity: Vec<f64>,
    /// Distance travelled since the last reversal (or since the run started moving), SI.
    pub travel: Vec<f64>,
    /// Whether the axis moves in both directions in this run.
    pub reverses: bool,
    /// Whether the axis moves at all.
    pub moves: bool,
    /// Median step between moving samples (SI): the finest detail the run resolves.
    pub step: f64,
    /// Range of positions (SI).
    pub range: (f64, f64),
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
    /// The effects already in the model (families may propose refinements of them).
    pub current: Vec<crate::EffectInfo>,
    /// Runs in time order, and where each starts in the timeline.
    order: Vec<usize>,
    start: Vec<usize>,
    /// Every sample's time, in timeline order.
    times: Vec<f64>,
    motion: Vec<Vec<AxisMotion>>,
    inputs: Mutex<HashMap<Input, Arc<Vec<f64>>>>,
    lags: Mutex<HashMap<(Input, u64), Arc<LagSeries>>>,
}

impl SessionView {
    /// Builds the view and the per-run motion series.
    pub fn new(
        axes: Vec<AxisView>,
        setups: Vec<SetupView>,
        runs: Vec<RunView>,
        model: Vec<ModelParamView>,
    ) -> Self {
        let mut order: Vec<usize> = (0..runs.len()).collect();
        order.sort_by(|&a, &b| {
            let ta = runs[a].t.first().copied().unwrap_or(0.0);
            let tb = runs[b].t.first().copied().unwrap_or(0.0);
            ta.total_cmp(&tb).then(a.cmp(&b))
        });
        let mut start = vec![0; runs.len()];
        let mut times = Vec::new();
        for &r in &order {
            start[r] = times.len();
            times.extend_from_slice(&runs[r].t);
        }
        let na = axes.len();
        // Each run's linear axes start in the state the previous run (in time) left them in:
        // the machine went straight from that run's last position to this run's first, so an
        // axis arrives from the side that move came from (or, if it did not move, keeps the
        // direction it last moved in). A rotary axis may have gone either way round between
        // runs (a controller unwinds or takes the short way): it, and the session's first run,
        // arrive from the side of their first motion.
        let mut motion: Vec<Vec<AxisMotion>> = vec![Vec::new(); runs.len()];
        let mut arrived: Vec<i8> = vec![0; na];
        let mut last_q: Option<&[f64]> = None;
        for &r in &order {
            let run = &runs[r];
            if run.is_empty() {
                motion[r] = (0..na).map(|_| AxisMotion::default()).collect();
                continue;
            }
            let first = &run.q[..na];
            motion[r] = (0..na)
                .map(|a| {
                    let initial = match last_q {
                        _ if axes[a].rotary => 0,
                        Some(prev) if (first[a] - prev[a]).abs() > STANDING => {
                            if first[a] > prev[a] { 1 } else { -1 }
                        }
                        _ => arrived[a],
                    };
                    axis_motion(run, a, na, initial)
                })
                .collect();
            for (a, d) in arrived.iter_mut().enumerate() {
                if let Some(&last) = motion[r][a].direction.last()
                    && last != 0
                {
                    *d = last;
                }
            }
            last_q = Some(&run.q[(run.len() - 1) * na..]);
        }
        Self {
            axes,
            setups,
            runs,
            model,
            current: Vec::new(),
            order,
            start,
            times,
            motion,
            inputs: Mutex::new(HashMap::new()),
            lags: Mutex::new(HashMap::new()),
        }
    }

    /// The view with `current` as the effects already in the model.
    pub fn with_current(mut self, current: Vec<crate::EffectInfo>) -> Self {
        self.current = current;
        self
    }

    /// Whether an effect of this label is in the model.
    pub fn has_current(&self, label: &str) -> bool {
        self.current.iter().any(|e| e.label == label)
    }

    /// Every sample's time in timeline order (runs in time order; [`Self::timeline_index`]).
    pub fn timeline(&self) -> &[f64] {
        &self.times
    }

    /// Time of the session's first sample (s).
    pub fn t0(&self) -> f64 {
        self.times.first().copied().unwrap_or(0.0)
    }

    /// Duration of the session, first to last sample (s).
    pub fn duration(&self) -> f64 {
        match (self.times.first(), self.times.last()) {
            (Some(a), Some(b)) => (b - a).max(0.0),
            _ => 0.0,
        }
    }

    /// Median interval between consecutive samples (s).
    pub fn median_interval(&self) -> f64 {
        let mut d: Vec<f64> = self
            .times
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .collect();
        if d.is_empty() {
            return 1.0;
        }
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
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

    /// Commanded position of axis `a` at sample `i` of run `r` (SI).
    pub fn q(&self, r: usize, i: usize, a: usize) -> f64 {
        self.runs[r].q[i * self.axes.len() + a]
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
        for run in &self.runs {
            if let Some(v) = run.context_column(name) {
                for &x in v {
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
        let mut cache = self.inputs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = cache.get(input) {
            return Arc::clone(s);
        }
        let series = Arc::new(self.build_input(input));
        cache.insert(input.clone(), Arc::clone(&series));
        series
    }

    fn build_input(&self, input: &Input) -> Vec<f64> {
        let column = input.column();
        let first_value = self
            .order
            .iter()
            .find_map(|&r| self.runs[r].context_column(column).and_then(|v| v.first()))
            .copied();
        let (offset, scale) = match input {
            Input::Speed | Input::SpeedSquared => (0.0, 1e-3),
            Input::Context(_) => (first_value.unwrap_or(0.0), 1.0),
        };
        let mut held = match input {
            Input::Speed | Input::SpeedSquared => 0.0,
            Input::Context(_) => first_value.unwrap_or(0.0),
        };
        let mut out = Vec::with_capacity(self.times.len());
        for &r in &self.order {
            let run = &self.runs[r];
            match run.context_column(column) {
                Some(v) => {
                    for &x in v {
                        held = x;
                        out.push((x - offset) * scale);
                    }
                }
                None => out.extend(std::iter::repeat_n((held - offset) * scale, run.len())),
            }
        }
        if *input == Input::SpeedSquared {
            out.iter_mut().for_each(|x| *x *= *x);
        }
        if let Input::Context(_) = input {
            out = smoothed(&out, &self.times, TEMPERATURE_SMOOTHING_S);
        }
        out
    }

    /// The first-order lag of `input` with time constant `tau_s`, over the timeline (cached).
    pub fn lag(&self, input: &Input, tau_s: f64) -> Arc<LagSeries> {
        let key = (input.clone(), tau_s.to_bits());
        if let Some(s) = self
            .lags
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&key)
        {
            return Arc::clone(s);
        }
        let u = self.input(input);
        let series = Arc::new(first_order_lag(&u, &self.times, tau_s));
        let mut cache = self.lags.lock().unwrap_or_else(|e| e.into_inner());
        // Keep the cache bounded: a fit refining τ asks for a new value at every evaluation.
        if cache.len() > 256 {
            cache.clear();
        }
        cache.insert(key, Arc::clone(&series));
        series
    }

    /// Drops cached lag series (after scoring a batch of candidates).
    pub fn clear_caches(&self) {
        self.lags.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }
}

/// How axis `a` moves in `run`, having arrived at its first position moving in direction
/// `initial` (±1; 0: unknown, then from the side of its first motion).
fn axis_motion(run: &RunView, a: usize, na: usize, initial: i8) -> AxisMotion {
    let n = run.len();
    let q = |i: usize| run.q[i * na + a];
    if n == 0 {
        return AxisMotion::default();
    }
    let mut steps = Vec::new();
    let mut raw = vec![0i8; n];
    for (i, dir) in raw.iter_mut().enumerate().skip(1) {
        let d = q(i) - q(i - 1);
        if d.abs() > STANDING {
            *dir = if d > 0.0 { 1 } else { -1 };
            steps.push(d.abs());
        }
    }
    let moves = !steps.is_empty();
    let first_dir = raw.iter().copied().find(|&d| d != 0).unwrap_or(0);
    let mut direction = vec![0i8; n];
    let mut travel = vec![0.0; n];
    let mut current = if initial != 0 { initial } else { first_dir };
    let mut anchor = q(0);
    let mut reverses = false;
    for i in 0..n {
        if raw[i] != 0 && raw[i] != current {
            // A reversal: the turning point is the previous sample (or the run's start, when
            // the axis arrived from the other side).
            reverses = true;
            current = raw[i];
            anchor = q(i.saturating_sub(1));
        }
        direction[i] = current;
        travel[i] = (q(i) - anchor).abs();
    }
    let velocity = (0..n)
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = run.t[hi] - run.t[lo];
            if hi == lo || dt <= 0.0 {
                0.0
            } else {
                (q(hi) - q(lo)) / dt
            }
        })
        .collect();
    steps.sort_by(f64::total_cmp);
    let step = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let (lo, hi) = (0..n).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
        (lo.min(q(i)), hi.max(q(i)))
    });
    AxisMotion {
        direction,
        velocity,
        travel,
        reverses,
        moves,
        step,
        range: (lo, hi),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(name: &str, t: Vec<f64>, q: Vec<f64>, context: Vec<(String, Vec<f64>)>) -> RunView {
        RunView {
            name: name.into(),
            setup: 0,
            fit: true,
            t,
            q,
            context,
        }
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
        assert_eq!(m.direction, vec![1, 1, 1, 1, -1, -1, -1]);
        assert!(m.reverses && m.moves);
        // Travel restarts at the turning point (0.002).
        assert!((m.travel[6] - 0.001).abs() < 1e-15);
        assert!((m.travel[2] - 0.002).abs() < 1e-15);
        assert!((m.velocity[1] - 0.001).abs() < 1e-15);
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
                &[0.0, 1.0, 20.0, 21.0],
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
        let s = smoothed(&noisy, &t, TEMPERATURE_SMOOTHING_S);
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
        let s2 = smoothed(&noisy, &t2, TEMPERATURE_SMOOTHING_S);
        assert!(s.iter().zip(&s2).all(|(a, b)| (a - b).abs() < 1e-7));
    }

    #[test]
    fn a_linear_axis_arrives_from_where_the_previous_run_left_it() {
        // Run "a" ends at X = 0.01 after moving up; run "b" starts at 0.02 and moves down: it
        // arrived moving up (from 0.01), so its first motion is a reversal.
        let a = run("a", vec![0.0, 1.0], vec![0.0, 0.01], vec![]);
        let b = run("b", vec![5.0, 6.0, 7.0], vec![0.02, 0.015, 0.01], vec![]);
        let v = view(vec![a, b]);
        let m = v.motion(1, 0);
        assert_eq!(m.direction, vec![1, -1, -1]);
        assert!(m.reverses);
        // Started where the last run ended: keeps its last direction.
        let a = run("a", vec![0.0, 1.0], vec![0.0, 0.01], vec![]);
        let b = run("b", vec![5.0, 6.0], vec![0.01, 0.02], vec![]);
        let v = view(vec![a, b]);
        assert_eq!(v.motion(1, 0).direction, vec![1, 1]);
        assert!(!v.motion(1, 0).reverses);
    }
}
