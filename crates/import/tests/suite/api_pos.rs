//! `api-pos` imports: a synthetic API XD linear data table (inch, LasRead opposite to the
//! travel, analysis blocks after the table), written here from the documented layout — no
//! third-party file is copied — round-trips into a session `identify` fits.

use crate::common;

use common::{identify, import_new, read_back};
use mtcal_import::Format;
use std::fmt::Write as _;

/// The deviation at `x_in` (inch) in cycle `j`, direction `up`, in inch: 10 µm per 254 mm
/// slope and a reversal of 2 µm.
fn error_in(x_in: f64, j: usize, up: bool) -> f64 {
    let um = 10.0 * x_in / 10.0 + if up { 1.0 } else { -1.0 } + 0.05 * j as f64;
    um / 25_400.0
}

fn synthetic_pos() -> String {
    let mut t = String::from(
        "API X-D Laser Measurement Linear Data Table (Company Name: )\nFile Version:\t5\n\
         Instrument(S/N):\t1\nFile Name:\tsynthetic.pos\nAxesLoc: \t(Y) 0\t(Z) 0\nTestAxis: \t(X)\n\n\
         Unit:\tinch\t0\nIniPos:\t0\nEndPos:\t10\nLength: 10\tIncrem: 2\tRunNum: 2\tNumofPos: 6\n\
         NumofPoints:\t24\nTestType: Bidirection\tTestMode: Auto\tDwell: 3\tWindow: 0.1\n\
         Direction: 1\tHumidity: 50\tExpCoef: 6.7\tDeadPath: 0\n\n\
         \x20   Position\t      LasRead\t  LinearError\tStatus\tAirTemp\tAirPress\tMatTemp\tMatTemp2\tMatTemp3\n",
    );
    for j in 0..2 {
        let up = (0..6).map(|i| (2.0 * i as f64, true));
        let down = (0..6).rev().map(|i| (2.0 * i as f64, false));
        for (x, dir) in up.chain(down) {
            let e = error_in(x, j, dir);
            // The instrument reads against the travel: LasRead = −(x + e).
            writeln!(
                t,
                "{x:12.5}\t{:13.6}\t{e:13.6}\t     0\t68.00\t29.92\t68.00\t-1.00\t-1.00",
                -(x + e)
            )
            .unwrap();
        }
    }
    t.push_str(
        "DecimalPoints:\t4\nHardwareNo:\t4\tWaveLength:\t0.000632990350\n\nComments:\tNone\n",
    );
    t.push_str("API Linear Error Compensation Table\nPosition   \tBidirectional Avg Error\n 0.000000\t0.000001\n");
    t.push_str(
        "\nAPI Linear Data Analysis Table\n<ASME B5.54-1992>\nDisplacement Accuracy: 0.000145\n",
    );
    t
}

#[test]
fn a_synthetic_pos_table_round_trips_into_a_session_identify_fits() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("X Axis Bidir.pos");
    std::fs::write(&file, synthetic_pos()).unwrap();
    let session = tmp.path().join("session");
    // The axis comes from `TestAxis: (X)`.
    let imported = import_new(Format::ApiPos, &file, &session, None);
    assert_eq!(imported.axis, 'X');
    assert_eq!(imported.run_name, "X-Axis-Bidir");
    let r = &imported.recording;
    assert_eq!(
        (r.targets, r.cycles, r.len(), r.unit.as_str()),
        (6, 2, 24, "inch")
    );
    let (travel, d_um) = read_back(&imported);
    // inch to mm and µm; 6 decimals of an inch are 0.0254 µm.
    assert_eq!(travel[5], 254.0);
    assert!((d_um[5] - (10.0 + 1.0)).abs() < 0.03, "{}", d_um[5]);
    assert!((d_um[6] - (10.0 - 1.0)).abs() < 0.03, "{}", d_um[6]);
    // Context: 68 °F = 20 °C, 29.92 inHg = 1013.2 hPa; MatTemp2/3 (−1: no sensor) left out.
    let names: Vec<&str> = r.context.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["T_air", "P_air", "T_material"]);
    assert!((r.context[0].1[0] - 20.0).abs() < 1e-9);
    assert!((r.context[1].1[0] - 1013.21).abs() < 0.01);
    let (rms_um, metrics) = identify(&session);
    let b = metrics
        .iter()
        .find(|(n, _)| n == "B (ISO 230-2)")
        .unwrap()
        .1;
    assert!((b - 2.0).abs() < 0.06, "B {b} µm");
    assert!(rms_um < 2.0, "fit rms {rms_um} µm");
}
