//! Effects under another label: a second effect of a label already in the model (a second
//! time constant of the same drift) becomes `… #2`.

use mtcal_effects::{Effect, EffectInfo, Features, ParamDef, SessionView, Term};
use std::sync::Arc;

/// `effect`, relabelled `… #2` if an effect of that label is in `existing` already.
pub(crate) fn unique(effect: &Arc<dyn Effect>, existing: &[Arc<dyn Effect>]) -> Arc<dyn Effect> {
    let label = &effect.info().label;
    let same = existing
        .iter()
        .filter(|e| e.info().label == *label || e.info().label.starts_with(&format!("{label} #")))
        .count();
    if same == 0 {
        return Arc::clone(effect);
    }
    let mut info = effect.info().clone();
    info.label = format!("{label} #{}", same + 1);
    Arc::new(Relabelled {
        inner: Arc::clone(effect),
        info,
    })
}

/// An effect under another label (a second time constant of the same drift).
#[derive(Debug)]
struct Relabelled {
    inner: Arc<dyn Effect>,
    info: EffectInfo,
}

impl Effect for Relabelled {
    fn info(&self) -> &EffectInfo {
        &self.info
    }
    fn params(&self) -> &[ParamDef] {
        self.inner.params()
    }
    fn terms(&self) -> &[Term] {
        self.inner.terms()
    }
    fn prepare(&self, view: &Arc<SessionView>, shape: &[f64]) -> Box<dyn Features> {
        self.inner.prepare(view, shape)
    }
    fn describe(&self, values: &[f64], u95: &[Option<f64>]) -> String {
        self.inner.describe(values, u95)
    }
    fn cached_series(&self) -> Vec<String> {
        self.inner.cached_series()
    }
    fn shape_scan(&self, view: &SessionView) -> Vec<Vec<f64>> {
        self.inner.shape_scan(view)
    }
    fn follows_the_session(&self) -> bool {
        self.inner.follows_the_session()
    }
    fn with_shape(&self, shape: &[f64]) -> Option<Arc<dyn Effect>> {
        let inner = self.inner.with_shape(shape)?;
        Some(Arc::new(Relabelled {
            inner,
            info: self.info.clone(),
        }))
    }
}
