//! Flat objects on box-only detections (`[mapper.extensions] flat_objects`): a 1 cm phone lies
//! inside the table top's plane band, so its points go with the table; it is located by its box
//! on the mapped table top instead.

mod mapper_common;

use glam::Vec3;
use mapper_common::{RenderOpts, Scene, Shape, camera, render, state, view};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use shm_types::{DepthFrame, Detections, boxed_zeroed, class_id};
use vpsom::mapper::{Mapper, MapperConfig};

/// Views around a phone lying on a table; the mapper's objects of class cell phone.
fn phones(flat: bool) -> Vec<vpsom::mapper::object::MappedObject> {
    let scene = Scene {
        objects: vec![
            Shape::new(
                "dining table",
                [0.0, 0.0, 0.375],
                [1.2, 0.8, 0.75],
                0.0,
                false,
            ),
            Shape::new(
                "cell phone",
                [0.25, 0.05, 0.755],
                [0.15, 0.07, 0.01],
                0.4,
                false,
            ),
        ],
        room: [-3.0, -3.0, 3.0, 3.0],
    };
    let cam = camera();
    let mut cfg = MapperConfig::default();
    cfg.extensions.flat_objects = flat;
    let mut mapper = Mapper::new(&cfg, &cam).unwrap();
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let mut rng = Pcg64::seed_from_u64(5);
    let opts = RenderOpts {
        boxes: true,
        ..Default::default()
    };
    let target = Vec3::new(0.25, 0.05, 0.755);
    for k in 0..8u64 {
        let pose = view(target, 1.3, -40.0 + 10.0 * k as f32);
        render(
            &scene,
            &cam,
            &pose,
            k + 1,
            k * 100_000_000,
            &opts,
            &mut rng,
            &mut frame,
            &mut dets,
        );
        mapper.integrate(&frame, &dets, &state()).unwrap();
    }
    let id = class_id("cell phone").unwrap();
    mapper
        .objects()
        .iter()
        .filter(|o| o.class_id == id)
        .cloned()
        .collect()
}

#[test]
fn a_phone_lying_on_a_table_is_located_by_its_box() {
    let got = phones(true);
    assert_eq!(got.len(), 1, "one phone");
    let b = got[0].cuboid;
    let d = b
        .center
        .truncate()
        .distance(Vec3::new(0.25, 0.05, 0.0).truncate());
    println!("phone centre off by {d:.3} m, size {:?}", b.size);
    assert!(d < 0.03, "centre off by {d:.3} m: {b:?}");
    assert!(b.size.x.max(b.size.y) < 0.25, "{b:?}");
    // Without the extension the phone is lost with the table top.
    assert!(phones(false).is_empty());
}
