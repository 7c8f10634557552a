//! The training curve as a PNG: mean contrastive loss per epoch (top) and validation zone
//! accuracy, exact and ±1 (bottom). Text needs a system font (fontconfig); without one the
//! caller gets an error and skips the picture.

use crate::NetError;
use crate::history::EpochRecord;
use plotters::prelude::*;
use std::path::Path;

/// Draws `history` into a 900×700 PNG at `path`.
///
/// # Errors
/// [`NetError::Io`] (with the plotting error as message) when drawing or writing fails, e.g.
/// no usable font.
pub fn loss_curve(path: &Path, history: &[EpochRecord]) -> Result<(), NetError> {
    draw(path, history).map_err(|e| NetError::io(path, std::io::Error::other(e.to_string())))
}

/// Draws `history` into `path` as [`loss_curve`] does; a failure (e.g. no usable font) is
/// logged as a warning and otherwise ignored, since the picture is optional.
pub fn loss_curve_or_warn(path: &Path, history: &[EpochRecord]) {
    if let Err(e) = loss_curve(path, history) {
        tracing::warn!("loss curve not drawn: {e}");
    }
}

fn draw(path: &Path, history: &[EpochRecord]) -> Result<(), Box<dyn std::error::Error>> {
    const SIZE: (u32, u32) = (900, 700);
    let mut buf = vec![255u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    draw_into(&mut buf, SIZE, history)?;
    let img =
        image::RgbImage::from_raw(SIZE.0, SIZE.1, buf).ok_or("plot buffer of a wrong size")?;
    img.save_with_format(path, image::ImageFormat::Png)?;
    Ok(())
}

/// Draws `history` into an RGB buffer of `size` pixels.
fn draw_into(
    buf: &mut [u8],
    size: (u32, u32),
    history: &[EpochRecord],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(420);
    let max_epoch = history.last().map_or(1, |r| r.epoch).max(1) as f64;
    let max_loss = history
        .iter()
        .map(|r| r.loss as f64)
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-6)
        * 1.05;
    let mut chart = ChartBuilder::on(&top)
        .caption("contrastive loss per epoch", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..max_epoch, 0.0..max_loss)?;
    chart
        .configure_mesh()
        .x_desc("epoch")
        .y_desc("loss")
        .draw()?;
    chart.draw_series(LineSeries::new(
        history.iter().map(|r| (r.epoch as f64, r.loss as f64)),
        &BLUE,
    ))?;
    let mut acc = ChartBuilder::on(&bottom)
        .caption("validation zone accuracy", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..max_epoch, 0.0..100.0)?;
    acc.configure_mesh().x_desc("epoch").y_desc("%").draw()?;
    let exact: Vec<(f64, f64)> = history
        .iter()
        .filter_map(|r| r.val_accuracy.map(|a| (r.epoch as f64, 100.0 * a as f64)))
        .collect();
    let near: Vec<(f64, f64)> = history
        .iter()
        .filter_map(|r| r.val_within1.map(|a| (r.epoch as f64, 100.0 * a as f64)))
        .collect();
    acc.draw_series(LineSeries::new(exact, &RED))?
        .label("exact")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    acc.draw_series(LineSeries::new(near, &GREEN))?
        .label("within ±1 zone")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
    acc.configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}
