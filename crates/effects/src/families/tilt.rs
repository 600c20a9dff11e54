//! **`thermal-tilt`** — the tool side of the machine turns as a whole about a line parallel to
//! one of the machine's directions as a recorded temperature rises: a cross-beam or a column
//! twists when a drive on one side of it warms, and the spindle head turns with it (source 000
//! saw the head turn about X under Y-drive load). The turn is `θ = g·ΔT` (`ΔT` the
//! temperature's rise, driver `T_<name>`), or `g·lag(ΔT, τ)` when the static form is already
//! in the model (the sensor is not where the heat is); the tool point `p` (machine frame) moves
//! by `θ·e × (p − m)` and the tool tilts by `θ` ([`Target::ToolTurn`] about the machine's
//! origin, less the shift `θ·e × m`, [`Target::ToolShift`]), `m` the middle of the tool point's
//! travel over the fitted samples. Where the line really lies is an offset that follows the
//! temperature: a `temperature-coupling` of the linear axes, a candidate of its own (as for
//! `thermal-expansion`, where the scale is fixed). About the middle of the travel the turn adds
//! the least it can to what those explain.
//!
//! What shows a turn is a lever arm that changes: the tool point standing at different heights
//! for a turn about X or Y, at different places across for a turn about Z. A turn is proposed
//! about a direction when the tool point travels at least [`LEVER_REACH_M`] across it over the
//! fitted samples (in the machine frame: on a machine whose table carries X and Y the tool point
//! moves only in Z, and a turn about Z would be a shift by another name), and when some channel
//! reads the tool pose.
//!
//! Plant keys: `about = "X"` (the machine direction), `driver = "T_<name>"`,
//! `gain_urad_per_K` and, for the lagged form, `tau_s`.

use super::{plant_values, static_and_lagged, string, temperature_driver};
use crate::basic::{AmplitudeUnit, Basic, Feature};
use crate::view::SessionView;
use crate::{
    Candidate, Effect, EffectFamily, EffectInfo, Features, ParamDef, ParamKind, PlantError,
    Planted, Target, Term,
};
use std::sync::Arc;

/// The least travel of the tool point across a direction (m) for a turn about it to be
/// proposed: over 10 mm a turn of a few µrad moves the tool by hundredths of a micrometre.
pub const LEVER_REACH_M: f64 = 0.01;

const DIRECTIONS: [char; 3] = ['X', 'Y', 'Z'];

/// The two directions across direction `k`, in right-handed order (`e_k × e_a = e_b`).
fn across(k: usize) -> [usize; 2] {
    [(k + 1) % 3, (k + 2) % 3]
}

/// A turn about direction `k` through the middle `m` of the tool's travel, following `feature`.
#[derive(Clone, Debug)]
struct Tilt {
    /// The feature on the turn and on the two shifts that move its line from the origin to `m`
    /// (one amplitude shared).
    inner: Basic,
    k: usize,
    column: String,
    /// The middle of the tool's travel (m, machine frame).
    middle_m: [f64; 3],
}

impl Tilt {
    fn new(k: usize, feature: Feature, column: &str, tau: Option<f64>, middle_m: [f64; 3]) -> Self {
        let about = DIRECTIONS[k];
        let info = EffectInfo {
            class: "thermal-tilt",
            axis: None,
            component: Some(format!("turn about {about}")),
            driver: Some(column.to_string()),
            label: format!("thermal-tilt about {about} ({column})"),
        };
        let [a, b] = across(k);
        let inner = Basic::shared(
            info,
            feature,
            vec![
                Target::ToolTurn(k),
                Target::ToolShift(a),
                Target::ToolShift(b),
            ],
            format!("the tool side about the machine's {about}"),
            AmplitudeUnit::urad(),
            tau,
        );
        Self {
            inner,
            k,
            column: column.to_string(),
            middle_m,
        }
    }

    /// The shifts per radian of turn that move the line from the origin to the middle:
    /// `−e_k × m = m_b·e_a − m_a·e_b`.
    fn shift_per_rad(&self) -> [f64; 2] {
        let [a, b] = across(self.k);
        [self.middle_m[b], -self.middle_m[a]]
    }
}

/// The inner feature, the shifts' copies weighted by the line's offset.
struct TiltFeatures {
    inner: Box<dyn Features>,
    weights: [f64; 2],
    n_shapes: usize,
}

impl Features for TiltFeatures {
    fn eval(&self, r: usize, i: usize, f: &mut [f64], df: &mut [f64]) {
        self.inner.eval(r, i, f, df);
        for (t, w) in [(1, self.weights[0]), (2, self.weights[1])] {
            f[t] *= w;
            for s in 0..self.n_shapes {
                df[t * self.n_shapes + s] *= w;
            }
        }
    }
}

impl Effect for Tilt {
    fn info(&self) -> &EffectInfo {
        self.inner.info()
    }
    fn params(&self) -> &[ParamDef] {
        self.inner.params()
    }
    fn terms(&self) -> &[Term] {
        self.inner.terms()
    }
    fn prepare(&self, view: &Arc<SessionView>, shape: &[f64]) -> Box<dyn Features> {
        Box::new(TiltFeatures {
            inner: self.inner.prepare(view, shape),
            weights: self.shift_per_rad(),
            n_shapes: shape.len(),
        })
    }
    fn cached_series(&self) -> Vec<String> {
        self.inner.cached_series()
    }
    fn follows_the_session(&self) -> bool {
        self.inner.follows_the_session()
    }
    fn with_shape(&self, shape: &[f64]) -> Option<Arc<dyn Effect>> {
        let tau = *shape.first()?;
        Some(Arc::new(Tilt::new(
            self.k,
            self.inner.feature().clone(),
            &self.column,
            Some(tau),
            self.middle_m,
        )))
    }
    fn describe(&self, v: &[f64], u: &[Option<f64>]) -> String {
        let about = DIRECTIONS[self.k];
        let p = &self.params()[0];
        let gain = match u[0] {
            Some(w) => format!("{:.3} ± {:.3} {}", v[0] * p.per_si, w * p.per_si, p.unit),
            None => format!("{:.3} {}", v[0] * p.per_si, p.unit),
        };
        let how = match self
            .params()
            .iter()
            .position(|p| p.kind == ParamKind::Shape)
        {
            Some(i) => format!(
                "following the temperature {} through a first-order lag of τ = {:.0} s",
                self.column, v[i]
            ),
            None => format!("with the temperature {}", self.column),
        };
        let [a, b] = across(self.k);
        format!(
            "the tool side turning about the machine's {about} {how}: {gain}, about a line \
             through the middle of the tool's travel ({} = {:.0} mm, {} = {:.0} mm; where \
             the line really lies is an offset following the temperature, which a \
             temperature-coupling of the axes would show)",
            DIRECTIONS[a],
            self.middle_m[a] * 1e3,
            DIRECTIONS[b],
            self.middle_m[b] * 1e3
        )
    }
}

fn tilt(view: &SessionView, k: usize, feature: Feature, column: &str, tau: Option<f64>) -> Tilt {
    Tilt::new(k, feature, column, tau, view.tool_middle_m)
}

/// Whether a turn about direction `k` shows: the lever arms across it change.
pub(crate) fn lever_changes(view: &SessionView, k: usize) -> bool {
    (0..3)
        .filter(|&j| j != k)
        .any(|j| view.tool_reach_m[j] >= LEVER_REACH_M)
}

fn candidates(view: &SessionView) -> Vec<Candidate> {
    if !view.any_pose_reading() {
        return Vec::new();
    }
    let mut out = Vec::new();
    for k in (0..3).filter(|&k| lever_changes(view, k)) {
        for column in view.temperature_columns() {
            out.extend(static_and_lagged(view, &column, |feature, tau| {
                tilt(view, k, feature, &column, tau)
            }));
        }
    }
    out.into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let about = string(table, "about")?
        .ok_or_else(|| "a thermal tilt needs `about = \"X\"`, \"Y\" or \"Z\"".to_string())?;
    let k = DIRECTIONS
        .iter()
        .position(|d| about.len() == 1 && about.starts_with(*d))
        .ok_or_else(|| {
            PlantError::at(
                "about",
                format!("`about = \"{about}\"`: a machine direction, \"X\", \"Y\" or \"Z\""),
            )
        })?;
    let (column, feature, tau) = temperature_driver(table, view, "a thermal tilt")?;
    let effect = tilt(view, k, feature, column, tau);
    let values = plant_values(&effect, table, &["driver", "about"])?;
    Ok((Arc::new(effect), values))
}

inventory::submit! {
    EffectFamily {
        name: "thermal-tilt",
        about: "the tool side turning about a machine direction with a recorded temperature (a cross-beam or column twisting as a drive warms)",
        candidates,
        plant: Some(plant),
        separated_by: None,
        told_from: &[],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::AxisView;

    fn view(reach_m: [f64; 3]) -> SessionView {
        let axes = vec![AxisView {
            letter: 'Z',
            rotary: false,
            stroke: (-0.5, 0.0),
        }];
        SessionView::new(axes, Vec::new(), Vec::new(), Vec::new())
            .with_tool_travel([0.0; 3], reach_m)
    }

    #[test]
    fn a_turn_is_proposed_only_where_the_lever_arms_change() {
        // The tool point moves in Z only (a table carrying X and Y): turns about X and Y
        // change the tool's place with its height, a turn about Z does not.
        let v = view([0.0, 0.0, 0.3]);
        assert!(lever_changes(&v, 0));
        assert!(lever_changes(&v, 1));
        assert!(!lever_changes(&v, 2));
        let still = view([0.005, 0.0, 0.0]);
        assert!((0..3).all(|k| !lever_changes(&still, k)));
    }
}
