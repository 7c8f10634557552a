//! Every configuration's sources of defaults agree: [`Default`] and deserialising an empty
//! TOML table (`#[serde(default)]`), so a config file that omits a field gets the documented
//! default.

use serde::de::DeserializeOwned;

use crate::regress::{RegressConfig, RegressSchedule};
use crate::train::{Schedule, TrainConfig, ValidationConfig};
use crate::{AugmentConfig, TemporalConfig, TrackConfig};

/// An empty TOML document deserialises to `T::default()`.
fn empty_is_default<T: DeserializeOwned + Default + PartialEq + std::fmt::Debug>() {
    let parsed: T = toml::from_str("").unwrap();
    assert_eq!(parsed, T::default(), "{}", std::any::type_name::<T>());
}

#[test]
fn configs_default_and_empty_agree() {
    empty_is_default::<TrackConfig>();
    empty_is_default::<TemporalConfig>();
    empty_is_default::<AugmentConfig>();
    empty_is_default::<RegressSchedule>();
    empty_is_default::<RegressConfig>();
    empty_is_default::<Schedule>();
    empty_is_default::<ValidationConfig>();
    empty_is_default::<TrainConfig>();
}
