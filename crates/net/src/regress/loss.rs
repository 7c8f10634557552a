//! PoseNet's loss (Kendall, Grimes & Cipolla 2015, Eq. 2), per sample
//!
//! `L = ‖x − x̂‖₂ + β ‖q − q̂ / ‖q̂‖‖₂`
//!
//! with `x` the (normalised) position, `q` the target unit quaternion (`x y z w`, sign chosen
//! by [`crate::regress::PoseNormalizer`]: `w ≥ 0` relative to the reference rotation), `x̂`,
//! `q̂` the network's outputs. The batch loss is the mean over samples. The norms are not
//! squared, as in the paper; `1e-12` under each square root keeps the gradient finite at a
//! perfect fit.
//!
//! The loss is not invariant to the sign of `q̂`: the prediction learns the sign of the
//! targets, which is why the targets must be canonicalised to one hemisphere; at inference
//! the sign of `q̂` does not matter (both signs are the same rotation).

use burn::tensor::Tensor;

/// The loss of one sample: the reference formula, also used by tests.
///
/// `q_hat` is normalised inside; a zero `q_hat` counts as `‖q‖` (the norm of the target).
pub fn posenet_loss_sample(
    x: [f64; 3],
    x_hat: [f64; 3],
    q: [f64; 4],
    q_hat: [f64; 4],
    beta: f64,
) -> f64 {
    let pos = (0..3)
        .map(|i| (x[i] - x_hat[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let n = q_hat.iter().map(|v| v * v).sum::<f64>().sqrt();
    let rot = (0..4)
        .map(|i| {
            let qh = if n > 0.0 { q_hat[i] / n } else { 0.0 };
            (q[i] - qh).powi(2)
        })
        .sum::<f64>()
        .sqrt();
    pos + beta * rot
}

/// Mean PoseNet loss of a batch.
///
/// # Shapes
/// - `x_hat`, `x`: `[b, 3]` predicted and target (normalised) positions
/// - `q_hat`, `q`: `[b, 4]` predicted (any norm) and target (unit) quaternions
/// - output: `[1]`
pub fn posenet_loss(
    x_hat: Tensor<2>,
    q_hat: Tensor<2>,
    x: Tensor<2>,
    q: Tensor<2>,
    beta: f32,
) -> Tensor<1> {
    let pos = (x_hat - x).square().sum_dim(1).add_scalar(1e-12).sqrt();
    let n = q_hat.clone().square().sum_dim(1).add_scalar(1e-12).sqrt();
    let rot = (q - q_hat / n).square().sum_dim(1).add_scalar(1e-12).sqrt();
    (pos + rot.mul_scalar(beta)).mean()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_formula_on_hand_computed_cases() {
        let id = [0.0, 0.0, 0.0, 1.0];
        // Position (3, 4, 0) off, rotation exact: 5.
        let l = posenet_loss_sample([0.0; 3], [3.0, 4.0, 0.0], id, [0.0, 0.0, 0.0, 2.5], 7.0);
        assert!((l - 5.0).abs() < 1e-12, "{l}");
        // Position exact, q̂ = (0, 0, 1, 1) → normalised (0, 0, 1/√2, 1/√2);
        // ‖(0, 0, −1/√2, 1 − 1/√2)‖ = √(2 − √2) ≈ 0.765367; × β = 2.
        let l = posenet_loss_sample([1.0; 3], [1.0; 3], id, [0.0, 0.0, 1.0, 1.0], 2.0);
        let expected = 2.0 * (2.0 - 2f64.sqrt()).sqrt();
        assert!((l - expected).abs() < 1e-12, "{l} vs {expected}");
        // The same rotation with the other sign costs 2β: the loss is sign-sensitive, hence
        // canonical targets.
        let l = posenet_loss_sample([0.0; 3], [0.0; 3], id, [0.0, 0.0, 0.0, -1.0], 3.0);
        assert!((l - 6.0).abs() < 1e-12, "{l}");
    }

    #[test]
    fn tensor_loss_matches_reference_formula() {
        let dev = crate::device::cpu();
        let xh = [[3.0f32, 4.0, 0.0], [1.0, 1.0, 1.0]];
        let x = [[0.0f32, 0.0, 0.0], [1.0, 1.0, 1.0]];
        let qh = [[0.0f32, 0.0, 0.0, 2.5], [0.0, 0.0, 1.0, 1.0]];
        let q = [[0.0f32, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]];
        let beta = 2.0;
        let l: f32 = posenet_loss(
            Tensor::<2>::from_floats(xh, &dev),
            Tensor::<2>::from_floats(qh, &dev),
            Tensor::<2>::from_floats(x, &dev),
            Tensor::<2>::from_floats(q, &dev),
            beta,
        )
        .into_scalar();
        let f = |a: [f32; 3]| a.map(f64::from);
        let g = |a: [f32; 4]| a.map(f64::from);
        let expected = (0..2)
            .map(|i| posenet_loss_sample(f(x[i]), f(xh[i]), g(q[i]), g(qh[i]), beta as f64))
            .sum::<f64>()
            / 2.0;
        assert!((l as f64 - expected).abs() < 1e-5, "{l} vs {expected}");
    }
}
