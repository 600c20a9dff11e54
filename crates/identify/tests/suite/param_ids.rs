//! A study's typed parameter ids ([`mtcal_identify::ids::ParamId`]) name the same parameter in
//! every study rebuilt from one session: with effects added, components given more orders,
//! parameters estimated and set-up parameters held, two parameters of two studies have the
//! same id exactly when they are the same parameter — checked against the names the report
//! prints, which say so for people — and no two parameters of a study share one.

use mtcal_effects::Candidate;
use mtcal_identify::Study;
use mtcal_identify::ids::ParamId;
use mtcal_identify::search::candidates;
use std::collections::{HashMap, HashSet};
use std::path::Path;

fn example() -> Study {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/three-axis/session");
    Study::load(&dir).unwrap()
}

/// Every parameter of `study`: id → name, each id once.
fn ids_and_names(study: &Study) -> HashMap<ParamId, String> {
    let n = study.layout().n_x();
    let map: HashMap<ParamId, String> = (0..n)
        .map(|i| (study.param_id(i), study.param_info(i).name))
        .collect();
    assert_eq!(map.len(), n, "two parameters of one study share an id");
    let names: HashSet<&String> = map.values().collect();
    assert_eq!(names.len(), n, "two parameters of one study share a name");
    for (id, &i) in &study.param_indices() {
        assert_eq!(&study.param_id(i), id);
    }
    map
}

#[test]
fn a_parameter_keeps_its_id_in_every_rebuilt_study_and_only_it_has_it() {
    let study = example();
    let mut changes = study.changes().clone();
    // Effects of several families, a model change of each kind, a set-up parameter held.
    let mut classes = HashSet::new();
    let mut orders = 0;
    for c in candidates(&study, None) {
        match c {
            Candidate::Effect(e) if classes.insert(e.info().class) => changes.effects.push(e),
            Candidate::Model(m) if m.extra_order == 0 && changes.estimate.len() < 2 => {
                changes.estimate.push(m.param)
            }
            Candidate::Model(m) if m.extra_order > 0 && orders < 2 => {
                orders += 1;
                changes.raise.push((m.param, m.extra_order))
            }
            _ => {}
        }
    }
    assert!(
        changes.effects.len() >= 3,
        "{} effects",
        changes.effects.len()
    );
    assert_eq!(orders, 2);
    let first = study.rebuild(changes.clone()).unwrap();
    // The second study: the first effect and the first raised order gone (every later
    // parameter moves in the vector), a set-up parameter held.
    changes.effects.remove(0);
    changes.raise.remove(0);
    let nuisance = (0..study.layout().n_x())
        .find(|&i| matches!(study.param_id(i), ParamId::Nuisance { .. }))
        .expect("a set-up parameter");
    changes.hold.push(study.param_id(nuisance));
    let second = study.rebuild(changes).unwrap();

    let mut moved = 0;
    for (a, b) in [(&study, &first), (&first, &second), (&second, &study)] {
        let (before, after) = (ids_and_names(a), ids_and_names(b));
        let by_name: HashMap<&String, &ParamId> = after.iter().map(|(id, n)| (n, id)).collect();
        for (id, name) in &before {
            // The same parameter (by the name people read) has the same id, and no other.
            assert_eq!(after.get(id), by_name.get(name).map(|_| name), "{name}");
            if let Some(other) = by_name.get(name) {
                assert_eq!(*other, id, "{name}");
                moved += usize::from(a.param_indices()[id] != b.param_indices()[id]);
            }
        }
    }
    assert!(moved > 10, "only {moved} parameters changed places");
    // The held set-up parameter left the vector.
    assert!(!ids_and_names(&second).contains_key(&study.param_id(nuisance)));
}
