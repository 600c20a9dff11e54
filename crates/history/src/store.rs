//! The store: opening either back end, and the only two ways to write — adding campaigns
//! (each call one transaction) and marking one superseded by a later one.

use crate::campaign::{Campaign, Parameter};
use crate::db::{Db, Param};
use crate::{CampaignId, Error, date, schema};
use std::collections::{BTreeSet, HashMap};
use std::path::Path;
use std::time::Duration;

/// How long a writer waits for another writer of the same SQLite file before giving up.
pub const BUSY_TIMEOUT: Duration = Duration::from_secs(60);

/// Which database a store is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    Sqlite,
    Postgres,
}

/// A machine history: an SQLite file or a PostgreSQL database. Writes take `&mut self`, reads
/// `&self`; two stores (in two processes or threads) on one database may write at once.
#[derive(Debug)]
pub struct Store {
    pub(crate) db: Db,
}

impl Store {
    /// Opens the history at `url_or_path`: `postgres://…` or `postgresql://…` is a PostgreSQL
    /// server, anything else an SQLite file (`sqlite:PATH` or a plain path), created when
    /// absent. An empty database becomes a history; an older one is migrated.
    pub fn open(url_or_path: &str) -> Result<Store, Error> {
        Store::open_at_version(url_or_path, schema::SCHEMA_VERSION)
    }

    /// As [`Store::open`], but creating or migrating the history only up to schema `version`:
    /// for the tests of the migrations, which need a history as an older mtcal left it.
    #[doc(hidden)]
    pub fn open_at_version(url_or_path: &str, version: i64) -> Result<Store, Error> {
        let db = connect(url_or_path)?;
        // Two processes making a new SQLite file a history at once: where waiting could
        // deadlock SQLite says "busy" at once instead of waiting, so the open is tried again
        // (the migration is one transaction, and the second process finds it done).
        let started = std::time::Instant::now();
        loop {
            match schema::prepare(&db, version) {
                Err(Error::Busy { .. }) if started.elapsed() < BUSY_TIMEOUT => {
                    std::thread::sleep(Duration::from_millis(5));
                }
                result => return result.map(|()| Store { db }),
            }
        }
    }

    /// The file path, or the URL without its password.
    pub fn location(&self) -> &str {
        self.db.location()
    }

    pub fn backend(&self) -> Backend {
        match self.db.dialect() {
            crate::db::Dialect::Sqlite => Backend::Sqlite,
            crate::db::Dialect::Postgres => Backend::Postgres,
        }
    }

    /// The schema version of the history ([`crate::SCHEMA_VERSION`] once opened).
    pub fn schema_version(&self) -> Result<i64, Error> {
        schema::version(&self.db)
    }

    /// Adds one campaign, all its rows in one transaction. Never replaces anything: the same
    /// campaign added twice is two campaigns.
    pub fn add(&mut self, campaign: &Campaign) -> Result<CampaignId, Error> {
        let ids = self.add_many(std::slice::from_ref(campaign), |_| {})?;
        Ok(ids[0])
    }

    /// Adds campaigns in one transaction (an import): all or none are stored. `progress` is
    /// called with the number written so far, inside the transaction — nothing is visible to
    /// other connections until the last is written and the transaction commits.
    pub fn add_many(
        &mut self,
        campaigns: &[Campaign],
        mut progress: impl FnMut(usize),
    ) -> Result<Vec<CampaignId>, Error> {
        for campaign in campaigns {
            campaign.check()?;
        }
        let transaction = self.db.write_transaction()?;
        let mut writer = Writer::new(&self.db, campaigns)?;
        let mut ids = Vec::with_capacity(campaigns.len());
        for (i, campaign) in campaigns.iter().enumerate() {
            ids.push(writer.campaign(campaign)?);
            progress(i + 1);
        }
        transaction.commit()?;
        Ok(ids)
    }

    /// Marks campaign `id` superseded by `by`, a later campaign (by date, then by number) of
    /// the same machine, for `reason`. Both stay; a campaign is superseded at most once.
    pub fn supersede(&mut self, id: CampaignId, by: CampaignId, reason: &str) -> Result<(), Error> {
        let refuse = |why: String| Error::Supersede {
            location: self.db.location().to_string(),
            id,
            by,
            why,
        };
        if reason.trim().is_empty() {
            return Err(refuse("a reason is required".into()));
        }
        if id == by {
            return Err(refuse("a campaign cannot supersede itself".into()));
        }
        let transaction = self.db.write_transaction()?;
        let old = self.placed(id)?;
        let new = self.placed(by)?;
        if old.machine != new.machine {
            return Err(refuse(format!(
                "{id} is of machine {:?} and {by} of machine {:?}",
                old.machine, new.machine
            )));
        }
        if (&new.date, by) <= (&old.date, id) {
            return Err(refuse(format!(
                "{by} ({}) is not later than {id} ({})",
                new.date, old.date
            )));
        }
        let inserted = self.db.execute(
            "INSERT INTO supersessions (campaign_id, superseded_by, reason, at_utc) \
             VALUES (?, ?, ?, ?) ON CONFLICT (campaign_id) DO NOTHING",
            &[
                Param::Int(id.0),
                Param::Int(by.0),
                Param::Text(Some(reason.trim())),
                Param::Text(Some(&date::now_stored())),
            ],
        )?;
        if inserted == 0 {
            let earlier = self.db.query_one(
                "SELECT superseded_by FROM supersessions WHERE campaign_id = ?",
                &[Param::Int(id.0)],
                |r| r.int(0),
            )?;
            return Err(refuse(format!("{id} is already superseded by {earlier}")));
        }
        transaction.commit()
    }

    /// A campaign's machine and stored date, or [`Error::UnknownCampaign`].
    fn placed(&self, id: CampaignId) -> Result<Placed, Error> {
        let rows = self.db.query(
            "SELECT m.name, c.date_utc FROM campaigns c JOIN machines m ON m.id = c.machine_id \
             WHERE c.id = ?",
            &[Param::Int(id.0)],
            |r| {
                Ok(Placed {
                    machine: r.required_text(0)?,
                    date: r.required_text(1)?,
                })
            },
        )?;
        rows.into_iter()
            .next()
            .ok_or_else(|| Error::UnknownCampaign {
                location: self.db.location().to_string(),
                id,
            })
    }
}

struct Placed {
    machine: String,
    date: String,
}

fn connect(url_or_path: &str) -> Result<Db, Error> {
    if url_or_path.starts_with("postgres://") || url_or_path.starts_with("postgresql://") {
        return Db::open_postgres(url_or_path);
    }
    let path = url_or_path
        .strip_prefix("sqlite://")
        .or_else(|| url_or_path.strip_prefix("sqlite:"))
        .unwrap_or(url_or_path);
    let refuse = |detail: &str| Error::Open {
        location: url_or_path.to_string(),
        detail: detail.to_string(),
    };
    if path.is_empty() {
        return Err(refuse("no file named"));
    }
    if Path::new(path).is_dir() {
        return Err(refuse("it is a folder, not a history file"));
    }
    Db::open_sqlite(Path::new(path), BUSY_TIMEOUT)
}

/// The key of a parameter's definition: name, unit and kind ('' when not known).
type DefKey = (String, String, String);

fn def_key(parameter: &Parameter) -> DefKey {
    (
        parameter.name.clone(),
        parameter.unit.clone().unwrap_or_default(),
        parameter.kind.clone().unwrap_or_default(),
    )
}

/// Writes campaigns inside an open transaction, with the ids of their machines and parameter
/// definitions looked up once.
struct Writer<'a> {
    db: &'a Db,
    machines: HashMap<String, i64>,
    defs: HashMap<DefKey, i64>,
    added_utc: String,
}

impl<'a> Writer<'a> {
    /// Creates every machine and parameter definition the campaigns need, each kind in sorted
    /// order: two PostgreSQL transactions creating the same new rows then wait for each other
    /// in the same order, never in a cycle (a deadlock).
    fn new(db: &'a Db, campaigns: &[Campaign]) -> Result<Writer<'a>, Error> {
        let mut writer = Writer {
            db,
            machines: HashMap::new(),
            defs: HashMap::new(),
            added_utc: date::now_stored(),
        };
        let machines: BTreeSet<&str> = campaigns.iter().map(|c| c.machine.name.as_str()).collect();
        for name in machines {
            writer.ensure_machine(name)?;
        }
        let defs: BTreeSet<DefKey> = campaigns
            .iter()
            .flat_map(|c| c.parameters.iter().map(def_key))
            .collect();
        for key in defs {
            writer.ensure_def(key)?;
        }
        Ok(writer)
    }

    fn ensure_machine(&mut self, name: &str) -> Result<(), Error> {
        self.db.execute(
            "INSERT INTO machines (name) VALUES (?) ON CONFLICT (name) DO NOTHING",
            &[Param::Text(Some(name))],
        )?;
        let id = self.db.query_one(
            "SELECT id FROM machines WHERE name = ?",
            &[Param::Text(Some(name))],
            |r| r.int(0),
        )?;
        self.machines.insert(name.to_string(), id);
        Ok(())
    }

    fn ensure_def(&mut self, key: DefKey) -> Result<(), Error> {
        let params = [
            Param::Text(Some(&key.0)),
            Param::Text(Some(&key.1)),
            Param::Text(Some(&key.2)),
        ];
        self.db.execute(
            "INSERT INTO parameter_defs (name, unit, kind) VALUES (?, ?, ?) \
             ON CONFLICT (name, unit, kind) DO NOTHING",
            &params,
        )?;
        let id = self.db.query_one(
            "SELECT id FROM parameter_defs WHERE name = ? AND unit = ? AND kind = ?",
            &params,
            |r| r.int(0),
        )?;
        self.defs.insert(key, id);
        Ok(())
    }

    fn campaign(&mut self, campaign: &Campaign) -> Result<CampaignId, Error> {
        let id = self.campaign_row(campaign)?;
        self.parameters(id, &campaign.parameters)?;
        for (k, instrument) in campaign.instruments.iter().enumerate() {
            self.db.execute(
                "INSERT INTO campaign_instruments (campaign_id, ordinal, instrument) \
                 VALUES (?, ?, ?)",
                &[Param::Int(id), ordinal(k), Param::Text(Some(instrument))],
            )?;
        }
        for (k, run) in campaign.validation.iter().enumerate() {
            self.db.execute(
                "INSERT INTO validation_runs (campaign_id, ordinal, name, instrument, rms_um) \
                 VALUES (?, ?, ?, ?, ?)",
                &[
                    Param::Int(id),
                    ordinal(k),
                    Param::Text(Some(&run.name)),
                    Param::Text(Some(&run.instrument)),
                    Param::Real(run.rms_um),
                ],
            )?;
        }
        for (k, discovery) in campaign.discoveries.iter().enumerate() {
            self.db.execute(
                "INSERT INTO discoveries (campaign_id, ordinal, effect, label, sentence) \
                 VALUES (?, ?, ?, ?, ?)",
                &[
                    Param::Int(id),
                    ordinal(k),
                    Param::Text(Some(&discovery.effect)),
                    Param::Text(Some(&discovery.label)),
                    Param::Text(discovery.sentence.as_deref()),
                ],
            )?;
        }
        Ok(CampaignId(id))
    }

    fn campaign_row(&self, c: &Campaign) -> Result<i64, Error> {
        // Checked by `Campaign::check` before the transaction began.
        let date = date::stored(c.date).map_err(Error::InvalidCampaign)?;
        self.db.query_one(
            "INSERT INTO campaigns (machine_id, date_utc, added_utc, urdf_digest, \
             error_model_digest, session_digest, mtcal_version, rms_um, chi2_reduced, dof, \
             fit_runs, converged, verdict, temperature_c, note) \
             VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
            &[
                Param::Int(self.machines[&c.machine.name]),
                Param::Text(Some(&date)),
                Param::Text(Some(&self.added_utc)),
                Param::Text(c.machine.urdf_digest.as_deref()),
                Param::Text(c.machine.error_model_digest.as_deref()),
                Param::Text(c.session_digest.as_deref()),
                Param::Text(c.mtcal_version.as_deref()),
                Param::Real(Some(c.fit.rms_um)),
                Param::Real(c.fit.chi2_reduced),
                Param::Int(c.fit.dof as i64),
                Param::Int(c.fit.runs as i64),
                Param::Bool(c.fit.converged),
                Param::Text(c.fit.verdict.as_deref()),
                Param::Real(c.temperature_c),
                Param::Text(c.note.as_deref()),
            ],
            |r| r.int(0),
        )
    }

    fn parameters(&self, campaign_id: i64, parameters: &[Parameter]) -> Result<(), Error> {
        for (k, parameter) in parameters.iter().enumerate() {
            let def_id = self.defs[&def_key(parameter)];
            self.db.execute(
                "INSERT INTO parameters (campaign_id, def_id, ordinal, status, value, u95, \
                 expression) VALUES (?, ?, ?, ?, ?, ?, ?)",
                &[
                    Param::Int(campaign_id),
                    Param::Int(def_id),
                    ordinal(k),
                    Param::Text(Some(parameter.status.as_str())),
                    Param::Real(parameter.value),
                    Param::Real(parameter.u95),
                    Param::Text(parameter.expression.as_deref()),
                ],
            )?;
        }
        Ok(())
    }
}

fn ordinal(k: usize) -> Param<'static> {
    Param::Int(k as i64)
}
