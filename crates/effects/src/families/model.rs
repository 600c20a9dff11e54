//! Changes of the machine's error model.
//!
//! - **`omitted-parameter`**: a parameter of the machine's full error model (its
//!   `.errors.toml`) that the fit holds at its start value.
//! - **`component-order`**: an estimated component error whose basis (Legendre polynomials or
//!   a Fourier series) is two orders short (not one the runs cannot determine, held near its
//!   start: its higher orders would be free where its lower ones are not).
//!
//! Both are planted through the truth parameter file (and, for a higher order than the
//! session's error model, a richer truth model: `truth_errors` in the test plan); the
//! identification core builds their columns from its kinematic model.

use crate::view::{BasisOrder, SessionView};
use crate::{Candidate, EffectFamily, ModelChange};

/// Orders a `component-order` candidate adds.
pub const EXTRA_ORDERS: usize = 2;

fn omitted(view: &SessionView) -> Vec<Candidate> {
    view.model
        .iter()
        .filter(|p| !p.estimated)
        .map(|p| {
            Candidate::Model(ModelChange {
                class: "omitted-parameter",
                param: p.name,
                extra_order: 0,
            })
        })
        .collect()
}

fn higher_order(view: &SessionView) -> Vec<Candidate> {
    view.model
        .iter()
        // A component the runs cannot determine (held) gains nothing from more orders.
        .filter(|p| p.estimated && !p.held && p.order != BasisOrder::Other)
        .map(|p| {
            Candidate::Model(ModelChange {
                class: "component-order",
                param: p.name,
                extra_order: EXTRA_ORDERS,
            })
        })
        .collect()
}

inventory::submit! {
    EffectFamily {
        name: "omitted-parameter",
        about: "a parameter of the machine's full error model that the fit left out",
        candidates: omitted,
        plant: None,
        separated_by: None,
        told_from: &[],
    }
}

inventory::submit! {
    EffectFamily {
        name: "component-order",
        about: "an estimated component error whose polynomial or Fourier order is too low",
        candidates: higher_order,
        plant: None,
        separated_by: None,
        told_from: &[],
    }
}
