//! The pose head both regression networks put on the backbone's descriptor ([`PoseHead`]),
//! and the tensor plumbing around it.

use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};

/// The regression head on a backbone descriptor (see the module documentation).
#[derive(Module, Debug)]
pub struct PoseHead {
    /// Features → hidden.
    pub fc: Linear,
    /// Hidden → 3 (normalised position or translation).
    pub position: Linear,
    /// Hidden → 4 (quaternion `x y z w`, before normalisation; identity added).
    pub rotation: Linear,
}

impl PoseHead {
    pub(crate) fn new(features: usize, hidden: usize, device: &Device) -> Self {
        PoseHead {
            fc: LinearConfig::new(features, hidden).init(device),
            position: LinearConfig::new(hidden, 3).init(device),
            rotation: LinearConfig::new(hidden, 4).init(device),
        }
    }

    /// Position and raw quaternion of a batch of features; the quaternion output is the
    /// layer's output plus the identity `(0, 0, 0, 1)`, so an untrained head predicts rotations
    /// near the reference.
    ///
    /// # Shapes
    /// `[b, features]` → (`[b, 3]`, `[b, 4]`)
    pub fn forward(&self, features: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
        let b = features.dims()[0];
        let device = features.device();
        let h = relu(self.fc.forward(features));
        let p = self.position.forward(h.clone());
        let mut id = vec![0f32; b * 4];
        for row in id.chunks_exact_mut(4) {
            row[3] = 1.0;
        }
        let id = Tensor::<2>::from_data(TensorData::new(id, [b, 4]), &device);
        (p, self.rotation.forward(h) + id)
    }
}

/// Descriptor scaled to entries of order 1: `descriptor · √dim`.
pub(crate) fn scaled_features(desc: Tensor<2>) -> Tensor<2> {
    let d = desc.dims()[1].max(1) as f32;
    desc.mul_scalar(d.sqrt())
}

/// Reads a `[rows, cols]` tensor back as `f32` rows.
pub(crate) fn tensor_rows(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_into_vec::<f32>().unwrap_or_default()
}
