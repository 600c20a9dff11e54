use super::*;

fn run(name: &str, t: Vec<f64>, q: Vec<f64>, context: Vec<(String, Vec<f64>)>) -> RunView {
    RunView::from_vectors(name, 0, true, &t, &q, &context)
}

fn directions(v: &SessionView, r: usize) -> Vec<i8> {
    (0..v.runs[r].len()).map(|i| v.direction(r, 0, i)).collect()
}

fn view(runs: Vec<RunView>) -> SessionView {
    SessionView::new(
        vec![AxisView {
            letter: 'X',
            rotary: false,
            stroke: (-0.5, 0.5),
        }],
        vec![],
        runs,
        vec![],
    )
}

#[test]
fn motion_follows_reversals_with_hysteresis() {
    // Up, stand, down, stand, down.
    let q = vec![0.0, 0.001, 0.002, 0.002, 0.0015, 0.0015, 0.001];
    let t: Vec<f64> = (0..q.len()).map(|i| i as f64).collect();
    let v = view(vec![run("a", t, q, vec![])]);
    let m = v.motion(0, 0);
    // Standing at the first sample: the side it came from is unknown.
    assert_eq!(directions(&v, 0), vec![0, 1, 1, 1, -1, -1, -1]);
    assert!(m.reverses && m.moves);
    // Travel restarts at the turning point (0.002).
    assert!((v.travel(0, 0, 6) - 0.001).abs() < 1e-15);
    assert!((v.travel(0, 0, 2) - 0.002).abs() < 1e-15);
    assert!((v.velocity(0, 0, 1) - 0.001).abs() < 1e-15);
}

#[test]
fn the_fitted_middle_is_where_the_fitted_samples_stand() {
    // Two balls' heights in the fitted runs; a validation run far away does not count.
    let fitted = |name: &str, q: f64| run(name, vec![0.0, 1.0], vec![q, q], vec![]);
    let mut far = fitted("validation", 0.45);
    far.fit = false;
    let v = view(vec![fitted("low", -0.40), fitted("high", -0.24), far]);
    assert!((v.fitted_middle(0) + 0.32).abs() < 1e-15);
    // No fitted sample: the middle of the stroke.
    let mut only = fitted("validation", 0.45);
    only.fit = false;
    assert_eq!(view(vec![only]).fitted_middle(0), 0.0);
}

#[test]
fn inputs_hold_across_runs_in_time_order() {
    // The second run in the file comes first in time and has no S column.
    let a = run(
        "late",
        vec![10.0, 11.0],
        vec![0.0, 0.0],
        vec![("S".into(), vec![2000.0, 3000.0])],
    );
    let b = run("early", vec![0.0, 1.0], vec![0.0, 0.0], vec![]);
    let v = view(vec![a, b]);
    assert_eq!(v.runs_in_time_order(), &[1, 0]);
    assert_eq!(v.timeline_index(0, 0), 2);
    assert_eq!(*v.input(&Input::Speed), vec![0.0, 0.0, 2.0, 3.0]);
    assert_eq!(*v.input(&Input::SpeedSquared), vec![0.0, 0.0, 4.0, 9.0]);
    let c = run(
        "t",
        vec![20.0, 21.0],
        vec![0.0, 0.0],
        vec![("T_bed".into(), vec![21.5, 22.0])],
    );
    let v = view(vec![run("x", vec![0.0, 1.0], vec![0.0, 0.0], vec![]), c]);
    // Before the column is first recorded it holds its first value (zero change), then
    // the readings go through the zero-phase smoothing.
    assert_eq!(
        *v.input(&Input::Context("T_bed".into())),
        smoothed(
            &[0.0, 0.0, 0.0, 0.5],
            |k| [0.0, 1.0, 20.0, 21.0][k],
            TEMPERATURE_SMOOTHING_S
        )
    );
    assert_eq!(v.temperature_columns(), vec!["T_bed".to_string()]);
}

#[test]
fn temperatures_are_smoothed_without_lag_and_continuously_in_time() {
    // Noise is averaged away, a slow rise is kept where it is (no lag), and moving a
    // sample's time a little changes the result a little.
    let t: Vec<f64> = (0..400).map(|k| k as f64).collect();
    let rise: Vec<f64> = t.iter().map(|&x| x / 400.0).collect();
    let noisy: Vec<f64> = rise
        .iter()
        .enumerate()
        .map(|(k, v)| v + if k % 2 == 0 { 0.02 } else { -0.02 })
        .collect();
    let s = smoothed(&noisy, |k| t[k], TEMPERATURE_SMOOTHING_S);
    for k in 50..350 {
        assert!(
            (s[k] - rise[k]).abs() < 2e-3,
            "{k}: {} vs {}",
            s[k],
            rise[k]
        );
    }
    let mut t2 = t.clone();
    t2[200] += 1e-6;
    let s2 = smoothed(&noisy, |k| t2[k], TEMPERATURE_SMOOTHING_S);
    assert!(s.iter().zip(&s2).all(|(a, b)| (a - b).abs() < 1e-7));
}

#[test]
fn a_linear_axis_arrives_from_where_the_previous_run_left_it() {
    // Run "a" ends at X = 0.01 after moving up; run "b" starts at 0.02, stands, then moves
    // down: it arrived moving up (from 0.01), so its first motion is a reversal.
    let a = run("a", vec![0.0, 1.0], vec![0.0, 0.01], vec![]);
    let b = run(
        "b",
        vec![5.0, 6.0, 7.0, 8.0, 9.0],
        vec![0.02, 0.02, 0.015, 0.01, 0.012],
        vec![],
    );
    let v = view(vec![a, b]);
    assert_eq!(directions(&v, 1), vec![1, 1, -1, -1, 1]);
    assert!(v.motion(1, 0).moves && v.motion(1, 0).reverses);
    assert_eq!(
        (0..5).map(|i| v.reversed(1, 0, i)).collect::<Vec<_>>(),
        vec![false, false, true, true, true]
    );
    // Travel and time count from the run's start, then from each turning point (sample 1,
    // 0.02; sample 3, 0.01).
    let travel: Vec<f64> = (0..5).map(|i| v.travel(1, 0, i)).collect();
    let expected = [0.0, 0.0, 0.005, 0.01, 0.002];
    assert!(
        travel
            .iter()
            .zip(expected)
            .all(|(a, b)| (a - b).abs() < 1e-15)
    );
    let since: Vec<f64> = (0..5).map(|i| v.since_turn(1, 0, i)).collect();
    assert_eq!(since, vec![0.0, 1.0, 1.0, 2.0, 1.0]);
    // Started where the last run ended: keeps its last direction.
    let a = run("a", vec![0.0, 1.0], vec![0.0, 0.01], vec![]);
    let b = run("b", vec![5.0, 6.0], vec![0.01, 0.02], vec![]);
    let v = view(vec![a, b]);
    assert_eq!(directions(&v, 1), vec![1, 1]);
    assert!(!v.motion(1, 0).reverses);
}

#[test]
fn the_first_runs_state_before_its_first_motion_is_unknown() {
    // Moving one way only: unknown (0) until the first step, which is no reversal.
    let c = run("c", vec![0.0, 1.0, 2.0], vec![0.01, 0.02, 0.03], vec![]);
    let v = view(vec![c]);
    assert_eq!(directions(&v, 0), vec![0, 1, 1]);
    assert!(!v.motion(0, 0).reverses && !v.reversed(0, 0, 2));
    // Never moving: unknown all through.
    let d = run("d", vec![0.0, 1.0, 2.0], vec![0.01; 3], vec![]);
    let v = view(vec![d]);
    assert_eq!(directions(&v, 0), vec![0, 0, 0]);
    assert!(!v.motion(0, 0).moves && !v.motion(0, 0).reverses);
    assert_eq!(v.travel(0, 0, 2), 0.0);
}

/// Direction, velocity and travel of one axis in one run as they were kept before they
/// were computed on demand (per sample, from plain vectors): the reference.
fn stored_motion(t: &[f64], q: &[f64], arrived: i8) -> (Vec<i8>, Vec<f64>, Vec<f64>) {
    let n = q.len();
    let mut raw = vec![0i8; n];
    for (i, dir) in raw.iter_mut().enumerate().skip(1) {
        let d = q[i] - q[i - 1];
        if d.abs() > STANDING {
            *dir = if d > 0.0 { 1 } else { -1 };
        }
    }
    let mut direction = vec![0i8; n];
    let mut travel = vec![0.0; n];
    // From the side it arrived from; unknown (0) until the first motion when that is not
    // known, and then the first motion is no reversal.
    let mut current = arrived;
    let mut anchor = q[0];
    for i in 0..n {
        if raw[i] != 0 && current == 0 {
            current = raw[i];
            anchor = q[i - 1];
        } else if raw[i] != 0 && raw[i] != current {
            current = raw[i];
            anchor = q[i.saturating_sub(1)];
        }
        direction[i] = current;
        travel[i] = (q[i] - anchor).abs();
    }
    let velocity = (0..n)
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = t[hi] - t[lo];
            if hi == lo || dt <= 0.0 {
                0.0
            } else {
                (q[hi] - q[lo]) / dt
            }
        })
        .collect();
    (direction, velocity, travel)
}

#[test]
fn motion_on_demand_is_the_stored_motion_bit_for_bit() {
    // A wobbling path with plateaus, steps below the standing threshold, repeated times and
    // recorded decimals; the second run starts below where the first ended (it arrives
    // moving down).
    let path = |n: usize, phase: f64| -> Vec<f64> {
        (0..n)
            .map(|i| {
                let x = i as f64 * 0.37 + phase;
                let v = 0.01 * x.sin() + 0.004 * (3.1 * x).cos();
                if i % 11 < 3 {
                    (v * 1e4).round() / 1e4
                } else {
                    v
                }
            })
            .collect()
    };
    let times = |n: usize, t0: f64| -> Vec<f64> {
        (0..n)
            .map(|i| t0 + 0.001 * (i - i % 5 / 4) as f64)
            .collect()
    };
    let (qa, qb) = (path(500, 0.0), path(300, 2.0));
    let (ta, tb) = (times(500, 0.0), times(300, 10.0));
    let v = view(vec![
        run("a", ta.clone(), qa.clone(), vec![]),
        run("b", tb.clone(), qb.clone(), vec![]),
    ]);
    let down = if qb[0] < qa[qa.len() - 1] { -1 } else { 1 };
    for (r, t, q, arrived) in [(0, &ta, &qa, 0), (1, &tb, &qb, down)] {
        let (direction, velocity, travel) = stored_motion(t, q, arrived);
        assert!(v.motion(r, 0).reverses);
        for i in 0..q.len() {
            assert_eq!(v.direction(r, 0, i), direction[i], "run {r} sample {i}");
            assert_eq!(v.velocity(r, 0, i).to_bits(), velocity[i].to_bits());
            assert_eq!(v.travel(r, 0, i).to_bits(), travel[i].to_bits());
        }
    }
}

/// Runs that overlap in time (the balls of a volumetric test, visited in turn over the
/// whole session): a temperature and its lags evolve in time, as over one run holding
/// every sample in time order — not run after run, which would start each run's lag
/// where the previous run ended, hours later.
#[test]
fn inputs_of_runs_that_overlap_in_time_follow_time() {
    let temperature = |t: f64| 20.0 + 5.0 * (1.0 - (-t / 3000.0).exp()) + 0.3 * (t / 700.0).sin();
    let times: Vec<f64> = (0..300).map(|k| 37.0 * k as f64).collect();
    let column = |ts: &[f64]| {
        vec![(
            "T_x".to_string(),
            ts.iter().map(|&t| temperature(t)).collect(),
        )]
    };
    // Three runs taking every third sample in turn.
    let parts: Vec<Vec<f64>> = (0..3)
        .map(|j| times.iter().copied().skip(j).step_by(3).collect())
        .collect();
    let runs = parts
        .iter()
        .enumerate()
        .map(|(j, ts)| {
            run(
                &format!("ball{j}"),
                ts.clone(),
                vec![0.0; ts.len()],
                column(ts),
            )
        })
        .collect();
    let overlapping = view(runs);
    let whole = view(vec![run(
        "all",
        times.clone(),
        vec![0.0; times.len()],
        column(&times),
    )]);
    let input = Input::Context("T_x".into());
    assert_eq!(overlapping.median_interval(), whole.median_interval());
    let (u, w) = (overlapping.input(&input), whole.input(&input));
    let (lu, lw) = (overlapping.lag(&input, 900.0), whole.lag(&input, 900.0));
    for (j, ts) in parts.iter().enumerate() {
        for i in 0..ts.len() {
            let k = overlapping.timeline_index(j, i);
            let m = 3 * i + j;
            assert!(
                (u[k] - w[m]).abs() < 1e-12,
                "ball{j} {i}: {} vs {}",
                u[k],
                w[m]
            );
            assert!((lu.y[k] - lw.y[m]).abs() < 1e-12, "lag ball{j} {i}");
            assert!(
                (lu.dy_dtau[k] - lw.dy_dtau[m]).abs() < 1e-15,
                "dlag ball{j} {i}"
            );
        }
    }
}

#[test]
fn the_timeline_reads_the_runs_in_time_order() {
    let a = run("late", vec![10.0, 10.5, 11.0], vec![0.0; 3], vec![]);
    let empty = run("empty", vec![], vec![], vec![]);
    let b = run("early", vec![0.0, 1.0], vec![0.0; 2], vec![]);
    let v = view(vec![a, empty, b]);
    let expected = [0.0, 1.0, 10.0, 10.5, 11.0];
    let timeline = v.timeline();
    assert_eq!(timeline.iter().collect::<Vec<_>>(), expected);
    assert_eq!(timeline.len(), 5);
    for (k, &t) in expected.iter().enumerate() {
        assert_eq!(timeline.get(k), t);
    }
    assert_eq!((v.t0(), v.duration()), (0.0, 11.0));
    // Intervals 1, 9, 0.5, 0.5: the upper median.
    assert_eq!(v.median_interval(), 1.0);
}

#[test]
fn the_median_without_a_copy_is_the_sorted_one() {
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    for n in [1usize, 2, 3, 10, 1001] {
        let values: Vec<f64> = (0..n)
            .map(|_| match next() % 5 {
                0 => 0.001,
                1 => -0.5,
                2 => 0.0,
                _ => (next() % 1_000_000) as f64 * 1e-7 + 1e-9,
            })
            .collect();
        let mut positive: Vec<f64> = values.iter().copied().filter(|v| *v > 0.0).collect();
        positive.sort_by(f64::total_cmp);
        let expected = positive.get(positive.len() / 2).copied();
        assert_eq!(
            median_of_positive(|| values.iter().copied()),
            expected,
            "{n}"
        );
    }
    assert_eq!(median_of_positive(|| [f64::NAN, -1.0].into_iter()), None);
}
