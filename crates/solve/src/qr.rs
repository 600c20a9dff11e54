//! The dense kernel of the streaming QR: fold a block of new rows `B` into an upper-triangular
//! factor `R`, i.e. compute the QR factorisation of the stacked matrix `[R; B]` while using that
//! `R` is already triangular.
//!
//! This is LAPACK's `tpqrt` (a "triangle-pentagon" QR) written with faer's matrix products:
//! Householder reflector `j` is `I − τ u uᵀ` with `u = [e_j; v]`; its part in the `R` rows is a
//! unit vector because `R` is triangular, so only the `B` rows (`v`) are stored, in place of the
//! eliminated column of `B`. Reflectors are grouped in panels (compact WY form `I − V T Vᵀ`,
//! Schreiber–Van Loan) and applied to the columns right of the panel with two matrix products;
//! panels are factored recursively (Elmroth–Gustavson) so almost all flops run in faer's
//! vectorised `matmul`. Cost: `2·k·e²` flops for `k` rows and `e` columns, about twice the
//! normal equations, in exchange for not squaring the condition number.
//!
//! Diagonal entries of `R` come out non-negative (the `β ≥ 0` Householder convention of LAPACK's
//! `dlarfgp`), so `R` is unique for a full-rank Jacobian: accumulating the same rows in a different
//! order or on a different number of threads changes it only by rounding.

use faer::prelude::*;
use faer::{Accum, MatMut, MatRef, Par};

/// Width of the panels whose reflectors are applied to the trailing columns together.
const PANEL: usize = 32;
/// Panels up to this width are factored column by column (level-2 loops).
const LEAF: usize = 4;

/// Scratch for [`fold`], sized for at most `max_cols` columns (including the right-hand side).
#[derive(Debug, Clone)]
pub(crate) struct Scratch {
    t: Vec<f64>,
    w1: Vec<f64>,
    w2: Vec<f64>,
    g: Vec<f64>,
    max_cols: usize,
}

impl Scratch {
    pub(crate) fn new(max_cols: usize) -> Self {
        Self {
            t: vec![0.0; PANEL * PANEL],
            w1: vec![0.0; PANEL * max_cols.max(1)],
            w2: vec![0.0; PANEL * max_cols.max(1)],
            g: vec![0.0; PANEL * PANEL],
            max_cols,
        }
    }
}

/// Folds the rows of `bot` (`k × (e+1)`, the last column is the right-hand side) into `top`
/// (`e × (e+1)`: an upper-triangular `R` whose strictly lower part must be zero, and `z` as its
/// last column).
///
/// On return `top` holds the `R` and `z` of `[top; bot]`, the first `e` columns of `bot` hold the
/// Householder vectors, and the last column of `bot` holds the part of the right-hand side that no
/// column explains (its squared norm is the residual sum of squares added by these rows).
pub(crate) fn fold(mut top: MatMut<'_, f64>, mut bot: MatMut<'_, f64>, scratch: &mut Scratch) {
    let e = top.nrows();
    debug_assert_eq!(top.ncols(), e + 1);
    debug_assert_eq!(bot.ncols(), e + 1);
    debug_assert!(e < scratch.max_cols);
    if bot.nrows() == 0 {
        return;
    }
    let mut p0 = 0;
    while p0 < e {
        let pb = PANEL.min(e - p0);
        let (tf, rest) = scratch_split(scratch, pb);
        let mut tf = tf;
        tf.fill(0.0);
        {
            let tt = top.rb_mut().submatrix_mut(p0, p0, pb, pb);
            let bp = bot.rb_mut().subcols_mut(p0, pb);
            factor_panel(tt, bp, tf.rb_mut(), rest.g);
        }
        let q = e + 1 - (p0 + pb);
        let (vb, btr) = bot.rb_mut().split_at_col_mut(p0 + pb);
        let vb = vb.subcols(p0, pb);
        let ttop = top.rb_mut().submatrix_mut(p0, p0 + pb, pb, q);
        apply_block(vb.rb(), tf.rb(), ttop, btr, rest.w1, rest.w2);
        p0 += pb;
    }
}

struct Rest<'a> {
    w1: &'a mut [f64],
    w2: &'a mut [f64],
    g: &'a mut [f64],
}

fn scratch_split(s: &mut Scratch, pb: usize) -> (MatMut<'_, f64>, Rest<'_>) {
    let tf = MatMut::from_column_major_slice_mut(&mut s.t[..pb * pb], pb, pb);
    (
        tf,
        Rest {
            w1: &mut s.w1,
            w2: &mut s.w2,
            g: &mut s.g,
        },
    )
}

/// Applies `Qᵀ = I − V Tᵀ Vᵀ` (with `V = [I; vb]`) to the columns `[ttop; btr]`.
fn apply_block(
    vb: MatRef<'_, f64>,
    t: MatRef<'_, f64>,
    mut ttop: MatMut<'_, f64>,
    btr: MatMut<'_, f64>,
    w1: &mut [f64],
    w2: &mut [f64],
) {
    let (p, q) = ttop.shape();
    if q == 0 {
        return;
    }
    let mut w = MatMut::from_column_major_slice_mut(&mut w1[..p * q], p, q);
    let mut w2 = MatMut::from_column_major_slice_mut(&mut w2[..p * q], p, q);
    // W = Vᵀ C = Ctop + vbᵀ Cbot
    w.copy_from(ttop.rb());
    faer::linalg::matmul::matmul(
        w.rb_mut(),
        Accum::Add,
        vb.transpose(),
        btr.rb(),
        1.0,
        Par::Seq,
    );
    // W2 = Tᵀ W
    faer::linalg::matmul::matmul(
        w2.rb_mut(),
        Accum::Replace,
        t.transpose(),
        w.rb(),
        1.0,
        Par::Seq,
    );
    // C −= V W2
    for j in 0..q {
        for i in 0..p {
            ttop[(i, j)] -= w2[(i, j)];
        }
    }
    faer::linalg::matmul::matmul(btr, Accum::Add, vb, w2.rb(), -1.0, Par::Seq);
}

/// QR of the panel `[tt; bp]` (`tt` upper triangular `pb × pb`), writing the compact-WY factor
/// `T` into `tf` (upper triangular, zero below on entry).
fn factor_panel(
    mut tt: MatMut<'_, f64>,
    mut bp: MatMut<'_, f64>,
    mut tf: MatMut<'_, f64>,
    g: &mut [f64],
) {
    let pb = tt.nrows();
    if pb <= LEAF {
        factor_leaf(tt, bp, tf);
        return;
    }
    let n1 = pb / 2;
    let n2 = pb - n1;
    {
        let t11 = tt.rb_mut().submatrix_mut(0, 0, n1, n1);
        let b1 = bp.rb_mut().subcols_mut(0, n1);
        let f11 = tf.rb_mut().submatrix_mut(0, 0, n1, n1);
        factor_panel(t11, b1, f11, g);
    }
    {
        let (b1, b2) = bp.rb_mut().split_at_col_mut(n1);
        let t12 = tt.rb_mut().submatrix_mut(0, n1, n1, n2);
        let f11 = tf.rb().submatrix(0, 0, n1, n1);
        // Scratch for the trailing update of a half panel: at most PANEL/2 × PANEL/2 each.
        let (ga, gb) = g.split_at_mut(g.len() / 2);
        apply_block(b1.rb(), f11, t12, b2, ga, gb);
    }
    {
        let t22 = tt.rb_mut().submatrix_mut(n1, n1, n2, n2);
        let b2 = bp.rb_mut().subcols_mut(n1, n2);
        let f22 = tf.rb_mut().submatrix_mut(n1, n1, n2, n2);
        factor_panel(t22, b2, f22, g);
    }
    // T12 = −T11 (b1ᵀ b2) T22
    let (ga, gb) = g.split_at_mut(g.len() / 2);
    let mut m1 = MatMut::from_column_major_slice_mut(&mut ga[..n1 * n2], n1, n2);
    let mut m2 = MatMut::from_column_major_slice_mut(&mut gb[..n1 * n2], n1, n2);
    let b1 = bp.rb().subcols(0, n1);
    let b2 = bp.rb().subcols(n1, n2);
    faer::linalg::matmul::matmul(
        m1.rb_mut(),
        Accum::Replace,
        b1.transpose(),
        b2,
        1.0,
        Par::Seq,
    );
    let f11 = tf.rb().submatrix(0, 0, n1, n1);
    faer::linalg::matmul::matmul(m2.rb_mut(), Accum::Replace, f11, m1.rb(), 1.0, Par::Seq);
    let (top_f, bottom_f) = tf.rb_mut().split_at_row_mut(n1);
    let f22 = bottom_f.rb().submatrix(0, n1, n2, n2);
    let f12 = top_f.submatrix_mut(0, n1, n1, n2);
    faer::linalg::matmul::matmul(f12, Accum::Replace, m2.rb(), f22, -1.0, Par::Seq);
}

/// Column-by-column structured Householder QR of a narrow panel, building `T` as it goes
/// (LAPACK `dlarft`, forward, columnwise).
fn factor_leaf(mut tt: MatMut<'_, f64>, mut bp: MatMut<'_, f64>, mut tf: MatMut<'_, f64>) {
    let pb = tt.nrows();
    for j in 0..pb {
        let tau = {
            let v = col_slice_mut(bp.rb_mut(), j);
            householder(&mut tt[(j, j)], v)
        };
        tf[(j, j)] = tau;
        if tau == 0.0 {
            continue;
        }
        let (left, right) = bp.rb_mut().split_at_col_mut(j + 1);
        let v = col_slice(left.rb(), j);
        // Apply to the panel columns right of j.
        let mut right = right;
        for c in 0..right.ncols() {
            let b = col_slice_mut(right.rb_mut(), c);
            let w = tt[(j, j + 1 + c)] + dot(v, b);
            let tw = tau * w;
            tt[(j, j + 1 + c)] -= tw;
            axpy(-tw, v, b);
        }
        // T[0..j, j] = −τ T[0..j, 0..j] (V[:, 0..j]ᵀ v_j); the unit parts of V are orthogonal.
        if j > 0 {
            let mut s = [0.0; LEAF];
            for (i, si) in s.iter_mut().enumerate().take(j) {
                *si = dot(col_slice(left.rb(), i), v);
            }
            for i in 0..j {
                let mut acc = 0.0;
                for l in i..j {
                    acc += tf[(i, l)] * s[l];
                }
                tf[(i, j)] = -tau * acc;
            }
        }
    }
}

/// Householder reflector that maps `[alpha; x]` to `[β; 0]` with `β ≥ 0`; overwrites `alpha` with
/// β and `x` with the essential part `v` of `u = [1; v]`, and returns τ (0 when `x` is zero).
fn householder(alpha: &mut f64, x: &mut [f64]) -> f64 {
    let xnorm = norm2(x);
    if xnorm == 0.0 {
        return 0.0;
    }
    let a = *alpha;
    let beta = a.hypot(xnorm);
    // α − β without cancellation (Parlett): for α > 0, α − β = −‖x‖²/(α + β).
    let (d, tau) = if a > 0.0 {
        let s = xnorm / (a + beta);
        (-xnorm * s, (xnorm / beta) * s)
    } else {
        (a - beta, (beta - a) / beta)
    };
    if d == 0.0 || !d.is_finite() {
        return 0.0;
    }
    let inv = 1.0 / d;
    for xi in x.iter_mut() {
        *xi *= inv;
    }
    *alpha = beta;
    tau
}

fn col_slice<'a>(m: MatRef<'a, f64>, j: usize) -> &'a [f64] {
    m.col(j)
        .try_as_col_major()
        .expect("column-major storage")
        .as_slice()
}

fn col_slice_mut<'a>(m: MatMut<'a, f64>, j: usize) -> &'a mut [f64] {
    m.col_mut(j)
        .try_as_col_major_mut()
        .expect("column-major storage")
        .as_slice_mut()
}

/// Euclidean norm, scaled against overflow and underflow only when needed.
pub(crate) fn norm2(x: &[f64]) -> f64 {
    let ss = dot(x, x);
    if ss.is_finite() && ss > 1e-280 {
        return ss.sqrt();
    }
    let m = x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    let inv = 1.0 / m;
    let s: f64 = x.iter().map(|v| (v * inv) * (v * inv)).sum();
    m * s.sqrt()
}

/// Dot product (faer's SIMD kernel, dispatched at run time to the widest vector unit).
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    faer::linalg::matmul::dot::inner_prod(
        faer::ColRef::from_slice(a).transpose(),
        faer::Conj::No,
        faer::ColRef::from_slice(b),
        faer::Conj::No,
    )
}

fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// Deterministic pseudo-random numbers in [−1, 1).
    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    /// Gram matrix and right-hand side of all rows folded so far, from R and z.
    fn gram(top: MatRef<'_, f64>) -> Mat<f64> {
        let e = top.nrows();
        let r = top.get(.., ..e + 1);
        r.transpose() * r
    }

    fn check(e: usize, chunks: &[usize], seed: u64) {
        let mut s = seed;
        let mut top = Mat::<f64>::zeros(e, e + 1);
        let mut scratch = Scratch::new(e + 1);
        let mut all = Mat::<f64>::zeros(chunks.iter().sum(), e + 1);
        let mut row0 = 0;
        let mut rss = 0.0;
        for &k in chunks {
            let mut bot = Mat::<f64>::from_fn(k, e + 1, |_, _| lcg(&mut s));
            all.get_mut(row0..row0 + k, ..).copy_from(&bot);
            row0 += k;
            fold(top.as_mut(), bot.as_mut(), &mut scratch);
            rss += bot.col(e).squared_norm_l2();
        }
        // [R z; 0 √rss]ᵀ[R z; 0 √rss] must equal [J r]ᵀ[J r].
        let mut g = gram(top.as_ref());
        g[(e, e)] += rss;
        let want = all.transpose() * &all;
        let err = (&g - &want).norm_max() / want.norm_max();
        assert!(err < 1e-13, "e={e} chunks={chunks:?}: gram error {err:e}");
        for j in 0..e {
            assert!(top[(j, j)] >= 0.0, "negative diagonal");
            for i in j + 1..e {
                assert_eq!(top[(i, j)], 0.0, "R not triangular");
            }
        }
    }

    #[test]
    fn fold_matches_dense_gram() {
        check(1, &[3, 1], 1);
        check(3, &[1, 1, 1, 1, 5], 2);
        check(7, &[2, 20, 3], 3);
        check(40, &[10, 100, 1, 64], 4);
        check(111, &[256, 256, 17], 5);
    }

    #[test]
    fn zero_column_stays_zero() {
        let e = 6;
        let mut s = 9;
        let mut top = Mat::<f64>::zeros(e, e + 1);
        let mut scratch = Scratch::new(e + 1);
        for _ in 0..3 {
            let mut bot =
                Mat::<f64>::from_fn(10, e + 1, |_, j| if j == 2 { 0.0 } else { lcg(&mut s) });
            fold(top.as_mut(), bot.as_mut(), &mut scratch);
        }
        for i in 0..e {
            assert_eq!(top[(i, 2)], 0.0);
        }
        assert!(top[(3, 3)] > 0.0);
    }
}
