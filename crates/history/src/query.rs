//! What the history is read for: the machines, one machine's campaigns, one parameter's series,
//! the fleet (every machine's latest campaign and its parameters, in two queries whatever the
//! number of machines) and one campaign in full. Multi-query reads run in one read
//! transaction, so they see one state of the history.

use crate::campaign::{
    Campaign, DiscoverySummary, FitSummary, MachineIdentity, Parameter, ParameterStatus,
    ValidationRun,
};
use crate::db::{Failure, Param, Row};
use crate::{CampaignId, Error, Store, Timestamp, date};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// A machine and the span of its campaigns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MachineSummary {
    pub name: String,
    /// Every campaign, superseded ones included.
    pub campaigns: u64,
    pub first_date: Timestamp,
    pub last_date: Timestamp,
}

/// That a campaign was superseded, by which and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Supersession {
    pub by: CampaignId,
    pub reason: String,
    /// When it was marked.
    pub at: Timestamp,
}

/// A campaign without its lists (parameters, instruments, validation runs, discoveries).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CampaignRow {
    pub id: CampaignId,
    pub machine: MachineIdentity,
    pub date: Timestamp,
    /// When it was added to the history.
    pub added: Timestamp,
    pub session_digest: Option<String>,
    pub mtcal_version: Option<String>,
    pub fit: FitSummary,
    pub temperature_c: Option<f64>,
    pub note: Option<String>,
    pub superseded: Option<Supersession>,
}

/// One campaign's value of a parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeriesPoint {
    pub campaign: CampaignId,
    pub date: Timestamp,
    pub status: ParameterStatus,
    /// `None` when not identifiable.
    pub value: Option<f64>,
    pub u95: Option<f64>,
    pub unit: Option<String>,
    pub superseded: bool,
    /// Why the campaign's fit is not a calibration (it did not converge, or the model does not
    /// explain the recordings): its value is shown, never counted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<String>,
}

impl SeriesPoint {
    /// Whether the value counts in the analyses: a number with an interval, from a fit that is
    /// a calibration, of a campaign not superseded.
    pub fn counts(&self) -> bool {
        !self.superseded
            && self.verdict.is_none()
            && self.value.is_some()
            && self.u95.is_some_and(|u| u > 0.0)
    }
}

/// A machine of the fleet: its latest campaign that is not superseded, and its parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetRow {
    pub machine: String,
    /// Every campaign of the machine, superseded ones included.
    pub campaigns: u64,
    pub latest: CampaignRow,
    pub parameters: Vec<Parameter>,
}

/// A campaign in full, as it was added, with what the history knows about it since.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CampaignRecord {
    pub id: CampaignId,
    pub added: Timestamp,
    pub superseded: Option<Supersession>,
    /// Earlier campaigns this one supersedes.
    pub supersedes: Vec<CampaignId>,
    pub campaign: Campaign,
}

/// The columns [`campaign_row`] decodes, and the tables they come from.
macro_rules! campaign_columns {
    () => {
        "c.id, m.name, c.urdf_digest, c.error_model_digest, c.date_utc, c.added_utc, \
         c.session_digest, c.mtcal_version, c.rms_um, c.chi2_reduced, c.dof, c.fit_runs, \
         c.converged, c.verdict, c.temperature_c, c.note, s.superseded_by, s.reason, s.at_utc"
    };
}
macro_rules! campaign_tables {
    () => {
        " FROM campaigns c JOIN machines m ON m.id = c.machine_id \
         LEFT JOIN supersessions s ON s.campaign_id = c.id "
    };
}
/// How many columns [`campaign_columns!`] has.
const CAMPAIGN_COLUMNS: usize = 19;

/// Each machine's latest campaign that is not superseded (a superseding campaign is later and
/// of the same machine, so every machine with campaigns has one).
macro_rules! latest_campaigns {
    () => {
        "WITH latest AS (SELECT m.id AS machine_id, \
           (SELECT COUNT(*) FROM campaigns a WHERE a.machine_id = m.id) AS campaigns, \
           (SELECT l.id FROM campaigns l WHERE l.machine_id = m.id \
              AND NOT EXISTS (SELECT 1 FROM supersessions x WHERE x.campaign_id = l.id) \
              ORDER BY l.date_utc DESC, l.id DESC LIMIT 1) AS campaign_id \
         FROM machines m) "
    };
}

/// The columns [`parameter`] decodes.
macro_rules! parameter_columns {
    () => {
        "d.name, d.unit, d.kind, p.status, p.value, p.u95, p.expression"
    };
}

impl Store {
    /// Every machine with its number of campaigns and their span, by name.
    pub fn machines(&self) -> Result<Vec<MachineSummary>, Error> {
        let mut machines = self.db.query(
            "SELECT m.name, COUNT(*), MIN(c.date_utc), MAX(c.date_utc) \
             FROM machines m JOIN campaigns c ON c.machine_id = m.id GROUP BY m.id, m.name",
            &[],
            |r| {
                Ok(MachineSummary {
                    name: r.required_text(0)?,
                    campaigns: count(r, 1)?,
                    first_date: stored_date(r, 2)?,
                    last_date: stored_date(r, 3)?,
                })
            },
        )?;
        machines.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(machines)
    }

    /// A machine's campaigns, oldest first (superseded ones included, and marked).
    pub fn campaigns(&self, machine: &str) -> Result<Vec<CampaignRow>, Error> {
        let transaction = self.db.read_transaction()?;
        let machine_id = self.machine_id(machine)?;
        let rows = self.db.query(
            concat!(
                "SELECT ",
                campaign_columns!(),
                campaign_tables!(),
                "WHERE c.machine_id = ? ORDER BY c.date_utc, c.id"
            ),
            &[Param::Int(machine_id)],
            campaign_row,
        )?;
        transaction.commit()?;
        Ok(rows)
    }

    /// One parameter of one machine over its campaigns, oldest first: the trend's input.
    pub fn series(&self, machine: &str, parameter: &str) -> Result<Vec<SeriesPoint>, Error> {
        let transaction = self.db.read_transaction()?;
        let machine_id = self.machine_id(machine)?;
        let points = self.db.query(
            "SELECT c.id, c.date_utc, p.status, p.value, p.u95, d.unit, \
                    CAST(CASE WHEN s.campaign_id IS NULL THEN 0 ELSE 1 END AS BIGINT), c.verdict \
             FROM campaigns c \
             JOIN parameters p ON p.campaign_id = c.id \
             JOIN parameter_defs d ON d.id = p.def_id \
             LEFT JOIN supersessions s ON s.campaign_id = c.id \
             WHERE c.machine_id = ? AND d.name = ? \
             ORDER BY c.date_utc, c.id",
            &[Param::Int(machine_id), Param::Text(Some(parameter))],
            series_point,
        )?;
        transaction.commit()?;
        if points.is_empty() {
            return Err(Error::UnknownParameter {
                location: self.location().to_string(),
                machine: machine.to_string(),
                parameter: parameter.to_string(),
            });
        }
        Ok(points)
    }

    /// Every machine's latest campaign that is not superseded, with its parameters, by
    /// machine name: two queries whatever the size of the fleet.
    pub fn fleet(&self) -> Result<Vec<FleetRow>, Error> {
        let transaction = self.db.read_transaction()?;
        let latest = self.db.query(
            concat!(
                latest_campaigns!(),
                "SELECT ",
                campaign_columns!(),
                ", latest.campaigns FROM latest JOIN campaigns c ON c.id = latest.campaign_id \
                 JOIN machines m ON m.id = c.machine_id \
                 LEFT JOIN supersessions s ON s.campaign_id = c.id"
            ),
            &[],
            |r| Ok((campaign_row(r)?, count(r, CAMPAIGN_COLUMNS)?)),
        )?;
        let parameters = self.db.query(
            concat!(
                latest_campaigns!(),
                "SELECT latest.campaign_id, ",
                parameter_columns!(),
                " FROM latest JOIN parameters p ON p.campaign_id = latest.campaign_id \
                 JOIN parameter_defs d ON d.id = p.def_id \
                 ORDER BY latest.campaign_id, p.ordinal"
            ),
            &[],
            |r| Ok((r.int(0)?, parameter(r, 1)?)),
        )?;
        transaction.commit()?;
        Ok(fleet_rows(latest, parameters))
    }

    /// One campaign in full.
    pub fn campaign(&self, id: CampaignId) -> Result<CampaignRecord, Error> {
        let transaction = self.db.read_transaction()?;
        let rows = self.db.query(
            concat!(
                "SELECT ",
                campaign_columns!(),
                campaign_tables!(),
                "WHERE c.id = ?"
            ),
            &[Param::Int(id.0)],
            campaign_row,
        )?;
        let row = rows
            .into_iter()
            .next()
            .ok_or_else(|| Error::UnknownCampaign {
                location: self.location().to_string(),
                id,
            })?;
        let record = self.record(row)?;
        transaction.commit()?;
        Ok(record)
    }

    /// The lists of a campaign, read into its record.
    fn record(&self, row: CampaignRow) -> Result<CampaignRecord, Error> {
        let id = [Param::Int(row.id.0)];
        let parameters = self.db.query(
            concat!(
                "SELECT ",
                parameter_columns!(),
                " FROM parameters p JOIN parameter_defs d ON d.id = p.def_id \
                 WHERE p.campaign_id = ? ORDER BY p.ordinal"
            ),
            &id,
            |r| parameter(r, 0),
        )?;
        let instruments = self.db.query(
            "SELECT instrument FROM campaign_instruments WHERE campaign_id = ? ORDER BY ordinal",
            &id,
            |r| r.required_text(0),
        )?;
        let validation = self.db.query(
            "SELECT name, instrument, rms_um FROM validation_runs WHERE campaign_id = ? \
             ORDER BY ordinal",
            &id,
            |r| {
                Ok(ValidationRun {
                    name: r.required_text(0)?,
                    instrument: r.required_text(1)?,
                    rms_um: r.real(2)?,
                })
            },
        )?;
        let discoveries = self.db.query(
            "SELECT effect, label, sentence FROM discoveries WHERE campaign_id = ? \
             ORDER BY ordinal",
            &id,
            |r| {
                Ok(DiscoverySummary {
                    effect: r.required_text(0)?,
                    label: r.required_text(1)?,
                    sentence: r.text(2)?,
                })
            },
        )?;
        let supersedes = self.db.query(
            "SELECT campaign_id FROM supersessions WHERE superseded_by = ? ORDER BY campaign_id",
            &id,
            |r| Ok(CampaignId(r.int(0)?)),
        )?;
        Ok(CampaignRecord {
            id: row.id,
            added: row.added,
            supersedes,
            campaign: Campaign {
                machine: row.machine,
                date: row.date,
                session_digest: row.session_digest,
                mtcal_version: row.mtcal_version,
                instruments,
                fit: row.fit,
                validation,
                discoveries,
                parameters,
                temperature_c: row.temperature_c,
                note: row.note,
            },
            superseded: row.superseded,
        })
    }

    fn machine_id(&self, name: &str) -> Result<i64, Error> {
        let ids = self.db.query(
            "SELECT id FROM machines WHERE name = ?",
            &[Param::Text(Some(name))],
            |r| r.int(0),
        )?;
        ids.first().copied().ok_or_else(|| Error::UnknownMachine {
            location: self.location().to_string(),
            name: name.to_string(),
        })
    }
}

fn fleet_rows(latest: Vec<(CampaignRow, u64)>, parameters: Vec<(i64, Parameter)>) -> Vec<FleetRow> {
    let mut by_campaign: HashMap<i64, Vec<Parameter>> = HashMap::new();
    for (campaign, parameter) in parameters {
        by_campaign.entry(campaign).or_default().push(parameter);
    }
    let mut rows: Vec<FleetRow> = latest
        .into_iter()
        .map(|(row, campaigns)| FleetRow {
            machine: row.machine.name.clone(),
            campaigns,
            parameters: by_campaign.remove(&row.id.0).unwrap_or_default(),
            latest: row,
        })
        .collect();
    rows.sort_by(|a, b| a.machine.cmp(&b.machine));
    rows
}

fn campaign_row(r: &dyn Row) -> Result<CampaignRow, Failure> {
    let superseded = supersession(r)?;
    Ok(CampaignRow {
        id: CampaignId(r.int(0)?),
        machine: MachineIdentity {
            name: r.required_text(1)?,
            urdf_digest: r.text(2)?,
            error_model_digest: r.text(3)?,
        },
        date: stored_date(r, 4)?,
        added: stored_date(r, 5)?,
        session_digest: r.text(6)?,
        mtcal_version: r.text(7)?,
        fit: FitSummary {
            rms_um: r
                .real(8)?
                .ok_or_else(|| Failure::other("a campaign without rms_um"))?,
            chi2_reduced: r.real(9)?,
            dof: count(r, 10)?,
            runs: count(r, 11)?,
            converged: r.flag(12)?,
            verdict: r.text(13)?,
        },
        temperature_c: r.real(14)?,
        note: r.text(15)?,
        superseded,
    })
}

/// Columns 16–18 of a campaign row: NULL unless superseded.
fn supersession(r: &dyn Row) -> Result<Option<Supersession>, Failure> {
    let Some(reason) = r.text(17)? else {
        return Ok(None);
    };
    Ok(Some(Supersession {
        by: CampaignId(r.int(16)?),
        reason,
        at: stored_date(r, 18)?,
    }))
}

fn series_point(r: &dyn Row) -> Result<SeriesPoint, Failure> {
    Ok(SeriesPoint {
        campaign: CampaignId(r.int(0)?),
        date: stored_date(r, 1)?,
        status: status(r, 2)?,
        value: r.real(3)?,
        u95: r.real(4)?,
        unit: known(r.required_text(5)?),
        superseded: r.int(6)? != 0,
        verdict: r.text(7)?,
    })
}

/// A parameter from [`parameter_columns!`] starting at column `at`.
fn parameter(r: &dyn Row, at: usize) -> Result<Parameter, Failure> {
    Ok(Parameter {
        name: r.required_text(at)?,
        unit: known(r.required_text(at + 1)?),
        kind: known(r.required_text(at + 2)?),
        status: status(r, at + 3)?,
        value: r.real(at + 4)?,
        u95: r.real(at + 5)?,
        expression: r.text(at + 6)?,
    })
}

/// '' is how the database stores "not known".
fn known(text: String) -> Option<String> {
    (!text.is_empty()).then_some(text)
}

fn status(r: &dyn Row, i: usize) -> Result<ParameterStatus, Failure> {
    let text = r.required_text(i)?;
    ParameterStatus::from_stored(&text)
        .ok_or_else(|| Failure::other(format!("unknown parameter status {text:?}")))
}

fn stored_date(r: &dyn Row, i: usize) -> Result<Timestamp, Failure> {
    date::from_stored(&r.required_text(i)?).map_err(Failure::other)
}

fn count(r: &dyn Row, i: usize) -> Result<u64, Failure> {
    let n = r.int(i)?;
    u64::try_from(n).map_err(|_| Failure::other(format!("negative count {n}")))
}
