//! Experiment: database augmentation with turned views (exact homographies).
use endoloc_net::ZoneClassifier;
use endoloc_net::preprocess::{resize_area, standardize};
use endoloc_net::regress::view::{ViewIntrinsics, rotate_view, view_turn};
use rayon::prelude::*;
use std::path::Path;

fn load(dir: &Path, n: Option<usize>) -> Vec<image::GrayImage> {
    let mut names: Vec<_> = std::fs::read_dir(dir.join("images"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    if let Some(n) = n {
        names.truncate(n);
    }
    names
        .par_iter()
        .map(|p| image::open(p).unwrap().to_luma8())
        .collect()
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let clf = ZoneClassifier::load(Path::new(&a[1])).unwrap();
    let train = load(Path::new(&a[2]), None);
    let test = load(Path::new(&a[3]), None);
    let truth: Vec<usize> = std::fs::read_to_string(&a[4])
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(7).unwrap().parse().unwrap())
        .collect();
    let tilts: Vec<f64> = a[5].split(',').map(|v| v.parse().unwrap()).collect();
    let size = clf.config().backbone.input();
    let (w, h) = (size.width as usize, size.height as usize);
    let k = ViewIntrinsics::centred(w, h, 320.0 * w as f64 / 640.0);
    let db = clf.database();
    let q = clf.describe_batch(&test).unwrap();
    let eval = |rows: &[Vec<f32>], zone: &[usize], name: &str| {
        let pred: Vec<usize> = q
            .par_iter()
            .map(|d| {
                let mut best = (f32::MAX, 0);
                for (r, z) in rows.iter().zip(zone) {
                    let dist: f32 = r.iter().zip(d).map(|(x, y)| (x - y) * (x - y)).sum();
                    if dist < best.0 {
                        best = (dist, *z);
                    }
                }
                best.1
            })
            .collect();
        let n = pred.len() as f64;
        let ex = pred.iter().zip(&truth).filter(|(p, t)| p == t).count() as f64 / n;
        let pm = pred
            .iter()
            .zip(&truth)
            .filter(|(p, t)| (**p as i64 - **t as i64).abs() <= 1)
            .count() as f64
            / n;
        println!(
            "{name}: rows {} exact {:.1} pm1 {:.1}",
            rows.len(),
            ex * 100.0,
            pm * 100.0
        );
    };
    let base: Vec<Vec<f32>> = (0..db.len()).map(|i| db.row(i).unwrap().to_vec()).collect();
    eval(&base, &db.zone_of_row, "base");
    let raw: Vec<Vec<f32>> = train
        .par_iter()
        .map(|im| resize_area(im.as_raw(), im.width() as usize, im.height() as usize, size))
        .collect();
    for &t in &tilts {
        let r = t.to_radians();
        let turns = [(0.0, r, 0.0), (0.0, -r, 0.0), (0.0, 0.0, r), (0.0, 0.0, -r)];
        let mut rows = base.clone();
        let mut zones = db.zone_of_row.clone();
        for (roll, p, y) in turns {
            let rot = view_turn(roll, p, y).to_rotation_matrix();
            let inputs: Vec<Vec<f32>> = raw
                .par_iter()
                .map(|px| {
                    let mut v = rotate_view(px, w, h, &k, &rot);
                    standardize(&mut v);
                    v
                })
                .collect();
            rows.extend(clf.describe_inputs(&inputs).unwrap());
            zones.extend(db.zone_of_row.iter().copied());
        }
        eval(&rows, &zones, &format!("tilt {t}"));
    }
}
