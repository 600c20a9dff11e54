//! Basis functions in which a machine axis' component error is expressed.
//!
//! A component error such as the positioning error EXX of an X axis is modelled as
//! `e(q) = sum_i c_i * f_i(q)`, where `q` is the axis position in SI units (metres for a linear
//! axis, radians for a rotary one). The coefficients `c_i` carry the unit of the error (m or rad);
//! the functions `f_i` are dimensionless. Keeping the unit in the coefficients lets the same basis
//! serve translational and angular errors alike.
//!
//! [`Basis::eval`], [`Basis::eval_with_derivative`] and [`Basis::value`] sit on the hot path of
//! the kinematic model, which is evaluated millions of times per second: they write into
//! caller-provided slices and never allocate.

use nalgebra::{DMatrix, DVector};

/// Singular values below this fraction of the largest one count as zero when [`Basis::fit`]
/// decides the rank. It is far above rounding noise (so aliased or duplicated samples are caught)
/// and far below the conditioning of any sample set that still yields usable coefficients.
const RANK_RELATIVE_TOLERANCE: f64 = 1e-10;

/// Degree of the B-spline basis (cubic).
const SPLINE_DEGREE: usize = 3;

/// One function of a basis, what a coefficient multiplies: the same term in a basis given more
/// orders is the same function.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Term {
    /// The Legendre polynomial of this degree (`P2`).
    Legendre(usize),
    /// The table knot of this index, counting pinned knots (`K3`).
    Knot(usize),
    /// The B-spline control point of this index, counting pinned ones (`B4`).
    Control(usize),
    /// The cosine of this harmonic (`C1`; `C0` the constant).
    Cos(usize),
    /// The sine of this harmonic (`S1`).
    Sin(usize),
}

impl std::fmt::Display for Term {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Term::Legendre(k) => write!(f, "P{k}"),
            Term::Knot(k) => write!(f, "K{k}"),
            Term::Control(k) => write!(f, "B{k}"),
            Term::Cos(k) => write!(f, "C{k}"),
            Term::Sin(k) => write!(f, "S{k}"),
        }
    }
}

/// The family of functions a component error is expanded in.
///
/// The fields are public so a basis can be written literally (e.g. from a configuration file);
/// such a value should go through [`Basis::validate`] before use, because evaluating an invalid
/// basis gives meaningless numbers and may panic. The constructors validate for you.
#[derive(Clone, Debug, PartialEq)]
pub enum Basis {
    /// Legendre polynomials P_k(u), u = 2(q-lo)/(hi-lo) - 1, for k in min_degree..=max_degree.
    ///
    /// Orthogonal on the stroke, hence well conditioned for least-squares fits; `min_degree`
    /// lets a model leave out terms (e.g. the constant) that another parameter already absorbs.
    Legendre {
        lo: f64,
        hi: f64,
        min_degree: usize,
        max_degree: usize,
    },
    /// Piecewise-linear table: one hat function per knot (strictly increasing knots);
    /// a pinned end knot has its value fixed at zero and gets no function.
    ///
    /// This is the classic laser-interferometer error table; pinning expresses that the error is
    /// measured relative to a reference position.
    Table {
        knots: Vec<f64>,
        pin_first: bool,
        pin_last: bool,
    },
    /// Clamped (open-uniform) cubic B-spline on [lo, hi] with `n_ctrl` control points
    /// (n_ctrl >= 4), uniform interior knots. pin_first / pin_last drop the first / last control
    /// point, i.e. fix the value at lo / hi to zero (a clamped spline takes its end control
    /// points' values at the ends).
    BSpline {
        lo: f64,
        hi: f64,
        n_ctrl: usize,
        pin_first: bool,
        pin_last: bool,
    },
    /// Fourier series in the axis angle q (radians): for k in min_harmonic..=max_harmonic:
    /// k = 0 gives the single function 1; k >= 1 gives cos(kq), sin(kq) in that order.
    ///
    /// Periodic, so it suits rotary axes that turn through full revolutions.
    Fourier {
        min_harmonic: usize,
        max_harmonic: usize,
    },
}

/// Why a basis or a fit was rejected. Each message says what to change.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BasisError {
    /// The stroke bounds are not finite or not ordered.
    #[error("stroke [lo, hi] must be finite with lo < hi, got [{lo}, {hi}]")]
    InvalidStroke { lo: f64, hi: f64 },
    /// A Legendre degree range with `min > max`.
    #[error("degree range {min}..={max} is empty: min_degree must not exceed max_degree")]
    EmptyDegreeRange { min: usize, max: usize },
    /// A Fourier harmonic range with `min > max`.
    #[error("harmonic range {min}..={max} is empty: min_harmonic must not exceed max_harmonic")]
    EmptyHarmonicRange { min: usize, max: usize },
    /// A table with fewer than two knots cannot interpolate.
    #[error("a table needs at least 2 knots, got {count}")]
    TooFewKnots { count: usize },
    /// A table knot is NaN or infinite.
    #[error("knot {index} is not finite ({value})")]
    NonFiniteKnot { index: usize, value: f64 },
    /// Two neighbouring table knots are not strictly increasing.
    #[error(
        "knots must be strictly increasing: knot {index} ({value}) <= knot {} ({previous})",
        index.saturating_sub(1)
    )]
    KnotsNotIncreasing {
        index: usize,
        value: f64,
        previous: f64,
    },
    /// A cubic B-spline needs at least degree + 1 control points.
    #[error("a B-spline needs at least 4 control points, got {count}")]
    TooFewControlPoints { count: usize },
    /// Pinning removed every function.
    #[error("basis has no functions left after pinning: add knots or unpin an end")]
    NoFunctions,
    /// A fit sample has a NaN or infinite position or value.
    #[error("sample {index} is not finite: ({position}, {value})")]
    NonFiniteSample {
        index: usize,
        position: f64,
        value: f64,
    },
    /// Fewer samples than coefficients.
    #[error(
        "fit needs at least as many independent samples as coefficients: \
         {samples} samples for {coefficients} coefficients"
    )]
    TooFewSamples { samples: usize, coefficients: usize },
    /// Enough samples, but they do not determine every coefficient (repeated positions, samples
    /// missing from some knot interval, aliased angles ...).
    #[error(
        "fit needs at least as many independent samples as coefficients: only {independent} \
         independent samples for {coefficients} coefficients; spread the samples over the whole \
         stroke, with samples in every knot interval"
    )]
    RankDeficient {
        independent: usize,
        coefficients: usize,
    },
}

impl Basis {
    /// Legendre polynomials of degrees `min_degree..=max_degree` on the stroke `[lo, hi]`.
    pub fn legendre(
        lo: f64,
        hi: f64,
        min_degree: usize,
        max_degree: usize,
    ) -> Result<Self, BasisError> {
        Self::validated(Basis::Legendre {
            lo,
            hi,
            min_degree,
            max_degree,
        })
    }

    /// Piecewise-linear table on strictly increasing `knots`.
    pub fn table(knots: Vec<f64>, pin_first: bool, pin_last: bool) -> Result<Self, BasisError> {
        Self::validated(Basis::Table {
            knots,
            pin_first,
            pin_last,
        })
    }

    /// Clamped cubic B-spline with `n_ctrl` control points on `[lo, hi]`.
    pub fn bspline(
        lo: f64,
        hi: f64,
        n_ctrl: usize,
        pin_first: bool,
        pin_last: bool,
    ) -> Result<Self, BasisError> {
        Self::validated(Basis::BSpline {
            lo,
            hi,
            n_ctrl,
            pin_first,
            pin_last,
        })
    }

    /// Fourier series with harmonics `min_harmonic..=max_harmonic`.
    pub fn fourier(min_harmonic: usize, max_harmonic: usize) -> Result<Self, BasisError> {
        Self::validated(Basis::Fourier {
            min_harmonic,
            max_harmonic,
        })
    }

    fn validated(basis: Basis) -> Result<Self, BasisError> {
        basis.validate()?;
        Ok(basis)
    }

    /// Validates a value built directly with the enum (same checks as the constructors).
    pub fn validate(&self) -> Result<(), BasisError> {
        match self {
            Basis::Legendre {
                lo,
                hi,
                min_degree,
                max_degree,
            } => {
                check_stroke(*lo, *hi)?;
                if min_degree > max_degree {
                    return Err(BasisError::EmptyDegreeRange {
                        min: *min_degree,
                        max: *max_degree,
                    });
                }
            }
            Basis::Table { knots, .. } => check_knots(knots)?,
            Basis::BSpline { lo, hi, n_ctrl, .. } => {
                check_stroke(*lo, *hi)?;
                if *n_ctrl < SPLINE_DEGREE + 1 {
                    return Err(BasisError::TooFewControlPoints { count: *n_ctrl });
                }
            }
            Basis::Fourier {
                min_harmonic,
                max_harmonic,
            } => {
                if min_harmonic > max_harmonic {
                    return Err(BasisError::EmptyHarmonicRange {
                        min: *min_harmonic,
                        max: *max_harmonic,
                    });
                }
            }
        }
        if self.is_empty() {
            return Err(BasisError::NoFunctions);
        }
        Ok(())
    }

    /// Number of basis functions (= number of coefficients).
    pub fn len(&self) -> usize {
        match self {
            Basis::Legendre {
                min_degree,
                max_degree,
                ..
            } => (max_degree + 1).saturating_sub(*min_degree),
            Basis::Table {
                knots,
                pin_first,
                pin_last,
            } => pinned_count(knots.len(), *pin_first, *pin_last),
            Basis::BSpline {
                n_ctrl,
                pin_first,
                pin_last,
                ..
            } => pinned_count(*n_ctrl, *pin_first, *pin_last),
            Basis::Fourier {
                min_harmonic,
                max_harmonic,
            } => match (*min_harmonic, *max_harmonic) {
                (min, max) if min > max => 0,
                (0, max) => 1 + 2 * max,
                (min, max) => 2 * (max - min + 1),
            },
        }
    }

    /// True if the basis has no functions (never the case for a validated basis).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Writes the function values at `q` into `out[..len()]`; `out[len()..]` is left untouched.
    ///
    /// Legendre, Table and BSpline hold their end value outside their stroke. Does not allocate.
    ///
    /// # Panics
    /// If `out.len() < self.len()`.
    pub fn eval(&self, q: f64, out: &mut [f64]) {
        let out = output_slice(out, self.len(), "out");
        if self.has_local_support() {
            out.fill(0.0);
        }
        self.visit::<false>(q, |i, value, _| out[i] = value);
    }

    /// Writes the function values at `q` into `out[..len()]` and their derivatives d/dq (per
    /// metre or per radian) into `d_out[..len()]`.
    ///
    /// Outside the stroke of Legendre, Table and BSpline the derivative is 0 (the value is held).
    /// At an interior table knot the right-hand slope is used, at the last knot the left-hand one.
    /// Does not allocate.
    ///
    /// # Panics
    /// If `out.len() < self.len()` or `d_out.len() < self.len()`.
    pub fn eval_with_derivative(&self, q: f64, out: &mut [f64], d_out: &mut [f64]) {
        let n = self.len();
        let out = output_slice(out, n, "out");
        let d_out = output_slice(d_out, n, "d_out");
        if self.has_local_support() {
            out.fill(0.0);
            d_out.fill(0.0);
        }
        self.visit::<true>(q, |i, value, derivative| {
            out[i] = value;
            d_out[i] = derivative;
        });
    }

    /// Value of `sum_i coeffs[i] * f_i(q)`, without allocation.
    ///
    /// # Panics
    /// If `coeffs.len() != self.len()`: a coefficient vector of another length belongs to another
    /// basis, and silently using part of it would hide that mistake.
    pub fn value(&self, q: f64, coeffs: &[f64]) -> f64 {
        assert_eq!(
            coeffs.len(),
            self.len(),
            "Basis::value: {} coefficients for a basis of {} functions",
            coeffs.len(),
            self.len()
        );
        let mut sum = 0.0;
        self.visit::<false>(q, |i, value, _| sum += coeffs[i] * value);
        sum
    }

    /// Short labels of the functions, in coefficient order: "P2" (Legendre degree 2), "K3" (table
    /// knot 3, counting pinned knots), "B4" (B-spline control point 4, counting pinned ones),
    /// "C0", "C1", "S1" (Fourier): the [`Term`]s written out.
    pub fn labels(&self) -> Vec<String> {
        self.terms().iter().map(Term::to_string).collect()
    }

    /// The functions, in coefficient order.
    pub fn terms(&self) -> Vec<Term> {
        match self {
            Basis::Legendre {
                min_degree,
                max_degree,
                ..
            } => (*min_degree..=*max_degree).map(Term::Legendre).collect(),
            Basis::Table {
                knots,
                pin_first,
                pin_last,
            } => unpinned_indices(knots.len(), *pin_first, *pin_last)
                .map(Term::Knot)
                .collect(),
            Basis::BSpline {
                n_ctrl,
                pin_first,
                pin_last,
                ..
            } => unpinned_indices(*n_ctrl, *pin_first, *pin_last)
                .map(Term::Control)
                .collect(),
            Basis::Fourier {
                min_harmonic,
                max_harmonic,
            } => (*min_harmonic..=*max_harmonic)
                .flat_map(|k| match k {
                    0 => vec![Term::Cos(0)],
                    k => vec![Term::Cos(k), Term::Sin(k)],
                })
                .collect(),
        }
    }

    /// The stroke this basis spans, if it has one (None for Fourier, which is periodic).
    pub fn stroke(&self) -> Option<(f64, f64)> {
        match self {
            Basis::Legendre { lo, hi, .. } | Basis::BSpline { lo, hi, .. } => Some((*lo, *hi)),
            Basis::Table { knots, .. } => Some((*knots.first()?, *knots.last()?)),
            Basis::Fourier { .. } => None,
        }
    }

    /// Least-squares coefficients reproducing `(position, value)` samples.
    ///
    /// Uses an SVD of the design matrix and refuses to extrapolate: if the samples do not
    /// determine every coefficient (too few samples, repeated positions, a knot interval without
    /// samples, aliased angles) it returns an error naming how many independent samples there
    /// were, rather than inventing values for the undetermined coefficients.
    pub fn fit(&self, samples: &[(f64, f64)]) -> Result<Vec<f64>, BasisError> {
        self.validate()?;
        check_samples(samples)?;
        let n = self.len();
        if samples.len() < n {
            return Err(BasisError::TooFewSamples {
                samples: samples.len(),
                coefficients: n,
            });
        }
        let rhs = DVector::from_iterator(samples.len(), samples.iter().map(|&(_, v)| v));
        let svd = self.design_matrix(samples).svd(true, true);
        let tolerance = RANK_RELATIVE_TOLERANCE * svd.singular_values.max();
        let rank = svd
            .singular_values
            .iter()
            .filter(|&&s| s > tolerance)
            .count();
        if rank < n {
            return Err(BasisError::RankDeficient {
                independent: rank,
                coefficients: n,
            });
        }
        let solution = svd
            .solve(&rhs, tolerance)
            .expect("SVD was computed with U and V^T");
        Ok(solution.as_slice().to_vec())
    }

    /// One row per sample, one column per function.
    fn design_matrix(&self, samples: &[(f64, f64)]) -> DMatrix<f64> {
        let n = self.len();
        let mut matrix = DMatrix::zeros(samples.len(), n);
        let mut row = vec![0.0; n];
        for (r, &(q, _)) in samples.iter().enumerate() {
            self.eval(q, &mut row);
            for (c, &value) in row.iter().enumerate() {
                matrix[(r, c)] = value;
            }
        }
        matrix
    }

    /// Table and B-spline functions vanish away from q; only the few non-zero ones are visited.
    fn has_local_support(&self) -> bool {
        matches!(self, Basis::Table { .. } | Basis::BSpline { .. })
    }

    /// Calls `f(index, value, derivative)` for every function that may be non-zero at `q`
    /// (all functions for the global bases). The derivative is only computed when `D` is true
    /// (otherwise 0 or garbage may be passed), so value-only callers skip that work.
    /// This single traversal serves `eval`, `eval_with_derivative` and `value`.
    #[inline]
    fn visit<const D: bool>(&self, q: f64, f: impl FnMut(usize, f64, f64)) {
        match self {
            Basis::Legendre {
                lo,
                hi,
                min_degree,
                max_degree,
            } => visit_legendre::<D>(*lo, *hi, *min_degree, *max_degree, q, f),
            Basis::Table {
                knots,
                pin_first,
                pin_last,
            } => visit_table(knots, *pin_first, *pin_last, q, f),
            Basis::BSpline {
                lo,
                hi,
                n_ctrl,
                pin_first,
                pin_last,
            } => visit_bspline::<D>(*lo, *hi, *n_ctrl, (*pin_first, *pin_last), q, f),
            Basis::Fourier {
                min_harmonic,
                max_harmonic,
            } => visit_fourier(*min_harmonic, *max_harmonic, q, f),
        }
    }
}

fn check_stroke(lo: f64, hi: f64) -> Result<(), BasisError> {
    if lo.is_finite() && hi.is_finite() && lo < hi {
        Ok(())
    } else {
        Err(BasisError::InvalidStroke { lo, hi })
    }
}

fn check_knots(knots: &[f64]) -> Result<(), BasisError> {
    if knots.len() < 2 {
        return Err(BasisError::TooFewKnots { count: knots.len() });
    }
    if let Some(index) = knots.iter().position(|k| !k.is_finite()) {
        let value = knots[index];
        return Err(BasisError::NonFiniteKnot { index, value });
    }
    if let Some(w) = knots.windows(2).position(|w| w[1] <= w[0]) {
        return Err(BasisError::KnotsNotIncreasing {
            index: w + 1,
            value: knots[w + 1],
            previous: knots[w],
        });
    }
    Ok(())
}

fn check_samples(samples: &[(f64, f64)]) -> Result<(), BasisError> {
    match samples
        .iter()
        .position(|(q, v)| !(q.is_finite() && v.is_finite()))
    {
        Some(index) => Err(BasisError::NonFiniteSample {
            index,
            position: samples[index].0,
            value: samples[index].1,
        }),
        None => Ok(()),
    }
}

/// Returns `out[..n]`, with a panic message that names the argument when it is too short.
fn output_slice<'a>(out: &'a mut [f64], n: usize, name: &str) -> &'a mut [f64] {
    assert!(
        out.len() >= n,
        "Basis: `{name}` has {} slots but the basis has {n} functions",
        out.len()
    );
    &mut out[..n]
}

/// Number of functions left from `count` knots / control points after pinning.
fn pinned_count(count: usize, pin_first: bool, pin_last: bool) -> usize {
    count.saturating_sub(usize::from(pin_first) + usize::from(pin_last))
}

/// Knot / control-point indices that carry a function, in coefficient order.
fn unpinned_indices(count: usize, pin_first: bool, pin_last: bool) -> impl Iterator<Item = usize> {
    let start = usize::from(pin_first);
    let end = count.saturating_sub(usize::from(pin_last));
    start..end
}

/// Coefficient index of knot / control point `j` of `count`, or None if it is pinned.
#[inline]
fn function_index(j: usize, count: usize, pin_first: bool, pin_last: bool) -> Option<usize> {
    let pinned = (pin_first && j == 0) || (pin_last && j + 1 == count);
    (!pinned).then(|| j - usize::from(pin_first))
}

/// Holds `q` at the nearest end of `[lo, hi]`; the second value is dq_held/dq (0 outside).
/// NaN passes through unchanged, so it shows up in the result instead of being hidden.
#[inline]
fn hold_in_stroke(q: f64, lo: f64, hi: f64) -> (f64, f64) {
    if q < lo {
        (lo, 0.0)
    } else if q > hi {
        (hi, 0.0)
    } else {
        (q, 1.0)
    }
}

/// Legendre values by the three-term recurrence
/// (k+1) P_{k+1} = (2k+1) u P_k - k P_{k-1}, and derivatives by
/// P'_{k+1} = P'_{k-1} + (2k+1) P_k; both are stable for any degree.
#[inline]
fn visit_legendre<const D: bool>(
    lo: f64,
    hi: f64,
    min_degree: usize,
    max_degree: usize,
    q: f64,
    mut f: impl FnMut(usize, f64, f64),
) {
    let (x, held) = hold_in_stroke(q, lo, hi);
    let du_dq = 2.0 / (hi - lo);
    let u = (x - lo) * du_dq - 1.0;
    let chain = held * du_dq;
    // (P_{k-1}, P_k) and (P'_{k-1}, P'_k), starting at k = 0 with P_{-1} = 0.
    let (mut p_prev, mut p) = (0.0, 1.0);
    let (mut d_prev, mut d) = (0.0, 0.0);
    for k in 0..=max_degree {
        if k >= min_degree {
            f(k - min_degree, p, d * chain);
        }
        let two_k_plus_1 = (2 * k + 1) as f64;
        // Multiplying by the reciprocal keeps the slow division off the recurrence's
        // dependency chain (it depends on k only).
        let inv_k_plus_1 = 1.0 / (k + 1) as f64;
        let p_next = (two_k_plus_1 * u * p - k as f64 * p_prev) * inv_k_plus_1;
        if D {
            (d_prev, d) = (d, d_prev + two_k_plus_1 * p);
        }
        (p_prev, p) = (p, p_next);
    }
}

/// Hat functions: on the knot interval [t_j, t_{j+1}] only hats j and j+1 are non-zero, and they
/// interpolate linearly between the knot values.
#[inline]
fn visit_table(
    knots: &[f64],
    pin_first: bool,
    pin_last: bool,
    q: f64,
    mut f: impl FnMut(usize, f64, f64),
) {
    let count = knots.len();
    let last = count - 1;
    let mut emit = |j: usize, value: f64, derivative: f64| {
        if let Some(i) = function_index(j, count, pin_first, pin_last) {
            f(i, value, derivative);
        }
    };
    if q < knots[0] {
        emit(0, 1.0, 0.0);
        return;
    }
    if q > knots[last] {
        emit(last, 1.0, 0.0);
        return;
    }
    // Interval whose left knot is the last one <= q (right-hand slope), except that q on the
    // last knot uses the last interval (left-hand slope).
    let j = knots
        .partition_point(|&t| t <= q)
        .saturating_sub(1)
        .min(last - 1);
    let inv_width = 1.0 / (knots[j + 1] - knots[j]);
    let w = (q - knots[j]) * inv_width;
    emit(j, 1.0 - w, -inv_width);
    emit(j + 1, w, inv_width);
}

/// Clamped uniform cubic B-spline: locates the knot span, evaluates its 4 non-zero functions and
/// maps them to coefficient indices (skipping pinned control points).
#[inline]
fn visit_bspline<const D: bool>(
    lo: f64,
    hi: f64,
    n_ctrl: usize,
    (pin_first, pin_last): (bool, bool),
    q: f64,
    mut f: impl FnMut(usize, f64, f64),
) {
    let (x, held) = hold_in_stroke(q, lo, hi);
    let spans = n_ctrl - SPLINE_DEGREE;
    let width = (hi - lo) / spans as f64;
    // Span s covers [lo + s*width, lo + (s+1)*width]; the float-to-int cast maps NaN to 0 and
    // `min` puts x == hi into the last span. If rounding picks the neighbouring span at an
    // interior knot that is harmless: a cubic spline's pieces agree there up to the 2nd
    // derivative.
    let span = (((x - lo) / width) as usize).min(spans - 1);
    let knot_index = span + SPLINE_DEGREE; // t[knot_index] <= x < t[knot_index + 1]
    let local_knots: [f64; 6] =
        std::array::from_fn(|i| clamped_knot(lo, hi, n_ctrl, width, knot_index - 2 + i));
    let (values, derivatives) = cubic_span_basis::<D>(&local_knots, x);
    for r in 0..=SPLINE_DEGREE {
        let j = span + r; // control point of the r-th non-zero function
        if let Some(i) = function_index(j, n_ctrl, pin_first, pin_last) {
            f(i, values[r], derivatives[r] * held);
        }
    }
}

/// Knot `i` of the clamped knot vector [lo x4, lo + width, ..., hi x4]. The ends are returned
/// exactly (not as lo + spans*width) so that q == hi lands on the end control point.
#[inline]
fn clamped_knot(lo: f64, hi: f64, n_ctrl: usize, width: f64, i: usize) -> f64 {
    if i <= SPLINE_DEGREE {
        lo
    } else if i >= n_ctrl {
        hi
    } else {
        lo + (i - SPLINE_DEGREE) as f64 * width
    }
}

/// Cox–de Boor triangle for the 4 cubic functions N_{k-3..=k} that are non-zero on knot span k
/// (The NURBS Book, algorithm A2.2), on stack arrays. `t` holds knots t_{k-2}..=t_{k+3}, so
/// t_k is `t[2]`. The derivative uses the degree-2 row of the same triangle:
/// N'_{i,3} = 3 N_{i,2} / (t_{i+3} - t_i) - 3 N_{i+1,2} / (t_{i+4} - t_{i+1}).
#[inline]
fn cubic_span_basis<const D: bool>(t: &[f64; 6], x: f64) -> ([f64; 4], [f64; 4]) {
    let mut n = [1.0, 0.0, 0.0, 0.0];
    let mut left = [0.0; 4];
    let mut right = [0.0; 4];
    let mut quadratic = [0.0; 3];
    for j in 1..=SPLINE_DEGREE {
        left[j] = x - t[3 - j];
        right[j] = t[2 + j] - x;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = n[r] / (right[r + 1] + left[j - r]);
            n[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        n[j] = saved;
        if j == 2 {
            quadratic = [n[0], n[1], n[2]];
        }
    }
    let mut dn = [0.0; 4];
    if D {
        for (r, d) in dn.iter_mut().enumerate() {
            // Function r is N_{k-3+r}; its degree-2 parts are quadratic[r-1] and quadratic[r].
            let rising = if r >= 1 {
                quadratic[r - 1] / (t[2 + r] - t[r - 1])
            } else {
                0.0
            };
            let falling = if r <= 2 {
                quadratic[r] / (t[3 + r] - t[r])
            } else {
                0.0
            };
            *d = 3.0 * (rising - falling);
        }
    }
    (n, dn)
}

/// cos(kq), sin(kq) by rotating (cos q, sin q) k times: one `sin_cos` per call instead of one
/// per harmonic. The rounding error grows about linearly with k (~k * 1e-16), negligible for the
/// harmonic counts an error model uses.
#[inline]
fn visit_fourier(
    min_harmonic: usize,
    max_harmonic: usize,
    q: f64,
    mut f: impl FnMut(usize, f64, f64),
) {
    let (s1, c1) = q.sin_cos();
    let (mut c, mut s) = (1.0, 0.0);
    let mut i = 0;
    if min_harmonic == 0 {
        f(0, 1.0, 0.0);
        i = 1;
    }
    for k in 1..=max_harmonic {
        (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
        if k >= min_harmonic {
            let kf = k as f64;
            f(i, c, -kf * s);
            f(i + 1, s, kf * c);
            i += 2;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn eval_vec(basis: &Basis, q: f64) -> Vec<f64> {
        let mut out = vec![0.0; basis.len()];
        basis.eval(q, &mut out);
        out
    }

    fn eval_with_derivative_vec(basis: &Basis, q: f64) -> (Vec<f64>, Vec<f64>) {
        let mut out = vec![0.0; basis.len()];
        let mut d_out = vec![0.0; basis.len()];
        basis.eval_with_derivative(q, &mut out, &mut d_out);
        (out, d_out)
    }

    fn max_abs(values: &[f64]) -> f64 {
        values.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// `n + 1` evenly spaced points from `a` to `b` inclusive.
    fn linspace(a: f64, b: f64, n: usize) -> impl Iterator<Item = f64> {
        (0..=n).map(move |i| a + (b - a) * i as f64 / n as f64)
    }

    /// Sample positions that determine every coefficient of `basis`: several per knot interval
    /// or span, more than twice the highest harmonic per period.
    fn spread_positions(basis: &Basis) -> Vec<f64> {
        match basis {
            Basis::Legendre { lo, hi, .. } => linspace(*lo, *hi, 4 * basis.len() + 8).collect(),
            Basis::Table { knots, .. } => knots
                .windows(2)
                .flat_map(|w| linspace(w[0], w[1], 4).take(4))
                .chain(knots.last().copied())
                .collect(),
            Basis::BSpline { lo, hi, n_ctrl, .. } => linspace(*lo, *hi, 5 * (n_ctrl - 3)).collect(),
            Basis::Fourier { max_harmonic, .. } => {
                let m = 4 * max_harmonic + 5;
                (0..m)
                    .map(|i| 0.1 + 2.0 * PI * i as f64 / m as f64)
                    .collect()
            }
        }
    }

    /// A position strictly inside the stroke (for a table: inside one knot interval, away from
    /// its knots) and a finite-difference step that stays inside with it.
    fn inner_point(basis: &Basis, fraction: f64, pick: usize) -> (f64, f64) {
        match basis {
            Basis::Legendre { lo, hi, .. } | Basis::BSpline { lo, hi, .. } => {
                let width = hi - lo;
                (lo + (0.001 + 0.998 * fraction) * width, 1e-6 * width)
            }
            Basis::Table { knots, .. } => {
                let j = pick % (knots.len() - 1);
                let width = knots[j + 1] - knots[j];
                (knots[j] + (0.01 + 0.98 * fraction) * width, 1e-3 * width)
            }
            Basis::Fourier { .. } => (-7.0 + 14.0 * fraction, 1e-6),
        }
    }

    fn stroke_strategy() -> impl Strategy<Value = (f64, f64)> {
        (-2.0..2.0f64, 0.01..3.0f64).prop_map(|(lo, width)| (lo, lo + width))
    }

    fn knots_strategy() -> impl Strategy<Value = Vec<f64>> {
        (-1.0..1.0f64, prop::collection::vec(0.05..1.0f64, 1..10)).prop_map(|(start, gaps)| {
            let mut knots = vec![start];
            for gap in gaps {
                knots.push(knots.last().unwrap() + gap);
            }
            knots
        })
    }

    fn basis_strategy() -> impl Strategy<Value = Basis> {
        prop_oneof![
            (stroke_strategy(), 0usize..4, 0usize..10).prop_map(|((lo, hi), min, extra)| {
                Basis::legendre(lo, hi, min, min + extra).unwrap()
            }),
            (knots_strategy(), any::<bool>(), any::<bool>())
                .prop_filter_map("pinning left no function", |(knots, first, last)| {
                    Basis::table(knots, first, last).ok()
                }),
            (stroke_strategy(), 4usize..13, any::<bool>(), any::<bool>()).prop_map(
                |((lo, hi), n_ctrl, first, last)| {
                    Basis::bspline(lo, hi, n_ctrl, first, last).unwrap()
                }
            ),
            (0usize..4, 0usize..6)
                .prop_map(|(min, extra)| Basis::fourier(min, min + extra).unwrap()),
        ]
    }

    // ---------------------------------------------------------------- Legendre

    #[test]
    fn legendre_matches_explicit_polynomials() {
        let (lo, hi) = (-0.3, 0.5);
        let basis = Basis::legendre(lo, hi, 0, 4).unwrap();
        for u in [-1.0, -0.7, -0.25, 0.0, 0.1, 0.5, 0.93, 1.0] {
            let q = lo + (u + 1.0) / 2.0 * (hi - lo);
            let expected = [
                1.0,
                u,
                (3.0 * u * u - 1.0) / 2.0,
                (5.0 * u * u * u - 3.0 * u) / 2.0,
                (35.0 * u.powi(4) - 30.0 * u * u + 3.0) / 8.0,
            ];
            let got = eval_vec(&basis, q);
            for (k, (g, e)) in got.iter().zip(expected).enumerate() {
                assert!((g - e).abs() < 1e-13, "P{k}({u}) = {g}, expected {e}");
            }
        }
    }

    #[test]
    fn legendre_min_degree_drops_low_degrees() {
        let full = Basis::legendre(0.0, 2.0, 0, 5).unwrap();
        let tail = Basis::legendre(0.0, 2.0, 2, 5).unwrap();
        assert_eq!(tail.len(), 4);
        assert_eq!(tail.labels(), ["P2", "P3", "P4", "P5"]);
        for q in [0.0, 0.3, 1.7, 2.0] {
            assert_eq!(eval_vec(&tail, q), eval_vec(&full, q)[2..]);
        }
    }

    #[test]
    fn legendre_polynomials_are_orthogonal() {
        // Composite Simpson rule on [-1, 1]; exact answer: 2 / (2k + 1) on the diagonal.
        let basis = Basis::legendre(-1.0, 1.0, 0, 8).unwrap();
        let n = basis.len();
        let intervals = 4000;
        let h = 2.0 / intervals as f64;
        let mut gram = vec![vec![0.0; n]; n];
        for (i, u) in linspace(-1.0, 1.0, intervals).enumerate() {
            let weight = match i {
                0 => 1.0,
                i if i == intervals => 1.0,
                i if i % 2 == 1 => 4.0,
                _ => 2.0,
            } * h
                / 3.0;
            let p = eval_vec(&basis, u);
            for (row, pj) in gram.iter_mut().zip(&p) {
                for (entry, pk) in row.iter_mut().zip(&p) {
                    *entry += weight * pj * pk;
                }
            }
        }
        for (j, row) in gram.iter().enumerate() {
            for (k, &entry) in row.iter().enumerate() {
                let expected = if j == k {
                    2.0 / (2 * k + 1) as f64
                } else {
                    0.0
                };
                assert!(
                    (entry - expected).abs() < 1e-9,
                    "<P{j}, P{k}> = {entry}, expected {expected}"
                );
            }
        }
    }

    #[test]
    fn legendre_high_degree_end_values_and_slopes() {
        // P_n(±1) = (±1)^n and P_n'(±1) = (±1)^(n+1) n(n+1)/2; d/dq adds 2/(hi-lo).
        let (lo, hi) = (0.1, 0.6);
        let basis = Basis::legendre(lo, hi, 0, 20).unwrap();
        let scale = 2.0 / (hi - lo);
        for (q, sign) in [(lo, -1.0f64), (hi, 1.0)] {
            let (p, dp) = eval_with_derivative_vec(&basis, q);
            for n in 0..=20 {
                let slope = sign.powi(n as i32 + 1) * (n * (n + 1)) as f64 / 2.0 * scale;
                assert!((p[n] - sign.powi(n as i32)).abs() < 1e-12, "P{n} at {q}");
                assert!(
                    (dp[n] - slope).abs() < 1e-9 * slope.abs().max(1.0),
                    "P{n}' at {q}"
                );
            }
        }
    }

    // ---------------------------------------------------------------- all bases

    #[test]
    fn stroke_bases_hold_end_values_outside_the_stroke() {
        let bases = [
            Basis::legendre(-0.5, 0.25, 0, 6).unwrap(),
            Basis::table(vec![-0.5, -0.1, 0.0, 0.25], false, false).unwrap(),
            Basis::bspline(-0.5, 0.25, 7, false, false).unwrap(),
        ];
        for basis in &bases {
            let (lo, hi) = basis.stroke().unwrap();
            for (outside, end) in [(lo - 0.3, lo), (hi + 1.0, hi)] {
                let (value, slope) = eval_with_derivative_vec(basis, outside);
                assert_eq!(value, eval_vec(basis, end), "{basis:?} at {outside}");
                assert!(slope.iter().all(|&d| d == 0.0), "{basis:?} at {outside}");
            }
        }
    }

    #[test]
    fn stroke_is_reported_per_kind() {
        assert_eq!(
            Basis::legendre(1.0, 2.0, 0, 1).unwrap().stroke(),
            Some((1.0, 2.0))
        );
        assert_eq!(
            Basis::table(vec![-1.0, 0.0, 3.0], true, false)
                .unwrap()
                .stroke(),
            Some((-1.0, 3.0))
        );
        assert_eq!(
            Basis::bspline(0.0, 0.5, 5, false, true).unwrap().stroke(),
            Some((0.0, 0.5))
        );
        assert_eq!(Basis::fourier(0, 2).unwrap().stroke(), None);
    }

    #[test]
    fn labels_name_every_function_in_order() {
        let cases = [
            (
                Basis::legendre(0.0, 1.0, 1, 3).unwrap(),
                vec!["P1", "P2", "P3"],
            ),
            (
                Basis::table(vec![0.0, 1.0, 2.0, 3.0], true, false).unwrap(),
                vec!["K1", "K2", "K3"],
            ),
            (
                Basis::bspline(0.0, 1.0, 5, false, true).unwrap(),
                vec!["B0", "B1", "B2", "B3"],
            ),
            (
                Basis::fourier(0, 2).unwrap(),
                vec!["C0", "C1", "S1", "C2", "S2"],
            ),
            (Basis::fourier(2, 3).unwrap(), vec!["C2", "S2", "C3", "S3"]),
        ];
        for (basis, expected) in cases {
            assert_eq!(basis.labels(), expected);
            assert_eq!(basis.len(), expected.len());
        }
    }

    #[test]
    #[should_panic(expected = "`out` has 2 slots but the basis has 3 functions")]
    fn eval_panics_on_short_output() {
        Basis::legendre(0.0, 1.0, 0, 2)
            .unwrap()
            .eval(0.5, &mut [0.0; 2]);
    }

    #[test]
    #[should_panic(expected = "`d_out` has 1 slots but the basis has 3 functions")]
    fn eval_with_derivative_panics_on_short_derivative_output() {
        let basis = Basis::fourier(0, 1).unwrap();
        basis.eval_with_derivative(0.5, &mut [0.0; 3], &mut [0.0; 1]);
    }

    #[test]
    #[should_panic(expected = "2 coefficients for a basis of 3 functions")]
    fn value_panics_on_wrong_coefficient_count() {
        Basis::fourier(0, 1).unwrap().value(0.5, &[1.0, 2.0]);
    }

    #[test]
    fn eval_leaves_slots_past_len_untouched() {
        let basis = Basis::table(vec![0.0, 1.0, 2.0], false, false).unwrap();
        let mut out = [7.0; 5];
        basis.eval(0.25, &mut out);
        assert_eq!(out, [0.75, 0.25, 0.0, 7.0, 7.0]);
    }

    // ---------------------------------------------------------------- Table

    #[test]
    fn table_interpolates_linearly_between_knots() {
        let basis = Basis::table(vec![0.0, 0.1, 0.3], false, false).unwrap();
        let (value, slope) = eval_with_derivative_vec(&basis, 0.15);
        assert!((value[1] - 0.75).abs() < 1e-15 && (value[2] - 0.25).abs() < 1e-15);
        assert_eq!(value[0], 0.0);
        assert!((slope[1] + 5.0).abs() < 1e-12 && (slope[2] - 5.0).abs() < 1e-12);
        // At an interior knot the right-hand slope, at the last knot the left-hand one.
        let (_, at_knot) = eval_with_derivative_vec(&basis, 0.1);
        assert!((at_knot[1] + 5.0).abs() < 1e-12 && at_knot[0] == 0.0);
        let (_, at_end) = eval_with_derivative_vec(&basis, 0.3);
        assert!((at_end[2] - 5.0).abs() < 1e-12 && (at_end[1] + 5.0).abs() < 1e-12);
    }

    #[test]
    fn table_value_at_knot_equals_coefficient() {
        let knots = vec![-0.2, 0.0, 0.05, 0.4, 1.0];
        let basis = Basis::table(knots.clone(), false, false).unwrap();
        let coeffs = [3.0, -1.5, 0.25, 8.0, -2.0];
        for (knot, c) in knots.iter().zip(coeffs) {
            assert_eq!(basis.value(*knot, &coeffs), c);
        }
    }

    #[test]
    fn table_pinned_end_knots_give_zero_value() {
        let knots = vec![0.0, 0.2, 0.5, 0.6];
        let basis = Basis::table(knots.clone(), true, true).unwrap();
        assert_eq!(basis.len(), 2);
        let coeffs = [4.0, -3.0];
        assert_eq!(basis.value(knots[0], &coeffs), 0.0);
        assert_eq!(basis.value(knots[3], &coeffs), 0.0);
        assert_eq!(basis.value(-5.0, &coeffs), 0.0);
        assert_eq!(basis.value(knots[1], &coeffs), 4.0);
        assert_eq!(basis.value(knots[2], &coeffs), -3.0);
        assert!((basis.value(0.1, &coeffs) - 2.0).abs() < 1e-15);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn table_is_a_partition_of_unity_when_unpinned(
            knots in knots_strategy(),
            fraction in -0.2..1.2f64,
        ) {
            let basis = Basis::table(knots.clone(), false, false).unwrap();
            let (lo, hi) = basis.stroke().unwrap();
            let (value, slope) = eval_with_derivative_vec(&basis, lo + fraction * (hi - lo));
            prop_assert!((value.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            prop_assert!(slope.iter().sum::<f64>().abs() < 1e-9 * max_abs(&slope).max(1.0));
        }

        #[test]
        fn table_fit_reproduces_any_linear_function(
            knots in knots_strategy(),
            a in -1.0..1.0f64,
            b in -1.0..1.0f64,
            fractions in prop::collection::vec(0.0..1.0f64, 5),
        ) {
            let basis = Basis::table(knots, false, false).unwrap();
            let line = |q: f64| a + b * q;
            let samples: Vec<_> =
                spread_positions(&basis).into_iter().map(|q| (q, line(q))).collect();
            let coeffs = basis.fit(&samples).unwrap();
            let (lo, hi) = basis.stroke().unwrap();
            for f in fractions {
                let q = lo + f * (hi - lo);
                prop_assert!((basis.value(q, &coeffs) - line(q)).abs() < 1e-12);
            }
        }
    }

    // ---------------------------------------------------------------- B-spline

    #[test]
    fn bspline_end_values_equal_end_control_points() {
        for n_ctrl in [4, 5, 9] {
            let basis = Basis::bspline(-0.3, 0.7, n_ctrl, false, false).unwrap();
            let coeffs: Vec<f64> = (0..n_ctrl).map(|i| (i as f64 * 1.3).sin() + 2.0).collect();
            assert!((basis.value(-0.3, &coeffs) - coeffs[0]).abs() < 1e-14);
            assert!((basis.value(0.7, &coeffs) - coeffs[n_ctrl - 1]).abs() < 1e-14);
        }
    }

    #[test]
    fn bspline_pinned_ends_give_zero_value() {
        let basis = Basis::bspline(0.0, 2.0, 6, true, true).unwrap();
        assert_eq!(basis.labels(), ["B1", "B2", "B3", "B4"]);
        let coeffs = [1.0, -2.0, 3.0, 4.0];
        assert!(basis.value(0.0, &coeffs).abs() < 1e-15);
        assert!(basis.value(2.0, &coeffs).abs() < 1e-15);
        assert!(basis.value(1.0, &coeffs).abs() > 0.1);
    }

    #[test]
    fn bspline_with_four_control_points_is_the_bernstein_basis() {
        // A single span: the clamped cubic B-spline reduces to the Bernstein polynomials.
        let basis = Basis::bspline(1.0, 3.0, 4, false, false).unwrap();
        for t in [0.0, 0.2, 0.5, 0.9, 1.0] {
            let s = 1.0 - t;
            let expected = [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t];
            let got = eval_vec(&basis, 1.0 + 2.0 * t);
            for (g, e) in got.iter().zip(expected) {
                assert!((g - e).abs() < 1e-14, "t = {t}: {got:?} vs {expected:?}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn bspline_is_a_partition_of_unity_when_unpinned(
            (lo, hi) in stroke_strategy(),
            n_ctrl in 4usize..20,
            fraction in -0.2..1.2f64,
        ) {
            let basis = Basis::bspline(lo, hi, n_ctrl, false, false).unwrap();
            let (value, slope) = eval_with_derivative_vec(&basis, lo + fraction * (hi - lo));
            prop_assert!((value.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            prop_assert!(value.iter().all(|&v| v >= -1e-15));
            prop_assert!(slope.iter().sum::<f64>().abs() < 1e-9 * max_abs(&slope).max(1.0));
        }

        #[test]
        fn bspline_fit_reproduces_any_cubic(
            (lo, hi) in stroke_strategy(),
            n_ctrl in 4usize..16,
            a in prop::array::uniform4(-1.0..1.0f64),
        ) {
            let basis = Basis::bspline(lo, hi, n_ctrl, false, false).unwrap();
            let cubic = |q: f64| a[0] + q * (a[1] + q * (a[2] + q * a[3]));
            let reach = lo.abs().max(hi.abs());
            // Bound on the size of the cubic's terms: the yardstick for "relative" error.
            let scale: f64 =
                a.iter().enumerate().map(|(k, c)| c.abs() * reach.powi(k as i32)).sum();
            let samples: Vec<_> =
                spread_positions(&basis).into_iter().map(|q| (q, cubic(q))).collect();
            let coeffs = basis.fit(&samples).unwrap();
            for q in linspace(lo, hi, 37) {
                let error = (basis.value(q, &coeffs) - cubic(q)).abs();
                prop_assert!(error <= 1e-9 * scale, "error {error} at {q}, scale {scale}");
            }
        }
    }

    // ---------------------------------------------------------------- Fourier

    #[test]
    fn fourier_values_and_derivatives_match_cos_sin() {
        let basis = Basis::fourier(0, 6).unwrap();
        for q in [-9.0, -PI, -0.4, 0.0, 0.3, 2.0, 7.5] {
            let (value, slope) = eval_with_derivative_vec(&basis, q);
            assert_eq!((value[0], slope[0]), (1.0, 0.0));
            for k in 1..=6 {
                let kf = k as f64;
                let (c, s) = ((kf * q).cos(), (kf * q).sin());
                let (i_cos, i_sin) = (2 * k - 1, 2 * k);
                assert!((value[i_cos] - c).abs() < 1e-13, "cos({k} * {q})");
                assert!((value[i_sin] - s).abs() < 1e-13, "sin({k} * {q})");
                assert!((slope[i_cos] + kf * s).abs() < 1e-12, "d cos({k} * {q})");
                assert!((slope[i_sin] - kf * c).abs() < 1e-12, "d sin({k} * {q})");
            }
        }
    }

    #[test]
    fn fourier_min_harmonic_skips_lower_harmonics() {
        let basis = Basis::fourier(2, 3).unwrap();
        let q = 0.7;
        let value = eval_vec(&basis, q);
        let expected = [
            (2.0 * q).cos(),
            (2.0 * q).sin(),
            (3.0 * q).cos(),
            (3.0 * q).sin(),
        ];
        for (v, e) in value.iter().zip(expected) {
            assert!((v - e).abs() < 1e-14);
        }
    }

    #[test]
    fn fourier_fit_recovers_planted_coefficients() {
        let basis = Basis::fourier(0, 3).unwrap();
        let planted = [1e-6, -2e-6, 0.5e-6, 3e-7, -1e-7, 4e-8, 2e-8];
        let samples: Vec<_> = (0..36)
            .map(|i| {
                let q = i as f64 * 10f64.to_radians();
                (q, basis.value(q, &planted))
            })
            .collect();
        let fitted = basis.fit(&samples).unwrap();
        for (f, p) in fitted.iter().zip(planted) {
            assert!((f - p).abs() < 1e-18, "{fitted:?} vs {planted:?}");
        }
    }

    // ---------------------------------------------------------------- fit

    #[test]
    fn fit_rejects_samples_between_two_knots() {
        let basis = Basis::table(vec![0.0, 1.0, 2.0, 3.0], false, false).unwrap();
        let samples: Vec<_> = (0..10).map(|i| (0.2 + 0.06 * i as f64, 1.0)).collect();
        let err = basis.fit(&samples).unwrap_err();
        assert_eq!(
            err,
            BasisError::RankDeficient {
                independent: 2,
                coefficients: 4
            }
        );
        assert!(
            err.to_string()
                .contains("only 2 independent samples for 4 coefficients")
        );
    }

    #[test]
    fn fit_rejects_samples_within_one_spline_span() {
        let basis = Basis::bspline(0.0, 1.0, 8, false, false).unwrap();
        let samples: Vec<_> = (0..20).map(|i| (0.01 * i as f64, 0.0)).collect();
        assert_eq!(
            basis.fit(&samples),
            Err(BasisError::RankDeficient {
                independent: 4,
                coefficients: 8
            })
        );
    }

    #[test]
    fn fit_rejects_repeated_positions() {
        let basis = Basis::legendre(0.0, 1.0, 0, 4).unwrap();
        let samples: Vec<_> = (0..12).map(|i| ((i % 3) as f64 * 0.4, 0.0)).collect();
        assert_eq!(
            basis.fit(&samples),
            Err(BasisError::RankDeficient {
                independent: 3,
                coefficients: 5
            })
        );
    }

    #[test]
    fn fit_rejects_aliased_angles() {
        // At multiples of 90 degrees sin(2q) vanishes: its coefficient is undetermined.
        let basis = Basis::fourier(0, 2).unwrap();
        let samples: Vec<_> = (0..8).map(|i| (i as f64 * PI / 2.0, 1.0)).collect();
        assert_eq!(
            basis.fit(&samples),
            Err(BasisError::RankDeficient {
                independent: 4,
                coefficients: 5
            })
        );
    }

    #[test]
    fn fit_rejects_too_few_samples() {
        let basis = Basis::bspline(0.0, 1.0, 4, false, false).unwrap();
        let err = basis
            .fit(&[(0.0, 1.0), (0.5, 1.0), (1.0, 1.0)])
            .unwrap_err();
        assert_eq!(
            err,
            BasisError::TooFewSamples {
                samples: 3,
                coefficients: 4
            }
        );
        assert_eq!(
            err.to_string(),
            "fit needs at least as many independent samples as coefficients: \
             3 samples for 4 coefficients"
        );
        assert!(matches!(
            basis.fit(&[]),
            Err(BasisError::TooFewSamples { samples: 0, .. })
        ));
    }

    #[test]
    fn fit_rejects_non_finite_samples() {
        let basis = Basis::legendre(0.0, 1.0, 0, 1).unwrap();
        let mut samples = vec![
            (0.0, 0.0),
            (0.25, 1.0),
            (0.5, 2.0),
            (0.75, 3.0),
            (1.0, f64::NAN),
        ];
        let err = basis.fit(&samples).unwrap_err();
        assert!(matches!(err, BasisError::NonFiniteSample { index: 4, .. }));
        assert!(err.to_string().starts_with("sample 4 is not finite"));
        samples[4] = (f64::INFINITY, 0.0);
        assert!(matches!(
            basis.fit(&samples),
            Err(BasisError::NonFiniteSample { index: 4, .. })
        ));
    }

    #[test]
    fn fit_validates_a_basis_built_directly() {
        let basis = Basis::BSpline {
            lo: 0.0,
            hi: 1.0,
            n_ctrl: 2,
            pin_first: false,
            pin_last: false,
        };
        assert_eq!(
            basis.fit(&[(0.0, 0.0); 8]),
            Err(BasisError::TooFewControlPoints { count: 2 })
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn fit_recovers_planted_coefficients(
            basis in basis_strategy(),
            pool in prop::collection::vec(-1.0..1.0f64, 16),
        ) {
            let planted = &pool[..basis.len()];
            let samples: Vec<_> = spread_positions(&basis)
                .into_iter()
                .map(|q| (q, basis.value(q, planted)))
                .collect();
            let fitted = basis.fit(&samples).unwrap();
            for (f, p) in fitted.iter().zip(planted) {
                prop_assert!((f - p).abs() < 1e-9, "{fitted:?} vs {planted:?}");
            }
        }

        #[test]
        fn derivative_matches_central_difference(
            basis in basis_strategy(),
            fraction in 0.0..1.0f64,
            pick in 0usize..100,
        ) {
            let (q, h) = inner_point(&basis, fraction, pick);
            let (_, slope) = eval_with_derivative_vec(&basis, q);
            let (plus, minus) = (eval_vec(&basis, q + h), eval_vec(&basis, q - h));
            let tolerance = 1e-6 * (1.0 + max_abs(&slope));
            for i in 0..basis.len() {
                let difference = (plus[i] - minus[i]) / (2.0 * h);
                prop_assert!(
                    (slope[i] - difference).abs() <= tolerance,
                    "function {i} at {q}: derivative {} vs difference {difference}", slope[i]
                );
            }
        }

        #[test]
        fn value_equals_dot_of_eval_and_coefficients(
            basis in basis_strategy(),
            q in -5.0..8.0f64,
            pool in prop::collection::vec(-1.0..1.0f64, 16),
        ) {
            let coeffs = &pool[..basis.len()];
            let dot: f64 = eval_vec(&basis, q).iter().zip(coeffs).map(|(f, c)| f * c).sum();
            prop_assert!((basis.value(q, coeffs) - dot).abs() <= 1e-12 * (1.0 + dot.abs()));
        }

        #[test]
        fn eval_with_derivative_values_equal_eval(basis in basis_strategy(), q in -5.0..8.0f64) {
            let (value, _) = eval_with_derivative_vec(&basis, q);
            prop_assert_eq!(value, eval_vec(&basis, q));
        }

        #[test]
        fn labels_match_len(basis in basis_strategy()) {
            prop_assert_eq!(basis.labels().len(), basis.len());
            prop_assert!(!basis.is_empty());
        }
    }

    // ---------------------------------------------------------------- validation

    fn message(result: Result<Basis, BasisError>) -> String {
        result.unwrap_err().to_string()
    }

    #[test]
    fn constructors_reject_invalid_strokes() {
        assert_eq!(
            message(Basis::legendre(1.0, 1.0, 0, 2)),
            "stroke [lo, hi] must be finite with lo < hi, got [1, 1]"
        );
        assert_eq!(
            message(Basis::bspline(0.5, -0.5, 6, false, false)),
            "stroke [lo, hi] must be finite with lo < hi, got [0.5, -0.5]"
        );
        assert!(matches!(
            Basis::legendre(0.0, f64::NAN, 0, 2),
            Err(BasisError::InvalidStroke { .. })
        ));
        assert!(matches!(
            Basis::bspline(f64::NEG_INFINITY, 0.0, 6, false, false),
            Err(BasisError::InvalidStroke { .. })
        ));
    }

    #[test]
    fn constructors_reject_empty_ranges() {
        assert_eq!(
            message(Basis::legendre(0.0, 1.0, 3, 2)),
            "degree range 3..=2 is empty: min_degree must not exceed max_degree"
        );
        assert_eq!(
            message(Basis::fourier(4, 1)),
            "harmonic range 4..=1 is empty: min_harmonic must not exceed max_harmonic"
        );
    }

    #[test]
    fn table_constructor_rejects_bad_knots() {
        assert_eq!(
            message(Basis::table(vec![0.0, 0.1, 0.2, 0.2], false, false)),
            "knots must be strictly increasing: knot 3 (0.2) <= knot 2 (0.2)"
        );
        assert_eq!(
            message(Basis::table(vec![0.0, -1.0], false, false)),
            "knots must be strictly increasing: knot 1 (-1) <= knot 0 (0)"
        );
        assert_eq!(
            message(Basis::table(vec![0.0, f64::INFINITY], false, false)),
            "knot 1 is not finite (inf)"
        );
        assert_eq!(
            message(Basis::table(vec![0.0], false, false)),
            "a table needs at least 2 knots, got 1"
        );
        assert_eq!(
            message(Basis::table(vec![0.0, 1.0], true, true)),
            "basis has no functions left after pinning: add knots or unpin an end"
        );
        assert!(Basis::table(vec![0.0, 1.0], true, false).is_ok());
    }

    #[test]
    fn bspline_constructor_rejects_too_few_control_points() {
        assert_eq!(
            message(Basis::bspline(0.0, 1.0, 3, false, false)),
            "a B-spline needs at least 4 control points, got 3"
        );
    }

    #[test]
    fn validate_checks_values_built_directly() {
        let bad_table = Basis::Table {
            knots: vec![],
            pin_first: false,
            pin_last: false,
        };
        assert_eq!(
            bad_table.validate(),
            Err(BasisError::TooFewKnots { count: 0 })
        );
        assert_eq!(bad_table.stroke(), None);
        let bad_legendre = Basis::Legendre {
            lo: 0.0,
            hi: 1.0,
            min_degree: 5,
            max_degree: 2,
        };
        assert_eq!(
            bad_legendre.validate(),
            Err(BasisError::EmptyDegreeRange { min: 5, max: 2 })
        );
        assert!(bad_legendre.is_empty());
        let good = Basis::Fourier {
            min_harmonic: 0,
            max_harmonic: 0,
        };
        assert_eq!(good.validate(), Ok(()));
        assert_eq!(good.len(), 1);
    }
}
