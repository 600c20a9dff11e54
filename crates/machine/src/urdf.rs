//! Machines as standard URDF files: load them into a [`Machine`], write a [`Machine`] back out.
//!
//! The rules (FORMATS.md, "Machine"): the root link is the machine frame; one branch leaves it
//! for a link named `workpiece`, the other for a link named `tool` (the tool point). Moving
//! joints are `prismatic`, `revolute` or `continuous` (a revolute joint without limits) and are
//! named after their axis letter (`X`…`W` prismatic, `A` `B` `C` rotary). Files are in SI
//! units, as every URDF tool expects.
//!
//! Fixed joints are collapsed: a moving joint's origin becomes the product of the fixed-joint
//! origins since the previous moving joint times its own origin, and the branch's end transform
//! the product of the fixed origins after the last moving joint. Fixed joints and links off both
//! branches (collision-only bodies, sensors) are allowed and ignored; a moving joint off both
//! branches is an error, because mtcal would silently drop an axis.
//!
//! urdf-rs reads the model (values, URDF 1.1 quaternions, URDF 1.2 limit rules); roxmltree reads
//! the same text again for what urdf-rs cannot tell: the line and column of every element, a
//! missing `<limit>` (urdf-rs silently defaults it to zeros), duplicate names, malformed numbers
//! (urdf-rs skips unparsable tokens). Every error names the file, line and column of the element
//! it concerns and says what was expected; no input makes the loader panic.

use mtcal_kinematics::machine::{
    AxisKind, BranchSpec, JointSpec, Machine, MachineError, MachineSpec, Side,
};
use mtcal_kinematics::names::AxisLetter;
use mtcal_kinematics::rigid::Rigid;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use roxmltree::{Document, Node};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

pub use crate::Location;

/// Why a URDF file does not describe a machine. Every variant but [`UrdfError::Io`] carries the
/// location of the offending element.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum UrdfError {
    #[error("{}: cannot read the URDF file: {message}", file.display())]
    Io { file: PathBuf, message: String },
    #[error("{at}: XML syntax error: {message}")]
    Syntax { at: Location, message: String },
    #[error("{at}: not a valid URDF: {message}")]
    Invalid { at: Location, message: String },
    #[error("{at}: <{element}> has no `{attribute}` attribute; {hint}")]
    MissingAttribute {
        at: Location,
        element: String,
        attribute: &'static str,
        hint: &'static str,
    },
    #[error("{at}: joint `{joint}` has no <{element}> element; {hint}")]
    MissingElement {
        at: Location,
        joint: String,
        element: &'static str,
        hint: &'static str,
    },
    #[error("{at}: <{element} {attribute}=\"{value}\"> is not valid: expected {expected}")]
    BadNumber {
        at: Location,
        element: &'static str,
        attribute: &'static str,
        value: String,
        expected: &'static str,
    },
    #[error(
        "{at}: link `{name}` is defined twice (first at line {first_line}); link names must be unique"
    )]
    DuplicateLink {
        at: Location,
        name: String,
        first_line: usize,
    },
    #[error(
        "{at}: joint `{name}` is defined twice (first at line {first_line}); joint names must be unique"
    )]
    DuplicateJoint {
        at: Location,
        name: String,
        first_line: usize,
    },
    #[error(
        "{at}: axis {letter} is defined twice (first at line {first_line}); each axis letter may \
         name one joint only"
    )]
    DuplicateAxis {
        at: Location,
        letter: char,
        first_line: usize,
    },
    #[error(
        "{at}: joint `{joint}` has type `{kind}`, which machines cannot use; model each axis as a \
         prismatic, revolute or continuous joint and rigid connections as fixed joints"
    )]
    UnsupportedJointType {
        at: Location,
        joint: String,
        kind: String,
    },
    #[error(
        "{at}: joint `{joint}` has unknown type `{kind}`; expected prismatic, revolute, \
         continuous or fixed"
    )]
    UnknownJointType {
        at: Location,
        joint: String,
        kind: String,
    },
    #[error(
        "{at}: joint `{joint}` names {role} link `{link}`, which is not defined; add \
         <link name=\"{link}\"/> or fix the name"
    )]
    UnknownLink {
        at: Location,
        joint: String,
        role: &'static str,
        link: String,
    },
    #[error(
        "{at}: link `{link}` is the child of joint `{first}` and of joint `{second}`; a URDF is \
         a tree, so each link has one parent joint"
    )]
    TwoParents {
        at: Location,
        link: String,
        first: String,
        second: String,
    },
    #[error(
        "{at}: the joints form a cycle through links {links}; a URDF is a tree: remove one of these joints"
    )]
    Cycle { at: Location, links: String },
    #[error(
        "{at}: links {roots} have no parent joint; a URDF has exactly one root link (the \
         machine frame): attach the others to it with fixed joints or remove them"
    )]
    MultipleRoots { at: Location, roots: String },
    #[error(
        "{at}: no link named `tool`; the tool branch must end in a link named `tool` (the tool \
         point: tool tip or ball centre)"
    )]
    MissingTool { at: Location },
    #[error(
        "{at}: no link named `workpiece`; the workpiece branch must end in a link named \
         `workpiece` (the workpiece frame on the table)"
    )]
    MissingWorkpiece { at: Location },
    #[error(
        "{at}: link `{lower}` hangs below link `{upper}`; `tool` and `workpiece` must end two \
         separate branches that leave the root link (the machine frame)"
    )]
    SameBranch {
        at: Location,
        upper: &'static str,
        lower: &'static str,
    },
    #[error(
        "{at}: moving joint `{joint}` carries both the tool and the workpiece, so it cannot \
         move one relative to the other; make it fixed, or attach one branch to the frame"
    )]
    SharedMovingJoint { at: Location, joint: String },
    #[error(
        "{at}: moving joint `{joint}` lies on neither the tool nor the workpiece branch; every \
         axis must move the tool or the workpiece: attach it to a branch or make it fixed"
    )]
    MovingJointOffBranch { at: Location, joint: String },
    #[error(
        "{at}: moving joint `{joint}` must be named after its axis letter: X, Y, Z, U, V, W \
         (prismatic) or A, B, C (revolute or continuous){hint}"
    )]
    UnknownAxisLetter {
        at: Location,
        joint: String,
        hint: &'static str,
    },
    #[error(
        "{at}: {kind} joint `{joint}` has no <limit>; add <limit lower=\"…\" upper=\"…\" \
         effort=\"…\" velocity=\"…\"/> in {units}{hint}"
    )]
    MissingLimit {
        at: Location,
        joint: String,
        kind: &'static str,
        units: &'static str,
        hint: &'static str,
    },
    #[error(
        "{at}: joint `{joint}` has a zero axis vector; give its direction of motion, e.g. \
         <axis xyz=\"1 0 0\"/>"
    )]
    ZeroAxis { at: Location, joint: String },
    #[error("{at}: joint `{joint}` has limits {limits}")]
    ImplausibleLimits {
        at: Location,
        joint: String,
        /// The limits, what they look like and how to write them.
        limits: String,
    },
    #[error("{at}: {cause}")]
    Machine { at: Location, cause: MachineError },
}

impl UrdfError {
    /// Where the error is, unless the file could not be read at all.
    pub fn location(&self) -> Option<&Location> {
        use UrdfError::*;
        match self {
            Io { .. } => None,
            Syntax { at, .. }
            | Invalid { at, .. }
            | MissingAttribute { at, .. }
            | MissingElement { at, .. }
            | BadNumber { at, .. }
            | DuplicateLink { at, .. }
            | DuplicateJoint { at, .. }
            | DuplicateAxis { at, .. }
            | UnsupportedJointType { at, .. }
            | UnknownJointType { at, .. }
            | UnknownLink { at, .. }
            | TwoParents { at, .. }
            | Cycle { at, .. }
            | MultipleRoots { at, .. }
            | MissingTool { at }
            | MissingWorkpiece { at }
            | SameBranch { at, .. }
            | SharedMovingJoint { at, .. }
            | MovingJointOffBranch { at, .. }
            | UnknownAxisLetter { at, .. }
            | MissingLimit { at, .. }
            | ZeroAxis { at, .. }
            | ImplausibleLimits { at, .. }
            | Machine { at, .. } => Some(at),
        }
    }
}

/// Loads a machine from a URDF file.
pub fn load_urdf_file(path: &Path) -> Result<Machine, UrdfError> {
    let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
    if bytes > MAX_URDF_BYTES {
        return Err(UrdfError::Io {
            file: path.to_path_buf(),
            message: format!(
                "{bytes} bytes: a machine's URDF is a few kilobytes, at most {MAX_URDF_BYTES} \
                 are read"
            ),
        });
    }
    let text = std::fs::read_to_string(path).map_err(|e| UrdfError::Io {
        file: path.to_path_buf(),
        message: e.to_string(),
    })?;
    load_urdf_str(&text, path)
}

/// The deepest nesting of elements a URDF may have. A machine's is 3 (`robot`, `joint`,
/// `limit`; a `visual`'s geometry 5); the readers after the XML parser recurse, and a file
/// nested thousands deep would overflow their stack.
pub const MAX_URDF_DEPTH: usize = 64;

/// The largest URDF file read (bytes): meshes are referenced, not inlined.
pub const MAX_URDF_BYTES: u64 = 64 << 20;

/// The most XML nodes (elements, text, comments) a URDF may have: a machine of a hundred
/// links with visuals has a few thousand.
pub const MAX_URDF_NODES: u32 = 1_000_000;

/// Loads a machine from URDF text; `file` only names the source in error messages.
pub fn load_urdf_str(text: &str, file: &Path) -> Result<Machine, UrdfError> {
    let options = roxmltree::ParsingOptions {
        nodes_limit: MAX_URDF_NODES,
        ..Default::default()
    };
    let doc = Document::parse_with_options(text, options).map_err(|e| syntax_error(file, &e))?;
    let ctx = Ctx { file, doc: &doc };
    check_depth(&ctx)?;
    let model = XmlModel::collect(&ctx)?;
    let tree = Tree::build(&ctx, &model)?;
    let branches = Branches::find(&ctx, &model, &tree)?;
    let robot = urdf_rs::read_from_string(text).map_err(|e| UrdfError::Invalid {
        at: ctx.at(model.robot),
        message: e.to_string(),
    })?;
    let by_name: HashMap<&str, &urdf_rs::Joint> =
        robot.joints.iter().map(|j| (j.name.as_str(), j)).collect();
    let spec = MachineSpec {
        name: model
            .robot
            .attribute("name")
            .unwrap_or_default()
            .to_string(),
        workpiece: branch_spec(&ctx, &model, &by_name, &branches.workpiece)?,
        tool: branch_spec(&ctx, &model, &by_name, &branches.tool)?,
    };
    let machine = Machine::try_new(&spec).map_err(|e| locate_machine_error(&ctx, &model, e))?;
    check_directions(&ctx, &model, &machine)?;
    Ok(machine)
}

/// The machine direction (0 = x, 1 = y, 2 = z) an axis letter names: X, U and A along x…
fn named_direction(letter: char) -> usize {
    match letter {
        'X' | 'U' | 'A' => 0,
        'Y' | 'V' | 'B' => 1,
        _ => 2,
    }
}

/// Refuses, at the joint, two linear axes named for different directions moving along one
/// (no error model can tell them apart), and an axis without `<axis>` whose URDF default (1 0 0 in its frame) is not
/// the direction its letter names: a line left out, not a machine with Z along X.
fn check_directions(ctx: &Ctx, model: &XmlModel, machine: &Machine) -> Result<(), UrdfError> {
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
fn check_depth(ctx: &Ctx) -> Result<(), UrdfError> {
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

fn syntax_error(file: &Path, e: &roxmltree::Error) -> UrdfError {
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
struct Ctx<'d, 'i> {
    file: &'d Path,
    doc: &'d Document<'i>,
}

impl Ctx<'_, '_> {
    fn at(&self, node: Node) -> Location {
        let pos = self.doc.text_pos_at(node.range().start);
        Location {
            file: self.file.to_path_buf(),
            line: pos.row as usize,
            column: pos.col as usize,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum JointKind {
    Fixed,
    Prismatic,
    Revolute,
    Continuous,
}

impl JointKind {
    fn name(self) -> &'static str {
        match self {
            JointKind::Fixed => "fixed",
            JointKind::Prismatic => "prismatic",
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
        }
    }
}

/// A `<joint>` as roxmltree sees it, checked for the attributes and elements mtcal needs.
struct XmlJoint<'d, 'i> {
    node: Node<'d, 'i>,
    name: &'d str,
    kind: JointKind,
    parent: (Node<'d, 'i>, &'d str),
    child: (Node<'d, 'i>, &'d str),
}

impl XmlJoint<'_, '_> {
    fn moving(&self) -> bool {
        self.kind != JointKind::Fixed
    }
}

/// The `<link>` and `<joint>` elements directly under `<robot>`, with unique names.
struct XmlModel<'d, 'i> {
    robot: Node<'d, 'i>,
    links: Vec<(Node<'d, 'i>, &'d str)>,
    link_index: HashMap<&'d str, usize>,
    joints: Vec<XmlJoint<'d, 'i>>,
}

impl<'d, 'i> XmlModel<'d, 'i> {
    fn collect(ctx: &Ctx<'d, 'i>) -> Result<Self, UrdfError> {
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

    fn add_link(&mut self, ctx: &Ctx<'d, 'i>, node: Node<'d, 'i>) -> Result<(), UrdfError> {
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

    fn joint_named(&self, name: &str) -> Option<&XmlJoint<'d, 'i>> {
        self.joints.iter().find(|j| j.name == name)
    }
}

fn required_attribute<'d>(
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

fn child_element<'d, 'i>(node: Node<'d, 'i>, tag: &str) -> Option<Node<'d, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == tag)
}

fn read_joint<'d, 'i>(
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
fn joint_kind(text: &str) -> Result<JointKind, bool> {
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
fn link_reference<'d, 'i>(
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

fn check_unique_joint<'d>(
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
fn axis_letter(name: &str) -> Option<AxisLetter> {
    let mut chars = name.chars();
    let c = chars.next()?;
    chars.next().is_none().then(|| AxisLetter::new(c)).flatten()
}

/// urdf-rs skips tokens it cannot parse, accepts `nan`/`inf` and reports a missing attribute
/// without saying where; check what mtcal and `check_urdf` need.
fn check_joint_numbers(ctx: &Ctx, joint: &XmlJoint) -> Result<(), UrdfError> {
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

/// The link tree: each link's parent joint, checked for dangling names, two parents and cycles.
struct Tree {
    /// Per link (index into `XmlModel::links`): the joint whose child it is.
    parent_joint: Vec<Option<usize>>,
    /// Per joint: (parent link, child link).
    ends: Vec<(usize, usize)>,
}

impl Tree {
    fn build(ctx: &Ctx, model: &XmlModel) -> Result<Self, UrdfError> {
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
    fn check_cycles(&self, ctx: &Ctx, model: &XmlModel) -> Result<(), UrdfError> {
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
    fn path_to(&self, link: usize) -> Vec<usize> {
        let mut path = Vec::new();
        let mut l = link;
        while let Some(j) = self.parent_joint[l] {
            path.push(j);
            l = self.ends[j].0;
        }
        path.reverse();
        path
    }

    fn roots(&self) -> Vec<usize> {
        (0..self.parent_joint.len())
            .filter(|&l| self.parent_joint[l].is_none())
            .collect()
    }
}

fn resolve_link(
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
struct Branches {
    workpiece: Vec<usize>,
    tool: Vec<usize>,
}

impl Branches {
    fn find(ctx: &Ctx, model: &XmlModel, tree: &Tree) -> Result<Self, UrdfError> {
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
    fn check_separate(
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

    fn check_all_axes_used(&self, ctx: &Ctx, model: &XmlModel) -> Result<(), UrdfError> {
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
fn branch_spec(
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
fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
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

fn moving_joint(
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

fn name_hint(name: &str) -> &'static str {
    let upper = name.to_ascii_uppercase();
    if axis_letter(&upper).is_some() {
        "; axis letters are upper case"
    } else {
        ""
    }
}

/// Attaches the location of the joint a [`MachineError`] concerns (the robot element if none).
fn locate_machine_error(ctx: &Ctx, model: &XmlModel, e: MachineError) -> UrdfError {
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

/// Placeholder effort (N or N·m) and velocity (m/s or rad/s) for written `<limit>` elements:
/// URDF requires them; mtcal does not use them.
const WRITTEN_EFFORT: f64 = 1000.0;
const WRITTEN_VELOCITY: f64 = 1.0;

/// Writes a machine as a standard URDF that `check_urdf`, pinocchio and [`load_urdf_str`] read.
///
/// Links: the root `frame`, one link per axis (`x_slide` for linear axes, `c_table` for rotary
/// axes of the workpiece branch, `b_head` for rotary axes of the tool branch), `workpiece` and
/// `tool`, each hung on a fixed joint (`workpiece_mount`, `tool_mount`) carrying the branch's
/// end transform. Every link but the root gets a small placeholder `<inertial>`: some ROS tools
/// (KDL) reject links without mass, and KDL warns about a root link with one. Numbers are written
/// in Rust's shortest round-trip form, so loading the file gives back the same machine.
/// `comment` goes into an XML comment at the top (`--`, which XML comments forbid, is split).
pub fn write_urdf(machine: &Machine, comment: Option<&str>) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?>\n");
    if let Some(c) = comment {
        let _ = writeln!(out, "<!--\n{}\n-->", comment_safe(c));
    }
    let _ = writeln!(out, "<robot name=\"{}\">", xml_escape(machine.name()));
    out.push_str("  <link name=\"frame\"/>\n");
    for side in [Side::Workpiece, Side::Tool] {
        write_branch(&mut out, machine, side);
    }
    out.push_str("</robot>\n");
    out
}

fn write_branch(out: &mut String, machine: &Machine, side: Side) {
    let branch = machine.branch(side);
    let mut parent = String::from("frame");
    for &i in branch.joints() {
        let axis = &machine.axes()[i];
        let child = axis_link_name(axis.letter(), axis.kind(), side);
        write_link(out, &child);
        write_joint(out, machine, i, &parent, &child);
        parent = child;
    }
    let (end, mount) = match side {
        Side::Workpiece => ("workpiece", "workpiece_mount"),
        Side::Tool => ("tool", "tool_mount"),
    };
    write_link(out, end);
    let _ = writeln!(out, "  <joint name=\"{mount}\" type=\"fixed\">");
    write_origin(out, branch.end());
    let _ = writeln!(
        out,
        "    <parent link=\"{parent}\"/>\n    <child link=\"{end}\"/>"
    );
    out.push_str("  </joint>\n");
}

fn axis_link_name(letter: AxisLetter, kind: AxisKind, side: Side) -> String {
    let body = match (kind, side) {
        (AxisKind::Linear, _) => "slide",
        (AxisKind::Rotary, Side::Workpiece) => "table",
        (AxisKind::Rotary, Side::Tool) => "head",
    };
    format!("{}_{body}", letter.as_char().to_ascii_lowercase())
}

fn write_link(out: &mut String, name: &str) {
    let _ = writeln!(
        out,
        "  <link name=\"{name}\">\n    <inertial>\n      <mass value=\"1\"/>\n      \
         <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\n    \
         </inertial>\n  </link>"
    );
}

fn write_joint(out: &mut String, machine: &Machine, i: usize, parent: &str, child: &str) {
    let axis = &machine.axes()[i];
    let kind = match (axis.kind(), axis.limits()) {
        (AxisKind::Linear, _) => "prismatic",
        (AxisKind::Rotary, Some(_)) => "revolute",
        (AxisKind::Rotary, None) => "continuous",
    };
    let _ = writeln!(out, "  <joint name=\"{}\" type=\"{kind}\">", axis.letter());
    write_origin(out, axis.origin());
    let _ = writeln!(
        out,
        "    <parent link=\"{parent}\"/>\n    <child link=\"{child}\"/>"
    );
    let _ = writeln!(out, "    <axis xyz=\"{}\"/>", vec3(axis.direction()));
    let (effort, velocity) = (num(WRITTEN_EFFORT), num(WRITTEN_VELOCITY));
    match axis.limits() {
        Some((lo, hi)) => {
            let (lo, hi) = (num(lo), num(hi));
            let _ = writeln!(
                out,
                "    <limit lower=\"{lo}\" upper=\"{hi}\" effort=\"{effort}\" velocity=\"{velocity}\"/>"
            );
        }
        None => {
            let _ = writeln!(
                out,
                "    <limit effort=\"{effort}\" velocity=\"{velocity}\"/>"
            );
        }
    }
    out.push_str("  </joint>\n");
}

fn write_origin(out: &mut String, t: &Rigid) {
    let rpy = rpy_from_matrix(&t.r);
    let _ = writeln!(
        out,
        "    <origin xyz=\"{}\" rpy=\"{}\"/>",
        vec3(&t.t),
        vec3(&Vector3::from(rpy))
    );
}

/// URDF roll, pitch, yaw of a rotation `R = Rz(yaw)·Ry(pitch)·Rx(roll)`, accurate to rounding
/// everywhere, including near pitch = ±90° (a horizontal spindle) where the textbook
/// `asin` formula loses half the digits: pitch comes from `atan2`, and roll from what is left
/// after yaw and pitch are taken out, so an ill-determined yaw is compensated exactly.
pub fn rpy_from_matrix(r: &Matrix3<f64>) -> [f64; 3] {
    let cos_pitch = r[(0, 0)].hypot(r[(1, 0)]);
    let pitch = (-r[(2, 0)]).atan2(cos_pitch);
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    let taken_out = Rotation3::from_euler_angles(0.0, pitch, yaw);
    let rest = taken_out.matrix().transpose() * r;
    let roll = rest[(2, 1)].atan2(rest[(2, 2)]);
    [roll, pitch, yaw]
}

fn vec3(v: &Vector3<f64>) -> String {
    format!("{} {} {}", num(v.x), num(v.y), num(v.z))
}

/// Shortest decimal that reads back to the same `f64`; exponent form for very small or large
/// magnitudes, which Rust's plain form would spell out digit by digit.
fn num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-5..1e9).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// XML comments may not contain `--` nor end in `-`.
fn comment_safe(s: &str) -> String {
    let mut t = s.to_string();
    while t.contains("--") {
        t = t.replace("--", "- -");
    }
    if t.ends_with('-') {
        t.push(' ');
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::{Reading, nominal_machine, parse_code};
    use proptest::prelude::*;

    const LIMIT: &str = r#"<limit lower="-0.3" upper="0.3" effort="1" velocity="1"/>"#;

    /// A small valid machine, one element per line so that tests can replace a line and know
    /// where the error must point. Line 13 is spare for additions.
    fn base_lines() -> Vec<String> {
        let z_limit = r#"<limit lower="-0.5" upper="0" effort="1" velocity="1"/>"#;
        vec![
            r#"<robot name="t">"#.into(),
            r#"<link name="frame"/>"#.into(),
            r#"<link name="y_slide"/>"#.into(),
            r#"<link name="x_slide"/>"#.into(),
            r#"<link name="workpiece"/>"#.into(),
            r#"<link name="z_slide"/>"#.into(),
            r#"<link name="tool"/>"#.into(),
            format!(
                r#"<joint name="Y" type="prismatic"><parent link="frame"/><child link="y_slide"/><axis xyz="0 -1 0"/>{LIMIT}</joint>"#
            ),
            format!(
                r#"<joint name="X" type="prismatic"><origin xyz="0 0 0.1"/><parent link="y_slide"/><child link="x_slide"/><axis xyz="-1 0 0"/>{LIMIT}</joint>"#
            ),
            r#"<joint name="wp" type="fixed"><origin xyz="0 0 0.05"/><parent link="x_slide"/><child link="workpiece"/></joint>"#.into(),
            format!(
                r#"<joint name="Z" type="prismatic"><origin xyz="0 0.4 0.8"/><parent link="frame"/><child link="z_slide"/><axis xyz="0 0 1"/>{z_limit}</joint>"#
            ),
            r#"<joint name="spindle" type="fixed"><origin xyz="0 -0.4 -0.2"/><parent link="z_slide"/><child link="tool"/></joint>"#.into(),
            String::new(),
            "</robot>".into(),
        ]
    }

    /// The base file with 1-based lines replaced.
    fn with(edits: &[(usize, &str)]) -> String {
        let mut lines = base_lines();
        for &(n, text) in edits {
            lines[n - 1] = text.to_string();
        }
        lines.join("\n")
    }

    fn moving(name: &str, kind: &str, parent: &str, child: &str, extra: &str) -> String {
        format!(
            r#"<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>{extra}</joint>"#
        )
    }

    enum Expect {
        Ok(&'static str),
        /// Message substring, and (line, text at the column) unless the error is file-wide.
        Err(&'static str, Option<(usize, &'static str)>),
    }

    /// Loads `text` and compares with the expectation: the topology code when it loads, else
    /// the message and the location of the offending element.
    fn check(case: &str, text: &str, expect: Expect) {
        let result = load_urdf_str(text, Path::new("m.urdf"));
        match (expect, result) {
            (Expect::Ok(code), Ok(m)) => assert_eq!(m.topology_code(), code, "{case}"),
            (Expect::Err(part, at), Err(e)) => {
                let msg = e.to_string();
                println!("{case}: {msg}");
                assert!(msg.contains(part), "{case}: {msg:?} lacks {part:?}");
                let loc = e.location().expect("located");
                assert!(msg.starts_with(&format!("m.urdf:{}:{}: ", loc.line, loc.column)));
                if let Some((line, marker)) = at {
                    let column = text.lines().nth(line - 1).unwrap().find(marker).unwrap() + 1;
                    assert_eq!((loc.line, loc.column), (line, column), "{case}: {msg}");
                }
            }
            (Expect::Ok(_), Err(e)) => panic!("{case}: expected to load, got {e}"),
            (Expect::Err(part, _), Ok(_)) => panic!("{case}: expected error {part:?}, loaded"),
        }
    }

    #[test]
    fn loads_valid_files_and_rejects_each_invalid_case_where_it_is() {
        use Expect::{Err as E, Ok as O};
        let stray_w = format!(
            r#"<link name="probe"/>{}"#,
            moving("W", "prismatic", "frame", "probe", LIMIT)
        );
        let cycle = concat!(
            r#"<link name="a"/><link name="b"/>"#,
            r#"<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>"#,
            r#"<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>"#
        );
        let b_head = |extra: &str| moving("B", "revolute", "z_slide", "tool", extra);
        let y_with = |extra: &str| moving("Y", "prismatic", "frame", "y_slide", extra);
        let cases: Vec<(&str, String, Expect)> = vec![
            ("valid", with(&[]), O("wXYFZt")),
            (
                "continuous head",
                with(&[(
                    12,
                    &moving(
                        "C",
                        "continuous",
                        "z_slide",
                        "tool",
                        r#"<axis xyz="0 0 1"/>"#,
                    ),
                )]),
                O("wXYFZCt"),
            ),
            (
                "a rotary axis without <axis>, URDF's default not its letter's",
                with(&[(12, &moving("C", "continuous", "z_slide", "tool", ""))]),
                E(
                    "joint `C` has no `<axis>`, and URDF's default",
                    Some((12, "<joint")),
                ),
            ),
            (
                "a linear axis without <axis>, moving along X",
                with(&[(8, &y_with(LIMIT))]),
                E(
                    "joint `Y` has no `<axis>`, and URDF's default",
                    Some((8, "<joint")),
                ),
            ),
            (
                "two linear axes along one direction",
                with(&[(8, &y_with(&format!(r#"<axis xyz="1 0 0"/>{LIMIT}"#)))]),
                E(
                    "two linear axes along one direction cannot be told apart",
                    None,
                ),
            ),
            (
                "collision-only link off the branches",
                with(&[(
                    13,
                    r#"<link name="guard"/><joint name="g" type="fixed"><parent link="frame"/><child link="guard"/></joint>"#,
                )]),
                O("wXYFZt"),
            ),
            (
                "syntax error",
                with(&[(13, "<link name=\"a\">")]),
                E("XML syntax error", Some((14, "</robot>"))),
            ),
            (
                "not a robot",
                "<robt name=\"t\"/>".into(),
                E("a URDF file has <robot", Some((1, "<robt"))),
            ),
            (
                "missing tool",
                with(&[
                    (7, r#"<link name="tip"/>"#),
                    (
                        12,
                        r#"<joint name="s" type="fixed"><parent link="z_slide"/><child link="tip"/></joint>"#,
                    ),
                ]),
                E("no link named `tool`", Some((1, "<robot"))),
            ),
            (
                "missing workpiece",
                with(&[
                    (5, r#"<link name="part"/>"#),
                    (
                        10,
                        r#"<joint name="wp" type="fixed"><parent link="x_slide"/><child link="part"/></joint>"#,
                    ),
                ]),
                E("no link named `workpiece`", Some((1, "<robot"))),
            ),
            (
                "moving joint off both branches",
                with(&[(13, &stray_w)]),
                E(
                    "lies on neither the tool nor the workpiece branch",
                    Some((13, "<joint")),
                ),
            ),
            (
                "unknown axis letter",
                with(&[(
                    9,
                    &moving("joint1", "prismatic", "y_slide", "x_slide", LIMIT),
                )]),
                E("must be named after its axis letter", Some((9, "<joint"))),
            ),
            (
                "lower-case letter",
                with(&[(9, &moving("x", "prismatic", "y_slide", "x_slide", LIMIT))]),
                E("axis letters are upper case", Some((9, "<joint"))),
            ),
            (
                "duplicate axis",
                with(&[(11, &moving("X", "prismatic", "frame", "z_slide", LIMIT))]),
                E(
                    "axis X is defined twice (first at line 9)",
                    Some((11, "<joint")),
                ),
            ),
            (
                "duplicate joint name",
                with(&[(
                    12,
                    r#"<joint name="wp" type="fixed"><parent link="z_slide"/><child link="tool"/></joint>"#,
                )]),
                E(
                    "joint `wp` is defined twice (first at line 10)",
                    Some((12, "<joint")),
                ),
            ),
            (
                "duplicate link",
                with(&[(13, r#"<link name="tool"/>"#)]),
                E(
                    "link `tool` is defined twice (first at line 7)",
                    Some((13, "<link")),
                ),
            ),
            (
                "prismatic without limit",
                with(&[(8, &y_with(r#"<axis xyz="0 -1 0"/>"#))]),
                E("prismatic joint `Y` has no <limit>", Some((8, "<joint"))),
            ),
            (
                "revolute without limit",
                with(&[(12, &b_head(r#"<axis xyz="0 1 0"/>"#))]),
                E("use type=\"continuous\"", Some((12, "<joint"))),
            ),
            (
                "limit without velocity",
                with(&[(8, &y_with(r#"<limit lower="-1" upper="1" effort="1"/>"#))]),
                E("<limit> has no `velocity` attribute", Some((8, "<limit"))),
            ),
            (
                "zero axis",
                with(&[(8, &y_with(&format!(r#"<axis xyz="0 0 0"/>{LIMIT}"#)))]),
                E("zero axis vector", Some((8, "<joint"))),
            ),
            (
                "malformed axis",
                with(&[(8, &y_with(&format!(r#"<axis xyz="0 -1"/>{LIMIT}"#)))]),
                E("three finite numbers", Some((8, "<axis"))),
            ),
            (
                "non-numeric origin",
                with(&[(
                    10,
                    r#"<joint name="wp" type="fixed"><origin xyz="0 x 0.05"/><parent link="x_slide"/><child link="workpiece"/></joint>"#,
                )]),
                E(
                    "<origin xyz=\"0 x 0.05\"> is not valid",
                    Some((10, "<origin")),
                ),
            ),
            (
                "nan limit",
                with(&[(
                    8,
                    &y_with(r#"<limit lower="nan" upper="1" effort="1" velocity="1"/>"#),
                )]),
                E("one finite number", Some((8, "<limit"))),
            ),
            (
                "inverted limits",
                with(&[(
                    8,
                    &y_with(
                        r#"<axis xyz="0 -1 0"/><limit lower="0.3" upper="-0.3" effort="1" velocity="1"/>"#,
                    ),
                )]),
                E(
                    "limits must be finite with lower < upper",
                    Some((8, "<joint")),
                ),
            ),
            (
                "kind mismatch",
                with(&[(8, &moving("A", "prismatic", "frame", "y_slide", LIMIT))]),
                E(
                    "A is a rotary axis letter but the joint is prismatic",
                    Some((8, "<joint")),
                ),
            ),
            (
                "link with two parents",
                with(&[(
                    13,
                    r#"<joint name="extra" type="fixed"><parent link="frame"/><child link="x_slide"/></joint>"#,
                )]),
                E(
                    "link `x_slide` is the child of joint `X` and of joint `extra`",
                    Some((13, "<joint")),
                ),
            ),
            (
                "two roots",
                with(&[(13, r#"<link name="stray"/>"#)]),
                E(
                    "links `frame`, `stray` have no parent joint",
                    Some((13, "<link")),
                ),
            ),
            (
                "cycle",
                with(&[(13, cycle)]),
                E(
                    "cycle through links `a`, `b`",
                    Some((13, "<joint name=\"ba\"")),
                ),
            ),
            (
                "unknown parent link",
                with(&[(
                    10,
                    r#"<joint name="wp" type="fixed"><parent link="table"/><child link="workpiece"/></joint>"#,
                )]),
                E(
                    "names parent link `table`, which is not defined",
                    Some((10, "<parent")),
                ),
            ),
            (
                "unknown child link",
                with(&[(
                    12,
                    r#"<joint name="spindle" type="fixed"><parent link="z_slide"/><child link="tol"/></joint>"#,
                )]),
                E("names child link `tol`", Some((12, "<child"))),
            ),
            (
                "missing parent element",
                with(&[(
                    10,
                    r#"<joint name="wp" type="fixed"><child link="workpiece"/></joint>"#,
                )]),
                E("joint `wp` has no <parent> element", Some((10, "<joint"))),
            ),
            (
                "missing type",
                with(&[(
                    10,
                    r#"<joint name="wp"><parent link="x_slide"/><child link="workpiece"/></joint>"#,
                )]),
                E("<joint> has no `type` attribute", Some((10, "<joint"))),
            ),
            (
                "floating joint",
                with(&[(12, &moving("spindle", "floating", "z_slide", "tool", ""))]),
                E(
                    "has type `floating`, which machines cannot use",
                    Some((12, "<joint")),
                ),
            ),
            (
                "planar joint",
                with(&[(12, &moving("spindle", "planar", "z_slide", "tool", ""))]),
                E("has type `planar`", Some((12, "<joint"))),
            ),
            (
                "unknown joint type",
                with(&[(12, &moving("spindle", "slider", "z_slide", "tool", ""))]),
                E("unknown type `slider`", Some((12, "<joint"))),
            ),
            (
                "tool below workpiece",
                with(&[(
                    12,
                    r#"<joint name="spindle" type="fixed"><parent link="workpiece"/><child link="tool"/></joint>"#,
                )]),
                E(
                    "link `tool` hangs below link `workpiece`",
                    Some((7, "<link")),
                ),
            ),
            (
                "shared moving joint",
                with(&[(
                    12,
                    r#"<joint name="spindle" type="fixed"><parent link="x_slide"/><child link="tool"/></joint>"#,
                )]),
                E(
                    "moving joint `Y` carries both the tool and the workpiece",
                    Some((8, "<joint")),
                ),
            ),
        ];
        for (case, text, expect) in cases {
            check(case, &text, expect);
        }
    }

    #[test]
    fn unreadable_file_names_the_file() {
        let e = load_urdf_file(Path::new("/nonexistent/m.urdf")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("/nonexistent/m.urdf: cannot read"),
            "{e}"
        );
        assert!(e.location().is_none());
    }

    #[test]
    fn fixed_joints_collapse_into_origins_and_ends() {
        // A fixed stem from the root (frame → bed) must reach both branches.
        let text = with(&[
            (
                2,
                r#"<link name="frame"/><link name="bed"/><joint name="stem" type="fixed"><origin xyz="1 2 3" rpy="0 0 1.5707963267948966"/><parent link="frame"/><child link="bed"/></joint>"#,
            ),
            (
                8,
                &format!(
                    r#"<joint name="Y" type="prismatic"><parent link="bed"/><child link="y_slide"/><axis xyz="0 -1 0"/>{LIMIT}</joint>"#
                ),
            ),
            (
                11,
                r#"<joint name="Z" type="prismatic"><origin xyz="0 0.4 0.8"/><parent link="bed"/><child link="z_slide"/><axis xyz="0 0 1"/><limit lower="-0.5" upper="0" effort="1" velocity="1"/></joint>"#,
            ),
        ]);
        let m = load_urdf_str(&text, Path::new("m.urdf")).unwrap();
        let q = [0.1, 0.2, -0.3];
        // Relative to the workpiece the stem cancels: tool − workpiece = Z origin + spindle
        // − X origin − wp + (X, Y, Z) motions.
        let p = m.tool_in_workpiece(&q).t;
        let expected = Vector3::new(0.1, 0.2, -0.3) + Vector3::new(0.0, 0.0, 0.6 - 0.15);
        assert!((p - expected).norm() < 1e-12, "{p}");
        // In the frame, the stem's 90° yaw turns the branches: the tool sits at stem ∘ (Z, spindle).
        let t = m.branch_pose(Side::Tool, &q).t;
        let in_bed = Vector3::new(0.0, 0.4 - 0.4, 0.8 - 0.3 - 0.2);
        let expected = Vector3::new(1.0 - in_bed.y, 2.0 + in_bed.x, 3.0 + in_bed.z);
        assert!((t - expected).norm() < 1e-12, "{t}");
    }

    fn random_q(m: &Machine, seed: &[f64]) -> Vec<f64> {
        m.axes()
            .iter()
            .zip(seed.iter().cycle())
            .map(|(a, s)| match a.limits() {
                Some((lo, hi)) => lo + (hi - lo) * s,
                None => (s - 0.5) * 20.0,
            })
            .collect()
    }

    fn assert_same_machine(a: &Machine, b: &Machine, seed: &[f64]) {
        assert_eq!(a.topology_code(), b.topology_code());
        assert_eq!(a.name(), b.name());
        let q = random_q(a, seed);
        for side in [Side::Workpiece, Side::Tool] {
            let (pa, pb) = (a.branch_pose(side, &q), b.branch_pose(side, &q));
            assert!((pa.t - pb.t).norm() < 1e-12 && (pa.r - pb.r).norm() < 1e-12);
        }
        let (ta, tb) = (a.tool_in_workpiece(&q), b.tool_in_workpiece(&q));
        assert!((ta.t - tb.t).norm() < 1e-12 && (ta.r - tb.r).norm() < 1e-12);
        for (x, y) in a.axes().iter().zip(b.axes()) {
            assert_eq!(x.limits(), y.limits());
        }
    }

    #[test]
    fn written_urdf_reads_back_and_keeps_comments_safe() {
        let code = parse_code("CAFYXZ", Reading::FromWorkpiece).unwrap();
        let m = nominal_machine(&code, "a \"quoted\" <name> & more").unwrap();
        let text = write_urdf(&m, Some("from -- topology code -"));
        assert!(
            text.contains("<!--\nfrom - - topology code - \n-->"),
            "{text}"
        );
        assert!(text.contains(r#"<joint name="C" type="continuous">"#));
        assert!(
            text.contains(r#"<link name="c_table">"#) && text.contains(r#"<link name="x_slide">"#)
        );
        let back = load_urdf_str(&text, Path::new("w.urdf")).unwrap();
        assert_same_machine(&m, &back, &[0.1, 0.7, 0.3, 0.9, 0.5]);
    }

    #[test]
    fn rpy_is_exact_near_gimbal_lock() {
        let half_pi = std::f64::consts::FRAC_PI_2;
        for pitch in [half_pi, -half_pi, half_pi - 3e-8, 3e-9 - half_pi] {
            let r = *Rotation3::from_euler_angles(0.3, pitch, -1.2).matrix();
            let [roll, p, yaw] = rpy_from_matrix(&r);
            let back = *Rotation3::from_euler_angles(roll, p, yaw).matrix();
            assert!(
                (back - r).norm() < 1e-15,
                "pitch {pitch}: {}",
                (back - r).norm()
            );
        }
    }

    fn rigid_strategy() -> impl Strategy<Value = Isometry3<f64>> {
        let angle = -4.0..4.0f64;
        let gimbal = prop_oneof![Just(None), Just(Some(std::f64::consts::FRAC_PI_2))];
        (
            proptest::array::uniform3(-2.0..2.0f64),
            proptest::array::uniform3(angle),
            gimbal,
        )
            .prop_map(|(t, [r, p, y], g)| {
                let rot = UnitQuaternion::from_euler_angles(r, g.unwrap_or(p), y);
                Isometry3::from_parts(Translation3::from(Vector3::from(t)), rot)
            })
    }

    fn joint_strategy(letter: char) -> impl Strategy<Value = JointSpec> {
        let rotary = AxisLetter::new(letter).is_some_and(|l| l.is_rotary());
        (
            rigid_strategy(),
            proptest::array::uniform3(-1.0..1.0f64),
            any::<bool>(),
        )
            .prop_map(move |(origin, axis, unlimited)| JointSpec {
                letter,
                kind: if rotary {
                    AxisKind::Rotary
                } else {
                    AxisKind::Linear
                },
                origin,
                axis: Vector3::from(axis) + Vector3::new(0.0, 0.0, 1.5),
                limits: if rotary && unlimited {
                    None
                } else {
                    Some((-0.7, 0.9))
                },
            })
    }

    proptest! {
        #[test]
        fn arbitrary_machines_round_trip(
            wp in proptest::collection::vec(joint_strategy('X'), 0..1),
            a in joint_strategy('A'),
            y in joint_strategy('Y'),
            c in joint_strategy('C'),
            ends in (rigid_strategy(), rigid_strategy()),
            seed in proptest::collection::vec(0.0..1.0f64, 5),
        ) {
            let mut wp_joints = wp;
            wp_joints.push(a);
            let spec = MachineSpec {
                name: "random".into(),
                workpiece: BranchSpec { joints: wp_joints, end: ends.0 },
                tool: BranchSpec { joints: vec![y, c], end: ends.1 },
            };
            let m = Machine::try_new(&spec).unwrap();
            let back = load_urdf_str(&write_urdf(&m, None), Path::new("r.urdf")).unwrap();
            assert_same_machine(&m, &back, &seed);
        }

        #[test]
        fn mangled_files_give_errors_not_panics(
            cut in 0usize..2000,
            len in 0usize..40,
            insert in "[<>/\"= XYZABCt0-9.a-z]{0,12}",
        ) {
            let text = with(&[]);
            let mut bytes: Vec<char> = text.chars().collect();
            let start = cut.min(bytes.len());
            let end = (start + len).min(bytes.len());
            bytes.splice(start..end, insert.chars());
            let mangled: String = bytes.into_iter().collect();
            let _ = load_urdf_str(&mangled, Path::new("f.urdf"));
        }
    }
}
