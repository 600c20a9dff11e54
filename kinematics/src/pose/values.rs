//! Basis values on the hot path: Legendre and Fourier series, reciprocals, the packed
//! monomial form.

use super::*;

/// `1/n` (a table for the small `n` of the Legendre recurrence keeps division off the hot path;
/// the values are the correctly rounded quotients, as `1.0 / n as f64`).
#[inline]
pub(super) fn recip(n: usize) -> f64 {
    const TABLE: [f64; 9] = [
        f64::INFINITY,
        1.0,
        1.0 / 2.0,
        1.0 / 3.0,
        1.0 / 4.0,
        1.0 / 5.0,
        1.0 / 6.0,
        1.0 / 7.0,
        1.0 / 8.0,
    ];
    if n < TABLE.len() {
        TABLE[n]
    } else {
        1.0 / n as f64
    }
}

/// `P_0 … P_(len−1)` at `q` on the stroke `(lo, hi)`, held at the ends outside it: the same
/// recurrence and rounding as [`crate::Basis`]'s Legendre evaluation.
#[inline]
pub(super) fn legendre_values(stroke: (f64, f64), q: f64, out: &mut [f64]) {
    let u = normalised(stroke, q);
    let (mut p_prev, mut p) = (0.0, 1.0);
    let n = out.len();
    for (k, o) in out.iter_mut().enumerate() {
        *o = p;
        if k + 1 < n {
            let p_next = ((2 * k + 1) as f64 * u * p - k as f64 * p_prev) * recip(k + 1);
            (p_prev, p) = (p, p_next);
        }
    }
}

/// The shared Fourier functions `1, cos q, sin q, cos 2q, sin 2q, …` at `q` into `out`: the
/// same angle-addition recurrence and rounding as [`crate::Basis`]'s Fourier evaluation.
#[inline]
pub(super) fn fourier_values(q: f64, out: &mut [f64]) {
    let Some((one, harmonics)) = out.split_first_mut() else {
        return;
    };
    *one = 1.0;
    let (s1, c1) = q.sin_cos();
    let (mut c, mut s) = (1.0, 0.0);
    for pair in harmonics.chunks_exact_mut(2) {
        (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
        pair[0] = c;
        pair[1] = s;
    }
}

/// `a == b` bit for bit (so NaN never matches a number), four lanes at a time without early
/// exit: this runs on every evaluation, and the usual answer is "equal".
#[inline]
pub(super) fn bitwise_equal(a: &[f64], b: &[f64]) -> bool {
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .fold(0u64, |acc, (x, y)| acc | (x.to_bits() ^ y.to_bits()));
    let lanes = ca.zip(cb).fold([0u64; 4], |mut acc, (x, y)| {
        for k in 0..4 {
            acc[k] |= x[k].to_bits() ^ y[k].to_bits();
        }
        acc
    });
    a.len() == b.len() && (tail | lanes[0] | lanes[1] | lanes[2] | lanes[3]) == 0
}

/// `q` mapped from the stroke `(lo, hi)` to `[−1, 1]`, held at the ends outside it.
#[inline(always)]
pub(super) fn normalised((lo, hi): (f64, f64), q: f64) -> f64 {
    let x = if q < lo {
        lo
    } else if q > hi {
        hi
    } else {
        q
    };
    (x - lo) * (2.0 / (hi - lo)) - 1.0
}

/// `P_k(u) = Σ_j L[k][j]·u^j` for `k < PACKED_TERMS` (Bonnet's recurrence on the monomial
/// coefficients; all entries are small exact-enough rationals).
pub(super) fn legendre_monomials() -> [[f64; PACKED_TERMS]; PACKED_TERMS] {
    let mut l = [[0.0; PACKED_TERMS]; PACKED_TERMS];
    l[0][0] = 1.0;
    l[1][1] = 1.0;
    for k in 1..PACKED_TERMS - 1 {
        // (k+1)·P_(k+1) = (2k+1)·u·P_k − k·P_(k−1)
        let (a, b, c) = ((2 * k + 1) as f64, k as f64, (k + 1) as f64);
        for j in 0..PACKED_TERMS {
            let up = if j > 0 { l[k][j - 1] } else { 0.0 };
            l[k + 1][j] = (a * up - b * l[k - 1][j]) / c;
        }
    }
    l
}
