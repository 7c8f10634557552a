//! The configuration's sources of defaults agree: [`Default`] and deserialising an empty
//! TOML table (`#[serde(default)]`).

use crate::VoConfig;

#[test]
fn config_default_and_empty_agree() {
    let parsed: VoConfig = toml::from_str("").unwrap();
    assert_eq!(parsed, VoConfig::default());
}
