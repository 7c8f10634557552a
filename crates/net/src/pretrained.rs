//! Starting from weights a user supplies: a safetensors file or a PyTorch state dict
//! (`.pt`/`.pth`), read with burn-store.
//!
//! Tensors are matched by name. The GoogLeNet backbone uses torchvision's `googlenet` names,
//! so a torchvision state dict (or a Places/ImageNet GoogLeNet converted to that layout)
//! loads directly: `branch4.1.*` is renamed to our `branch4_proj.*`, a 3-channel `conv1`
//! kernel is summed over its colour channels for our grey input, and tensors that do not fit
//! (torchvision's 1000-class `fc`, the auxiliary classifiers) are skipped and reported. For
//! torchvision's weights build the backbone with `branch3_kernel = 3`: torchvision kept a 3×3
//! kernel in the "5×5" branch. Any model's own `weights.safetensors` also loads (fine-tuning).
//!
//! **Built-in weights** ([`BUILTINS`]): the default compact backbone pretrained by
//! `endoloc pretrain` on simulated colons (two passes each, none of them the `paper` preset's
//! colon), shipped inside the binary (`crates/net/weights/`, provenance in its README).
//! `builtin` ([`BUILTIN`]) was pretrained with zone pairs on four colons (seeds 101–404),
//! `builtin-track` from it with track pairs on those and four more (seeds 505–808),
//! `builtin-joint` from that with track pairs on sixteen colons at once, then sixteen more
//! (pretrain with `joint`; 32 colons in all): indexing a pass with it and no training
//! (train with `pretrained` builtin-joint, `epochs` 0) is the best single model on the
//! `paper` preset; `builtin-changes` from that on eight colons whose test passes went
//! through colons changed at random (pretrain with `changes`), for colons that change
//! between the passes. They fit the default compact backbone only; any other network is refused with the architecture they
//! need.

use crate::NetError;
use crate::backbone::EmbeddingNet;
use burn::module::Param;
use burn::tensor::{Tensor, TensorData};
use burn_store::{ModuleSnapshot, ModuleStore, PytorchStore, SafetensorsStore};
use std::path::Path;

/// What was loaded.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct PretrainedReport {
    /// Tensors loaded.
    pub applied: usize,
    /// Names in the file that matched nothing or did not fit (skipped).
    pub skipped: Vec<String>,
    /// Network tensors the file did not provide (kept at their initial values).
    pub missing: Vec<String>,
    /// Whether a 3-channel first convolution was summed to 1 channel.
    pub conv1_from_rgb: bool,
}

const CONV1: &str = "conv1.conv.weight";

fn not_conv1(path: &str, _container: &str) -> bool {
    !path.ends_with(CONV1)
}

/// The name that stands for the built-in weights wherever a weights path is taken (a file of
/// that name is not looked for: write `./builtin` for one).
pub const BUILTIN: &str = "builtin";

/// A set of start weights shipped inside endoloc (`crates/net/weights/`, provenance in its
/// README), for the default compact backbone only.
#[derive(Debug, Clone, Copy)]
pub struct BuiltinWeights {
    /// The name that stands for them wherever a weights path is taken.
    pub name: &'static str,
    /// What they were pretrained with, and for which training they are the better start.
    pub about: &'static str,
    bytes: &'static [u8],
}

/// Every set of built-in weights; the first is [`BUILTIN`].
pub const BUILTINS: &[BuiltinWeights] = &[
    BuiltinWeights {
        name: BUILTIN,
        about: "zone pairs on four simulated colons (two passes each); \
                the start for zone-pair training",
        bytes: include_bytes!("../weights/compact-sim4.safetensors"),
    },
    BuiltinWeights {
        name: "builtin-track",
        about: "`builtin`, then track pairs (near fraction 0.1) on the same four colons and \
                four more; the start for track pairs (`pairs` track, `near_fraction` 0.1)",
        bytes: include_bytes!("../weights/compact-sim8-track.safetensors"),
    },
    BuiltinWeights {
        name: "builtin-joint",
        about: "`builtin-track`, then track pairs on sixteen colons at once and sixteen more \
                (pretrain with `joint`, 32 colons in all); used as they are: \
                train with `pretrained` builtin-joint, `epochs` 0",
        bytes: include_bytes!("../weights/compact-sim32-joint.safetensors"),
    },
    BuiltinWeights {
        name: "builtin-changes",
        about: "`builtin-joint`, then track pairs on eight colons at once, each test pass through \
                its colon changed at random up to `moderate` (pretrain with `joint` and \
                `changes` moderate); for passes through a colon that changed since its map \
                pass, used as they are: train with `pretrained` builtin-changes, `epochs` 0",
        bytes: include_bytes!("../weights/compact-sim8-changes.safetensors"),
    },
];

/// The built-in weights `path` names, if it names one.
pub fn builtin(path: &Path) -> Option<&'static BuiltinWeights> {
    BUILTINS.iter().find(|b| path.as_os_str() == b.name)
}

/// Whether `path` names built-in weights.
pub fn is_builtin(path: &Path) -> bool {
    builtin(path).is_some()
}

/// Loads the tensors of `path` that fit `net` (see the module documentation); a path that
/// names built-in weights ([`BUILTINS`]) loads those.
///
/// # Errors
/// [`NetError::Weights`] when the file cannot be read or nothing in it fits the network, or
/// for the built-in weights, when the network is not the default compact backbone.
pub fn load_pretrained(net: &mut EmbeddingNet, path: &Path) -> Result<PretrainedReport, NetError> {
    if let Some(b) = builtin(path) {
        return load_builtin(net, b);
    }
    if !path.is_file() {
        let names: Vec<&str> = BUILTINS.iter().map(|b| b.name).collect();
        let why = if path.to_string_lossy().starts_with(BUILTIN) {
            format!(
                "file not found, nor built-in weights of that name ({})",
                names.join(", ")
            )
        } else {
            "file not found".to_string()
        };
        return Err(NetError::weights(path, why));
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let remap = (r"^(.*inception\w+)\.branch4\.1\.", "$1.branch4_proj.");
    let mut report = PretrainedReport::default();
    let (result, conv1) = match ext.as_str() {
        "safetensors" => {
            let mut store = SafetensorsStore::from_file(path)
                .with_key_remapping(remap.0, remap.1)
                .allow_partial(true)
                .skip_enum_variants(true)
                .with_predicate(not_conv1)
                .validate(false);
            let r = net
                .load_from(&mut store)
                .map_err(|e| NetError::weights(path, e))?;
            let c = conv1_tensor(&mut store, path)?;
            (r, c)
        }
        "pt" | "pth" | "bin" => {
            let mut store = PytorchStore::from_file(path)
                .with_key_remapping(remap.0, remap.1)
                .allow_partial(true)
                .skip_enum_variants(true)
                .with_predicate(not_conv1)
                .validate(false);
            let r = net
                .load_from(&mut store)
                .map_err(|e| NetError::weights(path, e))?;
            let c = conv1_tensor(&mut store, path)?;
            (r, c)
        }
        other => {
            return Err(NetError::weights(
                path,
                format!("unknown weights format {other:?}; expected .safetensors, .pt or .pth"),
            ));
        }
    };
    report.applied = result.applied.len();
    report.skipped = result
        .unused
        .iter()
        .cloned()
        .chain(result.errors.iter().map(|e| format!("{e:?}")))
        .filter(|n| !n.ends_with(CONV1))
        .collect();
    report.missing = result
        .missing
        .iter()
        .map(|(n, _)| n.clone())
        .filter(|n| !n.ends_with(CONV1))
        .collect();
    if let Some(data) = conv1
        && set_conv1(net, data, &mut report).is_err()
    {
        report.skipped.push(CONV1.into());
    }
    if report.applied == 0 {
        return Err(NetError::weights(
            path,
            "no tensor in the file matches the backbone (is it the right architecture?)",
        ));
    }
    Ok(report)
}

/// Loads built-in weights; every tensor of `net` must be in them with its shape.
fn load_builtin(
    net: &mut EmbeddingNet,
    weights: &BuiltinWeights,
) -> Result<PretrainedReport, NetError> {
    let refuse = |why: String| {
        NetError::weights(
            weights.name,
            format!(
                "the built-in weights fit the default compact backbone only \
                 (`BackboneConfig::default()`: 256×192 input, stem stride 4, 128-d); {why}"
            ),
        )
    };
    if !matches!(net, EmbeddingNet::Compact(_)) {
        return Err(refuse("this network is GoogLeNet".into()));
    }
    let mut store = SafetensorsStore::from_bytes(Some(weights.bytes.to_vec()))
        .allow_partial(true)
        .skip_enum_variants(true)
        .validate(false);
    let r = net
        .load_from(&mut store)
        .map_err(|e| NetError::weights(weights.name, e))?;
    if !r.missing.is_empty() || !r.errors.is_empty() || !r.unused.is_empty() {
        let names: Vec<String> = r
            .missing
            .iter()
            .map(|(n, _)| format!("missing {n}"))
            .chain(r.errors.iter().map(|e| format!("{e:?}")))
            .chain(r.unused.iter().map(|n| format!("unused {n}")))
            .take(3)
            .collect();
        return Err(refuse(format!(
            "this network differs ({}{})",
            names.join("; "),
            if r.missing.len() + r.errors.len() + r.unused.len() > 3 {
                "; …"
            } else {
                ""
            }
        )));
    }
    Ok(PretrainedReport {
        applied: r.applied.len(),
        ..PretrainedReport::default()
    })
}

fn conv1_tensor<S: ModuleStore>(store: &mut S, path: &Path) -> Result<Option<TensorData>, NetError>
where
    S::Error: std::fmt::Display,
{
    match store
        .get_tensor(CONV1)
        .map_err(|e| NetError::weights(path, e))?
    {
        Some(t) => Ok(burn_store::bridge::to_data(t).ok()),
        None => Ok(None),
    }
}

/// Puts a `[64, c, k, k]` kernel into the first convolution, summing colour channels.
fn set_conv1(
    net: &mut EmbeddingNet,
    data: TensorData,
    report: &mut PretrainedReport,
) -> Result<(), ()> {
    let weight = match net {
        EmbeddingNet::GoogLeNet(g) => &mut g.conv1.conv.weight,
        EmbeddingNet::Compact(c) => match c.blocks.first_mut() {
            Some(b) => &mut b.conv.weight,
            None => return Err(()),
        },
    };
    let target = weight.dims();
    let shape = data.shape().clone();
    let dims: Vec<usize> = shape.iter().copied().collect();
    if dims.len() != 4 || dims[0] != target[0] || dims[2] != target[2] || dims[3] != target[3] {
        return Err(());
    }
    let device = weight.device();
    let t = Tensor::<4>::from_data(data, &device);
    let t = match (dims[1], target[1]) {
        (a, b) if a == b => t,
        (3, 1) => {
            report.conv1_from_rgb = true;
            t.sum_dim(1)
        }
        _ => return Err(()),
    };
    *weight = Param::from_tensor(t);
    report.applied += 1;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backbone::BackboneConfig;
    use crate::preprocess::InputSize;
    use burn::module::Module;

    #[test]
    fn own_weights_load_as_pretrained_and_give_the_same_descriptors() {
        let device = crate::device::cpu();
        let cfg = BackboneConfig::Compact {
            input: InputSize {
                width: 32,
                height: 24,
            },
            channels: vec![4, 8],
            descriptor_dim: 8,
            stem_stride: 2,
            pooling: Default::default(),
        };
        device.seed(5);
        let a = cfg.init(&device);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("w.safetensors");
        device.seed(6);
        let mut b = cfg.init(&device);
        // Saving replaces a file a killed run left (b's weights here).
        crate::model::save_weights(&b, &p).unwrap();
        crate::model::save_weights(&a, &p).unwrap();
        let r = load_pretrained(&mut b, &p).unwrap();
        assert!(r.applied >= 8, "{r:?}");
        assert!(r.missing.is_empty(), "{r:?}");
        let x = Tensor::<4>::random([2, 1, 24, 32], burn::tensor::Distribution::Default, &device);
        let (ya, yb) = (a.valid().forward(x.clone()), b.valid().forward(x));
        let diff: f32 = (ya - yb).abs().max().into_scalar();
        assert!(diff < 1e-6, "{diff}");
        let err = load_pretrained(&mut b, &dir.path().join("nope.pth")).unwrap_err();
        assert!(err.to_string().contains("not found"));

        // The built-in weights are for the default backbone only, and say so.
        let err = load_pretrained(&mut b, Path::new(BUILTIN)).unwrap_err();
        assert!(
            err.to_string().contains("default compact backbone"),
            "{err}"
        );
    }

    #[test]
    fn builtin_weights_fill_every_tensor_of_the_default_backbone() {
        let device = crate::device::cpu();
        device.seed(1);
        let fresh = BackboneConfig::default().init(&device);
        let x = Tensor::<4>::random(
            [1, 1, 192, 256],
            burn::tensor::Distribution::Default,
            &device,
        );
        let describe = |net: &EmbeddingNet| net.valid().forward(x.clone());
        let mut outputs = vec![describe(&fresh)];
        for b in BUILTINS {
            let mut net = fresh.clone();
            let r = load_pretrained(&mut net, Path::new(b.name)).unwrap();
            assert!(
                r.applied >= 10 && r.missing.is_empty() && r.skipped.is_empty(),
                "{}: {r:?}",
                b.name
            );
            outputs.push(describe(&net));
        }
        // Loaded, not left at the random start, and each set is its own: every pair of
        // networks describes the same image differently.
        for i in 0..outputs.len() {
            for j in i + 1..outputs.len() {
                let diff: f32 = (outputs[i].clone() - outputs[j].clone())
                    .abs()
                    .max()
                    .into_scalar();
                assert!(diff > 1e-3, "networks {i} and {j}: {diff}");
            }
        }
        // A name like a built-in one that is none says which there are.
        let mut net = fresh.clone();
        let err = load_pretrained(&mut net, Path::new("builtin-zone"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("builtin, builtin-track, builtin-joint, builtin-changes"),
            "{err}"
        );
    }
}
