//! `map.json`: the final estimated map of a run, in the format fixed by `docs/formats.md`:
//! `{"scene": NAME, "objects": [{"class", "background", "center", "size", "yaw", "h_sopm",
//! "complete"}, ...]}` (world frame, metres, radians).

use super::matching::MatchParams;
use super::metrics::{EstObject, GtObject, Layer, MapScore, estimates_from_map, score_map};
use super::{EvalError, read_json, write_json};
use serde::{Deserialize, Serialize};
use shm_types::ObjectMap;
use std::path::Path;

/// One object of `map.json` (same fields as [`EstObject`]).
pub type MapFileObject = EstObject;

/// Content of `map.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapFile {
    /// Scene name.
    pub scene: String,
    /// The estimated objects, in map order.
    pub objects: Vec<MapFileObject>,
}

/// Foreground and background scores of a map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapScores {
    /// Foreground objects (the headline precision, recall, IoU, CDE).
    pub foreground: MapScore,
    /// Background objects.
    pub background: MapScore,
}

impl MapFile {
    /// The map file of an estimated map.
    pub fn from_object_map(scene: &str, map: &ObjectMap) -> Self {
        Self::from_estimates(scene, &estimates_from_map(map))
    }

    /// The map file of a list of estimates.
    pub fn from_estimates(scene: &str, objects: &[EstObject]) -> Self {
        Self {
            scene: scene.to_string(),
            objects: objects.to_vec(),
        }
    }

    /// Write as pretty JSON (creating parent directories).
    pub fn write(&self, path: &Path) -> Result<(), EvalError> {
        write_json(path, self)
    }

    /// Read and check a `map.json`: numbers finite, sizes non-negative, classes non-empty.
    pub fn read(path: &Path) -> Result<Self, EvalError> {
        let m: MapFile = read_json(path)?;
        m.check(path)?;
        Ok(m)
    }

    fn check(&self, path: &Path) -> Result<(), EvalError> {
        let bad = |k: usize, field: &str, reason: String| EvalError::Invalid {
            path: path.to_path_buf(),
            field: format!("objects[{k}].{field}"),
            reason,
        };
        for (k, o) in self.objects.iter().enumerate() {
            if o.class.is_empty() {
                return Err(bad(k, "class", "is empty".into()));
            }
            if o.center.iter().any(|v| !v.is_finite()) {
                return Err(bad(k, "center", format!("{:?} is not finite", o.center)));
            }
            if o.size.iter().any(|v| !v.is_finite() || *v < 0.0) {
                return Err(bad(
                    k,
                    "size",
                    format!("{:?} must be finite and ≥ 0", o.size),
                ));
            }
            if !o.yaw.is_finite() {
                return Err(bad(k, "yaw", format!("{} is not finite", o.yaw)));
            }
            if !o.h_sopm.is_finite() {
                return Err(bad(k, "h_sopm", format!("{} is not finite", o.h_sopm)));
            }
        }
        Ok(())
    }

    /// Score this map against ground truth.
    pub fn score(&self, gt: &[GtObject], params: &MatchParams) -> MapScores {
        MapScores {
            foreground: score_map(gt, &self.objects, params, Layer::Foreground),
            background: score_map(gt, &self.objects, params, Layer::Background),
        }
    }
}

/// Re-score a `map.json` against ground truth.
pub fn rescore_map_file(
    path: &Path,
    gt: &[GtObject],
    params: &MatchParams,
) -> Result<MapScores, EvalError> {
    Ok(MapFile::read(path)?.score(gt, params))
}
