//! A simulated recording with a circular field stop and black side borders: the simulator
//! writes its own mask, `dataset mask` finds the same one from the frames alone, and SURF on
//! those frames keeps every keypoint inside it.

use std::sync::Arc;

use endoloc_data::Dataset;
use endoloc_features::mask::DETECTOR_REACH_PER_SCALE;
use endoloc_features::{Mask, SurfConfig};
use endoloc_jobs::{DatasetAction, DatasetJob, JobError, Silent};
use endoloc_sim::{Preset, SimConfig};

#[test]
fn the_mask_found_from_rendered_frames_matches_the_renderers() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("stop");
    let mut cfg = SimConfig::preset(Preset::Small).with_seed(5);
    cfg.train.frames = 48;
    cfg.test.frames = 16;
    cfg.render.field_stop = 0.92;
    cfg.render.black_border_px = 12;
    endoloc_sim::simulate(&cfg, &out, false, &|_| {}).unwrap();

    let ds = Dataset::open(&out).unwrap();
    let rendered =
        Mask::from_gray(&ds.load_mask().unwrap().expect("the simulator wrote a mask")).unwrap();
    assert!(rendered.valid_fraction() < 0.95 && rendered.valid_fraction() > 0.6);

    // Found again from the frames alone.
    let job = DatasetJob {
        action: DatasetAction::Mask,
        dir: out.clone(),
        ..DatasetJob::default()
    };
    let refused = job.run(&Silent).unwrap_err();
    assert!(matches!(refused, JobError::Exists { .. }), "{refused}");
    DatasetJob { force: true, ..job }.run(&Silent).unwrap();
    let found =
        Mask::from_gray(&Dataset::open(&out).unwrap().load_mask().unwrap().unwrap()).unwrap();
    let iou = found.iou(&rendered).unwrap();
    assert!(iou >= 0.98, "IoU {iou:.4} with the renderer's mask");

    // SURF with the mask: no keypoint whose filter reaches the black.
    let surf = SurfConfig::default()
        .with_threshold(50.0)
        .init()
        .unwrap()
        .with_mask(Some(Arc::new(rendered.clone())));
    let test = ds.sequence("test").unwrap();
    let mut total = 0;
    for i in 0..test.len() {
        for f in surf
            .detect_and_describe(&test.load_gray(i).unwrap())
            .unwrap()
        {
            let k = f.keypoint;
            assert!(
                rendered.clearance(k.x, k.y) >= DETECTOR_REACH_PER_SCALE * k.scale,
                "frame {i}: keypoint {k:?} reaches outside the mask"
            );
            total += 1;
        }
    }
    assert!(
        total > 100,
        "only {total} keypoints in {} frames",
        test.len()
    );
}
