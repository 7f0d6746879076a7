//! Object footprint sizes fused from per-view extents (`[mapper.extensions] view_extents`).
//!
//! The merged cloud of an object collects points from many views, each placed with that view's
//! pose estimate. Pose errors between views (SLAM drift, keyframe residuals, neck-encoder noise:
//! 1–4 cm) shift the views' points against each other, so the merged cloud — and a cuboid fitted
//! to its extents — is larger than the object by about the spread of the pose errors. A 0.1 m cup
//! comes out 0.15–0.19 m wide. Within one view the points are placed with one pose, so a single
//! view's extent is free of that smear.
//!
//! Each object keeps a bounded set of views: a subsample of the view's points and the horizontal
//! line of sight. The footprint size along a cuboid axis is a quantile (`view_quantile`), over the
//! views whose line of sight is roughly perpendicular to that axis (|cos| ≤ `perpendicular_cos`:
//! they see the object's full width along it, its silhouette), of the view's robust extent along
//! the axis.
//! Views cut by the image border are not recorded (their extent is short). A middle quantile
//! rejects both occluded or drop-out views (short) and views with segmentation bleed (long). With fewer than
//! `min_views` such views the merged cloud's extent stays. The fused size never exceeds the
//! merged cloud's (which holds every view's points).
//!
//! Only the published size changes: association gates, existence, merging and the SOPM keep the
//! merged cloud's cuboid, whose smear is a useful tolerance for the next view's pose error.

use glam::{Vec2, Vec3};

/// `[mapper.view_extents]` parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewExtentConfig {
    /// Views kept per object (a new view replaces the kept one of the closest line of sight).
    pub max_views: u32,
    /// Points kept per view (an even subsample).
    pub points_per_view: u32,
    /// A view sees an axis's full extent when |cos(line of sight, axis)| is at most this.
    pub perpendicular_cos: f32,
    /// Fewest such views for a fused extent (else the merged cloud's).
    pub min_views: u32,
    /// A detection box within this many pixels of the image border is cut: not recorded.
    pub border_px: f32,
    /// Robust min/max quantile of one view's points along an axis.
    pub point_quantile: f32,
    /// Quantile over the views' extents taken as the size (0.5: median; higher leans to the
    /// views that saw more of the object: occlusion, dropout and trimming only shorten a view).
    pub view_quantile: f32,
    /// The height too: each view's robust height, fused like the footprint (the cuboid keeps
    /// its bottom on the supporting plane); `false`: the merged cloud's height.
    pub height: bool,
    /// The horizontal centre too: per axis the median midpoint of the views that see it
    /// squarely; `false`: the merged cloud's centre.
    pub centre: bool,
}

impl Default for ViewExtentConfig {
    /// The `[mapper.view_extents]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.view_extents")
    }
}

impl ViewExtentConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &settings::Checker) -> Result<(), settings::ConfigError> {
        settings::ranges!(c, self, {
            max_views: count(1, 4096),
            points_per_view: count(3, 100_000),
            perpendicular_cos: in_range(0.0, 1.0),
            min_views: count(1, 4096),
            border_px: in_range(0.0, 1000.0),
            point_quantile: in_range(0.0, 0.2),
            view_quantile: in_range(0.0, 1.0),
        });
        Ok(())
    }
}

/// The fused footprint along one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FusedAxis {
    /// Extent, metres.
    pub size: f32,
    /// Median midpoint (coordinate along the axis), metres.
    pub mid: f32,
    /// Views that see the axis squarely.
    pub views: usize,
}

/// One recorded view.
#[derive(Debug, Clone, PartialEq)]
struct View {
    /// Unit horizontal line of sight (camera → points' centroid).
    los: Vec2,
    /// Subsampled points (xy only).
    pts: Vec<Vec2>,
    /// Robust height of the view's points (`point_quantile` to 1 − it), metres.
    height: f32,
}

/// The views of one object.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ViewExtents {
    views: Vec<View>,
}

/// Value at quantile `q` of `v` (partially reorders `v`); `v` must be non-empty.
fn quantile(v: &mut [f32], q: f32) -> f32 {
    let i = ((v.len() - 1) as f32 * q).round() as usize;
    *v.select_nth_unstable_by(i, |a, b| a.total_cmp(b)).1
}

impl ViewExtents {
    /// Number of recorded views.
    pub fn len(&self) -> usize {
        self.views.len()
    }

    /// No view recorded yet.
    pub fn is_empty(&self) -> bool {
        self.views.is_empty()
    }

    /// Record one view's points (world frame, one pose) seen from `camera`.
    pub fn record(&mut self, points: &[Vec3], camera: Vec3, cfg: &ViewExtentConfig) {
        if points.len() < 3 || cfg.max_views == 0 {
            return;
        }
        let centroid = points.iter().copied().sum::<Vec3>() / points.len() as f32;
        let Some(los) = (centroid - camera).truncate().try_normalize() else {
            return;
        };
        let k = (cfg.points_per_view as usize).clamp(3, points.len());
        let pts: Vec<Vec2> = (0..k)
            .map(|i| points[i * points.len() / k].truncate())
            .collect();
        let mut z: Vec<f32> = points.iter().map(|p| p.z).collect();
        let q = cfg.point_quantile;
        let height = quantile(&mut z, 1.0 - q) - quantile(&mut z, q);
        let view = View { los, pts, height };
        if self.views.len() < cfg.max_views as usize {
            self.views.push(view);
        } else if let Some(slot) = self
            .views
            .iter_mut()
            .max_by(|a, b| a.los.dot(los).total_cmp(&b.los.dot(los)))
        {
            *slot = view;
        }
    }

    /// Absorb a duplicate's views (up to the cap).
    pub fn absorb(&mut self, other: &ViewExtents, cfg: &ViewExtentConfig) {
        for v in &other.views {
            if self.views.len() >= cfg.max_views as usize {
                break;
            }
            self.views.push(v.clone());
        }
    }

    /// Fused footprint along the axes of `yaw` (x, y): per axis the `view_quantile` of the
    /// squarely-seeing views' extents and the median of their midpoints (a silhouette's middle
    /// is free of the near-side bias of a partial view; the median drops views with bleed or
    /// an outlying pose), each `None` when fewer than `min_views` views see that axis squarely.
    pub fn fused_axes(&self, yaw: f32, cfg: &ViewExtentConfig) -> [Option<FusedAxis>; 2] {
        let q = cfg.point_quantile;
        let (s, c) = yaw.sin_cos();
        let axes = [Vec2::new(c, s), Vec2::new(-s, c)];
        let mut vals = Vec::new();
        let (mut ext, mut mid) = (Vec::new(), Vec::new());
        axes.map(|axis| {
            ext.clear();
            mid.clear();
            for v in &self.views {
                if v.los.dot(axis).abs() > cfg.perpendicular_cos {
                    continue;
                }
                vals.clear();
                vals.extend(v.pts.iter().map(|p| p.dot(axis)));
                let lo = quantile(&mut vals, q);
                let hi = quantile(&mut vals, 1.0 - q);
                ext.push(hi - lo);
                mid.push(0.5 * (hi + lo));
            }
            (ext.len() >= cfg.min_views.max(1) as usize).then(|| FusedAxis {
                size: quantile(&mut ext, cfg.view_quantile),
                mid: quantile(&mut mid, 0.5),
                views: ext.len(),
            })
        })
    }

    /// Fused footprint size along the axes of `yaw` (x, y) ([`Self::fused_axes`]).
    pub fn fused(&self, yaw: f32, cfg: &ViewExtentConfig) -> [Option<f32>; 2] {
        self.fused_axes(yaw, cfg).map(|a| a.map(|a| a.size))
    }

    /// The horizontal centre: `centre` moved, along each axis of `yaw` with a fused midpoint of
    /// at least three views (a median of two is one of them), to that midpoint
    /// ([`Self::fused_axes`]); z is kept.
    pub fn centre(&self, centre: Vec3, yaw: f32, cfg: &ViewExtentConfig) -> Vec3 {
        let (s, c) = yaw.sin_cos();
        let axes = [Vec2::new(c, s), Vec2::new(-s, c)];
        let mut xy = centre.truncate();
        for (axis, fused) in axes.iter().zip(self.fused_axes(yaw, cfg)) {
            if let Some(f) = fused.filter(|f| f.views >= 3) {
                xy += (f.mid - xy.dot(*axis)) * *axis;
            }
        }
        xy.extend(centre.z)
    }

    /// Fused height: the `view_quantile` of the views' heights (every view sees the height),
    /// `None` with fewer than `min_views` views.
    pub fn fused_height(&self, cfg: &ViewExtentConfig) -> Option<f32> {
        let mut h: Vec<f32> = self.views.iter().map(|v| v.height).collect();
        (h.len() >= cfg.min_views.max(1) as usize).then(|| quantile(&mut h, cfg.view_quantile))
    }

    /// The published size: the fused footprint extents where known, never larger than the
    /// merged cloud's `size`; with `cfg.height` the height likewise, from the views' heights
    /// plus `bottom_gap` (the band above the supporting plane that extraction removes from
    /// every view).
    pub fn size(&self, size: Vec3, yaw: f32, bottom_gap: f32, cfg: &ViewExtentConfig) -> Vec3 {
        let [x, y] = self.fused(yaw, cfg);
        let z = if cfg.height {
            self.fused_height(cfg)
                .map_or(size.z, |h| (h + bottom_gap).min(size.z))
        } else {
            size.z
        };
        Vec3::new(
            x.map_or(size.x, |v| v.min(size.x)),
            y.map_or(size.y, |v| v.min(size.y)),
            z,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> ViewExtentConfig {
        ViewExtentConfig {
            max_views: 8,
            points_per_view: 64,
            perpendicular_cos: 0.5,
            min_views: 2,
            border_px: 2.0,
            point_quantile: 0.0,
            view_quantile: 0.5,
            height: false,
            centre: false,
        }
    }

    /// The camera-facing half of a 0.2 × 0.1 m box's outline at yaw 0, seen from azimuth `deg`,
    /// shifted by `shift` (that view's pose error).
    fn view_points(deg: f32, shift: Vec2) -> (Vec<Vec3>, Vec3) {
        let dir = Vec2::from_angle(deg.to_radians());
        let camera = (dir * 2.0).extend(1.2);
        let mut pts = Vec::new();
        for i in 0..=20 {
            let t = i as f32 / 20.0 - 0.5;
            for p in [
                Vec2::new(0.1, t * 0.1),
                Vec2::new(-0.1, t * 0.1),
                Vec2::new(t * 0.2, 0.05),
                Vec2::new(t * 0.2, -0.05),
            ] {
                // Faces whose outward side looks at the camera (the top shows the whole outline).
                pts.push((p + shift).extend(0.8));
            }
        }
        (pts, camera)
    }

    #[test]
    fn fused_size_ignores_the_shift_between_views() {
        let mut e = ViewExtents::default();
        let mut merged_lo = Vec2::splat(f32::INFINITY);
        let mut merged_hi = Vec2::splat(f32::NEG_INFINITY);
        for (k, deg) in [0.0f32, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]
            .iter()
            .enumerate()
        {
            // Views shifted by up to ±4 cm against each other.
            let shift = Vec2::new(0.04 * (k as f32).sin(), 0.04 * (k as f32 * 1.7).cos());
            let (pts, cam) = view_points(*deg, shift);
            for p in &pts {
                merged_lo = merged_lo.min(p.truncate());
                merged_hi = merged_hi.max(p.truncate());
            }
            e.record(&pts, cam, &cfg());
        }
        let merged = merged_hi - merged_lo;
        let size = e.size(merged.extend(0.1), 0.0, 0.0, &cfg());
        assert!(merged.x > 0.25 && merged.y > 0.15, "merged {merged}");
        assert!((size.x - 0.2).abs() < 1e-3, "{size}");
        assert!((size.y - 0.1).abs() < 1e-3, "{size}");
        assert_eq!(size.z, 0.1);
    }

    #[test]
    fn fused_centre_is_the_median_silhouette_middle() {
        // Views from around, each shifted by its own pose error (up to 1 cm), one with 15 cm of
        // bleed along x: the merged cloud's centre is pulled, the fused centre is not.
        let mut e = ViewExtents::default();
        let c16 = ViewExtentConfig {
            max_views: 16,
            ..cfg()
        };
        for k in 0..16 {
            let deg = 22.5 * k as f32;
            let shift = 0.01 * Vec2::new((k as f32 * 2.1).sin(), (k as f32 * 1.3).cos());
            let (mut pts, cam) = view_points(deg, shift);
            if k == 4 {
                pts.extend((0..40).map(|i| Vec3::new(0.1 + 0.15 * i as f32 / 39.0, 0.0, 0.8)));
            }
            e.record(&pts, cam, &c16);
        }
        let pulled = Vec3::new(0.05, -0.01, 0.8);
        let c = e.centre(pulled, 0.0, &c16);
        assert!(c.truncate().length() < 0.012, "{c}");
        assert_eq!(c.z, 0.8);
        // No view sees an axis squarely: that coordinate stays.
        assert_eq!(ViewExtents::default().centre(pulled, 0.0, &cfg()), pulled);
    }

    #[test]
    fn fused_height_ignores_the_height_error_between_views() {
        // A 0.12 m tall object seen from 6 views, each placed with its own height error of up
        // to ±3 cm, its lowest 1.5 cm removed (the support band): the merged cloud spans
        // 0.015 - 0.03 .. 0.12 + 0.03, each view 0.105.
        let c = ViewExtentConfig {
            height: true,
            ..cfg()
        };
        let mut e = ViewExtents::default();
        let mut merged = (f32::INFINITY, f32::NEG_INFINITY);
        for k in 0..6 {
            let dz = 0.03 * (k as f32 * 1.3).sin();
            let (mut pts, cam) = view_points(60.0 * k as f32, Vec2::ZERO);
            let n = pts.len();
            for (i, p) in pts.iter_mut().enumerate() {
                p.z = 0.8 + dz + 0.015 + 0.105 * i as f32 / (n - 1) as f32;
                merged = (merged.0.min(p.z), merged.1.max(p.z));
            }
            e.record(&pts, cam, &c);
        }
        let merged_h = merged.1 - 0.8 + 0.03;
        assert!(merged_h > 0.17, "{merged_h}");
        let size = e.size(Vec3::new(0.2, 0.1, merged_h), 0.0, 0.015, &c);
        assert!((size.z - 0.12).abs() < 1e-3, "{size}");
        // Never taller than the merged cloud; off: the merged height.
        assert_eq!(e.size(Vec3::new(0.2, 0.1, 0.05), 0.0, 0.015, &c).z, 0.05);
        assert_eq!(
            e.size(Vec3::new(0.2, 0.1, merged_h), 0.0, 0.015, &cfg()).z,
            merged_h
        );
    }

    #[test]
    fn axes_without_square_views_keep_the_merged_extent() {
        let mut e = ViewExtents::default();
        // Only views along +-x: they see y squarely, never x.
        for deg in [0.0f32, 180.0, 5.0] {
            let (pts, cam) = view_points(deg, Vec2::ZERO);
            e.record(&pts, cam, &cfg());
        }
        let [x, y] = e.fused(0.0, &cfg());
        assert_eq!(x, None);
        assert!((y.unwrap() - 0.1).abs() < 1e-3);
        let size = e.size(Vec3::new(0.3, 0.2, 0.1), 0.0, 0.0, &cfg());
        assert_eq!(size.x, 0.3);
    }

    #[test]
    fn a_full_set_replaces_the_view_of_the_closest_direction() {
        let mut e = ViewExtents::default();
        let c = ViewExtentConfig {
            max_views: 2,
            ..cfg()
        };
        let (a, ca) = view_points(0.0, Vec2::ZERO);
        let (b, cb) = view_points(90.0, Vec2::ZERO);
        let (n, cn) = view_points(80.0, Vec2::new(0.5, 0.0));
        e.record(&a, ca, &c);
        e.record(&b, cb, &c);
        e.record(&n, cn, &c);
        assert_eq!(e.len(), 2);
        // The 0° view stays; the 90° one was replaced by the shifted 80° one.
        assert!(e.views[0].pts.iter().all(|p| p.x.abs() <= 0.1 + 1e-6));
        assert!(e.views[1].pts.iter().any(|p| p.x > 0.3));
    }
}
