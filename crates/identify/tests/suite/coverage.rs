//! Honest uncertainties: over 200 random truths (fixed seeds) with 0.5 µm R-test noise, the
//! 95 % intervals contain the truth 93–97 % of the time for each parameter class, and the
//! typical errors stay within ~1 µm (location offsets) and ~5 µrad (orientations, squareness).

use crate::common;

use mtcal_identify::identify_session;
use mtcal_simulate::simulate;
use rand::SeedableRng;
use rand_distr::Normal;

const OFFSETS: [&str; 4] = ["EY0A", "EZ0A", "EX0C", "EY0C"];
const ANGLES: [&str; 7] = ["EC0Y", "EB0Z", "EA0Z", "EB0A", "EC0A", "EA0C", "EB0C"];
const TRIALS: u64 = 200;

#[test]
fn intervals_cover_the_truth_95_percent_of_the_time() {
    let all: Vec<&str> = OFFSETS.iter().chain(&ANGLES).copied().collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let dist = Normal::new(0.0, 15.0).unwrap();
    let (mut hits_off, mut n_off, mut ss_off) = (0, 0, 0.0);
    let (mut hits_ang, mut n_ang, mut ss_ang) = (0, 0, 0.0);
    let runs = mtcal_testkit::plans::rtest_low_high(25, 21, None);
    for trial in 0..TRIALS {
        let dir = tempfile::tempdir().unwrap();
        let (truth, plan) =
            common::coverage::random_truth_plan(dir.path(), &all, &mut rng, &dist, trial, &runs);
        simulate(&plan, &dir.path().join("s")).unwrap();
        let (_, id) = identify_session(&dir.path().join("s")).unwrap();
        assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
        for (name, t) in &truth {
            let p = id.parameters.iter().find(|p| &p.name == name).unwrap();
            let err = p.value - t;
            let hit = err.abs() <= p.u95;
            if OFFSETS.contains(name) {
                n_off += 1;
                hits_off += hit as usize;
                ss_off += err * err;
            } else {
                n_ang += 1;
                hits_ang += hit as usize;
                ss_ang += err * err;
            }
        }
    }
    let (c_off, c_ang) = (
        hits_off as f64 / n_off as f64,
        hits_ang as f64 / n_ang as f64,
    );
    let (rms_off, rms_ang) = (
        (ss_off / n_off as f64).sqrt(),
        (ss_ang / n_ang as f64).sqrt(),
    );
    eprintln!(
        "coverage: offsets {c_off:.3} (rms error {rms_off:.3} um), angles {c_ang:.3} (rms error {rms_ang:.3} urad)"
    );
    assert!((0.93..=0.97).contains(&c_off), "offset coverage {c_off}");
    assert!((0.93..=0.97).contains(&c_ang), "angle coverage {c_ang}");
    assert!(rms_off <= 1.0, "typical offset error {rms_off} um");
    assert!(rms_ang <= 5.0, "typical angle error {rms_ang} urad");
}
