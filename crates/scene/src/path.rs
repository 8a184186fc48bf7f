//! Camera path files (docs/path-format.md): one pose per line.
//!
//! A path is what `gigawalk generate --path` and the viewer write and what
//! replay reads: poses at increasing times, positions in f64 world
//! coordinates (so paths through models far from the origin keep precision),
//! orientations as quaternions rotating camera-local vectors into world.

use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};

/// How far a quaternion's length may be from 1 and still be accepted (and
/// normalised). Paths written with 6+ significant digits are well within
/// this; anything further off is a corrupt or hand-mangled line, not rounding.
pub const QUAT_NORM_TOLERANCE: f64 = 1e-3;

/// One camera sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Seconds from the start of the path; strictly increasing along a path.
    pub time: f64,
    /// Eye position in world coordinates.
    pub position: DVec3,
    /// Rotates camera-local vectors (camera looks along -Z, +Y up) into world.
    pub orientation: DQuat,
    /// Vertical field of view in radians (the file stores degrees).
    pub fovy: f64,
}

/// A sequence of poses at strictly increasing times.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraPath {
    pub poses: Vec<Pose>,
}

/// Why a path file could not be read or parsed. Line numbers are 1-based.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PathReadError {
    #[error("{file}: cannot read camera path: {source}")]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: {source}")]
    Parse {
        file: PathBuf,
        source: PathParseError,
    },
}

/// A malformed line in a path file.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum PathParseError {
    #[error("line {line}: expected 9 numbers (t x y z qx qy qz qw fovy_deg), found {found}")]
    FieldCount { line: usize, found: usize },
    #[error("line {line}: field {field} is not a number: {text:?}")]
    NotANumber {
        line: usize,
        field: usize,
        text: String,
    },
    #[error("line {line}: field {field} is not finite ({value})")]
    NotFinite {
        line: usize,
        field: usize,
        value: f64,
    },
    #[error("line {line}: time {time} does not increase (previous pose at {previous})")]
    NonIncreasingTime {
        line: usize,
        time: f64,
        previous: f64,
    },
    #[error("line {line}: quaternion length {length} is not close to 1 (tolerance {QUAT_NORM_TOLERANCE})")]
    BadQuaternion { line: usize, length: f64 },
    #[error("line {line}: vertical field of view {fovy_deg} degrees is outside (0, 180)")]
    BadFov { line: usize, fovy_deg: f64 },
}

/// Why a path could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PathWriteError {
    #[error("{file}: cannot write camera path: {source}")]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
}

const HEADER: &str = "# gigawalk camera path v1 (docs/path-format.md)\n\
# time_s x y z qx qy qz qw fovy_deg\n";

impl Pose {
    /// The unit vector the camera looks along, in world coordinates.
    pub fn forward(&self) -> DVec3 {
        self.orientation * DVec3::NEG_Z
    }
}

impl CameraPath {
    /// Reads and parses a path file.
    pub fn read(path: &Path) -> Result<CameraPath, PathReadError> {
        let text = std::fs::read_to_string(path).map_err(|source| PathReadError::Io {
            file: path.to_owned(),
            source,
        })?;
        Self::parse(&text).map_err(|source| PathReadError::Parse {
            file: path.to_owned(),
            source,
        })
    }

    /// Parses path text: one pose per line, `#` comments and blank lines
    /// allowed. Near-unit quaternions are normalised.
    pub fn parse(text: &str) -> Result<CameraPath, PathParseError> {
        let mut poses: Vec<Pose> = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let content = raw.split('#').next().unwrap_or("").trim();
            if content.is_empty() {
                continue;
            }
            let fields: Vec<&str> = content.split_whitespace().collect();
            if fields.len() != 9 {
                return Err(PathParseError::FieldCount {
                    line,
                    found: fields.len(),
                });
            }
            let mut v = [0.0f64; 9];
            for (k, f) in fields.iter().enumerate() {
                let value: f64 = f.parse().map_err(|_| PathParseError::NotANumber {
                    line,
                    field: k + 1,
                    text: (*f).to_owned(),
                })?;
                if !value.is_finite() {
                    return Err(PathParseError::NotFinite {
                        line,
                        field: k + 1,
                        value,
                    });
                }
                v[k] = value;
            }
            let time = v[0];
            if let Some(prev) = poses.last() {
                if time <= prev.time {
                    return Err(PathParseError::NonIncreasingTime {
                        line,
                        time,
                        previous: prev.time,
                    });
                }
            }
            let q = DQuat::from_xyzw(v[4], v[5], v[6], v[7]);
            let length = q.length();
            if (length - 1.0).abs() > QUAT_NORM_TOLERANCE {
                return Err(PathParseError::BadQuaternion { line, length });
            }
            let fovy_deg = v[8];
            if !(fovy_deg > 0.0 && fovy_deg < 180.0) {
                return Err(PathParseError::BadFov { line, fovy_deg });
            }
            poses.push(Pose {
                time,
                position: DVec3::new(v[1], v[2], v[3]),
                orientation: q / length,
                fovy: fovy_deg.to_radians(),
            });
        }
        Ok(CameraPath { poses })
    }

    /// The file text for this path. Numbers use Rust's shortest round-trip
    /// formatting, so `parse(to_text())` gives back the same positions and
    /// times bit for bit.
    pub fn to_text(&self) -> String {
        let mut s = String::with_capacity(HEADER.len() + self.poses.len() * 120);
        s.push_str(HEADER);
        for p in &self.poses {
            let q = p.orientation;
            s.push_str(&format!(
                "{} {} {} {} {} {} {} {} {}\n",
                p.time,
                p.position.x,
                p.position.y,
                p.position.z,
                q.x,
                q.y,
                q.z,
                q.w,
                p.fovy.to_degrees()
            ));
        }
        s
    }

    #[cfg(not(target_arch = "wasm32"))]
    /// Writes the path atomically: a temporary file in the same directory,
    /// renamed over `path` once complete, so readers never see half a file.
    pub fn write(&self, path: &Path) -> Result<(), PathWriteError> {
        let err = |source| PathWriteError::Io {
            file: path.to_owned(),
            source,
        };
        crate::write_atomic(path, self.to_text().as_bytes()).map_err(err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(time: f64) -> Pose {
        Pose {
            time,
            position: DVec3::new(1.0e7 + 0.125, 1.7, -3.5),
            orientation: DQuat::from_rotation_y(0.3),
            fovy: 60f64.to_radians(),
        }
    }

    #[test]
    fn empty_text_is_empty_path() {
        assert_eq!(CameraPath::parse("").unwrap().poses.len(), 0);
        assert_eq!(CameraPath::parse("# only\n\n  \n").unwrap().poses.len(), 0);
    }

    #[test]
    fn round_trip_is_exact_for_positions_and_times() {
        let path = CameraPath {
            poses: vec![pose(0.0), pose(0.1), pose(0.2)],
        };
        let back = CameraPath::parse(&path.to_text()).unwrap();
        assert_eq!(back.poses.len(), 3);
        for (a, b) in path.poses.iter().zip(&back.poses) {
            assert_eq!(a.time, b.time);
            assert_eq!(a.position, b.position);
            assert!(a.orientation.abs_diff_eq(b.orientation, 1e-15));
            assert!((a.fovy - b.fovy).abs() < 1e-15);
        }
    }

    #[test]
    fn comments_and_blank_lines_are_skipped() {
        let p = CameraPath::parse("# header\n\n0 1 2 3 0 0 0 1 60 # trailing\n").unwrap();
        assert_eq!(p.poses[0].position, DVec3::new(1.0, 2.0, 3.0));
        assert!((p.poses[0].fovy - 60f64.to_radians()).abs() < 1e-15);
    }

    #[test]
    fn near_unit_quaternion_is_normalised() {
        let p = CameraPath::parse("0 0 0 0 0 0 0 1.0004 60\n").unwrap();
        assert!((p.poses[0].orientation.length() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn rejects_with_line_numbers() {
        let check = |text: &str, expected: PathParseError| {
            assert_eq!(CameraPath::parse(text).unwrap_err(), expected, "{text:?}");
        };
        check(
            "0 0 0 0 0 0 0 1 60\n0 0 0 0 0 0 0 1 60\n",
            PathParseError::NonIncreasingTime {
                line: 2,
                time: 0.0,
                previous: 0.0,
            },
        );
        check(
            "# c\n0 0 0 0 0 0 0 0 60\n",
            PathParseError::BadQuaternion {
                line: 2,
                length: 0.0,
            },
        );
        check(
            "0 0 0 0 0 0 1 60\n",
            PathParseError::FieldCount { line: 1, found: 8 },
        );
        check(
            "0 0 zero 0 0 0 0 1 60\n",
            PathParseError::NotANumber {
                line: 1,
                field: 3,
                text: "zero".into(),
            },
        );
        check(
            "0 0 0 0 0 0 0 1 180\n",
            PathParseError::BadFov {
                line: 1,
                fovy_deg: 180.0,
            },
        );
    }

    #[test]
    fn nan_field_names_line_and_field() {
        let e = CameraPath::parse("0 0 0 0 0 0 0 1 60\n1 0 inf 0 0 0 0 1 60\n").unwrap_err();
        assert!(matches!(
            e,
            PathParseError::NotFinite {
                line: 2,
                field: 3,
                ..
            }
        ));
        let e = CameraPath::parse("0 nan 0 0 0 0 0 1 60\n").unwrap_err();
        assert!(matches!(
            e,
            PathParseError::NotFinite {
                line: 1,
                field: 2,
                ..
            }
        ));
    }

    #[test]
    fn write_then_read() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("walk.path");
        let path = CameraPath {
            poses: vec![pose(0.0), pose(1.5)],
        };
        path.write(&file).unwrap();
        let back = CameraPath::read(&file).unwrap();
        assert_eq!(back.poses.len(), 2);
        assert_eq!(back.poses[1].time, 1.5);
        let missing = CameraPath::read(&dir.path().join("nope.path")).unwrap_err();
        assert!(missing.to_string().contains("nope.path"));
    }
}
