//! The weighted straight line `y = level + slope·(x − x_ref)` both the drift and the
//! temperature sensitivity fit.

/// A weighted least-squares line. `x_ref` is the weighted mean of `x`, where the level and the
/// slope are uncorrelated.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Line {
    pub x_ref: f64,
    pub level: f64,
    pub slope: f64,
    /// Standard uncertainties from the stated ones (before any Birge inflation).
    pub sd_level: f64,
    pub sd_slope: f64,
    pub chi2: f64,
}

/// The weighted line through `(x, y)` with standard uncertainties `sigma`, weights `1/σ²`.
///
/// The caller guarantees equal lengths, positive finite `sigma` and at least two different
/// `x`. Weights are taken relative to the smallest σ, so the sums stay in range whatever the
/// unit (metres or micrometres); `None` when they still overflow.
pub(crate) fn fit_line(x: &[f64], y: &[f64], sigma: &[f64]) -> Option<Line> {
    let s = sigma.iter().copied().fold(f64::INFINITY, f64::min);
    let w = |i: usize| (s / sigma[i]).powi(2);
    let n = x.len();
    let (mut sw, mut swx, mut swy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        sw += w(i);
        swx += w(i) * x[i];
        swy += w(i) * y[i];
    }
    let (x_ref, y_mean) = (swx / sw, swy / sw);
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for i in 0..n {
        let dx = x[i] - x_ref;
        sxx += w(i) * dx * dx;
        sxy += w(i) * dx * (y[i] - y_mean);
    }
    let slope = sxy / sxx;
    let mut chi2 = 0.0;
    for i in 0..n {
        let r = (y[i] - y_mean - slope * (x[i] - x_ref)) / s;
        chi2 += w(i) * r * r;
    }
    let line = Line {
        x_ref,
        level: y_mean,
        slope,
        sd_level: s / sw.sqrt(),
        sd_slope: s / sxx.sqrt(),
        chi2,
    };
    let numbers = [x_ref, y_mean, slope, line.sd_level, line.sd_slope, chi2];
    (numbers.iter().all(|v| v.is_finite()) && sxx > 0.0).then_some(line)
}
