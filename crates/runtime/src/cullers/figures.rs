//! What a culler reports, as named figures: the counts it keeps each frame
//! ([`Counter`]), how a run pools them ([`Figure`]), the settings it ran
//! with ([`Setting`]) and the table it gets in a replay's summary.md
//! ([`Table`]). Each culler's file declares its own; replay's CSV,
//! summary and tables, and the viewer's HUD, print them without knowing
//! which culler they belong to.

/// A count a culler keeps each frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counter {
    /// Its name, unique over every culler ("grid_raster_ms"); its
    /// frames.csv column where it has one.
    pub name: &'static str,
    /// Decimals it prints with (0: a whole count).
    pub decimals: usize,
    /// Whether frames.csv has a column for it.
    pub csv: bool,
}

/// How a run's summary pools a counter over its measured frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pool {
    /// The mean of the named counter.
    Mean(&'static str),
    /// The median of the named counter.
    Median(&'static str),
    /// `part` summed over the frames, over `whole` summed (or over 1 when
    /// that is 0).
    Share {
        part: &'static str,
        whole: &'static str,
    },
}

/// A figure of a run's summary (summary.json key `key`), pooled from a
/// culler's counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Figure {
    pub key: &'static str,
    pub pool: Pool,
}

/// One of a culler's settings as a replay's summary records it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Setting {
    Whole(u64),
    Number(f64),
    Flag(bool),
    /// No value: the culler did not run, or the option is off.
    Unset,
}

impl Setting {
    pub fn whole(self) -> Option<u64> {
        match self {
            Setting::Whole(n) => Some(n),
            _ => None,
        }
    }

    /// A number, whole or not.
    pub fn number(self) -> Option<f64> {
        match self {
            Setting::Whole(n) => Some(n as f64),
            Setting::Number(x) => Some(x),
            _ => None,
        }
    }

    pub fn flag(self) -> Option<bool> {
        match self {
            Setting::Flag(b) => Some(b),
            _ => None,
        }
    }
}

/// A replay's settings by name ([`Setting::Unset`] for unknown names).
pub type Settings<'a> = &'a dyn Fn(&str) -> Setting;

/// A culler's table in a replay's summary.md: a line saying how it was
/// set, then a row per run of the culler (after the run's mode and pixel
/// error).
#[derive(Clone, Copy, Debug)]
pub struct Table {
    /// The section's title.
    pub title: &'static str,
    /// The line above the table, from the replay's settings by name.
    pub preamble: fn(Settings<'_>) -> String,
    pub columns: &'static [Column],
}

/// A column of a culler's table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Column {
    /// The run's median STC milliseconds.
    StcMs,
    /// One of the culler's figures: its header, summary key and the
    /// decimals it prints with (`None`: a whole number with thousands
    /// separators).
    Figure {
        header: &'static str,
        key: &'static str,
        decimals: Option<usize>,
    },
    /// The run's mean occlusion-culled nodes a frame.
    OcclusionCulled,
    /// The run's mean triangles drawn a frame.
    Triangles,
}

impl Column {
    pub fn header(&self) -> &'static str {
        match self {
            Column::StcMs => "STC ms",
            Column::Figure { header, .. } => header,
            Column::OcclusionCulled => "occlusion-culled",
            Column::Triangles => "triangles",
        }
    }
}
