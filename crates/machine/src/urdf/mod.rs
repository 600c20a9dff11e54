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

mod chain;
mod read;
#[cfg(test)]
mod tests;
mod write;

use chain::*;
pub use chain::{MAX_PLAUSIBLE_STROKE_M, MAX_PLAUSIBLE_TURN_RAD};
use read::*;
pub use write::{rpy_from_matrix, write_urdf};

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
