//! `renishaw-rtx` imports: a synthetic CARTO dynamic capture (ASCII header with CRLF line
//! ends, `Data:`, little-endian f64 samples in mm, `EOF::`), written here from the layout the
//! public readers agree on — no third-party file is copied — becomes a held-position laser
//! run that `identify` fits.

use crate::common;

use common::{identify, read_back, three_axis_machine};
use mtcal_import::{Format, ImportOptions};

/// A capture of `n` samples at 1 kHz: the reading 12.5 mm plus a ±0.2 µm wobble.
fn synthetic_rtx(n: usize) -> (Vec<u8>, Vec<f64>) {
    let header = format!(
        "HEADER::\r\nOwner: CARTO-Dynamic\r\nVersion no: 4.13\r\nFile Type: rtx\r\nVelocity: 0\r\n\
         Sample rate: 1000\r\nSample no: {n}\r\nTrigger point: 0\r\nTrigger interval: 0.001\r\n\
         Actual sample rate: 1000\r\nFlags: 0 1 2 0 2\r\nMachine: \r\nSerial No: \r\n\
         Date: 01/01/2026 12:00:00\r\nBy: User\r\nAxis: X\r\nLocation: \r\nData:\r\n"
    );
    let samples: Vec<f64> = (0..n)
        .map(|k| 12.5 + 0.2e-3 * ((k as f64) * 0.7).sin())
        .collect();
    let mut bytes = header.into_bytes();
    for s in &samples {
        bytes.extend_from_slice(&s.to_le_bytes());
    }
    bytes.extend_from_slice(b"EOF::\r\n");
    (bytes, samples)
}

#[test]
fn a_synthetic_capture_becomes_a_held_run_identify_fits() {
    let tmp = tempfile::tempdir().unwrap();
    let (bytes, samples) = synthetic_rtx(300);
    let file = tmp.path().join("capture.rtx");
    std::fs::write(&file, bytes).unwrap();
    let session = tmp.path().join("session");
    let machine = three_axis_machine();
    let imported = mtcal_import::import(&ImportOptions {
        format: Format::RenishawRtx,
        file: &file,
        session: &session,
        machine: Some(machine.to_str().unwrap()),
        axis: None,
        name: None,
        hold: Some("X=100,Z=-200"),
    })
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(imported.axis, 'X');
    assert_eq!(imported.recording.len(), 300);
    let (travel, d_um) = read_back(&imported);
    assert!(travel.iter().all(|&x| x == 100.0));
    for (d, s) in d_um.iter().zip(&samples) {
        assert!((d - (s - samples[0]) * 1e3).abs() < 1e-9);
    }
    let t = imported.recording.t_s.as_ref().unwrap();
    assert_eq!((t[1], t[299]), (0.001, 0.299));
    let (rms_um, _) = identify(&session);
    assert!(rms_um < 0.2, "fit rms {rms_um} µm");
}
