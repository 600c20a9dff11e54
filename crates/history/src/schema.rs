//! The versioned schema: what a database is (empty, an mtcal history of some version, or
//! something else), and the migrations that bring a history to [`SCHEMA_VERSION`] — all of
//! them in one transaction, so a crash part-way leaves the version it had.

use crate::Error;
use crate::db::{Db, Dialect, Failure, Param};

/// The newest schema this code knows.
pub const SCHEMA_VERSION: i64 = 2;

/// The marker that says a database is a history.
const FORMAT: &str = "mtcal.history";

/// Serialises concurrent migrations of one PostgreSQL database (an arbitrary fixed key:
/// "mtcal-hi" in ASCII).
const POSTGRES_MIGRATION_LOCK: i64 = 0x6d74_6361_6c2d_6869;

struct Migration {
    version: i64,
    description: &'static str,
    sqlite: &'static str,
    postgres: &'static str,
}

const MIGRATIONS: &[Migration] = &[
    Migration {
        version: 1,
        description: "machines, campaigns, parameters, instruments, validation runs, \
                      discoveries, supersessions",
        sqlite: include_str!("schema/1.sqlite.sql"),
        postgres: include_str!("schema/1.postgres.sql"),
    },
    Migration {
        version: 2,
        description: "the database refuses to change or delete stored campaigns",
        sqlite: include_str!("schema/2.sqlite.sql"),
        postgres: include_str!("schema/2.postgres.sql"),
    },
];

/// What an opened database holds.
#[derive(Debug, PartialEq, Eq)]
enum State {
    /// No table at all: a new history.
    Empty,
    /// A history at this schema version.
    History(i64),
}

/// Makes `db` a history at `target` (normally [`SCHEMA_VERSION`]), creating or migrating it,
/// or says why it cannot be one.
pub(crate) fn prepare(db: &Db, target: i64) -> Result<(), Error> {
    let known = MIGRATIONS.last().map_or(0, |m| m.version);
    debug_assert_eq!(known, SCHEMA_VERSION);
    if !(1..=known).contains(&target) {
        return Err(db.error(Failure::other(format!(
            "no schema version {target} (1..={known})"
        ))));
    }
    if state(db)? == State::History(target) {
        return Ok(());
    }
    migrate(db, target)
}

/// The schema version of a history.
pub(crate) fn version(db: &Db) -> Result<i64, Error> {
    match state(db)? {
        State::History(v) => Ok(v),
        State::Empty => Err(not_a_history(db, "it is empty".into())),
    }
}

fn migrate(db: &Db, target: i64) -> Result<(), Error> {
    if db.dialect() == Dialect::Sqlite {
        // WAL: readers see the last commit while a writer writes. Only once the file is
        // known to be a history or empty: a foreign file is never changed.
        db.query("PRAGMA journal_mode = WAL", &[], |r| r.text(0))?;
    }
    let transaction = db.write_transaction()?;
    if db.dialect() == Dialect::Postgres {
        db.execute(
            "SELECT pg_advisory_xact_lock(?)",
            &[Param::Int(POSTGRES_MIGRATION_LOCK)],
        )?;
    }
    // Again inside the lock: another process may have migrated since the first look.
    let from = match state(db)? {
        State::Empty => 0,
        State::History(v) => v,
    };
    for migration in MIGRATIONS
        .iter()
        .filter(|m| m.version > from && m.version <= target)
    {
        apply(db, migration)?;
    }
    transaction.commit()
}

fn apply(db: &Db, migration: &Migration) -> Result<(), Error> {
    db.batch(match db.dialect() {
        Dialect::Sqlite => migration.sqlite,
        Dialect::Postgres => migration.postgres,
    })?;
    if migration.version == 1 {
        db.execute(
            "INSERT INTO mtcal_history (key, value) VALUES ('format', ?), ('created_utc', ?)",
            &[
                Param::Text(Some(FORMAT)),
                Param::Text(Some(&crate::date::now_stored())),
            ],
        )?;
    }
    db.execute(
        "INSERT INTO schema_migrations (version, description, applied_utc) VALUES (?, ?, ?)",
        &[
            Param::Int(migration.version),
            Param::Text(Some(migration.description)),
            Param::Text(Some(&crate::date::now_stored())),
        ],
    )?;
    Ok(())
}

/// Looks without changing anything.
fn state(db: &Db) -> Result<State, Error> {
    let tables = tables(db)?;
    if tables.is_empty() {
        return Ok(State::Empty);
    }
    if !tables.iter().any(|t| t == "mtcal_history") {
        return Err(not_a_history(db, foreign_tables(&tables)));
    }
    let format = db.query(
        "SELECT value FROM mtcal_history WHERE key = 'format'",
        &[],
        |r| r.required_text(0),
    )?;
    if format.first().map(String::as_str) != Some(FORMAT) {
        return Err(not_a_history(
            db,
            format!("its mtcal_history table says format {format:?}, not {FORMAT:?}"),
        ));
    }
    let found = db.query_one(
        "SELECT COALESCE(MAX(version), 0) FROM schema_migrations",
        &[],
        |r| r.int(0),
    )?;
    if found > SCHEMA_VERSION {
        return Err(Error::NewerSchema {
            location: db.location().to_string(),
            found,
            known: SCHEMA_VERSION,
        });
    }
    Ok(State::History(found))
}

fn tables(db: &Db) -> Result<Vec<String>, Error> {
    match db.dialect() {
        Dialect::Sqlite => db.query(
            "SELECT name FROM sqlite_master WHERE type IN ('table', 'view') \
             AND name NOT LIKE 'sqlite_%' ORDER BY name",
            &[],
            |r| r.required_text(0),
        ),
        Dialect::Postgres => {
            let schema = db.query_one("SELECT current_schema()::text", &[], |r| r.text(0))?;
            if schema.is_none() {
                return Err(db.error(Failure::other(
                    "the connection has no current schema: the schema named by its \
                     search_path does not exist",
                )));
            }
            db.query(
                "SELECT table_name::text FROM information_schema.tables \
                 WHERE table_schema = current_schema() ORDER BY table_name",
                &[],
                |r| r.required_text(0),
            )
        }
    }
}

fn foreign_tables(tables: &[String]) -> String {
    const SHOWN: usize = 5;
    let mut list = tables
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if tables.len() > SHOWN {
        list.push_str(&format!(" and {} more", tables.len() - SHOWN));
    }
    format!("it holds other tables ({list}) and no mtcal_history table")
}

fn not_a_history(db: &Db, why: String) -> Error {
    Error::NotAHistory {
        location: db.location().to_string(),
        why,
    }
}
