//! Runs the visual odometry over a dataset sequence and prints the aligned errors, the
//! tracked fraction and where tracking was lost (`endoloc localize --method vo` is the
//! user-facing command; this example gives the figures in the crate README).
//!
//! `cargo run --release -p endoloc-vo --example vo_dataset -- DATASET [SEQUENCE] [FIRST] [COUNT]`

use std::time::Instant;

use endoloc_data::Dataset;
use endoloc_geometry::{orientation_error_deg, position_error_mm};
use endoloc_vo::{VisualOdometry, VoConfig, report};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .ok_or("usage: vo_dataset DATASET [SEQUENCE] [FIRST] [COUNT]")?;
    let name = args.get(2).map_or("test", String::as_str);
    let dataset = Dataset::open(std::path::Path::new(dir))?;
    let seq = dataset.sequence(name)?;
    let first: usize = args.get(3).map_or(Ok(0), |s| s.parse())?;
    let count: usize = args.get(4).map_or(Ok(seq.len()), |s| s.parse())?;
    let end = (first + count).min(seq.len());
    let mut vo = VisualOdometry::new(dataset.meta.camera, VoConfig::default())?;
    let start = Instant::now();
    let mut tracking_s = 0.0;
    for i in first..end {
        let img = seq.load_gray(i)?;
        let t = Instant::now();
        vo.track(&img)?;
        tracking_s += t.elapsed().as_secs_f64();
    }
    let gt: Vec<_> = seq.poses[first..end].iter().map(|p| p.pose).collect();
    let r = report(vo.frames(), &gt)?;
    let mut pos: Vec<f64> = Vec::new();
    let mut rot: Vec<f64> = Vec::new();
    for (e, g) in r.t_wc.iter().zip(&gt) {
        if let Some(p) = e {
            pos.push(position_error_mm(p, g));
            rot.push(orientation_error_deg(p, g));
        }
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
        let median = v.get(v.len() / 2).copied().unwrap_or(f64::NAN);
        (mean, median, v.last().copied().unwrap_or(f64::NAN))
    };
    let (pm, pmed, pmax) = stats(&mut pos);
    let (rm, rmed, rmax) = stats(&mut rot);
    let frames = end - first;
    println!("{dir}/{name} frames {first}..{end}");
    println!(
        "tracked {:.1} % of {frames} frames, {} segments, lost {} times at {:?}",
        100.0 * r.tracked_fraction,
        r.segments.len(),
        r.lost_at.len(),
        r.lost_at.iter().map(|k| k + first).collect::<Vec<_>>()
    );
    println!("position mm: mean {pm:.2} median {pmed:.2} max {pmax:.2}");
    println!("orientation deg: mean {rm:.2} median {rmed:.2} max {rmax:.2}");
    println!(
        "tracking {:.1} ms/frame (SURF included, image loading excluded), total {:.1} s",
        1e3 * tracking_s / frames.max(1) as f64,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
