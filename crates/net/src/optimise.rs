//! What every training in this crate shares at the optimiser: the cosine learning-rate
//! schedule and one Adam step that refuses a non-finite loss.

use crate::NetError;
use burn::module::Module;
use burn::optim::{GradientsParams, ModuleOptimizer};
use burn::tensor::Tensor;

/// Learning rate at `step` of `total`: a cosine from `start` (step 0) to `end` (the last step).
pub(crate) fn cosine_learning_rate(start: f64, end: f64, step: usize, total: usize) -> f64 {
    let t = if total <= 1 {
        0.0
    } else {
        step as f64 / (total - 1) as f64
    };
    end + 0.5 * (start - end) * (1.0 + (std::f64::consts::PI * t.clamp(0.0, 1.0)).cos())
}

/// One optimiser step on `loss` (a one-element tensor) at learning rate `lr`: the updated
/// network and the loss's value.
///
/// # Errors
/// [`NetError::Diverged`], naming the 1-based `epoch`, when the loss is not finite (no step
/// is taken).
pub(crate) fn descend<N: Module>(
    optim: &mut ModuleOptimizer,
    net: N,
    loss: Tensor<1>,
    lr: f64,
    epoch: usize,
) -> Result<(N, f32), NetError> {
    let value = loss
        .clone()
        .into_data()
        .try_into_vec::<f32>()
        .ok()
        .and_then(|v| v.first().copied())
        .unwrap_or(f32::NAN);
    if !value.is_finite() {
        return Err(NetError::Diverged { epoch, loss: value });
    }
    let grads = GradientsParams::from_grads(loss.backward(), &net);
    Ok((optim.step(lr, net, grads), value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cosine_runs_from_start_to_end() {
        assert_eq!(cosine_learning_rate(1e-3, 1e-4, 0, 100), 1e-3);
        assert!((cosine_learning_rate(1e-3, 1e-4, 99, 100) - 1e-4).abs() < 1e-15);
        assert!((cosine_learning_rate(1e-3, 1e-4, 33, 67) - 5.5e-4).abs() < 1e-12);
        assert_eq!(cosine_learning_rate(1e-3, 1e-4, 0, 1), 1e-3);
    }
}
