//! A fresh database per test on either back end, and campaigns to put in it.
//!
//! SQLite: a file in a new temporary folder. PostgreSQL: a new schema on the server named by
//! `MTCAL_TEST_POSTGRES` (a URL), dropped afterwards; without it the PostgreSQL tests say they
//! were skipped, unless `MTCAL_REQUIRE_POSTGRES=1` (CI), where they fail.

#![allow(dead_code)]

use mtcal_history::{
    Campaign, DiscoverySummary, FitSummary, MachineIdentity, Parameter, ParameterStatus, Store,
    ValidationRun, parse_date,
};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Once;
use std::sync::atomic::{AtomicUsize, Ordering};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Sqlite,
    Postgres,
}

pub struct TestDb {
    pub kind: Kind,
    /// What `Store::open` takes.
    pub url: String,
    dir: tempfile::TempDir,
    /// The server URL and the schema to drop at the end (PostgreSQL).
    schema: Option<(String, String)>,
}

impl TestDb {
    /// A fresh, empty database; `None` when PostgreSQL is not configured (and not required).
    pub fn new(kind: Kind) -> Option<TestDb> {
        let dir = tempfile::tempdir().expect("a temporary folder");
        match kind {
            Kind::Sqlite => Some(TestDb {
                kind,
                url: format!("sqlite:{}", dir.path().join("history.sqlite").display()),
                dir,
                schema: None,
            }),
            Kind::Postgres => {
                let server = postgres_server()?;
                let schema = fresh_schema(&server);
                Some(TestDb {
                    kind,
                    url: with_search_path(&server, &schema),
                    dir,
                    schema: Some((server, schema)),
                })
            }
        }
    }

    pub fn store(&self) -> Store {
        Store::open(&self.url).unwrap_or_else(|e| panic!("opening {}: {e}", self.url))
    }

    /// A folder of the test's own (child-process signals, stray files).
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// The SQLite file (SQLite only).
    pub fn sqlite_path(&self) -> PathBuf {
        assert_eq!(self.kind, Kind::Sqlite);
        PathBuf::from(self.url.strip_prefix("sqlite:").unwrap())
    }

    /// Runs SQL on a connection of its own, beside the store: what another program could do.
    pub fn raw(&self, sql: &str) -> Result<(), String> {
        match self.kind {
            Kind::Sqlite => rusqlite::Connection::open(self.sqlite_path())
                .and_then(|c| c.execute_batch(sql))
                .map_err(|e| e.to_string()),
            Kind::Postgres => postgres::Client::connect(&self.url, postgres::NoTls)
                .and_then(|mut c| c.batch_execute(sql))
                .map_err(|e| format!("{e:?}")),
        }
    }

    /// A number from SQL on a connection of its own.
    pub fn raw_count(&self, sql: &str) -> i64 {
        match self.kind {
            Kind::Sqlite => rusqlite::Connection::open(self.sqlite_path())
                .and_then(|c| c.query_row(sql, [], |r| r.get(0)))
                .unwrap(),
            Kind::Postgres => postgres::Client::connect(&self.url, postgres::NoTls)
                .and_then(|mut c| c.query_one(sql, &[]))
                .map(|r| r.get::<_, i64>(0))
                .unwrap(),
        }
    }
}

impl Drop for TestDb {
    fn drop(&mut self) {
        let Some((server, schema)) = &self.schema else {
            return;
        };
        if let Ok(mut client) = postgres::Client::connect(server, postgres::NoTls) {
            let _ = client.batch_execute(&format!("DROP SCHEMA {schema} CASCADE"));
        }
    }
}

/// The PostgreSQL server of the tests, or `None` after saying they were skipped.
fn postgres_server() -> Option<String> {
    let required = std::env::var("MTCAL_REQUIRE_POSTGRES").is_ok_and(|v| v == "1");
    match std::env::var("MTCAL_TEST_POSTGRES") {
        Ok(url) if !url.trim().is_empty() => Some(url),
        _ if required => panic!(
            "MTCAL_REQUIRE_POSTGRES=1 but MTCAL_TEST_POSTGRES is not set: the PostgreSQL back \
             end must be tested"
        ),
        _ => {
            static SAID: Once = Once::new();
            // Straight to stderr: libtest captures print macros of passing tests, and a
            // skip must be seen.
            SAID.call_once(|| {
                let _ = writeln!(
                    std::io::stderr(),
                    "mtcal-history: PostgreSQL tests SKIPPED (MTCAL_TEST_POSTGRES is not set; \
                     e.g. MTCAL_TEST_POSTGRES=postgres://postgres@127.0.0.1:5432/postgres)"
                );
            });
            None
        }
    }
}

fn fresh_schema(server: &str) -> String {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .subsec_nanos();
    let schema = format!(
        "mtcal_test_{}_{}_{nanos}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::SeqCst)
    );
    let mut client = postgres::Client::connect(server, postgres::NoTls)
        .unwrap_or_else(|e| panic!("MTCAL_TEST_POSTGRES={server} cannot be reached: {e}"));
    client
        .batch_execute(&format!("CREATE SCHEMA {schema}"))
        .unwrap_or_else(|e| panic!("creating schema {schema} on {server}: {e}"));
    schema
}

/// The server URL with the connection's schema set to `schema`.
pub fn with_search_path(server: &str, schema: &str) -> String {
    let separator = if server.contains('?') { '&' } else { '?' };
    format!("{server}{separator}options=-c%20search_path%3D{schema}")
}

/// A campaign with every kind of content: each parameter status, a discovery, a validation
/// run, the optional context. `shift` moves its numbers (0.1 + 0.2 and friends: binary
/// fractions no decimal text would keep exactly).
pub fn sample(machine: &str, date: &str, shift: f64) -> Campaign {
    Campaign {
        machine: MachineIdentity {
            name: machine.into(),
            urdf_digest: Some("sha256:5e1f0c".into()),
            error_model_digest: Some("sha256:77aa01".into()),
        },
        date: parse_date(date).unwrap(),
        session_digest: Some(format!("sha256:session-{shift}")),
        mtcal_version: Some("0.1.0".into()),
        instruments: vec!["laser".into(), "ballbar".into()],
        fit: FitSummary {
            rms_um: 0.1 + 0.2 + shift,
            chi2_reduced: Some(1.0 / 3.0),
            dof: 1027,
            runs: 15,
            converged: true,
            verdict: None,
        },
        validation: vec![ValidationRun {
            name: "rtest-check".into(),
            instrument: "rtest".into(),
            rms_um: Some(0.489_714_3),
        }],
        discoveries: vec![DiscoverySummary {
            effect: "thermal-drift".into(),
            label: "thermal-drift Z (t)".into(),
            sentence: Some("Z drifts 3.1 µm over the first half hour (τ = 1800 s).".into()),
        }],
        parameters: vec![
            Parameter::identified("EX0C", 12.3 + shift, 0.4, "um"),
            Parameter {
                name: "laser-x.tilt_1".into(),
                status: ParameterStatus::WeaklyDetermined,
                value: Some(-3.0e-7 * shift),
                u95: Some(195.9999),
                unit: Some("urad".into()),
                kind: Some("laser-x".into()),
                expression: None,
            },
            Parameter {
                name: "EC0Y".into(),
                status: ParameterStatus::Combination,
                value: Some(7.25 - shift),
                u95: Some(0.5),
                unit: Some("urad".into()),
                kind: Some("machine".into()),
                expression: Some("EC0Y − 0.5·EXX.P1".into()),
            },
            Parameter::not_identifiable("EZ0A"),
        ],
        temperature_c: Some(20.4),
        note: Some("after the crash\nof March".into()),
    }
}

/// The exit status and output of a child, for a failure message.
pub fn describe(output: &std::process::Output) -> String {
    format!(
        "{}\nstdout:\n{}\nstderr:\n{}",
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}
