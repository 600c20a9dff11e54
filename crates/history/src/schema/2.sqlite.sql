-- mtcal history, schema version 2, SQLite: stored campaigns cannot be changed or deleted
-- (a campaign found wrong is superseded by a later one, and both stay).
CREATE TRIGGER machines_no_update BEFORE UPDATE ON machines
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of machines refused'); END;
CREATE TRIGGER machines_no_delete BEFORE DELETE ON machines
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of machines refused'); END;
CREATE TRIGGER campaigns_no_update BEFORE UPDATE ON campaigns
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of campaigns refused'); END;
CREATE TRIGGER campaigns_no_delete BEFORE DELETE ON campaigns
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of campaigns refused'); END;
CREATE TRIGGER parameter_defs_no_update BEFORE UPDATE ON parameter_defs
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of parameter_defs refused'); END;
CREATE TRIGGER parameter_defs_no_delete BEFORE DELETE ON parameter_defs
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of parameter_defs refused'); END;
CREATE TRIGGER parameters_no_update BEFORE UPDATE ON parameters
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of parameters refused'); END;
CREATE TRIGGER parameters_no_delete BEFORE DELETE ON parameters
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of parameters refused'); END;
CREATE TRIGGER campaign_instruments_no_update BEFORE UPDATE ON campaign_instruments
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of campaign_instruments refused'); END;
CREATE TRIGGER campaign_instruments_no_delete BEFORE DELETE ON campaign_instruments
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of campaign_instruments refused'); END;
CREATE TRIGGER validation_runs_no_update BEFORE UPDATE ON validation_runs
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of validation_runs refused'); END;
CREATE TRIGGER validation_runs_no_delete BEFORE DELETE ON validation_runs
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of validation_runs refused'); END;
CREATE TRIGGER discoveries_no_update BEFORE UPDATE ON discoveries
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of discoveries refused'); END;
CREATE TRIGGER discoveries_no_delete BEFORE DELETE ON discoveries
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of discoveries refused'); END;
CREATE TRIGGER supersessions_no_update BEFORE UPDATE ON supersessions
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: UPDATE of supersessions refused'); END;
CREATE TRIGGER supersessions_no_delete BEFORE DELETE ON supersessions
BEGIN SELECT RAISE(ABORT, 'mtcal history is append-only: DELETE of supersessions refused'); END;
