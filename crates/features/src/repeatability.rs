//! Repeatability and matching precision under known homographies (Mikolajczyk et al. 2005,
//! point version): the evaluation behind `REPEATABILITY.md` and the invariance tests.
//!
//! - A keypoint is *in the overlap* when its support region — the square of half-side
//!   `support_radius_per_scale · σ` around it (default 3.75σ = half the detecting filter's
//!   side) — lies inside its own image and, mapped through `H` (or `H⁻¹`), inside the other
//!   one: as in Mikolajczyk et al., only regions fully visible in both images count. With
//!   `support_radius_per_scale = 0` only the centre is checked.
//! - Two keypoints *correspond* when `max(‖H·p₁ − p₂‖, ‖p₁ − H⁻¹·p₂‖) ≤ tolerance` — the
//!   distance is checked in both images' pixels, so neither zooming direction is favoured.
//!   Correspondences are one-to-one (greedy by distance).
//! - Repeatability = correspondences / min(overlap count 1, overlap count 2).
//! - Matching precision = fraction of descriptor matches (after the ratio test etc.) whose
//!   keypoints correspond by the same distance rule.

use serde::{Deserialize, Serialize};

use crate::texture::{TextureConfig, textured_plane};
use crate::warp::{Homography, Plane, adjust_brightness, gaussian_blur, warp};
use crate::{Feature, FeatureError, Keypoint, Matcher, MatcherConfig, SurfConfig};

/// Overlap counts and correspondences of two keypoint sets.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Repeatability {
    /// Keypoints of image 1 whose mapping lies inside image 2.
    pub overlap_1: usize,
    /// Keypoints of image 2 whose mapping lies inside image 1.
    pub overlap_2: usize,
    /// One-to-one correspondences within the tolerance.
    pub correspondences: usize,
    /// `correspondences / min(overlap_1, overlap_2)`; 0 when either is 0.
    pub repeatability: f64,
}

/// Outcome of matching descriptors between two images.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Precision {
    /// Matches returned by the matcher.
    pub matches: usize,
    /// Matches whose keypoints correspond within the tolerance.
    pub correct: usize,
    /// `correct / matches` (0 when there are no matches).
    pub precision: f64,
}

fn inside(p: (f64, f64), size: (usize, usize)) -> bool {
    p.0 >= 0.0 && p.1 >= 0.0 && p.0 <= (size.0 as f64 - 1.0) && p.1 <= (size.1 as f64 - 1.0)
}

/// How keypoints are compared: distance tolerance and support region.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CorrespondenceRule {
    /// Largest distance between corresponding keypoints, pixels (checked in both images).
    /// Default 2.5.
    pub tolerance_px: f64,
    /// Half-side of the support square in units of the keypoint scale σ; the square must be
    /// visible in both images for the keypoint to count. Default 3.75 (half the filter side).
    pub support_radius_per_scale: f64,
}

impl Default for CorrespondenceRule {
    fn default() -> Self {
        Self {
            tolerance_px: 2.5,
            support_radius_per_scale: 3.75,
        }
    }
}

/// Whether the support square of `k` is inside `own` and, mapped by `h`, inside `other`.
fn visible_in_both(
    k: &Keypoint,
    h: &Homography,
    own: (usize, usize),
    other: (usize, usize),
    r_per_scale: f64,
) -> bool {
    let (x, y, r) = (
        f64::from(k.x),
        f64::from(k.y),
        r_per_scale * f64::from(k.scale),
    );
    [
        (x, y),
        (x - r, y - r),
        (x + r, y - r),
        (x - r, y + r),
        (x + r, y + r),
    ]
    .iter()
    .all(|&p| inside(p, own) && h.apply(p.0, p.1).is_some_and(|q| inside(q, other)))
}

/// Symmetric transfer distance of a keypoint pair (pixels), `None` when a mapping fails.
fn pair_distance(h: &Homography, hinv: &Homography, a: &Keypoint, b: &Keypoint) -> Option<f64> {
    let (ax, ay) = h.apply(f64::from(a.x), f64::from(a.y))?;
    let (bx, by) = hinv.apply(f64::from(b.x), f64::from(b.y))?;
    let d2 = ((ax - f64::from(b.x)).powi(2) + (ay - f64::from(b.y)).powi(2)).sqrt();
    let d1 = ((bx - f64::from(a.x)).powi(2) + (by - f64::from(a.y)).powi(2)).sqrt();
    Some(d1.max(d2))
}

/// Repeatability of keypoints `kp1` (image of `size1` = (width, height)) and `kp2` (`size2`)
/// related by `h_2_from_1`, under `rule`.
///
/// # Errors
/// [`FeatureError::InvalidConfig`] when the homography is singular.
pub fn repeatability(
    kp1: &[Keypoint],
    kp2: &[Keypoint],
    h_2_from_1: &Homography,
    size1: (usize, usize),
    size2: (usize, usize),
    rule: &CorrespondenceRule,
) -> Result<Repeatability, FeatureError> {
    let tolerance_px = rule.tolerance_px;
    let r = rule.support_radius_per_scale;
    let hinv = h_2_from_1.inverse().ok_or_else(singular)?;
    let in1: Vec<&Keypoint> = kp1
        .iter()
        .filter(|k| visible_in_both(k, h_2_from_1, size1, size2, r))
        .collect();
    let in2: Vec<&Keypoint> = kp2
        .iter()
        .filter(|k| visible_in_both(k, &hinv, size2, size1, r))
        .collect();
    // Bucket image-2 keypoints on a grid of tolerance-sized cells for the candidate search.
    let cell = tolerance_px.max(1.0) * 2.0;
    let mut grid: std::collections::HashMap<(i64, i64), Vec<usize>> =
        std::collections::HashMap::new();
    for (j, k) in in2.iter().enumerate() {
        let key = (
            (f64::from(k.x) / cell).floor() as i64,
            (f64::from(k.y) / cell).floor() as i64,
        );
        grid.entry(key).or_default().push(j);
    }
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, a) in in1.iter().enumerate() {
        let Some((mx, my)) = h_2_from_1.apply(f64::from(a.x), f64::from(a.y)) else {
            continue;
        };
        let (cx, cy) = ((mx / cell).floor() as i64, (my / cell).floor() as i64);
        for gy in cy - 1..=cy + 1 {
            for gx in cx - 1..=cx + 1 {
                for &j in grid.get(&(gx, gy)).map(Vec::as_slice).unwrap_or(&[]) {
                    if let Some(d) = pair_distance(h_2_from_1, &hinv, a, in2[j])
                        && d <= tolerance_px
                    {
                        pairs.push((d, i, j));
                    }
                }
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut used1, mut used2) = (vec![false; in1.len()], vec![false; in2.len()]);
    let mut correspondences = 0;
    for (_, i, j) in pairs {
        if !used1[i] && !used2[j] {
            used1[i] = true;
            used2[j] = true;
            correspondences += 1;
        }
    }
    let denom = in1.len().min(in2.len());
    Ok(Repeatability {
        overlap_1: in1.len(),
        overlap_2: in2.len(),
        correspondences,
        repeatability: if denom == 0 {
            0.0
        } else {
            correspondences as f64 / denom as f64
        },
    })
}

fn singular() -> FeatureError {
    FeatureError::InvalidConfig {
        field: "homography",
        reason: "is singular".to_string(),
    }
}

/// Matches `f1` against `f2` and counts the matches whose keypoints correspond.
///
/// # Errors
/// As [`Matcher::match_descriptors`]; [`FeatureError::InvalidConfig`] for a singular homography.
pub fn matching_precision(
    f1: &[Feature],
    f2: &[Feature],
    h_2_from_1: &Homography,
    matcher: &Matcher,
    tolerance_px: f64,
) -> Result<Precision, FeatureError> {
    let hinv = h_2_from_1.inverse().ok_or_else(singular)?;
    let matches = matcher.match_descriptors(f1, f2)?;
    let correct = matches
        .iter()
        .filter(|m| {
            pair_distance(
                h_2_from_1,
                &hinv,
                &f1[m.query].keypoint,
                &f2[m.train].keypoint,
            )
            .is_some_and(|d| d <= tolerance_px)
        })
        .count();
    Ok(Precision {
        matches: matches.len(),
        correct,
        precision: if matches.is_empty() {
            0.0
        } else {
            correct as f64 / matches.len() as f64
        },
    })
}

/// A known image change of the evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Transform {
    /// Rotation about the image centre, degrees (image axes, clockwise on screen).
    Rotation(f64),
    /// Zoom about the image centre (2 = twice as large).
    Scale(f64),
    /// Gaussian blur, σ in pixels.
    Blur(f32),
    /// `gain · I + offset` on 0..255, clamped.
    Brightness {
        /// Multiplicative gain.
        gain: f32,
        /// Additive offset (0..255 scale).
        offset: f32,
    },
}

impl std::fmt::Display for Transform {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Transform::Rotation(d) => write!(f, "rotation {d}°"),
            Transform::Scale(s) => write!(f, "scale ×{s}"),
            Transform::Blur(s) => write!(f, "blur σ={s} px"),
            Transform::Brightness { gain, offset } => write!(f, "brightness {gain}·I{offset:+}"),
        }
    }
}

/// The evaluation's image pair sequence: rotations 0–180° step 30, scales 0.5–2, blur,
/// brightness.
pub fn standard_transforms() -> Vec<Transform> {
    let mut t: Vec<Transform> = (0..=6)
        .map(|k| Transform::Rotation(30.0 * f64::from(k)))
        .collect();
    t.extend([0.5, 0.7, 1.4, 2.0].map(Transform::Scale));
    t.extend([1.0, 2.0].map(Transform::Blur));
    t.extend([
        Transform::Brightness {
            gain: 0.6,
            offset: 0.0,
        },
        Transform::Brightness {
            gain: 1.3,
            offset: 20.0,
        },
    ]);
    t
}

/// Parameters of [`evaluate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvaluationConfig {
    /// Image size (width, height) in pixels. Default 640 × 480.
    pub size: (usize, usize),
    /// Texture seed. Default 1.
    pub seed: u64,
    /// Correspondence tolerance and support region. Default 2.5 px, 3.75σ.
    pub rule: CorrespondenceRule,
    /// Detector settings. Default: [`SurfConfig::default`].
    pub surf: SurfConfig,
    /// Matcher settings for the precision figure. Default: ratio 0.8, no mutual check,
    /// Laplacian gating.
    pub matcher: MatcherConfig,
}

impl Default for EvaluationConfig {
    fn default() -> Self {
        Self {
            size: (640, 480),
            seed: 1,
            rule: CorrespondenceRule::default(),
            surf: SurfConfig::default(),
            matcher: MatcherConfig::default().with_mutual(false),
        }
    }
}

/// One row of the evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EvaluationRow {
    /// The change applied to the reference image.
    pub transform: Transform,
    /// Keypoints in the reference image.
    pub keypoints_1: usize,
    /// Keypoints in the transformed image.
    pub keypoints_2: usize,
    /// Repeatability figures.
    pub repeatability: Repeatability,
    /// Matching precision figures.
    pub precision: Precision,
}

/// The reference image and a transformed one, rendered from one large texture so that both
/// are covered by texture everywhere (no artificial borders), plus `H` (reference →
/// transformed).
pub fn image_pair(cfg: &EvaluationConfig, transform: Transform) -> (Plane, Plane, Homography) {
    let (w, h) = cfg.size;
    let (bw, bh) = (2 * w + 160, 2 * h + 160);
    let big = textured_plane(&TextureConfig {
        width: bw,
        height: bh,
        seed: cfg.seed,
        ..TextureConfig::default()
    });
    let origin = (((bw - w) / 2) as f64, ((bh - h) / 2) as f64);
    let centre = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let tex_centre = (origin.0 + centre.0, origin.1 + centre.1);
    let crop = Homography::similarity(0.0, 1.0, tex_centre, centre);
    let reference = warp(&big, &crop, w, h, 0.0).unwrap_or_else(|| Plane::filled(w, h, 0.0));
    let (angle, scale) = match transform {
        Transform::Rotation(d) => (d.to_radians(), 1.0),
        Transform::Scale(s) => (0.0, s),
        _ => (0.0, 1.0),
    };
    let h_2_from_1 = Homography::similarity(angle, scale, centre, centre);
    let other = match transform {
        Transform::Rotation(_) | Transform::Scale(_) => {
            // Anti-aliasing before shrinking: bring the source to σ ≈ 0.5 px after scaling.
            let src = if scale < 1.0 {
                gaussian_blur(&big, (0.5 * (1.0 / (scale * scale) - 1.0).sqrt()) as f32)
            } else {
                big
            };
            let to_dst = Homography::similarity(angle, scale, tex_centre, centre);
            warp(&src, &to_dst, w, h, 0.0).unwrap_or_else(|| Plane::filled(w, h, 0.0))
        }
        Transform::Blur(s) => gaussian_blur(&reference, s),
        Transform::Brightness { gain, offset } => adjust_brightness(&reference, gain, offset),
    };
    (reference, other, h_2_from_1)
}

/// Runs detector, descriptor and matcher on every transform of [`standard_transforms`]
/// (images quantised to 8 bits, as a camera would deliver them).
///
/// # Errors
/// Configuration errors of the detector or matcher.
pub fn evaluate(
    cfg: &EvaluationConfig,
    transforms: &[Transform],
) -> Result<Vec<EvaluationRow>, FeatureError> {
    let surf = cfg.surf.clone().init()?;
    let matcher = Matcher::new(cfg.matcher.clone());
    let mut rows = Vec::new();
    for &t in transforms {
        let (a, b, h) = image_pair(cfg, t);
        let fa = surf.detect_and_describe(&a.to_gray())?;
        let fb = surf.detect_and_describe(&b.to_gray())?;
        let ka: Vec<Keypoint> = fa.iter().map(|f| f.keypoint).collect();
        let kb: Vec<Keypoint> = fb.iter().map(|f| f.keypoint).collect();
        let rep = repeatability(&ka, &kb, &h, cfg.size, cfg.size, &cfg.rule)?;
        let prec = matching_precision(&fa, &fb, &h, &matcher, cfg.rule.tolerance_px)?;
        rows.push(EvaluationRow {
            transform: t,
            keypoints_1: ka.len(),
            keypoints_2: kb.len(),
            repeatability: rep,
            precision: prec,
        });
    }
    Ok(rows)
}

/// A markdown table of the rows, with a mean line.
pub fn markdown_table(rows: &[EvaluationRow]) -> String {
    let mut s = String::from(
        "| transform | keypoints ref / transformed | in overlap | correspondences | repeatability | matches | correct | precision |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} / {} | {} / {} | {} | {:.3} | {} | {} | {:.3} |\n",
            r.transform,
            r.keypoints_1,
            r.keypoints_2,
            r.repeatability.overlap_1,
            r.repeatability.overlap_2,
            r.repeatability.correspondences,
            r.repeatability.repeatability,
            r.precision.matches,
            r.precision.correct,
            r.precision.precision,
        ));
    }
    if !rows.is_empty() {
        let n = rows.len() as f64;
        let mean_rep = rows
            .iter()
            .map(|r| r.repeatability.repeatability)
            .sum::<f64>()
            / n;
        let mean_prec = rows.iter().map(|r| r.precision.precision).sum::<f64>() / n;
        s.push_str(&format!(
            "| **mean** | | | | **{mean_rep:.3}** | | | **{mean_prec:.3}** |\n"
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kp(x: f32, y: f32) -> Keypoint {
        Keypoint {
            x,
            y,
            scale: 2.0,
            orientation: 0.0,
            response: 1.0,
            laplacian: 1,
            octave: 0,
        }
    }

    #[test]
    fn repeatability_counts_one_to_one_correspondences_in_the_overlap() {
        // Shift by +10 px in x: image-1 points beyond x = 89 leave image 2 (100 px wide).
        let h = Homography([[1.0, 0.0, 10.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        let k1 = [kp(5.0, 5.0), kp(50.0, 50.0), kp(95.0, 50.0)];
        // Image 2: matches of the first two (one 1 px off), a duplicate, one stray point.
        let k2 = [
            kp(15.0, 5.0),
            kp(61.0, 50.0),
            kp(61.5, 50.0),
            kp(30.0, 80.0),
        ];
        let centre_only = CorrespondenceRule {
            tolerance_px: 2.5,
            support_radius_per_scale: 0.0,
        };
        let r = repeatability(&k1, &k2, &h, (100, 100), (100, 100), &centre_only).unwrap();
        assert_eq!((r.overlap_1, r.overlap_2, r.correspondences), (2, 4, 2));
        assert!((r.repeatability - 1.0).abs() < 1e-12);
        let tight = CorrespondenceRule {
            tolerance_px: 0.5,
            ..centre_only
        };
        let r = repeatability(&k1, &k2, &h, (100, 100), (100, 100), &tight).unwrap();
        assert_eq!(r.correspondences, 1);
        // With a support of 3.75σ = 7.5 px, (5, 5) and (15, 5) are too close to the border,
        // and (95, 50) was already outside.
        let r = repeatability(
            &k1,
            &k2,
            &h,
            (100, 100),
            (100, 100),
            &CorrespondenceRule::default(),
        )
        .unwrap();
        assert_eq!((r.overlap_1, r.overlap_2, r.correspondences), (1, 3, 1));
    }
}
