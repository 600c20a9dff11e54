//! The first-order lag: the response of a thermal node to an input (spindle speed, a
//! temperature) through one time constant, with its derivative by the time constant.
//!
//! The input is held between samples (zero-order hold: during `(tₙ₋₁, tₙ]` it is `uₙ₋₁`), which
//! makes the discrete recursion exact for any spacing of the samples:
//!
//! ```text
//! y₀ = u₀                                  (the node starts in equilibrium with its input)
//! yₙ = a·yₙ₋₁ + (1 − a)·uₙ₋₁,   a = exp(−Δₙ/τ),  Δₙ = tₙ − tₙ₋₁
//! ∂yₙ/∂τ = a·∂yₙ₋₁/∂τ + a·(Δₙ/τ²)·(yₙ₋₁ − uₙ₋₁)
//! ```

/// The lagged series and its derivative by τ, on the input's samples.
#[derive(Clone, Debug, PartialEq)]
pub struct LagSeries {
    pub y: Vec<f64>,
    /// `∂y/∂τ`, per second of τ.
    pub dy_dtau: Vec<f64>,
}

/// First-order lag of `u` (sampled at the non-decreasing times `t`, s) with time constant
/// `tau_s` > 0. A step back in time (two runs recorded out of order) counts as no time passing.
pub fn first_order_lag(u: &[f64], t: &[f64], tau_s: f64) -> LagSeries {
    debug_assert_eq!(u.len(), t.len());
    first_order_lag_over(u, t.iter().copied(), tau_s)
}

/// [`first_order_lag`] with the times given one after another (a session's timeline, read
/// from its runs' columns).
pub fn first_order_lag_over(u: &[f64], t: impl IntoIterator<Item = f64>, tau_s: f64) -> LagSeries {
    let n = u.len();
    let mut y = Vec::with_capacity(n);
    let mut dy = Vec::with_capacity(n);
    let mut t = t.into_iter();
    let (Some(&u0), Some(mut t_prev)) = (u.first(), t.next()) else {
        return LagSeries { y, dy_dtau: dy };
    };
    y.push(u0);
    dy.push(0.0);
    for (k, tk) in (1..n).zip(t) {
        let step = (tk - t_prev).max(0.0);
        t_prev = tk;
        let a = (-step / tau_s).exp();
        let (yp, dp, up) = (y[k - 1], dy[k - 1], u[k - 1]);
        y.push(a * yp + (1.0 - a) * up);
        dy.push(a * dp + a * (step / (tau_s * tau_s)) * (yp - up));
    }
    LagSeries { y, dy_dtau: dy }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_rises_as_one_minus_exp() {
        // A step at t = 0 (held from the first sample on): y = 1 − exp(−t/τ).
        let t: Vec<f64> = (0..200).map(|k| 7.0 * k as f64).collect();
        let mut u = vec![1.0; t.len()];
        u[0] = 1.0;
        let s = first_order_lag(&u, &t, 300.0);
        // Starting in equilibrium with u₀ = 1 it stays at 1.
        assert!(s.y.iter().all(|&v| (v - 1.0).abs() < 1e-15));
        u[0] = 0.0;
        let s = first_order_lag(&u, &t, 300.0);
        for (k, &tk) in t.iter().enumerate().skip(1) {
            // The step reaches the node at the end of the first interval's hold: u₀ = 0 over
            // (t₀, t₁], then 1.
            let expect = 1.0 - (-(tk - t[1]) / 300.0).exp();
            assert!(
                (s.y[k] - expect).abs() < 1e-12,
                "{k}: {} vs {expect}",
                s.y[k]
            );
        }
    }

    #[test]
    fn derivative_by_tau_matches_differences() {
        let t: Vec<f64> = (0..300).map(|k| 15.0 * k as f64 + (k % 7) as f64).collect();
        let u: Vec<f64> = t
            .iter()
            .map(|&x| {
                if (x / 900.0) as i64 % 2 == 0 {
                    3.0
                } else {
                    0.5
                }
            })
            .collect();
        let tau = 640.0;
        let h = 1e-3;
        let s = first_order_lag(&u, &t, tau);
        let p = first_order_lag(&u, &t, tau + h);
        let m = first_order_lag(&u, &t, tau - h);
        for k in 0..t.len() {
            let fd = (p.y[k] - m.y[k]) / (2.0 * h);
            assert!(
                (s.dy_dtau[k] - fd).abs() < 1e-8 * (1.0 + fd.abs()),
                "{k}: {} vs {fd}",
                s.dy_dtau[k]
            );
        }
    }

    #[test]
    fn uneven_spacing_is_exact() {
        // Two halves of one interval give the same state as the whole interval when the input
        // is held.
        let whole = first_order_lag(&[0.0, 2.0, 2.0], &[0.0, 10.0, 110.0], 50.0);
        let split = first_order_lag(&[0.0, 2.0, 2.0, 2.0], &[0.0, 10.0, 60.0, 110.0], 50.0);
        assert!((whole.y[2] - split.y[3]).abs() < 1e-14);
    }
}
