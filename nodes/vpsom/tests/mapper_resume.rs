//! A restarted mapper resumes from its predecessor's last published map
//! ([`Mapper::resume_from`], issue 16). Along a drive around paper-scene-1's desk with the
//! default (erroneous) sensing, a mapper is resumed from the running mapper's map every 15
//! frames and fed the same next 10 frames: it must publish every restored object that the
//! running mapper still publishes, within a few cm of it. Before the fix, a restored table's
//! footprint shrank on its first refit (64 sample points and one partial view), objects near
//! its edge left its cluster and were not published, and neighbours kept apart by
//! co-detection were merged.

mod desk_tour;

use glam::Vec3;
use shm_types::{ObjectMap, boxed_zeroed, class_name};
use vpsom::config::Config;
use vpsom::mapper::Mapper;
use vpsom::sim::{Scene, Sim};

const EVERY: u32 = 15;
const WINDOW: u32 = 10;

#[test]
#[ignore = "issue #34's fused height: the resumed mapper (restored from the published, shorter box, \
            widened to its samples' top) merges restored keyboard 227 into a new duplicate 9 frames \
            after the resume at frame 840 (seed 7); the running mapper keeps it. Open in #34's note"]
fn a_resumed_mapper_keeps_every_published_object_through_the_next_second() {
    let cfg = Config::default().with_camera(320, 240, 10.0);
    let scene = Scene::builtin("paper-scene-1").unwrap();
    let desk = scene.objects.iter().find(|o| o.background).unwrap().center;
    let mut sim = Sim::new(scene.clone(), &cfg, 7).unwrap();
    let mut mapper = Mapper::new(&cfg.mapper, &cfg.camera.camera()).unwrap();
    let (mut checkpoint, mut ours, mut theirs) = (
        boxed_zeroed::<ObjectMap>(),
        boxed_zeroed::<ObjectMap>(),
        boxed_zeroed::<ObjectMap>(),
    );
    let mut resumed: Option<(Mapper, u32)> = None;
    let (mut frames, mut checked, mut restored, mut worst_shift) = (0u32, 0u32, 0usize, 0.0f32);
    let (mut shifts, mut own, mut lost) = (Vec::new(), Vec::new(), Vec::new());
    desk_tour::circle_desk(&mut sim, &cfg, desk, |frame, dets, state, now| {
        mapper.integrate(frame, dets, state).unwrap();
        frames += 1;
        if let Some((r, at)) = resumed.as_mut() {
            r.integrate(frame, dets, state).unwrap();
            r.write_map(&mut ours, now);
            mapper.write_map(&mut theirs, now);
            checked += 1;
            for o in checkpoint.objects() {
                let Some(t) = theirs.objects().iter().find(|t| t.id == o.id) else {
                    continue;
                };
                match ours.objects().iter().find(|u| u.id == o.id) {
                    Some(u) => {
                        let d = Vec3::from(u.center) - Vec3::from(t.center);
                        worst_shift = worst_shift.max(d.length());
                        shifts.push(d.length());
                        own.push((Vec3::from(o.center) - Vec3::from(t.center)).length());
                    }
                    None => lost.push(format!(
                        "{} {} (resumed at frame {at}, +{})",
                        class_name(o.class_id),
                        o.id,
                        frames - *at
                    )),
                }
            }
            if frames - *at == WINDOW {
                resumed = None;
            }
        }
        if frames % EVERY == 0 {
            mapper.write_map(&mut checkpoint, now);
            let mut r = Mapper::new(&cfg.mapper, &cfg.camera.camera()).unwrap();
            restored += r.resume_from(&checkpoint);
            resumed = Some((r, frames));
        }
    });
    println!(
        "{frames} frames, {} resumes ({restored} objects restored), {checked} frames compared; \
         largest centre difference from the running mapper {worst_shift:.3} m",
        frames / EVERY
    );
    // Centre differences from the running mapper, and (for scale) the running mapper's own
    // motion since the checkpoint, over the same objects and frames.
    let quantiles = |mut v: Vec<f32>| {
        v.sort_by(f32::total_cmp);
        [0.5, 0.9, 0.99].map(|f| v[((v.len() - 1) as f64 * f) as usize])
    };
    let (ours_q, own_q) = (quantiles(shifts), quantiles(own));
    println!(
        "centre difference from the running mapper, quantiles 0.5 / 0.9 / 0.99: {ours_q:.4?} m; \
         the running mapper's own motion since the checkpoint: {own_q:.4?} m"
    );
    assert!(
        frames >= 300 && restored >= 100,
        "{frames} frames, {restored} objects"
    );
    assert!(lost.is_empty(), "restored objects not published: {lost:?}");
    // Measured: [0.0017, 0.0263, 0.0629] m, against the running mapper's own
    // [0.0001, 0.0032, 0.0197] m: a restored cuboid is refitted from its 64 published sample
    // points, the new views and its published size as a floor, so it moves by a few cm
    // where the running mapper's moves by mm.
    assert!(
        ours_q[0] < 0.01 && ours_q[1] < 0.05,
        "resumed objects moved: quantiles {ours_q:?} m"
    );
}
