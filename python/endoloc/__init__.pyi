"""Type stubs of ``endoloc``: the job functions with their options."""

import os
from collections.abc import Callable, Sequence as Seq
from typing import Literal

from . import experiment as experiment
from ._endoloc import (
    Camera as Camera,
    Dataset as Dataset,
    EndolocError as EndolocError,
    FrameResult as FrameResult,
    Localizer as Localizer,
    Model as Model,
    Report as Report,
    Sequence as Sequence,
    VideoFrames as VideoFrames,
    __version__ as __version__,
    read_tum as read_tum,
    write_tum as write_tum,
)
from .progress import PrintProgress as PrintProgress, TqdmProgress as TqdmProgress

StrPath = str | os.PathLike[str]
ProgressArg = bool | Callable[[str, str, int, int], object] | None

def options(name: str) -> list[str]:
    """The keyword arguments job ``name`` takes (e.g. ``"train"``, ``"experiment.compare"``)."""

def run(config: StrPath, *, force: bool = False, progress: ProgressArg = None) -> Report:
    """The whole chain from one TOML file (``endoloc run --config FILE``)."""

def simulate(
    *,
    preset: str = ...,
    config: StrPath | None = ...,
    seed: int | None = ...,
    gca: StrPath | None = ...,
    mesh: StrPath | None = ...,
    path: StrPath | None = ...,
    landmarks: StrPath | None = ...,
    inflation: float | None = ...,
    train_frames: int | None = ...,
    test_frames: int | None = ...,
    fps: float | None = ...,
    width: int | None = ...,
    height: int | None = ...,
    hfov: float | None = ...,
    depth: bool | None = ...,
    no_depth: bool = ...,
    noise: float | None = ...,
    motion_blur: int | None = ...,
    field_stop: float | None = ...,
    black_border: int | None = ...,
    clearance: float | None = ...,
    changes: Literal["none", "mild", "moderate", "severe"] | None = ...,
    out: StrPath = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Dataset:
    """Render a colonoscopy dataset (``endoloc simulate``) and open it.

    Options (the command's, ``-`` as ``_``):

    - ``preset``: Starting configuration: `small` or `paper`.
    - ``config``: Full configuration from a TOML file instead of the preset (as printed
      by `SimulateJob::sim_config` + `to_toml`, or a dataset's `dataset.toml`).
    - ``seed``: Master seed: derives the colon shape, texture and both passes (default:
      the preset's, or the `config` file's). With `config`, a seed equal to the file's
      keeps the file's derived seeds.
    - ``gca``: GCA model folder (surface `.vtk`, mid-line `.jsn`, landmarks `.json`) as
      the colon.
    - ``mesh``: Colon surface mesh (VTK legacy ASCII, OBJ, PLY or STL, mm); needs
      `path`.
    - ``path``: Mid-line of the mesh colon, anus → caecum (GCA `.jsn`, or CSV of x,y,z
      in mm).
    - ``landmarks``: Landmarks labelling the mid-line with anatomical sections (GCA
      model JSON).
    - ``inflation``: Radial growth factor of a mesh colon's lumen (1.0 keeps the scanned
      wall).
    - ``train_frames``: Frames in the training pass.
    - ``test_frames``: Frames in the test pass.
    - ``fps``: Frame rate of both passes, frames per second.
    - ``width``: Image width, pixels.
    - ``height``: Image height, pixels.
    - ``hfov``: Horizontal field of view, degrees.
    - ``depth``: Write 16-bit depth maps (mm × 100) next to the images.
    - ``no_depth``: Do not write depth maps (``depth=False``).
    - ``noise``: Sensor noise standard deviation, 8-bit grey levels.
    - ``motion_blur``: Sub-frames averaged per frame for motion blur (1 = none).
    - ``field_stop``: Radius of a circular field stop, fraction of the half image diagonal
      (0 = none); the dataset then gets the renderer's mask.
    - ``black_border``: Black columns on the left and right of every frame, pixels.
    - ``clearance``: Smallest distance kept between the lens and the colon wall, mm.
    - ``changes``: How the colon changes between the training and the test pass (shape,
      look, scope); the test pass's ``poses.txt`` holds the anatomical poses.
    - ``out``: Output dataset folder.
    - ``force``: Replace an existing output folder.
    """
    ...

def import_video(
    video: StrPath,
    *,
    out: StrPath = ...,
    poses: StrPath | None = ...,
    camera: str | None = ...,
    units: Literal["mm", "cm", "m"] | None = ...,
    time_offset: str | float = ...,
    max_gap_ms: float = ...,
    sensor_to_camera: StrPath | None = ...,
    every: int = ...,
    max_fps: float | None = ...,
    size: str | None = ...,
    test: StrPath | None = ...,
    log_rate_hz: float | None = ...,
    test_poses: StrPath | None = ...,
    seq: str = ...,
    name: str | None = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Dataset:
    """A video file with its pass's tracker pose log as a dataset (``endoloc import video``),
    opened.

    Options (``endoloc import video``'s, ``-`` as ``_``):

    - ``out``: Output dataset folder.
    - ``poses``: The pass's pose log: a tracker CSV with a header, TUM, or C3VD's
      ``pose.txt``; without one the frames keep their times only (``frames.txt``): the pass
      can be localized, not evaluated.
    - ``log_rate_hz``: The rate of a log without time stamps (C3VD's ``pose.txt``), Hz;
      default the video's frame rate.
    - ``camera``: ``W,H,FX,FY,CX,CY``: the video carries no intrinsics (required).
    - ``units``: Length unit of the pose log (default mm).
    - ``time_offset``: Log time = video time + this many seconds, or ``"auto"``.
    - ``max_gap_ms``: A frame gets a pose only when valid log samples lie within this on
      both sides.
    - ``sensor_to_camera``: Text file with the 4×4 hand-eye transform ``T_sc``.
    - ``every``: Keep every N-th frame.
    - ``max_fps``: Keep at most this many frames per second.
    - ``size``: Resize the frames to ``"WxH"`` (same aspect ratio; the camera is scaled).
    - ``test`` / ``test_poses``: The other pass's video and log, written as ``test``.
    - ``seq``: Sequence name without ``test`` (default ``train``); into an existing dataset
      ``out``, the pass is added beside its sequences under this name.
    - ``name``: Dataset name in dataset.toml.
    - ``force``: Replace an existing dataset at ``out``.
    """
    ...

def train(
    *,
    method: Literal["siamese", "posenet", "offsetnet"] = ...,
    data: StrPath = ...,
    seq: str = ...,
    also_seq: Seq[str] = ...,
    zones: int | str = ...,
    uniform_by: str = ...,
    min_zone_frames: int = ...,
    out: StrPath = ...,
    force: bool = ...,
    resume: bool = ...,
    backbone: str = ...,
    input: str | None = ...,
    stem_stride: int | None = ...,
    pooling: str | None = ...,
    tilt_deg: float | None = ...,
    pairs: str | None = ...,
    pair_frames: str | None = ...,
    near_fraction: float | None = ...,
    zone_fraction: float | None = ...,
    whitening: float | None = ...,
    database_smoothing: float | None = ...,
    index_zoom_blur: str | None = ...,
    index_view_penalty: float | None = ...,
    schedule: str = ...,
    config: StrPath | None = ...,
    epochs: int | None = ...,
    lr: float | None = ...,
    batch_pairs: int | None = ...,
    no_augment: bool = ...,
    seed: int = ...,
    device: str = ...,
    val_seq: StrPath | None = ...,
    pretrained: StrPath | None = ...,
    progress: ProgressArg = None,
) -> Report:
    """Zones and the Siamese zone classifier, or a PoseNet/OffsetNet baseline (``endoloc train``); writes a model folder.

    Options (the command's, ``-`` as ``_``):

    - ``method``: The Siamese classifier, or a regression baseline on the same backbone.
    - ``data``: Dataset folder (with `dataset.toml`).
    - ``seq``: Training sequence inside the dataset.
    - ``also_seq``: Further passes through the same colon (sequences of this dataset)
      joined to the pairs.
    - ``zones``: Zones: a number (uniform, e.g. ``zones=50``) or `expert` / `expert:N`
      (anatomical, e.g. ``zones="expert:9"``).
    - ``uniform_by``: Uniform zones of equal `arc-length` or equal `frames`.
    - ``min_zone_frames``: Fewest training frames a uniform zone holds: a zone over a fast
      stretch of the pass is widened into its neighbours until it has this many.
    - ``out``: Model folder to write.
    - ``force``: Replace an existing model folder (or discard an interrupted run).
    - ``resume``: Continue an interrupted run from its checkpoint
      (`MODEL.partial/checkpoint`).
    - ``backbone``: Backbone: `compact` or `googlenet`.
    - ``input``: Network input size `WxH` (`None`: the backbone's).
    - ``stem_stride``: Stride of the compact backbone's first convolution.
    - ``pooling``: Global pooling of the compact backbone: `average` or `gem`.
    - ``tilt_deg``: Tilt augmentation, degrees about the camera's x and y axes.
    - ``pairs``: Training pairs: `zone` or `track`.
    - ``pair_frames``: Track pairs: largest positive and smallest negative frame gap,
      `P,N`.
    - ``near_fraction``: Track pairs: fraction of negatives within 2·N frames.
    - ``zone_fraction``: Track pairs: fraction of each batch drawn as zone pairs
      instead.
    - ``whitening``: Power of the partial PCA whitening of the descriptors (0: none).
    - ``database_smoothing``: Database smoothing along the training pass, ± mm of camera
      path (0: none).
    - ``index_zoom_blur``: Zoom-blurred views of every training frame in the database:
      amplitudes `A,..` of the magnification 1 ± A, or `none`.
    - ``index_view_penalty``: Descriptor distance added to a view's at look-up (default
      0: a view counts as its frame).
    - ``schedule``: Schedule preset: `fast` or `paper`.
    - ``config``: Training settings from a TOML file (fields of `TrainConfig`),
      overridden by the above.
    - ``epochs``: Epochs (0 with `pretrained`: only index the pass with the start
      weights).
    - ``lr``: Adam learning rate at the start.
    - ``batch_pairs``: Pairs per step.
    - ``no_augment``: Turn augmentation off.
    - ``seed``: Seed of every random step.
    - ``device``: Compute device: `cpu`, `cuda`, `wgpu` (GPU builds only) or `auto`.
    - ``val_seq``: Monitor validation accuracy on this sequence folder.
    - ``pretrained``: Start weights: a file, or `builtin`, `builtin-track`,
      `builtin-joint`, `builtin-changes`.
    """
    ...

def map(
    *,
    model: StrPath = ...,
    data: StrPath = ...,
    seq: str = ...,
    images_per_zone: int = ...,
    threshold: float = ...,
    intensity: Literal["linear", "log"] = ...,
    delta_r: float = ...,
    observation_radius: float = ...,
    smoothed_level: float | None = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """Per-zone SURF maps of a trained model (``endoloc map``), written into the model folder.

    Options (the command's, ``-`` as ``_``):

    - ``model``: Model folder written by `TrainJob`.
    - ``data``: Dataset the model was trained on.
    - ``seq``: Training sequence inside the dataset.
    - ``images_per_zone``: Images per zone (the paper's `m ≥ 3`).
    - ``threshold``: SURF threshold of the map (units of MATLAB's `MetricThreshold`).
    - ``intensity``: How intensities enter SURF, for the map and the frames localized
      against it: ``"linear"`` (as published) or ``"log"`` (robust to another light,
      exposure and highlights; more map points, slower frames).
    - ``delta_r``: δr: map points reprojecting farther than this are dropped, pixels.
    - ``observation_radius``: Every other training frame of a zone adds its observations
      of the zone's points (matched by projection within this many pixels) before they are
      triangulated again; 0 = only the ``images_per_zone`` images.
    - ``smoothed_level``: σ of the map's smoothed level, pixels: the map of the training
      images smoothed by a Gaussian, where a frame that does not register against the map
      is registered next (default: 1.5 per 320 pixels of image width; 0 = none).
    - ``force``: Replace an existing map.
    """
    ...

def localize(
    *,
    method: Literal["endoloc", "classify", "retrieval", "posenet", "offsetnet", "vo"] = ...,
    model: StrPath | None = ...,
    also_model: Seq[StrPath] = ...,
    regressor: StrPath | None = ...,
    reference_seq: StrPath | None = ...,
    seq: StrPath = ...,
    video: StrPath | None = ...,
    realtime: bool = ...,
    size: str | None = ...,
    pix_fmt: Literal["gray8", "rgb24"] = ...,
    mask: StrPath | None = ...,
    camera: StrPath | None = ...,
    out: StrPath = ...,
    live: bool = ...,
    track_frames: int = ...,
    recover_frames: int = ...,
    hold_frames: int = ...,
    classify_every_frame: bool = ...,
    trusted_inliers: int = ...,
    gate_mm: float = ...,
    neighbours: int = ...,
    threshold: float | None = ...,
    retry_threshold: float | None = ...,
    keypoint_budget: float = ...,
    max_keypoints: int = ...,
    candidate_zones: int = ...,
    max_sigma_mm: float = ...,
    max_std_mm: float = ...,
    weak_max_std_mm: float = ...,
    confirm: bool = ...,
    no_confirm: bool = ...,
    max_rms_px: float = ...,
    max_jump_mm: float = ...,
    polish_px: float = ...,
    wall_motion_mm: float = ...,
    keypoint_noise_px: float = ...,
    colon_scale: float = ...,
    strict: bool = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """Localize every frame of a sequence (``endoloc localize``); ``report.frames`` holds one ``FrameResult`` per frame.

    Options (the command's, ``-`` as ``_``):

    - ``method``: Method.
    - ``model``: Model folder (trained, with its map; for `posenet` the PoseNet folder).
    - ``also_model``: Zone models joined to `model` into an ensemble (same pass and
      zones).
    - ``regressor``: OffsetNet model folder (`offsetnet`).
    - ``reference_seq``: Training sequence folder holding the reference images
      (`offsetnet`).
    - ``seq``: Sequence folder to localize (inside a dataset folder).
    - ``video``: Instead of ``seq``: a video file localized live as it is decoded (each
      frame resized to the model's camera), or ``-`` for raw frames on standard input
      (``size``, ``pix_fmt``); needs ``live``; adds ``stream.csv`` (every frame's latency).
    - ``realtime``: With ``video``: frames arrive as a camera delivers them (a file paced at
      its frame times); the newest frame wins, older ones are dropped and counted.
    - ``size``: Raw frames on standard input: their size, ``"WxH"``.
    - ``pix_fmt``: Raw frames on standard input: ``gray8`` or ``rgb24``.
    - ``mask``: With ``video``: the frames' image mask, a dataset folder or a mask PNG.
    - ``camera``: The frames' camera when it is not the model's (another scope): a TOML file
      with a ``[camera]`` table as in ``dataset.toml``; default the sequence's own
      ``camera.toml``, else the model's camera.
    - ``out``: Output folder.
    - ``live``: Frames one at a time, in order, as a scope delivers them.
    - ``track_frames``: Live: frames a refined pose stays usable as the next frames'
      prior (0: off).
    - ``recover_frames``: Live: frames after a refined one during which the zones around
      it are tried (0: off).
    - ``hold_frames``: Live: the motion model predicts for at most this many frames after
      the last refined one; an `init_only` frame reports the prediction (0: always the zone
      median, no gate).
    - ``classify_every_frame``: Live: run the zone classifier on every frame, also on
      frames tracked from the motion model's prediction (default: only when tracking fails).
    - ``trusted_inliers``: Live: a registration with at least this many inliers is trusted
      without the motion model's agreement.
    - ``gate_mm``: Live: base radius of the motion gate around the predicted camera centre,
      mm.
    - ``neighbours``: Map points also come from this many zones on each side of the
      classified one.
    - ``threshold``: SURF threshold on the test frames (`None`: 0.4 × the map's).
    - ``retry_threshold``: Retry threshold for frames that register nowhere, every
      keypoint above it (`None`: twice the map's, per frame only; 0: off).
    - ``keypoint_budget``: At most this × √(width × height) SURF keypoints per test frame,
      the strongest (0: no budget).
    - ``max_keypoints``: At most this many SURF keypoints per test frame, the strongest
      (0: no fixed cap).
    - ``candidate_zones``: Zones tried, best score first, until one registers (1 = the
      paper's rule).
    - ``max_sigma_mm``: Validity: largest position uncertainty (1σ) of a refined pose,
      mm.
    - ``max_std_mm``: Per frame: largest stated position uncertainty of a refined frame,
      mm (default: no limit).
    - ``weak_max_std_mm``: Per frame: the same for registrations with fewer than
      ``trusted_inliers`` inliers.
    - ``confirm``: Confirm registrations against all map points near their pose and refine
      them again from those; one they do not support is `init_only` (`unsupported`). On by
      default; live, strong tracked registrations are trusted as they are.
    - ``no_confirm``: Do not confirm registrations against the map (``confirm=False``).
    - ``max_rms_px``: Validity: largest RMS reprojection error of the inliers, pixels.
    - ``max_jump_mm``: Validity: largest jump from the prior, mm.
    - ``polish_px``: Scale of the Cauchy kernel of the final polish on the inliers, pixels
      (0: least squares).
    - ``wall_motion_mm``: How far the colon wall may have moved since the mapping pass
      (standard deviation, mm): each map point's reprojection tolerance widens by
      √(1 + (f·σ/z)²) at depth z, near points most, tried only on a frame that does not
      register as a rigid wall; 0: a rigid colon.
    - ``keypoint_noise_px``: Keypoint noise of a registration to a wall that did not move,
      pixels per axis (1σ): the stated uncertainty reads residuals beyond it as a wall that
      moved since the mapping pass (correlated over 50 mm) and adds the pose error such a
      motion causes; 0: residuals are independent noise only.
    - ``colon_scale``: Refine each refined pose with the colon's scale about its mid-line
      (a pass insufflated differently from the mapping pass): the scale prior's standard
      deviation around 1 (0.15: about ±15 %); 0: rigid poses, as in the paper.
    - ``strict``: Stop at the first image that cannot be read instead of reporting the
      frame as `rejected` (`unreadable_image`) and going on.
    - ``force``: Replace existing results in `out`.
    """
    ...

def eval(
    *,
    gt: StrPath = ...,
    est: StrPath = ...,
    frames: StrPath | None = ...,
    gt_zones: StrPath | None = ...,
    out: StrPath = ...,
    force: bool = ...,
    align: Literal["none", "se3", "sim3"] = ...,
    t_max_diff: float = ...,
    t_offset: float = ...,
    rpe_delta: int = ...,
    rpe_all_pairs: bool = ...,
    no_plots: bool = ...,
    midline: StrPath | None = ...,
    progress: ProgressArg = None,
) -> Report:
    """Errors of an estimated trajectory against the truth (``endoloc eval``); ``report.metrics`` is ``metrics.json``.

    Options (the command's, ``-`` as ``_``):

    - ``gt``: Ground-truth trajectory of the test sequence (TUM).
    - ``est``: Estimated trajectory (TUM).
    - ``frames``: The run's `frames.csv` (`None`: `frames.csv` next to `est`, when it
      exists).
    - ``gt_zones``: True zone of each test frame (CSV `frame,zone`); enables the zone
      accuracy.
    - ``out``: Output folder (empty: `eval/` next to `est`).
    - ``force``: Replace existing output files.
    - ``align``: Alignment of the estimate onto the ground truth before the errors.
    - ``t_max_diff``: Largest timestamp difference for associating poses, seconds.
    - ``t_offset``: Offset added to the estimate's timestamps before associating,
      seconds.
    - ``rpe_delta``: RPE pair distance, in associated poses.
    - ``rpe_all_pairs``: RPE over every pair (i, i + delta) instead of consecutive
      pairs.
    - ``no_plots``: Do not draw the PNG plots.
    - ``midline``: The colon's mid-line for the error along the colon (default: the
      dataset's ``midline.txt``, else its training pass).
    """
    ...

def classify(
    *,
    model: StrPath = ...,
    also_model: Seq[StrPath] = ...,
    seq: StrPath = ...,
    filter: str = ...,
    out: StrPath | None = ...,
    scores: StrPath | None = ...,
    descriptors: StrPath | None = ...,
    limit: int | None = ...,
    stay: float | None = ...,
    temperature: float | None = ...,
    track_temperature: float | None = ...,
    track_scale: float | None = ...,
    track_step: int | None = ...,
    track_speed: int | None = ...,
    track_speed_change: float | None = ...,
    track_lag: int = ...,
    track_jump: float | None = ...,
    verify: int = ...,
    device: str = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """Per-frame zones and scores with temporal filters (``endoloc classify``).

    Options (the command's, ``-`` as ``_``):

    - ``model``: Model folder written by `TrainJob`.
    - ``also_model``: Models joined to `model` into an ensemble (same pass and zones).
    - ``seq``: Sequence folder (`images/` and `poses.txt`).
    - ``filter``: Which zone the `zone` column holds: `none` (raw), `forward`,
      `viterbi`, `track` or `smooth`.
    - ``out``: Per-frame CSV file (`None`: the CSV is returned in the report).
    - ``scores``: Every zone's score per frame (CSV).
    - ``descriptors``: Every frame's descriptor (NumPy `.npy`, float32, frames ×
      descriptor length).
    - ``limit``: Only the first N frames.
    - ``stay``: Zone HMM: probability of staying in a zone per frame.
    - ``temperature``: Zone HMM: emission temperature, descriptor-distance units.
    - ``track_temperature``: Track filter: emission temperature, descriptor-distance
      units.
    - ``track_scale``: Track filter: scale of the move per frame, training frames.
    - ``track_step``: Track filter: largest move per frame, training frames.
    - ``track_speed``: Track filter: largest speed, training frames per test frame (0:
      no speed state).
    - ``track_speed_change``: Track filter: probability per frame of the speed changing
      by one.
    - ``track_lag``: Track filter: fixed-lag smoothing over the next L frames (0 =
      causal).
    - ``track_jump``: Track filter: jump probability per frame.
    - ``verify``: Verify every frame against the SURF maps of its K best zones (0 =
      off).
    - ``device``: Compute device: `cpu`, `cuda`, `wgpu` (GPU builds only) or `auto`.
    - ``force``: Replace `out`, `scores` and `descriptors` files that exist.
    """
    ...

def view(
    *,
    run: StrPath = ...,
    out: StrPath | None = ...,
    force: bool = ...,
    thumb_width: int = ...,
    max_points: int = ...,
    no_gt: bool = ...,
    seq: StrPath | None = ...,
    model: StrPath | None = ...,
    jpeg_quality: int = ...,
    progress: ProgressArg = None,
) -> Report:
    """The self-contained HTML page of a localization run (``endoloc view``).

    Options (the command's, ``-`` as ``_``):

    - ``run``: Run folder written by `endoloc localize`.
    - ``out``: Output file (`None`: `view.html` in the run folder).
    - ``force``: Replace an existing page.
    - ``thumb_width``: Width of the frame thumbnails, pixels (height follows the
      camera's aspect ratio).
    - ``max_points``: At most this many map points in the page, in all zones together
      (subsampled evenly).
    - ``no_gt``: Leave out the ground truth even when the sequence has `poses.txt`.
    - ``seq``: Test sequence folder (`None`: the one in the run's `localize.toml`).
    - ``model``: Model folder (`None`: the one in the run's `localize.toml`).
    - ``jpeg_quality``: JPEG quality of the thumbnails, 1–100.
    """
    ...

def features(
    *,
    image: StrPath = ...,
    overlay: StrPath | None = ...,
    keypoints: StrPath | None = ...,
    descriptors: bool = ...,
    config: StrPath | None = ...,
    threshold: float | None = ...,
    octaves: int | None = ...,
    scale_levels: int | None = ...,
    initial_step: int | None = ...,
    upright: bool = ...,
    extended: bool = ...,
    single_thread: bool = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """SURF keypoints of one image (``endoloc features``).

    Options (the command's, ``-`` as ``_``):

    - ``image``: Input image (colour is converted to grey).
    - ``overlay``: Overlay picture to write (PNG).
    - ``keypoints``: Keypoint file to write: `.csv` (x, y, scale, orientation_rad,
      response, laplacian, octave; pixels, origin at the top-left pixel's centre) or
      `.json`.
    - ``descriptors``: Include the descriptors in the JSON keypoint file.
    - ``config``: Detector settings from a TOML file (fields of `SurfConfig`).
    - ``threshold``: Hessian threshold (MATLAB `MetricThreshold`).
    - ``octaves``: Number of octaves (MATLAB `NumOctaves`).
    - ``scale_levels``: Filter sizes per octave (MATLAB `NumScaleLevels`).
    - ``initial_step``: Sampling step of the first octave, pixels.
    - ``upright``: U-SURF: no orientation (0 = along +x).
    - ``extended``: 128-d descriptors instead of 64-d.
    - ``single_thread``: Use one thread.
    - ``force``: Replace output files that exist.
    """
    ...

def pretrain(
    *,
    out: StrPath = ...,
    colons: int = ...,
    seed: int = ...,
    preset: str = ...,
    zones: int = ...,
    epochs: int | None = ...,
    pairs: str | None = ...,
    near_fraction: float | None = ...,
    pretrained: str | None = ...,
    joint: bool = ...,
    pair_frames: str | None = ...,
    frames: int | None = ...,
    fps: float | None = ...,
    size: str | None = ...,
    changes: Literal["none", "mild", "moderate", "severe"] | None = ...,
    force: bool = ...,
    device: str = ...,
    progress: ProgressArg = None,
) -> Report:
    """Start weights for ``train(pretrained=...)`` (``endoloc pretrain``).

    Options (the command's, ``-`` as ``_``):

    - ``out``: Output folder.
    - ``colons``: Number of simulated colons.
    - ``seed``: Seed of the first colon; colon i has seed `seed + 101·i`.
    - ``preset``: Simulator preset of the colons (`paper` or `small`).
    - ``zones``: Uniform zones of each colon's training pass.
    - ``epochs``: Training epochs per colon (`None`: the `fast` schedule's); with
      `joint`, the whole training's (`None`: 60 per colon).
    - ``pairs``: Training pairs: `zone` or `track` (`None`: the training default).
    - ``near_fraction``: Track pairs: fraction of negatives near the positive.
    - ``pretrained``: Start weights of the first colon (a `.safetensors` or `.pt` file,
      or `builtin`); `None`: random weights.
    - ``joint``: Train one network on every colon at once.
    - ``pair_frames``: Track pairs: largest positive and smallest negative frame gap,
      `P,N`.
    - ``frames``: Frames of each pass (`None`: the preset's).
    - ``fps``: Frame rate of the simulated passes, frames per second (`None`: the
      preset's).
    - ``size``: Image size `WIDTHxHEIGHT`, pixels (`None`: the preset's).
    - ``changes``: Each colon's test pass through its colon changed at random up to this
      severity (every factor of the change model drawn between none and the severity's
      value, seeded by the colon's seed); `None`: both passes through the same colon.
    - ``force``: Replace an existing `out/weights.safetensors`.
    - ``device``: Compute device of the trainings: `cpu`, `cuda`, `wgpu` (GPU builds only)
      or `auto`.
    """
    ...

def demo(
    *,
    out: StrPath = ...,
    zones: int = ...,
    train: bool = ...,
    epochs: int = ...,
    size: tuple[int, int] = ...,
    threshold: float = ...,
    seed: int = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """The whole method on the built-in colon (``endoloc demo``).

    Options (the command's, ``-`` as ``_``):

    - ``out``: Output folder: `data/`, `model/`, `run/` (with `view.html`), `run/eval/`.
    - ``zones``: Uniform zones along the training pass.
    - ``train``: Train the paper's classifier from scratch (a short schedule of
      `epochs`) instead of indexing the pass with the shipped network.
    - ``epochs``: Training epochs with `train`.
    - ``size``: Image size of the simulated frames, pixels (`width`, `height`).
    - ``threshold``: SURF threshold of the map.
    - ``seed``: Master seed of the simulation and the training.
    - ``force``: Replace an existing output folder.
    """
    ...
