//! Which error parameters a machine model includes, and how each is laid out in the coefficient
//! vector.
//!
//! Every parameter is a block of coefficients in one flat `&[f64]` (SI: metres, radians): a
//! component error has one coefficient per basis function, a location or set-up parameter has
//! one. The order is the order of the configuration; nothing depends on it but the layout.

use crate::basis::{Basis, BasisError, Term};
use crate::machine::{AxisKind, Machine};
use crate::names::{Direction, ParamName, Setup};
use std::f64::consts::PI;

/// How a component error is parametrised along its axis, before the model's exclusion rules.
#[derive(Clone, Debug, PartialEq)]
pub enum BasisChoice {
    /// Legendre polynomials up to `degree` over the stroke.
    Legendre { degree: usize },
    /// Piecewise-linear table with `knots` equally spaced knots over the stroke (ends included).
    Table { knots: usize },
    /// Piecewise-linear table at given positions (m or rad).
    TableAt { knots: Vec<f64> },
    /// Clamped cubic B-spline with `n_ctrl` control points over the stroke.
    BSpline { n_ctrl: usize },
    /// Fourier series in angle up to `harmonics` (rotary axes only).
    Fourier { harmonics: usize },
}

impl BasisChoice {
    /// Builds the basis of component `direction` of an axis with stroke `(lo, hi)`, leaving out
    /// what location and set-up parameters already carry (documented in ARCHITECTURE.md):
    /// - translation along the axis' own direction (positioning): no constant (set-up offset);
    /// - translation across it (straightness): no constant and no slope (the slope is the
    ///   squareness / orientation location error); tables and splines pin both ends to zero;
    /// - rotations of a linear axis: everything kept;
    /// - Fourier series of a rotary axis: no constant term (constants of the translations are
    ///   set-up offsets, of the rotation about its own axis `EC0C`, of tilts workpiece set-up).
    pub fn build(
        &self,
        kind: AxisKind,
        own: usize,
        direction: Direction,
        stroke: (f64, f64),
    ) -> Result<Basis, BasisError> {
        let (lo, hi) = stroke;
        let translation = !direction.is_rotation();
        let along = translation && direction.cartesian() == own;
        let across = translation && !along;
        let (min_degree, pin_first, pin_last) = match (kind, along, across) {
            (AxisKind::Rotary, _, _) => (1, true, false),
            (AxisKind::Linear, true, _) => (1, true, false),
            (AxisKind::Linear, _, true) => (2, true, true),
            (AxisKind::Linear, false, false) => (0, false, false),
        };
        match self {
            BasisChoice::Legendre { degree } => Basis::legendre(lo, hi, min_degree, *degree),
            BasisChoice::Table { knots } => {
                let n = (*knots).max(2);
                let k = (0..n)
                    .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
                    .collect();
                Basis::table(k, pin_first, pin_last)
            }
            BasisChoice::TableAt { knots } => Basis::table(knots.clone(), pin_first, pin_last),
            BasisChoice::BSpline { n_ctrl } => Basis::bspline(lo, hi, *n_ctrl, pin_first, pin_last),
            BasisChoice::Fourier { harmonics } => Basis::fourier(1, *harmonics),
        }
    }
}

/// One entry of an error-model configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamConfig {
    pub name: ParamName,
    /// For component errors: how it varies along the axis. Ignored for the others.
    pub basis: Option<Basis>,
}

/// Why a configuration does not fit the machine.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelError {
    #[error("{name}: the machine has no axis {axis} (it has {axes})")]
    NoSuchAxis {
        name: String,
        axis: char,
        axes: String,
    },
    #[error("{name} is configured twice")]
    Duplicate { name: String },
    #[error("{name}: a component error needs a basis")]
    MissingBasis { name: String },
    #[error("{name}: {why}")]
    Impossible { name: String, why: String },
    #[error("{name}: {cause}")]
    Basis { name: String, cause: BasisError },
}

/// What a parameter does in the chain.
#[derive(Clone, Debug, PartialEq)]
pub enum Role {
    /// Component error of axis `axis` (index into `Machine::axes`).
    Component {
        axis: usize,
        direction: Direction,
        basis: Basis,
    },
    /// Location error of axis `axis`.
    Location {
        axis: usize,
        direction: Direction,
    },
    ToolOffset(Direction),
    WorkpieceOffset(Direction),
}

/// A configured parameter and its block in the coefficient vector.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub name: ParamName,
    pub role: Role,
    /// First coefficient of this parameter.
    pub offset: usize,
    /// Number of coefficients.
    pub len: usize,
}

/// The configured error parameters of one machine.
#[derive(Clone, Debug)]
pub struct ErrorModel {
    params: Vec<Param>,
    n_coeffs: usize,
    /// Per axis: parameter index of each component direction.
    components: Vec<[Option<usize>; 6]>,
    /// Per axis: parameter index of each location direction.
    locations: Vec<[Option<usize>; 6]>,
    tool: [Option<usize>; 3],
    workpiece: [Option<usize>; 6],
}

impl ErrorModel {
    /// Checks every entry against the machine and lays out the coefficient vector.
    pub fn new(machine: &Machine, config: &[ParamConfig]) -> Result<Self, ModelError> {
        let n = machine.n_axes();
        let mut model = ErrorModel {
            params: Vec::with_capacity(config.len()),
            n_coeffs: 0,
            components: vec![[None; 6]; n],
            locations: vec![[None; 6]; n],
            tool: [None; 3],
            workpiece: [None; 6],
        };
        for entry in config {
            let (role, len) = resolve(machine, entry)?;
            let idx = model.params.len();
            let slot = model.slot(&role);
            if slot.is_some() {
                return Err(ModelError::Duplicate {
                    name: entry.name.to_string(),
                });
            }
            *slot = Some(idx);
            model.params.push(Param {
                name: entry.name,
                role,
                offset: model.n_coeffs,
                len,
            });
            model.n_coeffs += len;
        }
        Ok(model)
    }

    fn slot(&mut self, role: &Role) -> &mut Option<usize> {
        match *role {
            Role::Component {
                axis, direction, ..
            } => &mut self.components[axis][direction.index()],
            Role::Location { axis, direction } => &mut self.locations[axis][direction.index()],
            Role::ToolOffset(d) => &mut self.tool[d.index()],
            Role::WorkpieceOffset(d) => &mut self.workpiece[d.index()],
        }
    }

    pub fn params(&self) -> &[Param] {
        &self.params
    }

    /// Length of the coefficient vector.
    pub fn n_coeffs(&self) -> usize {
        self.n_coeffs
    }

    pub fn find(&self, name: &ParamName) -> Option<&Param> {
        self.params.iter().find(|p| &p.name == name)
    }

    pub(crate) fn component(&self, axis: usize, d: usize) -> Option<&Param> {
        self.components[axis][d].map(|i| &self.params[i])
    }

    pub(crate) fn location(&self, axis: usize, d: usize) -> Option<&Param> {
        self.locations[axis][d].map(|i| &self.params[i])
    }

    pub(crate) fn tool_offset(&self, d: usize) -> Option<&Param> {
        self.tool[d].map(|i| &self.params[i])
    }

    pub(crate) fn workpiece_offset(&self, d: usize) -> Option<&Param> {
        self.workpiece[d].map(|i| &self.params[i])
    }

    /// The largest basis of any component (scratch size).
    pub fn max_basis_len(&self) -> usize {
        self.params.iter().map(|p| p.len).max().unwrap_or(0)
    }

    /// A label per coefficient: `EXX` for one-coefficient parameters, `EXX.P2` otherwise.
    pub fn coefficient_labels(&self) -> Vec<String> {
        self.coefficient_terms()
            .into_iter()
            .map(|(name, term)| match term {
                Some(term) => format!("{name}.{term}"),
                None => name.to_string(),
            })
            .collect()
    }

    /// Per coefficient, its parameter and its basis function (`P2`, `C1`, `K3`), `None` for a
    /// parameter of one coefficient: what a coefficient is, wherever it sits (a component given
    /// more orders keeps its coefficients' terms).
    pub fn coefficient_terms(&self) -> Vec<(ParamName, Option<Term>)> {
        let mut out = Vec::with_capacity(self.n_coeffs);
        for p in &self.params {
            match &p.role {
                Role::Component { basis, .. } => {
                    out.extend(basis.terms().into_iter().map(|t| (p.name, Some(t))));
                }
                _ => out.push((p.name, None)),
            }
        }
        out
    }
}

/// The stroke of an axis for its bases: its limits, or one turn for an unlimited rotary axis.
pub fn default_stroke(machine: &Machine, axis: usize) -> (f64, f64) {
    machine.axes()[axis].limits().unwrap_or((-PI, PI))
}

fn resolve(machine: &Machine, entry: &ParamConfig) -> Result<(Role, usize), ModelError> {
    let name = entry.name;
    let text = name.to_string();
    let impossible = |why: &str| ModelError::Impossible {
        name: text.clone(),
        why: why.to_string(),
    };
    let axis_of = |letter: char| {
        machine
            .axis_index(letter)
            .ok_or_else(|| ModelError::NoSuchAxis {
                name: text.clone(),
                axis: letter,
                axes: machine.letters(),
            })
    };
    match name {
        ParamName::Component { direction, axis } => {
            let a = axis_of(axis.as_char())?;
            let basis = entry
                .basis
                .clone()
                .ok_or_else(|| ModelError::MissingBasis { name: text.clone() })?;
            basis.validate().map_err(|source| ModelError::Basis {
                name: text.clone(),
                cause: source,
            })?;
            if matches!(basis, Basis::Fourier { .. })
                && machine.axes()[a].kind() == AxisKind::Linear
            {
                return Err(impossible(
                    "a Fourier series in angle needs a rotary axis; use legendre, table or bspline",
                ));
            }
            let len = basis.len();
            Ok((
                Role::Component {
                    axis: a,
                    direction,
                    basis,
                },
                len,
            ))
        }
        ParamName::Location { direction, axis } => {
            let a = axis_of(axis.as_char())?;
            let ax = &machine.axes()[a];
            if ax.kind() == AxisKind::Linear {
                if !direction.is_rotation() {
                    return Err(impossible(
                        "a linear axis has no translational location error; a constant offset \
                         belongs to the set-up (WP_DX.., TOOL_DX..)",
                    ));
                }
                if direction.cartesian() == ax.own_cartesian() {
                    return Err(impossible(
                        "a rotation of a linear axis about its own direction does not change its \
                         motion; use the roll component error instead",
                    ));
                }
            }
            Ok((Role::Location { axis: a, direction }, 1))
        }
        ParamName::Setup(Setup::Tool(d)) => {
            if d.is_rotation() {
                return Err(impossible("the tool point has no orientation offset"));
            }
            Ok((Role::ToolOffset(d), 1))
        }
        ParamName::Setup(Setup::Workpiece(d)) => Ok((Role::WorkpieceOffset(d), 1)),
    }
}

/// The ISO location errors of a machine: for every rotary axis the two positions and two
/// orientations across its own direction (4 per axis, e.g. EX0C EY0C EA0C EB0C), and the
/// squareness errors of the linear axes X, Y, Z that exist (EC0Y, EB0Z, EA0Z).
pub fn iso_location_names(machine: &Machine) -> Vec<ParamName> {
    let mut out = Vec::new();
    let has = |c: char| machine.axis_index(c).is_some();
    for (d, a, needs) in [
        (Direction::C, 'Y', 'X'),
        (Direction::B, 'Z', 'X'),
        (Direction::A, 'Z', 'Y'),
    ] {
        if has(a) && has(needs) {
            out.push(ParamName::location(
                d,
                machine.axes()[machine.axis_index(a).unwrap()].letter(),
            ));
        }
    }
    for ax in machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Rotary)
    {
        let own = ax.own_cartesian();
        for rotation in [false, true] {
            for c in (0..3).filter(|&c| c != own) {
                out.push(ParamName::location(
                    Direction::from_parts(rotation, c),
                    ax.letter(),
                ));
            }
        }
    }
    out
}

/// The full ISO 230-1 model: six component errors per axis with the given bases, the ISO
/// location errors ([`iso_location_names`]). For the five-axis machines of the sources this is
/// the 41-error model (30 + 3 + 8); for a 3-axis machine the 21-error model.
pub fn iso_full_config(
    machine: &Machine,
    linear: &BasisChoice,
    rotary: &BasisChoice,
) -> Result<Vec<ParamConfig>, ModelError> {
    let mut out = Vec::new();
    for (i, ax) in machine.axes().iter().enumerate() {
        let choice = match ax.kind() {
            AxisKind::Linear => linear,
            AxisKind::Rotary => rotary,
        };
        for d in Direction::ALL {
            let name = ParamName::component(d, ax.letter());
            let basis = choice
                .build(ax.kind(), ax.own_cartesian(), d, default_stroke(machine, i))
                .map_err(|source| ModelError::Basis {
                    name: name.to_string(),
                    cause: source,
                })?;
            out.push(ParamConfig {
                name,
                basis: Some(basis),
            });
        }
    }
    out.extend(
        iso_location_names(machine)
            .into_iter()
            .map(|name| ParamConfig { name, basis: None }),
    );
    Ok(out)
}
