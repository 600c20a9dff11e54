//! The parametric bootstrap's random numbers: SplitMix64 and Box–Muller, seeded per instant,
//! so the same session gives the same intervals on any machine.

/// A small, fast generator of standard normal draws.
pub(crate) struct Normals {
    state: u64,
    spare: Option<f64>,
}

impl Normals {
    pub(crate) fn new(seed: u64) -> Self {
        Normals {
            state: seed ^ 0x6A09_E667_F3BC_C909,
            spare: None,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1].
    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }

    pub(crate) fn next(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let (u1, u2) = (self.uniform(), self.uniform());
        let r = (-2.0 * u1.ln()).sqrt();
        let a = std::f64::consts::TAU * u2;
        self.spare = Some(r * a.sin());
        r * a.cos()
    }
}

/// The `q`-quantile of `values` (sorted in place; linear between order statistics).
pub(crate) fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (values.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(values.len() - 1);
    let f = pos - lo as f64;
    values[lo] * (1.0 - f) + values[hi] * f
}

/// The basic bootstrap's 95 % interval for a statistic observed as `t` whose draws are
/// `draws`: `[2t − q₉₇.₅, 2t − q₂.₅]`, clipped at 0 (a spread or a magnitude).
pub(crate) fn basic_interval(t: f64, draws: &mut [f64]) -> [f64; 2] {
    let hi = quantile(draws, 0.975);
    let lo = quantile(draws, 0.025);
    [(2.0 * t - hi).max(0.0), (2.0 * t - lo).max(0.0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_draws_are_standard_normal() {
        let mut g = Normals::new(7);
        let n = 200_000;
        let draws: Vec<f64> = (0..n).map(|_| g.next()).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let var = draws.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.01, "{var}");
        let mut v = draws;
        assert!((quantile(&mut v, 0.975) - 1.96).abs() < 0.02);
    }
}
