//! The history's suite, written once and run on both back ends (`sqlite::…` and
//! `postgres::…`): round trips, append-only, the queries against an in-memory model, two
//! processes writing at once, a process killed in the middle of a write, the errors for
//! foreign, newer and damaged databases, and the migration from schema 1.

use crate::common;

use common::{Kind, TestDb, describe, sample};
use mtcal_history::{
    Backend, Campaign, CampaignId, Error, MachineIdentity, Parameter, ParameterStatus,
    SCHEMA_VERSION, Store, parse_date,
};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

macro_rules! on_both_back_ends {
    ($($test:ident),* $(,)?) => {
        mod sqlite {
            $(#[test] fn $test() { super::$test(super::Kind::Sqlite) })*
        }
        mod postgres {
            $(#[test] fn $test() { super::$test(super::Kind::Postgres) })*
        }
    };
}

on_both_back_ends!(
    a_campaign_round_trips,
    an_identified_session_round_trips,
    nothing_is_ever_overwritten,
    supersede_keeps_both_and_refuses_what_is_not_later,
    queries_agree_with_an_in_memory_model,
    two_processes_adding_at_once_lose_nothing,
    a_process_killed_while_adding_leaves_no_partial_campaign,
    a_foreign_database_is_refused_unchanged,
    a_newer_schema_is_refused,
    a_schema_1_history_is_migrated,
    unknown_names_are_clear_errors,
    invalid_campaigns_are_refused_before_writing,
);

fn a_campaign_round_trips(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let mut store = db.store();
    assert_eq!(
        store.backend(),
        match kind {
            Kind::Sqlite => Backend::Sqlite,
            Kind::Postgres => Backend::Postgres,
        }
    );
    assert_eq!(store.schema_version().unwrap(), SCHEMA_VERSION);
    let full = sample("mill-7", "2024-05-01T08:30:00Z", 0.0);
    let mut bare = sample("mill-7", "2024-06-01T08:30:00Z", 1.0);
    bare.machine.urdf_digest = None;
    bare.machine.error_model_digest = None;
    bare.session_digest = None;
    bare.mtcal_version = None;
    bare.instruments.clear();
    bare.validation.clear();
    bare.discoveries.clear();
    bare.fit.chi2_reduced = None;
    bare.fit.converged = false;
    bare.fit.verdict = Some("NOT CONVERGED (MaxIterations) after 50 iterations".into());
    bare.temperature_c = None;
    bare.note = None;
    for campaign in [full, bare] {
        let before = jiff::Timestamp::now().as_second();
        let id = store.add(&campaign).unwrap();
        let record = db.store().campaign(id).unwrap();
        assert_eq!(record.campaign, campaign);
        assert_eq!(record.id, id);
        assert_eq!(record.superseded, None);
        assert!(record.supersedes.is_empty());
        assert!(record.added.as_second() >= before);
    }
    // Dates are kept to the second.
    let mut precise = sample("mill-7", "2024-07-01T08:30:00Z", 2.0);
    precise.date = "2024-07-01T08:30:00.987654Z".parse().unwrap();
    let id = store.add(&precise).unwrap();
    assert_eq!(
        store.campaign(id).unwrap().campaign.date,
        parse_date("2024-07-01T08:30:00Z").unwrap()
    );
}

/// What the real pipeline writes (identify on the shipped examples) survives the history.
fn an_identified_session_round_trips(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let mut store = db.store();
    for example in ["three-axis", "five-axis"] {
        let json = identify_json(example);
        let date = parse_date("2025-01-15").unwrap();
        let mut campaign = Campaign::from_identify_json(&json, example, date).unwrap();
        campaign.mtcal_version = Some(env!("CARGO_PKG_VERSION").into());
        let id = store.add(&campaign).unwrap();
        assert_eq!(store.campaign(id).unwrap().campaign, campaign);
        let first = &campaign.parameters[0];
        let series = store.series(example, &first.name).unwrap();
        assert_eq!(series.len(), 1);
        assert_eq!(series[0].value, first.value);
    }
}

fn identify_json(example: &str) -> String {
    let session = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(example)
        .join("session");
    let (_, identification) = mtcal_identify::identify_session(&session).unwrap();
    mtcal_identify::report::IdentifyJson::of(&identification).to_json()
}

fn nothing_is_ever_overwritten(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let mut store = db.store();
    let campaign = sample("mill-7", "2024-05-01T08:30:00Z", 0.0);
    let first = store.add(&campaign).unwrap();
    let second = store.add(&campaign).unwrap();
    assert_ne!(first, second, "the same campaign twice is two campaigns");
    assert_eq!(store.campaigns("mill-7").unwrap().len(), 2);
    assert_eq!(store.campaign(first).unwrap().campaign, campaign);
    // The database itself refuses a change, whoever asks.
    for sql in [
        "UPDATE campaigns SET note = 'rewritten'",
        "DELETE FROM parameters",
        "UPDATE parameters SET value = 0 WHERE value IS NOT NULL",
        "DELETE FROM campaigns",
        "UPDATE machines SET name = 'other'",
    ] {
        let refused = db.raw(sql).expect_err(sql);
        assert!(refused.contains("append-only"), "{sql}: {refused}");
    }
    assert_eq!(store.campaign(first).unwrap().campaign, campaign);
    assert_eq!(store.campaign(second).unwrap().campaign, campaign);
}

fn supersede_keeps_both_and_refuses_what_is_not_later(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let mut store = db.store();
    let old_campaign = sample("mill-7", "2024-05-01T08:30:00Z", 0.0);
    let old = store.add(&old_campaign).unwrap();
    let new = store
        .add(&sample("mill-7", "2024-05-01T08:30:00Z", 1.0))
        .unwrap();
    let other_machine = store
        .add(&sample("lathe-2", "2024-09-01T08:30:00Z", 0.0))
        .unwrap();
    let earlier = store
        .add(&sample("mill-7", "2024-04-01T08:30:00Z", 2.0))
        .unwrap();

    let refusals = [
        (old, old, "probe", "itself"),
        (old, other_machine, "probe", "machine"),
        (old, earlier, "probe", "not later"),
        (new, old, "probe", "not later"),
        (old, new, "  ", "reason"),
        (old, CampaignId(999_999), "probe", "no campaign 999999"),
    ];
    for (id, by, reason, why) in refusals {
        let error = store.supersede(id, by, reason).unwrap_err().to_string();
        assert!(error.contains(why), "{id} by {by}: {error}");
    }
    store
        .supersede(old, new, "probe was not clamped")
        .expect("same date, added later");
    let error = store.supersede(old, new, "again").unwrap_err().to_string();
    assert!(
        error.contains(&format!("already superseded by {new}")),
        "{error}"
    );

    let record = store.campaign(old).unwrap();
    assert_eq!(
        record.campaign, old_campaign,
        "a superseded campaign is kept"
    );
    let mark = record.superseded.unwrap();
    assert_eq!(
        (mark.by, mark.reason.as_str()),
        (new, "probe was not clamped")
    );
    assert_eq!(store.campaign(new).unwrap().supersedes, vec![old]);
    let flags: Vec<(CampaignId, bool)> = store
        .series("mill-7", "EX0C")
        .unwrap()
        .iter()
        .map(|p| (p.campaign, p.superseded))
        .collect();
    assert_eq!(flags, vec![(earlier, false), (old, true), (new, false)]);
}

/// A small history built at random: every query against what the history must say,
/// worked out in memory from the campaigns and supersessions themselves.
fn queries_agree_with_an_in_memory_model(kind: Kind) {
    if TestDb::new(kind).is_none() {
        return;
    }
    let cases = match kind {
        Kind::Sqlite => 24,
        Kind::Postgres => 12,
    };
    let planned = (
        0..3usize,
        0..6u32,
        proptest::option::of(-50.0..50.0f64),
        0.0..5.0f64,
    );
    let strategy = (
        proptest::collection::vec(planned, 1..10),
        proptest::collection::vec((0..10usize, 0..10usize), 0..6),
        any::<bool>(),
    );
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    runner
        .run(&strategy, |(planned, supersessions, batch)| {
            let db = TestDb::new(kind).unwrap();
            check_model(&db, &planned, &supersessions, batch);
            Ok(())
        })
        .unwrap();
}

/// One planned campaign: machine, day, the value of `P` (`None`: not identifiable), `Q`.
type Planned = (usize, u32, Option<f64>, f64);

fn planned_campaign(&(machine, day, p, q): &Planned) -> Campaign {
    let mut campaign = sample(
        &format!("machine-{machine}"),
        &format!("2024-03-{:02}T12:00:00Z", day + 1),
        q,
    );
    campaign.parameters = vec![
        match p {
            Some(v) => Parameter::identified("P", v, 0.25, "um"),
            None => Parameter::not_identifiable("P"),
        },
        Parameter::identified("Q", q, 0.1, "urad"),
    ];
    campaign
}

fn check_model(db: &TestDb, planned: &[Planned], supersessions: &[(usize, usize)], batch: bool) {
    let mut store = db.store();
    let campaigns: Vec<Campaign> = planned.iter().map(planned_campaign).collect();
    let ids = if batch {
        store.add_many(&campaigns, |_| {}).unwrap()
    } else {
        campaigns.iter().map(|c| store.add(c).unwrap()).collect()
    };
    // Series order: date, then id.
    let order = |i: usize| (planned[i].1, ids[i]);
    let mut superseded: BTreeMap<usize, usize> = BTreeMap::new();
    for &(i, j) in supersessions {
        let (i, j) = (i % planned.len(), j % planned.len());
        let allowed = i != j
            && planned[i].0 == planned[j].0
            && order(j) > order(i)
            && !superseded.contains_key(&i);
        let result = store.supersede(ids[i], ids[j], "re-measured");
        assert_eq!(result.is_ok(), allowed, "{i} by {j}: {result:?}");
        if allowed {
            superseded.insert(i, j);
        }
    }
    for machine in 0..3 {
        let name = format!("machine-{machine}");
        let mut mine: Vec<usize> = (0..planned.len())
            .filter(|&i| planned[i].0 == machine)
            .collect();
        mine.sort_by_key(|&i| order(i));
        if mine.is_empty() {
            assert!(matches!(
                store.series(&name, "P"),
                Err(Error::UnknownMachine { .. })
            ));
            continue;
        }
        let rows: Vec<CampaignId> = store
            .campaigns(&name)
            .unwrap()
            .iter()
            .map(|r| r.id)
            .collect();
        assert_eq!(rows, mine.iter().map(|&i| ids[i]).collect::<Vec<_>>());
        let series = store.series(&name, "P").unwrap();
        let expected: Vec<_> = mine
            .iter()
            .map(|&i| (ids[i], planned[i].2, superseded.contains_key(&i)))
            .collect();
        let got: Vec<_> = series
            .iter()
            .map(|p| (p.campaign, p.value, p.superseded))
            .collect();
        assert_eq!(got, expected);
        for (point, &i) in series.iter().zip(&mine) {
            assert_eq!(point.date, campaigns[i].date);
            let status = if planned[i].2.is_some() {
                ParameterStatus::Identified
            } else {
                ParameterStatus::NotIdentifiable
            };
            assert_eq!(point.status, status);
        }
    }
    check_fleet(&store, planned, &campaigns, &ids, &superseded);
}

fn check_fleet(
    store: &Store,
    planned: &[Planned],
    campaigns: &[Campaign],
    ids: &[CampaignId],
    superseded: &BTreeMap<usize, usize>,
) {
    let fleet = store.fleet().unwrap();
    let machines = store.machines().unwrap();
    let mut expected_machines: Vec<usize> = planned.iter().map(|p| p.0).collect();
    expected_machines.sort();
    expected_machines.dedup();
    assert_eq!(fleet.len(), expected_machines.len());
    assert_eq!(machines.len(), expected_machines.len());
    for ((row, summary), machine) in fleet.iter().zip(&machines).zip(expected_machines) {
        let mine: Vec<usize> = (0..planned.len())
            .filter(|&i| planned[i].0 == machine)
            .collect();
        let latest = *mine
            .iter()
            .filter(|i| !superseded.contains_key(i))
            .max_by_key(|&&i| (planned[i].1, ids[i]))
            .unwrap();
        assert_eq!(row.machine, format!("machine-{machine}"));
        assert_eq!(row.campaigns, mine.len() as u64);
        assert_eq!(row.latest.id, ids[latest]);
        assert_eq!(row.parameters, campaigns[latest].parameters);
        assert_eq!(summary.name, row.machine);
        assert_eq!(summary.campaigns, mine.len() as u64);
        let dates = mine.iter().map(|&i| campaigns[i].date);
        assert_eq!(summary.first_date, dates.clone().min().unwrap());
        assert_eq!(summary.last_date, dates.max().unwrap());
    }
}

/// The environment of a child process: what it does, where, and its share.
const CHILD_ROLE: &str = "MTCAL_HISTORY_TEST_CHILD";
const CHILD_URL: &str = "MTCAL_HISTORY_TEST_URL";
const CHILD_TAG: &str = "MTCAL_HISTORY_TEST_TAG";
const CHILD_GO: &str = "MTCAL_HISTORY_TEST_GO";
/// Campaigns each writer adds, one transaction each.
const PER_WRITER: usize = 30;
/// Campaigns of the batch the killed child is writing, and where it stops.
const KILLED_BATCH: usize = 40;
const KILLED_AT: usize = 20;

/// Not a test of its own: the body of the child processes the tests below start (this test
/// binary run again with `--exact child_process`). Does nothing unless started so.
#[test]
fn child_process() {
    let Ok(role) = std::env::var(CHILD_ROLE) else {
        return;
    };
    let url = std::env::var(CHILD_URL).unwrap();
    let tag = std::env::var(CHILD_TAG).unwrap();
    match role.as_str() {
        "writer" => writer(&url, &tag),
        "killed" => killed_writer(&url, &tag),
        other => panic!("unknown child role {other}"),
    }
}

/// [`child_process`]'s name as the test binary knows it: its module path without the crate
/// (`store::child_process` where the tests are gathered into one binary).
fn child_test_name() -> String {
    match module_path!().split_once("::") {
        Some((_, module)) => format!("{module}::child_process"),
        None => "child_process".to_string(),
    }
}

fn spawn_child(role: &str, db: &TestDb, tag: &str) -> std::process::Child {
    Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            &child_test_name(),
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD_ROLE, role)
        .env(CHILD_URL, &db.url)
        .env(CHILD_TAG, tag)
        .env(CHILD_GO, db.dir().join("go"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn writer_campaign(tag: &str, k: usize, machine: &str) -> Campaign {
    let mut campaign = sample(machine, "2024-01-01T00:00:00Z", k as f64);
    campaign.date =
        parse_date("2024-01-01T00:00:00Z").unwrap() + jiff::SignedDuration::from_hours(k as i64);
    campaign.note = Some(format!("{tag}-{k}"));
    campaign
}

/// Waits for the parent's signal, then opens the history (both children at once: the
/// first open of an empty database is concurrent too) and adds its campaigns one by one,
/// alternating between a machine both write and one of its own.
fn writer(url: &str, tag: &str) {
    let go = std::env::var(CHILD_GO).unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !std::path::Path::new(&go).exists() {
        assert!(Instant::now() < deadline, "no go signal");
        std::thread::sleep(Duration::from_millis(1));
    }
    let mut store = Store::open(url).unwrap();
    for k in 0..PER_WRITER {
        let machine = if k % 2 == 0 {
            "shared".to_string()
        } else {
            format!("own-{tag}")
        };
        let id = store.add(&writer_campaign(tag, k, &machine)).unwrap();
        println!("added {tag}-{k} {id}");
        // A pause between campaigns, as between real ones: SQLite's lock is not a queue,
        // and a writer that never pauses keeps it while the other backs off.
        std::thread::sleep(Duration::from_millis(3));
    }
}

fn two_processes_adding_at_once_lose_nothing(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let children = [
        spawn_child("writer", &db, "a"),
        spawn_child("writer", &db, "b"),
    ];
    std::fs::write(db.dir().join("go"), "").unwrap();
    let mut order = Vec::new();
    for child in children {
        let output = child.wait_with_output().unwrap();
        assert!(
            output.status.success(),
            "a writer failed: {}",
            describe(&output)
        );
        for line in String::from_utf8_lossy(&output.stdout).lines() {
            // The first line follows libtest's "test child_process ... ".
            if let Some(at) = line.find("added ") {
                let rest = &line[at + "added ".len()..];
                let (note, id) = rest.split_once(' ').unwrap();
                order.push((id.parse::<i64>().unwrap(), note.to_string()));
            }
        }
    }
    assert_eq!(order.len(), 2 * PER_WRITER);
    order.sort();
    // Both wrote at the same time: their campaigns' numbers interleave.
    let switches = order
        .windows(2)
        .filter(|w| w[0].1[..1] != w[1].1[..1])
        .count();
    assert!(switches >= 2, "the writers did not overlap: {order:?}");

    let store = db.store();
    let count = |machine: &str| store.campaigns(machine).unwrap().len();
    assert_eq!(count("shared"), PER_WRITER);
    assert_eq!(count("own-a"), PER_WRITER / 2);
    assert_eq!(count("own-b"), PER_WRITER / 2);
    for (id, note) in &order {
        let (tag, k) = note.split_once('-').unwrap();
        let k: usize = k.parse().unwrap();
        let machine = if k % 2 == 0 {
            "shared".to_string()
        } else {
            format!("own-{tag}")
        };
        let stored = store.campaign(CampaignId(*id)).unwrap().campaign;
        assert_eq!(stored, writer_campaign(tag, k, &machine), "campaign {id}");
    }
}

/// Adds a batch of campaigns in one transaction and, half-way, says so and waits to be
/// killed.
fn killed_writer(url: &str, tag: &str) {
    let mut store = Store::open(url).unwrap();
    let batch: Vec<Campaign> = (0..KILLED_BATCH)
        .map(|k| writer_campaign(tag, k, if k % 2 == 0 { "mill-7" } else { "doomed" }))
        .collect();
    store
        .add_many(&batch, |written| {
            if written == KILLED_AT {
                println!("inside the transaction");
                std::thread::sleep(Duration::from_secs(120));
            }
        })
        .unwrap();
    panic!("the parent was to kill this process inside the transaction");
}

fn a_process_killed_while_adding_leaves_no_partial_campaign(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let kept = sample("mill-7", "2023-12-01T00:00:00Z", 0.0);
    let kept_id = db.store().add(&kept).unwrap();
    let mut child = spawn_child("killed", &db, "k");
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    while !line.contains("inside the transaction") {
        line.clear();
        if stdout.read_line(&mut line).unwrap() == 0 {
            let output = child.wait_with_output().unwrap();
            panic!(
                "the child ended before it was killed: {}",
                describe(&output)
            );
        }
    }
    child.kill().unwrap(); // SIGKILL: no unwinding, no rollback by the process
    child.wait().unwrap();

    let mut store = db.store();
    let machines = store.machines().unwrap();
    assert_eq!(machines.len(), 1, "{machines:?}");
    assert_eq!(
        (machines[0].name.as_str(), machines[0].campaigns),
        ("mill-7", 1)
    );
    assert_eq!(db.raw_count("SELECT COUNT(*) FROM campaigns"), 1);
    assert_eq!(
        db.raw_count("SELECT COUNT(*) FROM parameters"),
        kept.parameters.len() as i64
    );
    assert_eq!(store.campaign(kept_id).unwrap().campaign, kept);
    // The history takes the next campaign, of the machine the dead transaction was creating.
    let next = sample("doomed", "2024-02-01T00:00:00Z", 1.0);
    let id = store.add(&next).unwrap();
    assert_eq!(store.campaign(id).unwrap().campaign, next);
}

fn a_foreign_database_is_refused_unchanged(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    db.raw("CREATE TABLE customers (id INTEGER, name TEXT)")
        .unwrap();
    db.raw("CREATE TABLE orders (id INTEGER)").unwrap();
    let error = Store::open(&db.url).unwrap_err();
    let message = error.to_string();
    assert!(matches!(error, Error::NotAHistory { .. }), "{message}");
    assert!(message.contains("not an mtcal history"), "{message}");
    assert!(message.contains("customers, orders"), "{message}");
    match kind {
        Kind::Sqlite => {
            assert!(message.contains(&db.sqlite_path().display().to_string()));
            // Not even switched to WAL.
            let mode: String = rusqlite::Connection::open(db.sqlite_path())
                .unwrap()
                .query_row("PRAGMA journal_mode", [], |r| r.get(0))
                .unwrap();
            assert_eq!(mode, "delete");
        }
        Kind::Postgres => assert!(message.contains("search_path"), "{message}"),
    }
    assert_eq!(db.raw_count("SELECT COUNT(*) FROM customers"), 0);
}

fn a_newer_schema_is_refused(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    db.store()
        .add(&sample("mill-7", "2024-05-01", 0.0))
        .unwrap();
    db.raw(
        "INSERT INTO schema_migrations (version, description, applied_utc) \
         VALUES (99, 'from the future', '2099-01-01T00:00:00Z')",
    )
    .unwrap();
    let error = Store::open(&db.url).unwrap_err();
    let message = error.to_string();
    assert!(
        matches!(
            error,
            Error::NewerSchema {
                found: 99,
                known: SCHEMA_VERSION,
                ..
            }
        ),
        "{message}"
    );
    assert!(message.contains("newer mtcal"), "{message}");
}

/// A history as schema 1 left it (no append-only guard) opens migrated, its campaigns intact.
fn a_schema_1_history_is_migrated(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let campaign = sample("mill-7", "2024-05-01T08:30:00Z", 0.0);
    let id = {
        let mut old = Store::open_at_version(&db.url, 1).unwrap();
        assert_eq!(old.schema_version().unwrap(), 1);
        old.add(&campaign).unwrap()
    };
    // Schema 1 did not guard its rows.
    db.raw("UPDATE campaigns SET note = note").unwrap();
    assert_eq!(db.raw_count("SELECT COUNT(*) FROM schema_migrations"), 1);

    let store = db.store();
    assert_eq!(store.schema_version().unwrap(), SCHEMA_VERSION);
    assert_eq!(db.raw_count("SELECT COUNT(*) FROM schema_migrations"), 2);
    assert_eq!(store.campaign(id).unwrap().campaign, campaign);
    let refused = db.raw("UPDATE campaigns SET note = note").unwrap_err();
    assert!(refused.contains("append-only"), "{refused}");
    // Opening again migrates nothing more.
    drop(store);
    assert_eq!(db.store().schema_version().unwrap(), SCHEMA_VERSION);
    assert_eq!(db.raw_count("SELECT COUNT(*) FROM schema_migrations"), 2);
}

fn unknown_names_are_clear_errors(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let mut store = db.store();
    store.add(&sample("mill-7", "2024-05-01", 0.0)).unwrap();
    let error = store.series("mill-8", "EX0C").unwrap_err().to_string();
    assert!(error.contains("no machine named \"mill-8\""), "{error}");
    let error = store.campaigns("mill-8").unwrap_err().to_string();
    assert!(error.contains("no machine named \"mill-8\""), "{error}");
    let error = store.series("mill-7", "EX0D").unwrap_err().to_string();
    assert!(error.contains("no parameter \"EX0D\""), "{error}");
    let error = store.campaign(CampaignId(42)).unwrap_err().to_string();
    assert!(error.contains("no campaign 42"), "{error}");
    // The not-identifiable parameter's series: statuses, no numbers.
    let series = store.series("mill-7", "EZ0A").unwrap();
    assert_eq!(series[0].status, ParameterStatus::NotIdentifiable);
    assert_eq!((series[0].value, series[0].u95), (None, None));
}

fn invalid_campaigns_are_refused_before_writing(kind: Kind) {
    let Some(db) = TestDb::new(kind) else { return };
    let mut store = db.store();
    let good = sample("mill-7", "2024-05-01", 0.0);
    let mut cases: Vec<(Campaign, &str)> = Vec::new();
    let mut c = good.clone();
    c.parameters[3].value = Some(1.0);
    c.parameters[3].u95 = Some(1.0);
    cases.push((c, "must carry no number"));
    let mut c = good.clone();
    c.parameters[0].value = Some(f64::NAN);
    cases.push((c, "not a finite number"));
    let mut c = good.clone();
    c.parameters[0].u95 = None;
    cases.push((c, "EX0C's u95 is missing"));
    let mut c = good.clone();
    c.parameters
        .push(Parameter::identified("EX0C", 1.0, 1.0, "um"));
    cases.push((c, "appears twice"));
    let mut c = good.clone();
    c.machine = MachineIdentity {
        name: "  ".into(),
        urdf_digest: None,
        error_model_digest: None,
    };
    cases.push((c, "machine name is empty"));
    let mut c = good.clone();
    c.parameters[2].expression = None;
    cases.push((c, "needs its expression"));
    let mut c = good.clone();
    c.parameters[0].unit = Some(String::new());
    cases.push((c, "unit is empty"));
    for (campaign, why) in cases {
        // In a batch with a good one: nothing of the batch is written.
        let error = store
            .add_many(&[good.clone(), campaign], |_| {})
            .unwrap_err()
            .to_string();
        assert!(error.contains(why), "{why}: {error}");
    }
    assert!(store.machines().unwrap().is_empty());
}

/// SQLite only: files that are not a history, or no longer one.
mod sqlite_files {
    use super::*;

    #[test]
    fn a_file_that_is_not_sqlite_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("readings.csv");
        let text = "x,y,z\n1,2,3\n".repeat(200);
        std::fs::write(&path, &text).unwrap();
        let error = Store::open(path.to_str().unwrap()).unwrap_err();
        let message = error.to_string();
        assert!(matches!(error, Error::NotAHistory { .. }), "{message}");
        assert!(message.contains(&path.display().to_string()), "{message}");
        assert!(message.contains("not an SQLite database"), "{message}");
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            text,
            "file changed"
        );
    }

    #[test]
    fn a_damaged_history_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("history.sqlite");
        let url = path.to_str().unwrap().to_string();
        {
            let mut store = Store::open(&url).unwrap();
            for k in 0..20 {
                store
                    .add(&sample("mill-7", "2024-05-01", k as f64))
                    .unwrap();
            }
        }
        // Overwrite the schema table's page after the file header: the file still says
        // SQLite, but its content is garbage.
        let mut bytes = std::fs::read(&path).unwrap();
        assert!(
            bytes.len() > 4096,
            "the history is checkpointed into its file"
        );
        for (i, b) in bytes[100..4096].iter_mut().enumerate() {
            *b = (i * 7 + 13) as u8;
        }
        std::fs::write(&path, &bytes).unwrap();
        let error = Store::open(&url).unwrap_err();
        let message = error.to_string();
        assert!(matches!(error, Error::Corrupt { .. }), "{message}");
        assert!(message.contains(&url), "{message}");
        assert!(message.contains("damaged"), "{message}");
    }

    #[test]
    fn paths_that_cannot_hold_a_history_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().to_str().unwrap().to_string();
        let message = Store::open(&folder).unwrap_err().to_string();
        assert!(
            message.contains(&folder) && message.contains("folder"),
            "{message}"
        );
        let missing = dir.path().join("no/such/dir/history.sqlite");
        let missing = missing.to_str().unwrap();
        let message = Store::open(missing).unwrap_err().to_string();
        assert!(
            message.contains(missing) && message.contains("cannot open"),
            "{message}"
        );
    }

    #[test]
    fn every_spelling_of_a_path_opens_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.sqlite");
        let id = Store::open(path.to_str().unwrap())
            .unwrap()
            .add(&sample("mill-7", "2024-05-01", 0.0))
            .unwrap();
        for url in [
            format!("sqlite:{}", path.display()),
            format!("sqlite://{}", path.display()),
        ] {
            let store = Store::open(&url).unwrap();
            assert_eq!(store.backend(), Backend::Sqlite);
            assert!(store.campaign(id).is_ok(), "{url}");
        }
    }

    #[test]
    fn an_unreachable_server_is_named_without_its_password() {
        // Port 1 on the loopback: nothing listens there.
        let url = "postgres://shop:s3cret@127.0.0.1:1/mtcal?connect_timeout=2";
        let message = Store::open(url).unwrap_err().to_string();
        assert!(
            message.contains("postgres://shop:***@127.0.0.1:1/mtcal"),
            "{message}"
        );
        assert!(!message.contains("s3cret"), "{message}");
    }
}
