//! `endoloc features`: SURF keypoints of one image — count, keypoint file, overlay picture.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use endoloc_eval::{refuse_existing, write_atomic};
use endoloc_features::{Feature, Keypoint, SurfConfig, draw, io};
use serde::Serialize;

/// Detect SURF keypoints in an image: print the count, optionally write the keypoints (CSV or
/// JSON, by extension) and an overlay picture (circles of radius 2.5σ with an orientation line;
/// green = dark blob, magenta = bright blob). Existing output files are kept unless --force.
///
/// Defaults are the paper's MATLAB settings: MetricThreshold 200, NumOctaves 4,
/// NumScaleLevels 6 (same units as MATLAB/OpenCV on 8-bit images).
///
/// Examples:
///
///   endoloc features frame.png --overlay frame_surf.png
///
///   endoloc features frame.png --keypoints kp.csv --threshold 400 --upright
///
///   endoloc features frame.png --keypoints kp.json --descriptors --extended
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Input image (any format the `image` crate reads; colour is converted to grey).
    image: PathBuf,

    /// Write the image with the keypoints drawn (PNG).
    #[arg(long, value_name = "PNG")]
    overlay: Option<PathBuf>,

    /// Write the keypoints: `.csv` (x,y,scale,orientation_rad,response,laplacian,octave; pixels,
    /// origin at the top-left pixel's centre) or `.json`.
    #[arg(long, value_name = "FILE")]
    keypoints: Option<PathBuf>,

    /// Include the descriptors in the JSON keypoint file.
    #[arg(long, requires = "keypoints")]
    descriptors: bool,

    /// Detector settings from a TOML file (fields of SurfConfig); flags below override it.
    #[arg(long, value_name = "TOML")]
    config: Option<PathBuf>,

    /// Hessian threshold (MATLAB MetricThreshold). [default: 200]
    #[arg(long)]
    threshold: Option<f32>,

    /// Number of octaves (MATLAB NumOctaves). [default: 4]
    #[arg(long)]
    octaves: Option<usize>,

    /// Filter sizes per octave (MATLAB NumScaleLevels). [default: 6]
    #[arg(long)]
    scale_levels: Option<usize>,

    /// Sampling step of the first octave in pixels. [default: 1]
    #[arg(long)]
    initial_step: Option<usize>,

    /// U-SURF: no orientation (0 = along +x).
    #[arg(long)]
    upright: bool,

    /// 128-d descriptors instead of 64-d.
    #[arg(long)]
    extended: bool,

    /// Use one thread.
    #[arg(long)]
    single_thread: bool,

    /// Replace --overlay and --keypoints files that already exist.
    #[arg(long)]
    force: bool,
}

/// Validated run settings.
struct Run {
    image: PathBuf,
    overlay: Option<PathBuf>,
    keypoints: Option<(PathBuf, Format)>,
    descriptors: bool,
    surf: SurfConfig,
}

#[derive(Clone, Copy)]
enum Format {
    Csv,
    Json,
}

impl Args {
    fn validate(self) -> Result<Run> {
        let mut surf = match &self.config {
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("reading {}", path.display()))?;
                toml::from_str::<SurfConfig>(&text)
                    .with_context(|| format!("parsing {} as SurfConfig", path.display()))?
            }
            None => SurfConfig::default(),
        };
        if let Some(t) = self.threshold {
            surf.threshold = t;
        }
        if let Some(o) = self.octaves {
            surf.octaves = o;
        }
        if let Some(l) = self.scale_levels {
            surf.scale_levels = l;
        }
        if let Some(s) = self.initial_step {
            surf.initial_step = s;
        }
        surf.upright |= self.upright;
        surf.extended |= self.extended;
        if self.single_thread {
            surf.parallel = false;
        }
        surf.validate()?;
        let keypoints = match self.keypoints {
            Some(p) => {
                let ext = p
                    .extension()
                    .and_then(|e| e.to_str())
                    .map(str::to_ascii_lowercase);
                let format = match ext.as_deref() {
                    Some("csv") => Format::Csv,
                    Some("json") => Format::Json,
                    _ => bail!(
                        "--keypoints {}: expected a .csv or .json file name",
                        p.display()
                    ),
                };
                if self.descriptors && matches!(format, Format::Csv) {
                    bail!("--descriptors needs a .json keypoint file (CSV holds keypoints only)");
                }
                Some((p, format))
            }
            None => None,
        };
        if let Some(p) = &self.overlay
            && !p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            bail!("--overlay {}: expected a .png file name", p.display());
        }
        if self.overlay.is_some() && self.overlay == keypoints.as_ref().map(|(p, _)| p.clone()) {
            bail!("--overlay and --keypoints name the same file; give two files");
        }
        let outputs: Vec<&PathBuf> = self
            .overlay
            .iter()
            .chain(keypoints.iter().map(|(p, _)| p))
            .collect();
        refuse_existing(&outputs, self.force)?;
        Ok(Run {
            image: self.image,
            overlay: self.overlay,
            keypoints,
            descriptors: self.descriptors,
            surf,
        })
    }
}

#[derive(Serialize)]
struct JsonOut<'a> {
    image: String,
    width: u32,
    height: u32,
    config: &'a SurfConfig,
    keypoints: Vec<&'a Keypoint>,
    #[serde(skip_serializing_if = "Option::is_none")]
    descriptors: Option<Vec<&'a [f32]>>,
}

/// Runs `endoloc features`.
pub fn run(args: Args) -> Result<()> {
    let run = args.validate()?;
    let grey = image::open(&run.image)
        .with_context(|| format!("reading image {}", run.image.display()))?
        .to_luma8();
    let surf = run.surf.clone().init()?;
    let start = Instant::now();
    let features: Vec<Feature> = surf
        .detect_and_describe(&grey)
        .with_context(|| format!("detecting SURF keypoints in {}", run.image.display()))?;
    let elapsed_ms = start.elapsed().as_secs_f64() * 1e3;
    println!(
        "{}: {} × {} px, {} keypoints (threshold {}, {} octaves, {} scale levels{}{}) in {:.1} ms",
        run.image.display(),
        grey.width(),
        grey.height(),
        features.len(),
        run.surf.threshold,
        run.surf.octaves,
        run.surf.scale_levels,
        if run.surf.upright { ", upright" } else { "" },
        if run.surf.extended { ", 128-d" } else { "" },
        elapsed_ms
    );
    let keypoints: Vec<Keypoint> = features.iter().map(|f| f.keypoint).collect();
    if let Some((path, format)) = &run.keypoints {
        let text = match format {
            Format::Csv => io::keypoints_to_csv(&keypoints),
            Format::Json => serde_json::to_string_pretty(&JsonOut {
                image: run.image.display().to_string(),
                width: grey.width(),
                height: grey.height(),
                config: &run.surf,
                keypoints: keypoints.iter().collect(),
                descriptors: run
                    .descriptors
                    .then(|| features.iter().map(|f| f.descriptor.as_slice()).collect()),
            })?,
        };
        write_file(path, text.as_bytes())?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &run.overlay {
        let picture = draw::draw_keypoints(&grey, &keypoints);
        let mut png = Vec::new();
        picture
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .with_context(|| format!("encoding overlay {}", path.display()))?;
        write_file(path, &png)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn create_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating folder {}", dir.display()))?;
    }
    Ok(())
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    create_parent(path)?;
    Ok(write_atomic(path, bytes)?)
}
