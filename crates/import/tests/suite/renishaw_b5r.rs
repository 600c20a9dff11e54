//! `renishaw-b5r` imports: synthetic ball-bar files written here from the element names the
//! public readers of `.b5r` agree on (no third-party file is copied) — a known circle with a
//! planted radial deviation, both directions, two planes — become ballbar runs whose positions
//! and readings are the planted ones, in a session that loads and that `identify` fits; and
//! broken files are refused with their exact located message, nothing written.

use crate::common;

use std::path::{Path, PathBuf};

use common::three_axis_machine;
use mtcal_import::{B5rImported, B5rOptions, ImportError, ReadingUnit, import_b5r};

const RADIUS_MM: f64 = 100.0;
const FEED: f64 = 1000.0;
const N: usize = 360;
/// The planted squareness-like pattern's amplitude, µm.
const AMPLITUDE_UM: f64 = 4.0;

/// A run as the test plants it.
struct Planted {
    /// `("XY", 'X', 'Y')`: the file's TEST_PLANE and its A and B axes.
    plane: (&'static str, char, char),
    ccw: bool,
    readings_um: Vec<f64>,
}

/// The radial deviation planted at angle `phi` (rad, from +A towards +B): what a squareness
/// error shows on a circle (`sin 2φ`), the same at an angle whichever way the circle runs.
fn planted_dr_um(phi: f64) -> f64 {
    AMPLITUDE_UM * (2.0 * phi).sin()
}

/// The angles (rad) of the `N` readings, 1° apart from 0°, negative for clockwise.
fn angles(ccw: bool) -> Vec<f64> {
    let sign = if ccw { 1.0 } else { -1.0 };
    (0..N)
        .map(|k| (sign * k as f64 * 360.0 / N as f64).to_radians())
        .collect()
}

fn planted(plane: (&'static str, char, char), ccw: bool) -> Planted {
    Planted {
        plane,
        ccw,
        readings_um: angles(ccw).into_iter().map(planted_dr_um).collect(),
    }
}

/// A `.b5r` document with the header, the runs, and the diagnostics analysis; `readings`
/// replaces the text of every `<READINGS>` when given.
fn b5r_xml(runs: &[&Planted], readings_attr: &str, readings_text: Option<&str>) -> String {
    let (plane, a, b) = runs[0].plane;
    let mut body = String::new();
    for r in runs {
        let text = match readings_text {
            Some(t) => t.to_string(),
            None => r
                .readings_um
                .iter()
                .map(|v| format!("{v}"))
                .collect::<Vec<_>>()
                .join(" "),
        };
        body.push_str(&format!(
            "    <BALLBAR_RUN>\n      <RUN_DIRECTION>{}</RUN_DIRECTION>\n      \
             <READINGS{readings_attr}>{text}</READINGS>\n      \
             <FEATURE NAME=\"AF_CIRCULARITY\" DT=\"UT_LENGTH_MM\">0.0081</FEATURE>\n    \
             </BALLBAR_RUN>\n",
            if r.ccw { "CCW" } else { "CW" }
        ));
    }
    format!(
        "<?xml version=\"1.0\" encoding=\"utf-8\" standalone=\"yes\"?>\n\
         <TEST_DOCUMENT>\n\
         \x20 <TEST_SPEC NAME=\"100mm {plane} 1000\" version=\"2.0\">\n\
         \x20   <INSTRUMENT MANUFACTURER=\"Renishaw\" MODEL=\"QC20-W\">\n\
         \x20     <DYNAMIC_BALLBAR>\n\
         \x20       <NOMINAL_LENGTH>{RADIUS_MM}</NOMINAL_LENGTH>\n\
         \x20       <PROGRAMMED_FEEDRATE>{FEED}</PROGRAMMED_FEEDRATE>\n\
         \x20       <PLANE VIEW=\"+A+B\" TEST_PLANE=\"{plane}\">\n\
         \x20         <A_AXIS_NAME>{a}</A_AXIS_NAME>\n\
         \x20         <B_AXIS_NAME>{b}</B_AXIS_NAME>\n\
         \x20       </PLANE>\n\
         \x20     </DYNAMIC_BALLBAR>\n\
         \x20   </INSTRUMENT>\n\
         \x20 </TEST_SPEC>\n\
         \x20 <DATE_STARTED>20260401-080000</DATE_STARTED>\n\
         \x20 <MACHINE_TESTED NAME=\"VMC-7\" />\n\
         \x20 <RUN_RESULTS>\n{body}  </RUN_RESULTS>\n\
         \x20 <ANALYSIS NAME=\"RENISHAW_DIAGNOSTICS\" version=\"2.1\">\n\
         \x20   <FEATURE NAME=\"AF_SQUARENESS\" DT=\"UT_SQUARENESS\">-80.0</FEATURE>\n\
         \x20   <FEATURE NAME=\"AF_BACKLASH_A_POS\" DT=\"UT_LENGTH_UM\">0.4</FEATURE>\n\
         \x20   <FEATURE NAME=\"AF_SERVO_MISMATCH\" DT=\"UT_TIME_MS\">0.12</FEATURE>\n\
         \x20   <FEATURE NAME=\"AF_SCALE_MISMATCH\" DT=\"UT_PPM\">3.5</FEATURE>\n\
         \x20 </ANALYSIS>\n\
         </TEST_DOCUMENT>\n"
    )
}

fn options<'a>(
    files: &'a [PathBuf],
    session: &'a Path,
    machine: Option<&'a str>,
) -> B5rOptions<'a> {
    B5rOptions {
        files,
        session,
        machine,
        name: None,
        center: Some("X=0,Y=0,Z=-200"),
        radius_mm: None,
        reading_unit: None,
        start_deg: None,
        sweep_deg: None,
        overshoot_deg: None,
        step_deg: None,
        feed_mm_per_min: None,
    }
}

/// The run's `t`, axis positions (X, Y, Z, mm) and `dr` (µm) as the session's CSV holds them.
fn read_run(file: &Path) -> (Vec<f64>, Vec<[f64; 3]>, Vec<f64>) {
    let axes = ['X', 'Y', 'Z'];
    let table = mtcal_session::read_run(
        file,
        &mtcal_session::RunColumns {
            axes: &axes,
            readings: &["dr"],
            readings_optional: false,
            labels: &[],
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let q = (0..table.len())
        .map(|i| {
            let r = table.q_row(i);
            [r[0], r[1], r[2]]
        })
        .collect();
    (table.t.clone(), q, table.values.clone().unwrap())
}

/// Writes the four planted files (XY and XZ, each plane's two directions in its own file).
fn write_four(dir: &Path) -> (Vec<PathBuf>, Vec<Planted>) {
    let runs = vec![
        planted(("XY", 'X', 'Y'), true),
        planted(("XY", 'X', 'Y'), false),
        planted(("XZ", 'X', 'Z'), true),
        planted(("XZ", 'X', 'Z'), false),
    ];
    let names = ["xy-ccw.b5r", "xy-cw.b5r", "xz-ccw.b5r", "xz-cw.b5r"];
    let files: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
    for (f, r) in files.iter().zip(&runs) {
        std::fs::write(f, b5r_xml(&[r], "", None)).unwrap();
    }
    (files, runs)
}

fn import_four(tmp: &Path) -> (B5rImported, Vec<Planted>, PathBuf) {
    let (files, runs) = write_four(tmp);
    let session = tmp.join("session");
    let machine = three_axis_machine();
    let imported = import_b5r(&options(&files, &session, Some(machine.to_str().unwrap())))
        .unwrap_or_else(|e| panic!("{e}"));
    (imported, runs, session)
}

#[test]
fn four_files_become_ballbar_runs_with_the_planted_positions_and_readings() {
    let tmp = tempfile::tempdir().unwrap();
    let (imported, runs, session) = import_four(tmp.path());
    assert_eq!(imported.runs.len(), 4);
    let centre = [0.0, 0.0, -200.0];
    for (w, p) in imported.runs.iter().zip(&runs) {
        let (t, q, dr) = read_run(&w.file);
        assert_eq!(dr.len(), N, "{}", w.name);
        // The readings are the planted ones, as written (µm, no unit change: DT absent = µm).
        assert_eq!(dr, p.readings_um, "{}", w.name);
        let (ia, ib) = (axis_index(p.plane.1), axis_index(p.plane.2));
        let normal = 3 - ia - ib;
        for (k, phi) in angles(p.ccw).into_iter().enumerate() {
            let want_a = centre[ia] + RADIUS_MM * phi.cos();
            let want_b = centre[ib] + RADIUS_MM * phi.sin();
            assert!(
                (q[k][ia] - want_a).abs() < 1e-9 && (q[k][ib] - want_b).abs() < 1e-9,
                "{} reading {k}: {:?}, expected {} = {want_a}, {} = {want_b}",
                w.name,
                q[k],
                p.plane.1,
                p.plane.2
            );
            assert!((q[k][normal] - centre[normal]).abs() < 1e-9);
        }
        // t = arc length / feed: 1° of a 100 mm radius at 1000 mm/min.
        let dt = RADIUS_MM * 1f64.to_radians() / (FEED / 60.0);
        assert!((t[1] - dt).abs() < 1e-12 && (t[N - 1] - dt * (N - 1) as f64).abs() < 1e-9);
    }
    // The set-ups: one per plane, pivot at the centre's tool point, length = radius.
    let text = std::fs::read_to_string(session.join("session.toml")).unwrap();
    assert!(text.contains("[setup.b5r-xy]"), "{text}");
    assert!(text.contains("[setup.b5r-xz]"), "{text}");
    assert!(text.contains("length = 100.0"), "{text}");
    assert!(text.contains("instrument = \"ballbar\""), "{text}");
    assert!(text.contains("AF_SQUARENESS"), "{text}");
    assert_eq!(imported.setups.len(), 2);
    // The session loads, and each run's diagnostics are in its [run.b5r] table.
    let loaded = mtcal_session::load_session(&session).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(loaded.runs.len(), 4);
    let b5r = loaded.runs[0].extra["b5r"].as_table().unwrap();
    assert_eq!(b5r["direction"].as_str(), Some("ccw"));
    assert_eq!(b5r["plane"].as_str(), Some("XY"));
    assert_eq!(b5r["machine_tested"].as_str(), Some("VMC-7"));
    let sq = b5r["diagnostics"]["AF_SQUARENESS"].as_table().unwrap();
    assert_eq!(sq["value"].as_float(), Some(-80.0));
    assert_eq!(sq["unit"].as_str(), Some("UT_SQUARENESS"));
    let card = imported.card();
    for needle in [
        "plane XY (A = X, B = Y, view +A+B)",
        "360 readings (um, assumed)",
        "radius 100 mm (NOMINAL_LENGTH)",
        "feed 1000 mm/min (PROGRAMMED_FEEDRATE)",
        "AF_SCALE_MISMATCH = 3.5 UT_PPM",
        "machine tested: VMC-7; started: 20260401-080000",
        "first reading at 0° from +A towards +B",
        "--start-deg overrides",
        "--sweep-deg overrides",
        "--overshoot-deg overrides",
        "readings 1° apart",
        "--step-deg overrides",
        "circle centre at axes X=0,Y=0,Z=-200 (given: --center)",
        "--reading-unit overrides",
    ] {
        assert!(card.contains(needle), "`{needle}` not on the card:\n{card}");
    }
}

fn axis_index(letter: char) -> usize {
    match letter {
        'X' => 0,
        'Y' => 1,
        _ => 2,
    }
}

/// The planted pattern is what a squareness error shows on both directions of a circle: the
/// model explains all four runs only if the import put every reading where it was taken (a
/// direction or an angle read the wrong way round would leave the pattern unexplained).
#[test]
fn identify_explains_the_planted_pattern_of_both_directions_and_planes() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, _, session) = import_four(tmp.path());
    let (_, id) = mtcal_identify::identify_session(&session).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(id.fit.runs.len(), 4);
    for run in &id.fit.runs {
        assert!(
            run.rms_um < 0.05 * AMPLITUDE_UM,
            "run {}: rms {} µm of a {AMPLITUDE_UM} µm pattern",
            run.name,
            run.rms_um
        );
    }
}

/// Options override what the file says: the reading unit, the start, the spacing, the radius,
/// and a name prefix.
#[test]
fn options_override_the_assumptions() {
    let tmp = tempfile::tempdir().unwrap();
    let p = planted(("XY", 'X', 'Y'), true);
    // Both runs in one file; readings written in mm.
    let mut cw = planted(("XY", 'X', 'Y'), false);
    cw.readings_um.iter_mut().for_each(|v| *v *= 0.5);
    let mm: Vec<Planted> = [&p, &cw]
        .iter()
        .map(|r| Planted {
            plane: r.plane,
            ccw: r.ccw,
            readings_um: r.readings_um.iter().map(|v| v * 1e-3).collect(),
        })
        .collect();
    let file = tmp.path().join("both.b5r");
    std::fs::write(&file, b5r_xml(&[&mm[0], &mm[1]], "", None)).unwrap();
    let files = [file];
    let session = tmp.path().join("s");
    let machine = three_axis_machine();
    let mut o = options(&files, &session, Some(machine.to_str().unwrap()));
    o.reading_unit = Some(ReadingUnit::Mm);
    o.start_deg = Some(90.0);
    o.step_deg = Some(0.5);
    o.radius_mm = Some(150.0);
    o.feed_mm_per_min = Some(2000.0);
    o.name = Some("vmc");
    let imported = import_b5r(&o).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = imported.runs.iter().map(|w| w.name.as_str()).collect();
    assert_eq!(names, ["vmc-xy-ccw", "vmc-xy-cw"]);
    let (t, q, dr) = read_run(&imported.runs[1].file);
    for (d, want) in dr.iter().zip(&cw.readings_um) {
        assert!((d - want).abs() < 1e-9, "{d} vs {want}");
    }
    // Clockwise from 90°, 0.5° apart, radius 150 mm about X=0, Y=0.
    let phi = (90.0f64 - 0.5 * 10.0).to_radians();
    assert!((q[10][0] - 150.0 * phi.cos()).abs() < 1e-9);
    assert!((q[10][1] - 150.0 * phi.sin()).abs() < 1e-9);
    let dt = 150.0 * 0.5f64.to_radians() / (2000.0 / 60.0);
    assert!((t[1] - dt).abs() < 1e-12);
    let card = imported.card();
    assert!(card.contains("(mm, --reading-unit)"), "{card}");
    assert!(card.contains("radius 150 mm (--radius-mm)"), "{card}");
    assert!(card.contains("given: --start-deg"), "{card}");
}

// ---------------------------------------------------------------------------------------------
// Bad inputs: the exact located message, nothing written.

/// `file:line:column` of the first `needle` in `text` (1-based, characters).
fn location_of(file: &Path, text: &str, needle: &str) -> String {
    let at = text
        .find(needle)
        .unwrap_or_else(|| panic!("{needle} not in the file"));
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let column = before[before.rfind('\n').map_or(0, |i| i + 1)..]
        .chars()
        .count()
        + 1;
    format!("{}:{line}:{column}", file.display())
}

/// Imports `text` as `bad.b5r` into a new session; returns the message and checks that nothing
/// was written.
fn refused(tmp: &Path, text: &str, configure: impl Fn(&mut B5rOptions<'_>)) -> (PathBuf, String) {
    let file = tmp.join("bad.b5r");
    std::fs::write(&file, text).unwrap();
    let files = [file.clone()];
    let session = tmp.join("session");
    let machine = three_axis_machine();
    let mut o = options(&files, &session, Some(machine.to_str().unwrap()));
    configure(&mut o);
    let err: ImportError = import_b5r(&o).expect_err("a bad file must be refused");
    assert!(!session.exists(), "nothing may be written: {err}");
    (file, err.to_string())
}

#[test]
fn not_xml_is_refused_where_the_parser_stopped() {
    let tmp = tempfile::tempdir().unwrap();
    let (file, msg) = refused(tmp.path(), "QC20 ballbar data\n1.0 2.0\n", |_| {});
    assert_eq!(
        msg,
        format!(
            "{}:1:1: expected XML (a ball-bar .b5r file), found: unknown token",
            file.display()
        )
    );
    // An element never closed: roxmltree names where the root opened.
    let (file, msg) = refused(tmp.path(), "<TEST_DOCUMENT>\n  <READINGS>1 2 3\n", |_| {});
    assert_eq!(
        msg,
        format!(
            "{}:1:1: expected XML (a ball-bar .b5r file), found: the root node was opened but \
             never closed",
            file.display()
        )
    );
}

#[test]
fn a_file_without_readings_is_refused_at_its_root() {
    let tmp = tempfile::tempdir().unwrap();
    let p = planted(("XY", 'X', 'Y'), true);
    let text = b5r_xml(&[&p], "", None);
    let start = text.find("    <BALLBAR_RUN>").unwrap();
    let end = text.find("  </RUN_RESULTS>").unwrap();
    let text = format!("{}{}", &text[..start], &text[end..]);
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: expected a <READINGS> element (the ball-bar's readings), found none in \
             <TEST_DOCUMENT>",
            location_of(&file, &text, "<TEST_DOCUMENT>")
        )
    );
}

#[test]
fn a_reading_that_is_not_a_number_is_refused_where_it_stands() {
    let tmp = tempfile::tempdir().unwrap();
    let p = planted(("XY", 'X', 'Y'), true);
    let text = b5r_xml(&[&p], "", Some("0.5 1.25 -0.75 n/a 0.1"));
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: <READINGS>: expected a number (reading 4), found `n/a`",
            location_of(&file, &text, "n/a")
        )
    );
}

#[test]
fn an_unknown_plane_is_refused_at_its_name() {
    let tmp = tempfile::tempdir().unwrap();
    let p = planted(("XW", 'X', 'Y'), true);
    let text = b5r_xml(&[&p], "", None);
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: unknown plane `XW`: expected two of the linear axes X, Y, Z (XY, YZ, ZX, YX, \
             ZY, XZ)",
            location_of(&file, &text, "XW\">")
        )
    );
    // A plane that does not hold the axes the file names.
    let p = planted(("YZ", 'X', 'Y'), true);
    let text = b5r_xml(&[&p], "", None);
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: plane `YZ` does not hold the axes <A_AXIS_NAME> X and <B_AXIS_NAME> Y",
            location_of(&file, &text, "YZ\">")
        )
    );
}

#[test]
fn a_count_the_readings_do_not_match_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let p = planted(("XY", 'X', 'Y'), true);
    let text = b5r_xml(&[&p], " COUNT=\"361\"", None);
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: COUNT: the header says 361 readings, <READINGS> holds 360",
            location_of(&file, &text, "361\"")
        )
    );
}

#[test]
fn readings_beyond_the_bar_range_name_the_unit_option() {
    let tmp = tempfile::tempdir().unwrap();
    let p = planted(("XY", 'X', 'Y'), true);
    let text = b5r_xml(&[&p], " DT=\"UT_LENGTH_MM\"", Some("0.001 0.002 3.5 0.001"));
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: reading 3 is 3500 µm as mm, beyond the ball-bar's ±1000 µm: the readings are \
             in another unit (give --reading-unit) or are bar lengths, not deviations from the \
             nominal length",
            location_of(&file, &text, "3.5 ")
        )
    );
}

#[test]
fn missing_header_values_ask_for_their_option() {
    let tmp = tempfile::tempdir().unwrap();
    let p = planted(("XY", 'X', 'Y'), true);
    let text = b5r_xml(&[&p], "", None)
        .replace(&format!("<NOMINAL_LENGTH>{RADIUS_MM}</NOMINAL_LENGTH>"), "");
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: the file gives no <NOMINAL_LENGTH> (the circle's radius): give --radius-mm",
            file.display()
        )
    );
    // A direction that is neither.
    let text = b5r_xml(&[&p], "", None).replace(">CCW<", ">UP<");
    let (file, msg) = refused(tmp.path(), &text, |_| {});
    assert_eq!(
        msg,
        format!(
            "{}: <RUN_DIRECTION>: expected CW or CCW, found `UP`",
            location_of(&file, &text, "UP<")
        )
    );
}
