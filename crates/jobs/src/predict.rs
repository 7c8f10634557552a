//! Zone predictions for a whole sequence, batched over all cores.

use std::time::Instant;

use endoloc_data::Sequence;
use endoloc_net::{ZoneClassifier, ZonePrediction};
use rayon::prelude::*;

use crate::error::Result;
use crate::progress::{Progress, bar};

/// Zone predictions of every test frame, and the time per frame (descriptor + look-up,
/// batched over both cores), ms.
pub fn predict_zones(
    classifier: &ZoneClassifier,
    seq: &Sequence,
    progress: &dyn Progress,
) -> Result<(Vec<ZonePrediction>, f64)> {
    const BATCH: usize = 64;
    let bar = bar(progress, seq.len() as u64, "zones");
    let t = Instant::now();
    let mut preds = Vec::with_capacity(seq.len());
    for start in (0..seq.len()).step_by(BATCH) {
        let end = (start + BATCH).min(seq.len());
        let imgs: Result<Vec<_>> = (start..end)
            .into_par_iter()
            .map(|i| Ok(seq.load_gray(i)?))
            .collect();
        preds.extend(classifier.classify_batch(&imgs?)?);
        bar.inc((end - start) as u64);
    }
    bar.finish_and_clear();
    let ms = t.elapsed().as_secs_f64() * 1e3 / seq.len().max(1) as f64;
    Ok((preds, ms))
}
