//! Session folders exactly as FORMATS.md ("Measurement session") describes them, plus the
//! ground-truth sidecar `truth/` that tests compare against.

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};

use crate::effects::{ContextValues, Effect, Resolved, SampleState, Timeline, effects_toml};
pub use crate::error::SimError;
pub use crate::instruments::SetupPlan;
use crate::instruments::{Instrument, SetupOffsets};
use crate::machine::{JointKind, Machine};
use crate::truth::Truth;

/// One run: its commanded poses (SI, machine order).
#[derive(Clone, Debug)]
pub struct RunPlan {
    pub name: String,
    pub setup: String,
    /// `use = "validate"`.
    pub validate: bool,
    pub poses: Vec<Vec<f64>>,
    /// One text per sample for an instrument with a label column (the artefact's `feature`:
    /// `feature`, or `placement/feature` with several placements); empty otherwise.
    pub labels: Vec<String>,
    /// Time between this run's samples, s (e.g. a ball bar's arc per sample over the feed);
    /// `None`: [`Realism::interval_s`].
    pub interval_s: Option<f64>,
    /// Time from the previous run's last sample to this run's first, s (e.g. a set-up
    /// change); `None`: [`Realism::pause_s`]. Before the session's first run there is no
    /// pause.
    pub pause_before_s: Option<f64>,
}

/// What to write: the machine (a URDF file, referred to by a relative path), set-ups, runs (in
/// time order), and the physical effects beyond the geometric errors.
#[derive(Clone, Debug)]
pub struct Plan {
    pub machine_urdf: PathBuf,
    pub setups: Vec<SetupPlan>,
    pub runs: Vec<RunPlan>,
    /// Effects acting through the session's timeline ([`crate::effects`]); empty: the
    /// geometric model alone, every reading as without effects.
    pub effects: Vec<Effect>,
}

/// How far the files are from the ideal: all zero (or `None`) in [`Realism::ideal`].
#[derive(Clone, Debug, PartialEq)]
pub struct Realism {
    /// Seed of every random draw of the realism (noise, jitter, set-up offsets).
    pub seed: u64,
    /// Time between samples, s.
    pub interval_s: f64,
    /// Time between runs, s.
    pub pause_s: f64,
    /// σ of the sample-time jitter, s (kept below 0.4 of the interval so `t` keeps rising).
    pub jitter_s: f64,
    /// σ of the reading noise, µm (in mm on the artefact's mm channels, µrad on an angular
    /// laser's), and its AR(1) coefficient φ:
    /// `e_k = φ·e_(k−1) + √(1−φ²)·σ·n_k` (stationary σ, coloured for φ > 0).
    pub noise_sigma_um: f64,
    pub noise_phi: f64,
    /// The σ the manifest states is this factor times the one used (1: honest).
    pub manifest_sigma_factor: f64,
    /// Readings are rounded to this resolution, µm (likewise; 0: not quantised).
    pub resolution_um: f64,
    /// Commanded positions are rounded to this many decimals of mm / degrees (the machine
    /// then moves exactly there; `None`: every digit).
    pub position_decimals: Option<i32>,
    /// σ of the difference between the real and the stated set-up, per coordinate, µm: the
    /// ball / nest / pivot / station position and the tool length (a normal draw, unbounded:
    /// σ = 100 µm puts a coordinate up to 0.2 mm off in 95 % of set-ups).
    pub setup_position_sigma_um: f64,
    pub tool_length_sigma_um: f64,
    /// A set-up placed by eye: each coordinate of the position additionally off by a uniform
    /// draw in `±setup_position_bound_um` µm (200: up to 0.2 mm off nominal; 0: none). Drawn
    /// from a random stream of its own, so that the other draws stay as without it.
    pub setup_position_bound_um: f64,
    /// σ of a temperature sensor's white noise, K, and the resolution it writes, K (0: exact):
    /// the temperature columns of effects ([`crate::effects`]), drawn from a random stream of
    /// their own so that the other draws stay as without effects.
    pub temperature_sigma_k: f64,
    pub temperature_resolution_k: f64,
}

impl Realism {
    /// Exact files: no noise, no jitter, no quantisation, the set-up as stated.
    pub fn ideal() -> Self {
        Realism {
            seed: 0,
            interval_s: 0.5,
            pause_s: 10.0,
            jitter_s: 0.0,
            noise_sigma_um: 0.0,
            noise_phi: 0.0,
            manifest_sigma_factor: 1.0,
            resolution_um: 0.0,
            position_decimals: None,
            setup_position_sigma_um: 0.0,
            tool_length_sigma_um: 0.0,
            setup_position_bound_um: 0.0,
            temperature_sigma_k: 0.0,
            temperature_resolution_k: 0.0,
        }
    }

    /// A plausible measurement: 0.3 µm noise coloured with φ = 0.6, stated 20 % optimistic,
    /// 0.1 µm resolution, 5 ms jitter, positions to 0.1 µm / 0.0001°, set-ups 20 µm off;
    /// temperatures read to 0.01 K with 0.02 K of noise.
    pub fn realistic(seed: u64) -> Self {
        Realism {
            seed,
            temperature_sigma_k: 0.02,
            temperature_resolution_k: 0.01,
            jitter_s: 0.005,
            noise_sigma_um: 0.3,
            noise_phi: 0.6,
            manifest_sigma_factor: 0.8,
            resolution_um: 0.1,
            position_decimals: Some(4),
            setup_position_sigma_um: 20.0,
            tool_length_sigma_um: 20.0,
            ..Realism::ideal()
        }
    }
}

/// One written run.
#[derive(Clone, Debug)]
pub struct WrittenRun {
    pub name: String,
    pub setup: String,
    pub file: PathBuf,
    /// Sample times as written, s since the session started.
    pub t: Vec<f64>,
    /// Commanded positions as written (mm / degrees), machine order.
    pub positions: Vec<Vec<f64>>,
    /// Noise-free readings (µm), also in `truth/<run>.csv`.
    pub clean_um: Vec<Vec<f64>>,
    /// The readings in the run file (µm).
    pub written_um: Vec<Vec<f64>>,
    /// The context columns as written (`T_<name>` °C, `S` rpm), in file order; their true
    /// values are in `truth/<run>.csv`.
    pub context: Vec<(String, Vec<f64>)>,
}

/// A written session: where, and what it was made from.
#[derive(Clone, Debug)]
pub struct Written {
    pub dir: PathBuf,
    pub truth: Truth,
    /// The real set-ups' offsets from the manifest's, by set-up name.
    pub offsets: Vec<(String, SetupOffsets)>,
    pub runs: Vec<WrittenRun>,
}

/// Writes `plan` for `machine` with errors `truth` into `dir` (created): `session.toml`, one
/// CSV per run, and `truth/` (`params.toml`, `errors.toml` — the model the params belong to —,
/// `setups.toml` with the real set-up offsets and the σ used, `<run>.csv` with the
/// noise-free readings and the true context values, and, when the plan has effects,
/// `effects.toml` naming every one with its parameters).
///
/// The plan's effects are checked first: a bad one (an unknown axis, a rotary axis where a
/// linear one is needed, a malformed column name…) is a [`SimError::Plan`] and nothing is
/// written.
pub fn write_session(
    dir: &Path,
    machine: &Machine,
    truth: &Truth,
    plan: &Plan,
    realism: &Realism,
) -> Result<Written, SimError> {
    let effects = Resolved::new(machine, &plan.setups, &plan.effects)?;
    std::fs::create_dir_all(dir.join("truth"))?;
    let mut rng = ChaCha8Rng::seed_from_u64(realism.seed);
    let offsets = draw_offsets(&plan.setups, realism, &mut rng);
    // Temperature sensors draw from a stream of their own, so that a plan with effects draws
    // the same noise, jitter and set-ups as without.
    let mut sensor_rng = ChaCha8Rng::seed_from_u64(realism.seed);
    sensor_rng.set_stream(1);
    let stated_sigma = (realism.noise_sigma_um > 0.0)
        .then_some(realism.noise_sigma_um * realism.manifest_sigma_factor);

    let mut manifest = String::from(
        "# Written by mtcal-indsim, an independent simulator (ground truth in truth/).\n",
    );
    let rel = relative_path(dir, &plan.machine_urdf)?;
    writeln!(manifest, "machine = \"{}\"", rel.display()).expect("string");
    for s in &plan.setups {
        write!(
            manifest,
            "\n[setup.{}]\n{}",
            s.name,
            s.instrument.setup_toml(stated_sigma)
        )
        .expect("string");
    }

    let letters: Vec<char> = machine.letters().chars().collect();
    let mut timeline = Timeline::new(&effects);
    let mut t0 = 0.0;
    let mut first_run = true;
    let mut runs = Vec::new();
    let mut mounted: std::collections::HashMap<&str, f64> = std::collections::HashMap::new();
    for run in &plan.runs {
        let setup_index = plan
            .setups
            .iter()
            .position(|s| s.name == run.setup)
            .ok_or_else(|| SimError::Plan(format!("run {}: no set-up {}", run.name, run.setup)))?;
        let instrument = &plan.setups[setup_index].instrument;
        let off = &offsets[setup_index].1;
        if run.labels.len() != instrument.label_columns().len().min(1) * run.poses.len() {
            return Err(SimError::Plan(format!(
                "run {}: {} labels for {} samples of {}",
                run.name,
                run.labels.len(),
                run.poses.len(),
                instrument.plugin_name()
            )));
        }
        // The random draws in their order: the reading noise's, then the sample times'.
        let n_ch = instrument.channels().len();
        let normals: Vec<Vec<f64>> = (0..run.poses.len())
            .map(|_| (0..n_ch).map(|_| StandardNormal.sample(&mut rng)).collect())
            .collect();
        if !first_run {
            t0 += run.pause_before_s.unwrap_or(realism.pause_s);
        }
        first_run = false;
        let interval_s = run.interval_s.unwrap_or(realism.interval_s);
        let times = sample_times(realism, interval_s, t0, run.poses.len(), &mut rng);
        t0 = times.last().copied().unwrap_or(t0);
        // The effects follow the commands as the machine moves to them.
        let commanded = to_si(machine, &to_file_units(machine, &run.poses, realism));
        let states = timeline.run(&commanded, &times);

        // A set-up is mounted when its first sample is taken.
        let mounted_s = *mounted
            .entry(run.setup.as_str())
            .or_insert(times.first().copied().unwrap_or(0.0));
        let creep = effects.setup_shift(&run.setup, mounted_s, &times);
        let measured = measure(
            machine,
            truth,
            instrument,
            (off, creep.as_deref()),
            run,
            &states,
            realism,
        );
        let mut clean_si = measured.readings;
        if let Some(own) = effects.instrument_own(&run.setup, &times) {
            for (r, d) in clean_si.iter_mut().zip(own) {
                r[0] += d;
            }
        }
        // Readings in the file's unit (µm; mm for the artefact's positions, µrad for angular
        // laser optics).
        let per_si = instrument.file_per_si();
        let clean_um: Vec<Vec<f64>> = clean_si
            .into_iter()
            .map(|r| r.into_iter().map(|v| v * per_si).collect())
            .collect();
        let written_um = add_noise(&clean_um, &normals, realism, per_si);
        let true_context = effects.context(&run.setup, &times);
        let context = sensed(&true_context, realism, &mut sensor_rng);
        let clean_context: Vec<(String, Vec<f64>)> = true_context
            .into_iter()
            .map(|c| (c.name, c.values))
            .collect();

        let file = PathBuf::from(format!("{}.csv", run.name));
        let channels = instrument.channels();
        let labels = Labels {
            columns: instrument.label_columns(),
            values: &run.labels,
        };
        let table = |readings, context| Table {
            letters: &letters,
            channels: &channels,
            labels: &labels,
            t: &times,
            positions: &measured.positions,
            readings,
            context,
        };
        write_csv(&dir.join(&file), &table(&written_um, &context))?;
        write_csv(
            &dir.join("truth").join(&file),
            &table(&clean_um, &clean_context),
        )?;
        write!(
            manifest,
            "\n[[run]]\nname = \"{}\"\ninstrument = \"{}\"\nfile = \"{}\"\nsetup = \"{}\"\n",
            run.name,
            instrument.plugin_name(),
            file.display(),
            run.setup
        )
        .expect("string");
        if run.validate {
            manifest.push_str("use = \"validate\"\n");
        }
        runs.push(WrittenRun {
            name: run.name.clone(),
            setup: run.setup.clone(),
            file,
            t: times,
            positions: measured.positions,
            clean_um,
            written_um,
            context,
        });
    }
    std::fs::write(dir.join("session.toml"), manifest)?;
    std::fs::write(dir.join("truth/params.toml"), truth.params_toml(machine))?;
    std::fs::write(dir.join("truth/errors.toml"), truth.model_config(machine))?;
    std::fs::write(
        dir.join("truth/setups.toml"),
        sidecar_setups(&offsets, realism),
    )?;
    if !plan.effects.is_empty() {
        std::fs::write(
            dir.join("truth/effects.toml"),
            effects_toml(machine, &plan.effects),
        )?;
    }
    Ok(Written {
        dir: dir.to_path_buf(),
        truth: truth.clone(),
        offsets,
        runs,
    })
}

/// How each set-up really differs from the manifest's.
pub(crate) fn draw_offsets(
    setups: &[SetupPlan],
    realism: &Realism,
    rng: &mut ChaCha8Rng,
) -> Vec<(String, SetupOffsets)> {
    let normal = |s: f64| Normal::new(0.0, s * 1e-6).expect("finite sigma");
    // Placed by eye: a stream of its own.
    let mut eye_rng = ChaCha8Rng::seed_from_u64(realism.seed);
    eye_rng.set_stream(2);
    let bound = realism.setup_position_bound_um * 1e-6;
    setups
        .iter()
        .map(|s| {
            let pos = normal(realism.setup_position_sigma_um);
            let len = normal(realism.tool_length_sigma_um);
            let mut position = Vector3::new(pos.sample(rng), pos.sample(rng), pos.sample(rng));
            if bound > 0.0 {
                for v in position.iter_mut() {
                    *v += eye_rng.random_range(-bound..=bound);
                }
            }
            let off = SetupOffsets {
                position,
                tool_length: len.sample(rng),
            };
            (s.name.clone(), off)
        })
        .collect()
}

/// `truth/setups.toml`.
pub(crate) fn sidecar_setups(offsets: &[(String, SetupOffsets)], realism: &Realism) -> String {
    let mut s = String::from("# Real set-ups: offsets from the manifest (um).\n");
    for (name, off) in offsets {
        writeln!(
            s,
            "[{name}]\nposition_um = [{:?}, {:?}, {:?}]\ntool_length_um = {:?}\nnoise_sigma_um = {:?}\nnoise_phi = {:?}\n",
            off.position.x * 1e6,
            off.position.y * 1e6,
            off.position.z * 1e6,
            off.tool_length * 1e6,
            realism.noise_sigma_um,
            realism.noise_phi
        )
        .expect("string");
    }
    s
}

/// The sample times of a run of `n` samples starting after `t0`: a regular `interval_s` with
/// jitter (clamped so that `t` keeps rising).
fn sample_times(
    realism: &Realism,
    interval_s: f64,
    t0: f64,
    n: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<f64> {
    let jitter = 0.4 * interval_s;
    (0..n)
        .map(|k| {
            let j = if realism.jitter_s > 0.0 {
                let n: f64 = StandardNormal.sample(rng);
                (n * realism.jitter_s).clamp(-jitter, jitter)
            } else {
                0.0
            };
            t0 + jitter + k as f64 * interval_s + j
        })
        .collect()
}

/// Axis positions (SI) in the file's units (mm / degrees), rounded as the controller writes
/// them; the machine moves exactly there.
pub(crate) fn to_file_units(
    machine: &Machine,
    poses: &[Vec<f64>],
    realism: &Realism,
) -> Vec<Vec<f64>> {
    poses
        .iter()
        .map(|q| {
            q.iter()
                .zip(&machine.joints)
                .map(|(&v, j)| {
                    let f = match j.kind {
                        JointKind::Linear => v * 1e3,
                        JointKind::Rotary => v.to_degrees(),
                    };
                    match realism.position_decimals {
                        Some(d) => round_to(f, 10f64.powi(-d)),
                        None => f,
                    }
                })
                .collect()
        })
        .collect()
}

/// File units to SI as FORMATS.md defines them (mm → m, degrees → rad).
pub(crate) fn to_si(machine: &Machine, positions: &[Vec<f64>]) -> Vec<Vec<f64>> {
    positions
        .iter()
        .map(|p| {
            p.iter()
                .zip(&machine.joints)
                .map(|(&v, j)| match j.kind {
                    JointKind::Linear => v * 1e-3,
                    JointKind::Rotary => v.to_radians(),
                })
                .collect()
        })
        .collect()
}

/// What a run records: its axis columns (file units) and the instrument's noise-free
/// readings (SI).
struct Measured {
    positions: Vec<Vec<f64>>,
    readings: Vec<Vec<f64>>,
}

/// The readings of `run`, its set-up `off` its stated one and, where it creeps, shifted by
/// `creep` at each sample ([`crate::effects::Effect::SetupCreep`]).
fn measure(
    machine: &Machine,
    truth: &Truth,
    instrument: &Instrument,
    (off, creep): (&SetupOffsets, Option<&[Vector3<f64>]>),
    run: &RunPlan,
    states: &[SampleState<'_>],
    realism: &Realism,
) -> Measured {
    // The positions as written are the positions the machine moves to (or, for a probing
    // cycle that reports the measured centre, those).
    let recorded = instrument.recorded_poses(machine, truth, &run.poses, &run.labels, off, states);
    // The readings at the positions as written, read back (rounding included).
    let positions = to_file_units(machine, &recorded, realism);
    let si = to_si(machine, &positions);
    let readings = match creep {
        None => instrument.readings(machine, truth, &si, &run.labels, off, states),
        // The set-up is another at every sample: each read on its own (only R-tests and ball
        // bars creep, and they read each sample absolutely).
        Some(shift) => (0..si.len())
            .map(|k| {
                let moved = SetupOffsets {
                    position: off.position + shift[k],
                    ..*off
                };
                let one = &states[k..=k];
                instrument.readings(machine, truth, &si[k..=k], &[], &moved, one)[0].clone()
            })
            .collect(),
    };
    Measured {
        positions,
        readings,
    }
}

/// The written readings: the clean ones plus AR(1) noise from the standard normals `normals`
/// (`e_k = φ·e_(k−1) + √(1−φ²)·σ·n_k`), quantised. Noise and resolution are stated in µm and
/// taken in the readings' own unit (`per_si` of it per SI unit).
fn add_noise(
    clean: &[Vec<f64>],
    normals: &[Vec<f64>],
    realism: &Realism,
    per_si: f64,
) -> Vec<Vec<f64>> {
    let to_unit = per_si * 1e-6;
    let (noise_sigma, resolution) = (
        realism.noise_sigma_um * to_unit,
        realism.resolution_um * to_unit,
    );
    let phi = realism.noise_phi;
    let mut noise = vec![0.0; normals.first().map_or(0, Vec::len)];
    clean
        .iter()
        .zip(normals)
        .enumerate()
        .map(|(k, (r, ns))| {
            r.iter()
                .zip(noise.iter_mut())
                .zip(ns)
                .map(|((&v, e), &n)| {
                    *e = if k == 0 {
                        noise_sigma * n
                    } else {
                        phi * *e + (1.0 - phi * phi).sqrt() * noise_sigma * n
                    };
                    let noisy = v + *e;
                    if resolution > 0.0 {
                        round_to(noisy, resolution)
                    } else {
                        noisy
                    }
                })
                .collect()
        })
        .collect()
}

/// The context columns as written: temperatures as a sensor reads them (white noise of
/// `temperature_sigma_k`, quantised to `temperature_resolution_k`), the spindle speed exact.
pub(crate) fn sensed(
    context: &[ContextValues],
    realism: &Realism,
    rng: &mut ChaCha8Rng,
) -> Vec<(String, Vec<f64>)> {
    context
        .iter()
        .map(|c| {
            let values = if c.sensed {
                c.values
                    .iter()
                    .map(|&v| {
                        let n: f64 = StandardNormal.sample(rng);
                        let read = v + realism.temperature_sigma_k * n;
                        if realism.temperature_resolution_k > 0.0 {
                            round_to(read, realism.temperature_resolution_k)
                        } else {
                            read
                        }
                    })
                    .collect()
            } else {
                c.values.clone()
            };
            (c.name.clone(), values)
        })
        .collect()
}

pub(crate) fn round_to(v: f64, step: f64) -> f64 {
    (v / step).round() * step
}

/// A run's text column (at most one) and its value per sample.
pub(crate) struct Labels<'a> {
    pub(crate) columns: &'a [&'a str],
    pub(crate) values: &'a [String],
}

/// One run file's content: `t`, the axes, the readings, the label, the context columns.
pub(crate) struct Table<'a> {
    pub(crate) letters: &'a [char],
    pub(crate) channels: &'a [String],
    pub(crate) labels: &'a Labels<'a>,
    pub(crate) t: &'a [f64],
    pub(crate) positions: &'a [Vec<f64>],
    pub(crate) readings: &'a [Vec<f64>],
    pub(crate) context: &'a [(String, Vec<f64>)],
}

pub(crate) fn write_csv(path: &Path, table: &Table<'_>) -> std::io::Result<()> {
    let mut s = String::from("t");
    for l in table.letters {
        write!(s, ",{l}").expect("string");
    }
    let names = table
        .channels
        .iter()
        .map(String::as_str)
        .chain(table.labels.columns.iter().copied())
        .chain(table.context.iter().map(|(n, _)| n.as_str()));
    for c in names {
        write!(s, ",{c}").expect("string");
    }
    s.push('\n');
    for (k, ((t, p), r)) in table
        .t
        .iter()
        .zip(table.positions)
        .zip(table.readings)
        .enumerate()
    {
        // `{}` prints the shortest decimal that reads back to the same f64.
        write!(s, "{t}").expect("string");
        for v in p.iter().chain(r) {
            write!(s, ",{v}").expect("string");
        }
        if !table.labels.columns.is_empty() {
            // Names are plain (letters, digits, `_ - . /`): no quoting needed.
            write!(s, ",{}", table.labels.values[k]).expect("string");
        }
        for (_, values) in table.context {
            write!(s, ",{}", values[k]).expect("string");
        }
        s.push('\n');
    }
    std::fs::write(path, s)
}

/// `target` relative to the folder `from` (both made absolute first).
pub(crate) fn relative_path(from: &Path, target: &Path) -> std::io::Result<PathBuf> {
    let from = std::fs::canonicalize(from)?;
    let target = std::fs::canonicalize(target)?;
    let a: Vec<Component> = from.components().collect();
    let b: Vec<Component> = target.components().collect();
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..a.len() {
        out.push("..");
    }
    for c in &b[common..] {
        out.push(c.as_os_str());
    }
    Ok(out)
}
