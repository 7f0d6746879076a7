//! All-views coverage baseline (paper section 7.1): drive a full circle around every cluster at
//! the GBV ring radius (footprint radius + safe distance), camera always on the cluster centre.
//!
//! Waypoints: `waypoints` evenly on the ring, starting at the robot's bearing from the centre and
//! going counter-clockwise, plus the start again to close the circle; the base yaw is the
//! direction of travel (tangent). Waypoints in collision or unreachable from the robot are
//! skipped; a cluster without any reachable waypoint is skipped as a whole. Each waypoint's view
//! (camera aimed at the cluster centre, [`geom::CameraMount::neck_yaw_toward`]) is evaluated with VP-SOM's terms on the
//! round's map, for the trace and the per-NBV metrics.

use crate::clusters::{ClusterInfo, unfinished_centroid};
use crate::evaluate::{Scoring, Target};
use crate::reach::NavParams;
use shm_types::{Candidate, OccupancyGrid};
use std::f32::consts::{FRAC_PI_2, TAU};

/// Parameters of the coverage baseline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoverageParams {
    /// Waypoints per circle.
    pub waypoints: usize,
    /// Ring clearance, metres.
    pub safe_distance: f32,
    /// Reading of the navigation grid.
    pub nav: NavParams,
}

/// The circle around a cluster: `[x, y, yaw]` waypoints, closed (first == last position).
pub fn circle(info: &ClusterInfo, p: &CoverageParams, from: [f32; 2]) -> Vec<[f32; 3]> {
    let r = info.radius + p.safe_distance;
    let a0 = (from[1] - info.center.y).atan2(from[0] - info.center.x);
    (0..=p.waypoints)
        .map(|k| {
            let a = a0 + TAU * k as f32 / p.waypoints as f32;
            let (s, c) = a.sin_cos();
            let yaw = geom::wrap_angle(a + FRAC_PI_2);
            [info.center.x + r * c, info.center.y + r * s, yaw]
        })
        .collect()
}

/// Plan the circle of the first cluster (in order) with a reachable waypoint, as an owned job.
#[derive(Debug)]
pub struct CoverageJob {
    /// Navigation grid snapshot.
    pub nav: Box<OccupancyGrid>,
    /// Robot base pose.
    pub base: [f32; 3],
    /// Clusters not circled yet, in order of first sighting.
    pub clusters: Vec<ClusterInfo>,
    /// Parameters.
    pub params: CoverageParams,
    /// Map snapshot and parameters to evaluate the waypoints' views with.
    pub scoring: Scoring,
}

/// A planned circle.
#[derive(Debug, Clone)]
pub struct Circle {
    /// The cluster circled.
    pub cluster: ClusterInfo,
    /// Reachable waypoints `[x, y, yaw]`, in driving order.
    pub waypoints: Vec<[f32; 3]>,
    /// The view at each waypoint (camera on the cluster centre), evaluated on the round's map
    /// with the cluster as f_c target.
    pub views: Vec<Candidate>,
}

/// Outcome of a [`CoverageJob`].
#[derive(Debug)]
pub struct CoverageResult {
    /// The cluster to circle and its reachable waypoints, `None` if no cluster has any.
    pub circle: Option<Circle>,
    /// Clusters tried before it (or all) without a reachable waypoint.
    pub unreachable: Vec<i32>,
    /// Buffer handed back for reuse.
    pub nav: Box<OccupancyGrid>,
    /// Handed back for reuse.
    pub scoring: Scoring,
}

impl CoverageJob {
    /// Run the planning.
    pub fn run(self) -> CoverageResult {
        let p = self.params;
        let nav = p.nav.flooded(&self.nav, [self.base[0], self.base[1]]);
        let mut unreachable = Vec::new();
        let mut found = None;
        for info in &self.clusters {
            let wps: Vec<[f32; 3]> = circle(info, &p, [self.base[0], self.base[1]])
                .into_iter()
                .filter(|w| nav.reachable([w[0], w[1]]))
                .collect();
            if wps.is_empty() {
                unreachable.push(info.id);
                continue;
            }
            let sc = &self.scoring;
            let target = Target {
                cluster_id: info.id,
                centroid: unfinished_centroid(&sc.map, info, sc.params.eps_sopm),
            };
            let mount = sc.params.mount;
            let views = wps
                .iter()
                .map(|w| sc.chosen(*w, mount.neck_yaw_toward(*w, info.center), Some(&target)))
                .collect();
            found = Some(Circle {
                cluster: *info,
                waypoints: wps,
                views,
            });
            break;
        }
        CoverageResult {
            circle: found,
            unreachable,
            nav: self.nav,
            scoring: self.scoring,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn circle_is_closed_and_tangent() {
        let info = ClusterInfo {
            id: 1,
            first_seen_ns: 0,
            center: Vec3::new(1.0, 0.0, 0.5),
            radius: 0.5,
            foreground: 0,
            foreground_done: 0,
            done: false,
            sides_seen: 0,
            approached: false,
        };
        let p = CoverageParams {
            waypoints: 4,
            safe_distance: 0.5,
            nav: NavParams {
                robot_radius: 0.3,
                inflated: false,
                unknown_traversable: true,
            },
        };
        let c = circle(&info, &p, [-3.0, 0.0]);
        assert_eq!(c.len(), 5);
        assert!((c[0][0] - 0.0).abs() < 1e-5 && c[0][1].abs() < 1e-5);
        assert!(
            (c[1][0] - 1.0).abs() < 1e-5 && (c[1][1] + 1.0).abs() < 1e-5,
            "ccw: {c:?}"
        );
        assert!((c[4][0] - c[0][0]).abs() < 1e-5 && (c[4][1] - c[0][1]).abs() < 1e-5);
        // At the west point moving counter-clockwise (south): yaw −π/2.
        assert!((geom::wrap_angle(c[0][2] + FRAC_PI_2)).abs() < 1e-5);
    }
}
