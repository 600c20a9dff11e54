//! The history at the scale of the issue: 1,000 machines × 500 campaigns × 20 parameters
//! (500,000 campaigns, 10 million parameter values) in one SQLite file. Measures the fleet
//! view (target < 1 s) and one parameter's series of one machine (target < 50 ms), and opening
//! the file (what every command pays first).
//!
//! `cargo bench -p mtcal-history --bench history`
//!
//! Measured (2-core machine, warm page cache, 620 MB file): fleet 59 ms, series 1.3 ms,
//! machines 77 ms, open 0.2 ms; generation 60 s.
//!
//! The file is generated once through the public API (`Store::add_many`, one transaction per
//! ten machines) into `target/history-bench/` and reused by later runs; delete it to
//! regenerate. Generation takes about a minute; it is written under a temporary name and
//! renamed when complete, so an interrupted run never leaves a partial file behind as if it
//! were whole.

use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_history::{
    Campaign, CampaignId, DiscoverySummary, FitSummary, MachineIdentity, Parameter,
    ParameterStatus, Store, Timestamp, ValidationRun,
};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const MACHINES: usize = 1000;
const CAMPAIGNS: usize = 500;
const PARAMETERS: [&str; 20] = [
    "EX0C", "EY0C", "EA0C", "EB0C", "EC0Y", "EB0Z", "EA0Z", "EY0A", "EZ0A", "EB0A", "EC0A",
    "EXX.P1", "EXX.P2", "EYY.P1", "EYY.P2", "EZZ.P1", "EZZ.P2", "ECX.P1", "ECY.P1", "EAZ.P1",
];
/// Machines per transaction while generating.
const MACHINES_PER_BATCH: usize = 10;

/// splitmix64: reproducible numbers without a generator crate.
fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// A number in [-1, 1) from a seed.
fn unit(seed: u64) -> f64 {
    (mix(seed) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

fn machine_name(m: usize) -> String {
    format!("machine-{m:04}")
}

/// Campaign `k` of machine `m`: every 2 weeks from 2005 on, parameters drifting slowly.
fn campaign(m: usize, k: usize) -> Campaign {
    let start: Timestamp = "2005-01-03T08:00:00Z".parse().unwrap();
    let seed = (m * CAMPAIGNS + k) as u64;
    let parameters = PARAMETERS
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let base = 20.0 * unit((m * 100 + j) as u64);
            let value = base + 0.01 * k as f64 + 0.3 * unit(seed * 64 + j as u64);
            match j {
                8 => Parameter::not_identifiable(name),
                9 => Parameter {
                    status: ParameterStatus::WeaklyDetermined,
                    ..Parameter::identified(name, value, 150.0, "urad")
                },
                _ => Parameter::identified(name, value, 0.4, if j < 4 { "um" } else { "urad" }),
            }
        })
        .collect();
    Campaign {
        machine: MachineIdentity {
            name: machine_name(m),
            urdf_digest: Some(format!("sha256:{:016x}", mix(m as u64))),
            error_model_digest: Some(format!("sha256:{:016x}", mix(m as u64 + 1))),
        },
        date: start + Duration::from_secs(14 * 86_400 * k as u64 + 60 * m as u64),
        session_digest: Some(format!("sha256:{:016x}", mix(seed))),
        mtcal_version: Some("0.1.0".into()),
        instruments: vec!["rtest".into(), "ballbar".into()],
        fit: FitSummary {
            rms_um: 0.5 + 0.1 * unit(seed).abs(),
            chi2_reduced: Some(1.0 + 0.05 * unit(seed + 1)),
            dof: 1762,
            runs: 9,
            converged: true,
            verdict: None,
        },
        validation: vec![ValidationRun {
            name: "rtest-xyzac".into(),
            instrument: "rtest".into(),
            rms_um: Some(0.49),
        }],
        discoveries: if k % 50 == 0 {
            vec![DiscoverySummary {
                effect: "thermal-drift".into(),
                label: "thermal-drift Z (t)".into(),
                sentence: Some("Z drifts by 3 µm with τ = 1800 s.".into()),
            }]
        } else {
            Vec::new()
        },
        parameters,
        temperature_c: Some(20.0 + unit(seed + 2)),
        note: None,
    }
}

fn bench_file() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target"));
    let dir = target.join("history-bench");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(format!(
        "fleet-{MACHINES}x{CAMPAIGNS}x{}-v1.sqlite",
        PARAMETERS.len()
    ))
}

fn generate(path: &Path) {
    let partial = path.with_extension("partial");
    for stale in ["", "-wal", "-shm"] {
        let _ = std::fs::remove_file(format!("{}{stale}", partial.display()));
    }
    let started = Instant::now();
    let mut store = Store::open(partial.to_str().unwrap()).unwrap();
    for first in (0..MACHINES).step_by(MACHINES_PER_BATCH) {
        let batch: Vec<Campaign> = (first..first + MACHINES_PER_BATCH)
            .flat_map(|m| (0..CAMPAIGNS).map(move |k| campaign(m, k)))
            .collect();
        let ids = store.add_many(&batch, |_| {}).unwrap();
        // One re-measured campaign per machine, as a real history has.
        for machine_ids in ids.chunks(CAMPAIGNS) {
            let (old, new): (CampaignId, CampaignId) = (machine_ids[250], machine_ids[251]);
            store.supersede(old, new, "probe not clamped").unwrap();
        }
        eprintln!(
            "generated {} of {MACHINES} machines ({:.0?})",
            first + MACHINES_PER_BATCH,
            started.elapsed()
        );
    }
    drop(store);
    std::fs::rename(&partial, path).unwrap();
    eprintln!(
        "history: {} ({:.0} MB) in {:.0?}",
        path.display(),
        std::fs::metadata(path).unwrap().len() as f64 / 1e6,
        started.elapsed()
    );
}

fn bench(c: &mut Criterion) {
    let path = bench_file();
    if !path.exists() {
        generate(&path);
    }
    let location = path.to_str().unwrap().to_string();
    let store = Store::open(&location).unwrap();
    // What is measured is what was asked for.
    let fleet = store.fleet().unwrap();
    assert_eq!(fleet.len(), MACHINES);
    assert!(
        fleet.iter().all(
            |row| row.parameters.len() == PARAMETERS.len() && row.campaigns == CAMPAIGNS as u64
        )
    );
    let series = store.series(&machine_name(617), "EC0Y").unwrap();
    assert_eq!(series.len(), CAMPAIGNS);
    assert_eq!(series.iter().filter(|p| p.superseded).count(), 1);

    let mut group = c.benchmark_group("history_1000_machines_x_500_campaigns_x_20_parameters");
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(20));
    group.bench_function("fleet", |b| b.iter(|| black_box(store.fleet().unwrap())));
    group.bench_function("series_one_machine_one_parameter", |b| {
        b.iter(|| black_box(store.series(&machine_name(617), "EC0Y").unwrap()))
    });
    group.bench_function("open", |b| {
        b.iter(|| black_box(Store::open(&location).unwrap()))
    });
    group.bench_function("machines", |b| {
        b.iter(|| black_box(store.machines().unwrap()))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
