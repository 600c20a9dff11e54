//! The conformance harness every mtcal instrument plugin must pass.
//!
//! A plugin's tests call [`check_plugin`] with its registered name:
//!
//! ```no_run
//! // in plugins/<name>/tests/conformance.rs
//! #[test]
//! fn conformance() {
//!     mtcal_conformance::check_plugin("rtest", 8);
//! }
//! ```
//!
//! For every shipped machine (`machines/*.urdf`, [`shipped_machines`]) and every seed
//! `0..cases`, the harness asks the plugin for a [`Fixture`] and, when it gets one, checks:
//!
//! 1. **fixture** — the poses are non-empty, one finite position per axis, within the axis
//!    limits, and the same seed gives the same fixture again;
//! 2. **load** — the fixture's set-up table loads;
//! 3. **sizes** — channels are non-empty with unique names and finite positive `sigma`;
//!    nuisance names are unique, priors finite and positive; `predict` writes every one of the
//!    `channels().len()` values (the buffer is pre-filled with NaN) and they are finite;
//!    `derivatives` fills its `channels × 6` and `channels × nuisance` buffers when it returns
//!    `true`;
//! 4. **zero residual** — *the fixture's poses are zero-reading poses*: on the nominal machine
//!    (`w_T_t = machine.tool_in_workpiece(q)`) with every nuisance at zero, every predicted
//!    reading is 0 within [`ZERO_TOL`] (SI). A plugin builds its fixture poses with its own
//!    `path` function on its documented ideal path (the R-test following the ball, the ball-bar
//!    on the circle of radius = bar length), so this checks model and path against each other;
//! 5. **jacobian** — the analytic derivatives equal central finite differences (step
//!    [`FD_STEP`]) over the left pose perturbation (`t ← t + h·eᵢ`, `R ← exp(h·[eⱼ]×)·R`) and
//!    over each nuisance parameter, at poses near the fixture's (±1 mm, ±1 mrad) with random
//!    nonzero nuisance values (±100 µm, ±100 µrad, ±100 ppm); the tolerance is
//!    `FD_REL·max(|analytic|, |difference quotient|) + FD_ABS + 8·ε·(|t| + 1 m)/h`, the last
//!    term bounding the rounding noise of a difference quotient of readings computed from
//!    positions of size `|t|`. Pose components the set-up does not [`touch`](mtcal_instrument::Touches)
//!    must have zero columns. A plugin whose `derivatives` returns `false` (the core then uses
//!    finite differences itself) skips this check; [`Report::without_analytic`] counts those;
//! 6. **round trip** — `load_setup(to_toml())` loads, its `to_toml()` is equal, the table
//!    survives TOML text, and the reloaded set-up has equal channels and nuisance parameters
//!    and predicts bit for bit the same readings;
//! 7. **rejection** — an unknown key, and a malformed value for each key of the set-up table
//!    (a string where something else is expected, an array of booleans where a string is),
//!    are rejected with a [`SetupError`] naming that key.
//!
//! Failures panic (or, from [`try_check_plugin`], return a [`Failure`]) naming the plugin,
//! machine, seed, check, channel and column, and the numbers.

use mtcal_instrument::{At, Fixture, InstrumentPlugin, Setup, SetupContext, SetupError};
use mtcal_kinematics::rigid::exp_so3;
use mtcal_kinematics::{Machine, Rigid};
use nalgebra::Vector3;
use std::fmt;
use std::path::{Path, PathBuf};

/// Largest reading (SI: m, rad) accepted as zero on a fixture pose of the nominal machine.
pub const ZERO_TOL: f64 = 1e-12;
/// Finite-difference step (SI) for the Jacobian check.
pub const FD_STEP: f64 = 1e-7;
/// Relative tolerance of the Jacobian check.
pub const FD_REL: f64 = 1e-6;
/// Absolute tolerance of the Jacobian check.
pub const FD_ABS: f64 = 1e-12;
/// Poses of each fixture at which the Jacobian is checked.
const JACOBIAN_SAMPLES: usize = 4;
/// The key the rejection check adds.
const UNKNOWN_KEY: &str = "conformance_unknown_key";
const POSE_COLUMNS: [&str; 6] = ["δt_x", "δt_y", "δt_z", "δθ_x", "δθ_y", "δθ_z"];

/// The folder of shipped machines (`machines/` at the repository root).
pub fn machines_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../machines")
}

/// Every shipped machine (`machines/*.urdf` in the repository), name (the file stem) and
/// nominal [`Machine`], sorted by name. Panics if one fails to load: they are part of the
/// repository.
pub fn shipped_machines() -> Vec<(String, Machine)> {
    let dir = machines_dir();
    let entries = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list the shipped machines in {}: {e}", dir.display()));
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "urdf"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let name = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let arg = p.to_string_lossy();
            let loaded =
                mtcal_machine::load_machine(&arg, mtcal_machine::topology::Reading::default())
                    .unwrap_or_else(|e| {
                        panic!("shipped machine {} does not load: {e}", p.display())
                    });
            (name, loaded.machine)
        })
        .collect()
}

/// Why a plugin failed the harness.
#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    pub plugin: String,
    /// The shipped machine, if the failure is about one.
    pub machine: Option<String>,
    /// The fixture seed, if the failure is about one.
    pub seed: Option<u64>,
    /// `registered`, `fixture`, `load`, `sizes`, `zero residual`, `jacobian`, `round trip`,
    /// `rejection`.
    pub check: &'static str,
    /// What was wrong: channel, column and numbers.
    pub detail: String,
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "conformance: plugin `{}`", self.plugin)?;
        if let Some(m) = &self.machine {
            write!(f, ", machine `{m}`")?;
        }
        if let Some(s) = self.seed {
            write!(f, ", seed {s}")?;
        }
        write!(f, ", check `{}` failed: {}", self.check, self.detail)
    }
}

impl std::error::Error for Failure {}

/// What the harness checked.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Report {
    /// Shipped machines on which the plugin offered a fixture.
    pub machines: Vec<String>,
    /// Fixtures checked (machines × seeds).
    pub fixtures: usize,
    /// Fixtures whose set-up gave no analytic derivatives (Jacobian check skipped).
    pub without_analytic: usize,
}

/// Runs every check on the plugin registered as `name` over the shipped machines on which it
/// offers a fixture, seeds `0..cases` each. Panics with a message naming the plugin, machine,
/// seed, check, channel/column and the numbers: call it from a `#[test]`.
pub fn check_plugin(name: &str, cases: u64) {
    if let Err(f) = try_check_plugin(name, cases) {
        panic!("{f}");
    }
}

/// [`check_plugin`] returning the first failure instead of panicking.
pub fn try_check_plugin(name: &str, cases: u64) -> Result<Report, Failure> {
    let plugin = mtcal_instrument::find(name).ok_or_else(|| {
        let known: Vec<&str> = mtcal_instrument::plugins().iter().map(|p| p.name).collect();
        Failure {
            plugin: name.to_string(),
            machine: None,
            seed: None,
            check: "registered",
            detail: format!(
                "no plugin is registered under this name; registered: [{}] (is the plugin \
                 crate linked into this test binary?)",
                known.join(", ")
            ),
        }
    })?;
    try_check_on(plugin, &shipped_machines(), cases)
}

/// The checks of [`try_check_plugin`] for a plugin descriptor on given machines.
pub fn try_check_on(
    plugin: &InstrumentPlugin,
    machines: &[(String, Machine)],
    cases: u64,
) -> Result<Report, Failure> {
    let mut report = Report::default();
    for (mname, machine) in machines {
        let mut offered = false;
        for seed in 0..cases {
            let Some(fixture) = (plugin.fixture)(machine, seed) else {
                continue;
            };
            offered = true;
            let again = (plugin.fixture)(machine, seed);
            let same = again
                .as_ref()
                .is_some_and(|g| g.setup == fixture.setup && g.poses == fixture.poses);
            if !same {
                return Err(Failure {
                    plugin: plugin.name.to_string(),
                    machine: Some(mname.clone()),
                    seed: Some(seed),
                    check: "fixture",
                    detail: "the same seed gave a different fixture the second time".into(),
                });
            }
            let analytic = check_fixture(plugin, mname, machine, seed, &fixture)?;
            report.fixtures += 1;
            if !analytic {
                report.without_analytic += 1;
            }
        }
        if offered {
            report.machines.push(mname.clone());
        }
    }
    if report.machines.is_empty() {
        let names: Vec<&str> = machines.iter().map(|(n, _)| n.as_str()).collect();
        return Err(Failure {
            plugin: plugin.name.to_string(),
            machine: None,
            seed: None,
            check: "fixture",
            detail: format!(
                "the plugin offers a fixture on none of the machines [{}] (seeds 0..{cases})",
                names.join(", ")
            ),
        });
    }
    Ok(report)
}

/// Runs checks 1–7 on one fixture. Returns whether the set-up has analytic derivatives.
pub fn check_fixture(
    plugin: &InstrumentPlugin,
    machine_name: &str,
    machine: &Machine,
    seed: u64,
    fixture: &Fixture,
) -> Result<bool, Failure> {
    let fail = |(check, detail): (&'static str, String)| Failure {
        plugin: plugin.name.to_string(),
        machine: Some(machine_name.to_string()),
        seed: Some(seed),
        check,
        detail,
    };
    let run = || -> Result<bool, (&'static str, String)> {
        check_poses(machine, fixture)?;
        let ctx = SetupContext { machine };
        let setup = (plugin.load_setup)(&fixture.setup, &ctx).map_err(|e| {
            (
                "load",
                format!(
                    "the fixture's set-up {} was rejected: {e}",
                    show(&fixture.setup)
                ),
            )
        })?;
        let mut rng = SplitMix::new(seed ^ fnv(machine_name) ^ fnv(plugin.name));
        let analytic = check_sizes(machine, fixture, setup.as_ref(), &mut rng)?;
        check_zero(machine, fixture, setup.as_ref())?;
        if analytic {
            check_jacobian(machine, fixture, setup.as_ref(), &mut rng)?;
        }
        check_round_trip(plugin, machine, fixture, setup.as_ref(), &mut rng)?;
        check_rejection(plugin, machine, fixture, setup.as_ref())?;
        Ok(analytic)
    };
    run().map_err(fail)
}

type Check<T = ()> = Result<T, (&'static str, String)>;

fn check_poses(machine: &Machine, fixture: &Fixture) -> Check {
    let err = |d: String| ("fixture", d);
    if fixture.poses.is_empty() {
        return Err(err("the fixture has no poses".into()));
    }
    for (k, q) in fixture.poses.iter().enumerate() {
        if q.len() != machine.n_axes() {
            return Err(err(format!(
                "pose {k} has {} positions, the machine has {} axes ({})",
                q.len(),
                machine.n_axes(),
                machine.letters()
            )));
        }
        if !q.iter().all(|v| v.is_finite()) {
            return Err(err(format!("pose {k} is not finite: {q:?}")));
        }
        if !machine.within_limits(q, 1e-9) {
            return Err(err(format!(
                "pose {k} {q:?} is outside the axis limits of {}",
                machine.letters()
            )));
        }
    }
    Ok(())
}

/// A fixture with label columns gives one set of label values per pose, each resolving; one
/// without gives none.
fn check_labels(fixture: &Fixture, setup: &dyn Setup) -> Result<(), String> {
    let columns = setup.label_columns();
    if columns.is_empty() {
        if !fixture.labels.is_empty() {
            return Err("the fixture has labels but the set-up declares no label columns".into());
        }
        return Ok(());
    }
    if fixture.labels.len() != fixture.poses.len() {
        return Err(format!(
            "the set-up has label columns {columns:?}: the fixture needs one set of labels per              pose ({} poses, {} label sets)",
            fixture.poses.len(),
            fixture.labels.len()
        ));
    }
    for (k, values) in fixture.labels.iter().enumerate() {
        if values.len() != columns.len() {
            return Err(format!(
                "fixture pose {k} has {} label values for the columns {columns:?}",
                values.len()
            ));
        }
        let refs: Vec<&str> = values.iter().map(String::as_str).collect();
        setup
            .resolve_label(&refs)
            .map_err(|e| format!("fixture pose {k}'s labels {values:?} do not resolve: {e}"))?;
    }
    Ok(())
}

/// Pose `k`'s label number (0 without label columns; [`check_labels`] has run before).
fn label_of(fixture: &Fixture, setup: &dyn Setup, k: usize) -> u32 {
    fixture.labels.get(k).map_or(0, |values| {
        let refs: Vec<&str> = values.iter().map(String::as_str).collect();
        setup.resolve_label(&refs).unwrap_or(0)
    })
}

/// A random nonzero nuisance value of ±(20…100) µm / µrad / ppm, SI.
fn random_nuisance(setup: &dyn Setup, rng: &mut SplitMix) -> Vec<f64> {
    setup
        .nuisance()
        .iter()
        .map(|n| {
            // 100 µm, 100 µrad or 100 ppm.
            let scale = 100.0 / n.unit.per_si();
            let mag = 0.2 + 0.8 * rng.unit();
            let sign = if rng.unit() < 0.5 { -1.0 } else { 1.0 };
            sign * mag * scale
        })
        .collect()
}

fn check_sizes(
    machine: &Machine,
    fixture: &Fixture,
    setup: &dyn Setup,
    rng: &mut SplitMix,
) -> Check<bool> {
    let err = |d: String| ("sizes", d);
    let channels = setup.channels();
    if channels.is_empty() {
        return Err(err("the set-up declares no reading channels".into()));
    }
    for (i, c) in channels.iter().enumerate() {
        if c.name.is_empty() {
            return Err(err(format!("channel {i} has an empty name")));
        }
        if channels[..i].iter().any(|o| o.name == c.name) {
            return Err(err(format!("channel name `{}` is used twice", c.name)));
        }
        if !(c.sigma.is_finite() && c.sigma > 0.0) {
            return Err(err(format!(
                "channel `{}` has sigma {:e} (SI); it must be finite and positive",
                c.name, c.sigma
            )));
        }
    }
    let nuisance = setup.nuisance();
    for (i, n) in nuisance.iter().enumerate() {
        if n.name.is_empty() {
            return Err(err(format!("nuisance parameter {i} has an empty name")));
        }
        if nuisance[..i].iter().any(|o| o.name == n.name) {
            return Err(err(format!("nuisance name `{}` is used twice", n.name)));
        }
        if let Some(s) = n.prior_sigma {
            if !(s.is_finite() && s > 0.0) {
                return Err(err(format!(
                    "nuisance `{}` has prior sigma {s:e} (SI); it must be finite and positive",
                    n.name
                )));
            }
        }
    }
    let (nc, nn) = (channels.len(), nuisance.len());
    check_labels(fixture, setup).map_err(err)?;
    let q = &fixture.poses[0];
    let pose = machine.tool_in_workpiece(q);
    let at = At {
        q,
        t: 0.0,
        w_t_t: &pose,
        label: label_of(fixture, setup, 0),
    };
    let mut analytic = None;
    for nuis in [vec![0.0; nn], random_nuisance(setup, rng)] {
        let mut out = vec![f64::NAN; nc];
        setup.predict(&at, &nuis, &mut out);
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            return Err(err(format!(
                "predict left channel `{}` (index {i} of {nc}) at {} (not written, or not \
                 finite) at pose 0 with nuisance {nuis:?}",
                channels[i].name, out[i]
            )));
        }
        let mut d_pose = vec![f64::NAN; nc * 6];
        let mut d_nuis = vec![f64::NAN; nc * nn];
        let has = setup.derivatives(&at, &nuis, &mut d_pose, &mut d_nuis);
        if *analytic.get_or_insert(has) != has {
            return Err(err(
                "derivatives returned true for one nuisance vector and false for another".into(),
            ));
        }
        if has {
            if let Some(k) = d_pose.iter().position(|v| !v.is_finite()) {
                return Err(err(format!(
                    "derivatives left d_pose[channel `{}`, column {}] at {} (buffer is \
                     channels × 6 = {nc} × 6)",
                    channels[k / 6].name,
                    POSE_COLUMNS[k % 6],
                    d_pose[k]
                )));
            }
            if let Some(k) = d_nuis.iter().position(|v| !v.is_finite()) {
                return Err(err(format!(
                    "derivatives left d_nuis[channel `{}`, nuisance `{}`] at {} (buffer is \
                     channels × nuisance = {nc} × {nn})",
                    channels[k / nn].name,
                    nuisance[k % nn].name,
                    d_nuis[k]
                )));
            }
        }
    }
    Ok(analytic.unwrap_or(false))
}

fn check_zero(machine: &Machine, fixture: &Fixture, setup: &dyn Setup) -> Check {
    let channels = setup.channels();
    let nuis = vec![0.0; setup.nuisance().len()];
    let mut out = vec![f64::NAN; channels.len()];
    for (k, q) in fixture.poses.iter().enumerate() {
        let pose = machine.tool_in_workpiece(q);
        let at = At {
            q,
            t: k as f64,
            w_t_t: &pose,
            label: label_of(fixture, setup, k),
        };
        out.fill(f64::NAN);
        setup.predict(&at, &nuis, &mut out);
        for (c, &v) in channels.iter().zip(&out) {
            if v.is_nan() || v.abs() > ZERO_TOL {
                return Err((
                    "zero residual",
                    format!(
                        "channel `{}` reads {v:e} SI ({} {}) at fixture pose {k} {q:?} of the \
                         nominal machine with zero nuisance; the fixture's poses must read 0 \
                         (within {ZERO_TOL:e})",
                        c.name,
                        v * c.unit.per_si(),
                        c.unit
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn perturbed(pose: &Rigid, dt: Vector3<f64>, dth: Vector3<f64>) -> Rigid {
    Rigid::new(exp_so3(&dth) * pose.r, pose.t + dt)
}

fn check_jacobian(
    machine: &Machine,
    fixture: &Fixture,
    setup: &dyn Setup,
    rng: &mut SplitMix,
) -> Check {
    let channels = setup.channels();
    let nuisance = setup.nuisance();
    let (nc, nn) = (channels.len(), nuisance.len());
    let touches = setup.touches();
    let n = fixture.poses.len();
    let samples = JACOBIAN_SAMPLES.min(n);
    let h = FD_STEP;
    let mut plus = vec![0.0; nc];
    let mut minus = vec![0.0; nc];
    for j in 0..samples {
        let k = if samples > 1 {
            j * (n - 1) / (samples - 1)
        } else {
            0
        };
        let q = &fixture.poses[k];
        let nominal = machine.tool_in_workpiece(q);
        let dt = Vector3::from_fn(|_, _| (2.0 * rng.unit() - 1.0) * 1e-3);
        let dth = Vector3::from_fn(|_, _| (2.0 * rng.unit() - 1.0) * 1e-3);
        let pose = perturbed(&nominal, dt, dth);
        let nuis = random_nuisance(setup, rng);
        let at = At {
            q,
            t: k as f64,
            w_t_t: &pose,
            label: label_of(fixture, setup, k),
        };
        let mut d_pose = vec![f64::NAN; nc * 6];
        let mut d_nuis = vec![f64::NAN; nc * nn];
        if !setup.derivatives(&at, &nuis, &mut d_pose, &mut d_nuis) {
            return Err((
                "jacobian",
                "derivatives returned false at one pose after returning true at another".into(),
            ));
        }
        // Finite differences, column by column.
        let mut fd_pose = vec![0.0; nc * 6];
        for col in 0..6 {
            let mut e = Vector3::zeros();
            e[col % 3] = h;
            let (p, m) = if col < 3 {
                (
                    perturbed(&pose, e, Vector3::zeros()),
                    perturbed(&pose, -e, Vector3::zeros()),
                )
            } else {
                (
                    perturbed(&pose, Vector3::zeros(), e),
                    perturbed(&pose, Vector3::zeros(), -e),
                )
            };
            setup.predict(&At { w_t_t: &p, ..at }, &nuis, &mut plus);
            setup.predict(&At { w_t_t: &m, ..at }, &nuis, &mut minus);
            for c in 0..nc {
                fd_pose[c * 6 + col] = (plus[c] - minus[c]) / (2.0 * h);
            }
        }
        // Rounding noise of a difference quotient of readings computed from positions of size
        // |t|: a few ulps of |t| (plus 1 m for lever arms) over the step.
        let floor = FD_ABS + 8.0 * f64::EPSILON * (pose.t.norm() + 1.0) / h;
        let mut fd_nuis = vec![0.0; nc * nn];
        let mut shifted = nuis.clone();
        for col in 0..nn {
            shifted[col] = nuis[col] + h;
            setup.predict(&at, &shifted, &mut plus);
            shifted[col] = nuis[col] - h;
            setup.predict(&at, &shifted, &mut minus);
            shifted[col] = nuis[col];
            for c in 0..nc {
                fd_nuis[c * nn + col] = (plus[c] - minus[c]) / (2.0 * h);
            }
        }
        for c in 0..nc {
            let tol = |a: f64, f: f64| FD_REL * a.abs().max(f.abs()) + floor;
            let within = |a: f64, f: f64| (a - f).abs() <= tol(a, f);
            let describe = |what: String, a: f64, f: f64| {
                format!(
                    "channel `{}`, column {what}: analytic {a:.9e}, finite difference {f:.9e}, \
                     |difference| {:.3e} > tolerance {:.3e}, at fixture pose {k} {q:?} perturbed by δt = {:?} m, δθ = {:?} \
                     rad, nuisance {nuis:?}",
                    channels[c].name,
                    (a - f).abs(),
                    tol(a, f),
                    dt.as_slice(),
                    dth.as_slice(),
                )
            };
            for col in 0..6 {
                let (a, f) = (d_pose[c * 6 + col], fd_pose[c * 6 + col]);
                if !within(a, f) {
                    return Err((
                        "jacobian",
                        describe(format!("{} (pose)", POSE_COLUMNS[col]), a, f),
                    ));
                }
                let touched = if col < 3 {
                    touches.position
                } else {
                    touches.orientation
                };
                let zero = within(0.0, f) && within(0.0, a);
                if !touched && !zero {
                    return Err((
                        "jacobian",
                        format!(
                            "{} although the set-up declares it does not touch the {}",
                            describe(format!("{} (pose)", POSE_COLUMNS[col]), a, f),
                            if col < 3 { "position" } else { "orientation" }
                        ),
                    ));
                }
            }
            for col in 0..nn {
                let (a, f) = (d_nuis[c * nn + col], fd_nuis[c * nn + col]);
                if !within(a, f) {
                    return Err((
                        "jacobian",
                        describe(format!("`{}` (nuisance)", nuisance[col].name), a, f),
                    ));
                }
            }
        }
    }
    Ok(())
}

fn check_round_trip(
    plugin: &InstrumentPlugin,
    machine: &Machine,
    fixture: &Fixture,
    setup: &dyn Setup,
    rng: &mut SplitMix,
) -> Check {
    let err = |d: String| ("round trip", d);
    let ctx = SetupContext { machine };
    let t1 = setup.to_toml();
    let again = (plugin.load_setup)(&t1, &ctx).map_err(|e| {
        err(format!(
            "to_toml() gave {} which does not load: {e}",
            show(&t1)
        ))
    })?;
    let t2 = again.to_toml();
    if t1 != t2 {
        return Err(err(format!(
            "to_toml() of the reloaded set-up differs:\n  first:  {}\n  second: {}",
            show(&t1),
            show(&t2)
        )));
    }
    let text = toml::to_string(&t1)
        .map_err(|e| err(format!("to_toml() gave a table TOML cannot write: {e}")))?;
    let parsed: toml::Table = toml::from_str(&text).map_err(|e| {
        err(format!(
            "to_toml() written as TOML does not parse: {e}\n{text}"
        ))
    })?;
    if parsed != t1 {
        return Err(err(format!(
            "to_toml() changes when written as TOML text and read back:\n  table: {}\n  text:  {}",
            show(&t1),
            show(&parsed)
        )));
    }
    if again.channels() != setup.channels() {
        return Err(err(format!(
            "channels differ after reloading: {:?} vs {:?}",
            setup.channels(),
            again.channels()
        )));
    }
    if again.nuisance() != setup.nuisance() {
        return Err(err(format!(
            "nuisance parameters differ after reloading: {:?} vs {:?}",
            setup.nuisance(),
            again.nuisance()
        )));
    }
    if again.touches() != setup.touches() {
        return Err(err("touches() differs after reloading".into()));
    }
    let nc = setup.channels().len();
    let mut a = vec![0.0; nc];
    let mut b = vec![0.0; nc];
    let nuis_sets = [
        vec![0.0; setup.nuisance().len()],
        random_nuisance(setup, rng),
    ];
    for (k, q) in fixture.poses.iter().enumerate() {
        let pose = machine.tool_in_workpiece(q);
        let at = At {
            q,
            t: k as f64,
            w_t_t: &pose,
            label: label_of(fixture, setup, k),
        };
        for nuis in &nuis_sets {
            setup.predict(&at, nuis, &mut a);
            again.predict(&at, nuis, &mut b);
            for c in 0..nc {
                if a[c].to_bits() != b[c].to_bits() {
                    return Err(err(format!(
                        "channel `{}` at fixture pose {k}: the original set-up predicts \
                         {:e}, the reloaded one {:e} (must be equal bit for bit)",
                        setup.channels()[c].name,
                        a[c],
                        b[c]
                    )));
                }
            }
        }
    }
    Ok(())
}

/// A value of a type the key cannot take.
fn malformed(v: &toml::Value) -> toml::Value {
    match v {
        toml::Value::String(_) => toml::Value::Array(vec![toml::Value::Boolean(true)]),
        _ => toml::Value::String("not-a-valid-value".into()),
    }
}

fn names_key(e: &SetupError, key: &str) -> bool {
    e.key == key || e.key.starts_with(&format!("{key}.")) || e.key.starts_with(&format!("{key}["))
}

fn check_rejection(
    plugin: &InstrumentPlugin,
    machine: &Machine,
    fixture: &Fixture,
    setup: &dyn Setup,
) -> Check {
    let err = |d: String| ("rejection", d);
    let ctx = SetupContext { machine };
    let mut t = fixture.setup.clone();
    t.insert(UNKNOWN_KEY.into(), toml::Value::Integer(1));
    match (plugin.load_setup)(&t, &ctx) {
        Ok(_) => {
            return Err(err(format!(
                "the unknown key `{UNKNOWN_KEY}` was accepted in {}",
                show(&t)
            )));
        }
        Err(e) if !names_key(&e, UNKNOWN_KEY) => {
            return Err(err(format!(
                "the unknown key `{UNKNOWN_KEY}` was rejected naming key `{}` instead: {e}",
                e.key
            )));
        }
        Err(_) => {}
    }
    let canonical = setup.to_toml();
    for base in [&fixture.setup, &canonical] {
        for (key, value) in base.iter() {
            let mut t = base.clone();
            let bad = malformed(value);
            t.insert(key.clone(), bad.clone());
            match (plugin.load_setup)(&t, &ctx) {
                Ok(_) => {
                    return Err(err(format!(
                        "key `{key}` = {bad} (was {value}) was accepted in {}",
                        show(&t)
                    )));
                }
                Err(e) if !names_key(&e, key) => {
                    return Err(err(format!(
                        "key `{key}` = {bad} was rejected naming key `{}` instead: {e}",
                        e.key
                    )));
                }
                Err(_) => {}
            }
        }
    }
    Ok(())
}

fn show(t: &toml::Table) -> String {
    let inline: Vec<String> = t.iter().map(|(k, v)| format!("{k} = {v}")).collect();
    format!("{{ {} }}", inline.join(", "))
}

/// FNV-1a of a string: seeds the harness' generator per machine and plugin.
fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// SplitMix64: a small deterministic generator, so failures reproduce from the seed.
#[derive(Debug)]
struct SplitMix(u64);

impl SplitMix {
    fn new(seed: u64) -> Self {
        Self(seed)
    }
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}
