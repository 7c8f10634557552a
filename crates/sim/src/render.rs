//! Software renderer for colonoscopy frames.
//!
//! Two passes per frame:
//! 1. **Visibility**: the triangles of the colon within `[s − view_behind, s + view_ahead]` of
//!    the scope are clipped at the near plane and rasterised into a visibility buffer holding,
//!    per pixel, the nearest triangle and its perspective-correct barycentric coordinates.
//!    Only that stretch can be seen from inside the lumen; beyond it the inverse-square fall-off
//!    leaves the lumen black anyway.
//! 2. **Shading**, once per pixel: position, normal and surface coordinates are interpolated;
//!    albedo and micro-relief come from the [`MucosaAtlas`]; the light sits at the scope tip
//!    (inverse-square fall-off, a cosine LED lobe), with a wet specular lobe, vignetting, a soft
//!    shoulder tone curve, display gamma and optional sensor noise.
//!
//! The camera is an ideal pinhole in OpenCV axes; pixel `(u, v)`'s centre is at `(u, v)`.
//! Depth is the z coordinate (along the optical axis) of the visible surface, mm.

use endoloc_geometry::{Camera, Pose};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::appearance::{MucosaAtlas, splitmix64};
use crate::change::ChangedLook;
use crate::colon::ColonModel;

/// Lighting, optics and sensor parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderConfig {
    /// Near clipping distance, mm.
    pub near_mm: f64,
    /// Stretch of colon drawn ahead of the scope, mm of arc length.
    pub view_ahead_mm: f64,
    /// Stretch of colon drawn behind the scope, mm of arc length.
    pub view_behind_mm: f64,
    /// Light power: a white wall facing the scope at 20 mm reaches linear intensity
    /// `light_power / 400` before tone mapping.
    pub light_power: f64,
    /// Ambient light (fraction of albedo), keeps the far lumen from pure black.
    pub ambient: f64,
    /// Strength of the wet specular highlight.
    pub specular: f64,
    /// Specular exponent; rounded to a power of two between 2 and 256.
    pub shininess: u32,
    /// Strength of the micro-relief (bump) shading.
    pub bump: f64,
    /// Vignetting: intensity × `1 − vignetting · r²` with `r` = 1 at the image corner.
    pub vignetting: f64,
    /// Sensor noise standard deviation, 8-bit grey levels (0 = none).
    pub noise_sigma: f64,
    /// Sub-frames averaged for motion blur (1 = none; even values are rounded up).
    pub motion_blur_samples: usize,
    /// Exposure time as a fraction of the frame interval (for motion blur).
    pub shutter_fraction: f64,
    /// Motion blur as the camera's travel during an exposure, mm: the sub-frames span this
    /// much of the camera's path around each frame (at most one frame interval), whatever
    /// the frames' spacing. 0 (default): `shutter_fraction` of the frame interval, so that a
    /// pass sampled sparsely (a few millimetres between frames) blurs over millimetres.
    #[serde(skip_serializing_if = "is_zero")]
    pub motion_blur_mm: f64,
    /// Radius of a circular field stop centred on the principal point, as a fraction of the
    /// half image diagonal (0 = none): pixels outside it are black, as on real endoscopes.
    pub field_stop: f64,
    /// Black border: this many columns on the left and on the right of every frame are
    /// black (0 = none).
    pub black_border_px: u32,
    /// Auto-exposure changes: each frame's brightness is multiplied by `exp(j · n)` with `n`
    /// standard normal from the frame's noise seed (0 = none).
    pub exposure_jitter: f64,
}

impl Default for RenderConfig {
    fn default() -> Self {
        RenderConfig {
            near_mm: 0.5,
            view_ahead_mm: 260.0,
            view_behind_mm: 40.0,
            light_power: 420.0,
            ambient: 0.01,
            specular: 0.3,
            shininess: 32,
            bump: 0.25,
            vignetting: 0.45,
            noise_sigma: 1.5,
            motion_blur_samples: 1,
            shutter_fraction: 0.5,
            motion_blur_mm: 0.0,
            field_stop: 0.0,
            black_border_px: 0,
            exposure_jitter: 0.0,
        }
    }
}

impl RenderConfig {
    /// Checks ranges.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] naming the first bad field.
    pub fn validate(&self) -> Result<(), SimError> {
        let check = |name: &str, v: f64, ok: bool| {
            if v.is_finite() && ok {
                Ok(())
            } else {
                Err(SimError::InvalidConfig(format!(
                    "render: {name} out of range: {v}"
                )))
            }
        };
        check("near_mm", self.near_mm, self.near_mm > 0.0)?;
        check(
            "view_ahead_mm",
            self.view_ahead_mm,
            self.view_ahead_mm > 0.0,
        )?;
        check(
            "view_behind_mm",
            self.view_behind_mm,
            self.view_behind_mm >= 0.0,
        )?;
        check("light_power", self.light_power, self.light_power > 0.0)?;
        check("ambient", self.ambient, self.ambient >= 0.0)?;
        check("specular", self.specular, self.specular >= 0.0)?;
        check("bump", self.bump, self.bump >= 0.0)?;
        check(
            "vignetting",
            self.vignetting,
            (0.0..=1.0).contains(&self.vignetting),
        )?;
        check("noise_sigma", self.noise_sigma, self.noise_sigma >= 0.0)?;
        check("field_stop", self.field_stop, self.field_stop >= 0.0)?;
        check(
            "exposure_jitter",
            self.exposure_jitter,
            (0.0..=2.0).contains(&self.exposure_jitter),
        )?;
        check(
            "shutter_fraction",
            self.shutter_fraction,
            (0.0..=1.0).contains(&self.shutter_fraction),
        )?;
        check(
            "motion_blur_mm",
            self.motion_blur_mm,
            (0.0..=50.0).contains(&self.motion_blur_mm),
        )?;
        if self.motion_blur_samples == 0 || self.motion_blur_samples > 64 {
            return Err(SimError::InvalidConfig(format!(
                "render: motion_blur_samples must be 1..=64, got {}",
                self.motion_blur_samples
            )));
        }
        Ok(())
    }
}

/// One rendered frame.
#[derive(Debug, Clone)]
pub struct RenderedFrame {
    /// 8-bit RGB, row-major, `width × height × 3`.
    pub rgb: Vec<u8>,
    /// Depth along the optical axis, mm, `width × height`; 0 where nothing was hit.
    pub depth_mm: Vec<f32>,
}

/// Per-thread scratch memory reused from frame to frame (no allocation per frame once warm).
#[derive(Debug, Default)]
pub struct RenderScratch {
    inv_z: Vec<f32>,
    tri: Vec<u32>,
    l1: Vec<f32>,
    l2: Vec<f32>,
    verts: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    linear: Vec<f32>,
    depth: Vec<f32>,
}

const NO_TRI: u32 = u32::MAX;

/// Renders frames of one colon with one camera.
pub struct Renderer<'a> {
    colon: &'a ColonModel,
    atlas: &'a MucosaAtlas,
    camera: Camera,
    /// The ideal pinhole the rasteriser draws with: the camera itself, or for a distorted
    /// camera a wider pinhole of the same focal length whose image is then resampled.
    raster: Camera,
    /// For a distorted camera: per output pixel, the raster pixel its ray hits (NaN: none).
    remap: Option<Vec<[f32; 2]>>,
    cfg: RenderConfig,
    gamma_lut: Vec<u8>,
    vignette: Vec<f32>,
    /// The valid area (255) when a field stop or black border hides part of the frame.
    mask: Option<Vec<u8>>,
    /// Another light, exposure, bubbles and defocus (the test pass of a changed colon).
    look: Option<&'a ChangedLook>,
}

impl<'a> Renderer<'a> {
    /// Prepares a renderer.
    ///
    /// # Errors
    /// [`SimError::InvalidConfig`] for an invalid camera or render config, or a distorted
    /// camera whose rays reach too far from the optical axis for a pinhole raster (add a field
    /// stop).
    pub fn new(
        colon: &'a ColonModel,
        atlas: &'a MucosaAtlas,
        camera: Camera,
        cfg: RenderConfig,
    ) -> Result<Self, SimError> {
        camera.validate().map_err(SimError::InvalidConfig)?;
        cfg.validate()?;
        let gamma_lut = display_lut(1.0);
        let (w, h) = (camera.width as usize, camera.height as usize);
        let half_diag2 = ((w as f64 / 2.0).powi(2) + (h as f64 / 2.0).powi(2)).max(1e-9);
        let mut vignette = Vec::with_capacity(w * h);
        let mut mask = Vec::with_capacity(w * h);
        let stop2 = cfg.field_stop * cfg.field_stop;
        let border = cfg.black_border_px as usize;
        if 2 * border >= w {
            return Err(SimError::InvalidConfig(format!(
                "render: black_border_px = {border} leaves nothing of a {w}-pixel-wide image"
            )));
        }
        for y in 0..h {
            for x in 0..w {
                let dx = x as f64 - camera.cx;
                let dy = y as f64 - camera.cy;
                let r2 = (dx * dx + dy * dy) / half_diag2;
                let valid = (stop2 == 0.0 || r2 <= stop2) && x >= border && x < w - border;
                mask.push(if valid { 255u8 } else { 0 });
                let v = if valid {
                    (1.0 - cfg.vignetting * r2).max(0.0) as f32
                } else {
                    0.0
                };
                vignette.push(v);
            }
        }
        if !mask.contains(&255) {
            return Err(SimError::InvalidConfig(format!(
                "render: field_stop = {} leaves no pixel inside the field stop",
                cfg.field_stop
            )));
        }
        let (raster, remap) = if camera.distortion.is_none() {
            (camera, None)
        } else {
            let (raster, table) = distortion_remap(&camera, &mask)?;
            // Pixels without a ray are black and invalid.
            for (m, r) in mask.iter_mut().zip(&table) {
                if !r[0].is_finite() {
                    *m = 0;
                }
            }
            (raster, Some(table))
        };
        let has_mask = mask.contains(&0);
        Ok(Renderer {
            colon,
            atlas,
            camera,
            raster,
            remap,
            cfg,
            gamma_lut,
            vignette,
            mask: has_mask.then_some(mask),
            look: None,
        })
    }

    /// Renders with a changed look: light, exposure and white balance, gamma, glossy cover
    /// (the atlas's gloss layer), bubbles and defocus.
    pub fn with_look(mut self, look: &'a ChangedLook) -> Self {
        self.gamma_lut = display_lut(look.gamma);
        self.look = Some(look);
        self
    }

    /// The camera frames are rendered with.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The render settings.
    pub fn config(&self) -> &RenderConfig {
        &self.cfg
    }

    /// The valid area of every frame (8-bit, row-major, 255 = valid) when a field stop or a
    /// black border hides part of it; `None` when every pixel is valid.
    pub fn mask(&self) -> Option<&[u8]> {
        self.mask.as_deref()
    }

    /// Renders one frame seen from `sub_poses` (T_wc, mm), each with the arc length of the
    /// scope along the mid-line (mm). One pose renders a sharp frame; several are averaged into
    /// a motion-blurred one, and the depth map is that of the middle pose. `noise_seed` seeds
    /// the sensor noise of this frame.
    pub fn render(
        &self,
        sub_poses: &[(Pose, f64)],
        noise_seed: u64,
        scratch: &mut RenderScratch,
    ) -> RenderedFrame {
        self.render_frame(sub_poses, noise_seed, 0, scratch)
    }

    /// [`Renderer::render`] for frame `frame` of a pass: the frame index drives a changed
    /// look's exposure drift and bubbles (see [`Renderer::with_look`]); without one it is
    /// ignored.
    pub fn render_frame(
        &self,
        sub_poses: &[(Pose, f64)],
        noise_seed: u64,
        frame: usize,
        scratch: &mut RenderScratch,
    ) -> RenderedFrame {
        let n = (self.raster.width * self.raster.height) as usize;
        scratch.linear.clear();
        scratch.linear.resize(3 * n, 0.0);
        scratch.depth.clear();
        scratch.depth.resize(n, 0.0);
        let weight = 1.0 / sub_poses.len().max(1) as f32;
        let middle = sub_poses.len() / 2;
        for (k, (pose, s)) in sub_poses.iter().enumerate() {
            let (tri_range, v0) = self.rasterize(pose, *s, scratch);
            self.shade(tri_range, v0, weight, scratch);
            if k == middle {
                for (d, iz) in scratch.depth.iter_mut().zip(&scratch.inv_z) {
                    *d = if *iz > 0.0 { 1.0 / iz } else { 0.0 };
                }
            }
        }
        if let Some(table) = &self.remap {
            self.resample(table, scratch);
        }
        if let Some(look) = self.look {
            let (w, h) = (self.camera.width as usize, self.camera.height as usize);
            look.draw_bubbles(&mut scratch.linear, w, h, frame);
            look.defocus(&mut scratch.linear, w, h);
        }
        let rgb = self.finish(noise_seed, frame, scratch);
        RenderedFrame {
            rgb,
            depth_mm: scratch.depth.clone(),
        }
    }

    /// Visibility pass. Returns the triangle index range drawn and the first cached vertex.
    fn rasterize(
        &self,
        pose: &Pose,
        s: f64,
        scratch: &mut RenderScratch,
    ) -> (std::ops::Range<usize>, usize) {
        let (w, h) = (self.raster.width as usize, self.raster.height as usize);
        let n = w * h;
        scratch.inv_z.clear();
        scratch.inv_z.resize(n, 0.0);
        scratch.tri.clear();
        scratch.tri.resize(n, NO_TRI);
        scratch.l1.resize(n, 0.0);
        scratch.l2.resize(n, 0.0);

        let mesh = &self.colon.mesh;
        let chunks = mesh.chunks_between(s - self.cfg.view_behind_mm, s + self.cfg.view_ahead_mm);
        let tri_range = mesh.triangle_range(chunks.clone());
        let vrange = mesh.vertex_range(chunks);
        let v0 = vrange.start;

        // Vertex cache in the camera frame (f32 is ample inside a 300 mm stretch).
        let r_cw: Matrix3<f64> = pose.rotation.inverse().to_rotation_matrix().into_inner();
        let t_wc: Vector3<f64> = pose.translation.vector;
        scratch.verts.clear();
        scratch.normals.clear();
        for v in vrange {
            let p = r_cw * (mesh.positions[v].coords - t_wc);
            scratch.verts.push([p.x as f32, p.y as f32, p.z as f32]);
            let nv = r_cw * mesh.normals[v].cast::<f64>();
            scratch
                .normals
                .push([nv.x as f32, nv.y as f32, nv.z as f32]);
        }

        let near = self.cfg.near_mm as f32;
        let cam = Intrinsics::from(&self.raster);
        let mut buf = VisBuffer {
            w,
            h,
            inv_z: &mut scratch.inv_z,
            tri: &mut scratch.tri,
            l1: &mut scratch.l1,
            l2: &mut scratch.l2,
        };
        const E: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for ti in tri_range.clone() {
            let t = mesh.triangles[ti];
            let p = t.map(|v| scratch.verts[v as usize - v0]);
            let in_front = p.iter().filter(|q| q[2] >= near).count();
            match in_front {
                0 => continue,
                3 => buf.draw(&cam, p, E, ti as u32),
                _ => {
                    // Clip the polygon against z = near (Sutherland–Hodgman), carrying the
                    // barycentric coordinates of the original triangle.
                    let mut poly: [([f32; 3], [f32; 3]); 4] = [([0.0; 3], [0.0; 3]); 4];
                    let mut m = 0;
                    for i in 0..3 {
                        let j = (i + 1) % 3;
                        let (a, b) = (p[i], p[j]);
                        let (ia, ib) = (a[2] >= near, b[2] >= near);
                        if ia {
                            poly[m] = (a, E[i]);
                            m += 1;
                        }
                        if ia != ib {
                            let f = (near - a[2]) / (b[2] - a[2]);
                            let lerp = |x: [f32; 3], y: [f32; 3]| {
                                [
                                    x[0] + (y[0] - x[0]) * f,
                                    x[1] + (y[1] - x[1]) * f,
                                    x[2] + (y[2] - x[2]) * f,
                                ]
                            };
                            let mut q = lerp(a, b);
                            q[2] = near;
                            poly[m] = (q, lerp(E[i], E[j]));
                            m += 1;
                        }
                    }
                    for k in 1..m.saturating_sub(1) {
                        buf.draw(
                            &cam,
                            [poly[0].0, poly[k].0, poly[k + 1].0],
                            [poly[0].1, poly[k].1, poly[k + 1].1],
                            ti as u32,
                        );
                    }
                }
            }
        }
        (tri_range, v0)
    }

    /// Shading pass: adds `weight ×` linear RGB of every covered pixel to `scratch.linear`.
    fn shade(
        &self,
        _tri_range: std::ops::Range<usize>,
        v0: usize,
        weight: f32,
        scratch: &mut RenderScratch,
    ) {
        let mesh = &self.colon.mesh;
        let cfg = &self.cfg;
        let look = self.look;
        let (power, specular) = match look {
            Some(l) => (
                cfg.light_power as f32 * l.light_power,
                cfg.specular as f32 * l.specular,
            ),
            None => (cfg.light_power as f32, cfg.specular as f32),
        };
        let ambient = cfg.ambient as f32;
        let squarings = cfg.shininess.clamp(2, 256).ilog2();
        let bump = cfg.bump as f32;
        let bump_k = bump * 0.6;
        let atlas = self.atlas;
        // Per-triangle data, reused while consecutive pixels hit the same triangle.
        let mut cached_tid = NO_TRI;
        let mut tri_data = TriangleShading::default();
        for (i, &tid) in scratch.tri.iter().enumerate() {
            if tid == NO_TRI {
                continue;
            }
            let t = mesh.triangles[tid as usize];
            let idx = t.map(|v| v as usize - v0);
            if tid != cached_tid {
                cached_tid = tid;
                tri_data = TriangleShading::new(mesh, t, idx, &scratch.verts);
            }
            let (l1, l2) = (scratch.l1[i], scratch.l2[i]);
            let l0 = 1.0 - l1 - l2;
            let lam = [l0, l1, l2];
            let mut p = [0f32; 3];
            let mut nrm = [0f32; 3];
            for k in 0..3 {
                let v = scratch.verts[idx[k]];
                let nv = scratch.normals[idx[k]];
                for c in 0..3 {
                    p[c] += lam[k] * v[c];
                    nrm[c] += lam[k] * nv[c];
                }
            }
            let s = l0 * tri_data.s[0] + l1 * tri_data.s[1] + l2 * tri_data.s[2];
            let theta = tri_data.theta0 + l1 * tri_data.dtheta[0] + l2 * tri_data.dtheta[1];
            let (tex, gs, gt) = atlas.sample_with_gradient(s, theta);

            // Micro-relief: perturb the normal along the surface directions of s and θ.
            let mut n = normalize(nrm);
            if bump > 0.0 && tri_data.has_frame {
                // Height gradient per mm along each unit surface direction.
                let (a, b) = (bump_k * gs * tri_data.inv_ls, bump_k * gt * tri_data.inv_lt);
                for (c, nc) in n.iter_mut().enumerate() {
                    *nc -= a * tri_data.dir_s[c] + b * tri_data.dir_t[c];
                }
                n = normalize(n);
            }

            let d2 = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).max(1e-6);
            let d = d2.sqrt();
            let l = [-p[0] / d, -p[1] / d, -p[2] / d];
            let ndl = (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]).abs();
            let mut lobe = (p[2] / d).max(0.0);
            if let Some(l) = look
                && l.beam_exponent != 1.0
            {
                lobe = lobe.powf(l.beam_exponent);
            }
            let irradiance = power * lobe / d2;
            let mut spec = ndl;
            for _ in 0..squarings {
                spec *= spec;
            }
            let mut spec = specular * spec * irradiance;
            if let Some(l) = look {
                spec *= atlas.gloss_at(s, theta);
                let n2 = ndl * ndl;
                spec += l.sheen * n2 * n2 * irradiance;
            }
            let diffuse = ndl * irradiance + ambient;
            for (c, t) in tex.iter().take(3).enumerate() {
                scratch.linear[3 * i + c] += weight * (t * diffuse + spec);
            }
        }
    }

    /// Resamples the raster's linear image and depth to the distorted camera's pixels through
    /// `table`: bilinear (depth: nearest where the neighbours disagree by more than 2 %, at a
    /// fold's silhouette).
    fn resample(&self, table: &[[f32; 2]], scratch: &mut RenderScratch) {
        let (rw, rh) = (self.raster.width as usize, self.raster.height as usize);
        let mut linear = vec![0.0f32; 3 * table.len()];
        let mut depth = vec![0.0f32; table.len()];
        for (i, &[x, y]) in table.iter().enumerate() {
            if !x.is_finite() {
                continue;
            }
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let (x0, y0) = (x0 as usize, y0 as usize);
            let (x1, y1) = ((x0 + 1).min(rw - 1), (y0 + 1).min(rh - 1));
            for c in 0..3 {
                let at = |xx: usize, yy: usize| scratch.linear[3 * (yy * rw + xx) + c];
                let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
                let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
                linear[3 * i + c] = top * (1.0 - fy) + bottom * fy;
            }
            let d = |xx: usize, yy: usize| scratch.depth[yy * rw + xx];
            let corners = [d(x0, y0), d(x1, y0), d(x0, y1), d(x1, y1)];
            let (lo, hi) = corners
                .iter()
                .fold((f32::MAX, 0.0f32), |(lo, hi), &z| (lo.min(z), hi.max(z)));
            // Bilinear on a smooth surface; nearest across a fold's silhouette.
            depth[i] = if lo > 0.0 && hi < 1.02 * lo {
                let top = corners[0] * (1.0 - fx) + corners[1] * fx;
                let bottom = corners[2] * (1.0 - fx) + corners[3] * fx;
                top * (1.0 - fy) + bottom * fy
            } else {
                let (nx, ny) = ((x + 0.5) as usize, (y + 0.5) as usize);
                d(nx.min(rw - 1), ny.min(rh - 1))
            };
        }
        scratch.linear = linear;
        scratch.depth = depth;
    }

    /// Tone curve, vignetting, gamma and sensor noise → 8-bit RGB.
    fn finish(&self, noise_seed: u64, frame: usize, scratch: &RenderScratch) -> Vec<u8> {
        let sigma = self.cfg.noise_sigma as f32;
        let lut = &self.gamma_lut;
        let gain = if self.cfg.exposure_jitter > 0.0 {
            // Box–Muller from two 32-bit uniforms of the frame's seed.
            let h = splitmix64(noise_seed ^ 0xE7F0_5E2E);
            let u1 = ((h >> 32) as f64 + 1.0) / 4_294_967_297.0;
            let u2 = (h & 0xFFFF_FFFF) as f64 / 4_294_967_296.0;
            let n = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            (self.cfg.exposure_jitter * n).exp() as f32
        } else {
            1.0
        };
        let (gain, white_balance) = match self.look {
            Some(l) => (gain * l.gain_at(frame), l.white_balance),
            None => (gain, [1.0; 3]),
        };
        let mut out = vec![0u8; scratch.linear.len()];
        for (i, px) in out.chunks_exact_mut(3).enumerate() {
            let v = self.vignette[i] * gain;
            let h = if sigma > 0.0 {
                splitmix64(noise_seed ^ (i as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93))
            } else {
                0
            };
            for (c, out) in px.iter_mut().enumerate() {
                // × 1 without a changed look: exact, the same bytes.
                let x = scratch.linear[3 * i + c] * v * white_balance[c];
                // Soft shoulder: linear near 0, saturating smoothly towards 1.
                let y = x * (1.0 + x * 0.25) / (1.0 + x);
                let g = lut[((y.clamp(0.0, 1.0)) * 4095.0) as usize] as f32;
                let g = if sigma > 0.0 {
                    // Irwin–Hall(4) of 16-bit uniforms: mean 2, variance 1/3.
                    let bits = (h >> (c * 16)) & 0xFFFF;
                    let bits2 = (h.rotate_left(21 + 8 * c as u32)) & 0xFFFF;
                    let u = (bits as f32 + bits2 as f32) / 65535.0;
                    let h2 = splitmix64(h ^ c as u64);
                    let u2 = ((h2 & 0xFFFF) as f32 + ((h2 >> 16) & 0xFFFF) as f32) / 65535.0;
                    g + sigma * (u + u2 - 2.0) * 1.732_050_8
                } else {
                    g
                };
                *out = (g + 0.5).clamp(0.0, 255.0) as u8; // round half up, no libm call
            }
        }
        out
    }
}

/// The display curve: `x^gamma` then the sRGB transfer curve, 12 bits in, 8 bits out.
fn display_lut(gamma: f64) -> Vec<u8> {
    (0..4096)
        .map(|i| {
            let x = i as f64 / 4095.0;
            let x = if gamma == 1.0 { x } else { x.powf(gamma) };
            // sRGB transfer curve.
            let y = if x <= 0.003_130_8 {
                12.92 * x
            } else {
                1.055 * x.powf(1.0 / 2.4) - 0.055
            };
            (y * 255.0).round().clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// Largest raster side for a distorted camera, pixels.
const MAX_RASTER_SIDE: u32 = 4096;

/// The pinhole raster and the per-pixel resampling table of a distorted `camera`: every pixel
/// valid in `mask` is undistorted to its ray; the raster is an ideal pinhole with the same
/// focal lengths, centred, just wide enough for all those rays.
fn distortion_remap(camera: &Camera, mask: &[u8]) -> Result<(Camera, Vec<[f32; 2]>), SimError> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut rays = Vec::with_capacity(w * h);
    let (mut ax, mut ay) = (0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let xd = nalgebra::Vector2::new(
                (x as f64 - camera.cx) / camera.fx,
                (y as f64 - camera.cy) / camera.fy,
            );
            // Rays beyond 80° from the axis cannot be drawn by a pinhole.
            let ray = (mask[y * w + x] != 0)
                .then(|| camera.distortion.undistort(xd))
                .flatten()
                .filter(|r| r.norm() < 80f64.to_radians().tan());
            if let Some(r) = ray {
                ax = ax.max(r.x.abs());
                ay = ay.max(r.y.abs());
            }
            rays.push(ray);
        }
    }
    let rw = (2.0 * (ax * camera.fx).ceil() + 4.0) as u32;
    let rh = (2.0 * (ay * camera.fy).ceil() + 4.0) as u32;
    if rw > MAX_RASTER_SIDE || rh > MAX_RASTER_SIDE {
        return Err(SimError::InvalidConfig(format!(
            "the distorted camera sees too far off its axis for the rasteriser ({rw}×{rh} \
             pinhole pixels needed, at most {MAX_RASTER_SIDE}): narrow the field of view or \
             add a field stop (render.field_stop)"
        )));
    }
    let raster = Camera {
        width: rw,
        height: rh,
        fx: camera.fx,
        fy: camera.fy,
        cx: (rw as f64 - 1.0) / 2.0,
        cy: (rh as f64 - 1.0) / 2.0,
        distortion: endoloc_geometry::Distortion::None,
    };
    let table = rays
        .iter()
        .map(|r| match r {
            Some(r) => [
                (r.x * raster.fx + raster.cx) as f32,
                (r.y * raster.fy + raster.cy) as f32,
            ],
            None => [f32::NAN, f32::NAN],
        })
        .collect();
    Ok((raster, table))
}

/// Per-triangle shading data: surface coordinates at the vertices and the unit surface
/// directions of increasing `s` and `θ` (camera frame).
#[derive(Default, Clone, Copy)]
struct TriangleShading {
    s: [f32; 3],
    theta0: f32,
    /// θ of vertices 1 and 2 relative to vertex 0, unwrapped to (−π, π].
    dtheta: [f32; 2],
    has_frame: bool,
    dir_s: [f32; 3],
    dir_t: [f32; 3],
    /// 1 / ‖∂p/∂s‖ (s-mm per surface-mm) and 1 / ‖∂p/∂θ‖ (rad per mm).
    inv_ls: f32,
    inv_lt: f32,
}

impl TriangleShading {
    fn new(
        mesh: &crate::colon::SurfaceMesh,
        t: [u32; 3],
        idx: [usize; 3],
        verts: &[[f32; 3]],
    ) -> Self {
        let s = t.map(|v| mesh.s_mm[v as usize]);
        let theta0 = mesh.theta[t[0] as usize];
        let unwrap = |th: f32| {
            let mut d = th - theta0;
            if d > std::f32::consts::PI {
                d -= std::f32::consts::TAU;
            } else if d < -std::f32::consts::PI {
                d += std::f32::consts::TAU;
            }
            d
        };
        let (dt1, dt2) = (
            unwrap(mesh.theta[t[1] as usize]),
            unwrap(mesh.theta[t[2] as usize]),
        );
        let mut out = TriangleShading {
            s,
            theta0,
            dtheta: [dt1, dt2],
            ..Default::default()
        };
        let a = verts[idx[0]];
        let e1 = sub(verts[idx[1]], a);
        let e2 = sub(verts[idx[2]], a);
        let (ds1, ds2) = (s[1] - s[0], s[2] - s[0]);
        let det = ds1 * dt2 - ds2 * dt1;
        if det.abs() > 1e-9 {
            // [e1 e2] = [∂p/∂s ∂p/∂θ] · [[ds1 ds2] [dt1 dt2]]
            let inv = 1.0 / det;
            let ps = [
                (e1[0] * dt2 - e2[0] * dt1) * inv,
                (e1[1] * dt2 - e2[1] * dt1) * inv,
                (e1[2] * dt2 - e2[2] * dt1) * inv,
            ];
            let pt = [
                (e2[0] * ds1 - e1[0] * ds2) * inv,
                (e2[1] * ds1 - e1[1] * ds2) * inv,
                (e2[2] * ds1 - e1[2] * ds2) * inv,
            ];
            let (ls, lt) = (norm(ps).max(1e-6), norm(pt).max(1e-6));
            out.has_frame = true;
            out.dir_s = ps.map(|x| x / ls);
            out.dir_t = pt.map(|x| x / lt);
            out.inv_ls = 1.0 / ls;
            out.inv_lt = 1.0 / lt;
        }
        out
    }
}

#[derive(Clone, Copy)]
struct Intrinsics {
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
}

impl From<&Camera> for Intrinsics {
    fn from(c: &Camera) -> Self {
        Intrinsics {
            fx: c.fx as f32,
            fy: c.fy as f32,
            cx: c.cx as f32,
            cy: c.cy as f32,
        }
    }
}

struct VisBuffer<'b> {
    w: usize,
    h: usize,
    inv_z: &'b mut [f32],
    tri: &'b mut [u32],
    l1: &'b mut [f32],
    l2: &'b mut [f32],
}

impl VisBuffer<'_> {
    /// Rasterises a triangle with camera-frame vertices `p` (all `z ≥ near`) whose
    /// barycentric coordinates in the original triangle are `bary`.
    #[inline]
    fn draw(&mut self, cam: &Intrinsics, p: [[f32; 3]; 3], bary: [[f32; 3]; 3], tid: u32) {
        let iz = [1.0 / p[0][2], 1.0 / p[1][2], 1.0 / p[2][2]];
        let x = [
            cam.fx * p[0][0] * iz[0] + cam.cx,
            cam.fx * p[1][0] * iz[1] + cam.cx,
            cam.fx * p[2][0] * iz[2] + cam.cx,
        ];
        let y = [
            cam.fy * p[0][1] * iz[0] + cam.cy,
            cam.fy * p[1][1] * iz[1] + cam.cy,
            cam.fy * p[2][1] * iz[2] + cam.cy,
        ];
        let area = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
        if !(area.abs() > 1e-12) {
            return;
        }
        let xmin = ceil_f(x[0].min(x[1]).min(x[2]).max(0.0));
        let xmax = floor_f(x[0].max(x[1]).max(x[2]).min((self.w - 1) as f32));
        let ymin = ceil_f(y[0].min(y[1]).min(y[2]).max(0.0));
        let ymax = floor_f(y[0].max(y[1]).max(y[2]).min((self.h - 1) as f32));
        if xmin > xmax || ymin > ymax {
            return;
        }
        // Normalised edge functions e_k(x, y) = a_k x + b_k y + c_k: the screen barycentric
        // of vertex k, for edges (1,2), (2,0), (0,1).
        let inv_area = 1.0 / area;
        let edge = |i: usize, j: usize| {
            let a = -(y[j] - y[i]) * inv_area;
            let b = (x[j] - x[i]) * inv_area;
            let c = ((y[j] - y[i]) * x[i] - (x[j] - x[i]) * y[i]) * inv_area;
            (a, b, c)
        };
        let e = [edge(1, 2), edge(2, 0), edge(0, 1)];
        const EPS: f32 = 1e-5;
        for yi in ymin as usize..=ymax as usize {
            let yf = yi as f32;
            let row = [
                e[0].1 * yf + e[0].2,
                e[1].1 * yf + e[1].2,
                e[2].1 * yf + e[2].2,
            ];
            let (mut lo, mut hi) = (xmin, xmax);
            let mut empty = false;
            for k in 0..3 {
                let a = e[k].0;
                let bound = (-EPS - row[k]) / a;
                if a > 0.0 {
                    lo = lo.max(ceil_f(bound.max(-1.0)));
                } else if a < 0.0 {
                    hi = hi.min(floor_f(bound.min(self.w as f32)));
                } else if row[k] < -EPS {
                    empty = true;
                }
            }
            if empty || lo > hi {
                continue;
            }
            let base = yi * self.w;
            for xi in lo as usize..=hi as usize {
                let xf = xi as f32;
                let b0 = (e[0].0 * xf + row[0]).max(0.0);
                let b1 = (e[1].0 * xf + row[1]).max(0.0);
                let b2 = (e[2].0 * xf + row[2]).max(0.0);
                let invz = b0 * iz[0] + b1 * iz[1] + b2 * iz[2];
                let idx = base + xi;
                if invz > self.inv_z[idx] {
                    self.inv_z[idx] = invz;
                    self.tri[idx] = tid;
                    let norm = 1.0 / invz;
                    let m = [b0 * iz[0] * norm, b1 * iz[1] * norm, b2 * iz[2] * norm];
                    self.l1[idx] = m[0] * bary[0][1] + m[1] * bary[1][1] + m[2] * bary[2][1];
                    self.l2[idx] = m[0] * bary[0][2] + m[1] * bary[1][2] + m[2] * bary[2][2];
                }
            }
        }
    }
}

/// `floor` for values in a small range, without a libm call on baseline x86-64.
#[inline]
fn floor_f(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t > x { t - 1.0 } else { t }
}

/// `ceil` likewise.
#[inline]
fn ceil_f(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t < x { t + 1.0 } else { t }
}

#[inline]
fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn norm(a: [f32; 3]) -> f32 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

#[inline]
fn normalize(a: [f32; 3]) -> [f32; 3] {
    let n = norm(a);
    if n > 1e-12 {
        [a[0] / n, a[1] / n, a[2] / n]
    } else {
        [0.0, 0.0, -1.0]
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
