//! Where a map goes wrong: every foreground ground-truth object and every foreground estimate
//! of a run sorted into one outcome each (issue #47), so that a change to the mapper can say
//! which errors it removed and which it made.
//!
//! Ground-truth objects ([`GtOutcome`]), first that applies:
//! 1. **correct**: assigned (same class, [`assign`]) and closer than `success_dist_m`;
//! 2. **off**: assigned, but 0.1–1 m away (`success_dist_m`..`max_pair_dist_m`);
//! 3. **missed, seen well**: not assigned although some frame showed it well
//!    ([`ObjectViews::frames_well_seen`] > 0: the detector or the mapper lost it);
//! 4. **missed, seen poorly**: in view in some frame, never well;
//! 5. **never seen**: in view in no frame (the planner never looked).
//!
//! Estimates ([`EstOutcome`]), first that applies:
//! 1. **correct** and 2. **off**: as above, for the assigned estimate;
//! 3. **duplicate**: not assigned, a same-class ground-truth object within `max_pair_dist_m`
//!    (which then has another estimate: the assignment leaves none within the gate unpaired);
//! 4. **wrong class**: not assigned, and its box overlaps a foreground ground-truth object of
//!    another class (grown by [`PLACE_MARGIN_M`]): a confusion of the detector founded an
//!    object at another object's place;
//! 5. **implausible** ([`Implausibility`]): its centre outside the room; its footprint through
//!    a room wall by more than [`WALL_MARGIN_M`]; resting on nothing (its bottom neither on the
//!    floor nor on or inside any ground-truth object under it, within [`SUPPORT_TOL_M`]); or a
//!    size its class cannot have (largest extent above [`SIZE_FACTOR`] × the largest extent of
//!    any ground-truth object of its class in the scene);
//! 6. **far false positive**: anything else (nothing of its own or another class near it).
//!
//! Pure functions over `plot.json` content (room, ground truth, estimates) and the run's view
//! records; [`report_section`] and [`csv`] turn many runs into the bench report's table.

use super::matching::MatchParams;
use super::metrics::{EstObject, GtObject, Layer, ObjectViews, score_map};
use super::plot::Room;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// An estimate counts as at another object's place when its box overlaps that object's box
/// grown by this, metres.
pub const PLACE_MARGIN_M: f32 = 0.05;
/// A footprint may cross a room wall by this much before it is inside the wall, metres.
pub const WALL_MARGIN_M: f32 = 0.05;
/// An estimate's bottom this close to the floor, to a support's top, or between a support's
/// bottom and top (a shelf's boards), is supported, metres.
pub const SUPPORT_TOL_M: f32 = 0.08;
/// An estimate whose largest extent exceeds this many times the largest extent of every
/// ground-truth object of its class in the scene has a size its class cannot have.
pub const SIZE_FACTOR: f32 = 2.0;

/// What became of a ground-truth foreground object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum GtOutcome {
    /// Mapped within `success_dist_m`.
    Correct,
    /// Mapped 0.1–1 m off.
    Off,
    /// Not mapped although some frame showed it well.
    MissedSeenWell,
    /// Not mapped; in view, but never well.
    MissedSeenPoorly,
    /// Never in view.
    NeverSeen,
}

impl GtOutcome {
    /// Every outcome, in table order.
    pub const ALL: [GtOutcome; 5] = [
        GtOutcome::Correct,
        GtOutcome::Off,
        GtOutcome::MissedSeenWell,
        GtOutcome::MissedSeenPoorly,
        GtOutcome::NeverSeen,
    ];

    /// Name in tables and CSV.
    pub fn name(self) -> &'static str {
        match self {
            GtOutcome::Correct => "correct",
            GtOutcome::Off => "off",
            GtOutcome::MissedSeenWell => "missed_seen_well",
            GtOutcome::MissedSeenPoorly => "missed_seen_poorly",
            GtOutcome::NeverSeen => "never_seen",
        }
    }
}

/// Why an estimate is implausible.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Implausibility {
    /// Its centre is outside the room.
    OutsideRoom,
    /// Its footprint crosses a room wall.
    InWall,
    /// Its bottom rests on nothing.
    Unsupported,
    /// Too large for its class.
    Size,
}

/// What an estimate is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum EstOutcome {
    /// A correct model of a ground-truth object.
    Correct,
    /// Assigned to a ground-truth object 0.1–1 m away.
    Off,
    /// A second estimate of an object of its class nearby.
    Duplicate,
    /// An object of the wrong class at another object's place.
    WrongClass,
    /// Somewhere or of a size no object can be.
    Implausible(Implausibility),
    /// A false positive away from every object.
    FarFalsePositive,
}

impl EstOutcome {
    /// Every outcome, in table order.
    pub const ALL: [EstOutcome; 9] = [
        EstOutcome::Correct,
        EstOutcome::Off,
        EstOutcome::Duplicate,
        EstOutcome::WrongClass,
        EstOutcome::Implausible(Implausibility::OutsideRoom),
        EstOutcome::Implausible(Implausibility::InWall),
        EstOutcome::Implausible(Implausibility::Unsupported),
        EstOutcome::Implausible(Implausibility::Size),
        EstOutcome::FarFalsePositive,
    ];

    /// Name in tables and CSV.
    pub fn name(self) -> &'static str {
        match self {
            EstOutcome::Correct => "correct",
            EstOutcome::Off => "off",
            EstOutcome::Duplicate => "duplicate",
            EstOutcome::WrongClass => "wrong_class",
            EstOutcome::Implausible(Implausibility::OutsideRoom) => "outside_room",
            EstOutcome::Implausible(Implausibility::InWall) => "in_wall",
            EstOutcome::Implausible(Implausibility::Unsupported) => "unsupported",
            EstOutcome::Implausible(Implausibility::Size) => "impossible_size",
            EstOutcome::FarFalsePositive => "far_false_positive",
        }
    }

    /// A duplicate, a wrong-class or an implausible estimate: the errors the mapper's
    /// association and plausibility gates are for.
    pub fn is_association_error(self) -> bool {
        matches!(
            self,
            EstOutcome::Duplicate | EstOutcome::WrongClass | EstOutcome::Implausible(_)
        )
    }
}

/// One object's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry<O> {
    /// Index in the run's ground truth or `map.json` list (both layers).
    pub index: usize,
    /// Class name.
    pub class: String,
    /// The outcome.
    pub outcome: O,
    /// The ground-truth object it was judged against (the assigned one, the one it duplicates
    /// or sits on), by name.
    pub other: Option<String>,
    /// Centre distance to `other`, metres.
    pub distance_m: Option<f64>,
}

/// The outcomes of one run's foreground objects.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunDiagnosis {
    /// One entry per foreground ground-truth object.
    pub gt: Vec<Entry<GtOutcome>>,
    /// One entry per foreground estimate.
    pub est: Vec<Entry<EstOutcome>>,
}

/// Sort every foreground object of a run (see the module docs). `views` are the run's view
/// records (`metrics.json` `views`); a ground-truth object without one counts as never seen.
pub fn diagnose(
    gt: &[GtObject],
    est: &[EstObject],
    views: &[ObjectViews],
    room: &Room,
    params: &MatchParams,
) -> RunDiagnosis {
    let score = score_map(gt, est, params, Layer::Foreground);
    let fg_gt: Vec<usize> = (0..gt.len()).filter(|&i| !gt[i].background).collect();
    let mut assigned_to: BTreeMap<usize, usize> = BTreeMap::new();
    let mut out = RunDiagnosis::default();
    for (k, m) in score.per_object.iter().enumerate() {
        let gi = fg_gt[k];
        let outcome = if m.estimate.is_some() {
            if m.correct {
                GtOutcome::Correct
            } else {
                GtOutcome::Off
            }
        } else {
            match views.iter().find(|v| v.name == m.name) {
                Some(v) if v.frames_well_seen > 0 => GtOutcome::MissedSeenWell,
                Some(v) if v.frames > 0 => GtOutcome::MissedSeenPoorly,
                _ => GtOutcome::NeverSeen,
            }
        };
        if let Some(j) = m.estimate {
            assigned_to.insert(j, gi);
        }
        out.gt.push(Entry {
            index: gi,
            class: m.class.clone(),
            outcome,
            other: m.estimate.map(|j| format!("estimate {j}")),
            distance_m: m.distance_m,
        });
    }
    for (j, e) in est.iter().enumerate().filter(|(_, e)| !e.background) {
        let named = |i: usize, outcome| Entry {
            index: j,
            class: e.class.clone(),
            outcome,
            other: Some(gt[i].name.clone()),
            distance_m: Some(super::matching::distance(gt[i].center, e.center)),
        };
        let entry = if let Some(&gi) = assigned_to.get(&j) {
            let d = super::matching::distance(gt[gi].center, e.center);
            let outcome = if d < params.success_dist_m {
                EstOutcome::Correct
            } else {
                EstOutcome::Off
            };
            named(gi, outcome)
        } else if let Some(gi) = nearest(gt, e, |g| g.class == e.class).filter(|&gi| {
            super::matching::distance(gt[gi].center, e.center) <= params.max_pair_dist_m
        }) {
            named(gi, EstOutcome::Duplicate)
        } else if let Some(gi) = nearest(gt, e, |g| {
            g.class != e.class && boxes_overlap(g.center, g.size, g.yaw, e, PLACE_MARGIN_M)
        }) {
            named(gi, EstOutcome::WrongClass)
        } else if let Some(why) = implausibility(gt, e, room) {
            Entry {
                index: j,
                class: e.class.clone(),
                outcome: EstOutcome::Implausible(why),
                other: None,
                distance_m: None,
            }
        } else {
            Entry {
                index: j,
                class: e.class.clone(),
                outcome: EstOutcome::FarFalsePositive,
                other: None,
                distance_m: None,
            }
        };
        out.est.push(entry);
    }
    out
}

/// The foreground ground-truth object nearest to `e` among those `keep` accepts.
fn nearest(gt: &[GtObject], e: &EstObject, keep: impl Fn(&GtObject) -> bool) -> Option<usize> {
    (0..gt.len())
        .filter(|&i| !gt[i].background && keep(&gt[i]))
        .min_by(|&a, &b| {
            let da = super::matching::distance(gt[a].center, e.center);
            let db = super::matching::distance(gt[b].center, e.center);
            da.total_cmp(&db)
        })
}

/// Half extents along world x and y of a footprint `size` turned by `yaw`.
fn half_xy(size: [f32; 3], yaw: f32) -> [f32; 2] {
    let (s, c) = yaw.sin_cos();
    let (hx, hy) = (size[0].abs() / 2.0, size[1].abs() / 2.0);
    [c.abs() * hx + s.abs() * hy, s.abs() * hx + c.abs() * hy]
}

/// Whether the world-axis bounds of a box and of estimate `e` overlap, the box grown by
/// `margin` on every side.
fn boxes_overlap(center: [f32; 3], size: [f32; 3], yaw: f32, e: &EstObject, margin: f32) -> bool {
    let (a, b) = (half_xy(size, yaw), half_xy(e.size, e.yaw));
    let ha = [a[0], a[1], size[2].abs() / 2.0];
    let hb = [b[0], b[1], e.size[2].abs() / 2.0];
    (0..3).all(|k| (center[k] - e.center[k]).abs() <= ha[k] + hb[k] + margin)
}

/// Why `e` is implausible in `room` among `gt`, if it is (module docs, item 5).
fn implausibility(gt: &[GtObject], e: &EstObject, room: &Room) -> Option<Implausibility> {
    let [cx, cy, cz] = e.center;
    if cx < room.min[0] || cx > room.max[0] || cy < room.min[1] || cy > room.max[1] {
        return Some(Implausibility::OutsideRoom);
    }
    let h = half_xy(e.size, e.yaw);
    let through = (room.min[0] - (cx - h[0]))
        .max((cx + h[0]) - room.max[0])
        .max(room.min[1] - (cy - h[1]))
        .max((cy + h[1]) - room.max[1]);
    if through > WALL_MARGIN_M {
        return Some(Implausibility::InWall);
    }
    let bottom = cz - e.size[2].abs() / 2.0;
    let on_floor = bottom.abs() <= SUPPORT_TOL_M;
    let on_something = gt.iter().any(|g| {
        let hg = half_xy(g.size, g.yaw);
        let inside_xy = (g.center[0] - cx).abs() <= hg[0] + SUPPORT_TOL_M
            && (g.center[1] - cy).abs() <= hg[1] + SUPPORT_TOL_M;
        let (g_bottom, g_top) = (
            g.center[2] - g.size[2].abs() / 2.0,
            g.center[2] + g.size[2].abs() / 2.0,
        );
        inside_xy && bottom >= g_bottom - SUPPORT_TOL_M && bottom <= g_top + SUPPORT_TOL_M
    });
    if !on_floor && !on_something {
        return Some(Implausibility::Unsupported);
    }
    let largest = |s: [f32; 3]| s.iter().fold(0f32, |m, v| m.max(v.abs()));
    let class_max = gt
        .iter()
        .filter(|g| g.class == e.class)
        .map(|g| largest(g.size))
        .reduce(f32::max);
    if class_max.is_some_and(|m| largest(e.size) > SIZE_FACTOR * m) {
        return Some(Implausibility::Size);
    }
    None
}

/// Outcome counts over runs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Counts {
    /// Runs counted.
    pub runs: usize,
    /// Ground-truth objects per [`GtOutcome::ALL`] entry.
    pub gt: [usize; 5],
    /// Estimates per [`EstOutcome::ALL`] entry.
    pub est: [usize; 9],
    /// Wrong-class estimates by (estimate class, class of the object it sits on).
    pub confusions: BTreeMap<(String, String), usize>,
}

impl Counts {
    /// Add one run.
    pub fn add(&mut self, d: &RunDiagnosis, gt: &[GtObject]) {
        self.runs += 1;
        for e in &d.gt {
            let k = GtOutcome::ALL.iter().position(|o| *o == e.outcome);
            self.gt[k.expect("every outcome is listed")] += 1;
        }
        for e in &d.est {
            let k = EstOutcome::ALL.iter().position(|o| *o == e.outcome);
            self.est[k.expect("every outcome is listed")] += 1;
            if e.outcome == EstOutcome::WrongClass {
                let under = e
                    .other
                    .as_ref()
                    .and_then(|n| gt.iter().find(|g| &g.name == n))
                    .map_or_else(String::new, |g| g.class.clone());
                *self.confusions.entry((e.class.clone(), under)).or_default() += 1;
            }
        }
    }

    /// Estimates counted.
    pub fn estimates(&self) -> usize {
        self.est.iter().sum()
    }

    /// Duplicates, wrong-class and implausible estimates together.
    pub fn association_errors(&self) -> usize {
        EstOutcome::ALL
            .iter()
            .zip(self.est)
            .filter(|(o, _)| o.is_association_error())
            .map(|(_, n)| n)
            .sum()
    }
}

/// One run's inputs to the diagnosis, as the bench leaves them (`plot.json` and `metrics.json`).
#[derive(Debug, Clone)]
pub struct RunInput<'a> {
    /// Planner label.
    pub planner: &'a str,
    /// Scene name.
    pub scene: &'a str,
    /// Seed.
    pub seed: u64,
    /// The room.
    pub room: &'a Room,
    /// Ground truth.
    pub gt: &'a [GtObject],
    /// The final map's estimates, `map.json` order.
    pub est: &'a [EstObject],
    /// View records.
    pub views: &'a [ObjectViews],
    /// Matching thresholds of the run.
    pub params: MatchParams,
}

/// File name of the per-object CSV beside `report.md`.
pub const CSV_FILE: &str = "map-errors.csv";

/// [`report_section`] over bench runs: each `metrics.json` of `files` (parsed as `runs`, same
/// order) with the `plot.json` beside it. A run without `plot.json` is left out, and the
/// section says how many were.
pub fn report_files(
    files: &[std::path::PathBuf],
    runs: &[super::Metrics],
) -> Result<(String, String), super::EvalError> {
    let mut plots = Vec::new();
    for (file, m) in files.iter().zip(runs) {
        let Some(path) = file.parent().map(|d| d.join(super::PLOT_FILE)) else {
            continue;
        };
        if path.is_file() {
            let plot: super::PlotInput = super::read_json(&path)?;
            plots.push((plot, m));
        }
    }
    let inputs: Vec<RunInput<'_>> = plots
        .iter()
        .map(|(p, m)| RunInput {
            planner: &m.planner,
            scene: &m.scene,
            seed: m.seed,
            room: &p.room,
            gt: &p.gt,
            est: &p.estimated,
            views: &m.views,
            params: m.match_params,
        })
        .collect();
    let (mut md, csv) = report_section(&inputs);
    let missing = runs.len() - inputs.len();
    if missing > 0 {
        let _ = writeln!(
            md,
            "
{missing} run(s) without `plot.json` are not in this table."
        );
    }
    Ok((md, csv))
}

/// The report section "Where the maps go wrong" (Markdown) and the per-object CSV rows of many
/// runs: `(markdown, csv)`.
pub fn report_section(runs: &[RunInput<'_>]) -> (String, String) {
    let mut per_planner: BTreeMap<&str, Counts> = BTreeMap::new();
    let mut rows = csv::Writer::from_writer(Vec::new());
    const MEMORY: &str = "CSV into memory";
    rows.write_record([
        "scene",
        "planner",
        "seed",
        "side",
        "index",
        "class",
        "outcome",
        "other",
        "distance_m",
    ])
    .expect(MEMORY);
    for r in runs {
        let d = diagnose(r.gt, r.est, r.views, r.room, &r.params);
        per_planner.entry(r.planner).or_default().add(&d, r.gt);
        let seed = r.seed.to_string();
        let gt_rows =
            d.gt.iter()
                .map(|e| ("gt", e.index, &e.class, e.outcome.name(), e));
        let est_rows = d
            .est
            .iter()
            .map(|e| ("estimate", e.index, &e.class, e.outcome.name(), e));
        let all = gt_rows
            .map(|(s, i, c, o, e)| (s, i, c, o, e.other.clone(), e.distance_m))
            .chain(est_rows.map(|(s, i, c, o, e)| (s, i, c, o, e.other.clone(), e.distance_m)));
        for (side, index, class, outcome, other, dist) in all {
            rows.write_record([
                r.scene,
                r.planner,
                &seed,
                side,
                &index.to_string(),
                class,
                outcome,
                other.as_deref().unwrap_or(""),
                &dist.map_or_else(String::new, |d| format!("{d:.4}")),
            ])
            .expect(MEMORY);
        }
    }
    let mut md = String::from(
        "\n## Where the maps go wrong\n\n\
         Every foreground object of every run, sorted into one outcome (`eval::diagnose`; one \
         row per object in `map-errors.csv`). Ground truth: correct (< 0.1 m), off (0.1–1 m), \
         missed although some frame showed it well, missed and only seen poorly, never in \
         view. Estimates: correct, off, same-class duplicate, wrong class at another object's \
         place, implausible (centre outside the room, through a wall, resting on nothing, \
         larger than twice its class's largest object in the scene), far false positive. \
         *Errors* = duplicates + wrong class + implausible, as a share of all estimates.\n\n",
    );
    md.push_str(
        "| planner | runs | GT | correct | off | missed, seen well | missed, seen poorly | \
         never seen | estimates | correct | off | duplicate | wrong class | outside room | \
         in wall | unsupported | impossible size | far FP | errors |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (planner, c) in &per_planner {
        let _ = write!(
            md,
            "| {} | {} | {} |",
            super::report::planner_title(planner),
            c.runs,
            c.gt.iter().sum::<usize>()
        );
        for n in c.gt {
            let _ = write!(md, " {n} |");
        }
        let _ = write!(md, " {} |", c.estimates());
        for n in c.est {
            let _ = write!(md, " {n} |");
        }
        let share = c.association_errors() as f64 / c.estimates().max(1) as f64;
        let _ = writeln!(md, " {} ({:.1} %) |", c.association_errors(), 100.0 * share);
    }
    let mut confusions: Vec<(&str, &(String, String), usize)> = per_planner
        .iter()
        .flat_map(|(p, c)| c.confusions.iter().map(move |(k, n)| (*p, k, *n)))
        .collect();
    if !confusions.is_empty() {
        confusions.sort_by(|a, b| b.2.cmp(&a.2).then_with(|| a.0.cmp(b.0)));
        md.push_str(
            "\nWrong-class estimates by the class mapped and the class of the object it sits \
             on (most frequent first, at most 12):\n\n\
             | planner | mapped as | on a | estimates |\n|---|---|---|---|\n",
        );
        for (p, (mapped, under), n) in confusions.into_iter().take(12) {
            let _ = writeln!(
                md,
                "| {} | {mapped} | {under} | {n} |",
                super::report::planner_title(p)
            );
        }
    }
    let csv = String::from_utf8(rows.into_inner().expect(MEMORY)).expect("UTF-8 fields");
    (md, csv)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gt(name: &str, class: &str, background: bool, c: [f32; 3], s: [f32; 3]) -> GtObject {
        GtObject {
            name: name.into(),
            class: class.into(),
            background,
            center: c,
            size: s,
            yaw: 0.0,
        }
    }

    fn est(class: &str, c: [f32; 3], s: [f32; 3]) -> EstObject {
        EstObject {
            class: class.into(),
            background: false,
            center: c,
            size: s,
            yaw: 0.0,
            h_sopm: 0.3,
            complete: true,
        }
    }

    fn seen(name: &str, frames: u64, well: u64) -> ObjectViews {
        ObjectViews {
            name: name.into(),
            frames,
            frames_well_seen: well,
            max_visible_px: 0,
        }
    }

    const ROOM: Room = Room {
        min: [0.0, 0.0],
        max: [5.0, 4.0],
    };

    /// A table (top at 0.75 m) with a cup, a book and a laptop on it, and a bottle elsewhere.
    fn scene() -> Vec<GtObject> {
        vec![
            gt(
                "table",
                "dining table",
                true,
                [2.0, 2.0, 0.375],
                [1.2, 0.8, 0.75],
            ),
            gt("cup", "cup", false, [1.8, 2.0, 0.80], [0.08, 0.08, 0.10]),
            gt("book", "book", false, [2.3, 2.1, 0.77], [0.2, 0.15, 0.04]),
            gt(
                "laptop",
                "laptop",
                false,
                [2.0, 1.8, 0.76],
                [0.33, 0.23, 0.02],
            ),
            gt(
                "bottle",
                "bottle",
                false,
                [4.0, 1.0, 0.15],
                [0.08, 0.08, 0.3],
            ),
        ]
    }

    #[test]
    fn each_object_gets_the_first_outcome_that_applies() {
        let gt = scene();
        let est = vec![
            est("cup", [1.82, 2.0, 0.80], [0.08, 0.08, 0.10]), // 0: correct
            est("book", [2.3, 2.4, 0.77], [0.2, 0.15, 0.04]),  // 1: 0.3 m off
            est("cup", [1.86, 2.0, 0.80], [0.08, 0.08, 0.10]), // 2: duplicate of the cup
            est("cell phone", [2.0, 1.8, 0.77], [0.15, 0.07, 0.01]), // 3: on the laptop
            est("chair", [-0.5, 2.0, 0.4], [0.5, 0.5, 0.8]),   // 4: outside the room
            est("tv", [4.95, 2.0, 1.0], [0.5, 0.3, 0.4]),      // 5: through the east wall
            est("vase", [1.0, 3.0, 1.5], [0.1, 0.1, 0.3]),     // 6: floating
            est("laptop", [3.0, 3.0, 0.3], [1.0, 0.6, 0.6]),   // 7: 3x the laptop, on the floor
            est("vase", [3.5, 3.0, 0.15], [0.1, 0.1, 0.3]),    // 8: far false positive
        ];
        let views = vec![
            seen("cup", 40, 30),
            seen("laptop", 10, 0),
            seen("bottle", 0, 0),
        ];
        let d = diagnose(&gt, &est, &views, &ROOM, &MatchParams::default());
        let g: Vec<GtOutcome> = d.gt.iter().map(|e| e.outcome).collect();
        // The laptop's estimate 7 is 1.33 m away: beyond the 1 m gate, so the laptop is missed.
        assert_eq!(
            g,
            [
                GtOutcome::Correct,
                GtOutcome::Off,
                GtOutcome::MissedSeenPoorly,
                GtOutcome::NeverSeen
            ]
        );
        // One estimate of each outcome, in table order.
        let e: Vec<EstOutcome> = d.est.iter().map(|e| e.outcome).collect();
        assert_eq!(e, EstOutcome::ALL);
        assert_eq!(d.est[3].other.as_deref(), Some("laptop"));
        assert_eq!(d.est[2].other.as_deref(), Some("cup"));
        let mut c = Counts::default();
        c.add(&d, &gt);
        assert_eq!(c.estimates(), 9);
        // duplicate + wrong class + 4 implausible
        assert_eq!(c.association_errors(), 6);
        assert_eq!(
            c.confusions.get(&("cell phone".into(), "laptop".into())),
            Some(&1)
        );
    }

    #[test]
    fn a_missed_object_seen_well_is_told_from_one_seen_poorly() {
        let gt = scene();
        let views = vec![seen("cup", 40, 3), seen("book", 5, 0)];
        let d = diagnose(&gt, &[], &views, &ROOM, &MatchParams::default());
        let g: Vec<GtOutcome> = d.gt.iter().map(|e| e.outcome).collect();
        assert_eq!(
            g,
            [
                GtOutcome::MissedSeenWell,
                GtOutcome::MissedSeenPoorly,
                GtOutcome::NeverSeen,
                GtOutcome::NeverSeen
            ]
        );
        assert!(d.est.is_empty());
    }

    #[test]
    fn objects_inside_a_shelf_and_turned_footprints_are_plausible() {
        // A shelf 1.8 m tall: an estimate on a middle board rests inside it.
        let gt = vec![
            gt("shelf", "shelf", true, [1.0, 3.7, 0.9], [1.0, 0.4, 1.8]),
            gt("book", "book", false, [3.0, 1.0, 0.02], [0.2, 0.15, 0.04]),
        ];
        let on_board = est("vase", [1.2, 3.7, 1.05], [0.1, 0.1, 0.3]);
        let d = diagnose(&gt, &[on_board], &[], &ROOM, &MatchParams::default());
        assert_eq!(d.est[0].outcome, EstOutcome::FarFalsePositive);
        // A long thin box along the north wall, turned a quarter: its world half extent in y
        // is 0.1 m, so it does not cross the wall at y = 4.
        let mut long = est("bench", [2.5, 3.85, 0.2], [1.6, 0.2, 0.4]);
        long.yaw = std::f32::consts::PI;
        assert_eq!(implausibility(&gt, &long, &ROOM), None);
        long.yaw = std::f32::consts::FRAC_PI_2;
        assert_eq!(
            implausibility(&gt, &long, &ROOM),
            Some(Implausibility::InWall)
        );
    }

    #[test]
    fn report_section_counts_per_planner_and_writes_a_row_per_object() {
        let gt = scene();
        let est = vec![
            est("cup", [1.82, 2.0, 0.80], [0.08, 0.08, 0.10]),
            est("cup", [1.86, 2.0, 0.80], [0.08, 0.08, 0.10]),
        ];
        let run = RunInput {
            planner: "vpsom",
            scene: "s",
            seed: 1,
            room: &ROOM,
            gt: &gt,
            est: &est,
            views: &[],
            params: MatchParams::default(),
        };
        let (md, csv) = report_section(&[run.clone(), RunInput { seed: 2, ..run }]);
        assert!(
            md.contains("| VP-SOM | 2 | 8 | 2 | 0 | 0 | 0 | 6 | 4 | 2 | 0 | 2 |"),
            "{md}"
        );
        assert!(md.contains("2 (50.0 %)"), "{md}");
        // Header + 2 runs x (4 ground-truth objects + 2 estimates).
        assert_eq!(csv.lines().count(), 1 + 2 * 6);
        assert!(csv.contains("s,vpsom,2,estimate,1,cup,duplicate,cup,"));
    }
}
