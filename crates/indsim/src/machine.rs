//! The machine: two serial branches read from a URDF, evaluated joint by joint with plain 4 × 4
//! homogeneous transforms, nominally or with a [`Truth`](crate::truth::Truth)'s errors inserted.
//!
//! Written from the conventions (FORMATS.md "Machine", ARCHITECTURE.md "Conventions"), not from
//! mtcal's code: the root link is the machine frame; one branch ends in the link `workpiece`,
//! the other in `tool`; moving joints are named after their axis letter; fixed joints are kept
//! as constant transforms where they sit in the chain.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Matrix3, Matrix4, Vector3};

/// Why a URDF could not be used.
#[derive(Debug, thiserror::Error)]
pub enum MachineError {
    #[error("cannot read the URDF: {0}")]
    Urdf(String),
    #[error("{0}")]
    Structure(String),
}

/// Linear (prismatic) or rotary (revolute / continuous) joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    Linear,
    Rotary,
}

/// The branch a joint sits in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Workpiece,
    Tool,
}

/// One moving joint.
#[derive(Clone, Debug)]
pub struct Joint {
    pub letter: char,
    pub kind: JointKind,
    pub side: Side,
    /// `parent_T_joint` at zero position (the URDF origin).
    pub origin: Matrix4<f64>,
    /// Unit axis in the joint frame.
    pub axis: Vector3<f64>,
    /// Limits in m or rad; `None` for a continuous joint.
    pub limits: Option<(f64, f64)>,
    /// Orientation of the joint frame in the machine frame with every axis at zero: error
    /// motions are given in machine directions and turned into the joint frame by its inverse.
    pub zero_rotation: Matrix3<f64>,
}

impl Joint {
    /// The stroke the Legendre bases span: the limits, or one turn for a continuous joint.
    pub fn stroke(&self) -> (f64, f64) {
        self.limits
            .unwrap_or((-std::f64::consts::PI, std::f64::consts::PI))
    }

    /// The machine direction (0 = X, 1 = Y, 2 = Z) the axis runs along or turns about at the
    /// zero pose: its "own" direction in the ISO names (`EXX`, `ECC`).
    pub fn own_direction(&self) -> usize {
        let d = self.zero_rotation * self.axis;
        (0..3)
            .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
            .expect("three directions")
    }
}

#[derive(Clone, Debug)]
enum Link {
    Fixed(Matrix4<f64>),
    Joint(usize),
}

/// A machine tool's kinematics, independent of mtcal's.
#[derive(Clone, Debug)]
pub struct Machine {
    pub name: String,
    /// Moving joints in the canonical letter order X Y Z U V W A B C (the order of axis
    /// positions `q` everywhere in this crate, and of the CSV columns).
    pub joints: Vec<Joint>,
    workpiece: Vec<Link>,
    tool: Vec<Link>,
}

/// Canonical order of axis letters in `q`.
pub const LETTER_ORDER: &str = "XYZUVWABC";

/// The errors an actual machine has beyond its nominal chain (a [`crate::truth::Truth`]): what
/// [`Machine::tool_in_workpiece`] inserts.
pub trait ActualErrors {
    /// Component and location errors of joint `i` at position `q` (machine directions at the
    /// zero pose: δx δy δz εx εy εz each).
    fn axis_errors(&self, machine: &Machine, i: usize, q: f64) -> ([f64; 6], [f64; 6]);
    /// Where the workpiece frame really sits on its link (x y z m, a b c rad).
    fn workpiece(&self) -> [f64; 6];
    /// The tool point's offset in the tool frame (m).
    fn tool(&self) -> [f64; 3];
}

impl Machine {
    pub fn from_urdf_file(path: &Path) -> Result<Self, MachineError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| MachineError::Urdf(format!("{}: {e}", path.display())))?;
        Self::from_urdf_text(&text)
    }

    pub fn from_urdf_text(text: &str) -> Result<Self, MachineError> {
        let robot =
            urdf_rs::read_from_string(text).map_err(|e| MachineError::Urdf(e.to_string()))?;
        let by_child: HashMap<&str, &urdf_rs::Joint> = robot
            .joints
            .iter()
            .map(|j| (j.child.link.as_str(), j))
            .collect();
        // From an end link up to the root, then reversed: root → end.
        let chain = |end: &str| -> Result<(String, Vec<&urdf_rs::Joint>), MachineError> {
            let mut link = end.to_string();
            let mut out = Vec::new();
            while let Some(j) = by_child.get(link.as_str()) {
                out.push(*j);
                link = j.parent.link.clone();
                if out.len() > robot.joints.len() {
                    return Err(MachineError::Structure("the URDF has a loop".into()));
                }
            }
            if out.is_empty() && !robot.links.iter().any(|l| l.name == end) {
                return Err(MachineError::Structure(format!("no link named `{end}`")));
            }
            out.reverse();
            Ok((link, out))
        };
        let (root_w, wp) = chain("workpiece")?;
        let (root_t, tl) = chain("tool")?;
        if root_w != root_t {
            return Err(MachineError::Structure(format!(
                "`workpiece` hangs from `{root_w}` and `tool` from `{root_t}`: one root expected"
            )));
        }
        let mut joints: Vec<Joint> = Vec::new();
        let mut branches = [Vec::new(), Vec::new()];
        for (b, (side, list)) in [(Side::Workpiece, &wp), (Side::Tool, &tl)]
            .iter()
            .enumerate()
        {
            let mut r0 = Matrix3::identity();
            for j in list.iter() {
                let origin = pose_matrix(&j.origin.xyz.0, &j.origin.rpy.0);
                r0 *= origin.fixed_view::<3, 3>(0, 0).into_owned();
                let kind = match j.joint_type {
                    urdf_rs::JointType::Fixed => {
                        branches[b].push(Link::Fixed(origin));
                        continue;
                    }
                    urdf_rs::JointType::Prismatic => JointKind::Linear,
                    urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {
                        JointKind::Rotary
                    }
                    ref other => {
                        return Err(MachineError::Structure(format!(
                            "joint `{}`: type {other:?} is not a machine axis",
                            j.name
                        )));
                    }
                };
                let letter = single_letter(&j.name).ok_or_else(|| {
                    MachineError::Structure(format!(
                        "joint `{}`: a moving joint is named after its axis letter",
                        j.name
                    ))
                })?;
                let a = Vector3::from(j.axis.xyz.0);
                let limits = match j.joint_type {
                    urdf_rs::JointType::Continuous => None,
                    _ => Some((j.limit.lower, j.limit.upper)),
                };
                branches[b].push(Link::Joint(joints.len()));
                joints.push(Joint {
                    letter,
                    kind,
                    side: *side,
                    origin,
                    axis: a / a.norm(),
                    limits,
                    zero_rotation: r0,
                });
            }
        }
        // Canonical order; the branches keep their order and are renumbered.
        let mut order: Vec<usize> = (0..joints.len()).collect();
        order.sort_by_key(|&i| LETTER_ORDER.find(joints[i].letter).unwrap_or(usize::MAX));
        let new_index: HashMap<usize, usize> = order
            .iter()
            .enumerate()
            .map(|(new, &old)| (old, new))
            .collect();
        let renumber = |v: &mut Vec<Link>| {
            for l in v.iter_mut() {
                if let Link::Joint(i) = l {
                    *i = new_index[i];
                }
            }
        };
        let [mut w, mut t] = branches;
        renumber(&mut w);
        renumber(&mut t);
        let joints = order.iter().map(|&i| joints[i].clone()).collect();
        Ok(Machine {
            name: robot.name.clone(),
            joints,
            workpiece: w,
            tool: t,
        })
    }

    /// Axis letters in `q` order, e.g. "XYZAC".
    pub fn letters(&self) -> String {
        self.joints.iter().map(|j| j.letter).collect()
    }

    pub fn index(&self, letter: char) -> Option<usize> {
        self.joints.iter().position(|j| j.letter == letter)
    }

    pub fn n_axes(&self) -> usize {
        self.joints.len()
    }

    /// `frame_T_end` of one branch at `q` (SI), with the truth's errors when given.
    pub fn branch_pose(
        &self,
        side: Side,
        q: &[f64],
        truth: Option<&dyn ActualErrors>,
    ) -> Matrix4<f64> {
        let links = match side {
            Side::Workpiece => &self.workpiece,
            Side::Tool => &self.tool,
        };
        let mut t = Matrix4::identity();
        for l in links {
            match l {
                Link::Fixed(m) => t *= m,
                Link::Joint(i) => t *= self.joint_transform(*i, q[*i], truth),
            }
        }
        match (side, truth) {
            // Set-up errors: where the workpiece frame really sits on its link, and the tool
            // point's offset in the tool frame.
            (Side::Workpiece, Some(tr)) => {
                let [x, y, z, a, b, c] = tr.workpiece();
                t * rigid(
                    &exp_rotation(&Vector3::new(a, b, c)),
                    &Vector3::new(x, y, z),
                )
            }
            (Side::Tool, Some(tr)) => t * translation(&Vector3::from(tr.tool())),
            (_, None) => t,
        }
    }

    /// The tool pose in the workpiece frame, `w_T_t(q)`: nominal (`truth = None`) or actual.
    pub fn tool_in_workpiece(&self, q: &[f64], truth: Option<&dyn ActualErrors>) -> Matrix4<f64> {
        let w = self.branch_pose(Side::Workpiece, q, truth);
        let t = self.branch_pose(Side::Tool, q, truth);
        rigid_inverse(&w) * t
    }

    /// `parent_T_child` of joint `i` at position `q`, errors inserted:
    /// - linear: `origin · Trans(q·R_L·a) · E_body` (squareness tilts the direction of motion;
    ///   the error motion follows the carriage);
    /// - rotary: `origin · E_body · L · Rot(a, q) · L⁻¹` (the axis turns about its actual line;
    ///   its error motion does not turn with it).
    ///
    /// `E = (exp([ε]×), δ)`; a workpiece-side body moves by `E⁻¹` because the errors are the
    /// tool's motion relative to the workpiece. Every error vector is given in machine
    /// directions at the zero pose and turned into the joint frame by `zero_rotationᵀ`.
    fn joint_transform(&self, i: usize, q: f64, truth: Option<&dyn ActualErrors>) -> Matrix4<f64> {
        let j = &self.joints[i];
        let Some(truth) = truth else {
            return j.origin * motion(j, q, &j.axis);
        };
        let (comp, loc) = truth.axis_errors(self, i, q);
        let r0t = j.zero_rotation.transpose();
        let local = |v: [f64; 6], k: usize| r0t * Vector3::new(v[k], v[k + 1], v[k + 2]);
        let e = rigid(&exp_rotation(&local(comp, 3)), &local(comp, 0));
        let e_body = match j.side {
            Side::Tool => e,
            Side::Workpiece => rigid_inverse(&e),
        };
        let l_rot = exp_rotation(&local(loc, 3));
        match j.kind {
            JointKind::Linear => {
                let dir = l_rot * j.axis;
                j.origin * motion(j, q, &dir) * e_body
            }
            JointKind::Rotary => {
                let l = rigid(&l_rot, &local(loc, 0));
                j.origin * e_body * l * motion(j, q, &j.axis) * rigid_inverse(&l)
            }
        }
    }

    /// The linear-axis positions that put the nominal point `offset` (tool frame, m) of the tool
    /// on `target` (workpiece frame, m), the other axes as in `q`. Newton on the nominal chain
    /// with a finite-difference Jacobian (the map is affine in the linear axes, so it converges
    /// in one step; the second one polishes the rounding).
    pub fn follow_point(
        &self,
        q: &[f64],
        offset: &Vector3<f64>,
        target: &Vector3<f64>,
    ) -> Result<Vec<f64>, MachineError> {
        let lin: Vec<usize> = (0..self.n_axes())
            .filter(|&i| self.joints[i].kind == JointKind::Linear)
            .collect();
        if lin.len() != 3 {
            return Err(MachineError::Structure(format!(
                "following a point needs three linear axes, the machine has {}",
                lin.len()
            )));
        }
        let point = |q: &[f64]| apply(&self.tool_in_workpiece(q, None), offset);
        let mut q = q.to_vec();
        for _ in 0..4 {
            let r = target - point(&q);
            if r.norm() < 1e-14 {
                break;
            }
            let mut jac = Matrix3::zeros();
            for (c, &i) in lin.iter().enumerate() {
                let h = 0.01;
                let mut qp = q.clone();
                let mut qm = q.clone();
                qp[i] += h;
                qm[i] -= h;
                jac.set_column(c, &((point(&qp) - point(&qm)) / (2.0 * h)));
            }
            let step = jac.lu().solve(&r).ok_or_else(|| {
                MachineError::Structure("the linear axes cannot move the tool point freely".into())
            })?;
            for (c, &i) in lin.iter().enumerate() {
                q[i] += step[c];
            }
        }
        Ok(q)
    }

    /// Whether every axis is within its limits (tolerance in m or rad).
    pub fn within_limits(&self, q: &[f64], tol: f64) -> bool {
        self.joints.iter().zip(q).all(|(j, &v)| match j.limits {
            Some((lo, hi)) => v >= lo - tol && v <= hi + tol,
            None => v.is_finite(),
        })
    }
}

fn single_letter(name: &str) -> Option<char> {
    let mut c = name.chars();
    let l = c.next()?;
    (c.next().is_none() && LETTER_ORDER.contains(l)).then_some(l)
}

/// The body's motion along (linear) or about (rotary) `dir` by `q`.
fn motion(j: &Joint, q: f64, dir: &Vector3<f64>) -> Matrix4<f64> {
    match j.kind {
        JointKind::Linear => translation(&(dir * q)),
        JointKind::Rotary => rigid(&axis_angle(dir, q), &Vector3::zeros()),
    }
}

/// URDF origin: translation `xyz`, rotation `Rz(yaw)·Ry(pitch)·Rx(roll)` (fixed axes).
pub fn pose_matrix(xyz: &[f64; 3], rpy: &[f64; 3]) -> Matrix4<f64> {
    let x = axis_angle(&Vector3::x(), rpy[0]);
    let y = axis_angle(&Vector3::y(), rpy[1]);
    let z = axis_angle(&Vector3::z(), rpy[2]);
    rigid(&(z * y * x), &Vector3::from(*xyz))
}

/// Rotation by `angle` about the unit vector `a` (Rodrigues).
pub fn axis_angle(a: &Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let k = skew(a);
    let (s, c) = angle.sin_cos();
    Matrix3::identity() + k * s + k * k * (1.0 - c)
}

/// `exp([w]×)`: the rotation by `|w|` about `w` — how an error's rotation vector becomes a
/// rotation. `1 − cos θ` as `2 sin²(θ/2)`, which keeps its digits at error-motion sizes.
pub fn exp_rotation(w: &Vector3<f64>) -> Matrix3<f64> {
    let th = w.norm();
    if th == 0.0 {
        return Matrix3::identity();
    }
    let k = skew(w);
    let half = (0.5 * th).sin();
    Matrix3::identity() + k * (th.sin() / th) + k * k * (2.0 * half * half / (th * th))
}

/// `log`: the rotation vector of `r`, the inverse of [`exp_rotation`] for angles below π. The
/// axis times `sin θ` is the skew-symmetric part of `r`, `cos θ = (tr r − 1)/2`, and the angle
/// comes from both (`atan2`), which keeps its digits at error-motion sizes where `acos` would
/// not. Near π (not an error motion) the axis loses its digits.
pub fn log_rotation(r: &Matrix3<f64>) -> Vector3<f64> {
    let sin_axis = 0.5
        * Vector3::new(
            r[(2, 1)] - r[(1, 2)],
            r[(0, 2)] - r[(2, 0)],
            r[(1, 0)] - r[(0, 1)],
        );
    let sin = sin_axis.norm();
    if sin == 0.0 {
        return Vector3::zeros();
    }
    let cos = 0.5 * (r.trace() - 1.0);
    sin_axis * (sin.atan2(cos) / sin)
}

pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

pub fn rigid(r: &Matrix3<f64>, t: &Vector3<f64>) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(r);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(t);
    m
}

pub fn translation(t: &Vector3<f64>) -> Matrix4<f64> {
    rigid(&Matrix3::identity(), t)
}

pub fn rigid_inverse(m: &Matrix4<f64>) -> Matrix4<f64> {
    let rt = rotation_of(m).transpose();
    rigid(&rt, &(-(rt * translation_of(m))))
}

pub fn rotation_of(m: &Matrix4<f64>) -> Matrix3<f64> {
    m.fixed_view::<3, 3>(0, 0).into_owned()
}

pub fn translation_of(m: &Matrix4<f64>) -> Vector3<f64> {
    m.fixed_view::<3, 1>(0, 3).into_owned()
}

/// `m` applied to the point `p`.
pub fn apply(m: &Matrix4<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    rotation_of(m) * p + translation_of(m)
}
