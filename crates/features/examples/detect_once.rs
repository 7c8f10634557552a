//! Runs SURF detect+describe once, single-threaded, on the 640 × 480 textured image (or the
//! PNG given as the first argument) — the workload measured with callgrind in BENCHMARKS.md:
//!
//! ```text
//! cargo build --release -p endoloc-features --example detect_once
//! valgrind --tool=callgrind --toggle-collect='*detect_and_describe*' \
//!     target/release/examples/detect_once
//! ```

use endoloc_features::{SurfConfig, texture};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let image = match std::env::args().nth(1) {
        Some(path) => image::open(&path)?.to_luma8(),
        None => texture::textured_image(640, 480, 1),
    };
    let threshold = std::env::var("SURF_THRESHOLD")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200.0);
    let surf = SurfConfig::default()
        .with_parallel(false)
        .with_threshold(threshold)
        .init()?;
    let features = surf.detect_and_describe(&image)?;
    println!(
        "{} × {} image, threshold {threshold}: {} keypoints",
        image.width(),
        image.height(),
        features.len()
    );
    Ok(())
}
