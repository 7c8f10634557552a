//! The error of one test frame, as `errors.csv` writes it and the spill file stores it.

use endoloc_geometry::Status;

use crate::spill::{Fields, Record};

/// The error of one test frame: a row of `errors.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameEvaluation {
    /// 0-based test frame index.
    pub frame: usize,
    /// Ground-truth timestamp, seconds.
    pub timestamp_s: f64,
    /// Whether an estimated pose is associated with the frame.
    pub localized: bool,
    /// Position error, mm (after alignment, if any).
    pub position_mm: Option<f64>,
    /// Orientation error, degrees.
    pub orientation_deg: Option<f64>,
    /// Status from `frames.csv`.
    pub status: Option<Status>,
    /// Predicted zone from `frames.csv`.
    pub zone: Option<usize>,
    /// True zone.
    pub gt_zone: Option<usize>,
}

const NONE_U64: u64 = u64::MAX;

pub(crate) fn status_code(s: Option<Status>) -> u8 {
    match s {
        None => 0,
        Some(Status::Refined) => 1,
        Some(Status::InitOnly) => 2,
        Some(Status::Rejected) => 3,
    }
}

pub(crate) fn status_of(code: u8) -> Option<Status> {
    match code {
        1 => Some(Status::Refined),
        2 => Some(Status::InitOnly),
        3 => Some(Status::Rejected),
        _ => None,
    }
}

fn opt_u64(v: Option<usize>) -> u64 {
    v.map_or(NONE_U64, |x| x as u64)
}

fn u64_opt(v: u64) -> Option<usize> {
    (v != NONE_U64).then_some(v as usize)
}

impl Record for FrameEvaluation {
    const SIZE: usize = 8 + 8 + 1 + 8 + 8 + 1 + 8 + 8;
    fn encode(&self, out: &mut Vec<u8>) {
        out.extend((self.frame as u64).to_le_bytes());
        out.extend(self.timestamp_s.to_le_bytes());
        out.push(u8::from(self.localized));
        out.extend(self.position_mm.unwrap_or(f64::NAN).to_le_bytes());
        out.extend(self.orientation_deg.unwrap_or(f64::NAN).to_le_bytes());
        out.push(status_code(self.status));
        out.extend(opt_u64(self.zone).to_le_bytes());
        out.extend(opt_u64(self.gt_zone).to_le_bytes());
    }
    fn decode(b: &[u8]) -> Self {
        let mut f = Fields(b);
        let frame = f.u64() as usize;
        let timestamp_s = f.f64();
        let localized = f.u8() == 1;
        let (p, r) = (f.f64(), f.f64());
        Self {
            frame,
            timestamp_s,
            localized,
            position_mm: localized.then_some(p),
            orientation_deg: localized.then_some(r),
            status: status_of(f.u8()),
            zone: u64_opt(f.u64()),
            gt_zone: u64_opt(f.u64()),
        }
    }
}
