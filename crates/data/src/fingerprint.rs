//! Fingerprints: short content hashes that tie what endoloc writes to what it was made from
//! (a model folder to its training poses, a map to its zone table), so that a folder mixed
//! with another dataset is refused with a message that says what differs.
//!
//! A fingerprint is the first 16 hexadecimal digits (64 bits) of a SHA-256: enough to tell two
//! inputs apart by accident, short enough to read in an error message.

use std::fmt;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::StampedPose;

/// A content fingerprint (16 lowercase hexadecimal digits), as written in `model.toml` and
/// `map.toml`.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Fingerprint(String);

impl Fingerprint {
    /// Hex digits kept of the SHA-256.
    pub const DIGITS: usize = 16;

    /// The fingerprint of `bytes`.
    pub fn of_bytes(bytes: &[u8]) -> Self {
        Self::from_digest(Sha256::digest(bytes).as_slice())
    }

    fn from_digest(digest: &[u8]) -> Self {
        let mut text = String::with_capacity(Self::DIGITS);
        for b in &digest[..Self::DIGITS / 2] {
            text.push_str(&format!("{b:02x}"));
        }
        Fingerprint(text)
    }

    /// The hexadecimal digits.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Fingerprint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The fingerprint of a pose sequence as parsed (time stamps, positions in mm, unit
/// quaternions, bit for bit): the same `poses.txt` always gives the same fingerprint,
/// whatever its number formatting, and any changed, added or removed pose changes it.
pub fn poses_fingerprint(poses: &[StampedPose]) -> Fingerprint {
    let mut hash = Sha256::new();
    hash.update((poses.len() as u64).to_le_bytes());
    for p in poses {
        let t = p.pose.translation.vector;
        let q = p.pose.rotation.coords;
        for v in [p.timestamp_s, t.x, t.y, t.z, q.x, q.y, q.z, q.w] {
            hash.update(v.to_bits().to_le_bytes());
        }
    }
    Fingerprint::from_digest(hash.finalize().as_slice())
}

#[cfg(test)]
mod tests {
    use super::*;
    use endoloc_geometry::Pose;
    use nalgebra::{Translation3, UnitQuaternion};

    fn pose(t: f64, x: f64) -> StampedPose {
        StampedPose {
            timestamp_s: t,
            pose: Pose::from_parts(Translation3::new(x, 0.0, 1.0), UnitQuaternion::identity()),
        }
    }

    #[test]
    fn a_changed_pose_changes_the_fingerprint_and_equal_poses_keep_it() {
        let a = vec![pose(0.0, 1.0), pose(0.1, 2.0)];
        let same = vec![pose(0.0, 1.0), pose(0.1, 2.0)];
        let moved = vec![pose(0.0, 1.0), pose(0.1, 2.000001)];
        let shorter = vec![pose(0.0, 1.0)];
        assert_eq!(poses_fingerprint(&a), poses_fingerprint(&same));
        assert_ne!(poses_fingerprint(&a), poses_fingerprint(&moved));
        assert_ne!(poses_fingerprint(&a), poses_fingerprint(&shorter));
        assert_eq!(poses_fingerprint(&a).as_str().len(), Fingerprint::DIGITS);
    }

    #[test]
    fn bytes_fingerprint_is_the_sha256_prefix() {
        // SHA-256("abc") = ba7816bf8f01cfea…
        assert_eq!(Fingerprint::of_bytes(b"abc").as_str(), "ba7816bf8f01cfea");
    }
}
