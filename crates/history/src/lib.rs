//! The machine history: every calibration campaign of every machine kept, append-only, in one
//! database — an SQLite file for a single user, a PostgreSQL server for a shop — and the
//! queries the trend and fleet views need. Storage and queries only: the statistics of a
//! series (drift, change points) are `mtcal-trend`'s.
//!
//! # Database crates
//! [`rusqlite`] with its `bundled` feature (the SQLite C library compiled into the binary:
//! nothing to install, the same SQLite everywhere) and [`postgres`], the synchronous client of
//! rust-postgres. Both are synchronous like the rest of mtcal, so no async runtime shows in the
//! API (sqlx would bring one and check queries against a live database at build time). One
//! [`Store`] type serves both back ends; the SQL is shared where the dialects agree (every
//! query and insert: `?` placeholders become `$n` for PostgreSQL) and written twice only for
//! the schema (identity columns, `WITHOUT ROWID`, trigger syntax).
//!
//! # Opening
//! [`Store::open`] takes a path, `sqlite:PATH`, or a `postgres://…` / `postgresql://…` URL. An
//! SQLite file is created when absent and put in WAL mode (readers never wait for a writer; two
//! writers take turns, waiting up to [`BUSY_TIMEOUT`]). On PostgreSQL the history lives in the
//! connection's current schema: choose another with `?options=-c%20search_path%3Dmtcal`.
//!
//! # Schema and migrations
//! A marker table `mtcal_history` (`format = mtcal.history`) says a database is a history;
//! `schema_migrations` lists the migrations applied ([`SCHEMA_VERSION`] is the newest this code
//! knows). Opening an empty database creates the schema; an older version is migrated in one
//! transaction; a newer one, a database with other tables, a file that is not SQLite or a
//! damaged one are clear errors naming the file ([`Error`]). Migration 1 creates every table;
//! migration 2 makes the database itself refuse `UPDATE`, `DELETE` (and on PostgreSQL
//! `TRUNCATE`) of stored campaigns.
//!
//! # What a campaign holds
//! [`Campaign`]: the machine (a name chosen by the user, the digests of its URDF and
//! error-model files), the date (UTC, stored to the second), the session's digest, the mtcal
//! version, the instruments, the fit (RMS, χ²/dof, convergence), the validation runs, the
//! discoveries and every parameter with its identifiability ([`ParameterStatus`]: a parameter
//! the data cannot determine stores no number), optionally a temperature and a note.
//! [`Campaign::from_identify_json`] reads mtcal's `mtcal.identify/1` JSON.
//!
//! # Concurrency
//! Any number of processes may read and write one history. On PostgreSQL writers run side by
//! side; on SQLite they take turns (`BEGIN IMMEDIATE`, waiting up to [`BUSY_TIMEOUT`]; the
//! lock is not a queue, so a process that writes without pause can keep another waiting).
//! Two writers creating the same new machine or parameter name both end up using one row.
//!
//! # Scale
//! `cargo bench -p mtcal-history --bench history` (SQLite, 1,000 machines × 500 campaigns ×
//! 20 parameters, a 620 MB file, warm cache, 2-core machine): [`Store::fleet`] 59 ms,
//! [`Store::series`] of one machine's parameter 1.3 ms, [`Store::machines`] 77 ms,
//! [`Store::open`] 0.2 ms.
//!
//! # What the history says
//! [`trend_view`] picks one parameter's series out of the store and asks `mtcal-trend` what it
//! says (changes between campaigns, drift, step, tolerance, next check); [`fleet_view`] sets
//! every machine's latest campaign against the parameter tolerances. Both serialise for
//! `--json` and print for a person.
//!
//! # Append-only
//! A campaign is written once, in one transaction with all its rows ([`Store::add`]: a crash
//! leaves nothing partial) and never changed: there is no update path, and from schema 2 on the
//! database refuses one. A campaign found wrong is [`Store::supersede`]d by a later one with a
//! reason; both stay, and every query says which are superseded.

mod campaign;
mod date;
mod db;
mod digest;
mod identify_json;
mod provenance;
mod query;
mod schema;
mod store;
mod view;

pub use campaign::{
    Campaign, DiscoverySummary, FitSummary, MachineIdentity, Parameter, ParameterStatus,
    ValidationRun,
};
pub use date::parse_date;
pub use digest::{DigestError, digest_files, digest_text};
pub use jiff::Timestamp;
pub use provenance::{Provenance, newest_modification};
pub use query::{CampaignRecord, CampaignRow, FleetRow, MachineSummary, SeriesPoint, Supersession};
pub use schema::SCHEMA_VERSION;
pub use store::{BUSY_TIMEOUT, Backend, Store};
pub use view::{
    FleetLine, Limits, MachineDrifts, ThermalView, TrendView, fleet_drift_rates, fleet_text,
    fleet_view, latest_parameters, machine_trends, thermal_view, trend_view,
};

use serde::{Deserialize, Serialize};

/// A campaign's number in its history: assigned when it is added, never reused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct CampaignId(pub i64);

impl std::fmt::Display for CampaignId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Everything that can go wrong; `location` is the file path or the PostgreSQL URL (without
/// its password).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("cannot open the history {location}: {detail}")]
    Open { location: String, detail: String },
    #[error("{location} is not an mtcal history: {why}")]
    NotAHistory { location: String, why: String },
    #[error("{location} is damaged (SQLite reports: {detail}); restore it from a backup")]
    Corrupt { location: String, detail: String },
    #[error(
        "{location} has history schema version {found}, newer than the {known} this mtcal \
         knows: open it with a newer mtcal"
    )]
    NewerSchema {
        location: String,
        found: i64,
        known: i64,
    },
    #[error("{location}: {detail}")]
    Database { location: String, detail: String },
    #[error("{location} is in use by another process, which did not let go ({detail})")]
    Busy { location: String, detail: String },
    #[error("identify JSON: {0}")]
    IdentifyJson(String),
    #[error("invalid campaign: {0}")]
    InvalidCampaign(String),
    #[error(transparent)]
    Digest(#[from] DigestError),
    #[error("{detail}")]
    FileDate { detail: String },
    #[error("invalid date {text:?}: {detail}")]
    Date { text: String, detail: String },
    #[error("{location}: no machine named {name:?}")]
    UnknownMachine { location: String, name: String },
    #[error("{location}: machine {machine:?} has no parameter {parameter:?} in any campaign")]
    UnknownParameter {
        location: String,
        machine: String,
        parameter: String,
    },
    #[error("{location}: no campaign {id}")]
    UnknownCampaign { location: String, id: CampaignId },
    #[error("{location}: campaign {id} cannot be superseded by {by}: {why}")]
    Supersede {
        location: String,
        id: CampaignId,
        by: CampaignId,
        why: String,
    },
}
