//! From the link tree to the machine: the workpiece and tool branches, fixed joints collapsed
//! into the moving joints' origins, each moving joint checked and turned into a joint spec.

use super::*;

/// The link tree: each link's parent joint, checked for dangling names, two parents and cycles.
pub(super) struct Tree {
    /// Per link (index into `XmlModel::links`): the joint whose child it is.
    pub(super) parent_joint: Vec<Option<usize>>,
    /// Per joint: (parent link, child link).
    pub(super) ends: Vec<(usize, usize)>,
}

impl Tree {
    pub(super) fn build(ctx: &Ctx, model: &XmlModel) -> Result<Self, UrdfError> {
        let mut tree = Tree {
            parent_joint: vec![None; model.links.len()],
            ends: Vec::with_capacity(model.joints.len()),
        };
        for (j, joint) in model.joints.iter().enumerate() {
            let parent = resolve_link(ctx, model, joint, &joint.parent, "parent")?;
            let child = resolve_link(ctx, model, joint, &joint.child, "child")?;
            if let Some(first) = tree.parent_joint[child] {
                return Err(UrdfError::TwoParents {
                    at: ctx.at(joint.node),
                    link: joint.child.1.to_string(),
                    first: model.joints[first].name.to_string(),
                    second: joint.name.to_string(),
                });
            }
            tree.parent_joint[child] = Some(j);
            tree.ends.push((parent, child));
        }
        tree.check_cycles(ctx, model)?;
        Ok(tree)
    }

    /// With one parent per link, walking up from any link either reaches a root or loops. A
    /// loop is reported at its joint that comes last in the file, the likelier mistake.
    pub(super) fn check_cycles(&self, ctx: &Ctx, model: &XmlModel) -> Result<(), UrdfError> {
        for start in 0..model.links.len() {
            let mut seen = vec![start];
            let mut via: Vec<usize> = Vec::new();
            let mut link = start;
            while let Some(j) = self.parent_joint[link] {
                link = self.ends[j].0;
                via.push(j);
                if let Some(k) = seen.iter().position(|&l| l == link) {
                    let names: Vec<String> = seen[k..]
                        .iter()
                        .map(|&l| format!("`{}`", model.links[l].1))
                        .collect();
                    let last = via[k..].iter().copied().max().unwrap_or(j);
                    return Err(UrdfError::Cycle {
                        at: ctx.at(model.joints[last].node),
                        links: names.join(", "),
                    });
                }
                seen.push(link);
            }
        }
        Ok(())
    }

    /// The joints from the root to `link`, root first.
    pub(super) fn path_to(&self, link: usize) -> Vec<usize> {
        let mut path = Vec::new();
        let mut l = link;
        while let Some(j) = self.parent_joint[l] {
            path.push(j);
            l = self.ends[j].0;
        }
        path.reverse();
        path
    }

    pub(super) fn roots(&self) -> Vec<usize> {
        (0..self.parent_joint.len())
            .filter(|&l| self.parent_joint[l].is_none())
            .collect()
    }
}

pub(super) fn resolve_link(
    ctx: &Ctx,
    model: &XmlModel,
    joint: &XmlJoint,
    reference: &(Node, &str),
    role: &'static str,
) -> Result<usize, UrdfError> {
    model
        .link_index
        .get(reference.1)
        .copied()
        .ok_or_else(|| UrdfError::UnknownLink {
            at: ctx.at(reference.0),
            joint: joint.name.to_string(),
            role,
            link: reference.1.to_string(),
        })
}

/// The joint paths from the root link to `workpiece` and to `tool`.
pub(super) struct Branches {
    pub(super) workpiece: Vec<usize>,
    pub(super) tool: Vec<usize>,
}

impl Branches {
    pub(super) fn find(ctx: &Ctx, model: &XmlModel, tree: &Tree) -> Result<Self, UrdfError> {
        let robot_at = || ctx.at(model.robot);
        let wp = *model
            .link_index
            .get("workpiece")
            .ok_or_else(|| UrdfError::MissingWorkpiece { at: robot_at() })?;
        let tool = *model
            .link_index
            .get("tool")
            .ok_or_else(|| UrdfError::MissingTool { at: robot_at() })?;
        let roots = tree.roots();
        if roots.len() > 1 {
            let names: Vec<String> = roots
                .iter()
                .map(|&l| format!("`{}`", model.links[l].1))
                .collect();
            return Err(UrdfError::MultipleRoots {
                at: ctx.at(model.links[roots[1]].0),
                roots: names.join(", "),
            });
        }
        let branches = Branches {
            workpiece: tree.path_to(wp),
            tool: tree.path_to(tool),
        };
        branches.check_separate(ctx, model, tree, wp, tool)?;
        branches.check_all_axes_used(ctx, model)?;
        Ok(branches)
    }

    /// Neither end lies below the other, and the shared stem from the root is rigid.
    pub(super) fn check_separate(
        &self,
        ctx: &Ctx,
        model: &XmlModel,
        tree: &Tree,
        wp: usize,
        tool: usize,
    ) -> Result<(), UrdfError> {
        let passes = |path: &[usize], link: usize| path.iter().any(|&j| tree.ends[j].0 == link);
        let same = if passes(&self.workpiece, tool) {
            Some(("tool", "workpiece", wp))
        } else if passes(&self.tool, wp) {
            Some(("workpiece", "tool", tool))
        } else {
            None
        };
        if let Some((upper, lower, link)) = same {
            return Err(UrdfError::SameBranch {
                at: ctx.at(model.links[link].0),
                upper,
                lower,
            });
        }
        let shared = self
            .workpiece
            .iter()
            .zip(&self.tool)
            .take_while(|(a, b)| a == b);
        for (&j, _) in shared {
            let joint = &model.joints[j];
            if joint.moving() {
                return Err(UrdfError::SharedMovingJoint {
                    at: ctx.at(joint.node),
                    joint: joint.name.to_string(),
                });
            }
        }
        Ok(())
    }

    pub(super) fn check_all_axes_used(&self, ctx: &Ctx, model: &XmlModel) -> Result<(), UrdfError> {
        let used = |j: usize| self.workpiece.contains(&j) || self.tool.contains(&j);
        let stray = (0..model.joints.len()).find(|&j| model.joints[j].moving() && !used(j));
        match stray {
            Some(j) => Err(UrdfError::MovingJointOffBranch {
                at: ctx.at(model.joints[j].node),
                joint: model.joints[j].name.to_string(),
            }),
            None => Ok(()),
        }
    }
}

/// One branch with fixed joints collapsed into the next moving joint's origin or the end.
pub(super) fn branch_spec(
    ctx: &Ctx,
    model: &XmlModel,
    joints: &HashMap<&str, &urdf_rs::Joint>,
    path: &[usize],
) -> Result<BranchSpec, UrdfError> {
    let mut pending = Isometry3::identity();
    let mut out = Vec::new();
    for &j in path {
        let xml = &model.joints[j];
        let Some(joint) = joints.get(xml.name) else {
            return Err(UrdfError::Invalid {
                at: ctx.at(xml.node),
                message: format!("urdf-rs did not read joint `{}`", xml.name),
            });
        };
        let origin = pending * pose(&joint.origin);
        if xml.moving() {
            out.push(moving_joint(ctx, xml, joint, origin)?);
            pending = Isometry3::identity();
        } else {
            pending = origin;
        }
    }
    Ok(BranchSpec {
        joints: out,
        end: pending,
    })
}

/// URDF `<origin xyz rpy>`: translation, then fixed-axis roll (x), pitch (y), yaw (z).
pub(super) fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    let [x, y, z] = p.xyz.0;
    let [roll, pitch, yaw] = p.rpy.0;
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(roll, pitch, yaw),
    )
}

/// A prismatic limit beyond this many metres is taken for mm.
pub const MAX_PLAUSIBLE_STROKE_M: f64 = 100.0;
/// A revolute limit beyond two turns (radians) is taken for degrees.
pub const MAX_PLAUSIBLE_TURN_RAD: f64 = 4.0 * std::f64::consts::PI;

pub(super) fn moving_joint(
    ctx: &Ctx,
    xml: &XmlJoint,
    joint: &urdf_rs::Joint,
    origin: Isometry3<f64>,
) -> Result<JointSpec, UrdfError> {
    let at = || ctx.at(xml.node);
    let letter = axis_letter(xml.name).ok_or_else(|| UrdfError::UnknownAxisLetter {
        at: at(),
        joint: xml.name.to_string(),
        hint: name_hint(xml.name),
    })?;
    let has_limit = child_element(xml.node, "limit").is_some();
    if !has_limit && xml.kind != JointKind::Continuous {
        let (units, hint) = match xml.kind {
            JointKind::Prismatic => ("metres", ""),
            _ => (
                "radians",
                "; use type=\"continuous\" for an unlimited rotary axis",
            ),
        };
        return Err(UrdfError::MissingLimit {
            at: at(),
            joint: xml.name.to_string(),
            kind: xml.kind.name(),
            units,
            hint,
        });
    }
    let axis = Vector3::from(joint.axis.xyz.0);
    if axis.norm() < 1e-12 {
        return Err(UrdfError::ZeroAxis {
            at: at(),
            joint: xml.name.to_string(),
        });
    }
    let limits = match xml.kind {
        JointKind::Continuous => None,
        _ => Some((joint.limit.lower, joint.limit.upper)),
    };
    if let (Some((lower, upper)), Some(limit)) = (limits, child_element(xml.node, "limit")) {
        // No machine-tool axis travels 100 m, and a limited rotary axis turns less than two
        // turns either way: larger numbers are mm or degrees written where URDF wants m, rad.
        let (plausible, found, expected, fix) = match xml.kind {
            JointKind::Prismatic => (
                MAX_PLAUSIBLE_STROKE_M,
                "mm",
                "metres",
                (lower * 1e-3, upper * 1e-3),
            ),
            _ => (
                MAX_PLAUSIBLE_TURN_RAD,
                "degrees",
                "radians",
                (lower.to_radians(), upper.to_radians()),
            ),
        };
        if lower.abs().max(upper.abs()) > plausible {
            return Err(UrdfError::ImplausibleLimits {
                at: ctx.at(limit),
                joint: xml.name.to_string(),
                limits: format!(
                    "{lower} … {upper}: this looks like {found}; expected {expected} (URDF's \
                     units), e.g. lower=\"{}\" upper=\"{}\"",
                    fix.0, fix.1
                ),
            });
        }
    }
    let kind = match xml.kind {
        JointKind::Prismatic => AxisKind::Linear,
        _ => AxisKind::Rotary,
    };
    Ok(JointSpec {
        letter: letter.as_char(),
        kind,
        origin,
        axis,
        limits,
    })
}

pub(super) fn name_hint(name: &str) -> &'static str {
    let upper = name.to_ascii_uppercase();
    if axis_letter(&upper).is_some() {
        "; axis letters are upper case"
    } else {
        ""
    }
}

/// Attaches the location of the joint a [`MachineError`] concerns (the robot element if none).
pub(super) fn locate_machine_error(ctx: &Ctx, model: &XmlModel, e: MachineError) -> UrdfError {
    let letter = match &e {
        MachineError::UnknownAxisLetter { name } => Some(name.clone()),
        MachineError::DuplicateAxis { letter }
        | MachineError::ZeroAxis { letter }
        | MachineError::KindMismatch { letter, .. }
        | MachineError::BadLimits { letter, .. }
        | MachineError::MissingLimits { letter } => Some(letter.to_string()),
        MachineError::NotFinite { what } => what
            .strip_prefix("axis ")
            .and_then(|rest| rest.chars().next())
            .map(String::from),
    };
    let node = letter
        .and_then(|l| model.joint_named(&l).map(|j| j.node))
        .unwrap_or(model.robot);
    UrdfError::Machine {
        at: ctx.at(node),
        cause: e,
    }
}
