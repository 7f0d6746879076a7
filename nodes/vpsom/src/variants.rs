//! Sensing variants of a bench label (`<planner>@<variant>`).
//!
//! - `vpsom bench --sensitivity` ([`SENSITIVITY`]): the default sensing with one group made
//!   worse. "Twice as bad" per group: every rate and sigma of the group doubled (probabilities
//!   capped at 1); false-positive scores: the low-score range shifted up by 0.3 (capped at 0.99).
//! - `vpsom bench --pose-ablation` ([`POSE_ABLATION`]): every pose-error source off
//!   (`pose-off`), or one source alone at its default with the others off (`pose-<source>`);
//!   detector and depth stay at their defaults.

use crate::config::Config;

/// The sensing groups of `--sensitivity`, in report order.
pub const SENSITIVITY: [&str; 6] = [
    "2x-misses",
    "2x-fp-rate",
    "fp-scores+0.3",
    "2x-confusion",
    "2x-depth-artefacts",
    "2x-pose-error",
];

/// The pose-error variants of `--pose-ablation`, in report order: all off, then each source
/// alone. The SLAM's sources act through its corrections of the odometry (an exact odometry
/// ignores them), so `pose-slam-residual` and `pose-map-drift` are the odometry with that source
/// (planar), read against `pose-odometry`; `pose-slam-6dof` is the odometry with both in 6 DoF:
/// beside them it shows what the out-of-plane part adds.
pub const POSE_ABLATION: [&str; 8] = [
    "pose-off",
    "pose-odometry",
    "pose-slam-residual",
    "pose-map-drift",
    "pose-slam-6dof",
    "pose-neck-bias",
    "pose-neck-noise",
    "pose-stamp-delay",
];

/// An unknown sensing variant in a bench label.
#[derive(Debug, thiserror::Error)]
#[error(
    "unknown sensing variant {0:?} in a planner label (known: {known}, {pose})",
    known = SENSITIVITY.join(", "),
    pose = POSE_ABLATION.join(", ")
)]
pub struct UnknownVariant(pub String);

/// Every pose-error source of `cfg` off except those `keep` names.
fn pose_only(cfg: &mut Config, keep: &[&str]) {
    let r = &mut cfg.robot;
    let off = |name: &str, v: &mut f32| {
        if !keep.contains(&name) {
            *v = 0.0;
        }
    };
    off("odometry", &mut r.odom_trans_noise);
    off("odometry", &mut r.odom_rot_noise);
    off("odometry", &mut r.odom_rot_per_m);
    off("slam-residual", &mut r.slam.residual_xy_m);
    off("slam-residual", &mut r.slam.residual_yaw_deg);
    off("map-drift", &mut r.slam.map_drift_xy_m);
    off("map-drift", &mut r.slam.map_drift_yaw_deg);
    off("neck-bias", &mut r.neck_encoder_bias_deg);
    off("neck-noise", &mut r.neck_encoder_noise_deg);
    off("stamp-delay", &mut r.pose_delay_ms);
    r.slam.out_of_plane = keep.contains(&"6dof");
}

/// Apply sensing variant `name` to `cfg`.
pub fn apply(cfg: &mut Config, name: &str) -> Result<(), UnknownVariant> {
    let p = |v: &mut f32| *v = (*v * 2.0).min(1.0);
    let x2 = |v: &mut f32| *v *= 2.0;
    match name {
        "2x-misses" => {
            let d = &mut cfg.detector;
            [
                &mut d.miss_rate,
                &mut d.miss_small,
                &mut d.miss_occluded,
                &mut d.miss_truncated,
            ]
            .into_iter()
            .for_each(p);
        }
        "2x-fp-rate" => {
            let d = &mut cfg.detector;
            x2(&mut d.fp_per_frame);
            [&mut d.dup_per_tp, &mut d.fp_confident_per_tp]
                .into_iter()
                .for_each(p);
        }
        "fp-scores+0.3" => {
            let d = &mut cfg.detector;
            d.fp_score_min = (d.fp_score_min + 0.3).min(0.99);
            d.fp_score_max = (d.fp_score_max + 0.3).min(0.99);
        }
        "2x-confusion" => {
            let d = &mut cfg.detector;
            [&mut d.confusion_rate, &mut d.other_rate]
                .into_iter()
                .for_each(p);
        }
        "2x-depth-artefacts" => {
            let s = &mut cfg.sim;
            [&mut s.noise_a, &mut s.noise_b].into_iter().for_each(x2);
            [
                &mut s.dropout,
                &mut s.edge_mixed,
                &mut s.edge_invalid,
                &mut s.glass_invalid,
                &mut s.glass_through,
                &mut s.dark_invalid,
                &mut s.specular_invalid,
            ]
            .into_iter()
            .for_each(p);
            if s.edge_mixed + s.edge_invalid > 1.0 {
                let k = 1.0 / (s.edge_mixed + s.edge_invalid);
                (s.edge_mixed, s.edge_invalid) = (s.edge_mixed * k, s.edge_invalid * k);
            }
            if s.glass_invalid + s.glass_through > 1.0 {
                let k = 1.0 / (s.glass_invalid + s.glass_through);
                (s.glass_invalid, s.glass_through) = (s.glass_invalid * k, s.glass_through * k);
            }
        }
        "2x-pose-error" => {
            let r = &mut cfg.robot;
            [
                &mut r.odom_trans_noise,
                &mut r.odom_rot_noise,
                &mut r.odom_rot_per_m,
                &mut r.neck_encoder_bias_deg,
                &mut r.neck_encoder_noise_deg,
                &mut r.pose_delay_ms,
                &mut r.slam.residual_xy_m,
                &mut r.slam.residual_yaw_deg,
                &mut r.slam.map_drift_xy_m,
                &mut r.slam.map_drift_yaw_deg,
            ]
            .into_iter()
            .for_each(x2);
        }
        "pose-off" => pose_only(cfg, &[]),
        // The SLAM corrects the odometry's estimate: with exact odometry (no uncertainty) its
        // measurements are ignored, so its sources come with the odometry's.
        "pose-slam-residual" => pose_only(cfg, &["odometry", "slam-residual"]),
        "pose-map-drift" => pose_only(cfg, &["odometry", "map-drift"]),
        "pose-slam-6dof" => pose_only(cfg, &["odometry", "slam-residual", "map-drift", "6dof"]),
        v => match v.strip_prefix("pose-") {
            Some(source) if POSE_ABLATION.contains(&v) => pose_only(cfg, &[source]),
            _ => return Err(UnknownVariant(name.to_string())),
        },
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_variant_is_valid_config_and_worse_than_the_default() {
        let base = Config::builtin();
        for v in SENSITIVITY {
            let mut c = base.clone();
            apply(&mut c, v).unwrap();
            assert_ne!(format!("{c:?}"), format!("{base:?}"), "{v} changed nothing");
            c.validate(std::path::Path::new("variant"))
                .unwrap_or_else(|e| panic!("{v}: {e}"));
        }
        for v in POSE_ABLATION {
            let mut c = base.clone();
            apply(&mut c, v).unwrap();
            c.validate(std::path::Path::new("variant"))
                .unwrap_or_else(|e| panic!("{v}: {e}"));
        }
        let mut off = base.clone();
        apply(&mut off, "pose-off").unwrap();
        let r = &off.robot;
        assert_eq!(
            (r.odom_trans_noise, r.neck_encoder_bias_deg, r.pose_delay_ms),
            (0.0, 0.0, 0.0)
        );
        assert_eq!((r.slam.residual_xy_m, r.slam.map_drift_yaw_deg), (0.0, 0.0));
        let mut neck = base.clone();
        apply(&mut neck, "pose-neck-noise").unwrap();
        assert_eq!(
            neck.robot.neck_encoder_noise_deg,
            base.robot.neck_encoder_noise_deg
        );
        assert_eq!(
            (neck.robot.odom_rot_noise, neck.robot.pose_delay_ms),
            (0.0, 0.0)
        );
        assert!(!neck.robot.slam.out_of_plane);
        let mut six = base.clone();
        apply(&mut six, "pose-slam-6dof").unwrap();
        assert!(six.robot.slam.out_of_plane);
        assert_eq!(six.robot.slam.residual_xy_m, base.robot.slam.residual_xy_m);
        assert_eq!(six.robot.odom_trans_noise, base.robot.odom_trans_noise);
        assert_eq!(six.robot.neck_encoder_bias_deg, 0.0);
        let mut c = base.clone();
        apply(&mut c, "fp-scores+0.3").unwrap();
        assert!((c.detector.fp_score_max - base.detector.fp_score_max - 0.3).abs() < 1e-6);
        assert!(apply(&mut c, "3x-misses").is_err());
    }
}
