//! Every configuration's three sources of defaults agree: [`Default`], `new()` where it
//! exists, and deserialising an empty table (`#[serde(default)]`).

use serde::de::DeserializeOwned;

use crate::{
    EssentialRansacConfig, GeodesicMedianConfig, RansacConfig, RefineConfig, RegistrationConfig,
    TriangulationConfig, ValidityConfig, synthetic::PnpSceneConfig,
};

/// `{}` deserialises to `T::default()`.
fn empty_is_default<T: DeserializeOwned + Default + PartialEq + std::fmt::Debug>() {
    let parsed: T = serde_json::from_str("{}").unwrap();
    assert_eq!(parsed, T::default(), "{}", std::any::type_name::<T>());
}

#[test]
fn registration_config_default_new_and_empty_agree() {
    assert_eq!(RegistrationConfig::default(), RegistrationConfig::new());
    assert_eq!(RegistrationConfig::default().ransac_below_inlier_ratio, 0.5);
    empty_is_default::<RegistrationConfig>();
    // A partial table keeps the other defaults.
    let partial: RegistrationConfig = serde_json::from_str(r#"{"always_ransac": true}"#).unwrap();
    assert_eq!(partial.ransac_below_inlier_ratio, 0.5);
}

#[test]
fn other_configs_default_and_empty_agree() {
    empty_is_default::<RansacConfig>();
    empty_is_default::<GeodesicMedianConfig>();
    empty_is_default::<EssentialRansacConfig>();
    empty_is_default::<PnpSceneConfig>();
    empty_is_default::<RefineConfig>();
    empty_is_default::<ValidityConfig>();
    empty_is_default::<TriangulationConfig>();
}
