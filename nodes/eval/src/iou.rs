//! Size-only 3D IoU of two cuboids after aligning their centres and orientations (paper § 7.2).

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// 3D IoU of two cuboids once their centres and yaws are aligned, so only the sizes matter.
///
/// `size_*` are the extents along each cuboid's own x, y, z axes and `yaw_*` its rotation about
/// +z. Aligning the estimate onto the ground truth rotates it by the relative yaw; since a cuboid
/// is symmetric under a quarter turn with its x and y extents swapped, the relative yaw is taken
/// modulo π/2 first: when it is nearer to ±π/2 than to 0 or π, the estimate's x and y extents
/// are swapped (a box of 2 × 1 m at yaw 0 is the same box as 1 × 2 m at yaw π/2). Any other yaw
/// error is ignored, as the paper's definition prescribes.
///
/// Returns intersection / union with intersection = Π min(a_i, b_i); 0 when both are empty.
pub fn aligned_iou(size_gt: [f32; 3], yaw_gt: f32, size_est: [f32; 3], yaw_est: f32) -> f64 {
    let mut est = size_est.map(|s| f64::from(s.max(0.0)));
    let gt = size_gt.map(|s| f64::from(s.max(0.0)));
    let rel = (f64::from(yaw_est) - f64::from(yaw_gt)).rem_euclid(PI);
    if (rel - FRAC_PI_2).abs() < FRAC_PI_4 {
        est.swap(0, 1);
    }
    let inter: f64 = (0..3).map(|i| gt[i].min(est[i])).product();
    let union = gt.iter().product::<f64>() + est.iter().product::<f64>() - inter;
    if union > 0.0 { inter / union } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_size_gives_half_iou_whatever_the_small_yaw_error() {
        for yaw in [0.0, 0.3, -0.7, 3.0] {
            let v = aligned_iou([1.0, 1.0, 1.0], 0.2, [0.5, 1.0, 1.0], 0.2 + yaw);
            assert!((v - 0.5).abs() < 1e-9, "yaw {yaw}: {v}");
        }
    }

    #[test]
    fn quarter_turn_swaps_extents() {
        let same = aligned_iou(
            [2.0, 1.0, 0.5],
            0.0,
            [1.0, 2.0, 0.5],
            std::f32::consts::FRAC_PI_2,
        );
        assert!((same - 1.0).abs() < 1e-6);
        let unswapped = aligned_iou([2.0, 1.0, 0.5], 0.0, [1.0, 2.0, 0.5], 0.0);
        assert!((unswapped - 1.0 / 3.0).abs() < 1e-6);
    }

    #[test]
    fn disjoint_sizes_and_empty_boxes() {
        // 1×1×1 inside 2×2×2: 1 / 8.
        assert!((aligned_iou([2.0; 3], 0.0, [1.0; 3], 0.0) - 0.125).abs() < 1e-9);
        assert_eq!(aligned_iou([0.0; 3], 0.0, [0.0; 3], 0.0), 0.0);
        assert_eq!(aligned_iou([1.0; 3], 0.0, [0.0; 3], 0.0), 0.0);
    }
}
