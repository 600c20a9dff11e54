//! Campaign dates: UTC instants, stored as fixed-width RFC 3339 text to the second
//! (`2024-05-01T08:30:00Z`) so that text order is time order in both back ends.

use crate::Error;
use jiff::Timestamp;
use jiff::civil::{Date, DateTime};
use jiff::tz::TimeZone;

/// Years a stored date may have: four digits keep text order equal to time order.
const YEARS: std::ops::RangeInclusive<i16> = 1..=9999;

/// A date as a person or a session gives it, in UTC: RFC 3339 with `Z` or an offset
/// (`2024-05-01T08:30:00+02:00`, converted to UTC), a date and time without offset
/// (`2024-05-01T08:30:00` or `2024-05-01 08:30`, taken as UTC) or a date alone
/// (`2024-05-01`, midnight UTC).
pub fn parse_date(text: &str) -> Result<Timestamp, Error> {
    let trimmed = text.trim();
    let fail = |detail: String| Error::Date {
        text: text.to_string(),
        detail,
    };
    let timestamp = if let Ok(ts) = trimmed.parse::<Timestamp>() {
        ts
    } else if let Ok(dt) = trimmed.parse::<DateTime>() {
        naive_utc(dt).map_err(|e| fail(e.to_string()))?
    } else {
        let date = trimmed.parse::<Date>().map_err(|_| {
            fail(
                "expected 2024-05-01, 2024-05-01T08:30:00 (UTC) or 2024-05-01T08:30:00+02:00"
                    .into(),
            )
        })?;
        naive_utc(date.to_datetime(jiff::civil::Time::midnight()))
            .map_err(|e| fail(e.to_string()))?
    };
    stored(timestamp).map_err(fail)?;
    Ok(timestamp)
}

fn naive_utc(dt: DateTime) -> Result<Timestamp, jiff::Error> {
    TimeZone::UTC.to_timestamp(dt)
}

/// The stored text of `timestamp` (sub-seconds dropped), or why it cannot be stored.
pub(crate) fn stored(timestamp: Timestamp) -> Result<String, String> {
    let dt = TimeZone::UTC.to_datetime(timestamp);
    if !YEARS.contains(&dt.year()) {
        return Err(format!(
            "year {} is outside 1..=9999, which a history cannot store",
            dt.year()
        ));
    }
    Ok(format!(
        "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z",
        dt.year(),
        dt.month(),
        dt.day(),
        dt.hour(),
        dt.minute(),
        dt.second()
    ))
}

/// A stored date back.
pub(crate) fn from_stored(text: &str) -> Result<Timestamp, String> {
    text.parse::<Timestamp>()
        .map_err(|e| format!("stored date {text:?} is not RFC 3339: {e}"))
}

/// Now, to the second.
pub(crate) fn now_stored() -> String {
    stored(Timestamp::now()).unwrap_or_else(|_| "9999-12-31T23:59:59Z".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_accepted_form_is_the_same_utc_instant() {
        let utc: Timestamp = "2024-05-01T06:30:00Z".parse().unwrap();
        for text in [
            "2024-05-01T06:30:00Z",
            "2024-05-01T08:30:00+02:00",
            "2024-05-01T06:30:00",
            "2024-05-01 06:30",
            " 2024-05-01T06:30:00.000Z ",
        ] {
            assert_eq!(parse_date(text).unwrap(), utc, "{text}");
        }
        assert_eq!(
            parse_date("2024-05-01").unwrap(),
            "2024-05-01T00:00:00Z".parse::<Timestamp>().unwrap()
        );
    }

    #[test]
    fn bad_dates_are_errors_that_quote_the_text() {
        for text in ["", "yesterday", "2024-13-01", "2024-02-30"] {
            let error = parse_date(text).unwrap_err().to_string();
            assert!(error.contains(&format!("{text:?}")), "{error}");
        }
    }

    #[test]
    fn stored_text_sorts_like_time_and_drops_sub_seconds() {
        let early: Timestamp = "0999-01-01T00:00:00Z".parse().unwrap();
        let late: Timestamp = "2024-05-01T06:30:00.75Z".parse().unwrap();
        let (a, b) = (stored(early).unwrap(), stored(late).unwrap());
        assert_eq!(a, "0999-01-01T00:00:00Z");
        assert_eq!(b, "2024-05-01T06:30:00Z");
        assert!(a < b);
        assert_eq!(
            from_stored(&b).unwrap(),
            "2024-05-01T06:30:00Z".parse::<Timestamp>().unwrap()
        );
        assert!(stored(Timestamp::MIN).is_err());
    }
}
