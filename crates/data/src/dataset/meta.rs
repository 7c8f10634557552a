//! `dataset.toml`: what a dataset is (name, source, camera, simulation settings).

use crate::DataError;
use crate::fsutil::read_text;
use endoloc_geometry::Camera;
use serde::{Deserialize, Serialize};
use std::path::Path;

use super::layout::{FORMAT_VERSION, MASK_FILE, SEQUENCE_CAMERA_FILE, UNITS};

/// The contents of `dataset.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "meta_toml::MetaRepr", into = "meta_toml::MetaRepr")]
pub struct DatasetMeta {
    /// Human-readable dataset name.
    pub name: String,
    /// Format version; [`FORMAT_VERSION`] for datasets written by this crate.
    pub format_version: u32,
    /// Length unit of every file: always `"mm"`.
    pub units: String,
    /// Provenance, free form (tool, version, command line, original source and licence, …).
    #[serde(default)]
    pub source: toml::Table,
    /// The camera all images of all sequences were taken with. Stored as a `[camera]` table
    /// with `model = "pinhole"`, size, intrinsics in pixels and an optional
    /// `[camera.distortion]` table (`model = "radial-tangential"` or `"fisheye"`).
    pub camera: Camera,
    /// The image mask, a file name relative to the dataset folder (`[camera] mask`, usually
    /// [`MASK_FILE`]): an 8-bit image of the frames' size, non-zero where the image is valid
    /// (inside the field stop, off the black border). `None`: every pixel is valid.
    pub mask: Option<String>,
    /// The simulator's full configuration when the dataset was simulated (opaque here), so
    /// the dataset can be regenerated from its own files.
    pub simulation: Option<toml::Table>,
}

impl DatasetMeta {
    /// Metadata for a new dataset: current format version, units mm, empty provenance, no
    /// simulation config.
    pub fn new(name: impl Into<String>, camera: Camera) -> Self {
        DatasetMeta {
            name: name.into(),
            format_version: FORMAT_VERSION,
            units: UNITS.to_string(),
            source: toml::Table::new(),
            camera,
            mask: None,
            simulation: None,
        }
    }

    /// Checks version, units and camera; the message says what was expected.
    ///
    /// # Errors
    /// A message for the first problem found.
    pub fn validate(&self) -> Result<(), String> {
        self.problems().into_iter().next().map_or(Ok(()), Err)
    }

    /// Every problem with version, units and camera.
    pub(crate) fn problems(&self) -> Vec<String> {
        let mut p = Vec::new();
        if self.format_version != FORMAT_VERSION {
            p.push(format!(
                "format_version = {}; expected {FORMAT_VERSION}",
                self.format_version
            ));
        }
        if self.units != UNITS {
            p.push(format!("units = {:?}; expected \"{UNITS}\"", self.units));
        }
        if let Err(e) = self.camera.validate() {
            p.push(format!("[camera]: {e}"));
        }
        if let Some(m) = &self.mask {
            let path = Path::new(m);
            if m.is_empty()
                || path.is_absolute()
                || path.components().any(|c| c.as_os_str() == "..")
            {
                p.push(format!(
                    "[camera] mask = {m:?}; expected a file name inside the dataset folder, e.g. \"{MASK_FILE}\""
                ));
            }
        }
        p
    }

    /// Parses `dataset.toml` text (without validating values).
    ///
    /// # Errors
    /// [`DataError::Parse`] naming the line and what was expected.
    pub fn from_toml_str(path: &Path, text: &str) -> Result<Self, DataError> {
        toml::from_str::<DatasetMeta>(text).map_err(|e| {
            let (line, message) = crate::toml_error_line(text, &e);
            DataError::parse(path, line, message)
        })
    }

    /// Reads and validates `dataset.toml`.
    ///
    /// # Errors
    /// [`DataError::Io`], [`DataError::Parse`], or [`DataError::Invalid`] for a wrong
    /// version, units or camera.
    pub fn read(path: &Path) -> Result<Self, DataError> {
        let text = read_text(path)?;
        let meta = Self::from_toml_str(path, &text)?;
        meta.validate().map_err(|m| DataError::invalid(path, m))?;
        Ok(meta)
    }

    /// The TOML text of `dataset.toml`, with a header comment.
    ///
    /// # Errors
    /// A message when the provenance or simulation tables cannot be written as TOML.
    pub fn to_toml_string(&self) -> Result<String, String> {
        let body = toml::to_string(self).map_err(|e| e.to_string())?;
        Ok(format!(
            "# endoloc dataset, format version {FORMAT_VERSION}: lengths in mm, poses T_wc (camera-to-world)\n{body}"
        ))
    }
}

/// The camera stated by the `[camera]` table of a TOML file: a sequence's `camera.toml`, a
/// `dataset.toml`, or a file of its own for another scope (`localize --camera`). A `mask` in
/// the table is ignored (masks belong to a dataset).
///
/// # Errors
/// [`DataError::Io`]; [`DataError::Parse`] naming the line; [`DataError::Invalid`] when the
/// file has no `[camera]` table or the camera is invalid.
pub fn read_camera_file(path: &Path) -> Result<Camera, DataError> {
    let text = read_text(path)?;
    #[derive(Deserialize)]
    struct File {
        camera: Option<meta_toml::CameraRepr>,
    }
    let file: File = toml::from_str(&text).map_err(|e| {
        let (line, message) = crate::toml_error_line(&text, &e);
        DataError::parse(path, line, message)
    })?;
    let Some(repr) = file.camera else {
        return Err(DataError::invalid(
            path,
            "no [camera] table; expected one with width, height, fx, fy, cx, cy (pixels)",
        ));
    };
    let camera = repr.camera();
    camera
        .validate()
        .map_err(|e| DataError::invalid(path, format!("[camera]: {e}")))?;
    Ok(camera)
}

/// The camera of the sequence in folder `seq_dir` when it has its own
/// ([`SEQUENCE_CAMERA_FILE`]), checked against the dataset's `dataset_camera`: same image size.
/// `None` when the sequence was taken with the dataset's camera.
///
/// # Errors
/// As [`read_camera_file`]; [`DataError::Invalid`] for another image size.
pub fn sequence_camera(
    seq_dir: &Path,
    dataset_camera: &Camera,
) -> Result<Option<Camera>, DataError> {
    let path = seq_dir.join(SEQUENCE_CAMERA_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let camera = read_camera_file(&path)?;
    if (camera.width, camera.height) != (dataset_camera.width, dataset_camera.height) {
        return Err(DataError::invalid(
            &path,
            format!(
                "a {}x{} camera; expected the dataset's image size, {}x{} (a sequence's own \
                 camera may differ in field of view, principal point or distortion, not in size)",
                camera.width, camera.height, dataset_camera.width, dataset_camera.height
            ),
        ));
    }
    Ok(Some(camera))
}

/// Writes `camera` as the sequence's own camera ([`SEQUENCE_CAMERA_FILE`] in `seq_dir`),
/// atomically.
///
/// # Errors
/// [`DataError::Io`] when the file cannot be written.
pub fn write_sequence_camera(seq_dir: &Path, camera: &Camera) -> Result<(), DataError> {
    #[derive(Serialize)]
    struct File {
        camera: meta_toml::CameraRepr,
    }
    let body = toml::to_string(&File {
        camera: meta_toml::CameraRepr::of(camera),
    })
    .map_err(|e| DataError::invalid(seq_dir, format!("cannot write the camera: {e}")))?;
    let text = format!(
        "# endoloc sequence camera: this sequence's scope (intrinsics in pixels), at the dataset's image size\n{body}"
    );
    crate::write_atomic(&seq_dir.join(SEQUENCE_CAMERA_FILE), text.as_bytes())
}

/// `dataset.toml` as stored: `[camera]` holds the [`Camera`], `model = "pinhole"` and the mask.
mod meta_toml {
    use crate::dataset::meta::DatasetMeta;
    use endoloc_geometry::{Camera, Distortion};
    use serde::{Deserialize, Serialize};

    fn pinhole() -> String {
        "pinhole".to_string()
    }

    /// The camera model, refused here (so the error points at its line) unless `pinhole`.
    fn pinhole_model<'de, D: serde::Deserializer<'de>>(d: D) -> Result<String, D::Error> {
        let model = String::deserialize(d)?;
        if model != "pinhole" {
            return Err(serde::de::Error::custom(format!(
                "camera model {model:?} is not supported; expected \"pinhole\" (lens distortion goes in [camera.distortion])"
            )));
        }
        Ok(model)
    }

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(super) struct CameraRepr {
        #[serde(default = "pinhole", deserialize_with = "pinhole_model")]
        model: String,
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        mask: Option<String>,
        #[serde(default, skip_serializing_if = "Distortion::is_none")]
        distortion: Distortion,
    }

    impl CameraRepr {
        /// The camera (the mask aside).
        pub(super) fn camera(&self) -> Camera {
            Camera {
                width: self.width,
                height: self.height,
                fx: self.fx,
                fy: self.fy,
                cx: self.cx,
                cy: self.cy,
                distortion: self.distortion,
            }
        }

        /// The table of `camera`, without a mask.
        pub(super) fn of(c: &Camera) -> Self {
            CameraRepr {
                model: pinhole(),
                width: c.width,
                height: c.height,
                fx: c.fx,
                fy: c.fy,
                cx: c.cx,
                cy: c.cy,
                mask: None,
                distortion: c.distortion,
            }
        }
    }

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(super) struct MetaRepr {
        name: String,
        format_version: u32,
        units: String,
        #[serde(default)]
        source: toml::Table,
        camera: CameraRepr,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        simulation: Option<toml::Table>,
    }

    impl TryFrom<MetaRepr> for DatasetMeta {
        type Error = String;
        fn try_from(r: MetaRepr) -> Result<Self, String> {
            Ok(DatasetMeta {
                name: r.name,
                format_version: r.format_version,
                units: r.units,
                source: r.source,
                camera: r.camera.camera(),
                mask: r.camera.mask,
                simulation: r.simulation,
            })
        }
    }

    impl From<DatasetMeta> for MetaRepr {
        fn from(m: DatasetMeta) -> Self {
            MetaRepr {
                name: m.name,
                format_version: m.format_version,
                units: m.units,
                source: m.source,
                camera: CameraRepr {
                    mask: m.mask,
                    ..CameraRepr::of(&m.camera)
                },
                simulation: m.simulation,
            }
        }
    }
}
