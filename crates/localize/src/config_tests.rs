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
