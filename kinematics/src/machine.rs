//! The nominal machine: two serial branches from the machine frame, one to the workpiece and one
//! to the tool point, with prismatic and revolute axes named by their letters.
//!
//! A [`Machine`] is built once (from a URDF, a topology code or by hand through [`MachineSpec`]),
//! validated in its constructor and never mutated afterwards. Everything is SI: metres, radians.
//!
//! Conventions (see ARCHITECTURE.md, "Conventions"):
//! - Axis positions follow the CNC convention: a positive command moves the tool relative to the
//!   workpiece in the positive direction. An axis that carries the workpiece therefore moves its
//!   body the other way, which its URDF joint axis says (e.g. `xyz="-1 0 0"` for an X table).
//! - The tool axis is the tool link's +z, pointing from the tool point into the spindle.

use crate::names::AxisLetter;
use crate::rigid::{Rigid, axis_rotation};
use nalgebra::{Isometry3, Matrix3, Unit, Vector3};

/// Prismatic (linear) or revolute (rotary) axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    Linear,
    Rotary,
}

impl AxisKind {
    /// A position from SI (m, rad) to file units (mm, °). Every writer converts with this one
    /// expression, so a value read back with [`Self::from_file`] is the same everywhere.
    pub fn to_file(self, si: f64) -> f64 {
        match self {
            AxisKind::Linear => si * 1e3,
            AxisKind::Rotary => si.to_degrees(),
        }
    }

    /// A position from file units (mm, °) to SI (m, rad), as every reader converts it.
    pub fn from_file(self, value: f64) -> f64 {
        match self {
            AxisKind::Linear => value * 1e-3,
            AxisKind::Rotary => value.to_radians(),
        }
    }
}

/// Which branch of the machine an axis sits in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Side {
    /// Between the machine frame and the workpiece (tables, saddles, trunnions).
    Workpiece,
    /// Between the machine frame and the tool point (columns, rams, heads).
    Tool,
}

/// One moving joint as the user describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct JointSpec {
    /// Axis letter, e.g. 'X' or 'C'.
    pub letter: char,
    pub kind: AxisKind,
    /// Pose of the joint frame at zero position in the previous joint's frame (or the machine
    /// frame for the first joint of a branch): `prev_T_joint`.
    pub origin: Isometry3<f64>,
    /// Direction of motion (linear) or rotation (rotary) in the joint frame; need not be unit.
    pub axis: Vector3<f64>,
    /// Travel limits in m or rad; `None` for an unlimited rotary axis (URDF `continuous`).
    pub limits: Option<(f64, f64)>,
}

/// One branch: joints from the machine frame outwards, then the fixed end transform.
#[derive(Clone, Debug, PartialEq)]
pub struct BranchSpec {
    pub joints: Vec<JointSpec>,
    /// `last_joint_T_end` (or `frame_T_end` if the branch has no joint).
    pub end: Isometry3<f64>,
}

/// Everything needed to build a [`Machine`].
#[derive(Clone, Debug, PartialEq)]
pub struct MachineSpec {
    pub name: String,
    pub workpiece: BranchSpec,
    pub tool: BranchSpec,
}

/// What is wrong with a machine description. Loaders add the file position.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MachineError {
    #[error(
        "joint `{name}`: a moving joint must be named after its axis letter (X, Y, Z, U, V, W, A, B or C)"
    )]
    UnknownAxisLetter { name: String },
    #[error("axis {letter} appears twice; each axis letter may name one joint only")]
    DuplicateAxis { letter: char },
    #[error(
        "axis {letter}: the axis vector is zero; give the direction of motion, e.g. xyz=\"1 0 0\""
    )]
    ZeroAxis { letter: char },
    #[error(
        "axis {letter}: {letter} is a {expected} axis letter but the joint is {found}; \
         A, B, C are revolute, X, Y, Z, U, V, W prismatic"
    )]
    KindMismatch {
        letter: char,
        expected: &'static str,
        found: &'static str,
    },
    #[error("axis {letter}: limits must be finite with lower < upper, got [{lower}, {upper}]")]
    BadLimits {
        letter: char,
        lower: f64,
        upper: f64,
    },
    #[error("axis {letter}: a linear axis needs limits")]
    MissingLimits { letter: char },
    #[error("{what} is not finite")]
    NotFinite { what: String },
}

/// A validated machine axis.
#[derive(Clone, Debug)]
pub struct Axis {
    letter: AxisLetter,
    kind: AxisKind,
    side: Side,
    origin: Rigid,
    direction: Vector3<f64>,
    limits: Option<(f64, f64)>,
    zero_rotation: Matrix3<f64>,
}

impl Axis {
    pub fn letter(&self) -> AxisLetter {
        self.letter
    }
    pub fn kind(&self) -> AxisKind {
        self.kind
    }
    pub fn side(&self) -> Side {
        self.side
    }
    /// `prev_T_joint` at zero position.
    pub fn origin(&self) -> &Rigid {
        &self.origin
    }
    /// Unit direction of motion or rotation in the joint frame.
    pub fn direction(&self) -> &Vector3<f64> {
        &self.direction
    }
    /// Limits in m or rad; `None` for an unlimited rotary axis.
    pub fn limits(&self) -> Option<(f64, f64)> {
        self.limits
    }
    /// Orientation of the joint frame in the machine frame when every axis is at zero
    /// (`f_R_joint`). Error motions are given in machine directions; this maps them in.
    pub fn zero_rotation(&self) -> &Matrix3<f64> {
        &self.zero_rotation
    }
    /// The body's motion at position `q`: `joint_T_moved`.
    #[inline]
    pub fn motion(&self, q: f64) -> Rigid {
        match self.kind {
            AxisKind::Linear => Rigid::translation(self.direction * q),
            AxisKind::Rotary => Rigid::rotation(axis_rotation(&self.direction, q)),
        }
    }
    /// The Cartesian machine direction (0 = X, 1 = Y, 2 = Z) closest to the axis direction at
    /// the zero pose: what the ISO names call its own direction (EXX is along X's own direction).
    pub fn own_cartesian(&self) -> usize {
        let d = self.zero_rotation * self.direction;
        d.iamax()
    }
}

/// A branch as indices into [`Machine::axes`], from the machine frame outwards.
#[derive(Clone, Debug)]
pub struct Branch {
    joints: Vec<usize>,
    end: Rigid,
}

impl Branch {
    pub fn joints(&self) -> &[usize] {
        &self.joints
    }
    /// `last_joint_T_end`.
    pub fn end(&self) -> &Rigid {
        &self.end
    }
}

/// A machine tool's nominal kinematics. Immutable once built.
#[derive(Clone, Debug)]
pub struct Machine {
    name: String,
    axes: Vec<Axis>,
    workpiece: Branch,
    tool: Branch,
}

impl Machine {
    /// Validates a description: known, unique axis letters matching the joint kind, non-zero
    /// axis vectors, finite transforms, limits with lower < upper.
    pub fn try_new(spec: &MachineSpec) -> Result<Self, MachineError> {
        let mut staged: Vec<(Axis, Side, usize)> = Vec::new();
        for (side, branch) in [(Side::Workpiece, &spec.workpiece), (Side::Tool, &spec.tool)] {
            for (pos, j) in branch.joints.iter().enumerate() {
                let axis = validate_joint(j, side)?;
                if staged.iter().any(|(a, _, _)| a.letter == axis.letter) {
                    return Err(MachineError::DuplicateAxis { letter: j.letter });
                }
                staged.push((axis, side, pos));
            }
            check_finite_iso(&branch.end, "the branch end transform")?;
        }
        staged.sort_by_key(|(a, _, _)| a.letter.order());
        let index_of = |side: Side, pos: usize| {
            staged
                .iter()
                .position(|(_, s, p)| *s == side && *p == pos)
                .expect("staged joint")
        };
        let workpiece = Branch {
            joints: (0..spec.workpiece.joints.len())
                .map(|p| index_of(Side::Workpiece, p))
                .collect(),
            end: Rigid::from_isometry(&spec.workpiece.end),
        };
        let tool = Branch {
            joints: (0..spec.tool.joints.len())
                .map(|p| index_of(Side::Tool, p))
                .collect(),
            end: Rigid::from_isometry(&spec.tool.end),
        };
        let mut machine = Machine {
            name: spec.name.clone(),
            axes: staged.into_iter().map(|(a, _, _)| a).collect(),
            workpiece,
            tool,
        };
        machine.fill_zero_rotations();
        Ok(machine)
    }

    fn fill_zero_rotations(&mut self) {
        for side in [Side::Workpiece, Side::Tool] {
            let mut r = Matrix3::identity();
            for &i in self.branch(side).joints.clone().iter() {
                r *= self.axes[i].origin.r;
                self.axes[i].zero_rotation = r;
            }
        }
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// Axes in canonical letter order (X Y Z U V W A B C); every `q` slice follows this order.
    pub fn axes(&self) -> &[Axis] {
        &self.axes
    }

    pub fn n_axes(&self) -> usize {
        self.axes.len()
    }

    /// Index of an axis in [`Machine::axes`] (and in `q`).
    pub fn axis_index(&self, letter: char) -> Option<usize> {
        self.axes.iter().position(|a| a.letter.as_char() == letter)
    }

    pub fn branch(&self, side: Side) -> &Branch {
        match side {
            Side::Workpiece => &self.workpiece,
            Side::Tool => &self.tool,
        }
    }

    /// The axis letters as a string in canonical order, e.g. "XYZAC".
    pub fn letters(&self) -> String {
        self.axes.iter().map(|a| a.letter.as_char()).collect()
    }

    /// The explicit topology code, e.g. `wCAFYXZt`: workpiece end first, frame `F`, tool last.
    pub fn topology_code(&self) -> String {
        let mut s = String::from("w");
        for &i in self.workpiece.joints.iter().rev() {
            s.push(self.axes[i].letter.as_char());
        }
        s.push('F');
        for &i in &self.tool.joints {
            s.push(self.axes[i].letter.as_char());
        }
        s.push('t');
        s
    }

    /// Nominal `frame_T_end` of one branch at axis positions `q` (canonical order).
    pub fn branch_pose(&self, side: Side, q: &[f64]) -> Rigid {
        let b = self.branch(side);
        let mut t = Rigid::IDENTITY;
        for &i in &b.joints {
            let a = &self.axes[i];
            t = t.compose(&a.origin).compose(&a.motion(q[i]));
        }
        t.compose(&b.end)
    }

    /// Nominal pose of the tool point in the workpiece frame, `w_T_t`.
    pub fn tool_in_workpiece(&self, q: &[f64]) -> Rigid {
        let f_t_w = self.branch_pose(Side::Workpiece, q);
        let f_t_t = self.branch_pose(Side::Tool, q);
        f_t_w.inverse().compose(&f_t_t)
    }

    /// Whether every axis position lies within its limits (with a tolerance in m or rad).
    pub fn within_limits(&self, q: &[f64], tol: f64) -> bool {
        self.axes.iter().zip(q).all(|(a, &v)| match a.limits {
            Some((lo, hi)) => v >= lo - tol && v <= hi + tol,
            None => v.is_finite(),
        })
    }

    /// The spec this machine was built from (joint origins and axes as validated: unit axes).
    pub fn to_spec(&self) -> MachineSpec {
        let branch = |b: &Branch| BranchSpec {
            joints: b
                .joints
                .iter()
                .map(|&i| {
                    let a = &self.axes[i];
                    JointSpec {
                        letter: a.letter.as_char(),
                        kind: a.kind,
                        origin: a.origin.to_isometry(),
                        axis: a.direction,
                        limits: a.limits,
                    }
                })
                .collect(),
            end: b.end.to_isometry(),
        };
        MachineSpec {
            name: self.name.clone(),
            workpiece: branch(&self.workpiece),
            tool: branch(&self.tool),
        }
    }
}

fn validate_joint(j: &JointSpec, side: Side) -> Result<Axis, MachineError> {
    let letter = AxisLetter::new(j.letter).ok_or_else(|| MachineError::UnknownAxisLetter {
        name: j.letter.to_string(),
    })?;
    let found = match j.kind {
        AxisKind::Linear => "prismatic",
        AxisKind::Rotary => "revolute",
    };
    if letter.is_rotary() != (j.kind == AxisKind::Rotary) {
        let expected = if letter.is_rotary() {
            "rotary"
        } else {
            "linear"
        };
        return Err(MachineError::KindMismatch {
            letter: j.letter,
            expected,
            found,
        });
    }
    check_finite_iso(&j.origin, &format!("axis {} origin", j.letter))?;
    if !j.axis.iter().all(|v| v.is_finite()) {
        return Err(MachineError::NotFinite {
            what: format!("axis {} direction", j.letter),
        });
    }
    let direction = Unit::try_new(j.axis, 1e-12)
        .ok_or(MachineError::ZeroAxis { letter: j.letter })?
        .into_inner();
    match j.limits {
        Some((lower, upper)) if !(lower.is_finite() && upper.is_finite() && lower < upper) => {
            return Err(MachineError::BadLimits {
                letter: j.letter,
                lower,
                upper,
            });
        }
        None if j.kind == AxisKind::Linear => {
            return Err(MachineError::MissingLimits { letter: j.letter });
        }
        _ => {}
    }
    Ok(Axis {
        letter,
        kind: j.kind,
        side,
        origin: Rigid::from_isometry(&j.origin),
        direction,
        limits: j.limits,
        zero_rotation: Matrix3::identity(),
    })
}

fn check_finite_iso(iso: &Isometry3<f64>, what: &str) -> Result<(), MachineError> {
    let ok = iso.translation.vector.iter().all(|v| v.is_finite())
        && iso.rotation.coords.iter().all(|v| v.is_finite());
    if ok {
        Ok(())
    } else {
        Err(MachineError::NotFinite {
            what: what.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_units_convert_with_the_arithmetic_every_reader_and_writer_used() {
        // The session's compact columns promise the same bits as a conversion in place: one
        // expression per direction, `* 1e3` / `* 1e-3` and `to_degrees` / `to_radians`.
        for v in [0.1234, -512.0005, 1e-9, 359.9999, 0.0] {
            assert_eq!(
                AxisKind::Linear.from_file(v).to_bits(),
                (v * 1e-3).to_bits()
            );
            assert_eq!(
                AxisKind::Rotary.from_file(v).to_bits(),
                v.to_radians().to_bits()
            );
            assert_eq!(AxisKind::Linear.to_file(v).to_bits(), (v * 1e3).to_bits());
            assert_eq!(
                AxisKind::Rotary.to_file(v).to_bits(),
                v.to_degrees().to_bits()
            );
        }
        assert_eq!(AxisKind::Rotary.to_file(std::f64::consts::FRAC_PI_2), 90.0);
        assert_eq!(AxisKind::Linear.from_file(250.0), 0.25);
    }

    fn lin(letter: char, axis: [f64; 3]) -> JointSpec {
        JointSpec {
            letter,
            kind: AxisKind::Linear,
            origin: Isometry3::identity(),
            axis: Vector3::from(axis),
            limits: Some((-0.5, 0.5)),
        }
    }

    fn spec(wp: Vec<JointSpec>, tool: Vec<JointSpec>) -> MachineSpec {
        MachineSpec {
            name: "m".into(),
            workpiece: BranchSpec {
                joints: wp,
                end: Isometry3::identity(),
            },
            tool: BranchSpec {
                joints: tool,
                end: Isometry3::identity(),
            },
        }
    }

    #[test]
    fn orders_axes_canonically_and_writes_code() {
        let m = Machine::try_new(&spec(
            vec![lin('Y', [0., -1., 0.]), lin('X', [-1., 0., 0.])],
            vec![lin('Z', [0., 0., 1.])],
        ))
        .unwrap();
        assert_eq!(m.letters(), "XYZ");
        assert_eq!(m.topology_code(), "wXYFZt");
        // CNC convention: +X moves the tool relative to the workpiece towards +X.
        let p = m.tool_in_workpiece(&[0.1, 0.2, 0.3]).t;
        assert!((p - Vector3::new(0.1, 0.2, 0.3)).norm() < 1e-15);
    }

    #[test]
    fn rejects_bad_joints() {
        let check = |s: MachineSpec, expect: MachineError| {
            assert_eq!(Machine::try_new(&s).unwrap_err(), expect);
        };
        check(
            spec(vec![lin('Q', [1., 0., 0.])], vec![]),
            MachineError::UnknownAxisLetter { name: "Q".into() },
        );
        check(
            spec(vec![lin('X', [1., 0., 0.])], vec![lin('X', [1., 0., 0.])]),
            MachineError::DuplicateAxis { letter: 'X' },
        );
        check(
            spec(vec![lin('X', [0., 0., 0.])], vec![]),
            MachineError::ZeroAxis { letter: 'X' },
        );
        check(
            spec(vec![lin('A', [1., 0., 0.])], vec![]),
            MachineError::KindMismatch {
                letter: 'A',
                expected: "rotary",
                found: "prismatic",
            },
        );
        let mut bad = lin('X', [1., 0., 0.]);
        bad.limits = Some((0.5, 0.5));
        check(
            spec(vec![bad], vec![]),
            MachineError::BadLimits {
                letter: 'X',
                lower: 0.5,
                upper: 0.5,
            },
        );
        let mut none = lin('X', [1., 0., 0.]);
        none.limits = None;
        check(
            spec(vec![none], vec![]),
            MachineError::MissingLimits { letter: 'X' },
        );
    }
}
