//! Choosing the compute device at run time.
//!
//! The pure-Rust `flex` CPU backend is always compiled in and is the default. A GPU backend
//! is compiled in only with the crate feature `cuda` or `wgpu`; it is then chosen by name
//! (`--device cuda`, or `BURN_DEVICE=cuda`). Tests never need one.

use crate::NetError;
use burn::module::{Module, ModuleVisitor, Param};
use burn::tensor::{Bool, Device, Int, Tensor};

/// The flex CPU device (multi-threaded with rayon, SIMD).
pub fn cpu() -> Device {
    Device::flex()
}

/// Runs `init` right after seeding the backend's random generator with `seed`, while no other
/// seeded initialisation of this crate runs.
///
/// The backend's generator is one per process: two trainings started at once (threads of a
/// test binary, or a host program) would otherwise draw each other's numbers and the same
/// seed would not give the same initial weights. Code outside this crate that draws from
/// the backend's generator at the same time can still interleave.
pub fn seeded<T>(device: &Device, seed: u64, init: impl FnOnce() -> T) -> T {
    static SEEDING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = SEEDING
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    device.seed(seed);
    init()
}

/// Builds a module with fresh weights drawn from the CPU backend's generator seeded with
/// `seed` ([`seeded`]), then moves it to `device`.
///
/// burn draws a parameter's initial values when it is first used, not when the module is
/// built; every parameter is therefore drawn here, while the seed holds. Each GPU backend has
/// its own random generator, so initialising on the device itself would give other weights
/// for the same seed; drawing them on the CPU gives every device the same start and, for a
/// network without dropout, the same trained model within float tolerance. A GPU's own
/// generator is then seeded with `seed` as well.
///
/// # Errors
/// Whatever `init` returns.
pub fn seeded_init<M: Module, E>(
    device: &Device,
    seed: u64,
    init: impl FnOnce(&Device) -> Result<M, E>,
) -> Result<M, E> {
    let host = if device.is_autodiff() {
        cpu().autodiff()
    } else {
        cpu()
    };
    let module = seeded(&host, seed, || {
        let module = init(&host)?;
        module.visit(&mut Materialize);
        Ok(module)
    })?;
    if *device == host {
        return Ok(module);
    }
    // The device's own generator (dropout during training) starts from the seed too, so that
    // one seed gives one run on a GPU as on the CPU.
    device.seed(seed);
    // A fork keeps trainable parameters leaves of the new device's graph.
    Ok(module.fork(device))
}

/// Draws every lazily initialised parameter of a module.
struct Materialize;

impl ModuleVisitor for Materialize {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let _ = param.val();
    }

    fn visit_int<const D: usize>(&mut self, param: &Param<Tensor<D, Int>>) {
        let _ = param.val();
    }

    fn visit_bool<const D: usize>(&mut self, param: &Param<Tensor<D, Bool>>) {
        let _ = param.val();
    }
}

/// Names of the devices this build can use, for help texts.
pub fn available() -> Vec<&'static str> {
    #[allow(unused_mut)]
    let mut v = vec!["cpu"];
    #[cfg(feature = "cuda")]
    v.push("cuda");
    #[cfg(feature = "wgpu")]
    v.push("wgpu");
    v
}

/// The device named `name`: `cpu` (or `flex`), `cuda`, `wgpu`, or `auto` (the `BURN_DEVICE`
/// environment variable when set, else the CPU).
///
/// # Errors
/// [`NetError::Device`] for an unknown name or a GPU backend not compiled into this build.
pub fn from_name(name: &str) -> Result<Device, NetError> {
    let lower = name.trim().to_ascii_lowercase();
    let lower = if lower == "auto" {
        match std::env::var("BURN_DEVICE") {
            Ok(v) if !v.trim().is_empty() => v.trim().to_ascii_lowercase(),
            _ => "cpu".to_string(),
        }
    } else {
        lower
    };
    #[allow(unreachable_patterns)]
    match lower.as_str() {
        "cpu" | "flex" => Ok(cpu()),
        #[cfg(feature = "cuda")]
        "cuda" => Ok(Device::cuda(burn::tensor::DeviceIndex::Default)),
        #[cfg(feature = "wgpu")]
        "wgpu" => Ok(Device::wgpu(burn::tensor::DeviceKind::default())),
        "cuda" | "wgpu" => Err(NetError::Device(format!(
            "{lower} is not compiled into this build (rebuild with `--features {lower}`); available: {}",
            available().join(", ")
        ))),
        other => Err(NetError::Device(format!(
            "unknown device {other:?}; available: {}",
            available().join(", ")
        ))),
    }
}
