//! Effects planted by code ([`Plant`]), for what no effect family describes.

use mtcal_kinematics::Rigid;

/// One sample as a [`Plant`] sees it.
#[derive(Debug, Clone, Copy)]
pub struct PlantSample<'a> {
    pub run: &'a str,
    pub instrument: &'a str,
    /// Index of the run in the plan.
    pub run_index: usize,
    pub sample: usize,
    pub t: f64,
    /// Axis positions, SI.
    pub q: &'a [f64],
    /// Actual tool pose in the workpiece frame.
    pub w_t_t: &'a Rigid,
}

/// An effect planted into simulated readings.
pub trait Plant: Sync + std::fmt::Debug {
    /// Adds the effect (SI) to the noise-free `readings` of one sample.
    fn apply(&self, sample: &PlantSample<'_>, readings: &mut [f64]);
}
