//! `[planner]` configuration: one struct per nested table, defaults from `config/default.toml`.

use serde::Deserialize;
use settings::{Checker, ConfigError};
use std::fmt;
use std::str::FromStr;

/// Which view planner drives the robot (`--planner vpsom|coverage|frontier`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PlannerKind {
    /// VP-SOM (paper sections 3–5): GBV on the chassis, LBV on the neck.
    Vpsom,
    /// All-views coverage: a full circle around every cluster, camera on the cluster centre.
    Coverage,
    /// Frontier exploration (Yamauchi 1997), neck fixed forward.
    Frontier,
}

impl PlannerKind {
    /// The name used on the command line and in `metrics.json`.
    pub fn name(self) -> &'static str {
        match self {
            PlannerKind::Vpsom => "vpsom",
            PlannerKind::Coverage => "coverage",
            PlannerKind::Frontier => "frontier",
        }
    }
}

impl fmt::Display for PlannerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown planner name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown planner `{0}` (expected vpsom, coverage or frontier)")]
pub struct UnknownPlanner(pub String);

impl FromStr for PlannerKind {
    type Err = UnknownPlanner;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "vpsom" => Ok(PlannerKind::Vpsom),
            "coverage" => Ok(PlannerKind::Coverage),
            "frontier" => Ok(PlannerKind::Frontier),
            other => Err(UnknownPlanner(other.to_string())),
        }
    }
}

/// Which foreground objects count as occluders of `fo_i` in H_IoU (eq. 21).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Occluders {
    /// Every other foreground object whose box projects into the image (the paper's `Σ_{j≠i}`):
    /// two overlapping boxes penalise both objects.
    All,
    /// Only objects whose centre is closer to the camera (along the optical axis) than `fo_i`'s
    /// centre: physically, only those can hide it.
    Closer,
}

/// Which foreground objects f_a (eq. 3) sums over, among those in the view's frustum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FaRelevance {
    /// Only the objects of the cluster the view is evaluated for (the GBV's target cluster);
    /// without a target, every object in the frustum.
    Cluster,
    /// Only objects whose centre lies within `fa_radius` of the camera (the public reference
    /// code counts objects within 1.5 m of the view).
    Radius,
    /// Every foreground object in the frustum and sensing range, of any cluster and state.
    Frustum,
}

/// Term switches for ablation studies. A disabled multiplicative factor (cos θ_sopm, C_asso,
/// N_cp, cos θ_c) is replaced by 1; a disabled additive term (H_sopm, H_IoU) by 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AblationConfig {
    /// Model uncertainty H_sopm in f_a (additive).
    pub h_sopm: bool,
    /// Non-occlusion H_IoU in f_a (additive).
    pub h_iou: bool,
    /// cos θ_sopm in f_a (multiplicative).
    pub theta_sopm: bool,
    /// C_asso in f_a (multiplicative).
    pub c_asso: bool,
    /// N_cp in f_c (multiplicative).
    pub n_cp: bool,
    /// cos θ_c in f_c (multiplicative).
    pub theta_c: bool,
}

impl Default for AblationConfig {
    /// The `[planner.ablation]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.ablation")
    }
}

impl AblationConfig {
    /// Names of the switchable terms, as used in config keys and ablation labels
    /// (`vpsom-no-<term>`).
    pub const TERMS: [&'static str; 6] =
        ["h_sopm", "h_iou", "theta_sopm", "c_asso", "n_cp", "theta_c"];

    /// Switch one term off by name.
    pub fn disable(&mut self, term: &str) -> Result<(), UnknownTerm> {
        let flag = match term {
            "h_sopm" => &mut self.h_sopm,
            "h_iou" => &mut self.h_iou,
            "theta_sopm" => &mut self.theta_sopm,
            "c_asso" => &mut self.c_asso,
            "n_cp" => &mut self.n_cp,
            "theta_c" => &mut self.theta_c,
            other => return Err(UnknownTerm(other.to_string())),
        };
        *flag = false;
        Ok(())
    }
}

/// A term name that is not one of [`AblationConfig::TERMS`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown F(v) term {0:?} (expected one of h_sopm, h_iou, theta_sopm, c_asso, n_cp, theta_c)"
)]
pub struct UnknownTerm(pub String);

/// `[planner.gbv]`: global best view.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GbvConfig {
    /// Candidates N sampled on a ring around the cluster.
    pub candidates: usize,
    /// Weight α of f_a.
    pub alpha: f32,
    /// Weight β of f_c.
    pub beta: f32,
    /// Clearance between the cluster's footprint (bounding circle) and the ring, metres.
    pub safe_distance: f32,
    /// GBV rounds spent on one cluster before it is given up (guarantees termination).
    pub max_rounds_per_cluster: u32,
    /// Candidates of a cluster within this distance of one of its earlier GBV goals (reached or
    /// refused) are dropped, so that every round moves the base to a new view, metres.
    pub revisit_radius: f32,
    /// Score each candidate base pose at the neck yaw the LBV will choose there (false: neck 0,
    /// the camera on the cluster centre).
    pub neck_aware: bool,
    /// Travel cost of a candidate: it is chosen by `F(v) / F_max − distance_weight × path`
    /// (path on the navigation grid from the robot, metres; F_max the round's best F), so a view
    /// `1 / distance_weight` metres further must be twice as informative. 0: F(v) alone.
    pub distance_weight: f32,
    /// GBV rounds a cluster that ended (out of rounds or views) gets again when a new unfinished
    /// foreground object appears in it (0: an ended cluster never reopens).
    pub reopen_rounds: u32,
    /// How many times one cluster may reopen (bounds the session).
    pub max_reopens: u32,
}

impl Default for GbvConfig {
    /// The `[planner.gbv]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.gbv")
    }
}

impl GbvConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            candidates: count(1, 100_000),
            [alpha, beta]: in_range(0.0, 100.0),
            safe_distance: in_range(0.0, 10.0),
            max_rounds_per_cluster: count(1, 10_000),
            [revisit_radius, distance_weight]: in_range(0.0, 10.0),
            reopen_rounds: count(0, 1000),
            max_reopens: count(0, 100),
        });
        Ok(())
    }
}

/// `[planner.lbv]`: local best view (neck).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LbvConfig {
    /// Candidates M spread evenly over the neck range.
    pub candidates: usize,
    /// Weight α of f_a (0 in the paper: LBV depends on continuity only).
    pub alpha: f32,
    /// Weight β of f_c.
    pub beta: f32,
    /// Lower end of the neck yaw range relative to the base, degrees.
    pub neck_min_deg: f32,
    /// Upper end of the neck yaw range, degrees (a 360° range does not repeat its end point).
    pub neck_max_deg: f32,
}

impl Default for LbvConfig {
    /// The `[planner.lbv]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.lbv")
    }
}

impl LbvConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            candidates: count(1, 100_000),
            [alpha, beta]: in_range(0.0, 100.0),
            neck_min_deg: in_range(-180.0, 180.0),
            neck_max_deg: require(
                self.neck_max_deg >= self.neck_min_deg && self.neck_max_deg <= 180.0,
                &format!("must be in [{}, 180]", settings::key!(c, neck_min_deg)),
            ),
        });
        Ok(())
    }
}

/// `[planner.bootstrap]`: behaviour before a cluster is known, and for clusters without
/// foreground objects.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BootstrapConfig {
    /// Neck stops of the in-place look-around sweep (evenly over 360°).
    pub look_around_steps: usize,
    /// A neck stop counts as reached within this yaw error, degrees.
    pub neck_tolerance_deg: f32,
    /// Angular sectors around a cluster (for the "looked at from enough sides" rule).
    pub sectors: usize,
    /// A cluster with no foreground object yet is done once its centre was in view from this
    /// many distinct sectors.
    pub empty_cluster_sectors: usize,
    /// No cluster is done before it was in view from within this distance of its support's
    /// footprint circle, metres (`inf`: the rule off); see `planner::clusters`.
    pub approach_m: f32,
    /// While exploring (the base driving to frontiers) the neck sweeps
    /// `amplitude · sin(2π t / period)` about the base's heading: amplitude, degrees.
    pub explore_neck_amplitude_deg: f32,
    /// Period of that sweep, seconds (peak neck rate 2π · amplitude / period).
    pub explore_neck_period_s: f32,
}

impl Default for BootstrapConfig {
    /// The `[planner.bootstrap]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.bootstrap")
    }
}

impl BootstrapConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            look_around_steps: count(1, 360),
            neck_tolerance_deg: in_range(0.1, 90.0),
            sectors: count(1, 64),
            empty_cluster_sectors: count(0, self.sectors),
            approach_m: require(self.approach_m > 0.0, "must be > 0 (inf: the rule off)"),
            explore_neck_amplitude_deg: in_range(0.0, 180.0),
            explore_neck_period_s: in_range(0.1, 1000.0),
        });
        Ok(())
    }
}

/// `[planner.coverage]`: all-views coverage baseline.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoverageConfig {
    /// Waypoints on the full circle around each cluster.
    pub waypoints: usize,
}

impl Default for CoverageConfig {
    /// The `[planner.coverage]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.coverage")
    }
}

impl CoverageConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            waypoints: count(3, 10_000),
        });
        Ok(())
    }
}

/// `[planner.frontier]`: frontier-exploration baseline (also VP-SOM's bootstrap exploration).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrontierConfig {
    /// Frontier clusters with fewer cells are ignored (noise).
    pub min_cells: usize,
    /// Frontier cells within this distance of an earlier frontier goal are ignored, metres
    /// (a frontier that survives a visit cannot be cleared from there).
    pub blacklist_radius: f32,
    /// Information weight: a frontier's length (metres of frontier cells) counts as this many
    /// metres less path, so that large frontiers win over slightly nearer small ones.
    pub gain_weight: f32,
    /// Unknown regions smaller than this make no frontier, m² (0: all do).
    pub min_unknown_area_m2: f32,
    /// Only UNKNOWN cells the base can reach (finite path on the inflated navigation grid) make
    /// frontiers.
    pub reachable_unknown: bool,
    /// A frontier goal being driven to is dropped (a new round chooses the next) once no
    /// frontier cell is left within this distance of it, metres (0: always driven to the end).
    pub seen_radius: f32,
}

impl Default for FrontierConfig {
    /// The `[planner.frontier]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.frontier")
    }
}

impl FrontierConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            min_cells: count(1, 100_000),
            blacklist_radius: in_range(0.0, 10.0),
            [gain_weight, min_unknown_area_m2]: in_range(0.0, 100.0),
            seen_radius: in_range(0.0, 10.0),
        });
        Ok(())
    }
}

/// `[planner.recovery]`: what every planner does while visual localization is lost (see
/// [`crate::recovery`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecoveryConfig {
    /// Whether the recovery runs at all.
    pub enabled: bool,
    /// Tracking lost, and the base standing (not driving to a goal), this long before the
    /// recovery takes over, seconds.
    pub lost_grace_s: f32,
    /// Tracking lost this long, whatever the base does, before the recovery takes over, seconds.
    pub lost_grace_driving_s: f32,
    /// Neck stops of the 360° sweep (evenly spaced).
    pub sweep_stops: usize,
    /// Time at each stop from its command (the slew included), seconds.
    pub stop_s: f32,
    /// Tracking must hold this long, the neck still, before the planner resumes, seconds.
    pub hold_s: f32,
    /// Drive after a sweep that did not recover, metres.
    pub move_m: f32,
}

impl Default for RecoveryConfig {
    /// The `[planner.recovery]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.recovery")
    }
}

impl RecoveryConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            [lost_grace_s, lost_grace_driving_s]: in_range(0.0, 600.0),
            sweep_stops: count(1, 360),
            [stop_s, hold_s]: in_range(0.0, 60.0),
            move_m: in_range(0.0, 10.0),
        });
        Ok(())
    }
}

/// `[planner.give_up]`: when VP-SOM gives up an object whose entropy stops falling (see
/// [`crate::giveup`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GiveUpConfig {
    /// Rounds N (GBV rounds aimed at the object's cluster that observed it) over which its
    /// H_sopm must fall by `min_drop`.
    pub rounds: usize,
    /// Least fall δ of H_sopm over `rounds` rounds.
    pub min_drop: f32,
}

impl Default for GiveUpConfig {
    /// The `[planner.give_up]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner.give_up")
    }
}

impl GiveUpConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        settings::ranges!(c, self, {
            rounds: count(1, 1000),
            min_drop: in_range(0.0, 1.0),
        });
        Ok(())
    }
}

/// `[planner]` section.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannerConfig {
    /// `vpsom`, `coverage` or `frontier`.
    pub kind: PlannerKind,
    /// LBV rate of the planner's real-time thread, Hz.
    pub lbv_hz: f64,
    /// Execution budget of one LBV cycle, ms.
    pub lbv_budget_ms: f64,
    /// A foreground object is complete when H_sopm < ε_sopm (section 3.4).
    pub eps_sopm: f32,
    /// ε_cp of eq. (22): co-visible points at which N_cp saturates at 1.
    pub eps_cp: f32,
    /// θ_thresh of section 5.1: largest co-visibility angle, degrees.
    pub theta_thresh_deg: f32,
    /// Occluders in H_IoU.
    pub occluders: Occluders,
    /// Which objects in the frustum f_a counts.
    pub fa_relevance: FaRelevance,
    /// Radius of [`FaRelevance::Radius`] around the camera, metres.
    pub fa_radius: f32,
    /// Whether an object counts as in view only if it is not hidden (ray casts against the map's
    /// cuboids and, for the GBV, the wall cells of the navigation grid).
    pub fa_occlusion: bool,
    /// Least fraction of an object's sample points (centre and 8 inner corners) a view must see
    /// unhidden for the object to count as in view.
    pub fa_min_visible: f32,
    /// Occupied navigation-grid cells this far beyond a map object's estimated footprint (and the
    /// grid's inflation) are taken for that object, not for a wall, metres.
    pub fa_wall_slack: f32,
    /// Robot footprint radius for collision and reachability, metres.
    pub robot_radius: f32,
    /// Whether UNKNOWN cells of the navigation grid may be driven through.
    pub nav_unknown_traversable: bool,
    /// Whether the navigation grid's obstacles are already inflated by the robot radius (a
    /// configuration-space map, as the simulator's pre-built map is); if false the planner
    /// inflates them by `robot_radius` itself.
    pub nav_inflated: bool,
    /// VP-SOM: a map object (foreground or background) with fewer associated detections is not
    /// yet trusted: it neither opens a cluster nor holds the session open (detector false
    /// positives are seen in one or two frames).
    pub min_observations: u32,
    /// Global best view.
    pub gbv: GbvConfig,
    /// Local best view.
    pub lbv: LbvConfig,
    /// Bootstrap and empty clusters.
    pub bootstrap: BootstrapConfig,
    /// Coverage baseline.
    pub coverage: CoverageConfig,
    /// Frontier baseline (and every planner's exploration).
    pub frontier: FrontierConfig,
    /// Giving up objects whose entropy stops falling.
    pub give_up: GiveUpConfig,
    /// Recovery while localization is lost (every planner).
    pub recovery: RecoveryConfig,
    /// Term switches.
    pub ablation: AblationConfig,
}

impl Default for PlannerConfig {
    /// The `[planner]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("planner")
    }
}

impl PlannerConfig {
    /// Range-check the `[planner]` section and its tables.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("planner");
        settings::ranges!(c, self, {
            lbv_hz: in_range(0.1, 1000.0),
            lbv_budget_ms: positive,
            lbv_budget_ms: require(
                self.lbv_budget_ms <= 1000.0 / self.lbv_hz,
                &format!("must not exceed the LBV period 1000 / {}", settings::key!(c, lbv_hz)),
            ),
            eps_sopm: in_range(0.0, 1.0),
            eps_cp: in_range(1.0, 1e6),
            theta_thresh_deg: in_range(0.1, 180.0),
            robot_radius: in_range(0.0, 2.0),
            fa_radius: in_range(0.01, 100.0),
            fa_wall_slack: in_range(0.0, 100.0),
            fa_min_visible: in_range(0.0, 1.0),
            gbv: section,
            min_observations: count(0, 1_000_000),
            [lbv, bootstrap, coverage, frontier, give_up, recovery]: section,
        });
        Ok(())
    }
}
