//! Negative control of the physics search: fifty clean sessions (the truth is inside the fitted
//! model; only the noise differs) searched with every effect family. The search may claim an
//! effect in at most 5 % of them — two of fifty.

mod common;

use common::planted::{Variant, searched};

#[test]
fn fifty_clean_sessions_rarely_raise_a_claim() {
    let seeds: Vec<u64> = (1000..1050).collect();
    let claims = std::sync::Mutex::new(Vec::new());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(4);
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(&seed) = seeds.get(k) else { return };
                    let result = searched("", seed, Variant::default());
                    let found: Vec<String> = result
                        .identification
                        .discoveries
                        .iter()
                        .map(|d| d.label.clone())
                        .collect();
                    if !found.is_empty() {
                        claims.lock().unwrap().push((seed, found));
                    }
                }
            });
        }
    });
    let claims = claims.into_inner().unwrap();
    eprintln!(
        "{} of 50 clean sessions claimed an effect: {claims:?}",
        claims.len()
    );
    assert!(claims.len() <= 2, "{} of 50: {claims:?}", claims.len());
}
