//! What `--axis` does to each registered format agrees with what its help says: a file of the
//! whole machine (help: "no --axis") refuses an axis by name instead of ignoring it, and every
//! format writes without one or says why not.

use mtcal_compensate::{Request, control_formats};

/// Whether `about` says the format takes no `--axis`.
fn says_no_axis(about: &str) -> bool {
    about.contains("no --axis")
}

#[test]
fn a_whole_machine_format_refuses_an_axis_by_name_and_one_that_takes_an_axis_says_so() {
    let formats = control_formats();
    assert!(formats.len() >= 11, "{} formats registered", formats.len());
    let mut whole_machine = Vec::new();
    for format in formats {
        let name = format.name();
        let refused: Vec<String> = ['X', 'Y', 'Z', 'A', 'C']
            .into_iter()
            .filter_map(|axis| Request::of(format, Some(axis)).err())
            .map(|e| e.to_string())
            .collect();
        if says_no_axis(format.about()) {
            whole_machine.push(name);
            assert_eq!(
                refused.len(),
                5,
                "{name} takes an --axis its help says it does not"
            );
            for (e, axis) in refused.iter().zip(['X', 'Y', 'Z', 'A', 'C']) {
                assert!(
                    e.contains(&format!("--format {name}"))
                        && e.contains(&format!("drop --axis {axis}")),
                    "{name}: {e}"
                );
            }
            Request::of(format, None).unwrap_or_else(|e| panic!("{name} without --axis: {e}"));
        } else {
            // A format whose help does not say "no --axis" takes one for some axis.
            assert!(refused.len() < 5, "{name} refuses every axis: {refused:?}");
        }
    }
    // The whole-machine files of the built-in formats (each silently ignored --axis once).
    for name in [
        "heidenhain-com",
        "heidenhain-kinematicscomp",
        "siemens-carr",
        "linuxcnc-trt",
        "isg",
        "etalon",
    ] {
        assert!(whole_machine.contains(&name), "{name}: {whole_machine:?}");
    }
}
