//! 2-D fits of measured against nominal feature positions, without a machine: what a CMM report
//! of a drilled hole plate, or a plate probed once, gives before any session is built.
//!
//! Every fit is linear least squares `measured − nominal = Σ xᵢ·termᵢ(nominal)` over the x and y
//! coordinates of all features, with the covariance `σ̂²·(AᵀA)⁻¹` from the residual scatter
//! (`σ̂² = SS / (2n − p)`), so the 95 % intervals are `±1.96·σᵢ`.
//!
//! # Terms ([`Term`])
//! - `Tx`, `Ty`: offset; `Rot`: small rotation `(−y, x)`; `Scale`: common scale `(x, y)`;
//! - the machine-tool terms of the XY plane (the drilling machine's errors at the hole): `Exx1`
//!   the X scale error (EXX slope, `(x, 0)`), `Eyy1` the Y scale error (EYY slope, `(0, y)`),
//!   `Ec0y` the squareness (`(−y, 0)`: moving Y by y moves the tool by −EC0Y·y along X,
//!   ARCHITECTURE.md), and second-order shape terms `Exx2` `(x², 0)`, `Eyy2` `(0, y²)`, `Eyx2`
//!   `(0, x²)` (straightness of X in Y), `Exy2` `(y², 0)` (straightness of Y in X);
//! - `QpCos`, `QpSin`: a radial quadrupole `M·r·cos(2(φ − α))·r̂` split into its linear
//!   coefficients (`M cos 2α`, `M sin 2α`), the "QP" term of plug-plate QA software.
//!
//! The similarity fit (`Tx Ty Scale Rot`) is exact, not linearised: `measured = t + s·R(θ)·nominal`
//! is linear in `(s cos θ, s sin θ)` ([`similarity`]). The other fits are made after removing
//! the similarity's rotation from the measured positions, so their `Rot` is a residual rotation of
//! the order of the errors and its linearisation error negligible.

use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

/// One linear term of a fit (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Term {
    Tx,
    Ty,
    Rot,
    Scale,
    Exx1,
    Eyy1,
    Ec0y,
    Exx2,
    Eyy2,
    Eyx2,
    Exy2,
    QpCos,
    QpSin,
}

impl Term {
    /// The term's displacement `(dx, dy)` at nominal point `(x, y)`.
    pub fn eval(self, x: f64, y: f64) -> [f64; 2] {
        let r2 = x * x + y * y;
        match self {
            Term::Tx => [1.0, 0.0],
            Term::Ty => [0.0, 1.0],
            Term::Rot => [-y, x],
            Term::Scale => [x, y],
            Term::Exx1 => [x, 0.0],
            Term::Eyy1 => [0.0, y],
            Term::Ec0y => [-y, 0.0],
            Term::Exx2 => [x * x, 0.0],
            Term::Eyy2 => [0.0, y * y],
            Term::Eyx2 => [0.0, x * x],
            Term::Exy2 => [y * y, 0.0],
            // r·cos 2φ · r̂ = (x² − y²)/r² · (x, y); r·sin 2φ · r̂ = 2xy/r² · (x, y).
            Term::QpCos if r2 > 0.0 => {
                let c = (x * x - y * y) / r2;
                [c * x, c * y]
            }
            Term::QpSin if r2 > 0.0 => {
                let s = 2.0 * x * y / r2;
                [s * x, s * y]
            }
            Term::QpCos | Term::QpSin => [0.0, 0.0],
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Term::Tx => "tx",
            Term::Ty => "ty",
            Term::Rot => "rot",
            Term::Scale => "scale",
            Term::Exx1 => "EXX slope",
            Term::Eyy1 => "EYY slope",
            Term::Ec0y => "EC0Y",
            Term::Exx2 => "EXX quadratic",
            Term::Eyy2 => "EYY quadratic",
            Term::Eyx2 => "EYX quadratic",
            Term::Exy2 => "EXY quadratic",
            Term::QpCos => "QP cos",
            Term::QpSin => "QP sin",
        }
    }
}

/// The result of a linear fit.
#[derive(Clone, Debug)]
pub struct LinearFit {
    pub terms: Vec<Term>,
    /// Coefficients (units of the data: mm, and mm/mm or 1/mm for the shape terms).
    pub x: Vec<f64>,
    /// Covariance of `x` from the residual scatter.
    pub cov: DMatrix<f64>,
    /// Residuals `(dx, dy)` per point.
    pub residuals: Vec<[f64; 2]>,
    /// Sum of squared residuals.
    pub ss: f64,
    /// Degrees of freedom `2n − p`.
    pub dof: usize,
}

impl LinearFit {
    /// Standard uncertainty of coefficient `i`.
    pub fn sigma(&self, i: usize) -> f64 {
        self.cov[(i, i)].sqrt()
    }
    /// The coefficient of `t` and its standard uncertainty.
    pub fn get(&self, t: Term) -> Option<(f64, f64)> {
        let i = self.terms.iter().position(|&u| u == t)?;
        Some((self.x[i], self.sigma(i)))
    }
    /// RMS of the radial residual `|r|` over the points `which` (all if `None`), dividing by
    /// `count − ddof`.
    pub fn radial_rms(&self, which: Option<&[bool]>, ddof: usize) -> f64 {
        let mut ss = 0.0;
        let mut n = 0usize;
        for (k, r) in self.residuals.iter().enumerate() {
            if which.is_none_or(|w| w[k]) {
                ss += r[0] * r[0] + r[1] * r[1];
                n += 1;
            }
        }
        (ss / (n.saturating_sub(ddof)).max(1) as f64).sqrt()
    }
}

/// Least squares `measured − nominal = Σ xᵢ·termᵢ(nominal)`. Panics if there are fewer
/// equations than terms.
pub fn fit(nominal: &[[f64; 2]], measured: &[[f64; 2]], terms: &[Term]) -> LinearFit {
    let n = nominal.len();
    let p = terms.len();
    assert!(2 * n > p, "{n} points cannot fit {p} terms");
    let mut a = DMatrix::zeros(2 * n, p);
    let mut b = DVector::zeros(2 * n);
    for (k, (nm, ms)) in nominal.iter().zip(measured).enumerate() {
        for (j, t) in terms.iter().enumerate() {
            let v = t.eval(nm[0], nm[1]);
            a[(2 * k, j)] = v[0];
            a[(2 * k + 1, j)] = v[1];
        }
        b[2 * k] = ms[0] - nm[0];
        b[2 * k + 1] = ms[1] - nm[1];
    }
    let svd = a.clone().svd(true, true);
    let x = svd.solve(&b, 1e-14).expect("SVD solve");
    let r = &b - &a * &x;
    let ss = r.norm_squared();
    let dof = 2 * n - p;
    let ata_inv = (a.transpose() * &a)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_element(p, p, f64::NAN));
    let cov = ata_inv * (ss / dof as f64);
    LinearFit {
        terms: terms.to_vec(),
        x: x.iter().copied().collect(),
        cov,
        residuals: (0..n).map(|k| [r[2 * k], r[2 * k + 1]]).collect(),
        ss,
        dof,
    }
}

/// The exact similarity fit `measured = t + s·R(θ)·nominal`.
#[derive(Clone, Debug)]
pub struct Similarity {
    pub offset: [f64; 2],
    pub scale: f64,
    /// Radians, counter-clockwise.
    pub rotation: f64,
    /// The linear fit behind it (terms `Tx Ty Scale Rot`: `s cos θ − 1`, `s sin θ`).
    pub fit: LinearFit,
}

/// The similarity fit of [`Similarity`] (linear in `s cos θ`, `s sin θ`).
pub fn similarity(nominal: &[[f64; 2]], measured: &[[f64; 2]]) -> Similarity {
    let f = fit(
        nominal,
        measured,
        &[Term::Tx, Term::Ty, Term::Scale, Term::Rot],
    );
    let (a, b) = (1.0 + f.x[2], f.x[3]);
    Similarity {
        offset: [f.x[0], f.x[1]],
        scale: a.hypot(b),
        rotation: b.atan2(a),
        fit: f,
    }
}

/// Measured positions with the similarity's rotation (about the origin) removed: what the other
/// fits use so that their `Rot` term stays small.
pub fn derotated(measured: &[[f64; 2]], rotation: f64) -> Vec<[f64; 2]> {
    let (s, c) = (-rotation).sin_cos();
    measured
        .iter()
        .map(|m| [c * m[0] - s * m[1], s * m[0] + c * m[1]])
        .collect()
}

/// The machine-tool fit: offsets, residual rotation, X and Y scale errors and squareness, plus
/// `extra` terms, on measured positions with the similarity rotation removed.
pub fn machine_fit(nominal: &[[f64; 2]], measured: &[[f64; 2]], extra: &[Term]) -> LinearFit {
    let sim = similarity(nominal, measured);
    let m = derotated(measured, sim.rotation);
    let mut terms = vec![
        Term::Tx,
        Term::Ty,
        Term::Rot,
        Term::Exx1,
        Term::Eyy1,
        Term::Ec0y,
    ];
    terms.extend_from_slice(extra);
    fit(nominal, &m, &terms)
}

/// A radial quadrupole `M·r·cos(2(φ − α))·r̂` from its two linear coefficients, with
/// first-order uncertainties: `(M, α rad, σ_M, σ_α)`.
pub fn quadrupole(c: f64, s: f64, cov: [[f64; 2]; 2]) -> (f64, f64, f64, f64) {
    let m = c.hypot(s);
    let alpha = 0.5 * s.atan2(c);
    // ∂M/∂(c, s) = (c, s)/M; ∂α/∂(c, s) = ½(−s, c)/M².
    let gm = [c / m, s / m];
    let ga = [-0.5 * s / (m * m), 0.5 * c / (m * m)];
    let q = |g: [f64; 2]| {
        (g[0] * g[0] * cov[0][0] + 2.0 * g[0] * g[1] * cov[0][1] + g[1] * g[1] * cov[1][1]).sqrt()
    };
    (m, alpha, q(gm), q(ga))
}

/// The F test of a nested fit: does `full` (more terms) fit significantly better than `reduced`?
/// Returns `(F, p-value)`.
pub fn f_test(reduced: &LinearFit, full: &LinearFit) -> (f64, f64) {
    let dp = full.terms.len() - reduced.terms.len();
    let f = ((reduced.ss - full.ss) / dp as f64) / (full.ss / full.dof as f64);
    (f, f_sf(f, dp as f64, full.dof as f64))
}

/// Survival function of the F distribution with `(d1, d2)` degrees of freedom (1 where the
/// distribution is undefined).
pub fn f_sf(f: f64, d1: f64, d2: f64) -> f64 {
    if f <= 0.0 {
        return 1.0;
    }
    FisherSnedecor::new(d1, d2).map_or(1.0, |d| d.sf(f))
}

/// One hole of a CMM hole-plate report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hole {
    /// Measured centre, mm.
    pub measured: [f64; 2],
    /// Nominal (drawing) centre, mm.
    pub nominal: [f64; 2],
    pub measured_diameter: f64,
    pub nominal_diameter: f64,
    pub roundness: f64,
}

/// Why a hole report could not be read: the line (1-based) and what was wrong with it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HoleReportError {
    #[error("line {line}: expected 9 numbers, found {found} fields")]
    FieldCount { line: usize, found: usize },
    #[error("line {line}: field {field} `{text}` is not a number")]
    NotANumber {
        line: usize,
        /// 1-based.
        field: usize,
        text: String,
    },
}

/// Reads a whitespace-separated hole report (the SDSS plug-plate CMM format): header lines
/// (`Plug Plate: …`, `Date: …`, a column header), `#` comments and blank lines are skipped;
/// every line of nine numbers is `Meas X, Meas Y, Nom X, Nom Y, Err X, Err Y, Meas D, Nom D,
/// Round`. CRLF line ends are accepted. An error names the line (1-based) of a malformed row.
pub fn read_hole_report(text: &str) -> Result<Vec<Hole>, HoleReportError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let first_numeric = fields[0]
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_digit() || c == '-' || c == '+' || c == '.');
        if !first_numeric {
            continue; // a header line
        }
        if fields.len() != 9 {
            return Err(HoleReportError::FieldCount {
                line: i + 1,
                found: fields.len(),
            });
        }
        let v: Vec<f64> = fields
            .iter()
            .enumerate()
            .map(|(j, f)| {
                f.parse::<f64>().map_err(|_| HoleReportError::NotANumber {
                    line: i + 1,
                    field: j + 1,
                    text: f.to_string(),
                })
            })
            .collect::<Result<_, _>>()?;
        out.push(Hole {
            measured: [v[0], v[1]],
            nominal: [v[2], v[3]],
            measured_diameter: v[6],
            nominal_diameter: v[7],
            roundness: v[8],
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hole_reports_are_read_and_bad_rows_located() {
        let text = "Plug Plate: 1234\r\n# a comment\r\nMeas X Meas Y ...\r\n\
                    1 2 1.5 2.5 -0.5 -0.5 3.1 3.0 0.01\r\n";
        let holes = read_hole_report(text).unwrap();
        assert_eq!(holes.len(), 1);
        assert_eq!(
            (holes[0].measured, holes[0].nominal, holes[0].roundness),
            ([1.0, 2.0], [1.5, 2.5], 0.01)
        );
        assert_eq!(
            read_hole_report("x\n1 2 3\n"),
            Err(HoleReportError::FieldCount { line: 2, found: 3 })
        );
        let e = read_hole_report("1 2 3 4 5 six 7 8 9").unwrap_err();
        assert_eq!(e.to_string(), "line 1: field 6 `six` is not a number");
    }

    #[test]
    fn f_distribution_matches_known_values() {
        // F(2, 10): P(F > 4.1028) = 0.05; F(1, 20): P(F > 4.3512) = 0.05.
        assert!((f_sf(4.1028, 2.0, 10.0) - 0.05).abs() < 1e-4);
        assert!((f_sf(4.3512, 1.0, 20.0) - 0.05).abs() < 1e-4);
    }

    #[test]
    fn machine_terms_are_recovered_exactly() {
        let mut nom = Vec::new();
        for i in -3..=3 {
            for j in -3..=3 {
                nom.push([50.0 * i as f64 + 3.0, 40.0 * j as f64 - 1.0]);
            }
        }
        let (a, b, g, th) = (12e-6, -7e-6, 9e-6, 0.01_f64);
        let meas: Vec<[f64; 2]> = nom
            .iter()
            .map(|&[x, y]| {
                let (ex, ey) = (x + a * x - g * y + 2e-7 * y * y, y + b * y);
                let (s, c) = th.sin_cos();
                [0.3 + c * ex - s * ey, -0.2 + s * ex + c * ey]
            })
            .collect();
        let f = machine_fit(&nom, &meas, &[Term::Exy2]);
        let get = |t| f.get(t).unwrap().0;
        // Exact to second order in the errors (the derotation uses the similarity's angle).
        assert!((get(Term::Exx1) - a).abs() < 1e-9, "{}", get(Term::Exx1));
        assert!((get(Term::Eyy1) - b).abs() < 1e-9);
        assert!((get(Term::Ec0y) - g).abs() < 1e-9);
        assert!((get(Term::Exy2) - 2e-7).abs() < 1e-11);
    }
}
