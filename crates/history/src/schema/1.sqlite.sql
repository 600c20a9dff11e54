-- mtcal history, schema version 1, SQLite. Dates are RFC 3339 UTC text to the second
-- (2024-05-01T08:30:00Z): text order is time order. An unknown unit or kind is ''.
CREATE TABLE mtcal_history (
    key TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE schema_migrations (
    version INTEGER PRIMARY KEY,
    description TEXT NOT NULL,
    applied_utc TEXT NOT NULL
);
CREATE TABLE machines (
    id INTEGER PRIMARY KEY,
    name TEXT NOT NULL UNIQUE
);
CREATE TABLE campaigns (
    id INTEGER PRIMARY KEY,
    machine_id INTEGER NOT NULL REFERENCES machines (id),
    date_utc TEXT NOT NULL,
    added_utc TEXT NOT NULL,
    urdf_digest TEXT,
    error_model_digest TEXT,
    session_digest TEXT,
    mtcal_version TEXT,
    rms_um REAL NOT NULL,
    chi2_reduced REAL,
    dof INTEGER NOT NULL,
    fit_runs INTEGER NOT NULL,
    converged INTEGER NOT NULL CHECK (converged IN (0, 1)),
    verdict TEXT,
    temperature_c REAL,
    note TEXT
);
-- A machine's campaigns in date order: its series, its latest campaign, its count.
CREATE INDEX campaigns_by_machine ON campaigns (machine_id, date_utc, id);
CREATE TABLE parameter_defs (
    id INTEGER PRIMARY KEY,
    name TEXT NOT NULL,
    unit TEXT NOT NULL,
    kind TEXT NOT NULL,
    UNIQUE (name, unit, kind)
);
-- Keyed by campaign then parameter: one parameter of one campaign is one seek.
CREATE TABLE parameters (
    campaign_id INTEGER NOT NULL REFERENCES campaigns (id),
    def_id INTEGER NOT NULL REFERENCES parameter_defs (id),
    ordinal INTEGER NOT NULL,
    status TEXT NOT NULL CHECK (status IN
        ('identified', 'combination', 'weakly-determined', 'not-identifiable')),
    value REAL,
    u95 REAL,
    expression TEXT,
    PRIMARY KEY (campaign_id, def_id),
    CHECK ((status = 'not-identifiable') = (value IS NULL)),
    CHECK ((value IS NULL) = (u95 IS NULL)),
    CHECK ((status = 'combination') = (expression IS NOT NULL))
) WITHOUT ROWID;
CREATE TABLE campaign_instruments (
    campaign_id INTEGER NOT NULL REFERENCES campaigns (id),
    ordinal INTEGER NOT NULL,
    instrument TEXT NOT NULL,
    PRIMARY KEY (campaign_id, ordinal)
) WITHOUT ROWID;
CREATE TABLE validation_runs (
    campaign_id INTEGER NOT NULL REFERENCES campaigns (id),
    ordinal INTEGER NOT NULL,
    name TEXT NOT NULL,
    instrument TEXT NOT NULL,
    rms_um REAL,
    PRIMARY KEY (campaign_id, ordinal)
) WITHOUT ROWID;
CREATE TABLE discoveries (
    campaign_id INTEGER NOT NULL REFERENCES campaigns (id),
    ordinal INTEGER NOT NULL,
    effect TEXT NOT NULL,
    label TEXT NOT NULL,
    sentence TEXT,
    PRIMARY KEY (campaign_id, ordinal)
) WITHOUT ROWID;
-- A campaign found wrong, and the later one that replaces it: both are kept.
CREATE TABLE supersessions (
    campaign_id INTEGER PRIMARY KEY REFERENCES campaigns (id),
    superseded_by INTEGER NOT NULL REFERENCES campaigns (id),
    reason TEXT NOT NULL,
    at_utc TEXT NOT NULL
);
