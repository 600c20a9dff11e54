//! The measurement-model trait every mtcal instrument plugin implements, and the registry the
//! plugins put their descriptors in.
//!
//! # How an instrument enters the identification
//! A plugin turns one run's set-up (the `[run.setup]` / `[setup.<name>]` table of the session
//! manifest) into a [`Setup`]: an object that, given the **actual pose of the tool point in the
//! workpiece frame** at one sample, predicts the instrument's readings. The identification core
//! owns the machine: it evaluates the pose with every error parameter inserted, hands it to the
//! set-up, and chains the set-up's derivatives with respect to that pose onto the kinematic
//! Jacobian (`∂reading/∂c = ∂reading/∂pose · ∂pose/∂c`). So a plugin touches machine parameters
//! only through the tool pose: the parameters it touches are exactly those the pose depends on
//! (in the pose components [`Setup::touches`] declares), and every other parameter has a zero
//! Jacobian column for its runs.
//!
//! A set-up also declares its own **nuisance parameters** (ball position, tool length, pivot,
//! bar length…). They are *deviations from the set-up's nominal values*, in SI units, starting
//! at zero; runs sharing a named set-up share them. And it gives a **noise model**: one standard
//! deviation per reading channel, which whitens the residuals so instruments mix fairly.
//!
//! # Conventions
//! - SI inside: m, rad, s. Readings are converted from the file units of [`Channel::unit`]
//!   (µm, µrad) at the edge by the caller.
//! - The pose derivative `d_pose` is with respect to a small *left* perturbation of the tool
//!   pose in the workpiece frame: `t ← t + δt`, `R ← exp([δθ]×)·R`; a point `x = R·o + t` fixed
//!   to the tool moves by `δt + δθ × (R·o)`. Columns `[δt_x, δt_y, δt_z, δθ_x, δθ_y, δθ_z]`.
//!
//! # Adding an instrument
//! Write a crate under `plugins/`, implement [`Setup`] (the measurement model) and
//! [`SetupFormat`] (the set-up as a table; how recordings differ from the model), read the
//! set-up table into a typed config with [`config::read`], submit an [`InstrumentPlugin`] with
//! `inventory::submit!`, name the crate in `mtcal-plugins`, and call the conformance harness
//! (`mtcal-conformance`) from its tests. Read its set-up and path tables with
//! [`config::read`], one typed struct per table. For the test planner to place it and check
//! it for collisions, give the registration a [`collision::Planning`]: the set-up key a
//! position goes into and the instrument's collision bodies (with their `[geometry]` sizes).
//! For the tools that handle runs by what they are (the importers, the volumetric test, the
//! report's polar section), submit its [`capability`] declarations too.

use mtcal_kinematics::{Machine, Rigid};
use std::fmt;

pub mod capability;
pub mod collision;
pub mod config;
pub mod program;

/// The unit a reading or a nuisance parameter is written in outside (files, reports).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unit {
    /// Micrometres; SI value in metres.
    Um,
    /// Microradians; SI value in radians.
    Urad,
    /// Parts per million; SI value dimensionless.
    Ppm,
    /// Millimetres; SI value in metres. For readings that are positions, not deviations (an
    /// artefact's measured feature centres).
    Mm,
}

impl Unit {
    /// Factor from SI to this unit (`value_in_unit = si * factor`).
    pub fn per_si(self) -> f64 {
        match self {
            Unit::Um | Unit::Urad | Unit::Ppm => 1e6,
            Unit::Mm => 1e3,
        }
    }
    pub fn as_str(self) -> &'static str {
        match self {
            Unit::Um => "um",
            Unit::Urad => "urad",
            Unit::Ppm => "ppm",
            Unit::Mm => "mm",
        }
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One reading column of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// The CSV column name (`dx`, `dr`, …).
    pub name: String,
    pub unit: Unit,
    /// Standard deviation of one reading, SI.
    pub sigma: f64,
}

/// A nuisance parameter of a set-up: a deviation from the set-up's nominal value.
#[derive(Clone, Debug, PartialEq)]
pub struct Nuisance {
    /// Short name, unique within the set-up (`ball_x`, `tool_length`, …). The core prefixes it
    /// with the set-up name in reports.
    pub name: String,
    pub unit: Unit,
    /// Estimated by the fit (`true`) or held at zero (calibrated).
    pub free: bool,
    /// Standard deviation of a prior centred on zero, SI; `None` = no prior.
    pub prior_sigma: Option<f64>,
}

/// Which parts of the tool pose a set-up's readings depend on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Touches {
    pub position: bool,
    pub orientation: bool,
}

/// One sample as the set-up sees it.
#[derive(Clone, Copy, Debug)]
pub struct At<'a> {
    /// Commanded axis positions, SI, in the machine's axis order.
    pub q: &'a [f64],
    /// Time since the session started, s.
    pub t: f64,
    /// Actual pose of the tool point in the workpiece frame (`w_T_t`), errors inserted.
    pub w_t_t: &'a Rigid,
    /// The sample's label as [`SetupFormat::resolve_label`] numbered it (which artefact feature was
    /// probed, say); 0 for an instrument without [`SetupFormat::label_columns`].
    pub label: u32,
}

/// One run's samples as [`SetupFormat::prepare_readings`] sees them.
#[derive(Clone, Copy, Debug)]
pub struct RunData<'a> {
    /// Commanded positions, SI, row-major `samples × axes` (the machine's axis order).
    pub q: &'a [f64],
    /// Time of each sample, s.
    pub t: &'a [f64],
    /// The run's context columns (`T_<name>` °C, `P_<name>` hPa, `H_<name>` %, `S`, `F`) by
    /// name, as written in the file (not SI).
    pub context: &'a [(String, Vec<f64>)],
}

impl RunData<'_> {
    /// The context column called `name`.
    pub fn context(&self, name: &str) -> Option<&[f64]> {
        self.context
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

/// Why a run's readings could not be prepared: which sample (0-based, in file order) and which
/// column, and what was expected. The core adds the file and its line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("column `{column}`: {message}")]
pub struct ReadingError {
    /// The sample, when one sample is at fault.
    pub row: Option<usize>,
    pub column: String,
    pub message: String,
}

/// Why a sample's label values name nothing the set-up has ([`SetupFormat::resolve_label`]);
/// the message says what was expected (the known features, say). The core adds the file, line
/// and column.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct LabelError {
    /// The label as written.
    pub value: String,
    pub message: String,
}

/// A loaded set-up seen as its own type: how a plugin's evaluation, diagnosis and view reach
/// the set-up it loaded ([`Evaluation::setup_as`]) instead of reading its table again. Every
/// `'static` type has it; nothing to implement.
pub trait AsAny: std::any::Any {
    fn as_any(&self) -> &dyn std::any::Any;
}

impl<T: std::any::Any> AsAny for T {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// A loaded set-up of one instrument: its measurement model for one or more runs — what it
/// reads and with what noise, which parameters of its own it has, and the readings it predicts
/// from the tool pose. How its files differ from that model is its [`SetupFormat`].
///
/// Object safe; the core holds `Box<dyn Setup>`. Implementations must not allocate in
/// [`Setup::predict`] or [`Setup::derivatives`]: they run once per sample.
pub trait Setup: SetupFormat + AsAny + fmt::Debug + Send + Sync {
    /// The reading channels, in the order `predict` writes them.
    fn channels(&self) -> &[Channel];

    /// The nuisance parameters, in the order `predict` reads them.
    fn nuisance(&self) -> &[Nuisance];

    /// Which parts of the tool pose the readings depend on.
    fn touches(&self) -> Touches {
        Touches {
            position: true,
            orientation: true,
        }
    }

    /// Whether reading channel `channel` depends on the tool pose at all. A channel that does
    /// not (a displacement sensor whose direction is unknown, say) is modelled on its own: the
    /// physics search gives it effects of its own (drift, temperature coupling) instead of
    /// effects through the machine's axes.
    fn reads_pose(&self, channel: usize) -> bool {
        let _ = channel;
        true
    }

    /// Whether the instrument's readings are taken with the axes standing at their targets (a
    /// laser's positioning and straightness runs, ISO 230-2; a tracer's or a probe's points):
    /// then no reading sees the axes' velocity, and the physics search proposes no effect of
    /// it there — a step between targets over the time between two readings is no velocity.
    /// `false` (the default) for an instrument that may read on the fly (a ball bar, an R-test
    /// following the ball).
    fn reads_at_standstill(&self) -> bool {
        false
    }

    /// Predicted readings (SI) at one sample, for nuisance values `nuis` (SI deviations).
    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]);

    /// Analytic derivatives of the predicted readings: `d_pose` is `channels × 6` row-major
    /// with respect to the left pose perturbation (module docs), `d_nuis` is
    /// `channels × nuisance` row-major. Return `false` (the default) if not implemented; the
    /// core then uses central finite differences.
    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let _ = (at, nuis, d_pose, d_nuis);
        false
    }
}

/// The file side of a set-up: the set-up as a manifest table, and how the instrument's
/// recordings differ from what [`Setup::predict`] models (readings as recorded, label columns,
/// a measuring range). Everything but [`SetupFormat::to_toml`] has a default that suits an
/// instrument whose recordings are the modelled readings.
pub trait SetupFormat {
    /// The set-up as a manifest table: loading it again gives an equal set-up.
    fn to_toml(&self) -> toml::Table;

    /// Text columns every sample of this set-up's runs carries besides the readings (an
    /// artefact's `feature`): the core reads them and asks [`SetupFormat::resolve_label`] for the
    /// number it then passes in [`At::label`]. Empty (the default) for most instruments.
    fn label_columns(&self) -> &[&'static str] {
        &[]
    }

    /// The number of a sample's labels (`values` in the order of [`SetupFormat::label_columns`]);
    /// an error says what was expected (the known features, say).
    fn resolve_label(&self, values: &[&str]) -> Result<u32, LabelError> {
        let _ = values;
        Ok(0)
    }

    /// Turns one run's readings as recorded (SI, row-major `samples × channels`) into the
    /// readings [`Setup::predict`] models, before any fit: environmental compensation of a
    /// laser (air refractive index, material temperature), say. The default keeps them.
    fn prepare_readings(
        &self,
        run: &RunData<'_>,
        readings: &mut [f64],
    ) -> Result<(), ReadingError> {
        let _ = (run, readings);
        Ok(())
    }

    /// The inverse of [`SetupFormat::prepare_readings`]: turns modelled readings (SI, row-major)
    /// into readings as the instrument would record them, for files mtcal writes (simulated
    /// runs, predictions of validation runs): `prepare_readings(record_readings(r)) = r`.
    fn record_readings(&self, run: &RunData<'_>, readings: &mut [f64]) -> Result<(), ReadingError> {
        let _ = (run, readings);
        Ok(())
    }

    /// The measuring range of reading channel `channel`: the largest magnitude (SI) of a
    /// reading as recorded that the instrument can report, or `None` (the default) when it has
    /// no fixed range. The core rejects a run file whose readings lie beyond it, naming the
    /// cell (a reading 1000 times too large, nm where µm are expected, is caught here).
    fn reading_range(&self, channel: usize) -> Option<f64> {
        let _ = channel;
        None
    }
}

/// What the loader needs to know besides the table.
#[derive(Clone, Copy, Debug)]
pub struct SetupContext<'a> {
    pub machine: &'a Machine,
}

/// Why a set-up table was rejected: the offending key and what was expected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("setup key `{key}`: {message}")]
pub struct SetupError {
    pub key: String,
    pub message: String,
}

impl SetupError {
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
        }
    }
}

/// A test set-up and the axis positions to measure it at: what a plugin offers the
/// conformance harness and the property tests for a given machine.
#[derive(Clone, Debug)]
pub struct Fixture {
    pub setup: toml::Table,
    /// Axis positions, SI, one `Vec` per sample.
    pub poses: Vec<Vec<f64>>,
    /// Each sample's label values (see [`SetupFormat::label_columns`]); empty when the instrument
    /// has no label columns.
    pub labels: Vec<Vec<String>>,
}

/// A named measuring path: commanded axis positions for a set-up on a machine.
#[derive(Clone, Debug)]
pub struct PathSpec<'a> {
    /// The run's `path` table from a test plan (plugin-specific keys, e.g. `kind = "xyc"`).
    pub path: &'a toml::Table,
    /// The set-up the path is for, as the plugin loaded it on `machine`
    /// ([`PathSpec::own_setup`] gives its own type).
    pub setup: &'a dyn Setup,
    pub machine: &'a Machine,
}

impl<'a> PathSpec<'a> {
    /// The set-up as the plugin's own type `T`, or the error a path function returns when
    /// handed another plugin's set-up (a caller's mistake, never the plan's).
    pub fn own_setup<T: 'static>(&self) -> Result<&'a T, SetupError> {
        let setup: &'a dyn Setup = self.setup;
        setup.as_any().downcast_ref().ok_or_else(|| {
            SetupError::new(
                "instrument",
                "the path was asked for another instrument's set-up",
            )
        })
    }
}

/// The label values of each sample of a measuring path (see [`SetupFormat::label_columns`]).
pub type PathLabels = fn(&PathSpec<'_>) -> Result<Vec<Vec<String>>, SetupError>;

/// A plugin's set-up loader: from a manifest table to a [`Setup`].
pub type LoadSetup = fn(&toml::Table, &SetupContext<'_>) -> Result<Box<dyn Setup>, SetupError>;

/// A plugin's diagnosis of groups of its runs ([`InstrumentPlugin::diagnose`]).
pub type Diagnose = fn(&[Evaluation<'_>]) -> Vec<Diagnosis>;

/// The registered descriptor of an instrument plugin.
#[derive(Debug)]
pub struct InstrumentPlugin {
    /// The `instrument` value in session manifests (`rtest`, `ballbar`, …).
    pub name: &'static str,
    /// One line for `mtcal plugins`.
    pub about: &'static str,
    /// Builds a set-up from its manifest table.
    pub load_setup: LoadSetup,
    /// A representative set-up and poses on `machine`, or `None` if the instrument cannot be
    /// used on it. `seed` varies the set-up for property tests.
    pub fixture: fn(&Machine, u64) -> Option<Fixture>,
    /// Commanded positions (SI) of a measuring path, one `Vec` per sample.
    pub path: fn(&PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError>,
    /// The label values of each sample of that path (see [`SetupFormat::label_columns`]), for an
    /// instrument that has label columns; `None` otherwise.
    pub path_labels: Option<PathLabels>,
    /// The instrument's own evaluation of one run (e.g. ISO 230-4 circular deviation), if any.
    pub evaluate: Option<fn(&Evaluation<'_>) -> Vec<Metric>>,
    /// A run drawn as a polar plot (a ball-bar's circle), for the instruments whose runs can
    /// be; `None` for the others. The report draws every run in its common plots whatever
    /// this says; only here does an instrument add its own view.
    pub polar_view: Option<fn(&Evaluation<'_>) -> Option<PolarView>>,
    /// The instrument's own diagnosis of groups of runs in its users' terms (a ball-bar's
    /// backlash, squareness, servo mismatch… per circle pair), each value linear in the
    /// readings so that the caller can say which part of the machine's model stands behind it;
    /// `None` for instruments without one.
    pub diagnose: Option<Diagnose>,
    /// What the test planner needs to place the instrument: the set-up key a planned position
    /// goes into, the keys it writes out, its collision bodies and their `[geometry]` sizes
    /// ([`collision`]); `None` for an instrument the planner only places where a planning file
    /// names the position key, and checks for nothing but the machine.
    pub planning: Option<collision::Planning>,
}

/// One group of runs diagnosed together (a ball-bar's counter-clockwise and clockwise circle in
/// one plane), what [`InstrumentPlugin::diagnose`] returns.
///
/// Every value is linear in the readings once the diagnosis has chosen its templates:
/// `value_k = Σ_runs Σ_samples estimator[run][k·n + s]·reading[s][channel]`. A caller that
/// knows how much of each reading a model's parameter predicts gets, by the same estimator,
/// how much of each diagnostic that parameter accounts for.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnosis {
    /// What the group is about, e.g. the plane `XY`.
    pub subject: String,
    /// Indices (into the evaluations given) of the group's runs.
    pub runs: Vec<usize>,
    /// The channel the estimator reads.
    pub channel: usize,
    /// The peak-to-valley the diagnostics are ranked against (a ball-bar's circularity), SI.
    pub circularity: f64,
    pub items: Vec<Diagnostic>,
    /// Per run of `runs`: row-major `items × samples`, SI value per SI reading.
    pub estimator: Vec<Vec<f64>>,
    /// What the diagnosis could not evaluate and why (a diagnostic left out), for people.
    pub notes: Vec<String>,
}

/// One diagnostic value of a [`Diagnosis`].
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// e.g. `backlash X+`.
    pub name: String,
    /// One line for people: what the value means and its sign.
    pub about: String,
    /// SI (m, dimensionless, s).
    pub value: f64,
    /// The expanded uncertainty (about 95 %), SI.
    pub u95: f64,
    /// Whether the value stands out of the noise with family-wise confidence over the group's
    /// items (a value that does not is reported, but not claimed).
    pub determined: bool,
    /// The peak-to-valley this item alone puts into the group's readings, SI: its
    /// contribution to the circularity.
    pub contribution: f64,
    /// The unit users read it in (`um`, `um/m`, `ms`, `ppm`) and the factor from SI to it.
    pub unit: &'static str,
    pub per_si: f64,
}

/// A run drawn on a circle: one reading channel at each sample's angle (a ball-bar's circular
/// test). What [`InstrumentPlugin::polar_view`] returns; the report adds the readings and the
/// model's predictions of that channel.
#[derive(Clone, Debug, PartialEq)]
pub struct PolarView {
    /// The circle's plane, e.g. `XY`.
    pub plane: String,
    /// The circle's radius, m.
    pub radius: f64,
    /// Each sample's angle on the circle, rad.
    pub angles: Vec<f64>,
    /// The channel drawn: its index among the set-up's channels.
    pub channel: usize,
}

/// One run's data for an instrument's own evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Evaluation<'a> {
    pub machine: &'a Machine,
    /// The run's set-up as the plugin loaded it ([`Evaluation::setup_as`] gives its own type).
    pub setup: &'a dyn Setup,
    /// Commanded positions, SI, row-major `samples × axes`.
    pub q: &'a [f64],
    /// Readings, SI, row-major `samples × channels` (after [`SetupFormat::prepare_readings`]).
    pub readings: &'a [f64],
    pub t: &'a [f64],
    /// Each sample's label number (empty for an instrument without label columns).
    pub labels: &'a [u32],
}

impl Evaluation<'_> {
    /// The run's set-up as the plugin's own type `T`, or `None` if it is another plugin's.
    pub fn setup_as<T: 'static>(&self) -> Option<&T> {
        // Through `&dyn Setup`: the loaded set-up's own `as_any`, not that of a reference.
        let setup: &dyn Setup = self.setup;
        setup.as_any().downcast_ref()
    }
}

/// A named number an instrument's evaluation reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Metric {
    /// e.g. `circular deviation G (ISO 230-4)`.
    pub name: String,
    /// SI.
    pub value: f64,
    pub unit: Unit,
    /// The expanded uncertainty `U = k·u` of `value` with coverage factor `k = 2` (about 95 %),
    /// SI, from the instrument's own uncertainty budget (its crate doc says which terms);
    /// `None` when the instrument gives none (acceptance then falls back to the simple rule).
    pub u95: Option<f64>,
    /// What the value is about, for acceptance against a standard's tolerances: the axis
    /// letter of an ISO 230-2 evaluation (`X`), the plane of an ISO 230-4 circle (`XY`);
    /// `None` when it is about nothing a tolerance names (a diagonal, a plate).
    pub subject: Option<String>,
}

impl Metric {
    /// A metric without uncertainty or subject.
    pub fn new(name: impl Into<String>, value: f64, unit: Unit) -> Self {
        Self {
            name: name.into(),
            value,
            unit,
            u95: None,
            subject: None,
        }
    }

    /// With the expanded uncertainty `u95` (k = 2, SI).
    pub fn with_u95(mut self, u95: f64) -> Self {
        self.u95 = Some(u95);
        self
    }

    /// About `subject` (an axis letter, a plane).
    pub fn about(mut self, subject: impl Into<String>) -> Self {
        self.subject = Some(subject.into());
        self
    }
}

inventory::collect!(InstrumentPlugin);

/// Every registered plugin, sorted by name. Only plugins whose crates the final binary links
/// are here: `mtcal-plugins` names them all.
pub fn plugins() -> Vec<&'static InstrumentPlugin> {
    let mut all: Vec<_> = inventory::iter::<InstrumentPlugin>.into_iter().collect();
    all.sort_by_key(|p| p.name);
    all
}

/// The plugin registered under `name`.
pub fn find(name: &str) -> Option<&'static InstrumentPlugin> {
    inventory::iter::<InstrumentPlugin>
        .into_iter()
        .find(|p| p.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_scale_si_to_micro() {
        assert_eq!(Unit::Um.per_si(), 1e6);
        assert_eq!(Unit::Urad.to_string(), "urad");
    }
}
