//! Recording the viewer's camera to a path file (docs/path-format.md) that
//! `gigawalk replay` and `gigawalk view --path` read back.

use std::path::{Path, PathBuf};

use gigawalk_cull::Camera;
use gigawalk_scene::path::{CameraPath, Pose};

/// Poses closer in time than this are dropped: 1/120 s, finer than any
/// display, so a fast viewer does not write thousands of near-duplicates.
pub const MIN_POSE_INTERVAL_S: f64 = 1.0 / 120.0;

/// A path being recorded: poses stamped with seconds since the start.
#[derive(Debug, Default)]
pub struct PathRecorder {
    recording: Option<CameraPath>,
}

impl PathRecorder {
    pub fn is_recording(&self) -> bool {
        self.recording.is_some()
    }

    pub fn start(&mut self) {
        self.recording = Some(CameraPath::default());
    }

    /// Adds the camera at `time` seconds since `start`; ignored when not
    /// recording or too soon after the previous pose.
    pub fn push(&mut self, time: f64, camera: &Camera) {
        let Some(path) = &mut self.recording else {
            return;
        };
        if let Some(last) = path.poses.last() {
            if time.is_nan() || time < last.time + MIN_POSE_INTERVAL_S {
                return;
            }
        }
        path.poses.push(Pose {
            time,
            position: camera.position,
            orientation: camera.orientation.normalize(),
            fovy: camera.fovy,
        });
    }

    /// Stops recording and returns the path (None if not recording).
    pub fn stop(&mut self) -> Option<CameraPath> {
        self.recording.take()
    }

    pub fn pose_count(&self) -> usize {
        self.recording.as_ref().map_or(0, |p| p.poses.len())
    }
}

/// Writes `path` to the first free `<stem>-<n>.<ext>` in `dir` (n from 1),
/// never overwriting an earlier recording or screenshot.
pub fn next_free_name(dir: &Path, stem: &str, ext: &str) -> PathBuf {
    (1..)
        .map(|n| dir.join(format!("{stem}-{n}.{ext}")))
        .find(|p| !p.exists())
        .expect("some number is free")
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};

    fn cam(x: f64) -> Camera {
        Camera {
            position: DVec3::new(x, 1.0, 2.0),
            orientation: DQuat::from_rotation_y(0.3),
            fovy: 1.0,
            aspect: 1.5,
            near: 0.1,
        }
    }

    #[test]
    fn not_recording_keeps_nothing() {
        let mut r = PathRecorder::default();
        r.push(0.0, &cam(0.0));
        assert!(r.stop().is_none());
    }

    #[test]
    fn too_close_poses_are_dropped_and_times_increase() {
        let mut r = PathRecorder::default();
        r.start();
        r.push(0.0, &cam(0.0));
        r.push(0.001, &cam(1.0));
        r.push(0.5, &cam(2.0));
        let p = r.stop().expect("recording");
        assert_eq!(p.poses.len(), 2);
        assert_eq!(p.poses[1].position.x, 2.0);
    }

    #[test]
    fn recorded_path_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let mut r = PathRecorder::default();
        r.start();
        for i in 0..5 {
            r.push(i as f64 * 0.1, &cam(i as f64));
        }
        let p = r.stop().unwrap();
        let file = next_free_name(dir.path(), "view", "path");
        assert!(file.ends_with("view-1.path"));
        p.write(&file).unwrap();
        let back = CameraPath::read(&file).unwrap();
        assert_eq!(back.poses.len(), 5);
        assert!((back.poses[4].position.x - 4.0).abs() < 1e-6);
        assert!(next_free_name(dir.path(), "view", "path").ends_with("view-2.path"));
    }
}
