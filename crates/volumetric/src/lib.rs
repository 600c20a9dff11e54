//! The volumetric thermal test evaluated (docs/VOLUMETRIC.md; source 000's TEVOR steps 5–7):
//! from a session of `rtest` runs, ball on the table, the deformation of every point over
//! time, the field's mean, standard deviation and max − min between points at each instant,
//! what pure noise would give, and whether ISO 230-3's single-point assumption holds.
//!
//! [`read_session`] reads the visits ([`Visits`]); [`evaluate`] gives the [`Evaluation`]
//! (its [`Evaluation::summary`] is the screen, [`Evaluation::to_json`] the file
//! `mtcal.volumetric/1`).
//!
//! # Points and visits
//! A *point* is a ball set-up at one commanded position of the rotary axes that vary in the
//! session, rounded to 0.001° (`ball1@C120`; a three-axis frame's points are its set-ups). Every
//! row of every `rtest` run is a visit of its point; validation runs count as well (a cycle
//! withheld from a fit is still a measurement of the field). Each point's visits in time order;
//! `t₀` is its first visit.
//!
//! # Deformation
//! `d_j(t) = −(r_j(t) − r_j(t₀))`, `r = (dx, dy, dz)` the reading (µm): the tool's displacement
//! relative to the workpiece since the point's first visit, in machine directions (the nest in
//! the spindle keeps the machine's axes where the spindle does not tilt). A tool that grows
//! towards the table (−Z) makes `dz` grow and `d_z` negative.
//!
//! # Cycles and the common time base
//! The visits in time order are cut into cycles (one visit of each point): a new cycle starts
//! when a point comes again, or after a pause between visits longer than
//! [`PAUSE_FACTOR`] × the median pause (a load or rest phase; it also keeps a cycle that misses
//! a visit from running into the next). Each cycle is an *instant*, at the midpoint of its
//! first and last visit.
//!
//! The value of each point at an instant ([`TimeBase`]):
//! - [`TimeBase::Interpolated`] (the default): linear in time between the point's two visits
//!   around the instant (beyond its first or last visit, along the nearest two);
//! - [`TimeBase::Cycle`]: the point's visit in that cycle (a visit the cycle misses is
//!   interpolated between the point's neighbouring visits): the cycle taken as one instant,
//!   as source 000 does.
//!
//! At the instants, every point's deformation is taken from its value at the *first instant*
//! on the same time base (with the cycle's own visits that is its first visit, `t₀`): the
//! points visited early and late in the first cycle then share one reference instant, so what
//! the machine did during the first cycle does not show as a difference between points. (Each
//! visit's own deformation, [`PointSeries`], stays relative to the point's first visit.)
//!
//! On source 000's schedule (measuring cycles between load phases) the line between two
//! cycles' visits is not the deformation's path: under the load it rises, during the cycle
//! (spindle still, head in it) it goes back a little. The error of the line is then about the
//! same at every cycle for a point (the load's heating rate times the point's place in the
//! cycle), and the common reference instant takes most of it out: on the simulator's spindle
//! test (63 µm) a point's value at a cycle's midpoint is within 0.85 µm of the truth (RMS
//! 0.15 µm), where the cycle's own visits are off by up to 2.4 µm (the drift during the cycle,
//! up to 4.7 µm of false spread). The uncertainties below are the noise's; this time-base
//! error is not in them.
//!
//! Neither time base can tell a drift *within* a cycle that the interpolation misses from a
//! difference between points that follows the order of the visits: one visit per point and
//! cycle does not hold that information. [`AxisVerdict::follows_visit_order_um`] says how much
//! of the spread at the verdict's instant follows the order.
//!
//! # Noise
//! The per-visit noise is estimated from the data, never taken from the manifest's
//! `sigma_um` (which is only compared). In the complete cycles, each point's readings less
//! their mean over the cycles (its set-up's offset out), and each cycle's less a linear
//! function of the points' commanded X, Y, Z and visit time within the cycle (the field at that
//! instant, however large, and a drift within the cycle): what remains is noise, and the
//! field's part that no such function follows. The residuals' sum of squares and lag-one
//! products along the cycles are matched to what AR(1) noise of σ and φ gives through the same
//! fit, exactly: σ per axis, φ pooled over the axes (the module `noise` has the formulas). The
//! AR(1) runs along each *set-up's* visits in time order — the head seating on one ball: a
//! trunnion's ball visited at three table positions is three points with one seating noise.
//! A field the linear function does not follow makes σ larger, never smaller. At least
//! [`MIN_CYCLES`] complete cycles are needed; φ needs five (else it is taken as 0, and said).
//!
//! # Uncertainties (95 %)
//! Every value at an instant is a linear combination of readings (the interpolation, less the
//! same at the first instant); its covariance with any other follows from σ² and the AR(1)
//! correlation `φ^|a−b|` between the visits `a`, `b` of a set-up involved (values of points of
//! different set-ups are independent):
//! - a point's deformation: from its own variance (at the reference a value is 0 exactly);
//! - the mean per axis: `1.96·√(1ᵀ C 1)/N`, `C` the points' covariance;
//! - max − min, the standard deviation, the mean's magnitude and the shares: a parametric
//!   bootstrap ([`BOOTSTRAP_DRAWS`] draws of the points' noise with that covariance, seeded by
//!   the instant): the lower end is the basic bootstrap's, `2T − q₉₇.₅` (it removes the
//!   inflation noise gives a spread), or 0 when the spread is not above its noise floor; the
//!   upper end the larger of `2T − q₂.₅` and `T + (q₅₀ − q₂.₅)` (it does not count on that
//!   inflation: noise can also pull the extreme points in). An interval is for the field's own
//!   value; the value shown is the observed one, noise included;
//! - the noise floor: the 95th percentile of max − min (and of the standard deviation) over
//!   the same draws of noise alone, a perfectly uniform field.
//!
//! [`Evaluation::instant_at`] gives the same at any time of the session.
//!
//! # Verdict
//! At the instant of the largest mean deformation `|m|` (vector), per axis: the spread
//! max − min as a share of `|m|`, with its interval. [`Verdict::Uniform`] when the spread is
//! not above its noise floor or the interval's upper end is within the tolerance share
//! (default 0.2); [`Verdict::NotUniform`] when its lower end is beyond it; otherwise
//! [`Verdict::CannotDecide`]. Overall: not uniform if any axis is, uniform if all are, else
//! cannot decide. The standard deviation's share is given beside it.

mod bootstrap;
mod cycles;
mod noise;
mod output;
mod phases;
mod points;
mod read;
mod stats;
mod timebase;
mod verdict;

#[cfg(test)]
mod tests;

use std::path::PathBuf;

pub use cycles::{CycleCut, Cycles, IncompleteCycle};
pub use noise::Noise;
pub use output::SCHEMA;
pub use phases::{Snapshot, SnapshotPoint};
pub use points::{Point, Visit, Visits};
pub use read::read_session;
pub use stats::{AxisSpread, Instant};
pub use timebase::{PointSeries, SeriesValue, TimeBase, TimeBaseChoice};
pub use verdict::{AxisVerdict, Homogeneity, Verdict};

/// A pause between two visits longer than this many times the median pause ends a cycle.
pub const PAUSE_FACTOR: f64 = 5.0;
/// Draws of the parametric bootstrap per instant.
pub const BOOTSTRAP_DRAWS: usize = 2000;
/// The coverage factor of every interval (normal, 95 %).
pub const K95: f64 = 1.959_963_984_540_054;
/// The tolerance share by default: the spread may be this share of the mean deformation.
pub const DEFAULT_TOLERANCE_SHARE: f64 = 0.2;
/// Complete cycles needed to estimate the noise.
pub const MIN_CYCLES: usize = 3;

/// Why a session cannot be evaluated. Every message names the file or the run at fault.
#[derive(Debug, thiserror::Error)]
pub enum VolumetricError {
    /// The session or a run file could not be read (the message is located).
    #[error(transparent)]
    Session(#[from] mtcal_session::SessionError),
    /// The session's machine could not be loaded (its axes name the run files' columns).
    #[error("{manifest}: cannot load the machine `{machine}`")]
    Machine {
        manifest: PathBuf,
        machine: String,
        #[source]
        cause: Box<mtcal_machine::LoadError>,
    },
    /// Something in the session does not make a volumetric thermal test.
    #[error("{at}: {message}")]
    Invalid { at: String, message: String },
    /// An option out of its range.
    #[error("{0}")]
    Options(String),
    /// No linked instrument plugin records point visits.
    #[error(transparent)]
    Instrument(#[from] mtcal_plugins::capability::CapabilityError),
}

impl VolumetricError {
    pub(crate) fn invalid(at: impl Into<String>, message: impl Into<String>) -> Self {
        VolumetricError::Invalid {
            at: at.into(),
            message: message.into(),
        }
    }
}

/// How to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// The spread may be this share of the mean deformation (0.2: 20 %).
    pub tolerance_share: f64,
    /// Snapshots of the deformation vectors at these times, h on the session's clock; each is
    /// the instant nearest to it. Empty: the verdict's instant, and the last one.
    pub phases_h: Vec<f64>,
    pub time_base: TimeBase,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            tolerance_share: DEFAULT_TOLERANCE_SHARE,
            phases_h: Vec::new(),
            time_base: TimeBase::Interpolated,
        }
    }
}

/// Everything the evaluation found.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// The visits evaluated: the session folder, its machine, the points.
    pub visits: Visits,
    pub cycles: Cycles,
    pub noise: Noise,
    pub time_base: TimeBaseChoice,
    /// Per point (in the order of [`Visits::points`]): its deformation at every visit.
    pub series: Vec<PointSeries>,
    /// One per cycle, in time order.
    pub instants: Vec<Instant>,
    pub homogeneity: Homogeneity,
    pub snapshots: Vec<Snapshot>,
    /// What the reader should know: runs left out, a stated σ that differs, a cycle missing
    /// a visit.
    pub notes: Vec<String>,
    pub options: Options,
}

/// Evaluates the visits ([`read_session`]) as the crate documentation says.
pub fn evaluate(visits: &Visits, options: &Options) -> Result<Evaluation, VolumetricError> {
    check_options(options)?;
    let cycles = cycles::cut(visits);
    let noise = noise::estimate(visits, &cycles)?;
    let time_base = timebase::choose(options.time_base, &cycles);
    let series = timebase::series(visits, &cycles, &noise);
    let times: Vec<timebase::At> = (0..cycles.len())
        .map(|cycle| timebase::At {
            t_s: cycles.mid_s[cycle],
            cycle,
        })
        .collect();
    let values = timebase::at_times(visits, &cycles, &noise, time_base.method, &times);
    let instants = stats::instants(&cycles, &times, &values);
    let homogeneity = verdict::judge(&cycles, &instants, options.tolerance_share);
    let snapshots = phases::snapshots(visits, &instants, &options.phases_h, &homogeneity)?;
    let mut notes = visits.notes.clone();
    notes.extend(cycles.notes());
    notes.extend(noise.notes());
    Ok(Evaluation {
        visits: visits.clone(),
        cycles,
        noise,
        time_base,
        series,
        instants,
        homogeneity,
        snapshots,
        notes,
        options: options.clone(),
    })
}

impl Evaluation {
    /// The field at any time `t_s` of the session (s on its clock, within its instants give or
    /// take one cycle's spacing): every point's deformation on the evaluation's time base (the
    /// cycle nearest `t_s` for [`TimeBase::Cycle`]), from the first instant, with the same
    /// statistics as [`Evaluation::instants`].
    pub fn instant_at(&self, t_s: f64) -> Result<Instant, VolumetricError> {
        let cycle = phases::nearest(&self.instants, t_s / 3600.0)
            .map_err(|m| VolumetricError::Options(format!("the field at {m}")))?;
        let times = [timebase::At { t_s, cycle }];
        let values = timebase::at_times(
            &self.visits,
            &self.cycles,
            &self.noise,
            self.time_base.method,
            &times,
        );
        let mut one = stats::instants(&self.cycles, &times, &values);
        Ok(one.remove(0))
    }
}

fn check_options(options: &Options) -> Result<(), VolumetricError> {
    let share = options.tolerance_share;
    if !(share.is_finite() && share > 0.0 && share < 10.0) {
        return Err(VolumetricError::Options(format!(
            "--tolerance-share: expected a share above 0 (0.2 for 20 %), found {share}"
        )));
    }
    if let Some(h) = options.phases_h.iter().find(|h| !h.is_finite()) {
        return Err(VolumetricError::Options(format!(
            "--phase: expected hours on the session's clock, found {h}"
        )));
    }
    Ok(())
}
