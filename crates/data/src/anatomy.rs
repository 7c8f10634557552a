//! Anatomical sections of the large intestine, from the anus to the caecum.
//!
//! These are the labels written to `sections.csv` (one per frame) and used for the
//! anatomical ("expert") zones. The order is the order met by a scope inserted from the anus.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// One anatomical section of the large intestine, in insertion order (anus → caecum).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Section {
    /// Anal canal, the first few centimetres from the anus.
    AnalCanal,
    /// Rectum: wide, smooth (no haustra), with transverse (Houston) folds.
    Rectum,
    /// Recto-sigmoid junction.
    Rectosigmoid,
    /// Sigmoid colon: tortuous, narrow, haustrated.
    Sigmoid,
    /// Descending colon: straight, left side.
    Descending,
    /// Splenic (left colic) flexure.
    SplenicFlexure,
    /// Transverse colon: long, sagging, roughly triangular cross-section.
    Transverse,
    /// Hepatic (right colic) flexure.
    HepaticFlexure,
    /// Ascending colon: wide, right side.
    Ascending,
    /// Caecum: the widest part, a blind pouch with the ileocaecal valve and appendix orifice.
    Caecum,
}

impl Section {
    /// All sections in insertion order.
    pub const ALL: [Section; 10] = [
        Section::AnalCanal,
        Section::Rectum,
        Section::Rectosigmoid,
        Section::Sigmoid,
        Section::Descending,
        Section::SplenicFlexure,
        Section::Transverse,
        Section::HepaticFlexure,
        Section::Ascending,
        Section::Caecum,
    ];

    /// The label written to files (`snake_case`).
    pub fn as_str(&self) -> &'static str {
        match self {
            Section::AnalCanal => "anal_canal",
            Section::Rectum => "rectum",
            Section::Rectosigmoid => "rectosigmoid",
            Section::Sigmoid => "sigmoid",
            Section::Descending => "descending",
            Section::SplenicFlexure => "splenic_flexure",
            Section::Transverse => "transverse",
            Section::HepaticFlexure => "hepatic_flexure",
            Section::Ascending => "ascending",
            Section::Caecum => "caecum",
        }
    }

    /// Position in insertion order, 0 for the anal canal.
    pub fn index(&self) -> usize {
        Section::ALL.iter().position(|s| s == self).unwrap_or(0)
    }
}

impl fmt::Display for Section {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Error for a section label that is not one of [`Section::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown section label {0:?}; expected one of: {list}", list = Section::ALL.map(|s| s.as_str()).join(", "))]
pub struct UnknownSection(pub String);

impl FromStr for Section {
    type Err = UnknownSection;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        Section::ALL
            .into_iter()
            .find(|sec| sec.as_str().eq_ignore_ascii_case(t))
            .ok_or_else(|| UnknownSection(t.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_round_trip_and_unknown_is_named() {
        for s in Section::ALL {
            assert_eq!(s.as_str().parse::<Section>().unwrap(), s);
        }
        let err = "colon".parse::<Section>().unwrap_err().to_string();
        assert!(err.contains("\"colon\"") && err.contains("caecum"), "{err}");
    }
}
