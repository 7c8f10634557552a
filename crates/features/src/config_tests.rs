//! Every configuration's sources of defaults agree: [`Default`] and deserialising an empty
//! table (`#[serde(default)]`).

use serde::Deserialize;
use serde::de::value::{Error, MapDeserializer};

use crate::repeatability::{CorrespondenceRule, EvaluationConfig};
use crate::texture::TextureConfig;
use crate::{MatcherConfig, SurfConfig};

/// An empty map deserialises to `T::default()`.
fn empty_is_default<T: for<'de> Deserialize<'de> + Default + PartialEq + std::fmt::Debug>() {
    let empty: MapDeserializer<'_, std::iter::Empty<(&str, &str)>, Error> =
        MapDeserializer::new(std::iter::empty());
    let parsed = T::deserialize(empty).unwrap();
    assert_eq!(parsed, T::default(), "{}", std::any::type_name::<T>());
}

#[test]
fn configs_default_and_empty_agree() {
    empty_is_default::<SurfConfig>();
    empty_is_default::<MatcherConfig>();
    empty_is_default::<TextureConfig>();
    empty_is_default::<CorrespondenceRule>();
    empty_is_default::<EvaluationConfig>();
}
