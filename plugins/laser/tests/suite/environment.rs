//! Environmental compensation: the revised Edlén equation against published values, and a
//! round trip from hand-made raw readings (a known true displacement seen through known air
//! and material temperature) back to the true deviation.

use mtcal_instrument::{RunData, SetupContext, SetupFormat};
use mtcal_kinematics::Machine;
use mtcal_laser::{edlen_index, edlen_index_f, load, saturation_vapour_pressure};

#[test]
fn edlen_matches_the_published_reference_value() {
    // NIST Engineering Metrology Toolbox ("Refractive index of air calculator", J. A. Stone,
    // J. H. Zimmerman): λ_vac = 633 nm, 20 °C, 101.325 kPa, 50 % RH, 450 ppm CO₂:
    // n = 1.000271373 (Ciddor); the modified Edlén equation agrees to 1e-9 there.
    let n = edlen_index(633.0, 20.0, 101_325.0, 50.0);
    assert!(
        ((n - 1.0) - 2.71373e-4).abs() < 2e-9,
        "n − 1 = {:e}",
        n - 1.0
    );
    // Birch & Downs built it so that dry standard air (15 °C, 101 325 Pa) gives the dispersion
    // formula itself: the density factor is 1 there to 1e-5 relative.
    let s2 = (1.0f64 / 0.633).powi(2);
    let ns = (8342.54 + 2_406_147.0 / (130.0 - s2) + 15998.0 / (38.9 - s2)) * 1e-8;
    let n15 = edlen_index_f(633.0, 15.0, 101_325.0, 0.0) - 1.0;
    assert!((n15 / ns - 1.0).abs() < 1e-5, "{n15:e} vs {ns:e}");
    // Humidity lowers the index (water vapour is less refractive than the air it displaces).
    assert!(edlen_index(633.0, 20.0, 101_325.0, 80.0) < n);
    // Saturation vapour pressure at 20 °C: 2.3392 kPa (IAPWS-IF97 steam tables).
    let p = saturation_vapour_pressure(20.0);
    assert!((p - 2339.2).abs() < 0.1, "{p}");
}

fn machine() -> Machine {
    mtcal_machine::load_machine("ZFYX", mtcal_machine::topology::Reading::default())
        .unwrap()
        .machine
}

/// A run along X: commanded x (m), with its true deviation (m) at 20 °C.
fn commanded() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let x: Vec<f64> = (0..6).map(|k| -0.2 + 0.08 * k as f64).collect();
    let q: Vec<f64> = x.iter().flat_map(|&x| [x, 0.05, -0.1]).collect();
    let d_true: Vec<f64> = x.iter().map(|&x| 3e-6 * (7.0 * x).sin() + 1e-6).collect();
    (x, q, d_true)
}

#[test]
fn uncompensated_readings_are_corrected_back_to_the_true_deviation() {
    let m = machine();
    let (x, q, d_true) = commanded();
    let n = x.len();
    let air_t: Vec<f64> = (0..n).map(|k| 21.0 + 0.3 * k as f64).collect();
    let air_p: Vec<f64> = (0..n).map(|k| 960.0 + 2.0 * k as f64).collect();
    let air_h: Vec<f64> = (0..n).map(|k| 40.0 + 3.0 * k as f64).collect();
    let mat_t: Vec<f64> = (0..n).map(|k| 22.5 - 0.2 * k as f64).collect();
    let alpha = 11.5e-6;
    let assumed = 1.000_27;
    // The physics, by hand: the machine's true displacement from the datum (sample 0) at
    // 20 °C is L20 = c + d_true (− the datum's own d_true, a constant the zero offset takes);
    // at T_material it is L20 (1 + α ΔT); the laser counts fringes of λ_vac / n_air and
    // reports lengths in units of λ_vac / n_assumed: L_reported = L n_air / n_assumed.
    let mut raw: Vec<f64> = (0..n)
        .map(|k| {
            let c = x[k] - x[0];
            let l20 = c + (d_true[k] - d_true[0]);
            let l = l20 * (1.0 + alpha * (mat_t[k] - 20.0));
            let n_air = edlen_index(632.991, air_t[k], air_p[k] * 100.0, air_h[k]);
            l * n_air / assumed - c
        })
        .collect();
    // Raw readings are off by tens of µm (refractive index ~2.6e-4 against 2.7e-4 assumed,
    // the material 2.5 K warm over 400 mm).
    assert!(raw.iter().map(|r| r.abs()).fold(0.0, f64::max) > 5e-6);
    let table: toml::Table = toml::from_str(&format!(
        "mode = \"linear\"\ndirection = \"X\"\nwavelength_compensated = false\n\
         assumed_index = {assumed}\nexpansion_ppm_per_k = 11.5"
    ))
    .unwrap();
    let s = load(&table, &SetupContext { machine: &m }).unwrap();
    let context = vec![
        ("T_air".to_string(), air_t),
        ("P_air".to_string(), air_p),
        ("H_air".to_string(), air_h),
        ("T_material".to_string(), mat_t),
        ("S".to_string(), vec![0.0; n]),
    ];
    let t: Vec<f64> = (0..n).map(|k| k as f64).collect();
    let recorded = raw.clone();
    let data = RunData {
        q: &q,
        t: &t,
        context: &context,
    };
    s.prepare_readings(&data, &mut raw).unwrap();
    for k in 0..n {
        let want = d_true[k] - d_true[0];
        assert!(
            (raw[k] - want).abs() < 1e-12,
            "sample {k}: {} vs {want}",
            raw[k]
        );
    }
    // And back: what simulate and --predict write is what the instrument would have reported.
    s.record_readings(&data, &mut raw).unwrap();
    for k in 0..n {
        assert!(
            (raw[k] - recorded[k]).abs() < 1e-15,
            "sample {k}: recorded {} vs {}",
            raw[k],
            recorded[k]
        );
    }
}

#[test]
fn fixed_values_stand_in_for_missing_columns_and_errors_name_column_and_row() {
    let m = machine();
    let (x, q, _) = commanded();
    let n = x.len();
    let t: Vec<f64> = (0..n).map(|k| k as f64).collect();
    // Material only, at a fixed 25 °C: a perfect axis reads α ΔT · travel; prepared, 0.
    let table: toml::Table = toml::from_str(
        "mode = \"linear\"\ndirection = \"X\"\nexpansion_ppm_per_k = 11.5\nmaterial_temperature_c = 25.0",
    )
    .unwrap();
    let s = load(&table, &SetupContext { machine: &m }).unwrap();
    let mut d: Vec<f64> = x.iter().map(|&xk| (xk - x[0]) * 11.5e-6 * 5.0).collect();
    assert!((d[n - 1] - 0.4 * 57.5e-6).abs() < 1e-12);
    s.prepare_readings(
        &RunData {
            q: &q,
            t: &t,
            context: &[],
        },
        &mut d,
    )
    .unwrap();
    assert!(d.iter().all(|v| v.abs() < 1e-12), "{d:?}");
    // Uncompensated readings without an air temperature anywhere.
    let table: toml::Table = toml::from_str(
        "mode = \"linear\"\ndirection = \"X\"\nwavelength_compensated = false\n\
         air_pressure_hpa = 1013.25\nair_humidity_pct = 50.0",
    )
    .unwrap();
    let s = load(&table, &SetupContext { machine: &m }).unwrap();
    let mut d = vec![0.0; n];
    let e = s
        .prepare_readings(
            &RunData {
                q: &q,
                t: &t,
                context: &[],
            },
            &mut d,
        )
        .unwrap_err();
    assert_eq!((e.column.as_str(), e.row), ("T_air", None), "{e}");
    // A pressure in Pa where hPa is expected, at row 2.
    let mut p = vec![1013.0; n];
    p[2] = 101_300.0;
    let context = vec![
        ("T_air".to_string(), vec![20.0; n]),
        ("P_air".to_string(), p),
    ];
    let e = s
        .prepare_readings(
            &RunData {
                q: &q,
                t: &t,
                context: &context,
            },
            &mut d,
        )
        .unwrap_err();
    assert_eq!((e.column.as_str(), e.row), ("P_air", Some(2)), "{e}");
    assert!(e.message.contains("hPa"), "{e}");
    // Compensated readings (the default) are left alone.
    let table: toml::Table = toml::from_str("mode = \"linear\"\ndirection = \"X\"").unwrap();
    let s = load(&table, &SetupContext { machine: &m }).unwrap();
    let mut d = vec![1e-6; n];
    s.prepare_readings(
        &RunData {
            q: &q,
            t: &t,
            context: &[],
        },
        &mut d,
    )
    .unwrap();
    assert!(d.iter().all(|&v| v == 1e-6));
}
