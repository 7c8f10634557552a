//! Tracker pose logs (`endoloc_data::import::tracker`): CSV with a header or TUM, dropout flags,
//! time stamps that must increase. Whatever the bytes, parsing returns a log or an error, and
//! a log's samples increase in time with at least one valid pose; resampling it never panics.
#![no_main]

use endoloc_data::import::endoslam::Units;
use endoloc_data::import::tracker::{ResampleConfig, TrackerLogConfig, parse_pose_log, poses_at};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let cfg = TrackerLogConfig {
        units: Units::Mm,
        rate_hz: Some(30.0),
    };
    let Ok(log) = parse_pose_log(Path::new("tracker.csv"), data.to_vec(), &cfg) else {
        return;
    };
    assert!(log.samples.windows(2).all(|w| w[0].time_s < w[1].time_s));
    assert!(log.samples.iter().any(|s| s.pose.is_some()));
    let first = log.samples[0].time_s;
    let times = [first - 1.0, first, first + 0.01, f64::NAN, f64::INFINITY];
    let poses = poses_at(&log, &times, &ResampleConfig::default());
    assert_eq!(poses.len(), times.len());
    assert!(poses[1].is_some() || log.samples[0].pose.is_none());
});
