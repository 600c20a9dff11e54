//! The two back ends behind one small interface: statements with `?` placeholders and a few
//! parameter and column types, prepared once per connection, and transactions that roll back
//! unless committed. Everything above this module is written once for both.

use crate::Error;
use postgres::types::{IsNull, ToSql, Type, to_sql_checked};
use rusqlite::types::{ToSqlOutput, ValueRef};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::Path;

/// The database dialect, where the schema must be written twice.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Dialect {
    Sqlite,
    Postgres,
}

/// A statement parameter, bound to either back end.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Param<'a> {
    Int(i64),
    Real(Option<f64>),
    Text(Option<&'a str>),
    Bool(bool),
}

impl rusqlite::ToSql for Param<'_> {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(match *self {
            Param::Int(v) => ToSqlOutput::from(v),
            Param::Real(Some(v)) => ToSqlOutput::from(v),
            Param::Real(None) | Param::Text(None) => ToSqlOutput::from(rusqlite::types::Null),
            Param::Text(Some(s)) => ToSqlOutput::Borrowed(ValueRef::Text(s.as_bytes())),
            Param::Bool(v) => ToSqlOutput::from(v),
        })
    }
}

impl ToSql for Param<'_> {
    /// Each variant checks the column type itself: a mismatch is an error, never wrong bytes.
    fn to_sql(
        &self,
        ty: &Type,
        out: &mut bytes::BytesMut,
    ) -> Result<IsNull, Box<dyn std::error::Error + Sync + Send>> {
        match self {
            Param::Int(v) => v.to_sql_checked(ty, out),
            Param::Real(v) => v.to_sql_checked(ty, out),
            Param::Text(v) => v.to_sql_checked(ty, out),
            Param::Bool(v) => v.to_sql_checked(ty, out),
        }
    }

    fn accepts(ty: &Type) -> bool {
        <i64 as ToSql>::accepts(ty)
            || <f64 as ToSql>::accepts(ty)
            || <&str as ToSql>::accepts(ty)
            || <bool as ToSql>::accepts(ty)
    }

    to_sql_checked!();
}

/// What went wrong in the database, before it is told with the database's location.
#[derive(Debug)]
pub(crate) struct Failure {
    pub kind: FailureKind,
    pub detail: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FailureKind {
    NotADatabase,
    Corrupt,
    CannotOpen,
    /// Another connection holds a lock SQLite will not wait for (it returns at once where
    /// waiting could deadlock, as when two processes make a new file a history together).
    Busy,
    Other,
}

impl Failure {
    pub fn other(detail: impl Into<String>) -> Failure {
        Failure {
            kind: FailureKind::Other,
            detail: detail.into(),
        }
    }
}

fn sqlite_failure(error: rusqlite::Error) -> Failure {
    use rusqlite::ErrorCode;
    let kind = match error.sqlite_error_code() {
        Some(ErrorCode::NotADatabase) => FailureKind::NotADatabase,
        Some(ErrorCode::DatabaseCorrupt) => FailureKind::Corrupt,
        Some(ErrorCode::CannotOpen) => FailureKind::CannotOpen,
        Some(ErrorCode::DatabaseBusy | ErrorCode::DatabaseLocked) => FailureKind::Busy,
        _ => FailureKind::Other,
    };
    Failure {
        kind,
        detail: error.to_string(),
    }
}

fn postgres_failure(error: postgres::Error) -> Failure {
    // The server's own message (with its detail) rather than the client's "db error".
    let detail = match error.as_db_error() {
        Some(db) => match db.detail() {
            Some(more) => format!("{}: {} ({more})", db.severity(), db.message()),
            None => format!("{}: {}", db.severity(), db.message()),
        },
        None => error.to_string(),
    };
    Failure::other(detail)
}

/// One result row, whichever back end produced it.
pub(crate) trait Row {
    fn int(&self, i: usize) -> Result<i64, Failure>;
    fn real(&self, i: usize) -> Result<Option<f64>, Failure>;
    fn text(&self, i: usize) -> Result<Option<String>, Failure>;
    fn flag(&self, i: usize) -> Result<bool, Failure>;

    /// A text column that may not be NULL.
    fn required_text(&self, i: usize) -> Result<String, Failure> {
        self.text(i)?
            .ok_or_else(|| Failure::other(format!("column {i} is unexpectedly NULL")))
    }
}

struct SqliteRow<'a, 'b>(&'a rusqlite::Row<'b>);

impl Row for SqliteRow<'_, '_> {
    fn int(&self, i: usize) -> Result<i64, Failure> {
        self.0.get(i).map_err(sqlite_failure)
    }
    fn real(&self, i: usize) -> Result<Option<f64>, Failure> {
        self.0.get(i).map_err(sqlite_failure)
    }
    fn text(&self, i: usize) -> Result<Option<String>, Failure> {
        self.0.get(i).map_err(sqlite_failure)
    }
    fn flag(&self, i: usize) -> Result<bool, Failure> {
        self.0.get(i).map_err(sqlite_failure)
    }
}

struct PostgresRow<'a>(&'a postgres::Row);

impl Row for PostgresRow<'_> {
    fn int(&self, i: usize) -> Result<i64, Failure> {
        self.0.try_get(i).map_err(postgres_failure)
    }
    fn real(&self, i: usize) -> Result<Option<f64>, Failure> {
        self.0.try_get(i).map_err(postgres_failure)
    }
    fn text(&self, i: usize) -> Result<Option<String>, Failure> {
        self.0.try_get(i).map_err(postgres_failure)
    }
    fn flag(&self, i: usize) -> Result<bool, Failure> {
        self.0.try_get(i).map_err(postgres_failure)
    }
}

struct Postgres {
    client: postgres::Client,
    /// Statements prepared on this connection, by their `?` text.
    statements: HashMap<&'static str, postgres::Statement>,
}

impl Postgres {
    fn statement(&mut self, sql: &'static str) -> Result<postgres::Statement, Failure> {
        if let Some(statement) = self.statements.get(sql) {
            return Ok(statement.clone());
        }
        let statement = self
            .client
            .prepare(&numbered_placeholders(sql))
            .map_err(postgres_failure)?;
        self.statements.insert(sql, statement.clone());
        Ok(statement)
    }
}

enum Connection {
    Sqlite(rusqlite::Connection),
    /// postgres' client needs `&mut` for every call; the store's reads take `&self`.
    Postgres(Box<RefCell<Postgres>>),
}

/// An open database and where it is (for every error message).
pub(crate) struct Db {
    location: String,
    connection: Connection,
}

impl std::fmt::Debug for Db {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Db")
            .field("location", &self.location)
            .field("dialect", &self.dialect())
            .finish()
    }
}

impl Db {
    /// Opens (creating when absent) an SQLite file; waits up to `busy` for another writer.
    pub fn open_sqlite(path: &Path, busy: std::time::Duration) -> Result<Db, Error> {
        use rusqlite::OpenFlags;
        let location = path.display().to_string();
        let flags = OpenFlags::SQLITE_OPEN_READ_WRITE
            | OpenFlags::SQLITE_OPEN_CREATE
            | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let open_error = |e: rusqlite::Error| Error::Open {
            location: location.clone(),
            detail: e.to_string(),
        };
        let connection = rusqlite::Connection::open_with_flags(path, flags).map_err(open_error)?;
        connection.busy_timeout(busy).map_err(open_error)?;
        connection.set_prepared_statement_cache_capacity(64);
        Ok(Db {
            location,
            connection: Connection::Sqlite(connection),
        })
    }

    /// Connects to a PostgreSQL server (no TLS: a shop's server on its own network, or a
    /// local socket).
    pub fn open_postgres(url: &str) -> Result<Db, Error> {
        let location = redacted(url);
        let client = postgres::Client::connect(url, postgres::NoTls).map_err(|e| Error::Open {
            location: location.clone(),
            detail: postgres_failure(e).detail,
        })?;
        Ok(Db {
            location,
            connection: Connection::Postgres(Box::new(RefCell::new(Postgres {
                client,
                statements: HashMap::new(),
            }))),
        })
    }

    pub fn location(&self) -> &str {
        &self.location
    }

    pub fn dialect(&self) -> Dialect {
        match self.connection {
            Connection::Sqlite(_) => Dialect::Sqlite,
            Connection::Postgres(_) => Dialect::Postgres,
        }
    }

    /// The error a failure is, told with this database's location.
    pub fn error(&self, failure: Failure) -> Error {
        let location = self.location.clone();
        let detail = failure.detail;
        match failure.kind {
            FailureKind::NotADatabase => Error::NotAHistory {
                location,
                why: format!("it is not an SQLite database ({detail})"),
            },
            FailureKind::Corrupt => Error::Corrupt { location, detail },
            FailureKind::CannotOpen => Error::Open { location, detail },
            FailureKind::Busy => Error::Busy { location, detail },
            FailureKind::Other => Error::Database { location, detail },
        }
    }

    /// Statements without parameters, separated by `;` (the schema).
    pub fn batch(&self, sql: &str) -> Result<(), Error> {
        let result = match &self.connection {
            Connection::Sqlite(c) => c.execute_batch(sql).map_err(sqlite_failure),
            Connection::Postgres(pg) => pg
                .borrow_mut()
                .client
                .batch_execute(sql)
                .map_err(postgres_failure),
        };
        result.map_err(|f| self.error(f))
    }

    /// Runs one statement; the number of rows it changed.
    pub fn execute(&self, sql: &'static str, params: &[Param<'_>]) -> Result<u64, Error> {
        let result = match &self.connection {
            Connection::Sqlite(c) => c
                .prepare_cached(sql)
                .and_then(|mut s| s.execute(rusqlite::params_from_iter(params)))
                .map(|n| n as u64)
                .map_err(sqlite_failure),
            Connection::Postgres(pg) => {
                let mut pg = pg.borrow_mut();
                pg.statement(sql).and_then(|statement| {
                    pg.client
                        .execute(&statement, &postgres_params(params))
                        .map_err(postgres_failure)
                })
            }
        };
        result.map_err(|f| self.error(f))
    }

    /// Every row of a query, each decoded by `decode`.
    pub fn query<T>(
        &self,
        sql: &'static str,
        params: &[Param<'_>],
        mut decode: impl FnMut(&dyn Row) -> Result<T, Failure>,
    ) -> Result<Vec<T>, Error> {
        let result = match &self.connection {
            Connection::Sqlite(c) => sqlite_query(c, sql, params, &mut decode),
            Connection::Postgres(pg) => {
                let mut pg = pg.borrow_mut();
                pg.statement(sql).and_then(|statement| {
                    let rows = pg
                        .client
                        .query(&statement, &postgres_params(params))
                        .map_err(postgres_failure)?;
                    rows.iter().map(|r| decode(&PostgresRow(r))).collect()
                })
            }
        };
        result.map_err(|f| self.error(f))
    }

    /// The one row a query must return.
    pub fn query_one<T>(
        &self,
        sql: &'static str,
        params: &[Param<'_>],
        decode: impl FnMut(&dyn Row) -> Result<T, Failure>,
    ) -> Result<T, Error> {
        let mut rows = self.query(sql, params, decode)?;
        if rows.len() != 1 {
            return Err(self.error(Failure::other(format!(
                "expected one row, got {} from: {sql}",
                rows.len()
            ))));
        }
        Ok(rows.remove(0))
    }

    /// A transaction that writes: on SQLite it takes the write lock at once (`BEGIN
    /// IMMEDIATE`), so two writers queue at the start instead of one failing at its first
    /// write.
    pub fn write_transaction(&self) -> Result<Transaction<'_>, Error> {
        self.batch(match self.dialect() {
            Dialect::Sqlite => "BEGIN IMMEDIATE",
            Dialect::Postgres => "BEGIN",
        })?;
        Ok(Transaction {
            db: self,
            done: false,
        })
    }

    /// A transaction that only reads: one consistent snapshot for several queries.
    pub fn read_transaction(&self) -> Result<Transaction<'_>, Error> {
        self.batch(match self.dialect() {
            Dialect::Sqlite => "BEGIN DEFERRED",
            Dialect::Postgres => "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY",
        })?;
        Ok(Transaction {
            db: self,
            done: false,
        })
    }
}

fn sqlite_query<T>(
    connection: &rusqlite::Connection,
    sql: &str,
    params: &[Param<'_>],
    decode: &mut impl FnMut(&dyn Row) -> Result<T, Failure>,
) -> Result<Vec<T>, Failure> {
    let mut statement = connection.prepare_cached(sql).map_err(sqlite_failure)?;
    let mut rows = statement
        .query(rusqlite::params_from_iter(params))
        .map_err(sqlite_failure)?;
    let mut out = Vec::new();
    while let Some(row) = rows.next().map_err(sqlite_failure)? {
        out.push(decode(&SqliteRow(row))?);
    }
    Ok(out)
}

fn postgres_params<'a>(params: &'a [Param<'a>]) -> Vec<&'a (dyn ToSql + Sync)> {
    params.iter().map(|p| p as &(dyn ToSql + Sync)).collect()
}

/// An open transaction; rolled back when dropped uncommitted (an error or a panic part-way
/// leaves nothing behind).
pub(crate) struct Transaction<'a> {
    db: &'a Db,
    done: bool,
}

impl Transaction<'_> {
    pub fn commit(mut self) -> Result<(), Error> {
        self.done = true;
        self.db.batch("COMMIT")
    }
}

impl Drop for Transaction<'_> {
    fn drop(&mut self) {
        if !self.done {
            // Nothing to report: the transaction failed already, and an error in rolling back
            // (a lost connection) means the server rolls back itself.
            let _ = self.db.batch("ROLLBACK");
        }
    }
}

/// `?` placeholders as PostgreSQL's `$1, $2, …` (the shared SQL has no `?` in literals).
fn numbered_placeholders(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len() + 16);
    let mut n = 0;
    for c in sql.chars() {
        if c == '?' {
            n += 1;
            out.push_str(&format!("${n}"));
        } else {
            out.push(c);
        }
    }
    out
}

/// A URL fit for messages: its password replaced by `***`.
pub(crate) fn redacted(url: &str) -> String {
    let Some(scheme_end) = url.find("://") else {
        return url.to_string();
    };
    let rest = &url[scheme_end + 3..];
    let authority_end = rest.find(['/', '?']).unwrap_or(rest.len());
    let authority = &rest[..authority_end];
    let authority = match authority.rfind('@') {
        Some(at) => match authority[..at].find(':') {
            Some(colon) => format!("{}:***{}", &authority[..colon], &authority[at..]),
            None => authority.to_string(),
        },
        None => authority.to_string(),
    };
    let tail = redact_query_password(&rest[authority_end..]);
    format!("{}{authority}{tail}", &url[..scheme_end + 3])
}

fn redact_query_password(tail: &str) -> String {
    let Some(q) = tail.find('?') else {
        return tail.to_string();
    };
    let pairs: Vec<String> = tail[q + 1..]
        .split('&')
        .map(|pair| match pair.split_once('=') {
            Some((key, _)) if key == "password" => format!("{key}=***"),
            _ => pair.to_string(),
        })
        .collect();
    format!("{}?{}", &tail[..q], pairs.join("&"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_are_numbered_in_order() {
        assert_eq!(
            numbered_placeholders("SELECT a FROM t WHERE b = ? AND c IN (?, ?)"),
            "SELECT a FROM t WHERE b = $1 AND c IN ($2, $3)"
        );
    }

    #[test]
    fn passwords_never_reach_a_message() {
        assert_eq!(
            redacted("postgres://shop:s3cret@db.local:5432/mtcal?options=-c%20x"),
            "postgres://shop:***@db.local:5432/mtcal?options=-c%20x"
        );
        assert_eq!(
            redacted("postgresql://db.local/mtcal?user=a&password=s3cret"),
            "postgresql://db.local/mtcal?user=a&password=***"
        );
        assert_eq!(
            redacted("postgres://shop@db.local/mtcal"),
            "postgres://shop@db.local/mtcal"
        );
    }
}
