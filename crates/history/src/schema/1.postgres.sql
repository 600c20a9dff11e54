-- mtcal history, schema version 1, PostgreSQL. Dates are RFC 3339 UTC text to the second
-- (2024-05-01T08:30:00Z), compared bytewise (COLLATE "C"): text order is time order, as in
-- SQLite. An unknown unit or kind is ''.
CREATE TABLE mtcal_history (
    key TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE schema_migrations (
    version BIGINT PRIMARY KEY,
    description TEXT NOT NULL,
    applied_utc TEXT NOT NULL
);
CREATE TABLE machines (
    id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    name TEXT COLLATE "C" NOT NULL UNIQUE
);
CREATE TABLE campaigns (
    id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id BIGINT NOT NULL REFERENCES machines (id),
    date_utc TEXT COLLATE "C" NOT NULL,
    added_utc TEXT COLLATE "C" NOT NULL,
    urdf_digest TEXT,
    error_model_digest TEXT,
    session_digest TEXT,
    mtcal_version TEXT,
    rms_um DOUBLE PRECISION NOT NULL,
    chi2_reduced DOUBLE PRECISION,
    dof BIGINT NOT NULL,
    fit_runs BIGINT NOT NULL,
    converged BOOLEAN NOT NULL,
    verdict TEXT,
    temperature_c DOUBLE PRECISION,
    note TEXT
);
-- A machine's campaigns in date order: its series, its latest campaign, its count.
CREATE INDEX campaigns_by_machine ON campaigns (machine_id, date_utc, id);
CREATE TABLE parameter_defs (
    id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    name TEXT COLLATE "C" NOT NULL,
    unit TEXT NOT NULL,
    kind TEXT NOT NULL,
    UNIQUE (name, unit, kind)
);
-- Keyed by campaign then parameter: one parameter of one campaign is one seek.
CREATE TABLE parameters (
    campaign_id BIGINT NOT NULL REFERENCES campaigns (id),
    def_id BIGINT NOT NULL REFERENCES parameter_defs (id),
    ordinal BIGINT NOT NULL,
    status TEXT NOT NULL CHECK (status IN
        ('identified', 'combination', 'weakly-determined', 'not-identifiable')),
    value DOUBLE PRECISION,
    u95 DOUBLE PRECISION,
    expression TEXT,
    PRIMARY KEY (campaign_id, def_id),
    CHECK ((status = 'not-identifiable') = (value IS NULL)),
    CHECK ((value IS NULL) = (u95 IS NULL)),
    CHECK ((status = 'combination') = (expression IS NOT NULL))
);
CREATE TABLE campaign_instruments (
    campaign_id BIGINT NOT NULL REFERENCES campaigns (id),
    ordinal BIGINT NOT NULL,
    instrument TEXT NOT NULL,
    PRIMARY KEY (campaign_id, ordinal)
);
CREATE TABLE validation_runs (
    campaign_id BIGINT NOT NULL REFERENCES campaigns (id),
    ordinal BIGINT NOT NULL,
    name TEXT NOT NULL,
    instrument TEXT NOT NULL,
    rms_um DOUBLE PRECISION,
    PRIMARY KEY (campaign_id, ordinal)
);
CREATE TABLE discoveries (
    campaign_id BIGINT NOT NULL REFERENCES campaigns (id),
    ordinal BIGINT NOT NULL,
    effect TEXT NOT NULL,
    label TEXT NOT NULL,
    sentence TEXT,
    PRIMARY KEY (campaign_id, ordinal)
);
-- A campaign found wrong, and the later one that replaces it: both are kept.
CREATE TABLE supersessions (
    campaign_id BIGINT PRIMARY KEY REFERENCES campaigns (id),
    superseded_by BIGINT NOT NULL REFERENCES campaigns (id),
    reason TEXT NOT NULL,
    at_utc TEXT COLLATE "C" NOT NULL
);
