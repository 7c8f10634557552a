"""Type stubs of the extension module ``endoloc._endoloc`` (re-exported by ``endoloc``)."""

import os
from pathlib import Path
from collections.abc import Callable, Sequence as _Seq
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

StrPath = str | os.PathLike[str]
ProgressCallback = Callable[[str, str, int, int], object]
Image = npt.NDArray[np.uint8]
"""A frame: ``uint8`` H×W grey, or H×W×3 RGB / H×W×4 RGBA (converted to grey as endoloc
converts a colour PNG)."""
Pose = npt.NDArray[np.float64]
"""A 4×4 ``float64`` homogeneous matrix ``T_wc`` (camera-to-world), translation in mm."""

__version__: str

class EndolocError(Exception):
    """An endoloc call failed; the message is endoloc's own: what was being done, then each
    cause (file, line, what was expected)."""

class Camera:
    """A pinhole camera with optional OpenCV distortion: intrinsics in pixels, OpenCV axes (x
    right, y down, z forward), pixel origin at the centre of the top-left pixel."""

    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def fx(self) -> float: ...
    @property
    def fy(self) -> float: ...
    @property
    def cx(self) -> float: ...
    @property
    def cy(self) -> float: ...
    @property
    def K(self) -> npt.NDArray[np.float64]:
        """The 3×3 intrinsic matrix (pixels)."""
    @property
    def distortion(self) -> dict[str, Any] | None:
        """``None``, or ``model`` (``radial-tangential`` or ``fisheye``) and its coefficients."""
    @property
    def hfov_deg(self) -> float:
        """Horizontal field of view, degrees."""

class Sequence:
    """One sequence of a dataset: ``len(seq)`` frames; ``seq[i]`` is frame ``i`` as grey
    ``uint8`` (H×W), loaded exactly as ``endoloc localize`` loads it."""

    def __init__(self, path: StrPath) -> None:
        """Opens a sequence folder (``images/``, ``poses.txt``)."""
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> Path: ...
    @property
    def poses(self) -> npt.NDArray[np.float64]:
        """``T_wc`` of every frame, (N, 4, 4), mm."""
    @property
    def timestamps(self) -> npt.NDArray[np.float64]:
        """Time stamps, seconds, (N,)."""
    def pose(self, i: int) -> Pose:
        """``T_wc`` of frame ``i``."""
    def image(self, i: int, rgb: bool = False) -> Image:
        """Frame ``i``: grey H×W, or RGB H×W×3 with ``rgb=True``."""
    def depth(self, i: int) -> npt.NDArray[np.float32]:
        """Depth along the optical axis, mm (H×W; 0 where there is none)."""
    @property
    def has_depth(self) -> bool: ...
    @property
    def sections(self) -> list[str] | None:
        """Anatomical section of every frame (``sections.csv``), or ``None``."""
    @property
    def image_paths(self) -> list[Path]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, i: int) -> Image: ...

class Dataset:
    """An endoloc dataset (format version 1): ``dataset.toml``, its camera, its sequences."""

    def __init__(self, path: StrPath) -> None:
        """Opens the dataset folder ``path`` (with ``dataset.toml``)."""
    @property
    def path(self) -> Path: ...
    @property
    def name(self) -> str: ...
    @property
    def camera(self) -> Camera: ...
    @property
    def sequences(self) -> list[str]: ...
    @property
    def unposed(self) -> list[str]:
        """Passes without poses (``frames.txt``: a video imported without a pose log), to
        localize by folder (``localize(seq=dataset.path / name, ...)``)."""
    @property
    def simulation(self) -> str | None:
        """The simulator's configuration (TOML) when the dataset was simulated."""
    def sequence(self, name: str) -> Sequence: ...
    def __getitem__(self, name: str) -> Sequence: ...
    def __contains__(self, name: str) -> bool: ...

class Model:
    """A trained model folder (``endoloc train``): the Siamese network, its zones and the
    descriptor database of the training pass."""

    @staticmethod
    def load(path: StrPath) -> Model:
        """Loads a model folder on the CPU."""
    @property
    def path(self) -> Path: ...
    @property
    def zone_count(self) -> int: ...
    @property
    def descriptor_dim(self) -> int: ...
    @property
    def camera(self) -> Camera: ...
    @property
    def zone_poses(self) -> npt.NDArray[np.float64]:
        """Median ``T_wc`` of every zone, (Z, 4, 4), mm."""
    def classify(self, image: Image) -> tuple[int, npt.NDArray[np.float32]]:
        """``(zone, scores)``: the zone (0-based) and every zone's descriptor distance
        (lower = better)."""
    def describe(self, images: Image | npt.NDArray[np.uint8] | _Seq[Image]) -> npt.NDArray[np.float32]:
        """Descriptors (N, D), unit rows, of one image, a stack N×H×W or a list of images."""

class FrameResult:
    """The outcome for one frame, as a row of ``frames.csv``."""

    @property
    def pose(self) -> Pose | None:
        """``T_wc`` (mm): refined, or the initial pose for ``init_only``; ``None`` when rejected."""
    @property
    def position(self) -> npt.NDArray[np.float64] | None:
        """Camera position ``t_wc`` (3,), mm; ``None`` when rejected."""
    @property
    def quaternion(self) -> npt.NDArray[np.float64] | None:
        """Rotation ``(qx, qy, qz, qw)``, ``qw ≥ 0`` (a TUM line's last four columns)."""
    @property
    def status(self) -> Literal["refined", "init_only", "rejected"]: ...
    @property
    def reason(self) -> str | None:
        """Why not ``refined``: ``too_few_correspondences``, ``too_few_inliers``,
        ``rms_too_high``, ``jump_too_large``, ``degenerate_geometry``, ``inconsistent_with_motion``,
        ``unconfirmed``, ``uncertain`` or ``unreadable_image``."""
    @property
    def reason_detail(self) -> str | None: ...
    @property
    def zone(self) -> int | None: ...
    @property
    def zone_score(self) -> float | None: ...
    @property
    def source(self) -> str:
        """Where the pose comes from: ``refined``, ``predicted`` (live motion model),
        ``registered`` (an ``uncertain`` frame's registration), ``zone_median`` or ``none``."""
        ...
    @property
    def std(self) -> tuple[float, float] | None:
        """Calibrated ``(position_mm, orientation_deg)`` standard deviations of a refined
        pose along its least certain direction; ``None`` unless refined."""
        ...
    @property
    def inliers(self) -> int: ...
    @property
    def correspondences(self) -> int: ...
    @property
    def inlier_px(self) -> npt.NDArray[np.float32]:
        """Inlier keypoints, (K, 2) pixels."""
    @property
    def reprojection_rms_px(self) -> float | None: ...
    @property
    def times_ms(self) -> dict[str, float]:
        """Per stage: ``zone``, ``surf``, ``matching``, ``refine``, ms."""
    @property
    def time_ms(self) -> float:
        """Sum of the stages, ms (``frames.csv``'s ``time_ms``)."""
    @property
    def wall_ms(self) -> float | None:
        """Wall time of the library call (``Localizer.localize``), ms."""

class Localizer:
    """A model, its map and ``endoloc localize``'s settings, for frames one at a time; live,
    the causal filters and the last refined pose are kept between calls. ``mask``: the frames'
    image mask, a dataset folder (its ``[camera] mask``) or a mask PNG: SURF keeps inside it and
    the zone network sees frames black outside it, as in training."""

    def __init__(
        self,
        model: Model | StrPath,
        live: bool = False,
        mask: StrPath | None = None,
        *,
        also_model: _Seq[StrPath] = ...,
        camera: StrPath | None = ...,
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
    ) -> None: ...
    def localize(self, image: Image) -> FrameResult:
        """Localizes one frame of the model's image size; live, frames in order."""
    def reset(self) -> None:
        """Forgets the live stream's past (a new video)."""
    @property
    def live(self) -> bool: ...
    @property
    def frames(self) -> int: ...
    @property
    def camera(self) -> Camera: ...
    @property
    def settings(self) -> str:
        """The settings as ``localize.toml`` records them."""

class VideoFrames:
    """The frames of a video file (whatever FFmpeg decodes; ``ffmpeg`` and ``ffprobe`` on the
    PATH), decoded while they are read, grey, as ``localize --live --video`` reads them:
    iterate for ``(index, time_s, image)`` — the frame's index in the video, its presentation
    time (seconds, the video's clock) and an ``(H, W)`` ``uint8`` array. ``size=(width,
    height)`` resizes them (same aspect ratio; e.g. a ``Localizer``'s camera size)."""

    def __init__(self, path: StrPath, size: tuple[int, int] | None = None) -> None: ...
    def __iter__(self) -> VideoFrames: ...
    def __next__(self) -> tuple[int, float, npt.NDArray[np.uint8]]: ...
    @property
    def size(self) -> tuple[int, int]:
        """The size of the frames handed out, ``(width, height)`` pixels."""
    @property
    def native_size(self) -> tuple[int, int]:
        """The video's own frame size, ``(width, height)`` pixels."""
    @property
    def damaged(self) -> str | None:
        """FFmpeg's message when the last frame was decoded from damaged data."""

class Report:
    """What a job did."""

    @property
    def job(self) -> str: ...
    @property
    def text(self) -> str:
        """The report as the command line prints it."""
    @property
    def out(self) -> Path | None: ...
    @property
    def settings(self) -> str:
        """The job's full settings, TOML (as ``endoloc run`` reads them)."""
    @property
    def frames(self) -> list[FrameResult]: ...
    @property
    def metrics(self) -> dict[str, Any] | None:
        """``eval``: ``metrics.json``."""

def read_tum(path: StrPath) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """``(timestamps (N,), poses (N, 4, 4))`` of a TUM trajectory (``T_wc``, mm)."""

def write_tum(path: StrPath, timestamps: npt.ArrayLike, poses: npt.ArrayLike) -> None:
    """Writes a TUM trajectory as endoloc does (atomically, ``qw ≥ 0``)."""

def run_job(name: str, progress: ProgressCallback | None = None, **options: Any) -> Report: ...
def run_config(config: StrPath, force: bool = False, progress: ProgressCallback | None = None) -> Report: ...
def job_options(name: str) -> list[str]: ...
def time_rust_calls(localizer: Localizer, images: Any) -> list[float]: ...
