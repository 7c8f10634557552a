//! Exports of a [`Map`] for other tools: PLY point clouds and a COLMAP text model.

use std::fmt::Write as _;
use std::path::Path;

use endoloc_data::Sequence;

use crate::LocalizeError;
use crate::map::{Map, ZoneMap};
use crate::map_io::write_atomic;

/// Writes one zone's map points as an ASCII PLY (`x y z` in mm, world frame).
///
/// # Errors
/// [`LocalizeError::File`] on I/O errors.
pub fn write_zone_ply(zone: &ZoneMap, path: &Path) -> Result<(), LocalizeError> {
    let mut s = String::new();
    let _ = write!(
        s,
        "ply\nformat ascii 1.0\ncomment endoloc zone {} map points, mm, world frame\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         property float reprojection_rms_px\nend_header\n",
        zone.zone,
        zone.points.len()
    );
    for p in &zone.points {
        let _ = writeln!(
            s,
            "{} {} {} {}",
            p.p_world.x, p.p_world.y, p.p_world.z, p.reprojection_rms_px as f32
        );
    }
    write_atomic(path, s.as_bytes())
}

/// Writes the whole map as a COLMAP text model (`cameras.txt`, `images.txt`,
/// `points3D.txt`) into `dir`: one PINHOLE camera, one image per training frame used by a zone
/// map (COLMAP poses are world-to-camera, so `T_cw = T_wc⁻¹` is written), one 3-D point per map
/// point with its track.
///
/// # Errors
/// [`LocalizeError::File`] on I/O errors.
pub fn write_colmap_text(map: &Map, train: &Sequence, dir: &Path) -> Result<(), LocalizeError> {
    std::fs::create_dir_all(dir).map_err(|e| LocalizeError::File {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let c = &map.camera;
    let cameras = format!(
        "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n\
         1 PINHOLE {} {} {} {} {} {}\n",
        c.width,
        c.height,
        c.fx,
        c.fy,
        c.cx + 0.5, // COLMAP: origin at the top-left corner, ours at the first pixel's centre
        c.cy + 0.5
    );
    write_atomic(&dir.join("cameras.txt"), cameras.as_bytes())?;

    // Images: every frame used by a zone map; 2-D points listed per image.
    let mut frames: Vec<usize> = map
        .zones
        .iter()
        .flat_map(|z| z.frames.iter().copied())
        .collect();
    frames.sort_unstable();
    frames.dedup();
    let image_id = |f: usize| frames.binary_search(&f).map(|i| i + 1).unwrap_or(0);
    let mut per_image: Vec<Vec<(f64, f64, usize)>> = vec![Vec::new(); frames.len()];
    let mut points = String::from(
        "# 3D point list with one line of data per point:\n\
         #   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n",
    );
    let mut pid = 0usize;
    for z in &map.zones {
        for p in &z.points {
            pid += 1;
            let _ = write!(
                points,
                "{pid} {} {} {} 200 120 110 {}",
                p.p_world.x, p.p_world.y, p.p_world.z, p.reprojection_rms_px
            );
            for (f, px) in &p.observations {
                let id = image_id(*f);
                if id == 0 {
                    continue;
                }
                let list = &mut per_image[id - 1];
                let _ = write!(points, " {id} {}", list.len());
                list.push((px.x, px.y, pid));
            }
            points.push('\n');
        }
    }
    let mut images = String::from(
        "# Image list with two lines of data per image:\n\
         #   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n",
    );
    for (i, &f) in frames.iter().enumerate() {
        let Some(sp) = train.poses.get(f) else {
            continue;
        };
        let t_cw = sp.pose.inverse();
        let q = t_cw.rotation;
        let t = t_cw.translation.vector;
        let name = train
            .image_paths
            .get(f)
            .and_then(|p| p.file_name())
            .map_or_else(
                || format!("{f:06}.png"),
                |n| n.to_string_lossy().into_owned(),
            );
        let _ = writeln!(
            images,
            "{} {} {} {} {} {} {} {} 1 {name}",
            i + 1,
            q.w,
            q.i,
            q.j,
            q.k,
            t.x,
            t.y,
            t.z
        );
        // COLMAP's pixel convention puts the origin at the top-left corner: add 0.5.
        let line: Vec<String> = per_image[i]
            .iter()
            .map(|(x, y, id)| format!("{} {} {id}", x + 0.5, y + 0.5))
            .collect();
        let _ = writeln!(images, "{}", line.join(" "));
    }
    write_atomic(&dir.join("images.txt"), images.as_bytes())?;
    write_atomic(&dir.join("points3D.txt"), points.as_bytes())
}
