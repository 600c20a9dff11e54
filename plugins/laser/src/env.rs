//! Environmental compensation of length readings: the refractive index of air (revised Edlén
//! equation of Birch & Downs) and the normalisation to a 20 °C material temperature.

use crate::mode::Mode;
use mtcal_instrument::{ReadingError, RunData, SetupError};

/// Vacuum wavelength of a stabilised He-Ne laser, nm (the default of `wavelength_nm`).
pub const HENE_NM: f64 = 632.991;
/// Reference temperature of dimensional metrology (ISO 1), °C.
pub const REFERENCE_C: f64 = 20.0;

/// The context columns read, as the run's CSV names them.
pub const COLUMN_AIR_T: &str = "T_air";
pub const COLUMN_AIR_P: &str = "P_air";
pub const COLUMN_AIR_H: &str = "H_air";
pub const COLUMN_MATERIAL_T: &str = "T_material";

/// Plausible ranges of the environment, beyond which a value is taken for a unit mistake.
const AIR_T_RANGE: (f64, f64) = (-20.0, 60.0);
const AIR_P_RANGE_HPA: (f64, f64) = (500.0, 1200.0);
const AIR_H_RANGE: (f64, f64) = (0.0, 100.0);
const MATERIAL_T_RANGE: (f64, f64) = (-20.0, 80.0);

/// Saturation vapour pressure of water over a plane liquid surface, Pa, at `t_c` °C: the
/// IAPWS-IF97 saturation-pressure equation as the NIST Engineering Metrology Toolbox uses it
/// (J. A. Stone, J. H. Zimmerman, "Index of refraction of air", Appendix A-I).
pub fn saturation_vapour_pressure(t_c: f64) -> f64 {
    const K: [f64; 10] = [
        1.167_052_145_28e3,
        -7.242_131_670_32e5,
        -1.707_384_694_01e1,
        1.202_082_470_25e4,
        -3.232_555_032_23e6,
        1.491_510_861_35e1,
        -4.823_265_736_16e3,
        4.051_134_054_21e5,
        -2.385_555_756_78e-1,
        6.501_753_484_48e2,
    ];
    let t = t_c + 273.15;
    let omega = t + K[8] / (t - K[9]);
    let a = omega * omega + K[0] * omega + K[1];
    let b = K[2] * omega * omega + K[3] * omega + K[4];
    let c = K[5] * omega * omega + K[6] * omega + K[7];
    let x = -b + (b * b - 4.0 * a * c).sqrt();
    1e6 * (2.0 * c / x).powi(4)
}

/// Refractive index of air by the revised Edlén equation of K. P. Birch and M. J. Downs,
/// "An updated Edlén equation for the refractive index of air", Metrologia 30 (1993) 155–162,
/// with the corrected form of "Correction to the updated Edlén equation for the refractive
/// index of air", Metrologia 31 (1994) 315–316 (standard air with 450 ppm CO₂):
///
/// ```text
/// σ = 1/λ_vac (µm⁻¹)
/// (n_s − 1)·10⁸   = 8342.54 + 2406147/(130 − σ²) + 15998/(38.9 − σ²)      dry air, 15 °C, 101 325 Pa
/// (n_tp − 1)      = p (n_s − 1)/96095.43 · [1 + 10⁻⁸ (0.601 − 0.00972 t) p]/(1 + 0.003661 t)
/// n_tpf − n_tp    = −f (3.7345 − 0.0401 σ²)·10⁻¹⁰
/// ```
///
/// `lambda_nm` vacuum wavelength, `t_c` °C, `p_pa` Pa, `f_pa` partial pressure of water
/// vapour, Pa.
pub fn edlen_index_f(lambda_nm: f64, t_c: f64, p_pa: f64, f_pa: f64) -> f64 {
    let sigma = 1e3 / lambda_nm;
    let s2 = sigma * sigma;
    let ns = (8342.54 + 2_406_147.0 / (130.0 - s2) + 15998.0 / (38.9 - s2)) * 1e-8;
    let ntp = p_pa * ns / 96095.43 * (1.0 + 1e-8 * (0.601 - 0.00972 * t_c) * p_pa)
        / (1.0 + 0.003661 * t_c);
    let water = -f_pa * (3.7345 - 0.0401 * s2) * 1e-10;
    1.0 + ntp + water
}

/// [`edlen_index_f`] with the humidity as relative humidity `rh_pct` (%):
/// `f = rh/100 · p_sv(t)` ([`saturation_vapour_pressure`]).
pub fn edlen_index(lambda_nm: f64, t_c: f64, p_pa: f64, rh_pct: f64) -> f64 {
    edlen_index_f(
        lambda_nm,
        t_c,
        p_pa,
        rh_pct / 100.0 * saturation_vapour_pressure(t_c),
    )
}

/// The environmental settings of a set-up (keys in the crate documentation).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Environment {
    /// `false`: the readings were made with the instrument's assumed refractive index and
    /// must be corrected for the air; `None` means the key was not written (= `true`).
    pub wavelength_compensated: Option<bool>,
    pub assumed_index: Option<f64>,
    pub wavelength_nm: Option<f64>,
    pub air_temperature_c: Option<f64>,
    pub air_pressure_hpa: Option<f64>,
    pub air_humidity_pct: Option<f64>,
    pub material_temperature_c: Option<f64>,
    pub expansion_ppm_per_k: Option<f64>,
}

fn in_range(key: &str, v: Option<f64>, lo: f64, hi: f64, what: &str) -> Result<(), SetupError> {
    match v {
        Some(x) if !(lo..=hi).contains(&x) => Err(SetupError::new(
            key,
            format!("{what}: expected {lo} to {hi}, found {x}"),
        )),
        _ => Ok(()),
    }
}

impl Environment {
    /// The air keys and whether each is written.
    fn air_keys(&self) -> [(&'static str, bool); 5] {
        [
            ("assumed_index", self.assumed_index.is_some()),
            ("wavelength_nm", self.wavelength_nm.is_some()),
            ("air_temperature_c", self.air_temperature_c.is_some()),
            ("air_pressure_hpa", self.air_pressure_hpa.is_some()),
            ("air_humidity_pct", self.air_humidity_pct.is_some()),
        ]
    }

    /// Checks the environment keys as written: they apply to length modes only, the air keys
    /// to uncompensated readings only, and each lies in its plausible range.
    pub fn checked(self, mode: Mode) -> Result<Self, SetupError> {
        if !mode.is_length() {
            let others = [
                (
                    "wavelength_compensated",
                    self.wavelength_compensated.is_some(),
                ),
                (
                    "material_temperature_c",
                    self.material_temperature_c.is_some(),
                ),
                ("expansion_ppm_per_k", self.expansion_ppm_per_k.is_some()),
            ];
            for (key, given) in self.air_keys().into_iter().chain(others) {
                if given {
                    return Err(SetupError::new(
                        key,
                        format!(
                            "environmental compensation applies to length readings (linear, \
                             diagonal, step-diagonal), not \"{}\"",
                            mode.as_str()
                        ),
                    ));
                }
            }
        }
        if self.wavelength_compensated != Some(false) {
            for (key, given) in self.air_keys() {
                if given {
                    return Err(SetupError::new(
                        key,
                        "only used with `wavelength_compensated = false` (the readings are \
                         otherwise already corrected for the air by the instrument)",
                    ));
                }
            }
        }
        in_range(
            "assumed_index",
            self.assumed_index,
            0.9,
            1.1,
            "a refractive index",
        )?;
        in_range(
            "wavelength_nm",
            self.wavelength_nm,
            200.0,
            2000.0,
            "a vacuum wavelength, nm",
        )?;
        in_range(
            "air_temperature_c",
            self.air_temperature_c,
            AIR_T_RANGE.0,
            AIR_T_RANGE.1,
            "an air temperature, °C",
        )?;
        in_range(
            "air_pressure_hpa",
            self.air_pressure_hpa,
            AIR_P_RANGE_HPA.0,
            AIR_P_RANGE_HPA.1,
            "an air pressure, hPa",
        )?;
        in_range(
            "air_humidity_pct",
            self.air_humidity_pct,
            AIR_H_RANGE.0,
            AIR_H_RANGE.1,
            "a relative humidity, %",
        )?;
        in_range(
            "material_temperature_c",
            self.material_temperature_c,
            MATERIAL_T_RANGE.0,
            MATERIAL_T_RANGE.1,
            "a material temperature, °C",
        )?;
        in_range(
            "expansion_ppm_per_k",
            self.expansion_ppm_per_k,
            -50.0,
            50.0,
            "an expansion coefficient, ppm/K",
        )?;
        if self.material_temperature_c.is_some() && self.expansion_ppm_per_k.is_none() {
            return Err(SetupError::new(
                "material_temperature_c",
                "needs `expansion_ppm_per_k` (the material's expansion coefficient)",
            ));
        }
        Ok(self)
    }

    /// Writes the keys that were given (and `wavelength_compensated` for length modes).
    pub fn write(&self, t: &mut toml::Table) {
        if let Some(b) = self.wavelength_compensated {
            t.insert("wavelength_compensated".into(), b.into());
        }
        for (key, v) in [
            ("assumed_index", self.assumed_index),
            ("wavelength_nm", self.wavelength_nm),
            ("air_temperature_c", self.air_temperature_c),
            ("air_pressure_hpa", self.air_pressure_hpa),
            ("air_humidity_pct", self.air_humidity_pct),
            ("material_temperature_c", self.material_temperature_c),
            ("expansion_ppm_per_k", self.expansion_ppm_per_k),
        ] {
            if let Some(x) = v {
                t.insert(key.into(), x.into());
            }
        }
    }

    /// Whether the air correction applies.
    pub fn air(&self) -> bool {
        self.wavelength_compensated == Some(false)
    }

    /// Whether the material normalisation applies (an expansion coefficient was given).
    pub fn material(&self) -> bool {
        self.expansion_ppm_per_k.is_some_and(|a| a != 0.0)
    }

    /// Whether [`compensate`] changes anything.
    pub fn active(&self) -> bool {
        self.air() || self.material()
    }
}

/// One environment quantity at every sample: the run's column, or the set-up's fixed value.
fn series<'a>(
    run: &'a RunData<'_>,
    column: &str,
    fixed: Option<f64>,
    key: &str,
    range: (f64, f64),
    what: &str,
) -> Result<Source<'a>, ReadingError> {
    if let Some(col) = run.context(column) {
        if let Some(row) = col
            .iter()
            .position(|v| !(v.is_finite() && (range.0..=range.1).contains(v)))
        {
            return Err(ReadingError {
                row: Some(row),
                column: column.to_string(),
                message: format!(
                    "{what}: expected a value from {} to {}, found {}",
                    range.0, range.1, col[row]
                ),
            });
        }
        return Ok(Source::Column(col));
    }
    fixed.map(Source::Fixed).ok_or_else(|| ReadingError {
        row: None,
        column: column.to_string(),
        message: format!(
            "the set-up asks for environmental compensation but the run has no column \
             `{column}` ({what}) and the set-up no `{key}`"
        ),
    })
}

enum Source<'a> {
    Column(&'a [f64]),
    Fixed(f64),
}

impl Source<'_> {
    fn at(&self, k: usize) -> f64 {
        match self {
            Source::Column(c) => c[k],
            Source::Fixed(v) => *v,
        }
    }
}

/// The factor `κ` that turns a length the instrument reported into the length at 20 °C
/// material temperature through the actual air:
/// `κ = n_assumed / (n_air · (1 + α (T_material − 20 °C)))` (either factor 1 when its
/// correction does not apply).
pub fn length_factor(env: &Environment, n_air: Option<f64>, t_material: Option<f64>) -> f64 {
    let air = match n_air {
        Some(n) => env.assumed_index.unwrap_or(1.0) / n,
        None => 1.0,
    };
    let material = match (t_material, env.expansion_ppm_per_k) {
        (Some(t), Some(a)) => 1.0 / (1.0 + a * 1e-6 * (t - REFERENCE_C)),
        _ => 1.0,
    };
    air * material
}

/// Corrects one run's length readings (SI, one channel) in place. `travel[k]` is the
/// commanded travel along the beam at sample k (m, any origin); the datum is the first sample:
/// the instrument's length there is taken as zero, so the length it reports at sample k is
/// `L_k = (travel_k − travel_0) + d_k`, the true length `κ_k L_k`, and the prepared deviation
/// `κ_k L_k − (travel_k − travel_0) = κ_k d_k + (κ_k − 1)(travel_k − travel_0)`.
pub fn compensate(
    env: &Environment,
    run: &RunData<'_>,
    travel: &[f64],
    readings: &mut [f64],
) -> Result<(), ReadingError> {
    apply(env, run, travel, readings, false)
}

/// The inverse of [`compensate`]: from prepared deviations back to the readings the
/// instrument reports (for simulated runs and predictions): `d = (d' − (κ − 1)·c)/κ`.
pub fn uncompensate(
    env: &Environment,
    run: &RunData<'_>,
    travel: &[f64],
    readings: &mut [f64],
) -> Result<(), ReadingError> {
    apply(env, run, travel, readings, true)
}

fn apply(
    env: &Environment,
    run: &RunData<'_>,
    travel: &[f64],
    readings: &mut [f64],
    inverse: bool,
) -> Result<(), ReadingError> {
    let n = readings.len();
    if n == 0 {
        return Ok(());
    }
    let air = if env.air() {
        Some((
            series(
                run,
                COLUMN_AIR_T,
                env.air_temperature_c,
                "air_temperature_c",
                AIR_T_RANGE,
                "air temperature, °C",
            )?,
            series(
                run,
                COLUMN_AIR_P,
                env.air_pressure_hpa,
                "air_pressure_hpa",
                AIR_P_RANGE_HPA,
                "air pressure, hPa",
            )?,
            series(
                run,
                COLUMN_AIR_H,
                env.air_humidity_pct,
                "air_humidity_pct",
                AIR_H_RANGE,
                "relative humidity, %",
            )?,
        ))
    } else {
        None
    };
    let material = if env.material() {
        Some(series(
            run,
            COLUMN_MATERIAL_T,
            env.material_temperature_c,
            "material_temperature_c",
            MATERIAL_T_RANGE,
            "material temperature, °C",
        )?)
    } else {
        None
    };
    let lambda = env.wavelength_nm.unwrap_or(HENE_NM);
    let c0 = travel[0];
    for (k, d) in readings.iter_mut().enumerate() {
        let n_air = air
            .as_ref()
            .map(|(t, p, h)| edlen_index(lambda, t.at(k), p.at(k) * 100.0, h.at(k)));
        let tm = material.as_ref().map(|m| m.at(k));
        let kappa = length_factor(env, n_air, tm);
        let c = travel[k] - c0;
        *d = if inverse {
            (*d - (kappa - 1.0) * c) / kappa
        } else {
            kappa * *d + (kappa - 1.0) * c
        };
    }
    Ok(())
}
