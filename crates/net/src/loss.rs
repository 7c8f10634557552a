//! The contrastive loss of the paper (Hadsell, Chopra & LeCun 2006), Eq. (1):
//!
//! `L(x, d) = (1 − x) · ½ d² + x · ½ max(0, m − d)²`
//!
//! with `d` the Euclidean distance between the two descriptors of a pair, `x` the pair label
//! — **0 for a similar pair (same zone), 1 for a dissimilar pair (different zones)**, as in
//! the paper — and `m` the margin. The batch loss is the mean over pairs. With unit-length
//! descriptors `d ∈ [0, 2]`; the default margin is 1.
//!
//! At inference the paper assigns a test image to the zone "with the smallest contrastive
//! loss" against the database: for the similar hypothesis (`x = 0`) that loss is `½ d²`,
//! increasing in `d`, so it is the zone of the nearest descriptors ([`crate::database`]).

use burn::tensor::Tensor;

/// Default margin `m` for unit-length descriptors.
pub const DEFAULT_MARGIN: f32 = 1.0;

/// The loss of one pair at distance `d` with label `dissimilar` (0 or 1; values between
/// interpolate) and margin `m`: the reference formula, also used by tests.
pub fn contrastive_loss_pair(d: f32, dissimilar: f32, margin: f32) -> f32 {
    let hinge = (margin - d).max(0.0);
    (1.0 - dissimilar) * 0.5 * d * d + dissimilar * 0.5 * hinge * hinge
}

/// Mean contrastive loss of a batch of pairs.
///
/// `d` is computed as `sqrt(Σ (a − b)² + 1e-12)` so that the gradient stays finite for
/// identical descriptors.
///
/// # Shapes
/// - `a`, `b`: `[pairs, dim]` descriptors of the two twins
/// - `dissimilar`: `[pairs]`, 0 = same zone, 1 = different zones
/// - output: `[1]`
pub fn contrastive_loss(
    a: Tensor<2>,
    b: Tensor<2>,
    dissimilar: Tensor<1>,
    margin: f32,
) -> Tensor<1> {
    let d2 = (a - b).square().sum_dim(1).squeeze_dim::<1>(1);
    let d = d2.clone().add_scalar(1e-12).sqrt();
    let hinge = d.neg().add_scalar(margin).clamp_min(0.0);
    let similar = dissimilar.clone().neg().add_scalar(1.0);
    (similar * d2 + dissimilar * hinge.square())
        .mul_scalar(0.5)
        .mean()
}

/// Euclidean distances of pairs of rows.
///
/// # Shapes
/// `[pairs, dim]`, `[pairs, dim]` → `[pairs]`
pub fn pair_distances(a: Tensor<2>, b: Tensor<2>) -> Tensor<1> {
    (a - b)
        .square()
        .sum_dim(1)
        .squeeze_dim::<1>(1)
        .add_scalar(1e-12)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_formula_on_hand_computed_cases() {
        // Similar pair: ½ d².
        assert_eq!(contrastive_loss_pair(0.0, 0.0, 1.0), 0.0);
        assert!((contrastive_loss_pair(0.6, 0.0, 1.0) - 0.18).abs() < 1e-7);
        // Dissimilar pair inside the margin: ½ (m − d)² = ½ · 0.4² = 0.08.
        assert!((contrastive_loss_pair(0.6, 1.0, 1.0) - 0.08).abs() < 1e-7);
        // Dissimilar pair beyond the margin: 0.
        assert_eq!(contrastive_loss_pair(1.5, 1.0, 1.0), 0.0);
        // Dissimilar identical descriptors: ½ m² = 2 for m = 2.
        assert!((contrastive_loss_pair(0.0, 1.0, 2.0) - 2.0).abs() < 1e-7);
    }

    #[test]
    fn tensor_loss_matches_hand_computed_batch() {
        let dev = crate::device::cpu();
        // Pair 1: (0,0) vs (3,4): d = 5, similar → 12.5.
        // Pair 2: (1,0) vs (1,0.5): d = 0.5, dissimilar, m = 1 → ½ · 0.25 = 0.125.
        // Pair 3: (0,0) vs (0,2): d = 2, dissimilar → 0.
        let a = Tensor::<2>::from_floats([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]], &dev);
        let b = Tensor::<2>::from_floats([[3.0, 4.0], [1.0, 0.5], [0.0, 2.0]], &dev);
        let y = Tensor::<1>::from_floats([0.0, 1.0, 1.0], &dev);
        let l: f32 = contrastive_loss(a.clone(), b.clone(), y, 1.0).into_scalar();
        let expected = (12.5 + 0.125 + 0.0) / 3.0;
        assert!((l - expected).abs() < 1e-5, "{l} vs {expected}");
        let d = pair_distances(a, b).into_data();
        let d = d.as_slice::<f32>().unwrap();
        assert!(
            (d[0] - 5.0).abs() < 1e-5 && (d[1] - 0.5).abs() < 1e-5 && (d[2] - 2.0).abs() < 1e-5
        );
    }

    #[test]
    fn gradient_pulls_similar_and_pushes_dissimilar() {
        let dev = crate::device::cpu().autodiff();
        let a = Tensor::<2>::from_floats([[0.0, 0.0], [0.0, 0.0]], &dev).require_grad();
        let b = Tensor::<2>::from_floats([[0.3, 0.0], [0.3, 0.0]], &dev);
        let y = Tensor::<1>::from_floats([0.0, 1.0], &dev);
        let grads = contrastive_loss(a.clone(), b, y, 1.0).backward();
        let g = a.grad(&grads).unwrap().into_data();
        let g = g.as_slice::<f32>().unwrap();
        // Similar: dL/da_x = −(b − a)/2 = −0.15 → moving a along −grad goes towards b.
        assert!((g[0] + 0.15).abs() < 1e-5, "{g:?}");
        // Dissimilar: ½ (m − d)², dL/da_x = (m − d) · (b_x − a_x)/d / 2 = 0.7/2 = 0.35 → away.
        assert!((g[2] - 0.35).abs() < 1e-5, "{g:?}");
    }
}
