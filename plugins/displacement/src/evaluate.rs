//! ISO 230-3-style evaluation of a run: each sensor's drift over the run.

use crate::setup::DisplacementSetup;
use mtcal_instrument::{Evaluation, Metric, Unit};

/// The range (max − min) of each channel of `readings` (row-major `samples × channels`),
/// leaving out non-finite values; `None` for a channel without a finite value.
pub fn drift(readings: &[f64], channels: usize) -> Vec<Option<f64>> {
    let mut range = vec![None::<(f64, f64)>; channels];
    if channels == 0 {
        return Vec::new();
    }
    for row in readings.chunks_exact(channels) {
        for (r, &v) in range.iter_mut().zip(row) {
            if v.is_finite() {
                let (lo, hi) = r.get_or_insert((v, v));
                *lo = lo.min(v);
                *hi = hi.max(v);
            }
        }
    }
    range
        .into_iter()
        .map(|r| r.map(|(lo, hi)| hi - lo))
        .collect()
}

/// The plugin's `evaluate`: per sensor `thermal drift d_<sensor> (ISO 230-3)`, the largest
/// change of its reading over the run (max − min, µm; ISO 230-3 reports the drift of each
/// sensor over the test). Nothing for a set-up that does not load or readings that do not
/// match its channels.
pub fn evaluate(ev: &Evaluation<'_>) -> Vec<Metric> {
    let Some(setup) = ev.setup_as::<DisplacementSetup>() else {
        return Vec::new();
    };
    let channels = setup.sensors().len();
    if channels == 0 || ev.readings.len() % channels != 0 {
        return Vec::new();
    }
    setup
        .sensors()
        .iter()
        .zip(drift(ev.readings, channels))
        .filter_map(|(s, d)| {
            d.map(|value| {
                Metric::new(
                    format!("thermal drift d_{} (ISO 230-3)", s.name()),
                    value,
                    Unit::Um,
                )
            })
        })
        .collect()
}
