//! The noise a fit assumes, per set-up and channel (a scale of the stated σ and an AR(1)
//! coefficient), and the prewhitening filter that makes coloured noise white; estimated by
//! [`crate::noise`].

/// The noise of one channel of one set-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelNoise {
    /// The real σ over the stated one (≥ 1).
    pub scale: f64,
    /// AR(1) coefficient of the noise in sample order (0: white).
    pub phi: f64,
    /// Differences the estimate rests on.
    pub samples: usize,
}

impl ChannelNoise {
    /// White noise of the stated σ.
    pub const STATED: ChannelNoise = ChannelNoise {
        scale: 1.0,
        phi: 0.0,
        samples: 0,
    };

    /// Whether this is the stated, white noise.
    pub fn is_stated(&self) -> bool {
        self.scale == 1.0 && self.phi == 0.0
    }
}

/// Per set-up (the study's order) and channel, the noise the fit assumes.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseModel {
    pub per_setup: Vec<Vec<ChannelNoise>>,
}

impl NoiseModel {
    /// The noise of channel `c` of set-up `s`.
    pub fn of(&self, s: usize, c: usize) -> ChannelNoise {
        self.per_setup
            .get(s)
            .and_then(|v| v.get(c))
            .copied()
            .unwrap_or(ChannelNoise::STATED)
    }

    /// Whether every channel keeps the stated, white noise (the model changes nothing).
    pub fn is_stated(&self) -> bool {
        self.per_setup.iter().flatten().all(ChannelNoise::is_stated)
    }
}

/// One step of the AR(1) prewhitening filter of a channel's rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ArStep {
    pub phi: f64,
    /// The previous row of this channel is the previous sample of the run (otherwise the chain
    /// starts again here).
    pub continued: bool,
}

impl ArStep {
    /// The prewhitened value of `x` given the previous sample's `prev`.
    pub fn apply(&self, x: f64, prev: f64) -> f64 {
        if self.continued && self.phi != 0.0 {
            (x - self.phi * prev) / (1.0 - self.phi * self.phi).sqrt()
        } else {
            x
        }
    }

    /// Whether the filter changes anything.
    pub fn active(&self) -> bool {
        self.continued && self.phi != 0.0
    }
}

/// `values` prewhitened with `phi` (Prais–Winsten; the first value as it is).
pub(crate) fn prewhiten(values: &[f64], phi: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(values.len());
    for (i, &v) in values.iter().enumerate() {
        let step = ArStep {
            phi,
            continued: i > 0,
        };
        out.push(step.apply(v, if i > 0 { values[i - 1] } else { 0.0 }));
    }
    out
}
