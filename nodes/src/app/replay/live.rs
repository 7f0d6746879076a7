//! `vpsom replay --check` on a live trace: the maps, reproduced to a tolerance.
//!
//! In a live run the mapper is a process of its own. It integrates the frames it receives in
//! order, with the newest robot state it has, and publishes a map when a map period has passed;
//! every map says how many frames it integrated (`/map/meta` `frames_integrated`). The check
//! follows that record: before each recorded map it feeds a fresh mapper the recorded frames in
//! order (with the newest recorded state not later than each frame, and the frame's detections
//! by `frame_seq`) until it has integrated as many, writes the map at the recorded time, and
//! compares it with the recorded one object by object:
//!
//! - the same object ids, with the same class and background flag;
//! - each centre within [`CENTER_TOL_M`] and each size within [`SIZE_TOL_M`] per axis;
//! - the same number of frames integrated (fewer only if the trace lacks frames).
//!
//! The tolerance covers what a live host changes and the logic does not decide: the state the
//! mapper took for a frame (the newest it had received; here the newest recorded not later than
//! the frame, measured closer than the state before it). The state decides only whether the
//! frame is skipped for a lost localization. A frame the live mapper never read (overwritten in its buffer) is integrated here in
//! its place, so the maps after it differ beyond the tolerance. The first map outside it is
//! the divergence. Decisions and goals are not compared: which map the planner ran on, and when
//! its GBV job came back, are the host's timing.

use super::{
    Divergence, Inputs, ReplayError, ReplayReport, depth_stream, detections_of, frame_of, image_at,
    state_of, trace_err,
};
use crate::config::Config;
use crate::mapper::Mapper;
use runtime::recorder::convert;
use runtime::recorder::foxglove::messages::SceneUpdate;
use runtime::recorder::messages as rec;
use runtime::recorder::schemas::topic;
use shm_types::{DepthFrame, Detections, ObjectMap, RobotState, boxed_zeroed};
use std::fmt;
use std::path::Path;

/// Largest distance between a recorded and a replayed object centre still within tolerance, m.
pub const CENTER_TOL_M: f64 = 0.02;
/// Largest difference of a recorded and a replayed object size, per axis, m.
pub const SIZE_TOL_M: f64 = 0.02;

/// What the tolerance check of a live trace found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LiveCheck {
    /// Recorded maps compared.
    pub maps: u64,
    /// Of which within tolerance.
    pub within: u64,
    /// Objects compared (over every map).
    pub objects: u64,
    /// Largest centre deviation of a matched object, m.
    pub max_center_m: f64,
    /// Largest size deviation of a matched object, per axis, m.
    pub max_size_m: f64,
    /// Messages the recorder dropped (a dropped input makes the maps after it differ).
    pub dropped: u64,
}

impl fmt::Display for LiveCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "live trace: {} of {} maps within tolerance (centre {CENTER_TOL_M} m, size \
             {SIZE_TOL_M} m, same ids, classes and frame counts); {} objects compared, largest \
             deviation centre {:.4} m, size {:.4} m; {} messages dropped by the recorder; decisions \
             and goals not compared (host timing)",
            self.within, self.maps, self.objects, self.max_center_m, self.max_size_m, self.dropped
        )
    }
}

/// One object of a map as recorded: id, class, background, centre, size.
#[derive(Debug, Clone, PartialEq)]
struct Cuboid {
    id: String,
    class: String,
    background: String,
    center: [f64; 3],
    size: [f64; 3],
}

/// The cuboids of a recorded (or converted) map.
fn cuboids(u: &SceneUpdate) -> Vec<Cuboid> {
    u.entities
        .iter()
        .filter_map(|e| {
            let c = e.cubes.first()?;
            let p = c.pose.as_ref()?.position.as_ref()?;
            let s = c.size.as_ref()?;
            let meta = |k: &str| {
                e.metadata
                    .iter()
                    .find(|kv| kv.key == k)
                    .map_or(String::new(), |kv| kv.value.clone())
            };
            Some(Cuboid {
                id: e.id.clone(),
                class: meta("class"),
                background: meta("background"),
                center: [p.x, p.y, p.z],
                size: [s.x, s.y, s.z],
            })
        })
        .collect()
}

/// Compare a replayed map with the recorded one; `Err` says what is outside the tolerance.
fn compare(got: &[Cuboid], want: &[Cuboid], stats: &mut LiveCheck) -> Result<(), String> {
    if got.len() != want.len() {
        return Err(format!(
            "{} objects recorded, {} replayed",
            want.len(),
            got.len()
        ));
    }
    for w in want {
        let Some(g) = got.iter().find(|g| g.id == w.id) else {
            return Err(format!("{} ({}) recorded, not replayed", w.id, w.class));
        };
        if (&g.class, &g.background) != (&w.class, &w.background) {
            return Err(format!(
                "{}: recorded {} (background {}), replayed {} (background {})",
                w.id, w.class, w.background, g.class, g.background
            ));
        }
        let dc = (0..3)
            .map(|i| (g.center[i] - w.center[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let ds = (0..3)
            .map(|i| (g.size[i] - w.size[i]).abs())
            .fold(0.0, f64::max);
        stats.objects += 1;
        stats.max_center_m = stats.max_center_m.max(dc);
        stats.max_size_m = stats.max_size_m.max(ds);
        if dc > CENTER_TOL_M || ds > SIZE_TOL_M {
            return Err(format!(
                "{} ({}): centre {:.4} m and size {:.4} m from the recording (tolerance \
                 {CENTER_TOL_M} m, {SIZE_TOL_M} m)",
                w.id, w.class, dc, ds
            ));
        }
    }
    Ok(())
}

/// The tolerance check of a live trace (module docs).
pub(super) fn check(path: &Path, inp: Inputs, cfg: &Config) -> Result<ReplayReport, ReplayError> {
    let mut mapper = Mapper::new(&cfg.mapper, &cfg.camera.camera())?;
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let mut map = boxed_zeroed::<ObjectMap>();
    let mut metas: Vec<_> = inp.depth_meta.values().collect();
    metas.sort_by_key(|m| m.seq);
    // By frame: a live detector stamps its detections with a time of its own.
    let by_frame: std::collections::HashMap<u64, &rec::DetectionsRaw> =
        inp.detections.values().map(|d| (d.frame_seq, d)).collect();
    let frames = depth_stream(path);
    let mut report = ReplayReport::default();
    let mut stats = LiveCheck {
        dropped: inp.dropped,
        ..LiveCheck::default()
    };
    let (mut next_frame, mut next_state) = (0usize, 0usize);
    let mut state = RobotState::default();
    let mut integrated = 0u32;
    let outputs = inp.outputs;
    for (i, ((t, want), (_, meta))) in outputs.maps.iter().zip(&outputs.map_meta).enumerate() {
        while integrated < meta.frames_integrated {
            let Some(m) = metas.get(next_frame) else {
                break;
            };
            next_frame += 1;
            let ft = m.sim_time_ns;
            let img = image_at(&frames, path, ft)?;
            while let Some(s) = inp.states.get(next_state).filter(|s| s.sim_time_ns <= ft) {
                state = state_of(s).map_err(|e| trace_err(path, format!("/robot/state: {e}")))?;
                next_state += 1;
            }
            // Without its detections the live mapper skipped the frame too.
            let Some(d) = by_frame.get(&m.seq) else {
                continue;
            };
            frame_of(m, &img, &mut frame).map_err(|e| trace_err(path, e))?;
            detections_of(d, &mut dets).map_err(|e| trace_err(path, e))?;
            // A frame the mapper refuses the live mapper counted as rejected or unmatched.
            if mapper.integrate(&frame, &dets, &state).is_ok() {
                integrated += 1;
            }
            report.frames += 1;
        }
        mapper.write_map(&mut map, meta.sim_time_ns);
        stats.maps += 1;
        *report.produced.entry(topic::MAP).or_insert(0) += 1;
        *report.compared.entry(topic::MAP).or_insert(0) += 1;
        let r = if integrated != meta.frames_integrated {
            Err(format!(
                "{} frames integrated by the live mapper, only {integrated} here: the trace lacks \
                 frames it read",
                meta.frames_integrated
            ))
        } else {
            compare(
                &cuboids(&convert::map_objects(&map)),
                &cuboids(want),
                &mut stats,
            )
        };
        match r {
            Ok(()) => stats.within += 1,
            Err(detail) => {
                if report.divergence.is_none() {
                    report.divergence = Some(Divergence {
                        time_ns: *t,
                        topic: topic::MAP,
                        index: i,
                        detail,
                    });
                }
            }
        }
        report.end_ns = meta.sim_time_ns;
    }
    report.steps = inp.states.len() as u64;
    report.live = Some(stats);
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cuboid(id: &str, class: &str, center: [f64; 3]) -> Cuboid {
        Cuboid {
            id: id.into(),
            class: class.into(),
            background: "false".into(),
            center,
            size: [0.1, 0.1, 0.12],
        }
    }

    #[test]
    fn maps_within_the_tolerance_pass_and_outside_it_diverge() {
        let want = [cuboid("obj/1", "cup", [1.0, 0.0, 0.8])];
        let mut s = LiveCheck::default();
        assert!(compare(&[cuboid("obj/1", "cup", [1.015, 0.0, 0.8])], &want, &mut s).is_ok());
        assert!((s.max_center_m - 0.015).abs() < 1e-9 && s.objects == 1);
        let far = compare(&[cuboid("obj/1", "cup", [1.03, 0.0, 0.8])], &want, &mut s);
        assert!(far.unwrap_err().contains("centre 0.0300 m"));
        let class = compare(&[cuboid("obj/1", "bowl", [1.0, 0.0, 0.8])], &want, &mut s);
        assert!(class.unwrap_err().contains("replayed bowl"));
        let id = compare(&[cuboid("obj/2", "cup", [1.0, 0.0, 0.8])], &want, &mut s);
        assert!(id.unwrap_err().contains("not replayed"));
        assert!(compare(&[], &want, &mut s).is_err());
        let mut big = cuboid("obj/1", "cup", [1.0, 0.0, 0.8]);
        big.size[2] = 0.15;
        assert!(compare(&[big], &want, &mut s).is_err());
    }
}
