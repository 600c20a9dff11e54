//! The small dense `n × n` algebra on the factor: column scaling, SVD, rank, damped minimum-norm
//! steps, predicted cost reduction and covariance.

use faer::Mat;

use crate::SolveError;
use crate::eval::Lin;

/// A factor falls into independent blocks when its largest block has at most this share of its
/// columns: then each block is decomposed alone. Five sensors' thermal models, each its own
/// channel, are five blocks: five SVDs of a fifth the size cost a twenty-fifth as much. A
/// factor with one dominant block (a machine's errors, a few parameters seen by no run beside)
/// is decomposed whole, as before.
const BLOCKS_BELOW_SHARE: f64 = 0.5;

/// The singular values of the upper-triangular `rs` (descending), its right singular vectors
/// (columns, in that order) and `Uᵀ z`. Where `rs` is block diagonal after a permutation — the
/// connected components of its pattern, [`BLOCKS_BELOW_SHARE`] — each block's SVD is taken
/// alone and the decompositions merged: the same factorisation, to rounding.
fn svd_by_blocks(rs: &Mat<f64>, z: &[f64]) -> Result<Decomposed, SolveError> {
    let n = rs.nrows();
    let blocks = blocks_of(rs);
    let largest = blocks.iter().map(Vec::len).max().unwrap_or(0);
    let whole = [(0..n).collect::<Vec<_>>()];
    let blocks: &[Vec<usize>] = if (largest as f64) <= BLOCKS_BELOW_SHARE * n as f64 {
        &blocks
    } else {
        &whole
    };
    // Per block its singular values, and per singular value (block, index in the block).
    let mut parts = Vec::with_capacity(blocks.len());
    let mut order: Vec<(f64, usize, usize)> = Vec::with_capacity(n);
    for (b, cols) in blocks.iter().enumerate() {
        let m = cols.len();
        let sub = Mat::<f64>::from_fn(m, m, |i, j| rs[(cols[i], cols[j])]);
        let svd = sub.svd().map_err(|e| {
            SolveError::Numerical(format!("the SVD of the scaled Jacobian failed: {e:?}"))
        })?;
        let sb: Vec<f64> = svd.S().column_vector().iter().copied().collect();
        order.extend(sb.iter().enumerate().map(|(k, &sk)| (sk, b, k)));
        parts.push((svd.U().to_owned(), svd.V().to_owned()));
    }
    // Descending; ties in block order, as a block's own SVD orders them.
    order.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut v = Mat::<f64>::zeros(n, n);
    let mut c = vec![0.0; n];
    for (p, &(_, b, k)) in order.iter().enumerate() {
        let (u_b, v_b) = &parts[b];
        let cols = &blocks[b];
        for (a, &j) in cols.iter().enumerate() {
            v[(j, p)] = v_b[(a, k)];
        }
        c[p] = cols
            .iter()
            .enumerate()
            .map(|(a, &j)| u_b[(a, k)] * z[j])
            .sum();
    }
    let s = order.iter().map(|o| o.0).collect();
    Ok(Decomposed { s, v, c })
}

/// What [`svd_by_blocks`] gives: the singular values (descending), the right singular vectors
/// (columns, in that order) and `Uᵀ z`.
struct Decomposed {
    s: Vec<f64>,
    v: Mat<f64>,
    c: Vec<f64>,
}

/// The connected components of the pattern of the upper-triangular `rs` (columns `i` and `j`
/// joined by a non-zero `rs[i, j]`), each in increasing column order, ordered by their first
/// column.
fn blocks_of(rs: &Mat<f64>) -> Vec<Vec<usize>> {
    let n = rs.nrows();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for j in 0..n {
        for i in 0..j {
            if rs[(i, j)] != 0.0 {
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    let mut index = vec![usize::MAX; n];
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    for j in 0..n {
        let r = root(&mut parent, j);
        if index[r] == usize::MAX {
            index[r] = blocks.len();
            blocks.push(Vec::new());
        }
        blocks[index[r]].push(j);
    }
    blocks
}

/// SVD of the column-scaled factor `R·D⁻¹ = U Σ Vᵀ` at one point.
#[derive(Debug, Clone)]
pub(crate) struct Analysis {
    /// Column norms of the (whitened, prior-augmented) Jacobian; 1 for empty columns.
    pub(crate) d: Vec<f64>,
    /// Singular values, descending.
    pub(crate) s: Vec<f64>,
    pub(crate) v: Mat<f64>,
    /// `Uᵀ z`.
    pub(crate) c: Vec<f64>,
    /// Number of singular values above the threshold.
    pub(crate) rank: usize,
}

impl Analysis {
    /// `floor[p]` (per parameter, 0 for none) is the least column scale of parameter `p`
    /// (`1/ParamSpec::scale`).
    pub(crate) fn new(lin: &Lin, rank_tolerance: f64, floor: &[f64]) -> Result<Self, SolveError> {
        let n = lin.n();
        let mut visible = vec![true; n];
        let d: Vec<f64> = (0..n)
            .map(|j| {
                let norm = crate::qr::norm2(&lin.r[j * n..j * n + j + 1]);
                let f = floor.get(lin.order[j]).copied().unwrap_or(0.0);
                visible[j] = crate::visible(norm, f);
                let d = norm.max(f);
                if d > 0.0 { d } else { 1.0 }
            })
            .collect();
        let rs = Mat::<f64>::from_fn(n, n, |i, j| {
            if i <= j && visible[j] {
                lin.r[i + j * n] / d[j]
            } else {
                0.0
            }
        });
        if n == 0 {
            return Ok(Self {
                d,
                s: Vec::new(),
                v: Mat::zeros(0, 0),
                c: Vec::new(),
                rank: 0,
            });
        }
        if !rs.as_ref().is_all_finite() {
            return Err(SolveError::Numerical(
                "the scaled Jacobian factor is not finite".into(),
            ));
        }
        let Decomposed { s, mut v, c } = svd_by_blocks(&rs, &lin.z)?;
        let smax = s.first().copied().unwrap_or(0.0);
        let rank = s
            .iter()
            .filter(|&&si| si > rank_tolerance * smax && si > 0.0)
            .count();
        // A zero column lies exactly in the null space: the identified directions have no
        // component along it, but the SVD leaves rounding there, which a weak direction's 1/σ
        // turns into a step. A parameter whose column is zero to first order at a degenerate
        // point (a ball-bar pivot's height in a circle at that height) then drifted off the
        // point by rounding, its column grew with the drift, and whether it ended identified
        // depended on the rounding (the order of the sums, the machine).
        for j in 0..n {
            if !visible[j] || lin.r[j * n..j * n + j + 1].iter().all(|&r| r == 0.0) {
                for i in 0..rank {
                    v[(j, i)] = 0.0;
                }
            }
        }
        Ok(Self { d, s, v, c, rank })
    }

    /// `σ_max²`, the natural unit of the damping λ.
    pub(crate) fn s2max(&self) -> f64 {
        self.s
            .first()
            .map_or(1.0, |s| if *s > 0.0 { s * s } else { 1.0 })
    }

    /// The damped step `argmin ‖R dx + z‖² + λ‖D dx‖²` restricted to the identified directions
    /// (column order of the factor).
    pub(crate) fn step(&self, lambda: f64) -> Vec<f64> {
        let n = self.d.len();
        let mut y = vec![0.0; n];
        for i in 0..self.rank {
            let si = self.s[i];
            let coef = -si * self.c[i] / (si * si + lambda);
            for (j, yj) in y.iter_mut().enumerate() {
                *yj += coef * self.v[(j, i)];
            }
        }
        for (yj, dj) in y.iter_mut().zip(&self.d) {
            *yj /= dj;
        }
        y
    }

    /// The Gauss–Newton step `−(RᵀR)⁺·g` for a gradient `g` evaluated elsewhere (the chord
    /// method: this factor stands in for the one at the new point), restricted to the identified
    /// directions, and its length `‖R·dx‖`. Column order of the factor.
    pub(crate) fn chord_step(&self, g: &[f64]) -> (Vec<f64>, f64) {
        let n = self.d.len();
        let gs: Vec<f64> = g.iter().zip(&self.d).map(|(a, d)| a / d).collect();
        let mut y = vec![0.0; n];
        let mut len2 = 0.0;
        for i in 0..self.rank {
            let vg: f64 = (0..n).map(|j| self.v[(j, i)] * gs[j]).sum();
            let si = self.s[i];
            len2 += (vg / si) * (vg / si);
            let coef = -vg / (si * si);
            for (j, yj) in y.iter_mut().enumerate() {
                *yj += coef * self.v[(j, i)];
            }
        }
        for (yj, dj) in y.iter_mut().zip(&self.d) {
            *yj /= dj;
        }
        (y, len2.sqrt())
    }

    /// Probe directions for checking whether another point's Jacobian `J` has the metric of
    /// this factor. First `identified.len()`… directions `u` in the identified subspace with
    /// `‖R·u‖ = 1` — `dx` itself, the `weakest` least determined singular directions (where a
    /// small change of the Jacobian matters most) and `random` fixed pseudo-random ones — on
    /// which `‖J·u‖² − 1` is the relative change of the metric along `u`; then one unit
    /// (scaled) direction per null-space vector, on which `‖J·u‖` must stay below the rank
    /// threshold for the rank to hold. Returns the probes (`k × n`, probe-major, column order
    /// of the factor) and how many of them, at the end, are null-space probes.
    pub(crate) fn probes(
        &self,
        lin: &Lin,
        dx: &[f64],
        weakest: usize,
        random: usize,
    ) -> (Vec<f64>, usize) {
        let n = self.d.len();
        let mut out = Vec::new();
        let (_, len) = predicted(lin, dx);
        if len > 0.0 {
            out.extend(dx.iter().map(|v| v / len));
        }
        // u = D⁻¹ Σᵢ vᵢ aᵢ/σᵢ with ‖a‖ = 1 gives R·u = Σᵢ aᵢ·uᵢ (left singular vectors).
        let push = |a: &[f64], out: &mut Vec<f64>| {
            let norm = crate::qr::norm2(a);
            if norm == 0.0 {
                return;
            }
            let mut u = vec![0.0; n];
            for (i, ai) in a.iter().enumerate() {
                if *ai == 0.0 {
                    continue;
                }
                let coef = ai / (norm * self.s[i]);
                for (j, uj) in u.iter_mut().enumerate() {
                    *uj += coef * self.v[(j, i)];
                }
            }
            for (uj, dj) in u.iter_mut().zip(&self.d) {
                *uj /= dj;
            }
            out.extend(u);
        };
        for i in (0..self.rank).rev().take(weakest) {
            let mut a = vec![0.0; self.rank];
            a[i] = 1.0;
            push(&a, &mut out);
        }
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..random {
            let a: Vec<f64> = (0..self.rank)
                .map(|_| {
                    seed = seed
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1_442_695_040_888_963_407);
                    (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                })
                .collect();
            push(&a, &mut out);
        }
        for k in self.rank..n {
            out.extend((0..n).map(|j| self.v[(j, k)] / self.d[j]));
        }
        (out, n - self.rank)
    }

    /// Whether the null space of this factor is still (numerically) null for another point's
    /// Hessian `H`, given `cross` = `H·u_k` (`n × k`, column-major) for the null-space probes
    /// `u_k = D⁻¹vₖ` of [`Self::probes`]. The test is on the Schur complement of the
    /// identified block, `S = WᵀHW − WᵀHV Σ⁻² VᵀHW` (scaled), which does not mind the null
    /// space turning slightly: its norm must stay below `(rank_tolerance · σ_max)²`, the
    /// threshold that decides the rank. `VᵀHV = Σ²` is what the metric probes check.
    pub(crate) fn null_space_kept(&self, cross: &[f64], rank_tolerance: f64) -> bool {
        let n = self.d.len();
        let m = n - self.rank;
        if m == 0 {
            return true;
        }
        // h_k = D⁻¹·H·u_k, the scaled Hessian applied to the scaled null vector.
        let h: Vec<Vec<f64>> = cross
            .chunks_exact(n)
            .map(|c| c.iter().zip(&self.d).map(|(a, d)| a / d).collect())
            .collect();
        // Projections of each h_k on the identified directions, divided by σᵢ.
        let proj: Vec<Vec<f64>> = h
            .iter()
            .map(|hk| {
                (0..self.rank)
                    .map(|i| (0..n).map(|j| self.v[(j, i)] * hk[j]).sum::<f64>() / self.s[i])
                    .collect()
            })
            .collect();
        let mut frob2 = 0.0;
        for k in 0..m {
            for l in 0..m {
                let vk_hl: f64 = (0..n).map(|j| self.v[(j, self.rank + k)] * h[l][j]).sum();
                let sk = vk_hl - crate::qr::dot(&proj[k], &proj[l]);
                frob2 += sk * sk;
            }
        }
        let limit = rank_tolerance * self.s.first().copied().unwrap_or(0.0);
        frob2.sqrt() <= limit * limit
    }

    /// `‖D·dx‖`.
    pub(crate) fn scaled_norm(&self, dx: &[f64]) -> f64 {
        let scaled: Vec<f64> = dx.iter().zip(&self.d).map(|(a, d)| a * d).collect();
        crate::qr::norm2(&scaled)
    }

    /// Covariance `D⁻¹ V_r Σ_r⁻² V_rᵀ D⁻¹` in the column order of the factor.
    pub(crate) fn covariance(&self) -> Mat<f64> {
        let n = self.d.len();
        let m = Mat::<f64>::from_fn(n, self.rank, |j, i| {
            self.v[(j, i)] / (self.s[i] * self.d[j])
        });
        &m * m.transpose()
    }

    /// Null-space basis (one column per direction) in scaled units, rows in factor order.
    pub(crate) fn null_space(&self) -> Mat<f64> {
        let n = self.d.len();
        Mat::<f64>::from_fn(n, n - self.rank, |j, k| self.v[(j, self.rank + k)])
    }
}

/// The linear model's prediction for a step: `(cost − model cost, ‖R·dx‖)`, with
/// `cost − model = −zᵀ(R dx) − ½‖R dx‖²` (no cancellation against the constant part).
pub(crate) fn predicted(lin: &Lin, dx: &[f64]) -> (f64, f64) {
    let n = lin.n();
    let mut w = vec![0.0; n];
    for (j, &dxj) in dx.iter().enumerate() {
        if dxj == 0.0 {
            continue;
        }
        let col = &lin.r[j * n..j * n + j + 1];
        for (wi, &rij) in w.iter_mut().zip(col) {
            *wi += rij * dxj;
        }
    }
    let zw = crate::qr::dot(&lin.z, &w);
    let ww = crate::qr::dot(&w, &w);
    (-zw - 0.5 * ww, ww.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An upper-triangular factor whose columns fall into blocks (a column's block drawn at
    /// random, entries between blocks zero), with a zero column and one block rank-deficient:
    /// decomposed block by block, the same singular values and the same minimum-norm
    /// solution `V Σ⁺ Uᵀ z` as one SVD of the whole. Fails with a block's rows or columns
    /// mixed up in the merge.
    #[test]
    fn a_block_diagonal_factor_decomposes_as_a_whole() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut rand = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let n = 23;
        let block: Vec<usize> = (0..n).map(|_| ((rand() + 0.5) * 4.0) as usize).collect();
        let mut rs = Mat::<f64>::from_fn(n, n, |i, j| {
            if i <= j && block[i] == block[j] {
                if i == j { 1.0 + rand() } else { rand() }
            } else {
                0.0
            }
        });
        // Column 5 empty; in column 9's block, column 9 a copy of the first column before it.
        for i in 0..n {
            rs[(i, 5)] = 0.0;
        }
        let first = (0..9).find(|&j| block[j] == block[9] && j != 5).unwrap();
        for i in 0..n {
            rs[(i, 9)] = rs[(i, first)];
        }
        let z: Vec<f64> = (0..n).map(|_| rand()).collect();
        assert!(blocks_of(&rs).len() >= 4, "{:?}", blocks_of(&rs));
        let Decomposed { s, v, c } = svd_by_blocks(&rs, &z).unwrap();
        let whole = rs.svd().unwrap();
        let s_whole: Vec<f64> = whole.S().column_vector().iter().copied().collect();
        let u = whole.U();
        let c_whole: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|k| u[(k, i)] * z[k]).sum())
            .collect();
        let solution = |s: &[f64], v: &Mat<f64>, c: &[f64]| -> Vec<f64> {
            (0..n)
                .map(|j| {
                    (0..n)
                        .filter(|&i| s[i] > 1e-9 * s[0])
                        .map(|i| v[(j, i)] * c[i] / s[i])
                        .sum()
                })
                .collect()
        };
        let (x, x_whole) = (
            solution(&s, &v, &c),
            solution(&s_whole, &whole.V().to_owned(), &c_whole),
        );
        for k in 0..n {
            assert!(
                (s[k] - s_whole[k]).abs() < 1e-12 * s_whole[0],
                "{s:?}\n{s_whole:?}"
            );
            assert!((x[k] - x_whole[k]).abs() < 1e-9, "{x:?}\n{x_whole:?}");
        }
        assert_eq!(s.iter().filter(|&&v| v > 1e-9 * s[0]).count(), n - 2);
    }

    /// `R = diag(2, 1, 0)`: rank 2, null direction e₃.
    fn deficient() -> (Lin, Analysis) {
        let lin = Lin {
            order: vec![0, 1, 2],
            r: vec![2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            z: vec![0.0; 3],
            rss: 0.0,
            cost: 0.0,
            n_rows: 3,
            usage: vec![1; 3],
        };
        let an = Analysis::new(&lin, 1e-9, &[]).unwrap();
        (lin, an)
    }

    /// `H·u` for the null probe `u` of [`deficient`].
    fn h_times_null(an: &Analysis, lin: &Lin, h: [[f64; 3]; 3]) -> Vec<f64> {
        let (probes, n_null) = an.probes(lin, &[1.0, 0.0, 0.0], 0, 0);
        assert_eq!(n_null, 1);
        let u = &probes[probes.len() - 3..];
        (0..3)
            .map(|i| (0..3).map(|j| h[i][j] * u[j]).sum())
            .collect()
    }

    /// The same Hessian keeps the null space; one where the null direction turned a little
    /// (a rotation of `R` by 10⁻⁶ rad) keeps it too: the Schur complement does not see the
    /// turn. A Hessian in which e₃ gained a singular value above the threshold does not.
    #[test]
    fn null_space_check_sees_new_directions_not_turns() {
        let (lin, an) = deficient();
        assert_eq!(an.rank, 2);
        let same = [[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]];
        assert!(an.null_space_kept(&h_times_null(&an, &lin, same), 1e-9));
        // H = Qᵀ·diag(4, 1, 0)·Q with Q a rotation by θ in the (1, 3) plane.
        let (c, s) = (1e-6f64.cos(), 1e-6f64.sin());
        let turned = [
            [4.0 * c * c, 0.0, 4.0 * c * s],
            [0.0, 1.0, 0.0],
            [4.0 * c * s, 0.0, 4.0 * s * s],
        ];
        let cross = h_times_null(&an, &lin, turned);
        assert!(
            cross[0].abs() > 1e-6,
            "the turn is visible in H·u: {cross:?}"
        );
        assert!(an.null_space_kept(&cross, 1e-9));
        let smax = 2.0;
        for (sigma, kept) in [(0.5e-9 * smax, true), (3e-9 * smax, false)] {
            let grown = [[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, sigma * sigma]];
            assert_eq!(
                an.null_space_kept(&h_times_null(&an, &lin, grown), 1e-9),
                kept,
                "σ = {sigma:e}"
            );
        }
    }

    /// The chord step with this factor's own gradient is its Gauss–Newton step.
    #[test]
    fn chord_step_with_the_own_gradient_is_the_gauss_newton_step() {
        let lin = Lin {
            order: vec![0, 1],
            r: vec![2.0, 0.0, 0.5, 1.0],
            z: vec![0.3, -0.7],
            rss: 0.0,
            cost: 0.0,
            n_rows: 2,
            usage: vec![1; 2],
        };
        let an = Analysis::new(&lin, 1e-9, &[]).unwrap();
        // g = Rᵀz
        let g = [2.0 * 0.3, 0.5 * 0.3 + 1.0 * -0.7];
        let (chord, len) = an.chord_step(&g);
        let gn = an.step(0.0);
        for (a, b) in chord.iter().zip(&gn) {
            assert!((a - b).abs() < 1e-14, "{chord:?} vs {gn:?}");
        }
        assert!((len - predicted(&lin, &gn).1).abs() < 1e-14);
    }
}
