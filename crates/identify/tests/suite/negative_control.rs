//! Negative control of the physics search: fifty clean sessions (the truth is inside the fitted
//! model; only the noise differs) searched with every effect family. The search may claim an
//! effect in at most 5 % of them — two of fifty.

use crate::common;

use common::planted::{Variant, searched};
use mtcal_testkit::sessions::parallel;

#[test]
fn fifty_clean_sessions_rarely_raise_a_claim() {
    let seeds: Vec<u64> = (1000..1050).collect();
    let claims: Vec<(u64, Vec<String>)> = parallel(&seeds, |&seed| {
        let result = searched("", seed, Variant::default());
        let found: Vec<String> = result
            .findings
            .discoveries
            .iter()
            .map(|d| d.label.clone())
            .collect();
        (seed, found)
    })
    .into_iter()
    .filter(|(_, found)| !found.is_empty())
    .collect();
    eprintln!(
        "{} of 50 clean sessions claimed an effect: {claims:?}",
        claims.len()
    );
    assert!(claims.len() <= 2, "{} of 50: {claims:?}", claims.len());
}
