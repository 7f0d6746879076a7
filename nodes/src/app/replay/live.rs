//! `vpsom replay --check` on a live trace: the maps, reproduced exactly.
//!
//! In a live run the mapper is a process of its own. Which frames it reads (a frame its buffer
//! overwrote is never read), which robot state it holds for each (the newest it has received,
//! racing with the sim's next state) and whether the detections came in time are the host's
//! timing, not the mapper's logic. So the mapper says what it consumed: every map carries the
//! receipts of the frames consumed since the previous one (`ObjectMap::receipts`, recorded on
//! `/map/meta`): frame seq, the seq of the state it held, and the outcome (integrated, skipped
//! for lost localization, no detections, refused). The check follows them: before each
//! recorded map it feeds a fresh mapper the frames the receipts name, each with the recorded
//! state of that seq and the frame's detections (by `frame_seq`), writes the map at the
//! recorded time and requires
//!
//! - the same receipts (the replayed mapper came to the same outcome for every frame), and
//! - the same objects bit for bit: the recorded `/map/objects` scene update and the replayed
//!   one are equal (ids, classes, flags, cuboids, SOPM summary).
//!
//! The first map that differs is the divergence; the check goes on to the end and counts the
//! maps that are identical. A trace without receipts (recorded before they were added), or
//! one that lacks an input a receipt names (dropped by the recorder: counted and reported), is
//! reported as such. A mapper restarted mid-run resumes from its last map, which a fresh
//! mapper does not: the maps after a restart diverge. Decisions and goals are not compared:
//! which map the planner ran on, and when its GBV job came back, are the host's timing and are
//! not recorded.

use super::{
    Divergence, Inputs, ReplayError, ReplayReport, depth_stream, detections_of, frame_of, image_at,
    state_of, trace_err,
};
use crate::config::Config;
use crate::mapper::Mapper;
use runtime::recorder::convert;
use runtime::recorder::foxglove::messages::{RawImage, SceneUpdate};
use runtime::recorder::messages as rec;
use runtime::recorder::schemas::topic;
use shm_types::{DepthFrame, Detections, ObjectMap, RobotState, boxed_zeroed, frame_outcome};
use std::collections::HashMap;
use std::fmt;
use std::path::Path;
use std::sync::mpsc::Receiver;

/// What the check of a live trace found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LiveCheck {
    /// Recorded maps compared.
    pub maps: u64,
    /// Of which reproduced bit for bit.
    pub identical: u64,
    /// Objects of the recorded maps (over every map).
    pub objects: u64,
    /// Frames the receipts named (fed to the mapper or noted as without detections).
    pub receipts: u64,
    /// Messages the recorder dropped (a dropped input makes the maps after it differ).
    pub dropped: u64,
}

impl fmt::Display for LiveCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "live trace: {} of {} maps identical ({} objects; the mapper fed the {} frames the \
             maps' receipts name, each with the state the live mapper held); {} messages \
             dropped by the recorder; decisions and goals not compared (host timing)",
            self.identical, self.maps, self.objects, self.receipts, self.dropped
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

/// The first difference between a replayed and a recorded map that differ.
fn describe(got: &SceneUpdate, want: &SceneUpdate) -> String {
    let (got_c, want_c) = (cuboids(got), cuboids(want));
    if got_c.len() != want_c.len() {
        return format!(
            "{} objects recorded, {} replayed",
            want_c.len(),
            got_c.len()
        );
    }
    for w in &want_c {
        let Some(g) = got_c.iter().find(|g| g.id == w.id) else {
            return format!("{} ({}) recorded, not replayed", w.id, w.class);
        };
        if (&g.class, &g.background) != (&w.class, &w.background) {
            return format!(
                "{}: recorded {} (background {}), replayed {} (background {})",
                w.id, w.class, w.background, g.class, g.background
            );
        }
        if g != w {
            let dc = (0..3)
                .map(|i| (g.center[i] - w.center[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            let ds = (0..3)
                .map(|i| (g.size[i] - w.size[i]).abs())
                .fold(0.0, f64::max);
            return format!(
                "{} ({}): centre {dc:.2e} m and size {ds:.2e} m from the recording",
                w.id, w.class
            );
        }
    }
    let id = got
        .entities
        .iter()
        .zip(&want.entities)
        .find(|(g, w)| g != w)
        .map_or("the update", |(_, w)| w.id.as_str());
    format!("{id}: the same cuboid, other fields differ (metadata, colour or lifetime)")
}

/// The check of a live trace (module docs).
pub(super) fn check(path: &Path, inp: Inputs, cfg: &Config) -> Result<ReplayReport, ReplayError> {
    let outputs = &inp.outputs;
    if outputs.map_meta.iter().all(|(_, m)| m.receipt_count == 0)
        && outputs
            .map_meta
            .iter()
            .any(|(_, m)| m.frames_integrated > 0)
    {
        return Err(trace_err(
            path,
            "/map/meta has no frame receipts (a trace recorded before they were added): the \
             frames each map consumed are not known; record the run again",
        ));
    }
    let mut mapper = Mapper::new(&cfg.mapper, &cfg.camera.camera())?;
    let mut map = boxed_zeroed::<ObjectMap>();
    let mut feed = Feed {
        path,
        frames: depth_stream(path),
        metas: inp.depth_meta.values().map(|m| (m.seq, m)).collect(),
        // By frame: a live detector stamps its detections with a time of its own.
        detections: inp.detections.values().map(|d| (d.frame_seq, d)).collect(),
        states: inp.states.iter().map(|s| (s.seq, s)).collect(),
        frame: boxed_zeroed::<DepthFrame>(),
        dets: boxed_zeroed::<Detections>(),
    };
    let mut report = ReplayReport::default();
    let mut stats = LiveCheck {
        dropped: inp.dropped,
        ..LiveCheck::default()
    };
    for (i, ((t, want), (_, meta))) in outputs.maps.iter().zip(&outputs.map_meta).enumerate() {
        let r = feed.consume(&mut mapper, meta, &mut stats).and_then(|()| {
            mapper.write_map(&mut map, meta.sim_time_ns);
            let got = convert::map_meta(&map);
            if got.receipts != meta.receipts {
                let k = got
                    .receipts
                    .iter()
                    .zip(&meta.receipts)
                    .position(|(g, w)| g != w)
                    .unwrap_or(got.receipts.len().min(meta.receipts.len()));
                let name = |r: Option<&rec::FrameReceipt>| {
                    r.map_or("nothing".into(), |r| {
                        format!("frame {} {}", r.frame_seq, r.outcome)
                    })
                };
                return Err(format!(
                    "receipt {k}: recorded {}, replayed {}",
                    name(meta.receipts.get(k)),
                    name(got.receipts.get(k))
                ));
            }
            stats.objects += cuboids(want).len() as u64;
            let got = convert::map_objects(&map);
            if got == *want {
                Ok(())
            } else {
                Err(describe(&got, want))
            }
        });
        stats.maps += 1;
        *report.produced.entry(topic::MAP).or_insert(0) += 1;
        *report.compared.entry(topic::MAP).or_insert(0) += 1;
        match r {
            Ok(()) => stats.identical += 1,
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
    report.frames = stats.receipts;
    report.live = Some(stats);
    Ok(report)
}

/// The recorded inputs, looked up the way a map's receipts name them.
struct Feed<'a> {
    path: &'a Path,
    frames: Receiver<Result<(u64, RawImage), String>>,
    metas: HashMap<u64, &'a rec::DepthMeta>,
    detections: HashMap<u64, &'a rec::DetectionsRaw>,
    states: HashMap<u64, &'a rec::RobotStateRaw>,
    frame: Box<DepthFrame>,
    dets: Box<Detections>,
}

impl Feed<'_> {
    /// Feed `mapper` the frames a recorded map consumed, as its receipts name them: each frame
    /// with the state the live mapper held and its detections; a frame without detections only
    /// leaves its receipt. `Err` says which input the trace lacks.
    fn consume(
        &mut self,
        mapper: &mut Mapper,
        meta: &rec::MapMeta,
        stats: &mut LiveCheck,
    ) -> Result<(), String> {
        if meta.receipt_count as usize > meta.receipts.len() {
            return Err(format!(
                "the live mapper consumed {} frames for this map, its receipts name only {}",
                meta.receipt_count,
                meta.receipts.len()
            ));
        }
        for r in &meta.receipts {
            stats.receipts += 1;
            if r.outcome == convert::frame_outcome_name(frame_outcome::NO_DETECTIONS) {
                mapper.note_unmatched(r.frame_seq, r.state_seq);
                continue;
            }
            let m = self
                .metas
                .get(&r.frame_seq)
                .ok_or_else(|| format!("the trace lacks depth frame {}", r.frame_seq))?;
            let d = self.detections.get(&r.frame_seq).ok_or_else(|| {
                format!("the trace lacks the detections of frame {}", r.frame_seq)
            })?;
            let state = match r.state_seq {
                0 => RobotState::default(),
                seq => self
                    .states
                    .get(&seq)
                    .ok_or_else(|| format!("the trace lacks robot state {seq}"))
                    .and_then(|s| state_of(s).map_err(|e| format!("/robot/state: {e}")))?,
            };
            let img =
                image_at(&self.frames, self.path, m.sim_time_ns).map_err(|e| e.to_string())?;
            frame_of(m, &img, &mut self.frame)?;
            detections_of(d, &mut self.dets)?;
            // A refusal is a receipt too: compared with the recorded one after the map.
            let _ = mapper.integrate(&self.frame, &self.dets, &state);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::class_id;

    fn map_with(center: [f32; 3], class: &str) -> SceneUpdate {
        let mut m = boxed_zeroed::<ObjectMap>();
        m.count = 1;
        let o = &mut m.objects[0];
        o.id = 1;
        o.class_id = class_id(class).unwrap();
        o.center = center;
        o.size = [0.1, 0.1, 0.12];
        convert::map_objects(&m)
    }

    #[test]
    fn the_first_difference_of_two_maps_is_named() {
        let want = map_with([1.0, 0.0, 0.8], "cup");
        assert_eq!(map_with([1.0, 0.0, 0.8], "cup"), want);
        let moved = describe(&map_with([1.0, 0.001, 0.8], "cup"), &want);
        assert!(moved.contains("centre 1.00e-3 m"), "{moved}");
        let class = describe(&map_with([1.0, 0.0, 0.8], "bowl"), &want);
        assert!(class.contains("replayed bowl"), "{class}");
        let mut none = want.clone();
        none.entities.clear();
        assert!(describe(&none, &want).contains("1 objects recorded, 0 replayed"));
    }
}
