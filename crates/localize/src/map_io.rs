//! Saving and loading a [`Map`]: `map.toml` (settings, camera, counts — readable) next to
//! `map.bin` (the points).
//!
//! `map.bin`, little-endian: magic `b"ENDOLOCMAP"`, format version `u32` (1), zone count `u32`;
//! per zone: zone index `u32`, frame count `u32` + frames `u32`…, point count `u32`, descriptor
//! length `u32`; per point: `x y z` `f64` (mm, world), RMS `f64` (px), Laplacian `i8`,
//! descriptor `f32`…, observation count `u32` + (frame `u32`, `u` `f64`, `v` `f64`)….
//! Written to a temporary file and renamed.

use std::io::Read;
use std::path::Path;

use endoloc_data::Fingerprint;
use endoloc_geometry::Camera;
use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

use crate::LocalizeError;
use crate::map::{Map, MapConfig, MapPoint, ZoneMap};

const MAGIC: &[u8; 10] = b"ENDOLOCMAP";
const VERSION: u32 = 1;

/// `map.toml`: what the map was built with.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct MapMeta {
    format_version: u32,
    camera: Camera,
    config: MapConfig,
    zones: usize,
    points: usize,
    empty_zones: Vec<usize>,
    /// Fingerprint of the model's `zones.csv` the map was built for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    model_zones: Option<Fingerprint>,
    /// Fingerprint of `map.bin`: the two files belong to one build.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bin: Option<Fingerprint>,
}

fn file_err(path: &Path, e: impl std::fmt::Display) -> LocalizeError {
    LocalizeError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// The earlier map's files, kept (as hard links) while a new map replaces them.
const PREV_BIN: &str = ".map.bin.prev";
/// See [`PREV_BIN`].
const PREV_TOML: &str = ".map.toml.prev";

/// Writes `map.bin` and then `map.toml` into `dir`, each atomically (temporary file, rename).
/// `map.toml` records `map.bin`'s fingerprint, so a pair from two builds is never used. While
/// the two files are replaced, the earlier pair stays reachable as `.map.bin.prev` and
/// `.map.toml.prev`: a run killed between the two renames leaves the new `map.bin` beside the
/// earlier `map.toml`, and [`load_map`] then reads the earlier map whole.
///
/// # Errors
/// [`LocalizeError::File`] on I/O errors.
pub fn save_map(map: &Map, dir: &Path) -> Result<(), LocalizeError> {
    let bin = map_bytes(map);
    let summary = map.summary();
    let meta = MapMeta {
        format_version: VERSION,
        camera: map.camera,
        config: map.config.clone(),
        zones: summary.zones,
        points: summary.points,
        empty_zones: summary.empty_zones,
        model_zones: map.model_zones.clone(),
        bin: Some(Fingerprint::of_bytes(&bin)),
    };
    let toml_path = dir.join("map.toml");
    let text = toml::to_string_pretty(&meta).map_err(|e| file_err(&toml_path, e))?;
    keep_previous(dir)?;
    write_atomic(&dir.join("map.bin"), &bin)?;
    write_atomic(&toml_path, text.as_bytes())?;
    for name in [PREV_BIN, PREV_TOML] {
        remove_if_present(&dir.join(name))?;
    }
    Ok(())
}

/// Keeps the current `map.bin` and `map.toml` of `dir` reachable as [`PREV_BIN`] and
/// [`PREV_TOML`] (hard links, or copies where the file system has none) — unless they do not
/// form a pair. Backups left by a killed run are replaced.
fn keep_previous(dir: &Path) -> Result<(), LocalizeError> {
    let (bin, toml_path) = (dir.join("map.bin"), dir.join("map.toml"));
    let (prev_bin, prev_toml) = (dir.join(PREV_BIN), dir.join(PREV_TOML));
    // A killed run's backups are the map to keep when the current files do not pair.
    if prev_bin.is_file() && prev_toml.is_file() && read_pair(dir, "map.toml", "map.bin").is_err() {
        return Ok(());
    }
    for p in [&prev_bin, &prev_toml] {
        remove_if_present(p)?;
    }
    if !(bin.is_file() && toml_path.is_file()) {
        return Ok(());
    }
    for (from, to) in [(&bin, &prev_bin), (&toml_path, &prev_toml)] {
        if std::fs::hard_link(from, to).is_err() {
            std::fs::copy(from, to).map_err(|e| file_err(to, e))?;
        }
    }
    endoloc_data::fsutil::sync_dir(dir);
    Ok(())
}

fn remove_if_present(path: &Path) -> Result<(), LocalizeError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(file_err(path, e)),
        _ => Ok(()),
    }
}

/// `map.bin`'s bytes (module doc).
fn map_bytes(map: &Map) -> Vec<u8> {
    let mut buf: Vec<u8> = Vec::new();
    buf.extend_from_slice(MAGIC);
    put_u32(&mut buf, VERSION);
    put_u32(&mut buf, map.zones.len() as u32);
    for z in &map.zones {
        put_u32(&mut buf, z.zone as u32);
        put_u32(&mut buf, z.frames.len() as u32);
        for &f in &z.frames {
            put_u32(&mut buf, f as u32);
        }
        put_u32(&mut buf, z.points.len() as u32);
        let dim = z.points.first().map_or(0, |p| p.descriptor.len());
        put_u32(&mut buf, dim as u32);
        for p in &z.points {
            for v in [p.p_world.x, p.p_world.y, p.p_world.z, p.reprojection_rms_px] {
                buf.extend_from_slice(&v.to_le_bytes());
            }
            buf.push(p.laplacian as u8);
            for v in &p.descriptor {
                buf.extend_from_slice(&v.to_le_bytes());
            }
            put_u32(&mut buf, p.observations.len() as u32);
            for (f, px) in &p.observations {
                put_u32(&mut buf, *f as u32);
                buf.extend_from_slice(&px.x.to_le_bytes());
                buf.extend_from_slice(&px.y.to_le_bytes());
            }
        }
    }
    buf
}

/// Folder of the map's smoothed level inside a model folder (a `map.toml` and `map.bin` of
/// its own, written by [`save_map`]): the map of the training images smoothed by a Gaussian
/// ([`crate::MapConfig::blur_px`], [`crate::Localizer::with_smoothed_level`]).
pub const SMOOTHED_LEVEL_DIR: &str = "map_smoothed";

/// Writes the map's smoothed level into `dir/map_smoothed/` ([`save_map`]); with `None`,
/// removes a level an earlier build left there, so that a map is never read with another
/// build's level.
///
/// # Errors
/// [`LocalizeError::File`] on I/O errors.
pub fn save_smoothed_level(level: Option<&Map>, dir: &Path) -> Result<(), LocalizeError> {
    let level_dir = dir.join(SMOOTHED_LEVEL_DIR);
    match level {
        Some(map) => {
            std::fs::create_dir_all(&level_dir).map_err(|e| file_err(&level_dir, e))?;
            save_map(map, &level_dir)
        }
        None => match std::fs::remove_dir_all(&level_dir) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(file_err(&level_dir, e)),
            _ => Ok(()),
        },
    }
}

/// The smoothed level of the map in model folder `dir` ([`save_smoothed_level`]), or `None`
/// when the map has none.
///
/// # Errors
/// As [`load_map`], for a level that is there but cannot be read.
pub fn load_smoothed_level(dir: &Path) -> Result<Option<Map>, LocalizeError> {
    let level_dir = dir.join(SMOOTHED_LEVEL_DIR);
    if !level_dir.join("map.toml").is_file() {
        return Ok(None);
    }
    load_map(&level_dir).map(Some)
}

/// The σ of the smoothed level of the map in model folder `dir`, pixels
/// ([`crate::MapConfig::blur_px`] of `dir/map_smoothed/map.toml`); 0 when the map has no level.
///
/// # Errors
/// [`LocalizeError::File`] for a level `map.toml` that cannot be read or parsed.
pub fn smoothed_level_px(dir: &Path) -> Result<f64, LocalizeError> {
    let path = dir.join(SMOOTHED_LEVEL_DIR).join("map.toml");
    let text = match std::fs::read_to_string(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0.0),
        r => r.map_err(|e| file_err(&path, e))?,
    };
    let meta: MapMeta = toml::from_str(&text).map_err(|e| file_err(&path, e))?;
    Ok(meta.config.blur_px)
}

/// Reads a map written by [`save_map`]. When `map.bin` does not belong to `map.toml` (a
/// `map` run killed between its two renames) but the earlier `map.bin` kept beside them does,
/// that earlier map is read, with a warning.
///
/// # Errors
/// [`LocalizeError::File`] for a missing, truncated or foreign file (naming it and what was
/// expected).
pub fn load_map(dir: &Path) -> Result<Map, LocalizeError> {
    let (meta, bytes) = match read_pair(dir, "map.toml", "map.bin") {
        Err(PairError::Mismatch(e)) => match read_pair(dir, "map.toml", PREV_BIN) {
            Ok(pair) => {
                tracing::warn!(
                    "{}: map.bin is from an interrupted `endoloc map`; using the earlier map \
                     ({PREV_BIN}); rebuild it with the map job and `force`",
                    dir.display()
                );
                pair
            }
            Err(_) => return Err(e),
        },
        Err(PairError::Other(e)) => return Err(e),
        Ok(pair) => pair,
    };
    map_from_parts(meta, &dir.join("map.bin"), &bytes)
}

/// Why a `map.toml` and a `map.bin` could not be read as one map.
enum PairError {
    /// Both read, but the bin is not the one the toml records.
    Mismatch(LocalizeError),
    /// A file is missing or unreadable.
    Other(LocalizeError),
}

/// Reads `dir/toml_name` and `dir/bin_name` and checks that the bin is the one the toml
/// records (when it records one).
fn read_pair(dir: &Path, toml_name: &str, bin_name: &str) -> Result<(MapMeta, Vec<u8>), PairError> {
    let toml_path = dir.join(toml_name);
    let text = std::fs::read_to_string(&toml_path).map_err(|e| {
        PairError::Other(file_err(
            &toml_path,
            format!("{e} (build the map first with the map job)"),
        ))
    })?;
    let meta: MapMeta =
        toml::from_str(&text).map_err(|e| PairError::Other(file_err(&toml_path, e)))?;
    let bin_path = dir.join(bin_name);
    let mut bytes = Vec::new();
    std::fs::File::open(&bin_path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(|e| PairError::Other(file_err(&bin_path, e)))?;
    if let Some(recorded) = &meta.bin {
        let found = Fingerprint::of_bytes(&bytes);
        if &found != recorded {
            return Err(PairError::Mismatch(file_err(
                &bin_path,
                format!(
                    "fingerprint {found}, but map.toml records {recorded}: the two files come \
                     from different builds (an interrupted map job?); rebuild the map with `force`"
                ),
            )));
        }
    }
    Ok((meta, bytes))
}

/// Parses a map from the text of its `map.toml` and the bytes of its `map.bin` (see
/// [`load_map`]); the paths name the files in errors.
///
/// # Errors
/// [`LocalizeError::File`] for TOML that does not describe a map, or a truncated or foreign
/// `map.bin` (naming the file and what was expected).
pub fn parse_map(
    toml_path: &Path,
    toml_text: &str,
    bin_path: &Path,
    bin_bytes: &[u8],
) -> Result<Map, LocalizeError> {
    let meta: MapMeta = toml::from_str(toml_text).map_err(|e| file_err(toml_path, e))?;
    map_from_parts(meta, bin_path, bin_bytes)
}

/// The map of `meta` with the points of `map.bin`'s `bytes`.
fn map_from_parts(meta: MapMeta, bin_path: &Path, bytes: &[u8]) -> Result<Map, LocalizeError> {
    let mut r = Reader {
        bytes,
        pos: 0,
        path: bin_path,
    };
    if r.take(MAGIC.len())? != MAGIC {
        return Err(file_err(bin_path, "not an endoloc map file (bad magic)"));
    }
    let version = r.u32()?;
    if version != VERSION {
        return Err(file_err(
            bin_path,
            format!("map format {version}, expected {VERSION}"),
        ));
    }
    let n_zones = r.u32()? as usize;
    // Capacities from the counts in the file, bounded by what the rest of it can hold: a
    // damaged count must not reserve memory for records that are not there.
    let mut zones = Vec::with_capacity(n_zones.min(r.remaining() / ZONE_MIN_BYTES));
    for _ in 0..n_zones {
        let zone = r.u32()? as usize;
        let nf = r.u32()? as usize;
        let frames = (0..nf)
            .map(|_| r.u32().map(|v| v as usize))
            .collect::<Result<_, _>>()?;
        let np = r.u32()? as usize;
        let dim = r.u32()? as usize;
        let mut points = Vec::with_capacity(np.min(r.remaining() / POINT_MIN_BYTES));
        for _ in 0..np {
            let (x, y, z, rms) = (r.f64()?, r.f64()?, r.f64()?, r.f64()?);
            let laplacian = r.take(1)?[0] as i8;
            let descriptor = (0..dim).map(|_| r.f32()).collect::<Result<_, _>>()?;
            let no = r.u32()? as usize;
            let mut observations = Vec::with_capacity(no.min(r.remaining() / OBSERVATION_BYTES));
            for _ in 0..no {
                let f = r.u32()? as usize;
                observations.push((f, Point2::new(r.f64()?, r.f64()?)));
            }
            points.push(MapPoint {
                p_world: Point3::new(x, y, z),
                descriptor,
                laplacian,
                observations,
                reprojection_rms_px: rms,
            });
        }
        zones.push(ZoneMap {
            zone,
            frames,
            points,
            rejected_tracks: 0,
            keypoints: 0,
        });
    }
    Ok(Map {
        config: meta.config,
        camera: meta.camera,
        zones,
        model_zones: meta.model_zones,
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

/// Fewest bytes of a zone in `map.bin`: index, frame count, point count, descriptor length.
const ZONE_MIN_BYTES: usize = 16;
/// Fewest bytes of a point: position, RMS, Laplacian, observation count.
const POINT_MIN_BYTES: usize = 37;
/// Bytes of an observation: frame, `u`, `v`.
const OBSERVATION_BYTES: usize = 20;

impl Reader<'_> {
    /// Bytes not read yet.
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }
    fn take(&mut self, n: usize) -> Result<&[u8], LocalizeError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(file_err(
                self.path,
                format!("truncated at byte {}: expected {n} more bytes", self.pos),
            ));
        };
        let out = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(out)
    }
    fn u32(&mut self) -> Result<u32, LocalizeError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn f32(&mut self) -> Result<f32, LocalizeError> {
        Ok(f32::from_bits(self.u32()?))
    }
    fn f64(&mut self) -> Result<f64, LocalizeError> {
        let b = self.take(8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(f64::from_le_bytes(a))
    }
}

fn put_u32(buf: &mut Vec<u8>, v: u32) {
    buf.extend_from_slice(&v.to_le_bytes());
}

/// Writes `bytes` to `path` through [`endoloc_data::write_atomic`] (temporary file in the same
/// folder, flushed, renamed, folder flushed; the temporary is removed on error).
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), LocalizeError> {
    endoloc_data::write_atomic(path, bytes).map_err(|e| match e {
        endoloc_data::DataError::Io { path, source } => file_err(&path, source),
        other => file_err(path, other),
    })
}
