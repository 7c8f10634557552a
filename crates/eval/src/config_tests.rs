//! Every configuration's sources of defaults agree: [`Default`] and deserialising an empty
//! JSON object (`#[serde(default)]`).

use serde::de::DeserializeOwned;

use crate::{AssociationConfig, EvalConfig, RpeConfig};

/// `{}` deserialises to `T::default()`.
fn empty_is_default<T: DeserializeOwned + Default + PartialEq + std::fmt::Debug>() {
    let parsed: T = serde_json::from_str("{}").unwrap();
    assert_eq!(parsed, T::default(), "{}", std::any::type_name::<T>());
}

#[test]
fn configs_default_and_empty_agree() {
    empty_is_default::<AssociationConfig>();
    empty_is_default::<RpeConfig>();
    empty_is_default::<EvalConfig>();
}
