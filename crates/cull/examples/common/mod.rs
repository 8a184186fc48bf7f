//! What the cull examples share: positional arguments with defaults, and
//! the median they report.

/// Argument `i` parsed, or `default` when it is not given.
pub fn arg<T: std::str::FromStr>(args: &[String], i: usize, default: T) -> Result<T, String> {
    match args.get(i) {
        None => Ok(default),
        Some(s) => s
            .parse()
            .map_err(|_| format!("argument {i}: cannot parse {s:?}")),
    }
}

/// The upper median (of an even count, the larger middle value).
#[allow(dead_code)] // not every example reports one
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
