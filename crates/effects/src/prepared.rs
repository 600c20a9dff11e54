//! Effects at one parameter vector, evaluated sample by sample: the total perturbation of the
//! axes, the set-up's nuisance parameters and the readings, and its derivative by every effect
//! parameter. This is what the identification core calls in its hot loop; it allocates
//! nothing per sample.

use crate::view::SessionView;
use crate::{Effect, Features, ParamKind, Target};
use std::sync::Arc;

/// A set of effects with their parameters laid out one after another, prepared at given
/// values of their shape parameters.
pub struct PreparedEffects {
    effects: Vec<Arc<dyn Effect>>,
    features: Vec<Box<dyn Features>>,
    /// Per effect: where its parameters start.
    offsets: Vec<usize>,
    /// Per effect: indices (within the effect) of its shape parameters.
    shapes: Vec<Vec<usize>>,
    n_params: usize,
    /// The machine's axes: a tool turn's slot comes after them.
    n_axes: usize,
    /// The location errors a term can act on ([`SessionView::locations`]), in slot order.
    locations: Vec<mtcal_kinematics::ParamName>,
}

impl std::fmt::Debug for PreparedEffects {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PreparedEffects")
            .field("effects", &self.effects)
            .field("n_params", &self.n_params)
            .finish_non_exhaustive()
    }
}

/// Number of parameters of `effects`, laid out one after another.
pub fn n_params(effects: &[Arc<dyn Effect>]) -> usize {
    effects.iter().map(|e| e.params().len()).sum()
}

/// The shape parameters' values of `effects` in `params` (all effects' parameters, laid out
/// one after another): what decides whether a prepared set is still valid.
pub fn shape_values(effects: &[Arc<dyn Effect>], params: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    let mut o = 0;
    for e in effects {
        for (j, p) in e.params().iter().enumerate() {
            if p.kind == ParamKind::Shape {
                out.push(params[o + j]);
            }
        }
        o += e.params().len();
    }
    out
}

impl PreparedEffects {
    /// Prepares `effects` at the shape parameters in `params`.
    pub fn new(effects: &[Arc<dyn Effect>], view: &Arc<SessionView>, params: &[f64]) -> Self {
        let mut offsets = Vec::with_capacity(effects.len());
        let mut shapes = Vec::with_capacity(effects.len());
        let mut features = Vec::with_capacity(effects.len());
        let mut o = 0;
        for e in effects {
            let idx: Vec<usize> = e
                .params()
                .iter()
                .enumerate()
                .filter(|(_, p)| p.kind == ParamKind::Shape)
                .map(|(j, _)| j)
                .collect();
            let values: Vec<f64> = idx.iter().map(|&j| params[o + j]).collect();
            features.push(e.prepare(view, &values));
            offsets.push(o);
            shapes.push(idx);
            o += e.params().len();
        }
        Self {
            effects: effects.to_vec(),
            features,
            offsets,
            shapes,
            n_params: o,
            n_axes: view.axes.len(),
            locations: view.locations.clone(),
        }
    }

    pub fn n_params(&self) -> usize {
        self.n_params
    }

    pub fn is_empty(&self) -> bool {
        self.effects.is_empty()
    }

    /// Scratch for [`Self::sample`], sized for the machine's `n_axes` axes (and the tool
    /// side's motions after them: [`axis_slots`]), the view's location errors, and up to
    /// `max_nuisance` nuisance parameters and `max_channels` channels per set-up.
    pub fn scratch(
        &self,
        n_axes: usize,
        max_nuisance: usize,
        max_channels: usize,
    ) -> SampleEffects {
        assert_eq!(n_axes, self.n_axes, "the session's axes");
        let n_axes = axis_slots(n_axes);
        let max_terms = self
            .effects
            .iter()
            .map(|e| e.terms().len())
            .max()
            .unwrap_or(0);
        let max_shapes = self.shapes.iter().map(Vec::len).max().unwrap_or(0);
        let np = self.n_params;
        let n_loc = self.locations.len();
        SampleEffects {
            n_axes,
            n_loc,
            n_nuis: max_nuisance,
            n_ch: max_channels,
            dq: vec![0.0; n_axes],
            dl: vec![0.0; n_loc],
            dn: vec![0.0; max_nuisance],
            dr: vec![0.0; max_channels],
            gain: vec![0.0; max_channels],
            jq: vec![0.0; np * n_axes],
            jl: vec![0.0; np * n_loc],
            jn: vec![0.0; np * max_nuisance],
            jr: vec![0.0; np * max_channels],
            jg: vec![0.0; np * max_channels],
            axes_touched: false,
            locations_touched: false,
            written: [NOTHING_WRITTEN; 5],
            f: vec![0.0; max_terms],
            df: vec![0.0; max_terms * max_shapes.max(1)],
        }
    }

    /// The amplitude columns only, sparse: one [`Entry`] per term acting at sample `i` of run
    /// `r` (set-up `setup`), into `out` (cleared first). What scoring candidates needs: at zero
    /// amplitude the shape parameters have no column, and most effects touch one slot.
    /// `scratch` gives the feature buffers.
    pub fn amplitude_entries(
        &self,
        r: usize,
        setup: usize,
        i: usize,
        scratch: &mut SampleEffects,
        out: &mut Vec<Entry>,
    ) {
        out.clear();
        for (e, effect) in self.effects.iter().enumerate() {
            self.features[e].eval(r, i, &mut scratch.f, &mut scratch.df);
            let o = self.offsets[e];
            for (k, term) in effect.terms().iter().enumerate() {
                if let Some(slot) = self.slot_of(&term.target, setup) {
                    out.push(Entry {
                        param: o + term.amplitude,
                        slot,
                        value: scratch.f[k],
                    });
                }
            }
        }
    }

    /// The effects at sample `i` of run `r` (set-up `setup`), for effect parameters
    /// `params`: totals and derivatives into `out`.
    pub fn sample(
        &self,
        r: usize,
        setup: usize,
        i: usize,
        params: &[f64],
        out: &mut SampleEffects,
    ) {
        self.sample_only(r, setup, i, params, out, None);
    }

    /// [`Self::sample`] of the effects `only` marks (one flag per effect; all without it): a
    /// caller that reads some channels only leaves out the effects that cannot reach them
    /// (another sensor's joint thermal model). The others' totals and derivatives stay zero.
    pub fn sample_only(
        &self,
        r: usize,
        setup: usize,
        i: usize,
        params: &[f64],
        out: &mut SampleEffects,
        only: Option<&[bool]>,
    ) {
        out.clear();
        for (e, effect) in self.effects.iter().enumerate() {
            if only.is_some_and(|only| !only[e]) {
                continue;
            }
            let terms = effect.terms();
            let shapes = &self.shapes[e];
            let ns = shapes.len();
            let o = self.offsets[e];
            self.features[e].eval(r, i, &mut out.f, &mut out.df);
            for (k, term) in terms.iter().enumerate() {
                let amp_index = o + term.amplitude;
                let amp = params[amp_index];
                let f = out.f[k];
                let Some(slot) = self.slot_of(&term.target, setup) else {
                    continue;
                };
                out.add(slot, None, amp * f);
                out.add(slot, Some(amp_index), f);
                for (s, &j) in shapes.iter().enumerate() {
                    out.add(slot, Some(o + j), amp * out.df[k * ns + s]);
                }
            }
        }
    }
}

/// The axis slots of a machine with `n_axes` axes: its axes, then the tool side's shifts along
/// and turns about the machine's X, Y and Z ([`Target::ToolShift`], [`Target::ToolTurn`]).
pub fn axis_slots(n_axes: usize) -> usize {
    n_axes + mtcal_kinematics::TOOL_MOTIONS
}

impl PreparedEffects {
    /// The slot of a term's target in the runs of set-up `setup`, if it acts there.
    fn slot_of(&self, target: &Target, setup: usize) -> Option<Slot> {
        let n_axes = self.n_axes;
        match target {
            Target::Axis(a) => Some(Slot::Axis(*a)),
            Target::ToolShift(k) => Some(Slot::Axis(n_axes + k)),
            Target::ToolTurn(k) => Some(Slot::Axis(n_axes + 3 + k)),
            Target::Nuisance { setup: s, index } => (*s == setup).then_some(Slot::Nuisance(*index)),
            Target::Channel { per_setup } => {
                per_setup.get(setup).copied().flatten().map(Slot::Channel)
            }
            Target::Gain { per_setup } => per_setup.get(setup).copied().flatten().map(Slot::Gain),
            Target::Location(name) => self
                .locations
                .iter()
                .position(|n| n == name)
                .map(Slot::Location),
        }
    }
}

/// An empty range of written parameters.
const NOTHING_WRITTEN: (usize, usize) = (usize::MAX, 0);

/// Where a term acts at one sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// An axis (index into the machine's axes), or after them a turn of the tool side
    /// ([`axis_slots`]).
    Axis(usize),
    /// A nuisance parameter of the sample's set-up.
    Nuisance(usize),
    /// A reading channel of the sample's set-up.
    Channel(usize),
    /// A reading channel's gain.
    Gain(usize),
    /// A location error of the machine (index into [`SessionView::locations`]).
    Location(usize),
}

/// The derivative of an effect's perturbation by one of its amplitudes at one sample: the
/// amplitude `param` (in the parameters laid out one after another) times `value` acts on
/// `slot`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    pub param: usize,
    pub slot: Slot,
    pub value: f64,
}

/// The effects at one sample.
#[derive(Clone, Debug)]
pub struct SampleEffects {
    pub n_axes: usize,
    /// Row stride of `jl` (the view's location errors).
    pub n_loc: usize,
    /// Row stride of `jn` (the largest nuisance count of a set-up).
    pub n_nuis: usize,
    /// Row stride of `jr` (the largest channel count of a set-up).
    pub n_ch: usize,
    /// Totals: axis perturbations (SI), nuisance perturbations, reading changes, gain changes
    /// per channel. The reading becomes `(1 + gain)·prediction + dr`.
    pub dq: Vec<f64>,
    pub dl: Vec<f64>,
    pub dn: Vec<f64>,
    pub dr: Vec<f64>,
    pub gain: Vec<f64>,
    /// Per effect parameter, row-major: `∂dq/∂p` (`n_params × n_axes`), `∂dn/∂p`, `∂dr/∂p`,
    /// `∂gain/∂p`.
    pub jq: Vec<f64>,
    /// `∂dl/∂p` (`n_params × n_loc`).
    pub jl: Vec<f64>,
    pub jn: Vec<f64>,
    pub jr: Vec<f64>,
    pub jg: Vec<f64>,
    /// Whether any term acted on an axis (the caller needs the axis Jacobian only then).
    pub axes_touched: bool,
    /// Whether any term acted on a location error (the caller needs their columns only then).
    pub locations_touched: bool,
    /// Per buffer `jq`, `jn`, `jr`, `jg`, `jl`: the parameters (`lo..hi`) whose rows hold
    /// something since the last clear. A sample clears only those: a joint thermal model of a
    /// channel writes its own rows of `jr` alone, and the buffers are hundreds of parameters
    /// wide (clearing them whole was a twentieth of a thermal search).
    written: [(usize, usize); 5],
    f: Vec<f64>,
    df: Vec<f64>,
}

impl SampleEffects {
    fn clear(&mut self) {
        for v in [
            &mut self.dq,
            &mut self.dn,
            &mut self.dr,
            &mut self.gain,
            &mut self.dl,
        ] {
            v.fill(0.0);
        }
        let strides = [self.n_axes, self.n_nuis, self.n_ch, self.n_ch, self.n_loc];
        for ((v, stride), (lo, hi)) in [
            &mut self.jq,
            &mut self.jn,
            &mut self.jr,
            &mut self.jg,
            &mut self.jl,
        ]
        .into_iter()
        .zip(strides)
        .zip(self.written)
        {
            if lo < hi {
                v[lo * stride..hi * stride].fill(0.0);
            }
        }
        self.written = [NOTHING_WRITTEN; 5];
        self.axes_touched = false;
        self.locations_touched = false;
    }

    /// Parameter `p`'s row of buffer `k` holds something.
    #[inline]
    fn mark(&mut self, k: usize, p: usize) {
        let (lo, hi) = &mut self.written[k];
        *lo = (*lo).min(p);
        *hi = (*hi).max(p + 1);
    }

    /// Adds `v` to the total (`param` None) or to parameter `param`'s derivative.
    #[inline]
    fn add(&mut self, slot: Slot, param: Option<usize>, v: f64) {
        match (slot, param) {
            (Slot::Axis(a), None) => {
                self.dq[a] += v;
                self.axes_touched = true;
            }
            (Slot::Axis(a), Some(p)) => {
                self.jq[p * self.n_axes + a] += v;
                self.mark(0, p);
                self.axes_touched = true;
            }
            (Slot::Nuisance(j), None) => self.dn[j] += v,
            (Slot::Nuisance(j), Some(p)) => {
                self.jn[p * self.n_nuis + j] += v;
                self.mark(1, p);
            }
            (Slot::Channel(c), None) => self.dr[c] += v,
            (Slot::Channel(c), Some(p)) => {
                self.jr[p * self.n_ch + c] += v;
                self.mark(2, p);
            }
            (Slot::Location(j), None) => {
                self.dl[j] += v;
                self.locations_touched = true;
            }
            (Slot::Location(j), Some(p)) => {
                self.jl[p * self.n_loc + j] += v;
                self.mark(4, p);
                self.locations_touched = true;
            }
            (Slot::Gain(c), None) => self.gain[c] += v,
            (Slot::Gain(c), Some(p)) => {
                self.jg[p * self.n_ch + c] += v;
                self.mark(3, p);
            }
        }
    }
}
