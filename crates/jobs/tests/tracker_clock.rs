//! A tracker log on its own clock against a rendered pass: the log is written at 100 Hz from the
//! pass's true camera path, 0.35 s off the video's clock, for a sensor 5 mm behind the camera,
//! with two 200 ms dropouts; the clock offset is found from the images alone, and the camera
//! poses resampled at the frame times match the pass's own.

use endoloc_data::import::endoslam::Units;
use endoloc_data::import::tracker::{
    OffsetSearch, PoseLog, PoseSample, ResampleConfig, TrackerLogConfig, estimate_time_offset,
    frame_motion, parse_pose_log, poses_at,
};
use endoloc_geometry::Pose;
use endoloc_jobs::{Silent, SimulateJob};
use nalgebra::{Translation3, UnitQuaternion};

const OFFSET_S: f64 = 0.35;

#[test]
fn a_known_clock_offset_is_found_and_the_poses_come_back() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    SimulateJob {
        train_frames: Some(240),
        test_frames: Some(2),
        width: Some(160),
        height: Some(120),
        depth: Some(false),
        out: data.clone(),
        ..SimulateJob::default()
    }
    .run(&Silent)
    .unwrap();
    let seq = endoloc_data::Dataset::open(&data)
        .unwrap()
        .sequence("train")
        .unwrap();
    let times: Vec<f64> = seq.poses.iter().map(|p| p.timestamp_s).collect();

    // The true camera path as a log on the video's clock, to sample the tracker from.
    let truth = PoseLog {
        source: "truth".into(),
        samples: seq
            .poses
            .iter()
            .enumerate()
            .map(|(i, p)| PoseSample {
                time_s: p.timestamp_s,
                pose: Some(p.pose),
                line: i + 1,
            })
            .collect(),
        notes: Vec::new(),
    };
    // The sensor sits 5 mm behind the camera: T_sc moves 5 mm along the camera's z.
    let t_sc = Pose::from_parts(Translation3::new(0.0, 0.0, 5.0), UnitQuaternion::identity());
    let t_cs = t_sc.inverse();
    let dropouts = [(2.0, 2.2), (5.0, 5.2)];
    let mut csv = String::from("time [s],x,y,z,qx,qy,qz,qw,valid\n");
    let (t0, t1) = (times[0], *times.last().unwrap());
    for k in 0.. {
        let log_time = -0.5 + k as f64 * 0.01;
        let video_time = log_time - OFFSET_S;
        if video_time > t1 + 0.5 {
            break;
        }
        let camera = (video_time >= t0 && video_time <= t1)
            .then(|| {
                poses_at(&truth, &[video_time], &ResampleConfig::default())[0]
                    .expect("inside the pass")
            })
            .filter(|_| !dropouts.iter().any(|(a, b)| (*a..*b).contains(&log_time)));
        match camera {
            Some(c) => {
                let s = c * t_cs;
                let (t, q) = (s.translation.vector, s.rotation);
                csv.push_str(&format!(
                    "{log_time},{},{},{},{},{},{},{},1\n",
                    t.x, t.y, t.z, q.i, q.j, q.k, q.w
                ));
            }
            None => csv.push_str(&format!("{log_time},,,,,,,,0\n")),
        }
    }
    let log = parse_pose_log(
        std::path::Path::new("tracker.csv"),
        csv.into_bytes(),
        &TrackerLogConfig { units: Units::Mm },
    )
    .unwrap();

    // The offset from the images alone.
    let frames: Vec<image::GrayImage> = (0..seq.len()).map(|i| seq.load_gray(i).unwrap()).collect();
    let motion: Vec<f64> = (0..frames.len())
        .map(|i| match i {
            0 => f64::NAN,
            _ => frame_motion(&frames[i - 1], &frames[i]),
        })
        .collect();
    let found = estimate_time_offset(&log, &times, &motion, &OffsetSearch::default()).unwrap();
    eprintln!("{found:?}");
    let frame_s = 1.0 / 30.0;
    assert!(
        (found.offset_s - OFFSET_S).abs() < frame_s,
        "found {found:?}, true offset {OFFSET_S} s"
    );

    // The poses at the frame times: with the true offset the pass's own (to the interpolation
    // of a 100 Hz log sampled from a path that bends at every frame: 0.3 mm here), with the found one off by at most the camera's speed times the clock
    // error; none in the dropouts.
    let fastest_mm_s = seq
        .poses
        .windows(2)
        .map(|w| {
            (w[1].pose.translation.vector - w[0].pose.translation.vector).norm()
                / (w[1].timestamp_s - w[0].timestamp_s)
        })
        .fold(0.0, f64::max);
    let resample = |offset_s: f64| {
        let cfg = ResampleConfig {
            time_offset_s: offset_s,
            max_gap_s: 0.05,
            sensor_to_camera: Some(t_sc),
        };
        let mut worst = 0.0_f64;
        let mut unposed = Vec::new();
        for (i, (p, truth)) in poses_at(&log, &times, &cfg)
            .iter()
            .zip(&seq.poses)
            .enumerate()
        {
            match p {
                Some(p) => {
                    worst = worst.max((p.translation.vector - truth.pose.translation.vector).norm())
                }
                None => unposed.push(i),
            }
        }
        (worst, unposed)
    };
    let (exact_mm, _) = resample(OFFSET_S);
    assert!(
        exact_mm < 0.5,
        "true offset: largest position error {exact_mm:.3} mm"
    );
    let (worst, unposed) = resample(found.offset_s);
    let allowed = fastest_mm_s * (found.offset_s - OFFSET_S).abs() + 0.5;
    assert!(
        worst < allowed,
        "largest position error {worst:.3} mm, allowed {allowed:.3}"
    );
    // Unposed: in a dropout, or (a fraction of a frame off the true clock) past either end
    // of the log's valid samples.
    let (first, last) = (t0 + OFFSET_S, t1 + OFFSET_S);
    let in_dropout = |i: usize| {
        let t = times[i] + found.offset_s;
        t < first + 0.05
            || t > last - 0.05
            || dropouts.iter().any(|(a, b)| t > a - 0.05 && t < b + 0.05)
    };
    assert!(unposed.iter().all(|&i| in_dropout(i)), "{unposed:?}");
    assert!(unposed.len() >= 10, "{unposed:?}");
}
