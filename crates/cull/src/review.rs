//! What a reviewer's viewer keeps about a scene besides the camera: the
//! selection, search, hidden objects and saved views ([`objects`]), and
//! the section planes and box ([`sections`]). Pure state and text,
//! shared by the native viewer and the page, so both answer the same keys
//! the same way.

pub mod objects;
pub mod sections;

/// 1234567 -> "1,234,567": counts of millions read at a glance.
pub fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn group_thousands() {
        assert_eq!(group(0), "0");
        assert_eq!(group(999), "999");
        assert_eq!(group(1000), "1,000");
        assert_eq!(group(1234567), "1,234,567");
    }
}
