//! Typed identities of a study's parameters ([`ParamId`]). The same parameter in two studies of
//! one session — a refit with an effect more, a component given more orders, a set-up
//! parameter held — has the same id wherever it sits in the parameter vector, so the search
//! carries values, additions and comparisons from one study to the next by id. Names
//! (`EXX.P2`, `ball1.x`, `reversal X.b_um`) are for people: the report prints them, the code
//! does not compare them.

use mtcal_kinematics::{ParamName, Term};
use std::sync::Arc;

/// A machine coefficient: error parameter `param`'s coefficient of the basis function `term`
/// (`P2`, `C1`, `K3`), `None` for a parameter of one coefficient (`EC0Y`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CoeffId {
    pub param: ParamName,
    pub term: Option<Term>,
}

/// A set-up of the session, by its place in the session's list: a session's set-ups are
/// loaded once and shared by every study rebuilt from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SetupId(pub usize);

/// An effect of a study, by its label: unique in a study (a second effect with the label of
/// one in the model is numbered, `relabel::unique`) and kept by a rebuilt study.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EffectId(pub Arc<str>);

/// What parameter of a study a value is.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ParamId {
    Machine(CoeffId),
    /// Nuisance parameter `nuisance` (its place in the set-up's list) of set-up `setup`.
    Nuisance {
        setup: SetupId,
        nuisance: usize,
    },
    /// Parameter `param` (its place in the effect's list) of effect `effect`.
    Effect {
        effect: EffectId,
        param: usize,
    },
}
