//! What the history says, through the store: a location error warming up over one day of
//! quick checks gives back its planted time constant and temperature sensitivity
//! ([`thermal_view`]); a drifting one over a year gives its drift rate, and the fleet names it
//! once it is beyond its tolerance ([`trend_view`], [`fleet_view`]). The statistics themselves
//! are proven in crates/trend (coverage over many seeds, and through the simulator and the
//! identification in `simulated_campaigns.rs`); here, that the views pick the right points.

use crate::common;

use common::{Kind, TestDb, sample};
use mtcal_history::{
    Limits, Parameter, Timestamp, fleet_drift_rates, fleet_view, latest_parameters, machine_trends,
    thermal_view, trend_view,
};

/// Deterministic noise in [−1, 1] (a fixed sequence: the test must not depend on a seed).
fn noise(k: usize) -> f64 {
    ((k as f64 * 12.9898).sin() * 43_758.545).fract() * 2.0 - 1.0
}

/// `sample`'s campaign of `machine` at `date` with EX0C = `value` ± `u95` µm and temperature.
fn campaign(
    machine: &str,
    date: Timestamp,
    value: f64,
    u95: f64,
    temperature_c: f64,
) -> mtcal_history::Campaign {
    let mut c = sample(machine, "2026-01-01", 0.0);
    c.date = date;
    c.parameters[0] = Parameter::identified("EX0C", value, u95, "um");
    c.temperature_c = Some(temperature_c);
    c
}

#[test]
fn a_warm_up_day_gives_its_time_constant_and_a_year_its_drift() {
    let Some(db) = TestDb::new(Kind::Sqlite) else {
        return;
    };
    let mut store = db.store();
    // Twelve checks over five hours: EX0C warms from 18 to 30 µm with τ = 60 min, the
    // temperature from 20 to 25 °C with the same τ (2.4 µm/K), noise 0.3 µm (u95 0.6).
    let start = mtcal_history::parse_date("2026-03-02T06:00:00Z").unwrap();
    let warm = |t_min: f64| 1.0 - (-t_min / 60.0).exp();
    for k in 0..12 {
        let t_min = 25.0 * k as f64 + 3.0 * noise(100 + k);
        let date = Timestamp::from_second(start.as_second() + (t_min * 60.0) as i64).unwrap();
        let value = 18.0 + 12.0 * warm(t_min) + 0.3 * noise(k);
        let c = campaign("mill-3", date, value, 0.6, 20.0 + 5.0 * warm(t_min));
        store.add(&c).unwrap();
    }
    // A check of the day before does not belong to the day.
    let before = mtcal_history::parse_date("2026-03-01T15:00:00Z").unwrap();
    store
        .add(&campaign("mill-3", before, 55.0, 0.6, 30.0))
        .unwrap();

    let view = thermal_view(&store, "mill-3", "EX0C", Some("2026-03-02")).unwrap();
    assert_eq!(view.checks, 12);
    let t = view.trajectory.expect("determined");
    assert!(
        t.tau_low_min <= 60.0 && 60.0 <= t.tau_high_min,
        "τ {} ({}…{})",
        t.tau_min,
        t.tau_low_min,
        t.tau_high_min
    );
    // The change still to come at the first check, which the jitter may have moved off 06:00.
    let t0_min = (t.start_time_s - start.as_second() as f64) / 60.0;
    let amplitude = -12.0 * (-t0_min / 60.0).exp();
    assert!(
        (t.amplitude - amplitude).abs() <= t.amplitude_u95,
        "{amplitude} {t:?}"
    );
    let s = view.sensitivity.expect("temperatures recorded");
    assert!((s.per_kelvin - 2.4).abs() <= s.u95_per_kelvin, "{s:?}");
    let said = view.to_string();
    assert!(
        said.starts_with("EX0C of mill-3 on 2026-03-02: 12 checks; time constant"),
        "{said}"
    );

    // A year of monthly campaigns on another machine: +0.02 µm/day, noise 0.2 µm.
    let jan = mtcal_history::parse_date("2026-01-05").unwrap();
    for k in 0..12 {
        let days = 30.0 * k as f64 + 4.0 * noise(200 + k);
        let date = Timestamp::from_second(jan.as_second() + (days * 86_400.0) as i64).unwrap();
        let value = 5.0 + 0.02 * days + 0.2 * noise(300 + k);
        store
            .add(&campaign("mill-7", date, value, 0.5, 20.0))
            .unwrap();
    }
    let limits = Limits {
        limits: [("EX0C".to_string(), 10.0)].into(),
        guard_band: true,
    };
    let view = trend_view(&store, "mill-7", "EX0C", &limits, 365.0).unwrap();
    let trend = view.trend.expect("analysed");
    let d = &trend.drift;
    assert!((d.rate_per_day - 0.02).abs() <= d.rate_u95_per_day, "{d:?}");
    assert!(d.significant);
    assert_eq!(trend.verdict, mtcal_trend::Verdict::Drift);
    // 5 + 0.02 × 330 ≈ 11.6 µm > 10 + U: beyond the tolerance, proven.
    assert!(trend.tolerance.unwrap().first_out.is_some());
    let fleet = fleet_view(&store, &limits).unwrap();
    let names: Vec<(&str, &[String])> = fleet
        .iter()
        .map(|l| (l.machine.as_str(), l.out_of_tolerance.as_slice()))
        .collect();
    // mill-3's latest check (30 µm) is beyond 10 µm too; mill-7's latest ≈ 11.6 µm.
    assert_eq!(
        names,
        [
            ("mill-3", &["EX0C".to_string()][..]),
            ("mill-7", &["EX0C".to_string()][..])
        ]
    );

    // What the history pages show: a machine's parameters with a value (EZ0A never had one),
    // and per machine the drift rate of each parameter the tolerances name.
    let latest = latest_parameters(&store, "mill-7").unwrap();
    assert_eq!(latest, ["EX0C", "laser-x.tilt_1", "EC0Y", "EZ0A"]);
    let trends = machine_trends(&store, "mill-7", &[], &limits, 365.0).unwrap();
    let plotted: Vec<&str> = trends.iter().map(|t| t.parameter.as_str()).collect();
    assert_eq!(plotted, ["EX0C", "laser-x.tilt_1", "EC0Y"]);
    let e = latest_parameters(&store, "mill-9").unwrap_err().to_string();
    assert!(e.contains("no machine named \"mill-9\""), "{e}");
    let rates = fleet_drift_rates(&store, &fleet, &[], &limits, 365.0).unwrap();
    assert_eq!(rates.len(), 2);
    let (machine, mill7) = &rates[1];
    assert_eq!(machine, "mill-7");
    assert_eq!(mill7.len(), 1);
    assert_eq!(mill7[0].0, "EX0C");
    let want = format!(
        "{:+.4} ± {:.4} um/day (significant)",
        d.rate_per_day, d.rate_u95_per_day
    );
    assert_eq!(mill7[0].1, want);
    // A parameter a machine's model does not have is left out, not an error.
    let other = fleet_drift_rates(&store, &fleet, &["EQ0Q".into()], &limits, 365.0).unwrap();
    assert!(other.iter().all(|(_, r)| r.is_empty()), "{other:?}");
}

/// A campaign whose fit is not a calibration (identify's verdict: it did not converge, or the
/// model does not explain the recordings) is listed with its number but never counted: not in
/// the drift, not in the same-day thermal fit, not the "latest" value.
#[test]
fn a_fit_that_is_not_a_calibration_is_shown_and_not_counted() {
    let Some(db) = TestDb::new(Kind::Sqlite) else {
        return;
    };
    let mut store = db.store();
    let jan = mtcal_history::parse_date("2026-01-05").unwrap();
    let date = |days: i64| Timestamp::from_second(jan.as_second() + days * 86_400).unwrap();
    // Steady at 5 µm, ± 0.3: monthly campaigns, and on day 100 and at the end a fit that did
    // not converge, its last iterate 40 µm off.
    for k in 0..8 {
        let c = campaign(
            "mill-5",
            date(30 * k),
            5.0 + 0.1 * noise(k as usize),
            0.5,
            20.0,
        );
        store.add(&c).unwrap();
    }
    for days in [100, 240] {
        let mut c = campaign("mill-5", date(days), 45.0, 0.5, 20.0);
        c.fit.converged = false;
        c.fit.verdict = Some("NOT CONVERGED (MaxIterations) after 100 iterations".into());
        store.add(&c).unwrap();
    }
    let view = trend_view(&store, "mill-5", "EX0C", &Limits::default(), 365.0).unwrap();
    assert_eq!(view.points.len(), 10);
    assert_eq!(view.points.iter().filter(|p| p.counts()).count(), 8);
    let trend = view.trend.as_ref().expect("analysed");
    assert_eq!(trend.drift.n, 8);
    assert_eq!(trend.verdict, mtcal_trend::Verdict::NoChange, "{view}");
    let said = view.to_string();
    assert!(
        said.contains("2 campaign(s) not counted: their fit is not a calibration"),
        "{said}"
    );
    assert_eq!(
        said.matches("(not counted: the fit is not a calibration)")
            .count(),
        2,
        "{said}"
    );
    // The latest value is the last calibration's, not the unconverged one of day 240.
    let line = view.one_line();
    assert!(!line.contains("45.000"), "{line}");
    let last = 5.0 + 0.1 * noise(7);
    assert!(
        line.contains(&format!("latest {last:.3} ± 0.500")),
        "{line}"
    );
}
