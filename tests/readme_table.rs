//! The README's demo table says what `gigawalk demo` prints today: its
//! columns are columns of the table the demo prints (`Summary::table`, the
//! same function, not a copy of its header), in the same order, and its
//! rows are the demo's modes (`demo::replay_options`).

use gigawalk_replay::RUN_TABLE_HEADER;

#[test]
fn the_readme_demo_table_has_the_columns_and_modes_the_demo_prints() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let (header, rows) =
        demo_table(&readme).expect("a table in README.md whose first column is mode");
    let printed = cells(
        summary_table_header()
            .lines()
            .next()
            .expect("the demo's table has a header"),
    );
    let mut at = 0;
    for column in &header {
        match printed[at..].iter().position(|c| c == column) {
            Some(i) => at += i + 1,
            None => panic!(
                "README's demo table has the column {column:?}, which the demo does not print \
                 there (in this order); the demo prints: {printed:?}"
            ),
        }
    }
    let modes: Vec<String> = rows
        .iter()
        .map(|r| r.first().cloned().unwrap_or_default())
        .collect();
    let demo = gigawalk_replay::demo::replay_options(1, 1, 1);
    let expected: Vec<&str> = demo.modes.iter().map(|m| m.name()).collect();
    assert_eq!(
        modes, expected,
        "the README's rows against the demo's modes"
    );
    for row in &rows {
        assert_eq!(row.len(), header.len(), "README demo table row {row:?}");
    }
}

#[test]
fn a_column_the_demo_does_not_print_is_found() {
    let readme =
        "# x\n\n| mode | mean fps | frames per joule |\n|---|---:|---:|\n| vfc | 1 | 2 |\n";
    let (header, _) = demo_table(readme).expect("a table");
    let printed = cells(summary_table_header().lines().next().expect("a header"));
    assert!(printed.contains(&header[1]));
    assert!(!printed.contains(&header[2]));
}

/// The header the demo prints above its per-run table, as the function
/// that prints it writes it.
fn summary_table_header() -> String {
    RUN_TABLE_HEADER.to_string()
}

/// The first markdown table of `text` whose first column is "mode": its
/// header cells and its rows' cells.
fn demo_table(text: &str) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    let lines: Vec<&str> = text.lines().collect();
    let start = lines.iter().position(|l| {
        l.trim_start().starts_with('|') && cells(l).first().map(String::as_str) == Some("mode")
    })?;
    let header = cells(lines[start]);
    let rows = lines[start + 2..]
        .iter()
        .take_while(|l| l.trim_start().starts_with('|'))
        .map(|l| cells(l))
        .collect();
    Some((header, rows))
}

/// The cells of a markdown table row, trimmed.
fn cells(row: &str) -> Vec<String> {
    let row = row.trim();
    let row = row.strip_prefix('|').unwrap_or(row);
    let row = row.strip_suffix('|').unwrap_or(row);
    row.split('|').map(|c| c.trim().to_string()).collect()
}
