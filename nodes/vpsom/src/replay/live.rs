//! `vpsom replay --check` on a live trace: maps, decisions and goals, reproduced exactly.
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
//! The planner is followed the same way. Its LBV thread runs a cycle whenever a robot state
//! arrives, on the newest map and grids it holds, and takes a chassis-goal round's result when
//! the pool has one; each cycle publishes a neck goal naming what it used (`map_seq`,
//! `state_seq`, `nav_seq`, `explore_seq`, `round_done`). The check runs a fresh planner one cycle
//! per recorded neck goal, on the replayed map and exploration grid of those seqs (the mapper
//! publishes the two together, so their seqs agree) and the recorded state and navigation grid,
//! runs an outstanding round where the goal says its result came back, and requires every neck
//! goal, decision and nav goal to equal the recorded one but for the host's fields (sequence
//! numbers, wall-clock stamps, evaluation times).
//!
//! The first output that differs is the divergence. The maps are checked to the end and the
//! identical ones counted (the receipts keep the mapper's inputs in step); the planner's outputs
//! are not compared past its first divergence. A trace without receipts (recorded before they
//! were added), or one that lacks an input a receipt or goal names (dropped by the recorder:
//! counted and reported), is reported as such. A node restarted mid-run diverges after the
//! restart: a resumed mapper starts from its last map, a restarted planner from nothing.

use super::{
    Divergence, Inputs, ReplayError, ReplayReport, depth_stream, detections_of, frame_of, grid_of,
    header, image_at, state_of, trace_err,
};
use crate::config::Config;
use crate::mapper::Mapper;
use crate::planner::{self, PlannerInputs, Step, ViewPlanner};
use crate::recording::messages as rec;
use crate::recording::{convert, topic};
use crate::step::gbv_cycle;
use foxglove::messages::{RawImage, SceneUpdate};
use shm_types::{
    DepthFrame, Detections, ObjectMap, OccupancyGrid, PlannerDecision, RobotState, boxed_zeroed,
    decision_kind, frame_outcome, planner_state,
};
use std::collections::{HashMap, VecDeque};
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
    /// Planner cycles replayed (one per recorded neck goal) up to the planner's first divergence.
    pub cycles: u64,
    /// Decisions compared.
    pub decisions: u64,
    /// Nav goals compared.
    pub nav_goals: u64,
    /// The planner's first divergence (its outputs after it are not compared).
    pub planner_divergence: Option<Divergence>,
}

impl fmt::Display for LiveCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "live trace: {} of {} maps identical ({} objects; the mapper fed the {} frames the \
             maps' receipts name, each with the state the live mapper held); {} messages \
             dropped by the recorder",
            self.identical, self.maps, self.objects, self.receipts, self.dropped
        )?;
        write!(
            f,
            "live trace: planner {} cycles (one per neck goal, with the map, state and grids it \
             names), {} decisions and {} nav goals compared",
            self.cycles, self.decisions, self.nav_goals
        )?;
        match &self.planner_divergence {
            None => writeln!(f, ", all identical"),
            Some(d) => writeln!(f, "; the planner diverged: {d}"),
        }
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
    let mut maps = Maps {
        mapper: Mapper::new(&cfg.mapper, &cfg.camera.camera())?,
        feed: Feed {
            path,
            frames: depth_stream(path),
            metas: inp.depth_meta.values().map(|m| (m.seq, m)).collect(),
            // By frame: a live detector stamps its detections with a time of its own.
            detections: inp.detections.values().map(|d| (d.frame_seq, d)).collect(),
            states: inp.states.iter().map(|s| (s.seq, s)).collect(),
            frame: boxed_zeroed::<DepthFrame>(),
            dets: boxed_zeroed::<Detections>(),
        },
        recorded: outputs.maps.iter().zip(&outputs.map_meta).enumerate(),
        held: VecDeque::new(),
        stats: LiveCheck {
            dropped: inp.dropped,
            ..LiveCheck::default()
        },
        divergence: None,
        end_ns: 0,
    };
    let mut plan = Cycles::new(cfg, outputs, inp.grids.iter().map(|g| (g.seq, g)).collect());
    for (t, neck) in &outputs.neck {
        if plan.divergence.is_some() {
            break;
        }
        maps.produce_through(neck.map_seq.max(neck.explore_seq));
        let r = plan.cycle(*t, neck, &maps, &maps.feed.states);
        if let Err(detail) = r {
            plan.diverge(*t, topic::NECK_GOAL, detail);
        }
    }
    maps.produce_through(u64::MAX);
    plan.leftovers();
    let mut stats = maps.stats;
    (stats.cycles, stats.decisions, stats.nav_goals) =
        (plan.cycles, plan.out.decisions, plan.out.nav);
    stats.planner_divergence = plan.divergence.clone();
    let mut report = ReplayReport {
        divergence: [maps.divergence, plan.divergence]
            .into_iter()
            .flatten()
            .min_by_key(|d| d.time_ns),
        end_ns: maps.end_ns,
        steps: inp.states.len() as u64,
        frames: stats.receipts,
        ..ReplayReport::default()
    };
    for (topic, n) in [
        (topic::MAP, stats.maps),
        (topic::NECK_GOAL, plan.cycles),
        (topic::DECISIONS, plan.out.decisions),
        (topic::NAV_GOAL, plan.out.nav),
    ] {
        report.produced.insert(topic, n);
        report.compared.insert(topic, n);
    }
    report.live = Some(stats);
    Ok(report)
}

/// The mapper's side: the recorded maps reproduced in order, following their receipts; the
/// newest few kept (with the exploration grid written with each) for the planner's cycles.
struct Maps<'a, I> {
    mapper: Mapper,
    feed: Feed<'a>,
    recorded: I,
    /// Maps produced, newest last: (seq, map, exploration grid).
    held: VecDeque<(u64, Box<ObjectMap>, Box<OccupancyGrid>)>,
    stats: LiveCheck,
    divergence: Option<Divergence>,
    end_ns: u64,
}

/// Maps (and their grids) kept for the planner: it may run on a map older than the newest.
const HELD_MAPS: usize = 8;

impl<'a, I> Maps<'a, I>
where
    I: Iterator<Item = (usize, (&'a (u64, SceneUpdate), &'a (u64, rec::MapMeta)))>,
{
    /// Reproduce the recorded maps up to and including the one of header seq `seq`.
    fn produce_through(&mut self, seq: u64) {
        while self.held.back().is_none_or(|(s, ..)| *s < seq) {
            let Some((i, ((t, want), (_, meta)))) = self.recorded.next() else {
                return;
            };
            let (mut map, mut grid) = if self.held.len() == HELD_MAPS {
                let (_, m, g) = self.held.pop_front().expect("held maps");
                (m, g)
            } else {
                (boxed_zeroed::<ObjectMap>(), boxed_zeroed::<OccupancyGrid>())
            };
            let r = self.next_map(meta, want, &mut map);
            self.mapper.write_grid(&mut grid);
            // The host's header and counts, as the planner received them; the mapper publishes
            // the exploration grid with every map, so the two seqs go together.
            map.header = header(meta.seq, meta.stamp_ns, meta.sim_time_ns);
            (
                map.frames_integrated,
                map.frames_rejected,
                map.frames_unmatched,
            ) = (
                meta.frames_integrated,
                meta.frames_rejected,
                meta.frames_unmatched,
            );
            grid.header = map.header;
            self.held.push_back((meta.seq, map, grid));
            self.stats.maps += 1;
            self.end_ns = meta.sim_time_ns;
            match r {
                Ok(()) => self.stats.identical += 1,
                Err(detail) => {
                    if self.divergence.is_none() {
                        self.divergence = Some(Divergence {
                            time_ns: *t,
                            topic: topic::MAP,
                            index: i,
                            detail,
                        });
                    }
                }
            }
        }
    }

    /// Feed the mapper what `meta`'s receipts name, write the map and compare it.
    fn next_map(
        &mut self,
        meta: &rec::MapMeta,
        want: &SceneUpdate,
        map: &mut ObjectMap,
    ) -> Result<(), String> {
        self.feed.consume(&mut self.mapper, meta, &mut self.stats)?;
        self.mapper.write_map(map, meta.sim_time_ns);
        let got = convert::map_meta(map);
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
        self.stats.objects += want.entities.iter().filter(|e| !e.cubes.is_empty()).count() as u64;
        let got = convert::map_objects(map);
        if got == *want {
            Ok(())
        } else {
            Err(describe(&got, want))
        }
    }

    /// The map of header seq `seq` and the exploration grid published with it, if still held.
    fn held(&self, seq: u64) -> Option<(&ObjectMap, &OccupancyGrid)> {
        self.held
            .iter()
            .find(|(s, ..)| *s == seq)
            .map(|(_, m, g)| (&**m, &**g))
    }
}

/// The planner's side: its LBV cycles as the live host ran them, one per recorded neck goal,
/// each with the map, state and grids the goal names, and a chassis-goal round taken where the
/// goal says one came back from the pool; every neck goal, decision and nav goal compared with
/// the recorded one (host fields apart: sequence numbers, wall-clock stamps, evaluation times).
struct Cycles<'a> {
    planner: Box<dyn ViewPlanner>,
    lbv: Box<PlannerDecision>,
    empty_map: Box<ObjectMap>,
    empty_grid: Box<OccupancyGrid>,
    nav_grid: Box<OccupancyGrid>,
    nav_grids: HashMap<u64, &'a rec::OccupancyGridRaw>,
    /// The round in the pool.
    outstanding: Option<planner::PlannerJob>,
    finished: bool,
    cycles: u64,
    out: Outputs<'a>,
    divergence: Option<Divergence>,
}

/// The recorded decisions and nav goals not yet compared, and how many were.
struct Outputs<'a> {
    decisions_left: std::collections::vec_deque::Iter<'a, (u64, rec::PlannerDecision)>,
    nav_left: std::collections::vec_deque::Iter<'a, (u64, rec::NavGoal)>,
    decisions: u64,
    nav: u64,
}

impl<'a> Cycles<'a> {
    fn new(
        cfg: &Config,
        outputs: &'a super::Recorded,
        nav_grids: HashMap<u64, &'a rec::OccupancyGridRaw>,
    ) -> Self {
        Self {
            planner: planner::make_planner(&cfg.planner, &cfg.camera),
            lbv: boxed_zeroed(),
            empty_map: boxed_zeroed(),
            empty_grid: boxed_zeroed(),
            nav_grid: boxed_zeroed(),
            nav_grids,
            outstanding: None,
            finished: false,
            cycles: 0,
            out: Outputs {
                decisions_left: outputs.decisions.iter(),
                nav_left: outputs.nav.iter(),
                decisions: 0,
                nav: 0,
            },
            divergence: None,
        }
    }

    fn diverge(&mut self, time_ns: u64, topic: &'static str, detail: String) {
        let index = match topic {
            topic::DECISIONS => self.out.decisions,
            topic::NAV_GOAL => self.out.nav,
            _ => self.cycles,
        } as usize;
        self.divergence.get_or_insert(Divergence {
            time_ns,
            topic,
            index,
            detail,
        });
    }

    /// One LBV cycle of the live planner host, from the inputs its recorded neck goal names.
    fn cycle<I>(
        &mut self,
        t_rec: u64,
        want: &rec::NeckGoal,
        maps: &Maps<'a, I>,
        states: &HashMap<u64, &rec::RobotStateRaw>,
    ) -> Result<(), String>
    where
        I: Iterator<Item = (usize, (&'a (u64, SceneUpdate), &'a (u64, rec::MapMeta)))>,
    {
        if self.finished {
            return Err("recorded after the replayed planner finished".into());
        }
        let state = states
            .get(&want.state_seq)
            .ok_or_else(|| format!("the trace lacks robot state {}", want.state_seq))
            .and_then(|s| state_of(s).map_err(|e| format!("/robot/state: {e}")))?;
        let t = state.header.sim_time_ns;
        let map = match want.map_seq {
            0 => &*self.empty_map,
            seq => {
                maps.held(seq)
                    .ok_or_else(|| format!("map {seq} is not among the replayed maps"))?
                    .0
            }
        };
        let explore = match want.explore_seq {
            0 => &*self.empty_grid,
            seq => {
                maps.held(seq)
                    .ok_or_else(|| {
                        format!("exploration grid {seq} is not among the replayed ones")
                    })?
                    .1
            }
        };
        let nav = match want.nav_seq {
            0 => &*self.empty_grid,
            seq => {
                let g = self
                    .nav_grids
                    .get(&seq)
                    .ok_or_else(|| format!("the trace lacks navigation grid {seq}"))?;
                // The grid changes rarely: decode it once per seq, not every cycle.
                if self.nav_grid.header.seq != seq {
                    grid_of(g, &mut self.nav_grid)?;
                }
                &*self.nav_grid
            }
        };

        let mut neck = self.planner.neck_goal(map, &state, t);
        neck.header = header(0, 0, t);
        neck.map_seq = map.header.seq;
        neck.frame_stamp_ns = map.last_frame_stamp_ns;
        (
            neck.round_done,
            neck.state_seq,
            neck.nav_seq,
            neck.explore_seq,
        ) = (
            want.round_done as u32,
            want.state_seq,
            want.nav_seq,
            want.explore_seq,
        );
        let mut got = convert::neck_goal(&neck);
        (got.seq, got.stamp_ns) = (want.seq, want.stamp_ns);
        same(t, t_rec, &got, want)?;
        self.cycles += 1;
        if self.planner.lbv_decision(&mut self.lbv) {
            self.lbv.header = header(0, 0, t);
            self.lbv.map_seq = map.header.seq;
            self.out.decision(t, convert::decision(&self.lbv))?;
        }

        let round = match want.round_done {
            true => Some(
                self.outstanding
                    .take()
                    .ok_or("the recording took a chassis-goal round, none is outstanding here")?
                    .run(),
            ),
            false => None,
        };
        let busy = self.outstanding.is_some();
        let inputs = || PlannerInputs {
            map,
            state: &state,
            nav,
            explore,
        };
        match gbv_cycle(&mut *self.planner, round, busy, inputs, t) {
            Step::Wait => {}
            Step::Compute(job) => self.outstanding = Some(job),
            Step::Goal(mut goal) => {
                goal.header = header(0, 0, t);
                self.out.nav(t, convert::nav_goal(&goal))?;
                self.out
                    .gbv_decision(&mut *self.planner, t, planner_state::RUNNING)?;
            }
            Step::Finished(summary) => {
                self.finished = true;
                self.out
                    .gbv_decision(&mut *self.planner, t, summary.status.code())?;
            }
        }
        Ok(())
    }

    /// Decisions and nav goals recorded and never replayed.
    fn leftovers(&mut self) {
        if self.divergence.is_some() {
            return;
        }
        if let Some((t, _)) = self.out.decisions_left.next() {
            self.diverge(
                *t,
                topic::DECISIONS,
                "recorded, never produced by the replay".into(),
            );
        } else if let Some((t, _)) = self.out.nav_left.next() {
            self.diverge(
                *t,
                topic::NAV_GOAL,
                "recorded, never produced by the replay".into(),
            );
        }
    }
}

impl Outputs<'_> {
    /// The GBV decision the host publishes with a goal or at the end (none if the planner has
    /// none and the session goes on).
    fn gbv_decision(
        &mut self,
        planner: &mut dyn ViewPlanner,
        t: u64,
        state: u8,
    ) -> Result<(), String> {
        let src = planner.take_decision();
        if src.is_none() && state == planner_state::RUNNING {
            return Ok(());
        }
        let mut d = boxed_zeroed::<PlannerDecision>();
        if let Some(src) = src {
            let n = src.count as usize;
            d.candidates[..n].copy_from_slice(&src.candidates[..n]);
            (d.count, d.evaluated, d.cluster_id, d.map_seq) =
                (src.count, src.evaluated, src.cluster_id, src.map_seq);
        }
        d.header = header(0, 0, t);
        d.kind = decision_kind::GBV;
        d.state = state;
        self.decision(t, convert::decision(&d))
    }

    fn decision(&mut self, t: u64, mut got: rec::PlannerDecision) -> Result<(), String> {
        let Some((t_rec, want)) = self.decisions_left.next() else {
            return Err(format!("a decision the recording lacks: {got:?}"));
        };
        (got.seq, got.stamp_ns, got.eval_ns) = (want.seq, want.stamp_ns, want.eval_ns);
        self.decisions += 1;
        same(t, *t_rec, &got, want).map_err(|e| format!("decision: {e}"))
    }

    fn nav(&mut self, t: u64, mut got: rec::NavGoal) -> Result<(), String> {
        let Some((t_rec, want)) = self.nav_left.next() else {
            return Err(format!("a nav goal the recording lacks: {got:?}"));
        };
        (got.seq, got.stamp_ns) = (want.seq, want.stamp_ns);
        self.nav += 1;
        same(t, *t_rec, &got, want).map_err(|e| format!("nav goal: {e}"))
    }
}

/// `got` (replayed at `t`) is `want` (recorded at `t_rec`).
fn same<T: PartialEq + fmt::Debug>(t: u64, t_rec: u64, got: &T, want: &T) -> Result<(), String> {
    if t != t_rec {
        Err(format!(
            "recorded at t = {:.3} s, replayed at t = {:.3} s",
            t_rec as f64 * 1e-9,
            t as f64 * 1e-9
        ))
    } else if got != want {
        Err(format!("recorded {want:?}, replayed {got:?}"))
    } else {
        Ok(())
    }
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
