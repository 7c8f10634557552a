//! Where matching fails on a test pass: detection or description.
//!
//! Every 10th frame of a sequence with ground-truth poses (`poses.txt`, in the map's frame) is
//! described with the map's SURF settings at a test threshold, and every map point is projected
//! with the true pose. A feature with a projected map point within 2 px has a true partner;
//! the share of those whose descriptor's nearest visible map point is that partner (within
//! 3 px), and that also pass Lowe's ratio 0.8, tell how far the descriptors still recognise the
//! wall; the median descriptor distance of the true pairs, how far they moved. Occlusion is
//! ignored: a projected point may lie behind a fold.
//!
//! ```text
//! cargo run --release -p endoloc-localize --example match_oracle -- MODEL SEQ [THRESHOLD]
//! ```

use std::path::PathBuf;

use endoloc_data::{Sequence, read_camera_file};
use endoloc_features::Describe;
use nalgebra::Point2;

/// Pixels within which a projected map point is a feature's true partner.
const PARTNER_PX: f64 = 2.0;
/// Pixels within which the descriptor's nearest point counts as the partner.
const NEAREST_PX: f64 = 3.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(model), Some(seq)) = (args.first(), args.get(1)) else {
        return Err("usage: match_oracle MODEL SEQ [THRESHOLD]".into());
    };
    let (model, seq) = (PathBuf::from(model), PathBuf::from(seq));
    let map = endoloc_localize::map_io::load_map(&model)?;
    let threshold: f32 = match args.get(2) {
        Some(t) => t.parse()?,
        None => 2.0 * map.config.surf.threshold,
    };
    let own_camera = seq.join(endoloc_data::SEQUENCE_CAMERA_FILE);
    let camera = if own_camera.is_file() {
        read_camera_file(&own_camera)?
    } else {
        map.camera
    };
    let sequence = Sequence::open(&seq)?;
    let surf = map.config.surf.clone().with_threshold(threshold).init()?;
    let points: Vec<_> = map.zones.iter().flat_map(|z| z.points.iter()).collect();
    let (mut features, mut partnered, mut nearest, mut ratio) = (0usize, 0usize, 0usize, 0usize);
    let mut partner_distance = Vec::new();
    for i in (0..sequence.len()).step_by(10) {
        let found = surf.detect_and_describe(&sequence.load_gray(i)?)?;
        let c_w = sequence.poses[i].pose.inverse();
        let visible: Vec<(usize, Point2<f64>)> = points
            .iter()
            .enumerate()
            .filter_map(|(k, p)| {
                let p_c = c_w.transform_point(&p.p_world);
                (p_c.z > 0.5).then(|| camera.project(&p_c).map(|px| (k, px)))?
            })
            .collect();
        features += found.len();
        for f in &found {
            let at = Point2::new(f64::from(f.keypoint.x), f64::from(f.keypoint.y));
            let partner = visible
                .iter()
                .map(|&(k, px)| (k, (px - at).norm()))
                .filter(|&(_, d)| d < PARTNER_PX)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let Some((partner, _)) = partner else {
                continue;
            };
            partnered += 1;
            let distance = |k: usize| -> f32 {
                let d = points[k].descriptor();
                d.iter()
                    .zip(&f.descriptor)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f32>()
                    .sqrt()
            };
            partner_distance.push(distance(partner));
            let mut ranked: Vec<(f32, usize)> =
                visible.iter().map(|&(k, _)| (distance(k), k)).collect();
            ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
            let best = ranked[0];
            let is_partner = visible
                .iter()
                .any(|&(k, px)| k == best.1 && (px - at).norm() < NEAREST_PX);
            if is_partner {
                nearest += 1;
                if ranked.get(1).is_none_or(|second| best.0 < 0.8 * second.0) {
                    ratio += 1;
                }
            }
        }
    }
    partner_distance.sort_by(|a, b| a.total_cmp(b));
    let median = partner_distance
        .get(partner_distance.len() / 2)
        .copied()
        .unwrap_or(f32::NAN);
    let pct = |a: usize, b: usize| 100.0 * a as f64 / b.max(1) as f64;
    println!(
        "{features} features at threshold {threshold}; {partnered} ({:.1} %) with a map point at \
         their pixel; of those, {nearest} ({:.1} %) nearest in descriptor space, {ratio} ({:.1} %) \
         also past the ratio test; median descriptor distance of the true pairs {median:.3}",
        pct(partnered, features),
        pct(nearest, partnered),
        pct(ratio, partnered)
    );
    Ok(())
}
