//! Every configuration's sources of defaults agree: [`Default`] and deserialising an empty
//! TOML table (`#[serde(default)]`), nested tables included.

use serde::de::DeserializeOwned;

use crate::{LocalizerConfig, MapConfig};

/// An empty TOML document deserialises to `T::default()`.
fn empty_is_default<T: DeserializeOwned + Default + PartialEq + std::fmt::Debug>() {
    let parsed: T = toml::from_str("").unwrap();
    assert_eq!(parsed, T::default(), "{}", std::any::type_name::<T>());
}

#[test]
fn configs_default_and_empty_agree() {
    empty_is_default::<MapConfig>();
    empty_is_default::<LocalizerConfig>();
    // An empty `[localize]` table gives the same registration settings as the default.
    let parsed: LocalizerConfig = toml::from_str("[localize]\n").unwrap();
    assert_eq!(parsed, LocalizerConfig::default());
}

#[test]
fn test_frames_keep_a_budget_and_retry_per_frame_with_their_strongest_keypoints() {
    let map = MapConfig::default().surf;
    let cfg = LocalizerConfig::default();
    let test = cfg.test_surf(&map);
    assert_eq!(test.threshold, 0.4 * map.threshold);
    assert_eq!(test.keypoint_cap(640, 480), Some(1109));
    // By default the retry describes every keypoint above twice the map's threshold, per
    // frame only.
    let retry = cfg.retry_surf(&map).expect("a retry by default");
    assert_eq!(retry.threshold, 2.0 * map.threshold);
    assert_eq!(retry.keypoint_cap(640, 480), None);
    assert!(!cfg.retry_live(&map));
    // A retry threshold below a fixed test threshold retries live too (a lost frame is
    // described once, at it); 0 turns the retry off.
    let fixed = LocalizerConfig {
        surf: Some(map.clone().with_threshold(50.0)),
        retry_threshold: Some(25.0),
        ..LocalizerConfig::default()
    };
    assert_eq!(fixed.retry_surf(&map).map(|s| s.threshold), Some(25.0));
    assert!(fixed.retry_live(&map));
    let off = LocalizerConfig {
        retry_threshold: Some(0.0),
        ..LocalizerConfig::default()
    };
    assert_eq!(off.retry_surf(&map), None);
    // A retry identical to the test frames' own description is none.
    let same = LocalizerConfig {
        surf: Some(map.clone().with_threshold(50.0)),
        retry_threshold: Some(50.0),
        ..LocalizerConfig::default()
    };
    assert_eq!(same.retry_surf(&map), None);
}
