//! The twin network: a backbone that maps one grey image to an L2-normalised descriptor.
//!
//! - [`BackboneConfig::Compact`] — the CPU default: `N` conv blocks (3×3, stride 2; the first
//!   5×5 with stride 4), each conv → batch-norm → ReLU, channels 32 → 64 → 128 → 128, global
//!   average pool, a linear layer to 128, L2 normalisation. Input 256×192 grey (the 4:3
//!   frames keep their aspect). About 0.27 M parameters, ~40 M multiply-adds per image. The
//!   stride-4 first layer reads twice the resolution of a 128×96 input with stride 2 at about
//!   the same cost after it: the fine mucosal texture that tells zones apart survives
//!   ([`BackboneConfig::compact_low_res`] is the 128×96 variant).
//! - [`BackboneConfig::GoogLeNet`] — faithful to the paper: the GoogLeNet (Inception v1) trunk
//!   that PoseNet builds on (conv 7×7/2, max-pool, conv 1×1, conv 3×3, max-pool, inception
//!   3a–3b, max-pool, 4a–4e, max-pool, 5a–5b; each conv followed by batch-norm and ReLU as in
//!   torchvision), global average pool, dropout, a linear 1024 → 128 head, L2 normalisation.
//!   Input 224×224×1. About 6 M parameters, ~1.5 G multiply-adds per image: for a GPU.
//!   Module and parameter names follow torchvision's `googlenet` (`conv1.conv.weight`,
//!   `inception3a.branch2.1.bn.running_mean`, ...) so its state dict can be loaded
//!   ([`crate::pretrained`]).
//!
//! # Shapes
//! - input: `[batch, 1, height, width]`, standardised grey ([`crate::preprocess`])
//! - output: `[batch, descriptor_dim]`, rows of unit L2 norm

use crate::preprocess::InputSize;
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig, MaxPool2d, MaxPool2dConfig};
use burn::nn::{
    BatchNorm, BatchNormConfig, Dropout, DropoutConfig, Linear, LinearConfig, PaddingConfig2d,
};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};

/// Which backbone, and its size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum BackboneConfig {
    /// Small CNN for CPUs (the default).
    Compact {
        /// Network input size (default 256×192).
        input: InputSize,
        /// Output channels of the conv blocks, each halving the resolution.
        channels: Vec<usize>,
        /// Descriptor length (paper: 128).
        descriptor_dim: usize,
        /// Stride of the first (5×5) convolution: 2, or 4 to read an input twice as large a
        /// side at about the same cost after the first layer.
        #[serde(default = "default_stem_stride")]
        stem_stride: usize,
        /// Global pooling of the last feature map (default `average`; older model.toml
        /// files without the field load as average).
        #[serde(default)]
        pooling: Pooling,
    },
    /// GoogLeNet / PoseNet trunk, as in the paper.
    #[serde(rename = "googlenet")]
    GoogLeNet {
        /// Network input size (paper: 224×224).
        input: InputSize,
        /// Descriptor length (paper: 128).
        descriptor_dim: usize,
        /// Kernel of the "5×5" inception branch: 5 as in the GoogLeNet paper, 3 to load
        /// torchvision's weights (torchvision kept a 3×3 there).
        branch3_kernel: usize,
        /// Dropout before the head (GoogLeNet: 0.4).
        dropout: f64,
    },
}

/// Global pooling of the compact backbone's last feature map.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pooling {
    /// Mean over positions: every part of the view counts alike.
    #[default]
    Average,
    /// Generalised mean with `p = 3` (Radenović et al., "Fine-tuning CNN image retrieval
    /// with no human annotation", TPAMI 2019): `(mean xᵖ)^(1/p)`, between the average
    /// (`p = 1`) and the maximum (`p → ∞`), so a few distinctive activations (a vessel
    /// pattern, a fold) weigh more than the bland wall around them.
    Gem,
}

impl std::fmt::Display for Pooling {
    /// `average` or `gem`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Pooling::Average => "average",
            Pooling::Gem => "gem",
        })
    }
}

impl std::str::FromStr for Pooling {
    type Err = crate::NetError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "average" | "avg" => Ok(Pooling::Average),
            "gem" => Ok(Pooling::Gem),
            other => Err(crate::NetError::Config(format!(
                "unknown pooling {other:?}; expected average or gem"
            ))),
        }
    }
}

impl Pooling {
    /// Exponent of the generalised mean (1 = average).
    pub fn exponent(self) -> f32 {
        match self {
            Pooling::Average => 1.0,
            Pooling::Gem => 3.0,
        }
    }
}

fn default_stem_stride() -> usize {
    2
}

impl Default for BackboneConfig {
    fn default() -> Self {
        BackboneConfig::compact()
    }
}

impl BackboneConfig {
    /// The compact CPU backbone at 256×192 with a stride-4 first layer, 32-64-128-128
    /// channels, 128-d descriptor.
    pub fn compact() -> Self {
        BackboneConfig::Compact {
            input: InputSize {
                width: 256,
                height: 192,
            },
            channels: vec![32, 64, 128, 128],
            descriptor_dim: 128,
            stem_stride: 4,
            pooling: Pooling::Average,
        }
    }

    /// The compact backbone at 128×96 with a stride-2 first layer: the zone classifier's
    /// default before the stride-4 stem (about 10 points less zone accuracy on the `paper`
    /// preset, 20 % faster to train); the PoseNet and OffsetNet baselines still use it.
    pub fn compact_low_res() -> Self {
        BackboneConfig::Compact {
            input: InputSize {
                width: 128,
                height: 96,
            },
            channels: vec![32, 64, 128, 128],
            descriptor_dim: 128,
            stem_stride: 2,
            pooling: Pooling::Average,
        }
    }

    /// The paper's GoogLeNet at 224×224×1 with a 128-d head.
    pub fn googlenet() -> Self {
        BackboneConfig::GoogLeNet {
            input: InputSize {
                width: 224,
                height: 224,
            },
            descriptor_dim: 128,
            branch3_kernel: 5,
            dropout: 0.4,
        }
    }

    /// The backbone named `compact` or `googlenet`, with default sizes.
    ///
    /// # Errors
    /// [`crate::NetError::Config`] for another name.
    pub fn from_name(name: &str) -> Result<Self, crate::NetError> {
        match name.trim().to_ascii_lowercase().as_str() {
            "compact" => Ok(BackboneConfig::compact()),
            "googlenet" | "posenet" => Ok(BackboneConfig::googlenet()),
            other => Err(crate::NetError::Config(format!(
                "unknown backbone {other:?}; expected compact or googlenet"
            ))),
        }
    }

    /// Short name: `compact` or `googlenet`.
    pub fn name(&self) -> &'static str {
        match self {
            BackboneConfig::Compact { .. } => "compact",
            BackboneConfig::GoogLeNet { .. } => "googlenet",
        }
    }

    /// The same backbone at another input size.
    pub fn with_input(mut self, size: InputSize) -> Self {
        match &mut self {
            BackboneConfig::Compact { input, .. } | BackboneConfig::GoogLeNet { input, .. } => {
                *input = size;
            }
        }
        self
    }

    /// Network input size.
    pub fn input(&self) -> InputSize {
        match self {
            BackboneConfig::Compact { input, .. } | BackboneConfig::GoogLeNet { input, .. } => {
                *input
            }
        }
    }

    /// Descriptor length.
    pub fn descriptor_dim(&self) -> usize {
        match self {
            BackboneConfig::Compact { descriptor_dim, .. }
            | BackboneConfig::GoogLeNet { descriptor_dim, .. } => *descriptor_dim,
        }
    }

    /// Checks sizes.
    ///
    /// # Errors
    /// [`crate::NetError::Config`] naming the bad value.
    pub fn validate(&self) -> Result<(), crate::NetError> {
        let bad = |m: String| Err(crate::NetError::Config(m));
        let input = self.input();
        if input.width < 16 || input.height < 16 || input.width > 2048 || input.height > 2048 {
            return bad(format!(
                "backbone input {input} must be between 16 and 2048 pixels a side"
            ));
        }
        if self.descriptor_dim() == 0 || self.descriptor_dim() > 4096 {
            return bad(format!(
                "descriptor_dim {} must be in 1..=4096",
                self.descriptor_dim()
            ));
        }
        match self {
            BackboneConfig::Compact {
                channels,
                stem_stride,
                ..
            } => {
                if channels.is_empty() || channels.len() > 7 || channels.contains(&0) {
                    return bad(format!(
                        "compact channels {channels:?}: expected 1 to 7 positive counts"
                    ));
                }
                if !(1..=5).contains(stem_stride) {
                    return bad(format!(
                        "compact stem_stride {stem_stride}: expected 1 to 5"
                    ));
                }
            }
            BackboneConfig::GoogLeNet {
                branch3_kernel,
                dropout,
                ..
            } => {
                if *branch3_kernel != 3 && *branch3_kernel != 5 {
                    return bad(format!(
                        "googlenet branch3_kernel {branch3_kernel}: expected 3 or 5"
                    ));
                }
                if !(0.0..1.0).contains(dropout) {
                    return bad(format!("googlenet dropout {dropout}: expected [0, 1)"));
                }
            }
        }
        Ok(())
    }

    /// Builds the network with fresh weights on `device` (seed the device first for a
    /// reproducible start, [`Device::seed`]).
    pub fn init(&self, device: &Device) -> EmbeddingNet {
        match self {
            BackboneConfig::Compact {
                channels,
                descriptor_dim,
                stem_stride,
                pooling,
                ..
            } => EmbeddingNet::Compact(CompactNet::new(
                channels,
                *descriptor_dim,
                *stem_stride,
                *pooling,
                device,
            )),
            BackboneConfig::GoogLeNet {
                descriptor_dim,
                branch3_kernel,
                dropout,
                ..
            } => EmbeddingNet::GoogLeNet(GoogLeNet::new(
                *descriptor_dim,
                *branch3_kernel,
                *dropout,
                device,
            )),
        }
    }
}

/// Conv (no bias) → batch-norm → ReLU; torchvision's `BasicConv2d`.
#[derive(Module, Debug)]
pub struct BasicConv2d {
    /// The convolution.
    pub conv: Conv2d,
    /// Its batch normalisation.
    pub bn: BatchNorm,
}

impl BasicConv2d {
    fn new(c_in: usize, c_out: usize, kernel: usize, stride: usize, device: &Device) -> Self {
        let pad = kernel / 2;
        BasicConv2d {
            conv: Conv2dConfig::new([c_in, c_out], [kernel, kernel])
                .with_stride([stride, stride])
                .with_padding(PaddingConfig2d::Explicit(pad, pad, pad, pad))
                .with_bias(false)
                .init(device),
            bn: BatchNormConfig::new(c_out).with_epsilon(1e-3).init(device),
        }
    }

    /// # Shapes
    /// `[b, c_in, h, w]` → `[b, c_out, h / stride, w / stride]` (rounded up).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        relu(self.bn.forward(self.conv.forward(x)))
    }
}

/// L2-normalises the rows of `[n, d]`.
pub fn l2_normalize(x: Tensor<2>) -> Tensor<2> {
    let norm = x.clone().square().sum_dim(1).add_scalar(1e-12).sqrt();
    x / norm
}

/// The compact CPU backbone (see the module documentation).
#[derive(Module, Debug)]
pub struct CompactNet {
    /// Conv blocks, each halving the resolution.
    pub blocks: Vec<BasicConv2d>,
    /// Global average pooling.
    pub pool: AdaptiveAvgPool2d,
    /// Exponent of the generalised-mean pooling ([`Pooling::exponent`]; 1 = average).
    pub pool_exponent: f32,
    /// Descriptor head.
    pub head: Linear,
}

impl CompactNet {
    fn new(
        channels: &[usize],
        descriptor_dim: usize,
        stem_stride: usize,
        pooling: Pooling,
        device: &Device,
    ) -> Self {
        let mut blocks = Vec::with_capacity(channels.len());
        let mut c_in = 1;
        for (i, &c) in channels.iter().enumerate() {
            let (kernel, stride) = if i == 0 { (5, stem_stride) } else { (3, 2) };
            blocks.push(BasicConv2d::new(c_in, c, kernel, stride, device));
            c_in = c;
        }
        CompactNet {
            blocks,
            pool: AdaptiveAvgPool2dConfig::new([1, 1]).init(),
            pool_exponent: pooling.exponent(),
            head: LinearConfig::new(c_in, descriptor_dim).init(device),
        }
    }

    /// Descriptors of a batch (see the module documentation for shapes).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        let mut x = x;
        for b in &self.blocks {
            x = b.forward(x);
        }
        let x = self.global_pool(x).flatten::<2>(1, 3);
        l2_normalize(self.head.forward(x))
    }

    /// Global pooling, `[b, c, h, w]` → `[b, c, 1, 1]`: the mean, or the generalised mean
    /// `(mean xᵖ)^(1/p)` of the (non-negative, post-ReLU) features.
    pub fn global_pool(&self, x: Tensor<4>) -> Tensor<4> {
        let p = self.pool_exponent;
        if p == 1.0 {
            return self.pool.forward(x);
        }
        // The floor keeps x^(1/p) and its gradient finite where a channel is all zeros.
        self.pool
            .forward(x.clamp_min(1e-6).powf_scalar(p))
            .powf_scalar(1.0 / p)
    }
}

/// An Inception v1 module (four branches concatenated along channels).
#[derive(Module, Debug)]
pub struct Inception {
    /// 1×1 branch.
    pub branch1: BasicConv2d,
    /// 1×1 reduce → 3×3.
    pub branch2: Vec<BasicConv2d>,
    /// 1×1 reduce → 5×5 (or 3×3, torchvision layout).
    pub branch3: Vec<BasicConv2d>,
    /// 3×3 max-pool (stride 1) → 1×1 projection; the projection (torchvision
    /// `branch4.1`).
    pub branch4_proj: BasicConv2d,
    pool: MaxPool2d,
}

impl Inception {
    #[allow(clippy::too_many_arguments)]
    fn new(
        c_in: usize,
        ch1: usize,
        ch3red: usize,
        ch3: usize,
        ch5red: usize,
        ch5: usize,
        pool_proj: usize,
        k5: usize,
        device: &Device,
    ) -> Self {
        Inception {
            branch1: BasicConv2d::new(c_in, ch1, 1, 1, device),
            branch2: vec![
                BasicConv2d::new(c_in, ch3red, 1, 1, device),
                BasicConv2d::new(ch3red, ch3, 3, 1, device),
            ],
            branch3: vec![
                BasicConv2d::new(c_in, ch5red, 1, 1, device),
                BasicConv2d::new(ch5red, ch5, k5, 1, device),
            ],
            branch4_proj: BasicConv2d::new(c_in, pool_proj, 1, 1, device),
            pool: MaxPool2dConfig::new([3, 3])
                .with_strides([1, 1])
                .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                .with_ceil_mode(true)
                .init(),
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let b1 = self.branch1.forward(x.clone());
        let b2 = self.branch2[1].forward(self.branch2[0].forward(x.clone()));
        let b3 = self.branch3[1].forward(self.branch3[0].forward(x.clone()));
        let b4 = self.branch4_proj.forward(self.pool.forward(x));
        Tensor::cat(vec![b1, b2, b3, b4], 1)
    }
}

/// GoogLeNet (Inception v1) trunk with a descriptor head (see the module documentation).
#[derive(Module, Debug)]
pub struct GoogLeNet {
    /// 7×7/2 conv, 1 → 64 channels.
    pub conv1: BasicConv2d,
    /// 1×1 conv 64 → 64.
    pub conv2: BasicConv2d,
    /// 3×3 conv 64 → 192.
    pub conv3: BasicConv2d,
    /// Inception 3a.
    pub inception3a: Inception,
    /// Inception 3b.
    pub inception3b: Inception,
    /// Inception 4a.
    pub inception4a: Inception,
    /// Inception 4b.
    pub inception4b: Inception,
    /// Inception 4c.
    pub inception4c: Inception,
    /// Inception 4d.
    pub inception4d: Inception,
    /// Inception 4e.
    pub inception4e: Inception,
    /// Inception 5a.
    pub inception5a: Inception,
    /// Inception 5b.
    pub inception5b: Inception,
    /// Descriptor head 1024 → descriptor_dim (named `head` so that torchvision's 1000-class
    /// `fc` is never loaded into it).
    pub head: Linear,
    pool3s2: MaxPool2d,
    pool2s2: MaxPool2d,
    avgpool: AdaptiveAvgPool2d,
    dropout: Dropout,
}

impl GoogLeNet {
    fn new(descriptor_dim: usize, k5: usize, dropout: f64, device: &Device) -> Self {
        let inc = |c, a, b, c2, d, e, f| Inception::new(c, a, b, c2, d, e, f, k5, device);
        GoogLeNet {
            conv1: BasicConv2d::new(1, 64, 7, 2, device),
            conv2: BasicConv2d::new(64, 64, 1, 1, device),
            conv3: BasicConv2d::new(64, 192, 3, 1, device),
            inception3a: inc(192, 64, 96, 128, 16, 32, 32),
            inception3b: inc(256, 128, 128, 192, 32, 96, 64),
            inception4a: inc(480, 192, 96, 208, 16, 48, 64),
            inception4b: inc(512, 160, 112, 224, 24, 64, 64),
            inception4c: inc(512, 128, 128, 256, 24, 64, 64),
            inception4d: inc(512, 112, 144, 288, 32, 64, 64),
            inception4e: inc(528, 256, 160, 320, 32, 128, 128),
            inception5a: inc(832, 256, 160, 320, 32, 128, 128),
            inception5b: inc(832, 384, 192, 384, 48, 128, 128),
            head: LinearConfig::new(1024, descriptor_dim).init(device),
            pool3s2: MaxPool2dConfig::new([3, 3])
                .with_strides([2, 2])
                .with_ceil_mode(true)
                .init(),
            pool2s2: MaxPool2dConfig::new([2, 2])
                .with_strides([2, 2])
                .with_ceil_mode(true)
                .init(),
            avgpool: AdaptiveAvgPool2dConfig::new([1, 1]).init(),
            dropout: DropoutConfig::new(dropout).init(),
        }
    }

    /// Descriptors of a batch (see the module documentation for shapes).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        let x = self.pool3s2.forward(self.conv1.forward(x));
        let x = self.conv3.forward(self.conv2.forward(x));
        let x = self.pool3s2.forward(x);
        let x = self.inception3b.forward(self.inception3a.forward(x));
        let x = self.pool3s2.forward(x);
        let x = self.inception4a.forward(x);
        let x = self.inception4b.forward(x);
        let x = self.inception4c.forward(x);
        let x = self.inception4d.forward(x);
        let x = self.inception4e.forward(x);
        let x = self.pool2s2.forward(x);
        let x = self.inception5b.forward(self.inception5a.forward(x));
        let x = self.avgpool.forward(x).flatten::<2>(1, 3);
        let x = self.dropout.forward(x);
        l2_normalize(self.head.forward(x))
    }
}

/// The backbone of either kind.
// A network is built once and then borrowed; the size of its larger variant costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Module, Debug)]
pub enum EmbeddingNet {
    /// Compact CPU backbone.
    Compact(CompactNet),
    /// GoogLeNet backbone.
    GoogLeNet(GoogLeNet),
}

impl EmbeddingNet {
    /// Descriptors of a batch.
    ///
    /// # Shapes
    /// `[batch, 1, height, width]` → `[batch, descriptor_dim]`, unit rows.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        match self {
            EmbeddingNet::Compact(n) => n.forward(x),
            EmbeddingNet::GoogLeNet(n) => n.forward(x),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_backbones_give_unit_descriptors_of_the_configured_size() {
        let device = crate::device::cpu();
        device.seed(1);
        for pooling in [Pooling::Average, Pooling::Gem] {
            let cfg = BackboneConfig::Compact {
                input: InputSize {
                    width: 32,
                    height: 24,
                },
                channels: vec![4, 8],
                descriptor_dim: 16,
                stem_stride: 2,
                pooling,
            };
            let net = cfg.init(&device);
            let x =
                Tensor::<4>::random([3, 1, 24, 32], burn::tensor::Distribution::Default, &device);
            let y = net.forward(x);
            assert_eq!(y.dims(), [3, 16]);
            let norms = y.square().sum_dim(1).into_data();
            for n in norms.as_slice::<f32>().unwrap() {
                assert!((n - 1.0).abs() < 1e-4, "{pooling:?}: {n}");
            }
        }
        // GoogLeNet at a small input (the trunk reduces by 32): shape check only.
        let g = BackboneConfig::GoogLeNet {
            input: InputSize {
                width: 64,
                height: 64,
            },
            descriptor_dim: 8,
            branch3_kernel: 5,
            dropout: 0.4,
        };
        g.validate().unwrap();
        let net = g.init(&device).valid();
        let y = net.forward(Tensor::<4>::zeros([1, 1, 64, 64], &device));
        assert_eq!(y.dims(), [1, 8]);
    }

    #[test]
    fn stem_stride_sets_the_first_layer_and_older_configs_read_as_stride_2() {
        let device = crate::device::cpu();
        device.seed(2);
        for stride in [2usize, 4] {
            let cfg = BackboneConfig::Compact {
                input: InputSize {
                    width: 64,
                    height: 48,
                },
                channels: vec![4, 8],
                descriptor_dim: 8,
                stem_stride: stride,
                pooling: Pooling::Average,
            };
            cfg.validate().unwrap();
            let EmbeddingNet::Compact(net) = cfg.init(&device) else {
                panic!("compact config built another network");
            };
            let y = net.blocks[0].forward(Tensor::<4>::zeros([1, 1, 48, 64], &device));
            assert_eq!(
                y.dims(),
                [1, 4, 48 / stride, 64 / stride],
                "stride {stride}"
            );
        }
        // A model.toml written before the stem stride existed keeps its network.
        let old = "kind = \"compact\"\nchannels = [32, 64, 128, 128]\ndescriptor_dim = 128\n\
                   [input]\nwidth = 128\nheight = 96\n";
        let cfg: BackboneConfig = toml::from_str(old).unwrap();
        assert_eq!(cfg, BackboneConfig::compact_low_res());
        let bad = BackboneConfig::Compact {
            input: InputSize {
                width: 64,
                height: 48,
            },
            channels: vec![4],
            descriptor_dim: 8,
            stem_stride: 0,
            pooling: Pooling::Average,
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("stem_stride")
        );
    }

    #[test]
    fn gem_pooling_is_the_cube_root_of_the_mean_cube_and_average_the_mean() {
        let device = crate::device::cpu();
        let x = Tensor::<4>::from_floats([[[[0.0f32, 1.0], [2.0, 3.0]]]], &device);
        let net = |pooling| {
            let cfg = BackboneConfig::Compact {
                input: InputSize {
                    width: 16,
                    height: 16,
                },
                channels: vec![1],
                descriptor_dim: 2,
                stem_stride: 1,
                pooling,
            };
            match cfg.init(&device) {
                EmbeddingNet::Compact(n) => n,
                EmbeddingNet::GoogLeNet(_) => panic!("compact config built another network"),
            }
        };
        let pooled = |p| {
            net(p)
                .global_pool(x.clone())
                .into_data()
                .as_slice::<f32>()
                .unwrap()[0]
        };
        // (0 + 1 + 8 + 27) / 4 = 9 → 9^(1/3) = 2.0801; the mean is 1.5.
        assert!((pooled(Pooling::Gem) - 9f32.cbrt()).abs() < 1e-4);
        assert!((pooled(Pooling::Average) - 1.5).abs() < 1e-6);
        // Model files name the pooling; files without it read as average.
        let toml_text = toml::to_string(&BackboneConfig::Compact {
            input: InputSize {
                width: 16,
                height: 16,
            },
            channels: vec![1],
            descriptor_dim: 2,
            stem_stride: 1,
            pooling: Pooling::Gem,
        })
        .unwrap();
        assert!(toml_text.contains("pooling = \"gem\""), "{toml_text}");
    }
}
