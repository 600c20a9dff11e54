//! An instrument's collision bodies as the test planner (`mtcal-plan`) checks them against the
//! machine's: plain data, SI. A plugin builds them from its loaded set-up in its
//! [`Planning::bodies`] hook; the planner places them at every planned pose.
//!
//! The planner owns the machine's bodies and the shared sizes of the tool side (the holder up
//! to the gauge point, the stem below it, the table top the posts stand on: [`ToolSide`]); a
//! plugin owns its own bodies and the `[geometry]` sizes they take ([`SizeKey`]), which it
//! declares in [`Planning::sizes`] so that the planner reads and checks them with the rest of
//! the planning file.

use crate::{Setup, SetupError};
use mtcal_kinematics::{Machine, Rigid};
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// A primitive shape in its own frame (SI). Cylinders and capsules run along their local z,
/// centred on the origin, as URDF cylinders do.
#[derive(Clone, Debug, PartialEq)]
pub enum Primitive {
    Box { half: [f64; 3] },
    Cylinder { radius: f64, half_length: f64 },
    Sphere { radius: f64 },
    Capsule { radius: f64, half_length: f64 },
}

/// Where an instrument body is attached.
#[derive(Clone, Debug, PartialEq)]
pub enum Mount {
    /// The tool point of the tooled machine (offset in the tool frame; +z into the spindle).
    Tool,
    /// The workpiece frame.
    Workpiece,
    /// A bar from a point fixed in the workpiece frame to the tool point, shortened by `trim`
    /// (m) at each end.
    Bar { pivot: Vector3<f64>, trim: f64 },
}

/// One body of an instrument or fixture.
#[derive(Clone, Debug, PartialEq)]
pub struct InstrumentBody {
    pub name: String,
    pub mount: Mount,
    /// `mount_T_shape` (unused for a bar).
    pub offset: Rigid,
    pub primitive: Primitive,
    /// Only present at the samples whose label starts with this (an artefact placement).
    pub only_label: Option<String>,
}

/// An instrument's bodies and the pairs of them (by name) that touch by design.
pub type Bodies = (Vec<InstrumentBody>, Vec<(String, String)>);

/// The sizes every instrument's tool side and fixtures share (the planning file's
/// `[geometry]`, read by the planner), m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolSide {
    /// Where fixtures stand: the table top's z in the workpiece frame.
    pub table_z: f64,
    /// The holder: a cylinder from the gauge point down the tool axis.
    pub holder_diameter: f64,
    pub holder_length: f64,
    /// The stem from the instrument's tool-side part up to the holder.
    pub stem_diameter: f64,
}

/// What a `[geometry]` size must be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SizeRule {
    /// A finite number above zero (a diameter, a length).
    Positive,
    /// Any finite number (an offset, a gap, a margin).
    Finite,
}

/// One key of the planning file's `[geometry]` table that an instrument's bodies take: its
/// name (mm, as written), its default and what it must be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SizeKey {
    pub name: &'static str,
    pub default_mm: f64,
    pub rule: SizeRule,
}

impl SizeKey {
    /// A diameter or length: finite and above zero.
    pub const fn positive(name: &'static str, default_mm: f64) -> Self {
        Self {
            name,
            default_mm,
            rule: SizeRule::Positive,
        }
    }

    /// An offset: any finite number.
    pub const fn finite(name: &'static str, default_mm: f64) -> Self {
        Self {
            name,
            default_mm,
            rule: SizeRule::Finite,
        }
    }

    /// Whether `mm` is a value this key takes; the error says what it must be and what was
    /// found.
    pub fn check(&self, mm: f64) -> Result<(), String> {
        match self.rule {
            SizeRule::Positive if !(mm.is_finite() && mm > 0.0) => {
                Err(format!("must be > 0, found {mm}"))
            }
            SizeRule::Finite if !mm.is_finite() => {
                Err(format!("must be a finite number, found {mm}"))
            }
            _ => Ok(()),
        }
    }
}

/// The `[geometry]` sizes a planning file gives, mm by key (already checked against their
/// [`SizeKey`]s); a key it leaves out takes its default.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sizes {
    given_mm: BTreeMap<String, f64>,
}

impl Sizes {
    pub fn new(given_mm: BTreeMap<String, f64>) -> Self {
        Self { given_mm }
    }

    /// The size of `key`, m: as given, else its default.
    pub fn m(&self, key: &SizeKey) -> f64 {
        self.mm(key) * 1e-3
    }

    /// The size of `key` as written (mm): as given, else its default.
    pub fn mm(&self, key: &SizeKey) -> f64 {
        self.given_mm
            .get(key.name)
            .copied()
            .unwrap_or(key.default_mm)
    }

    /// The sizes given, mm by key.
    pub fn given_mm(&self) -> &BTreeMap<String, f64> {
        &self.given_mm
    }

    /// With `key` given as `mm`.
    pub fn with(mut self, key: &str, mm: f64) -> Self {
        self.given_mm.insert(key.to_string(), mm);
        self
    }
}

/// What an instrument's [`Planning::bodies`] hook gets: the set-up as its plugin loaded it
/// (on the plan's machine, the tool length added) and what the planner knows around it.
#[derive(Clone, Copy, Debug)]
pub struct BodySpec<'a> {
    /// The set-up as the plugin loaded it ([`BodySpec::setup_as`] gives its own type).
    pub setup: &'a dyn Setup,
    /// Its table, with the keys the planner wrote out ([`Planning::written_out`]).
    pub table: &'a toml::Table,
    /// From the gauge point down to the tool point (the ball or probe centre), m.
    pub tool_length: f64,
    /// The machine as loaded (its tool point the gauge point).
    pub machine: &'a Machine,
    pub tool_side: &'a ToolSide,
    /// The `[geometry]` sizes; the plugin reads its own [`Planning::sizes`].
    pub sizes: &'a Sizes,
}

impl BodySpec<'_> {
    /// The set-up as the plugin's own type `T`, or `None` if it is another plugin's.
    pub fn setup_as<T: 'static>(&self) -> Option<&T> {
        let setup: &dyn Setup = self.setup;
        setup.as_any().downcast_ref()
    }

    /// [`BodySpec::setup_as`], or the error a hook returns when handed another plugin's set-up
    /// (a caller's mistake, never the planning file's).
    pub fn own_setup<T: 'static>(&self) -> Result<&T, SetupError> {
        self.setup_as().ok_or_else(|| {
            SetupError::new(
                "instrument",
                "the collision bodies were asked for another instrument's set-up",
            )
        })
    }

    /// The size of `key`, m.
    pub fn size_m(&self, key: &SizeKey) -> f64 {
        self.sizes.m(key)
    }
}

/// A plugin's collision bodies for one set-up ([`Planning::bodies`]); `Ok(None)` when this
/// set-up has none (the planner then checks the machine alone and says so).
pub type BodiesOf = fn(&BodySpec<'_>) -> Result<Option<Bodies>, SetupError>;

/// What the test planner needs from an instrument to place it
/// ([`crate::InstrumentPlugin::planning`]).
#[derive(Clone, Copy, Debug)]
pub struct Planning {
    /// The set-up key a planned position goes into (mm, `[x, y, z]`), when a candidate group
    /// does not say (`position = "…"`); `None`: the group must say.
    pub position_key: Option<&'static str>,
    /// Set-up keys the planner writes out from the loaded set-up ([`crate::SetupFormat::to_toml`])
    /// when the planning file leaves them to their default, so that the plan says what it was
    /// planned and collision-checked for.
    pub written_out: &'static [&'static str],
    /// The `[geometry]` keys the bodies take.
    pub sizes: &'static [SizeKey],
    /// The collision bodies of a set-up; `None`: the instrument has none (only the machine is
    /// checked).
    pub bodies: Option<BodiesOf>,
}

/// A translation.
pub fn at(p: Vector3<f64>) -> Rigid {
    Rigid::translation(p)
}

/// A vertical cylinder (workpiece frame) from `z0` to `z1` at `(x, y)`, m: a post, a nest on
/// the table; `None` if empty.
pub fn column(name: &str, x: f64, y: f64, z0: f64, z1: f64, radius: f64) -> Option<InstrumentBody> {
    (z1 - z0 > 1e-9).then(|| InstrumentBody {
        name: name.into(),
        mount: Mount::Workpiece,
        offset: at(Vector3::new(x, y, 0.5 * (z0 + z1))),
        primitive: Primitive::Cylinder {
            radius,
            half_length: 0.5 * (z1 - z0),
        },
        only_label: None,
    })
}

/// A cylinder on the tool axis from `z0` to `z1` above the tool point, m (a holder, a stem,
/// a nest in the spindle); `None` if empty.
pub fn on_tool_axis(name: &str, z0: f64, z1: f64, radius: f64) -> Option<InstrumentBody> {
    (z1 - z0 > 1e-9).then(|| InstrumentBody {
        name: name.into(),
        mount: Mount::Tool,
        offset: at(Vector3::new(0.0, 0.0, 0.5 * (z0 + z1))),
        primitive: Primitive::Cylinder {
            radius,
            half_length: 0.5 * (z1 - z0),
        },
        only_label: None,
    })
}

/// The common tool side: a ball of `ball_radius` (m) at the tool point, a stem from the ball's
/// top up to the holder, the holder up to the gauge point `tool_length` above the tool point.
pub fn tool_ball_stem_holder(
    ball_name: &str,
    ball_radius: f64,
    tool_length: f64,
    tool: &ToolSide,
) -> Vec<InstrumentBody> {
    let mut out = vec![InstrumentBody {
        name: ball_name.into(),
        mount: Mount::Tool,
        offset: Rigid::IDENTITY,
        primitive: Primitive::Sphere {
            radius: ball_radius,
        },
        only_label: None,
    }];
    let holder_start = (tool_length - tool.holder_length).max(0.0);
    out.extend(on_tool_axis(
        "stem",
        ball_radius,
        holder_start,
        0.5 * tool.stem_diameter,
    ));
    out.extend(on_tool_axis(
        "holder",
        holder_start.max(ball_radius),
        tool_length,
        0.5 * tool.holder_diameter,
    ));
    out
}
