//! What a request's `Range` and `If-Range` headers ask of a body: one
//! byte range, the whole body, or nothing (416). RFC 9110, 14.

use std::time::SystemTime;

/// What a Range header asks of a body of `len` bytes.
#[derive(Debug, PartialEq)]
pub(crate) enum Ranged {
    /// The whole body: no Range, or one this server ignores (another unit,
    /// a malformed one, several ranges) — RFC 9110, 14.2 lets a server
    /// answer any Range with the whole body, and a request for several
    /// ranges gets it rather than a multipart/byteranges answer.
    Whole,
    /// Bytes `start..=end`.
    Part(u64, u64),
    /// No byte of the body is in the range: 416.
    Unsatisfiable,
}

/// The Range header `header` against a body of `len` bytes.
pub(crate) fn ranged(header: Option<&str>, len: u64) -> Ranged {
    let Some(header) = header else {
        return Ranged::Whole;
    };
    let Some((unit, spec)) = header.split_once('=') else {
        return Ranged::Whole;
    };
    if !unit.trim().eq_ignore_ascii_case("bytes") || spec.contains(',') {
        return Ranged::Whole;
    }
    let Some((first, last)) = spec.trim().split_once('-') else {
        return Ranged::Whole;
    };
    // Digits only; a number past u64 is as good as u64::MAX here.
    let number = |s: &str| {
        (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
            .then(|| s.parse::<u64>().unwrap_or(u64::MAX))
    };
    match (first, number(first), number(last)) {
        // bytes=-n: the last n bytes.
        ("", _, Some(n)) => {
            if n == 0 || len == 0 {
                Ranged::Unsatisfiable
            } else {
                Ranged::Part(len.saturating_sub(n), len - 1)
            }
        }
        // bytes=a-
        (_, Some(a), None) if last.is_empty() => {
            if a >= len {
                Ranged::Unsatisfiable
            } else {
                Ranged::Part(a, len - 1)
            }
        }
        // bytes=a-b
        (_, Some(a), Some(b)) if a <= b => {
            if a >= len {
                Ranged::Unsatisfiable
            } else {
                Ranged::Part(a, b.min(len - 1))
            }
        }
        _ => Ranged::Whole,
    }
}

/// Whether a request's `If-Range` lets its Range apply to a body with
/// these validators (RFC 9110, 13.1.5): an entity tag must match `etag`
/// strongly (a weak one never does), a date must be `modified` exactly.
/// Anything else sends the whole body.
pub(crate) fn if_range_holds(if_range: &str, etag: &str, modified: Option<SystemTime>) -> bool {
    let v = if_range.trim();
    if v.starts_with('"') {
        return !etag.starts_with("W/") && v == etag;
    }
    if v.starts_with("W/") {
        return false;
    }
    match (httpdate::parse_http_date(v), modified) {
        (Ok(date), Some(m)) => httpdate::fmt_http_date(m) == httpdate::fmt_http_date(date),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, UNIX_EPOCH};

    #[test]
    fn ranges() {
        let r = |h: &str| ranged(Some(h), 100);
        assert_eq!(ranged(None, 100), Ranged::Whole);
        assert_eq!(r("bytes=0-9"), Ranged::Part(0, 9));
        assert_eq!(r("bytes=90-200"), Ranged::Part(90, 99));
        assert_eq!(r("bytes=10-"), Ranged::Part(10, 99));
        assert_eq!(r("bytes=-10"), Ranged::Part(90, 99));
        assert_eq!(r("bytes=-1000"), Ranged::Part(0, 99));
        assert_eq!(r("Bytes = 5-5"), Ranged::Part(5, 5));
        assert_eq!(r("bytes=100-"), Ranged::Unsatisfiable);
        assert_eq!(r("bytes=100-200"), Ranged::Unsatisfiable);
        assert_eq!(r("bytes=-0"), Ranged::Unsatisfiable);
        assert_eq!(
            r("bytes=99999999999999999999999999-"),
            Ranged::Unsatisfiable
        );
        assert_eq!(r("bytes=0-99999999999999999999999999"), Ranged::Part(0, 99));
        assert_eq!(ranged(Some("bytes=0-"), 0), Ranged::Unsatisfiable);
        assert_eq!(ranged(Some("bytes=-5"), 0), Ranged::Unsatisfiable);
        for ignored in [
            "bytes=5-1",
            "bytes=0-1,5-6",
            "items=0-1",
            "bytes=a-b",
            "bytes=-",
            "bytes=1",
            "bytes=+1-2",
            "bytes",
            "",
        ] {
            assert_eq!(r(ignored), Ranged::Whole, "{ignored}");
        }
    }

    #[test]
    fn if_range_needs_a_strong_tag_or_the_exact_date() {
        let m = UNIX_EPOCH + Duration::from_secs(784_111_777);
        let date = "Sun, 06 Nov 1994 08:49:37 GMT";
        assert!(if_range_holds("\"a\"", "\"a\"", Some(m)));
        assert!(!if_range_holds("\"b\"", "\"a\"", Some(m)));
        assert!(!if_range_holds("W/\"a\"", "W/\"a\"", Some(m)));
        assert!(!if_range_holds("\"a\"", "W/\"a\"", Some(m)));
        assert!(if_range_holds(date, "\"a\"", Some(m)));
        assert!(!if_range_holds(
            date,
            "\"a\"",
            Some(m + Duration::from_secs(1))
        ));
        assert!(!if_range_holds(date, "\"a\"", None));
        assert!(!if_range_holds("yesterday", "\"a\"", Some(m)));
    }
}
