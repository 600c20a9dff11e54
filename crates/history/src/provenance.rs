//! Where a campaign came from: the session's files and the machine's sources, digested, and
//! its date when none is given (the newest of the session's files: when it was recorded).

use crate::{Campaign, Error, Timestamp, digest_files, digest_text};
use std::path::Path;

/// The files and sources behind an identification.
#[derive(Debug, Clone, Copy)]
pub struct Provenance<'a> {
    /// The session's manifest first, then every run file in the manifest's order.
    pub session_files: &'a [&'a Path],
    /// The machine's URDF (a file) or the text that names it (a topology code).
    pub machine_source: &'a str,
    /// The error model's file, or the text that names it ("full ISO model").
    pub error_model_source: &'a str,
    pub mtcal_version: &'a str,
}

impl Campaign {
    /// The campaign of an identification of a session: identify's JSON read as
    /// [`Campaign::from_identify_json`] does, dated `date` or else by the session's newest
    /// file, with the digests of the session, the machine and its error model.
    pub fn from_identified_session(
        identify_json: &str,
        machine: &str,
        date: Option<Timestamp>,
        from: &Provenance<'_>,
    ) -> Result<Campaign, Error> {
        let date = match date {
            Some(date) => date,
            None => newest_modification(from.session_files)?,
        };
        let mut campaign = Campaign::from_identify_json(identify_json, machine, date)?;
        campaign.session_digest = Some(digest_files(from.session_files)?);
        campaign.machine.urdf_digest = Some(source_digest(from.machine_source)?);
        campaign.machine.error_model_digest = Some(source_digest(from.error_model_source)?);
        campaign.mtcal_version = Some(from.mtcal_version.to_string());
        Ok(campaign)
    }
}

/// The digest of a machine or error-model source: the file's when it is one, else of the text
/// that names it.
fn source_digest(source: &str) -> Result<String, Error> {
    let path = Path::new(source);
    Ok(if path.is_file() {
        digest_files(&[path])?
    } else {
        digest_text(source)
    })
}

/// The newest modification time of `files`: when the recordings were written.
pub fn newest_modification(files: &[&Path]) -> Result<Timestamp, Error> {
    let mut newest = None;
    for f in files {
        let modified = std::fs::metadata(f)
            .and_then(|m| m.modified())
            .map_err(|e| Error::FileDate {
                detail: format!("cannot read the date of {}: {e} (give a date)", f.display()),
            })?;
        newest = newest.max(Some(modified));
    }
    let newest = newest.ok_or_else(|| Error::FileDate {
        detail: "no file to date the campaign by: give a date".into(),
    })?;
    Timestamp::try_from(newest).map_err(|e| Error::FileDate {
        detail: format!("a file's date is out of range ({e}): give a date"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_source_is_digested_as_a_file_when_it_is_one_and_as_text_otherwise() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("m.urdf");
        std::fs::write(&file, "<robot/>").unwrap();
        let as_file = source_digest(file.to_str().unwrap()).unwrap();
        assert_eq!(as_file, digest_files(&[file.as_path()]).unwrap());
        assert_ne!(as_file, digest_text(file.to_str().unwrap()));
        assert_eq!(
            source_digest("full ISO model").unwrap(),
            digest_text("full ISO model")
        );
    }

    #[test]
    fn a_session_is_dated_by_its_newest_file() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::fs::write(&a, "a").unwrap();
        std::fs::write(&b, "b").unwrap();
        let old = std::time::SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_700_000_000);
        std::fs::File::options()
            .write(true)
            .open(&a)
            .unwrap()
            .set_modified(old)
            .unwrap();
        let newest = newest_modification(&[a.as_path(), b.as_path()]).unwrap();
        assert!(newest.as_second() > 1_700_000_000, "{newest}");
        assert_eq!(
            newest_modification(&[a.as_path()]).unwrap().as_second(),
            1_700_000_000
        );
        let missing = dir.path().join("missing");
        let e = newest_modification(&[missing.as_path()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing") && e.contains("give a date"), "{e}");
        assert!(newest_modification(&[]).is_err());
    }
}
