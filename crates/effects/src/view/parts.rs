//! The study's parts as effects see them: the machine's axes, the set-ups, the runs with their
//! columns, the model's parameters, and the inputs an effect can be driven by.

use super::*;

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
            at_standstill: setup.reads_at_standstill(),
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
    /// Whether its readings are taken with the axes standing (`Setup::reads_at_standstill`):
    /// its runs see no velocity.
    pub at_standstill: bool,
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
