//! Every configuration's sources of defaults agree: [`Default`] and deserialising an empty
//! TOML table (`#[serde(default)]`).

use serde::de::DeserializeOwned;

use crate::appearance::AppearanceConfig;
use crate::colon::procedural::ProceduralColonConfig;
use crate::render::RenderConfig;
use crate::trajectory::TrajectoryConfig;

/// An empty TOML document deserialises to `T::default()`.
fn empty_is_default<T: DeserializeOwned + Default + PartialEq + std::fmt::Debug>() {
    let parsed: T = toml::from_str("").unwrap();
    assert_eq!(parsed, T::default(), "{}", std::any::type_name::<T>());
}

#[test]
fn configs_default_and_empty_agree() {
    empty_is_default::<AppearanceConfig>();
    empty_is_default::<TrajectoryConfig>();
    empty_is_default::<ProceduralColonConfig>();
    empty_is_default::<RenderConfig>();
}
