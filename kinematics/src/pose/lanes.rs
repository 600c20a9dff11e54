//! Arithmetic on [`LANES`] poses at once, for the batched pose errors (`batch`).
//!
//! Every value is an array with one entry per pose and every operation a loop over the entries,
//! so the compiler turns each into vector instructions (lanes = poses). Everything is
//! `#[inline(always)]`: the loops must be compiled inside the kernel that `pulp` compiles for
//! the detected instruction set, or they would get the baseline one. No `mul_add`: without
//! FMA hardware it is a slow library call, and without it both dispatch paths round alike (the
//! same bits on any x86_64).

// Index loops over lanes and directions: the shape the vectoriser turns into one instruction.
#![allow(clippy::needless_range_loop)]

use crate::rigid::log_so3;
use nalgebra::{Matrix3, Vector3};
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// Poses evaluated together: eight, two AVX2 registers per value. The exact walk is a chain
/// of dependent small products per pose; two registers per value give the processor two
/// independent chains to interleave (on the trunnion benchmark, 82 ns per pose against 125 at
/// four lanes; the first-order error 40 against 35). AVX-512 (pulp's `x86-v4`, one register per
/// value) measured no faster for the exact error and slower for the first order (47 ns), so the
/// kernels stay at AVX2.
pub(super) const LANES: usize = 8;

/// One number per pose.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct L(pub(super) [f64; LANES]);

impl L {
    pub(super) const ZERO: L = L([0.0; LANES]);

    #[inline(always)]
    pub(super) fn splat(x: f64) -> L {
        L([x; LANES])
    }

    // Index loops, not `array::map`/`from_fn`: those go through `try_map`, which is not always
    // inlined, and then nothing around it is vectorised.
    #[inline(always)]
    pub(super) fn map(self, f: impl Fn(f64) -> f64) -> L {
        let mut out = [0.0; LANES];
        for k in 0..LANES {
            out[k] = f(self.0[k]);
        }
        L(out)
    }

    #[inline(always)]
    fn zip(self, o: L, f: impl Fn(f64, f64) -> f64) -> L {
        let mut out = [0.0; LANES];
        for k in 0..LANES {
            out[k] = f(self.0[k], o.0[k]);
        }
        L(out)
    }

    /// Every lane satisfies `f`; decided without early exit (a vector compare and a mask).
    #[inline(always)]
    pub(super) fn all(self, f: impl Fn(f64) -> bool) -> bool {
        self.0.iter().fold(true, |acc, &x| acc & f(x))
    }
}

impl Add for L {
    type Output = L;
    #[inline(always)]
    fn add(self, o: L) -> L {
        self.zip(o, |a, b| a + b)
    }
}

impl Sub for L {
    type Output = L;
    #[inline(always)]
    fn sub(self, o: L) -> L {
        self.zip(o, |a, b| a - b)
    }
}

impl Mul for L {
    type Output = L;
    #[inline(always)]
    fn mul(self, o: L) -> L {
        self.zip(o, |a, b| a * b)
    }
}

impl Mul<f64> for L {
    type Output = L;
    #[inline(always)]
    fn mul(self, s: f64) -> L {
        self.map(|a| a * s)
    }
}

impl Neg for L {
    type Output = L;
    #[inline(always)]
    fn neg(self) -> L {
        self.map(|a| -a)
    }
}

impl AddAssign for L {
    #[inline(always)]
    fn add_assign(&mut self, o: L) {
        *self = *self + o;
    }
}

/// A 3-vector per pose.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct V3 {
    pub(super) x: L,
    pub(super) y: L,
    pub(super) z: L,
}

impl V3 {
    #[inline(always)]
    pub(super) fn new(x: L, y: L, z: L) -> V3 {
        V3 { x, y, z }
    }

    /// The same vector in every lane.
    #[inline(always)]
    pub(super) fn splat(v: &Vector3<f64>) -> V3 {
        V3::new(L::splat(v.x), L::splat(v.y), L::splat(v.z))
    }

    /// Entries `start..start + 3` of six values per lane.
    #[inline(always)]
    pub(super) fn of(a: &[L; 6], start: usize) -> V3 {
        V3::new(a[start], a[start + 1], a[start + 2])
    }

    /// `self · s` with one scale per lane.
    #[inline(always)]
    pub(super) fn scale(self, s: L) -> V3 {
        V3::new(self.x * s, self.y * s, self.z * s)
    }

    #[inline(always)]
    pub(super) fn cross(self, o: V3) -> V3 {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    #[inline(always)]
    pub(super) fn norm_squared(self) -> L {
        self.x * self.x + self.y * self.y + self.z * self.z
    }

    /// Lane `k` as a vector.
    #[inline(always)]
    pub(super) fn lane(&self, k: usize) -> Vector3<f64> {
        Vector3::new(self.x.0[k], self.y.0[k], self.z.0[k])
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Neg for V3 {
    type Output = V3;
    #[inline(always)]
    fn neg(self) -> V3 {
        V3::new(-self.x, -self.y, -self.z)
    }
}

impl AddAssign for V3 {
    #[inline(always)]
    fn add_assign(&mut self, o: V3) {
        *self = *self + o;
    }
}

impl SubAssign for V3 {
    #[inline(always)]
    fn sub_assign(&mut self, o: V3) {
        *self = *self - o;
    }
}

/// `m · v` for a matrix shared by all lanes (a joint origin, a location factor).
#[inline(always)]
pub(super) fn mv_const(m: &Matrix3<f64>, v: V3) -> V3 {
    let c = &m.data.0;
    V3::new(
        v.x * c[0][0] + v.y * c[1][0] + v.z * c[2][0],
        v.x * c[0][1] + v.y * c[1][1] + v.z * c[2][1],
        v.x * c[0][2] + v.y * c[1][2] + v.z * c[2][2],
    )
}

/// `v · s` for a vector shared by all lanes and one scale per lane.
#[inline(always)]
pub(super) fn scaled_const(v: &Vector3<f64>, s: L) -> V3 {
    V3::new(s * v.x, s * v.y, s * v.z)
}

/// A 3 × 3 matrix per pose, by columns (as nalgebra stores them).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct M3 {
    pub(super) c: [V3; 3],
}

impl M3 {
    /// The same matrix in every lane.
    #[inline(always)]
    pub(super) fn splat(m: &Matrix3<f64>) -> M3 {
        let col = |j: usize| V3::splat(&m.column(j).into_owned());
        M3 {
            c: [col(0), col(1), col(2)],
        }
    }

    #[inline(always)]
    pub(super) fn mv(&self, v: V3) -> V3 {
        let [c0, c1, c2] = self.c;
        c0.scale(v.x) + c1.scale(v.y) + c2.scale(v.z)
    }

    /// `selfᵀ · v`.
    #[inline(always)]
    pub(super) fn tmv(&self, v: V3) -> V3 {
        let dot = |c: V3| c.x * v.x + c.y * v.y + c.z * v.z;
        V3::new(dot(self.c[0]), dot(self.c[1]), dot(self.c[2]))
    }

    #[inline(always)]
    pub(super) fn mm(&self, o: &M3) -> M3 {
        M3 {
            c: [self.mv(o.c[0]), self.mv(o.c[1]), self.mv(o.c[2])],
        }
    }

    /// `self · m` for a matrix shared by all lanes.
    #[inline(always)]
    pub(super) fn mm_const(&self, m: &Matrix3<f64>) -> M3 {
        let d = &m.data.0;
        let [c0, c1, c2] = self.c;
        let col = |j: usize| c0.scale_s(d[j][0]) + c1.scale_s(d[j][1]) + c2.scale_s(d[j][2]);
        M3 {
            c: [col(0), col(1), col(2)],
        }
    }

    #[inline(always)]
    pub(super) fn transpose(&self) -> M3 {
        let [a, b, c] = self.c;
        M3 {
            c: [
                V3::new(a.x, b.x, c.x),
                V3::new(a.y, b.y, c.y),
                V3::new(a.z, b.z, c.z),
            ],
        }
    }

    /// Lane `k` as a matrix.
    #[inline(always)]
    pub(super) fn lane(&self, k: usize) -> Matrix3<f64> {
        Matrix3::from_columns(&[self.c[0].lane(k), self.c[1].lane(k), self.c[2].lane(k)])
    }
}

impl Add for M3 {
    type Output = M3;
    #[inline(always)]
    fn add(self, o: M3) -> M3 {
        M3 {
            c: [self.c[0] + o.c[0], self.c[1] + o.c[1], self.c[2] + o.c[2]],
        }
    }
}

/// `m · a` for a matrix `m` shared by all lanes.
#[inline(always)]
pub(super) fn mm_const_left(m: &Matrix3<f64>, a: &M3) -> M3 {
    M3 {
        c: [
            mv_const(m, a.c[0]),
            mv_const(m, a.c[1]),
            mv_const(m, a.c[2]),
        ],
    }
}

impl V3 {
    /// `self · s` for a scale shared by all lanes.
    #[inline(always)]
    fn scale_s(self, s: f64) -> V3 {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}

/// `(sin x, cos x)` per lane, vectorised: Cody–Waite reduction by π/2 and fdlibm's kernel
/// polynomials (within an ulp or two of the library's; `std`'s `sin_cos` is a scalar call per
/// lane, slower than the whole first-order error of a pose). Lanes beyond `|x| < 2^19` (never
/// an axis position) take the library's values.
#[inline(always)]
pub(super) fn sin_cos(x: L) -> (L, L) {
    if !x.all(|v| v.abs() < 524288.0) {
        return (x.map(f64::sin), x.map(f64::cos));
    }
    // n = round(x·2/π) by the 1.5·2⁵² trick: exact for |x·2/π| < 2⁵¹, the quadrant in the low
    // bits, and no rounding instruction (the portable path has none).
    const SHIFT: f64 = 6755399441055744.0;
    let shifted = (x * std::f64::consts::FRAC_2_PI).map(|v| v + SHIFT);
    let n = shifted.map(|v| v - SHIFT);
    // π/2 in three parts of 33 bits (fdlibm's pio2_1, pio2_2, pio2_3): n·part is exact for
    // |n| < 2²⁰, so the reduced argument keeps full precision.
    const P1: f64 = 1.570_796_326_734_125_6;
    const P2: f64 = 6.077_100_506_303_966e-11;
    const P3: f64 = 2.022_266_248_711_166_5e-21;
    let r = ((x - n * P1) - n * P2) - n * P3;
    let z = r * r;
    // fdlibm __kernel_sin / __kernel_cos on [−π/4, π/4].
    let s = r + r * z * poly(z, &SIN);
    let hz = z * 0.5;
    let w = L::splat(1.0) - hz;
    let c = w + (((L::splat(1.0) - w) - hz) + z * z * poly(z, &COS));
    let mut sin = L::ZERO;
    let mut cos = L::ZERO;
    for k in 0..LANES {
        let q = shifted.0[k].to_bits();
        // Quadrant q: sin = [s, c, −s, −c], cos = [c, −s, −c, s]. The swap by a bit mask, not
        // a branch: the quadrants of a batch are random, and a branch per lane is mispredicted
        // half the time where the compiler does not turn it into a select.
        let (sb, cb) = (s.0[k].to_bits(), c.0[k].to_bits());
        let swap = 0u64.wrapping_sub(q & 1);
        let (sv, cv) = ((sb & !swap) | (cb & swap), (cb & !swap) | (sb & swap));
        sin.0[k] = f64::from_bits(sv ^ ((q & 2) << 62));
        cos.0[k] = f64::from_bits(cv ^ (((q + 1) & 2) << 62));
    }
    (sin, cos)
}

const SIN: [f64; 6] = [
    -1.666_666_666_666_663_2e-1,
    8.333_333_333_322_49e-3,
    -1.984_126_982_985_795e-4,
    2.755_731_370_707_006_8e-6,
    -2.505_076_025_340_686_3e-8,
    1.589_690_995_211_55e-10,
];

const COS: [f64; 6] = [
    4.166_666_666_666_66e-2,
    -1.388_888_888_887_411e-3,
    2.480_158_728_947_673e-5,
    -2.755_731_435_139_066_3e-7,
    2.087_572_321_298_175e-9,
    -1.135_964_755_778_819_5e-11,
];

/// `Σ_k a[k]·z^k` by Horner's rule.
#[inline(always)]
fn poly(z: L, a: &[f64; 6]) -> L {
    let mut acc = L::splat(a[5]);
    for &ak in a[..5].iter().rev() {
        acc = acc * z + L::splat(ak);
    }
    acc
}

/// `exp([ω]×) − I` per lane (see [`crate::rigid::exp_so3`]), without the identity: a small
/// rotation's difference from the identity to full relative precision (forming the rotation
/// and subtracting `I` would leave an ulp of 1). The Taylor series of `sin θ/θ` and
/// `(1 − cos θ)/θ²` up to θ⁸ for angles below 0.1 rad (the first term left out is below 3e-18,
/// under the rounding): error motions are micro-radians, so every lane in practice; a larger
/// lane sends all through the scalar function.
#[inline(always)]
pub(super) fn exp_minus_identity(w: V3) -> M3 {
    let th2 = w.norm_squared();
    if !th2.all(|t| t < 1e-2) {
        return from_lanes(|k| crate::rigid::exp_so3(&w.lane(k)) - Matrix3::identity());
    }
    let a = series(
        th2,
        &[1.0, -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0],
    );
    let b = series(
        th2,
        &[
            0.5,
            -1.0 / 24.0,
            1.0 / 720.0,
            -1.0 / 40320.0,
            1.0 / 3628800.0,
        ],
    );
    ak_bk2(w, a, b)
}

/// `Σ_k a[k]·x^k` by Horner's rule.
#[inline(always)]
fn series(x: L, a: &[f64; 5]) -> L {
    let mut acc = L::splat(a[4]);
    for &ak in a[..4].iter().rev() {
        acc = acc * x + L::splat(ak);
    }
    acc
}

/// Rotation by `q` (as its sine and cosine per lane) about the unit vector `a` shared by all
/// lanes (see [`crate::rigid::axis_rotation`]).
#[inline(always)]
pub(super) fn axis_rotation(a: &Vector3<f64>, sin: L, cos: L) -> M3 {
    i_ak_bk2(V3::splat(a), sin, L::splat(1.0) - cos)
}

/// `a·[w]× + b·[w]×²` per lane (`[w]×² = w·wᵀ − |w|²·I`).
#[inline(always)]
fn ak_bk2(w: V3, a: L, b: L) -> M3 {
    let (x, y, z) = (w.x, w.y, w.z);
    let (bxx, byy, bzz) = (b * x * x, b * y * y, b * z * z);
    let (bxy, bxz, byz) = (b * x * y, b * x * z, b * y * z);
    let (ax, ay, az) = (a * x, a * y, a * z);
    M3 {
        c: [
            V3::new(-(byy + bzz), bxy + az, bxz - ay),
            V3::new(bxy - az, -(bxx + bzz), byz + ax),
            V3::new(bxz + ay, byz - ax, -(bxx + byy)),
        ],
    }
}

/// `I + a·[w]× + b·[w]×²` per lane, as the scalar `rigid::i_ak_bk2`.
#[inline(always)]
fn i_ak_bk2(w: V3, a: L, b: L) -> M3 {
    let (x, y, z) = (w.x, w.y, w.z);
    let d = L::splat(1.0) - b * (x * x + y * y + z * z);
    let (bxy, bxz, byz) = (b * x * y, b * x * z, b * y * z);
    let (ax, ay, az) = (a * x, a * y, a * z);
    M3 {
        c: [
            V3::new(d + b * x * x, bxy + az, bxz - ay),
            V3::new(bxy - az, d + b * y * y, byz + ax),
            V3::new(bxz + ay, byz - ax, d + b * z * z),
        ],
    }
}

/// `log(I + a)` per lane for a rotation given as its difference `a` from the identity (see
/// [`crate::rigid::log_so3`]): the skew part and the trace come from `a` alone, so a
/// micro-radian rotation keeps its full relative precision. `θ/sin θ` as the series of
/// `asin s / s` in `s = sin θ` up to s⁸ for angles below 0.03 rad (the first term left out,
/// 0.022·s¹⁰, is below 3e-17, under the rounding): pose errors are micro-radians, so every lane
/// in practice; otherwise the scalar function lane by lane.
#[inline(always)]
pub(super) fn log_near_identity(a: &M3) -> V3 {
    let [c0, c1, c2] = a.c;
    let v = V3::new(c1.z - c2.y, c2.x - c0.z, c0.y - c1.x);
    // cos θ = (tr(I + a) − 1)/2 = 1 + tr(a)/2.
    let cos = L::splat(1.0) + (c0.x + c1.y + c2.z) * 0.5;
    let sin2 = v.norm_squared() * 0.25;
    if !(sin2.all(|s| s < 1e-3) && cos.all(|c| c > 0.0)) {
        let mut out = V3::default();
        for k in 0..LANES {
            let w = log_so3(&(a.lane(k) + Matrix3::identity()));
            (out.x.0[k], out.y.0[k], out.z.0[k]) = (w.x, w.y, w.z);
        }
        return out;
    }
    let ratio = series(
        sin2,
        &[1.0, 1.0 / 6.0, 3.0 / 40.0, 5.0 / 112.0, 35.0 / 1152.0],
    );
    v.scale(ratio * 0.5)
}

/// A matrix per lane from a scalar function of the lane.
#[inline(always)]
fn from_lanes(f: impl Fn(usize) -> Matrix3<f64>) -> M3 {
    let mut out = M3::default();
    for k in 0..LANES {
        let m = f(k);
        for (j, col) in out.c.iter_mut().enumerate() {
            (col.x.0[k], col.y.0[k], col.z.0[k]) = (m[(0, j)], m[(1, j)], m[(2, j)]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vectorised sine and cosine agree with the library's to two ulps over axis-position
    /// ranges, including the quadrant boundaries and negative angles.
    #[test]
    fn sin_cos_matches_std() {
        let mut worst: f64 = 0.0;
        for i in -200_000..200_000 {
            let x = i as f64 * 1.3e-4 + (i % 7) as f64 * std::f64::consts::FRAC_PI_4;
            let (s, c) = sin_cos(L::splat(x));
            for (got, want) in [(s.0[0], x.sin()), (c.0[0], x.cos())] {
                let ulp = f64::EPSILON * want.abs().max(f64::MIN_POSITIVE);
                worst = worst.max((got - want).abs() / ulp.max(f64::EPSILON * 1e-3));
                assert!(
                    (got - want).abs() <= 2.0 * f64::EPSILON * want.abs().max(1e-300)
                        || (got - want).abs() < 1e-300,
                    "x = {x:e}: {got:e} vs {want:e}"
                );
            }
        }
        assert!(worst <= 2.0, "worst {worst} ulps");
        // Huge arguments go to the library.
        let mut x = L::splat(-2.0);
        x.0[0] = 1e6;
        let (s, c) = sin_cos(x);
        assert_eq!((s.0[0], c.0[0]), (1e6f64.sin(), 1e6f64.cos()));
    }

    /// The lane-wise `exp − I` and `log(I + ·)` are the scalar functions' (small angles
    /// through the series, large ones through the fallback), and `exp − I` keeps the relative
    /// precision of a micro-radian rotation.
    #[test]
    fn exp_and_log_match_scalar() {
        let pattern = [
            1.0, -0.3, 0.2, 0.0, 0.5, 0.7, -0.9, 0.0, -0.25, 0.1, 0.4, 1.0,
        ];
        let lanes = |start: usize, scale: f64| {
            let mut l = L::ZERO;
            for k in 0..LANES {
                l.0[k] = pattern[(start + 5 * k) % pattern.len()] * scale;
            }
            l
        };
        for scale in [1e-6, 1e-4, 1e-2, 0.5] {
            let w = V3::new(lanes(0, scale), lanes(1, scale), lanes(2, scale));
            let b = exp_minus_identity(w);
            let back = log_near_identity(&b);
            for k in 0..LANES {
                let want = crate::rigid::exp_so3(&w.lane(k)) - Matrix3::identity();
                assert!((b.lane(k) - want).norm() < 4e-16, "exp lane {k}");
                // The skew part is a·[w]×: relative precision, however small the angle.
                let skew = (b.lane(k) - b.lane(k).transpose()) * 0.5;
                let small = w.lane(k).norm() < 1e-3;
                if small {
                    let a = 1.0 - w.lane(k).norm_squared() / 6.0;
                    let v = w.lane(k) * a;
                    let want = Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0);
                    assert!((skew - want).norm() <= 1e-15 * w.lane(k).norm(), "skew {k}");
                }
                assert!(
                    (back.lane(k) - w.lane(k)).norm() < 1e-15 * scale,
                    "log lane {k}"
                );
            }
        }
    }
}
