//! Collision geometry: the machine's URDF `<collision>` shapes placed by the nominal forward
//! kinematics, the instrument's bodies, and which pairs are checked.
//!
//! A machine body is carried by the machine frame or by a moving joint (the joint frame after
//! its motion, as [`Machine`] composes it); its fixed offset is the product of the fixed-joint
//! origins from that joint down to its link, times the `<collision>` origin. So a link's pose at
//! `q` is `frame_T_joint(q) · joint_T_link · link_T_shape`, the same chain the URDF loader
//! collapses.

use crate::PlanError;
use mtcal_kinematics::rigid::Rigid;
use mtcal_kinematics::{Machine, Side};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion};
use parry3d_f64::math::{Pose, Rotation, Vector};
use parry3d_f64::query;
use parry3d_f64::shape::{Ball, Capsule, Cuboid, Cylinder, Shape};
use std::collections::HashMap;
use std::path::Path;

pub use mtcal_instrument::collision::Primitive;

/// The parry shape of a primitive and the local pose that turns parry's y-axis cylinders onto
/// z.
fn parry(primitive: &Primitive) -> (Box<dyn Shape>, Rigid) {
    let to_z = Rigid::rotation(Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0));
    match *primitive {
        Primitive::Box { half } => (
            Box::new(Cuboid::new(Vector::new(half[0], half[1], half[2]))),
            Rigid::IDENTITY,
        ),
        Primitive::Cylinder {
            radius,
            half_length,
        } => (Box::new(Cylinder::new(half_length, radius)), to_z),
        Primitive::Sphere { radius } => (Box::new(Ball::new(radius)), Rigid::IDENTITY),
        Primitive::Capsule {
            radius,
            half_length,
        } => (
            Box::new(Capsule::new_z(half_length, radius)),
            Rigid::IDENTITY,
        ),
    }
}

/// A shape ready for queries: the parry shape and its fixed local correction.
pub struct Solid {
    shape: Box<dyn Shape>,
    local: Rigid,
}

impl std::fmt::Debug for Solid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Solid")
            .field("shape", &self.shape.shape_type())
            .field("local", &self.local)
            .finish()
    }
}

impl Solid {
    pub fn new(p: &Primitive) -> Self {
        let (shape, local) = parry(p);
        Solid { shape, local }
    }
}

/// `Rigid` → parry pose. The quaternion comes from Shepperd's closed form
/// (`from_rotation_matrix`), exact also near half turns, where nalgebra's iterative
/// `from_matrix` started from the identity does not converge.
pub fn to_pose(t: &Rigid) -> Pose {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(t.r));
    let c = q.coords;
    Pose::from_parts(
        Vector::new(t.t.x, t.t.y, t.t.z),
        Rotation::from_xyzw(c.x, c.y, c.z, c.w).normalize(),
    )
}

/// The signed distance between two solids at two poses (machine frame), or `None` when they
/// are further apart than `prediction`. Negative: penetration depth.
pub fn signed_distance(
    a: &Solid,
    pa: &Rigid,
    b: &Solid,
    pb: &Rigid,
    prediction: f64,
) -> Result<Option<f64>, String> {
    let (xa, xb) = (
        to_pose(&pa.compose(&a.local)),
        to_pose(&pb.compose(&b.local)),
    );
    match query::contact(&xa, a.shape.as_ref(), &xb, b.shape.as_ref(), prediction) {
        Ok(c) => Ok(c.map(|c| c.dist)),
        Err(_) => Err("this pair of shapes is not supported by the collision queries".into()),
    }
}

/// What carries a body of the machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Carrier {
    /// The machine frame (the root link and everything fixed to it).
    Frame,
    /// A moving axis (index into [`Machine::axes`]): its joint frame after the motion.
    Axis(usize),
}

impl Carrier {
    /// `frame_T_carrier` at axis positions `q`.
    pub fn pose(self, machine: &Machine, q: &[f64]) -> Rigid {
        let Carrier::Axis(k) = self else {
            return Rigid::IDENTITY;
        };
        let side = machine.axes()[k].side();
        let mut t = Rigid::IDENTITY;
        for &i in machine.branch(side).joints() {
            let a = &machine.axes()[i];
            t = t.compose(a.origin()).compose(&a.motion(q[i]));
            if i == k {
                break;
            }
        }
        t
    }

    /// The branch it sits in (`None` for the frame, which both branches leave).
    pub fn side(self, machine: &Machine) -> Option<Side> {
        match self {
            Carrier::Frame => None,
            Carrier::Axis(i) => Some(machine.axes()[i].side()),
        }
    }

    /// The carrier this one sits on (`None` for the frame).
    pub fn parent(self, machine: &Machine) -> Option<Carrier> {
        let Carrier::Axis(k) = self else {
            return None;
        };
        let joints = machine.branch(machine.axes()[k].side()).joints();
        let pos = joints.iter().position(|&i| i == k)?;
        Some(if pos == 0 {
            Carrier::Frame
        } else {
            Carrier::Axis(joints[pos - 1])
        })
    }

    /// The carrier of a branch's end link (`tool` or `workpiece`): its last joint, or the frame.
    pub fn end_of(machine: &Machine, side: Side) -> Carrier {
        machine
            .branch(side)
            .joints()
            .last()
            .map_or(Carrier::Frame, |&i| Carrier::Axis(i))
    }
}

/// One `<collision>` element of the machine.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineBody {
    /// The link's name (`#2`, `#3` … for its further collision elements).
    pub name: String,
    pub carrier: Carrier,
    /// `carrier_T_shape`.
    pub offset: Rigid,
    pub primitive: Primitive,
}

/// The machine's collision geometry.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MachineGeometry {
    pub bodies: Vec<MachineBody>,
    /// Collision elements that are not checked (meshes), one sentence each.
    pub unsupported: Vec<String>,
}

fn iso(p: &urdf_rs::Pose) -> Isometry3<f64> {
    let [x, y, z] = p.xyz.0;
    let [roll, pitch, yaw] = p.rpy.0;
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(roll, pitch, yaw),
    )
}

impl MachineGeometry {
    /// Reads the `<collision>` elements of a URDF file that loads as `machine`.
    pub fn from_urdf_file(path: &Path, machine: &Machine) -> Result<Self, PlanError> {
        let text = std::fs::read_to_string(path).map_err(|e| PlanError::Io {
            path: path.to_path_buf(),
            cause: e,
        })?;
        Self::from_urdf_str(&text, path, machine)
    }

    /// [`MachineGeometry::from_urdf_file`] from the file's text (`file` names it in errors).
    /// Boxes, cylinders, spheres and capsules are read; meshes are listed in `unsupported`
    /// (never approximated: a mesh's extent is not in the URDF).
    pub fn from_urdf_str(text: &str, file: &Path, machine: &Machine) -> Result<Self, PlanError> {
        let bad = |message: String| PlanError::Geometry {
            file: file.to_path_buf(),
            message,
        };
        let robot = urdf_rs::read_from_string(text).map_err(|e| bad(e.to_string()))?;
        let parent_joint: HashMap<&str, &urdf_rs::Joint> = robot
            .joints
            .iter()
            .map(|j| (j.child.link.as_str(), j))
            .collect();
        let mut out = MachineGeometry::default();
        for link in &robot.links {
            if link.collision.is_empty() {
                continue;
            }
            // Joints from the root down to this link.
            let mut chain = Vec::new();
            let mut at = link.name.as_str();
            while let Some(j) = parent_joint.get(at) {
                if chain.len() > robot.joints.len() {
                    return Err(bad(format!(
                        "link `{}`: the joints form a cycle",
                        link.name
                    )));
                }
                chain.push(*j);
                at = j.parent.link.as_str();
            }
            chain.reverse();
            let (mut carrier, mut offset) = (Carrier::Frame, Isometry3::identity());
            for j in chain {
                if matches!(j.joint_type, urdf_rs::JointType::Fixed) {
                    offset *= iso(&j.origin);
                    continue;
                }
                let letter = j
                    .name
                    .chars()
                    .next()
                    .filter(|_| j.name.chars().count() == 1);
                let k = letter.and_then(|c| machine.axis_index(c)).ok_or_else(|| {
                    bad(format!(
                        "link `{}` hangs on moving joint `{}`, which is not an axis of machine `{}`",
                        link.name,
                        j.name,
                        machine.name()
                    ))
                })?;
                carrier = Carrier::Axis(k);
                offset = Isometry3::identity();
            }
            for (n, c) in link.collision.iter().enumerate() {
                let name = if n == 0 {
                    link.name.clone()
                } else {
                    format!("{}#{}", link.name, n + 1)
                };
                let primitive = match &c.geometry {
                    urdf_rs::Geometry::Box { size } => Primitive::Box {
                        half: [size.0[0] / 2.0, size.0[1] / 2.0, size.0[2] / 2.0],
                    },
                    urdf_rs::Geometry::Cylinder { radius, length } => Primitive::Cylinder {
                        radius: *radius,
                        half_length: length / 2.0,
                    },
                    urdf_rs::Geometry::Capsule { radius, length } => Primitive::Capsule {
                        radius: *radius,
                        half_length: length / 2.0,
                    },
                    urdf_rs::Geometry::Sphere { radius } => Primitive::Sphere { radius: *radius },
                    urdf_rs::Geometry::Mesh { filename, .. } => {
                        out.unsupported.push(format!(
                            "link `{name}`: mesh `{filename}` is not checked (only box, cylinder, \
                             sphere and capsule collision shapes are)"
                        ));
                        continue;
                    }
                };
                let ok = match &primitive {
                    Primitive::Box { half } => half.iter().all(|h| h.is_finite() && *h > 0.0),
                    Primitive::Cylinder {
                        radius,
                        half_length,
                    }
                    | Primitive::Capsule {
                        radius,
                        half_length,
                    } => radius.is_finite() && *radius > 0.0 && half_length.is_finite(),
                    Primitive::Sphere { radius } => radius.is_finite() && *radius > 0.0,
                };
                if !ok {
                    return Err(bad(format!(
                        "link `{name}`: collision shape {primitive:?} needs finite positive sizes"
                    )));
                }
                out.bodies.push(MachineBody {
                    name,
                    carrier,
                    offset: Rigid::from_isometry(&(offset * iso(&c.origin))),
                    primitive,
                });
            }
        }
        Ok(out)
    }

    /// `frame_T_shape` of body `k` at axis positions `q`.
    pub fn body_pose(&self, machine: &Machine, k: usize, q: &[f64]) -> Rigid {
        let b = &self.bodies[k];
        b.carrier.pose(machine, q).compose(&b.offset)
    }

    /// Whether two machine bodies can touch other than by design: they sit in different
    /// branches (the frame counts as neither) and neither carrier carries the other directly.
    /// Bodies of one branch are the machine builder's business.
    pub fn pair_checked(machine: &Machine, a: Carrier, b: Carrier) -> bool {
        if a == b || a.side(machine) == b.side(machine) {
            return false;
        }
        a.parent(machine) != Some(b) && b.parent(machine) != Some(a)
    }
}
