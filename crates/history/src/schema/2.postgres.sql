-- mtcal history, schema version 2, PostgreSQL: stored campaigns cannot be changed or deleted
-- (a campaign found wrong is superseded by a later one, and both stay).
CREATE FUNCTION mtcal_history_append_only() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    RAISE EXCEPTION 'mtcal history is append-only: % of % refused', TG_OP, TG_TABLE_NAME;
END
$$;
CREATE TRIGGER machines_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON machines
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
CREATE TRIGGER campaigns_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON campaigns
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
CREATE TRIGGER parameter_defs_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON parameter_defs
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
CREATE TRIGGER parameters_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON parameters
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
CREATE TRIGGER campaign_instruments_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON campaign_instruments
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
CREATE TRIGGER validation_runs_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON validation_runs
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
CREATE TRIGGER discoveries_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON discoveries
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
CREATE TRIGGER supersessions_append_only BEFORE UPDATE OR DELETE OR TRUNCATE ON supersessions
    FOR EACH STATEMENT EXECUTE FUNCTION mtcal_history_append_only();
