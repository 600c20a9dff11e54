//! The URDF's XML as roxmltree reads it: elements with their places, joints, the checks of
//! what urdf-rs cannot tell (missing limits, duplicate names, malformed numbers, nesting).

use super::*;

/// The machine direction (0 = x, 1 = y, 2 = z) an axis letter names: X, U and A along x…
pub(super) fn named_direction(letter: char) -> usize {
    match letter {
        'X' | 'U' | 'A' => 0,
        'Y' | 'V' | 'B' => 1,
        _ => 2,
    }
}

/// Refuses, at the joint, two linear axes named for different directions moving along one
/// (no error model can tell them apart), and an axis without `<axis>` whose URDF default (1 0 0 in its frame) is not
/// the direction its letter names: a line left out, not a machine with Z along X.
pub(super) fn check_directions(
    ctx: &Ctx,
    model: &XmlModel,
    machine: &Machine,
) -> Result<(), UrdfError> {
    let world = |a: &mtcal_kinematics::machine::Axis| a.zero_rotation() * a.direction();
    let axes = machine.axes();
    for (i, a) in axes.iter().enumerate() {
        let letter = a.letter().as_char();
        let Some(joint) = model.joint_named(&letter.to_string()) else {
            continue;
        };
        let d = world(a);
        let show = |d: &nalgebra::Vector3<f64>| format!("({:.3} {:.3} {:.3})", d.x, d.y, d.z);
        let no_axis = !joint.node.children().any(|c| c.has_tag_name("axis"));
        if no_axis && d.iamax() != named_direction(letter) {
            return Err(UrdfError::Invalid {
                at: ctx.at(joint.node),
                message: format!(
                    "joint `{letter}` has no `<axis>`, and URDF's default (1 0 0 in the joint's \
                     frame) moves it along {} in the machine, not the direction its letter \
                     names: give it, e.g. `<axis xyz=\"{}\"/>`",
                    show(&d),
                    ["1 0 0", "0 1 0", "0 0 1"][named_direction(letter)]
                ),
            });
        }
        if a.kind() != mtcal_kinematics::AxisKind::Linear {
            continue;
        }
        // X and U (Y and V, Z and W) are parallel by name (a quill beside Z); X and Z are not.
        let twin = axes[..i].iter().find(|b| {
            b.kind() == mtcal_kinematics::AxisKind::Linear
                && named_direction(b.letter().as_char()) != named_direction(letter)
                && world(b).cross(&d).norm() < 1e-6
        });
        if let Some(b) = twin {
            return Err(UrdfError::Invalid {
                at: ctx.at(joint.node),
                message: format!(
                    "joint `{letter}` moves along {}, parallel to axis {}: two linear axes \
                     along one direction cannot be told apart{}",
                    show(&d),
                    b.letter().as_char(),
                    if no_axis {
                        " (it has no `<axis>`: URDF's default is 1 0 0)"
                    } else {
                        ""
                    }
                ),
            });
        }
    }
    Ok(())
}

/// Refuses, at the first element too deep, a document nested beyond [`MAX_URDF_DEPTH`]
/// (walked without recursion).
pub(super) fn check_depth(ctx: &Ctx) -> Result<(), UrdfError> {
    // Nodes come parent first: each one's depth is its parent's plus one.
    let mut depth = vec![0usize; ctx.doc.descendants().count()];
    for n in ctx.doc.descendants() {
        let Some(parent) = n.parent() else { continue };
        let d = depth[parent.id().get_usize()] + usize::from(n.is_element());
        depth[n.id().get_usize()] = d;
        if d > MAX_URDF_DEPTH {
            return Err(UrdfError::Syntax {
                at: ctx.at(n),
                message: format!(
                    "elements nested {d} deep (`<{}>`): a URDF nests a few deep, at most \
                     {MAX_URDF_DEPTH} are read",
                    n.tag_name().name()
                ),
            });
        }
    }
    Ok(())
}

pub(super) fn syntax_error(file: &Path, e: &roxmltree::Error) -> UrdfError {
    let pos = e.pos();
    UrdfError::Syntax {
        at: Location {
            file: file.to_path_buf(),
            line: pos.row as usize,
            column: pos.col as usize,
        },
        // roxmltree appends the position; the location already says it.
        message: e.to_string().replace(&format!(" at {pos}"), ""),
    }
}

/// The file and the parsed XML, to turn nodes into locations.
pub(super) struct Ctx<'d, 'i> {
    pub(super) file: &'d Path,
    pub(super) doc: &'d Document<'i>,
}

impl Ctx<'_, '_> {
    pub(super) fn at(&self, node: Node) -> Location {
        let pos = self.doc.text_pos_at(node.range().start);
        Location {
            file: self.file.to_path_buf(),
            line: pos.row as usize,
            column: pos.col as usize,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum JointKind {
    Fixed,
    Prismatic,
    Revolute,
    Continuous,
}

impl JointKind {
    pub(super) fn name(self) -> &'static str {
        match self {
            JointKind::Fixed => "fixed",
            JointKind::Prismatic => "prismatic",
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
        }
    }
}

/// A `<joint>` as roxmltree sees it, checked for the attributes and elements mtcal needs.
pub(super) struct XmlJoint<'d, 'i> {
    pub(super) node: Node<'d, 'i>,
    pub(super) name: &'d str,
    pub(super) kind: JointKind,
    pub(super) parent: (Node<'d, 'i>, &'d str),
    pub(super) child: (Node<'d, 'i>, &'d str),
}

impl XmlJoint<'_, '_> {
    pub(super) fn moving(&self) -> bool {
        self.kind != JointKind::Fixed
    }
}

/// The `<link>` and `<joint>` elements directly under `<robot>`, with unique names.
pub(super) struct XmlModel<'d, 'i> {
    pub(super) robot: Node<'d, 'i>,
    pub(super) links: Vec<(Node<'d, 'i>, &'d str)>,
    pub(super) link_index: HashMap<&'d str, usize>,
    pub(super) joints: Vec<XmlJoint<'d, 'i>>,
}

impl<'d, 'i> XmlModel<'d, 'i> {
    pub(super) fn collect(ctx: &Ctx<'d, 'i>) -> Result<Self, UrdfError> {
        let robot = ctx.doc.root_element();
        if robot.tag_name().name() != "robot" {
            return Err(UrdfError::Invalid {
                at: ctx.at(robot),
                message: format!(
                    "the root element is <{}>; a URDF file has <robot name=\"…\"> at its root",
                    robot.tag_name().name()
                ),
            });
        }
        let mut model = XmlModel {
            robot,
            links: Vec::new(),
            link_index: HashMap::new(),
            joints: Vec::new(),
        };
        let mut joint_lines: HashMap<&str, usize> = HashMap::new();
        for node in robot.children().filter(Node::is_element) {
            match node.tag_name().name() {
                "link" => model.add_link(ctx, node)?,
                "joint" => {
                    let joint = read_joint(ctx, node)?;
                    check_unique_joint(ctx, &joint, &mut joint_lines)?;
                    check_joint_numbers(ctx, &joint)?;
                    model.joints.push(joint);
                }
                _ => {}
            }
        }
        Ok(model)
    }

    pub(super) fn add_link(
        &mut self,
        ctx: &Ctx<'d, 'i>,
        node: Node<'d, 'i>,
    ) -> Result<(), UrdfError> {
        let name = required_attribute(
            ctx,
            node,
            "name",
            "name every link, e.g. <link name=\"x_slide\">",
        )?;
        if let Some(&first) = self.link_index.get(name) {
            return Err(UrdfError::DuplicateLink {
                at: ctx.at(node),
                name: name.to_string(),
                first_line: ctx.at(self.links[first].0).line,
            });
        }
        self.link_index.insert(name, self.links.len());
        self.links.push((node, name));
        Ok(())
    }

    pub(super) fn joint_named(&self, name: &str) -> Option<&XmlJoint<'d, 'i>> {
        self.joints.iter().find(|j| j.name == name)
    }
}

pub(super) fn required_attribute<'d>(
    ctx: &Ctx<'d, '_>,
    node: Node<'d, '_>,
    attribute: &'static str,
    hint: &'static str,
) -> Result<&'d str, UrdfError> {
    node.attribute(attribute)
        .ok_or_else(|| UrdfError::MissingAttribute {
            at: ctx.at(node),
            element: node.tag_name().name().to_string(),
            attribute,
            hint,
        })
}

pub(super) fn child_element<'d, 'i>(node: Node<'d, 'i>, tag: &str) -> Option<Node<'d, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == tag)
}

pub(super) fn read_joint<'d, 'i>(
    ctx: &Ctx<'d, 'i>,
    node: Node<'d, 'i>,
) -> Result<XmlJoint<'d, 'i>, UrdfError> {
    let name = required_attribute(
        ctx,
        node,
        "name",
        "name every joint; moving joints after their axis letter",
    )?;
    let kind_text = required_attribute(
        ctx,
        node,
        "type",
        "give the joint type: prismatic, revolute, continuous or fixed",
    )?;
    let kind = joint_kind(kind_text).map_err(|unknown| {
        let (joint, kind) = (name.to_string(), kind_text.to_string());
        let at = ctx.at(node);
        if unknown {
            UrdfError::UnknownJointType { at, joint, kind }
        } else {
            UrdfError::UnsupportedJointType { at, joint, kind }
        }
    })?;
    let parent = link_reference(ctx, node, name, "parent")?;
    let child = link_reference(ctx, node, name, "child")?;
    Ok(XmlJoint {
        node,
        name,
        kind,
        parent,
        child,
    })
}

/// The kind of a URDF joint type; `Err(false)` for URDF types machines cannot use (several
/// axes in one joint), `Err(true)` for strings that are no URDF type at all.
pub(super) fn joint_kind(text: &str) -> Result<JointKind, bool> {
    match text {
        "fixed" => Ok(JointKind::Fixed),
        "prismatic" => Ok(JointKind::Prismatic),
        "revolute" => Ok(JointKind::Revolute),
        "continuous" => Ok(JointKind::Continuous),
        "floating" | "planar" | "spherical" => Err(false),
        _ => Err(true),
    }
}

/// The `<parent link="…">` or `<child link="…">` of a joint.
pub(super) fn link_reference<'d, 'i>(
    ctx: &Ctx<'d, 'i>,
    joint: Node<'d, 'i>,
    name: &str,
    role: &'static str,
) -> Result<(Node<'d, 'i>, &'d str), UrdfError> {
    let hint = "a joint connects <parent link=\"…\"/> to <child link=\"…\"/>";
    let node = child_element(joint, role).ok_or_else(|| UrdfError::MissingElement {
        at: ctx.at(joint),
        joint: name.to_string(),
        element: role,
        hint,
    })?;
    let link = required_attribute(
        ctx,
        node,
        "link",
        "name the link, e.g. <parent link=\"frame\"/>",
    )?;
    Ok((node, link))
}

pub(super) fn check_unique_joint<'d>(
    ctx: &Ctx<'d, '_>,
    joint: &XmlJoint<'d, '_>,
    lines: &mut HashMap<&'d str, usize>,
) -> Result<(), UrdfError> {
    let at = ctx.at(joint.node);
    if let Some(&first_line) = lines.get(joint.name) {
        let letter = axis_letter(joint.name).filter(|_| joint.moving());
        return Err(match letter {
            Some(l) => UrdfError::DuplicateAxis {
                at,
                letter: l.as_char(),
                first_line,
            },
            None => UrdfError::DuplicateJoint {
                at,
                name: joint.name.to_string(),
                first_line,
            },
        });
    }
    lines.insert(joint.name, at.line);
    Ok(())
}

/// The axis letter a joint name stands for: exactly one of X Y Z U V W A B C.
pub(super) fn axis_letter(name: &str) -> Option<AxisLetter> {
    let mut chars = name.chars();
    let c = chars.next()?;
    chars.next().is_none().then(|| AxisLetter::new(c)).flatten()
}

/// urdf-rs skips tokens it cannot parse, accepts `nan`/`inf` and reports a missing attribute
/// without saying where; check what mtcal and `check_urdf` need.
pub(super) fn check_joint_numbers(ctx: &Ctx, joint: &XmlJoint) -> Result<(), UrdfError> {
    let checks: [(&str, &str, usize); 7] = [
        ("origin", "xyz", 3),
        ("origin", "rpy", 3),
        ("axis", "xyz", 3),
        ("limit", "lower", 1),
        ("limit", "upper", 1),
        ("limit", "effort", 1),
        ("limit", "velocity", 1),
    ];
    if let Some(limit) = child_element(joint.node, "limit") {
        for attribute in ["effort", "velocity"] {
            required_attribute(
                ctx,
                limit,
                attribute,
                "URDF requires effort and velocity limits (mtcal ignores their values)",
            )?;
        }
    }
    for (tag, attribute, count) in checks {
        let Some(node) = child_element(joint.node, tag) else {
            continue;
        };
        let Some(value) = node.attribute(attribute) else {
            continue;
        };
        let numbers: Vec<f64> = value
            .split_whitespace()
            .filter_map(|t| t.parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .collect();
        if numbers.len() != count || value.split_whitespace().count() != count {
            return Err(UrdfError::BadNumber {
                at: ctx.at(node),
                element: tag,
                attribute,
                value: value.to_string(),
                expected: if count == 3 {
                    "three finite numbers separated by spaces, e.g. \"0 0 0.1\""
                } else {
                    "one finite number"
                },
            });
        }
    }
    Ok(())
}
