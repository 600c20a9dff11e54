//! Serial-chain kinematics of machine tools with ISO 230-1 error motions.
//!
//! A [`Machine`] is two serial branches from the machine frame: one to the workpiece, one to the
//! tool point. A [`MachineModel`] adds configured error parameters (component errors as
//! functions of their axis' position in a chosen [`Basis`], location errors, squareness, set-up)
//! and evaluates the tool's pose error relative to the workpiece — exactly or to first order —
//! with analytic Jacobians. This crate does no I/O: loaders live in `mtcal-machine`.

pub mod basis;
pub mod ik;
pub mod machine;
pub mod model;
pub mod names;
pub mod pose;
pub mod rigid;
pub mod volmap;

pub use basis::{Basis, BasisError, Term};
pub use machine::{AxisKind, BranchSpec, JointSpec, Machine, MachineError, MachineSpec, Side};
pub use model::{BasisChoice, ErrorModel, ModelError, ParamConfig};
pub use names::{AxisLetter, Direction, ParamName, Setup};
pub use pose::{BatchKernel, BatchWorkspace, MachineModel, PoseError, TOOL_MOTIONS, Workspace};
pub use rigid::Rigid;
