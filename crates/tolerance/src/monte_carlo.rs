//! Source 001's "Model C": random machines from tolerances, the P90 of their maximum volumetric
//! error, and each tolerance's sensitivity.
//!
//! Per sample `i` and tolerance `j` a random stream (ChaCha8 seeded from `(seed, j, i)`) draws
//! that tolerance's random part (rail profiles, pad deviations, a component error's factor).
//! Its effect on the analysis model's coefficients, `g_j`, is linear in the tolerance value, so
//! every run of a sample reuses the same draws (common random numbers): the baseline is
//! `c = g_0 + Σ_j g_j` (`g_0`: the loads' constant share), a sensitivity run scales one `g_j`.
//! Each run's maximum of `|Δ|` over the grid is recorded. The result does not depend on the
//! number of threads. Nothing is allocated per sample.

use mtcal_kinematics::Machine;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::eval::{EvalError, GridMax, GridScratch, Layout, N_LINEAR, RawCurves};
use crate::rail::{Carriage, Guide, ProfileBasis, RailError};
use crate::spec::{Distribution, RailDirection, Spec, Target, Tolerance};
use crate::stats::{Summary, percentile_in};

/// Why an analysis cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error("the guide of axis {axis}: {cause}")]
    Rail { axis: char, cause: RailError },
    #[error("the machine has no linear axis {axis} for the guide given in the specification")]
    NoAxis { axis: char },
    #[error("{what} must be at least 1")]
    Zero { what: &'static str },
}

/// Run settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Sampled machines.
    pub samples: usize,
    pub seed: u64,
    /// Worker threads (0: all cores). The result does not depend on it.
    pub threads: usize,
    /// Paired bootstrap resamples for the sensitivities' standard errors (0: none).
    pub bootstrap: usize,
    /// Confidence of the percentile intervals.
    pub confidence: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            samples: DEFAULT_SAMPLES,
            seed: 1,
            threads: 0,
            bootstrap: 100,
            confidence: 0.95,
        }
    }
}

/// Default number of sampled machines.
pub const DEFAULT_SAMPLES: usize = 5000;
/// Default grid: points per linear axis.
pub const DEFAULT_GRID: [usize; 3] = [11, 11, 11];

/// The guide of one axis, ready to sample.
#[derive(Clone, Debug)]
struct AxisGuide {
    carriage: Carriage,
    profile: ProfileBasis,
    /// +1 tool branch, −1 workpiece branch (functional errors are the negated body twist).
    sign: f64,
}

/// A prepared analysis: the model, the grid evaluator, the tolerances and their guides.
#[derive(Clone, Debug)]
pub struct Analysis {
    layout: Layout,
    grid_max: GridMax,
    tolerances: Vec<Tolerance>,
    guides: [Option<AxisGuide>; N_LINEAR],
    /// The loads' constant share of the coefficients.
    g0: Vec<f64>,
    levels: Vec<f64>,
    machine_name: String,
    counts: Vec<usize>,
}

/// Per-thread scratch: everything a sample needs, allocated once.
struct Scratch {
    raw: RawCurves,
    /// `n_tol × n_coeffs`.
    g: Vec<f64>,
    sum: Vec<f64>,
    c: Vec<f64>,
    grid: GridScratch,
    amps: Vec<f64>,
    profile: Vec<f64>,
    rear: [Vec<f64>; 2],
    front: [Vec<f64>; 2],
}

impl Analysis {
    /// Prepares `spec` on `machine` with a grid of `counts` points per linear axis (X, Y, Z).
    pub fn new(machine: &Machine, spec: &Spec, counts: &[usize]) -> Result<Self, AnalysisError> {
        let layout = Layout::new(machine, counts)?;
        let grid_max = GridMax::new(&layout)?;
        let mut guides: [Option<AxisGuide>; N_LINEAR] = Default::default();
        for (l, g) in spec.guides.iter().enumerate() {
            let Some(g) = g else { continue };
            let letter = ['X', 'Y', 'Z'][l];
            let ax = &machine.axes()[layout.axis(l)];
            let carriage = Carriage::new(Guide {
                axis: ax.zero_rotation() * ax.direction(),
                normal: g.normal,
                rail_spacing: g.rail_spacing,
                block_pitch: g.block_pitch,
                stiffness: g.stiffness,
                lateral_stiffness: g.lateral_stiffness,
                load: g.load,
                lateral_load: g.lateral_load,
            })
            .map_err(|source| AnalysisError::Rail {
                axis: letter,
                cause: source,
            })?;
            let knots = layout.knots(l);
            let stroke = ax.limits().ok_or(AnalysisError::NoAxis { axis: letter })?;
            let stroke = (stroke.0.min(knots[0]), stroke.1.max(knots[knots.len() - 1]));
            guides[l] = Some(AxisGuide {
                profile: ProfileBasis::new(knots, stroke, g.block_pitch, g.modes, g.decay),
                carriage,
                sign: match ax.side() {
                    mtcal_kinematics::Side::Tool => 1.0,
                    mtcal_kinematics::Side::Workpiece => -1.0,
                },
            });
        }
        let mut analysis = Analysis {
            g0: vec![0.0; layout.n_coeffs()],
            layout,
            grid_max,
            tolerances: spec.tolerances.clone(),
            guides,
            levels: spec.levels.clone(),
            machine_name: machine.name().to_string(),
            counts: counts.to_vec(),
        };
        analysis.g0 = analysis.load_share();
        Ok(analysis)
    }

    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    pub fn tolerances(&self) -> &[Tolerance] {
        &self.tolerances
    }

    /// The coefficients the loads give on their own (constant over the stroke).
    fn load_share(&self) -> Vec<f64> {
        let mut raw = RawCurves::new(&self.layout);
        for (l, g) in self.guides.iter().enumerate() {
            let Some(g) = g else { continue };
            let t = g
                .carriage
                .body_twist(&g.carriage.motion(&[0.0; 4], &[0.0; 4], true));
            for (d, v) in t.iter().enumerate() {
                raw.curve_mut(l, d).fill(g.sign * v);
            }
        }
        let mut out = vec![0.0; self.layout.n_coeffs()];
        self.layout.to_coefficients(&raw, &mut out);
        out
    }

    fn scratch(&self) -> Scratch {
        let n = self.layout.n_coeffs();
        let modes = self
            .guides
            .iter()
            .flatten()
            .map(|g| g.profile.n_amplitudes())
            .max()
            .unwrap_or(0);
        let points = self
            .guides
            .iter()
            .flatten()
            .map(|g| g.profile.n_points())
            .max()
            .unwrap_or(0);
        let knots = (0..N_LINEAR)
            .map(|l| self.layout.knots(l).len())
            .max()
            .unwrap_or(0);
        Scratch {
            raw: RawCurves::new(&self.layout),
            g: vec![0.0; self.tolerances.len() * n],
            sum: vec![0.0; n],
            c: vec![0.0; n],
            grid: self.grid_max.scratch(),
            amps: vec![0.0; modes],
            profile: vec![0.0; points],
            rear: [vec![0.0; knots], vec![0.0; knots]],
            front: [vec![0.0; knots], vec![0.0; knots]],
        }
    }

    /// Number of runs per sample: the baseline and one per tolerance and level.
    pub fn n_runs(&self) -> usize {
        1 + self.tolerances.len() * self.levels.len()
    }

    /// The scale of tolerance `j` in run `r` (1 for the others).
    fn run_target(&self, r: usize) -> Option<(usize, f64)> {
        (r > 0).then(|| {
            let k = r - 1;
            (k / self.levels.len(), self.levels[k % self.levels.len()])
        })
    }

    /// Draws the effect of tolerance `j` on sample `i` into `out` (coefficients), using the
    /// raw-curve scratch.
    fn draw(&self, j: usize, seed: u64, i: usize, s: &mut Scratch, range: std::ops::Range<usize>) {
        let tol = &self.tolerances[j];
        let mut rng = ChaCha8Rng::seed_from_u64(stream_seed(seed, j, i));
        s.raw.clear();
        let mut square = None;
        match tol.target {
            Target::Rail { axis, direction } => {
                let g = self.guides[axis].as_ref().expect("checked by the spec");
                let n = self.layout.knots(axis).len();
                for rail in 0..2 {
                    let amps = &mut s.amps[..g.profile.n_amplitudes()];
                    for a in amps.iter_mut() {
                        *a = rng.sample(StandardNormal);
                    }
                    let width = tol.value * draw_x(tol.distribution, &mut rng).abs();
                    g.profile.profile(
                        amps,
                        width,
                        &mut s.profile,
                        &mut s.rear[rail][..n],
                        &mut s.front[rail][..n],
                    );
                }
                for k in 0..n {
                    // Blocks 1 (rail A rear), 2 (A front), 3 (B front), 4 (B rear).
                    let d = [s.rear[0][k], s.front[0][k], s.front[1][k], s.rear[1][k]];
                    let m = match direction {
                        RailDirection::Vertical => g.carriage.motion(&d, &[0.0; 4], false),
                        RailDirection::Horizontal => g.carriage.motion(&[0.0; 4], &d, false),
                    };
                    let t = g.carriage.body_twist(&m);
                    for (dir, v) in t.iter().enumerate() {
                        s.raw.curve_mut(axis, dir)[k] = g.sign * v;
                    }
                }
            }
            Target::Pads { axis } => {
                let g = self.guides[axis].as_ref().expect("checked by the spec");
                let d: [f64; 4] =
                    std::array::from_fn(|_| 0.5 * tol.value * draw_x(tol.distribution, &mut rng));
                let t = g
                    .carriage
                    .body_twist(&g.carriage.motion(&d, &[0.0; 4], false));
                for (dir, v) in t.iter().enumerate() {
                    s.raw.curve_mut(axis, dir).fill(g.sign * v);
                }
            }
            Target::Component {
                axis,
                direction,
                shape,
            } => {
                let x = tol.value * draw_x(tol.distribution, &mut rng);
                let q = self.layout.knots(axis);
                let (lo, hi) = (q[0], q[q.len() - 1]);
                let curve = s.raw.curve_mut(axis, direction.index());
                for (v, &qk) in curve.iter_mut().zip(q) {
                    *v = x * shape.at((qk - lo) / (hi - lo));
                }
            }
            Target::Squareness { which } => {
                square = Some((which, tol.value * draw_x(tol.distribution, &mut rng)));
            }
        }
        let out = &mut s.g[range];
        out.fill(0.0);
        self.layout.to_coefficients(&s.raw, out);
        if let Some((which, v)) = square {
            out[self.layout.squareness(which)] += v;
        }
    }

    /// Samples `first..first + out.len()/n_runs` into `out` (sample-major, µm).
    fn run_chunk(&self, seed: u64, first: usize, out: &mut [f64]) {
        let mut sampler = self.sampler();
        for (offset, row) in out.chunks_mut(self.n_runs()).enumerate() {
            sampler.sample(seed, first + offset, row);
        }
    }

    /// A sampler with its own scratch (one per thread).
    pub fn sampler(&self) -> Sampler<'_> {
        Sampler {
            analysis: self,
            scratch: self.scratch(),
        }
    }

    /// The maxima of every run of every sample, µm, sample-major (`samples × n_runs`).
    pub fn sample_maxima(&self, opts: &Options) -> Result<Vec<f64>, AnalysisError> {
        if opts.samples == 0 {
            return Err(AnalysisError::Zero { what: "samples" });
        }
        let runs = self.n_runs();
        let mut out = vec![0.0; opts.samples * runs];
        let threads = match opts.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            t => t,
        }
        .min(opts.samples);
        let per = opts.samples.div_ceil(threads);
        std::thread::scope(|scope| {
            for (t, chunk) in out.chunks_mut(per * runs).enumerate() {
                scope.spawn(move || self.run_chunk(opts.seed, t * per, chunk));
            }
        });
        Ok(out)
    }

    /// Runs the analysis.
    pub fn run(&self, opts: &Options) -> Result<Report, AnalysisError> {
        let maxima = self.sample_maxima(opts)?;
        let runs = self.n_runs();
        let column =
            |r: usize| -> Vec<f64> { maxima.iter().skip(r).step_by(runs).copied().collect() };
        let baseline = Summary::of(&column(0), opts.confidence);
        let mut buf = Vec::new();
        let p90s: Vec<f64> = (0..runs)
            .map(|r| percentile_in(&column(r), 90.0, &mut buf))
            .collect();
        let boot = self.bootstrap(&maxima, opts);
        let sensitivities = (0..self.tolerances.len())
            .map(|j| self.sensitivity(j, &p90s, &boot))
            .collect();
        Ok(Report {
            schema: REPORT_SCHEMA,
            machine: self.machine_name.clone(),
            samples: opts.samples,
            seed: opts.seed,
            grid: self.counts.clone(),
            grid_points: self.grid_max.len(),
            baseline,
            levels: self.levels.clone(),
            bootstrap: opts.bootstrap,
            sensitivities,
        })
    }

    /// Paired bootstrap: per resample, the P90 of every run (`bootstrap × n_runs`).
    fn bootstrap(&self, maxima: &[f64], opts: &Options) -> Vec<f64> {
        let runs = self.n_runs();
        let n = opts.samples;
        let mut rng = ChaCha8Rng::seed_from_u64(stream_seed(opts.seed, usize::MAX, 0));
        let mut out = Vec::with_capacity(opts.bootstrap * runs);
        let (mut idx, mut col, mut buf) = (vec![0usize; n], vec![0.0; n], Vec::new());
        for _ in 0..opts.bootstrap {
            for i in idx.iter_mut() {
                *i = rng.random_range(0..n);
            }
            for r in 0..runs {
                for (c, &i) in col.iter_mut().zip(&idx) {
                    *c = maxima[i * runs + r];
                }
                out.push(percentile_in(&col, 90.0, &mut buf));
            }
        }
        out
    }

    fn sensitivity(&self, j: usize, p90s: &[f64], boot: &[f64]) -> Sensitivity {
        let tol = &self.tolerances[j];
        let nl = self.levels.len();
        let unit = if tol.is_angle() { "urad" } else { "um" };
        let value = tol.value * 1e6;
        let runs = self.n_runs();
        // (scale, run) pairs including the baseline.
        let mut pairs: Vec<(f64, usize)> = vec![(1.0, 0)];
        pairs.extend((0..nl).map(|k| (self.levels[k], 1 + j * nl + k)));
        let levels = pairs
            .iter()
            .map(|&(scale, r)| Level {
                scale,
                tolerance: scale * value,
                p90_um: p90s[r],
            })
            .collect();
        let zero = pairs.iter().find(|p| p.0 == 0.0).map(|p| p.1);
        let xs: Vec<f64> = pairs.iter().map(|p| p.0 * value).collect();
        // (delta, slope) from one set of per-run P90s.
        let stats = |p90: &[f64]| {
            let ys: Vec<f64> = pairs.iter().map(|p| p90[p.1]).collect();
            (zero.map(|z| p90[0] - p90[z]), regression_slope(&xs, &ys))
        };
        let (delta, slope) = stats(p90s);
        let boot_stats: Vec<(Option<f64>, Option<f64>)> =
            boot.chunks_exact(runs).map(stats).collect();
        let se = |vals: Vec<f64>| {
            (vals.len() >= 2).then(|| {
                let m = vals.iter().sum::<f64>() / vals.len() as f64;
                (vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (vals.len() - 1) as f64).sqrt()
            })
        };
        Sensitivity {
            label: tol.label.clone(),
            target: describe_target(&tol.target),
            tolerance: value,
            unit,
            distribution: tol.distribution,
            levels,
            p90_without_um: zero.map(|z| p90s[z]),
            delta_p90_um: delta,
            delta_p90_se_um: se(boot_stats.iter().filter_map(|b| b.0).collect()),
            slope,
            slope_se: se(boot_stats.iter().filter_map(|b| b.1).collect()),
        }
    }
}

/// Draws single samples without allocating: all scratch is allocated by
/// [`Analysis::sampler`].
pub struct Sampler<'a> {
    analysis: &'a Analysis,
    scratch: Scratch,
}

impl std::fmt::Debug for Sampler<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sampler").finish_non_exhaustive()
    }
}

impl Sampler<'_> {
    /// The maximum |Δ| over the grid (µm) of sample `i` of the stream `seed`, for every run
    /// (`out`: [`Analysis::n_runs`] long; the baseline first).
    pub fn sample(&mut self, seed: u64, i: usize, out: &mut [f64]) {
        let a = self.analysis;
        let s = &mut self.scratch;
        let n = a.layout.n_coeffs();
        for j in 0..a.tolerances.len() {
            a.draw(j, seed, i, s, j * n..(j + 1) * n);
        }
        s.sum.copy_from_slice(&a.g0);
        for j in 0..a.tolerances.len() {
            for (x, y) in s.sum.iter_mut().zip(&s.g[j * n..(j + 1) * n]) {
                *x += y;
            }
        }
        for (r, slot) in out.iter_mut().enumerate() {
            let coeffs = match a.run_target(r) {
                None => &s.sum,
                Some((j, scale)) => {
                    let g = &s.g[j * n..(j + 1) * n];
                    for ((c, x), y) in s.c.iter_mut().zip(&s.sum).zip(g) {
                        *c = x + (scale - 1.0) * y;
                    }
                    &s.c
                }
            };
            *slot = a.grid_max.max(coeffs, &mut s.grid) * 1e6;
        }
    }
}

/// Least-squares slope of `ys` against `xs` (None if the xs do not vary).
fn regression_slope(xs: &[f64], ys: &[f64]) -> Option<f64> {
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// `X` of a distribution (the sampled error is `tolerance · X`).
fn draw_x(d: Distribution, rng: &mut ChaCha8Rng) -> f64 {
    match d {
        Distribution::Uniform => rng.random_range(-1.0..=1.0),
        Distribution::Normal => 0.5 * rng.sample::<f64, _>(StandardNormal),
        Distribution::Limit => {
            if rng.random::<bool>() {
                1.0
            } else {
                -1.0
            }
        }
    }
}

/// The seed of the stream of tolerance `j` in sample `i` (SplitMix64 finalisers).
fn stream_seed(seed: u64, j: usize, i: usize) -> u64 {
    fn mix(mut z: u64) -> u64 {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    mix(mix(mix(seed) ^ j as u64) ^ i as u64)
}

fn describe_target(t: &Target) -> String {
    let letter = |a: usize| ['X', 'Y', 'Z'][a];
    match t {
        Target::Rail { axis, direction } => format!(
            "rail {} {}",
            letter(*axis),
            match direction {
                RailDirection::Vertical => "vertical",
                RailDirection::Horizontal => "horizontal",
            }
        ),
        Target::Pads { axis } => format!("pads {}", letter(*axis)),
        Target::Component {
            axis, direction, ..
        } => format!("component E{}{}", direction.letter(), letter(*axis)),
        Target::Squareness { which } => {
            format!("squareness {}", ["EC0Y", "EB0Z", "EA0Z"][*which])
        }
    }
}

/// The `schema` of the JSON report.
pub const REPORT_SCHEMA: &str = "mtcal.tolerance/1";

/// One tolerance's P90 at one scale.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Level {
    pub scale: f64,
    /// The scaled tolerance, µm or µrad.
    pub tolerance: f64,
    pub p90_um: f64,
}

/// How the P90 responds to one tolerance alone (others at baseline, common random numbers).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sensitivity {
    pub label: String,
    pub target: String,
    /// Baseline tolerance, in `unit`.
    pub tolerance: f64,
    /// `um` or `urad`.
    pub unit: &'static str,
    pub distribution: Distribution,
    /// The baseline (scale 1) first, then the levels.
    pub levels: Vec<Level>,
    /// P90 with this tolerance at zero (if 0 is a level).
    pub p90_without_um: Option<f64>,
    /// Baseline P90 minus `p90_without_um`: what this tolerance adds.
    pub delta_p90_um: Option<f64>,
    /// Its paired-bootstrap standard error.
    pub delta_p90_se_um: Option<f64>,
    /// Least-squares slope of P90 against the tolerance over the levels and the baseline
    /// (µm per `unit`; source 001's Table 1 coefficients are such slopes).
    pub slope: Option<f64>,
    pub slope_se: Option<f64>,
}

/// The result of a tolerance analysis.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Report {
    pub schema: &'static str,
    pub machine: String,
    pub samples: usize,
    pub seed: u64,
    pub grid: Vec<usize>,
    pub grid_points: usize,
    /// The maximum |Δ| over the grid of the sampled machines at the specified tolerances.
    pub baseline: Summary,
    pub levels: Vec<f64>,
    pub bootstrap: usize,
    pub sensitivities: Vec<Sensitivity>,
}

impl Report {
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("plain data serialises")
    }
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let b = &self.baseline;
        let g: Vec<String> = self.grid.iter().map(ToString::to_string).collect();
        writeln!(
            f,
            "tolerance analysis  {}: {} sampled machines (seed {}), grid {} = {} points",
            self.machine,
            self.samples,
            self.seed,
            g.join(" x "),
            self.grid_points
        )?;
        writeln!(
            f,
            "maximum volumetric error |Δ| over the grid, per machine:"
        )?;
        let pct = 100.0 * b.confidence;
        writeln!(
            f,
            "  P90 {:.2} um  ({pct:.0} % CI {:.2} … {:.2} um, order statistics)",
            b.p90_um, b.p90_ci_um[0], b.p90_ci_um[1]
        )?;
        writeln!(
            f,
            "  P50 {:.2} um  P95 {:.2} um  mean {:.2} um  sd {:.2} um  range {:.2} … {:.2} um",
            b.p50_um, b.p95_um, b.mean_um, b.std_um, b.min_um, b.max_um
        )?;
        let peak = b.histogram.iter().map(|h| h.1).max().unwrap_or(1).max(1);
        for (edge, count) in &b.histogram {
            let bar = "#".repeat((40 * count).div_ceil(peak));
            writeln!(f, "  {edge:>9.2} um {count:>7} {bar}")?;
        }
        if self.sensitivities.is_empty() {
            return Ok(());
        }
        let levels: Vec<String> = self.levels.iter().map(|l| format!("{l}")).collect();
        writeln!(
            f,
            "sensitivity: each tolerance alone at scales {} (others at baseline; common random \
             numbers; ± bootstrap standard error, {} resamples)",
            levels.join(", "),
            self.bootstrap
        )?;
        let width = self
            .sensitivities
            .iter()
            .map(|s| s.label.chars().count())
            .max()
            .unwrap_or(0)
            .max(9);
        writeln!(
            f,
            "  {:<width$}  {:>17}  {:>12}  {:>18}  {:>20}",
            "tolerance", "value", "P90 without", "adds to P90", "slope dP90/dtol"
        )?;
        for s in &self.sensitivities {
            let opt = |v: Option<f64>, se: Option<f64>, unit: &str| match (v, se) {
                (Some(v), Some(se)) => format!("{v:.2}±{se:.2}{unit}"),
                (Some(v), None) => format!("{v:.3}{unit}"),
                _ => "-".to_string(),
            };
            writeln!(
                f,
                "  {:<width$}  {:>17}  {:>12}  {:>18}  {:>20}",
                s.label,
                format!("{:.1} {} {:?}", s.tolerance, s.unit, s.distribution).to_lowercase(),
                s.p90_without_um
                    .map_or("-".to_string(), |v| format!("{v:.2} um")),
                opt(s.delta_p90_um, s.delta_p90_se_um, " um"),
                opt(s.slope, s.slope_se, &format!(" um/{}", s.unit)),
            )?;
        }
        Ok(())
    }
}
