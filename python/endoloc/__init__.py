"""endoloc from Python: where is the colonoscope?

The same library as the ``endoloc`` command line, in process:

- ``Dataset(path)`` / ``Sequence(path)``: frames as NumPy ``uint8`` arrays, poses as 4×4
  ``float64`` arrays (``T_wc``, camera-to-world, millimetres), the camera;
- ``Model.load(path)``: the zone classifier (``classify``, ``describe``);
- ``Localizer(model, live=True)``: ``localize(image)`` frame by frame, as ``endoloc localize``;
- ``VideoFrames(path, size)``: a video file's frames as FFmpeg decodes them, to feed a
  ``Localizer`` (``localize(video=..., live=True)`` does it as a job);
- the jobs — ``simulate``, ``import_video``, ``train``, ``map``, ``localize``, ``eval``, ``classify``, ``view``,
  ``features``, ``pretrain``, ``demo``, ``run`` and ``experiment.benchmark`` / ``changes`` / ``compare`` / ``zones`` /
  ``expert`` / ``perturb`` — with the command line's options as keyword arguments
  (``--images-per-zone 8`` is ``images_per_zone=8``);
- ``read_tum`` / ``write_tum`` for trajectories (readable by evo).

Errors are ``EndolocError`` with endoloc's full message (what was being done, the file, the
line and what was expected); an unknown keyword argument is a ``TypeError``, an invalid value
a ``ValueError``. Jobs release the GIL while they run; ``progress=True`` shows progress bars
(tqdm when installed), or pass any callable ``progress(event, text, done, total)``.

Conventions: millimetres; poses ``T_wc`` (``p_world = R @ p_cam + t``); OpenCV camera axes
(x right, y down, z forward); pixel origin at the centre of the top-left pixel; zones 0-based
along the training pass.
"""

from __future__ import annotations

from . import _endoloc, experiment
from ._endoloc import (
    Camera,
    Dataset,
    EndolocError,
    FrameResult,
    Localizer,
    Model,
    Report,
    Sequence,
    VideoFrames,
    __version__,
    read_tum,
    write_tum,
)
from ._jobs import job, options, progress_callback
from .progress import PrintProgress, TqdmProgress

__all__ = [
    "Camera",
    "Dataset",
    "EndolocError",
    "FrameResult",
    "Localizer",
    "Model",
    "PrintProgress",
    "Report",
    "Sequence",
    "TqdmProgress",
    "VideoFrames",
    "__version__",
    "classify",
    "demo",
    "eval",
    "experiment",
    "features",
    "import_video",
    "localize",
    "map",
    "options",
    "pretrain",
    "read_tum",
    "run",
    "simulate",
    "train",
    "view",
    "write_tum",
]


def simulate(*, progress=None, **options) -> Dataset:
    """Render a colonoscopy dataset (``endoloc simulate``) and open it.

    Keyword arguments are ``endoloc simulate``'s options (``preset``, ``out``, ``seed``,
    ``train_frames``, …). Returns the new ``Dataset``.
    """
    report = job("simulate", progress, options)
    return Dataset(report.out)


def import_video(video, *, progress=None, **options) -> Dataset:
    """A video file with its pass's tracker pose log as a dataset (``endoloc import video``),
    opened; into an existing dataset ``out``, the pass is added as ``seq``.

    Keyword arguments are ``endoloc import``'s options (``out``, ``poses``, ``camera``,
    ``time_offset``, ``sensor_to_camera``, ``test``, ``test_poses``, ``seq``, …); without
    ``poses`` the frames keep their times only (``Dataset.unposed``). Returns the
    ``Dataset``.
    """
    if "time_offset" in options and not isinstance(options["time_offset"], str):
        options["time_offset"] = repr(float(options["time_offset"]))  # seconds, or "auto"
    report = job("import", progress, {"format": "video", "src": video, **options})
    return Dataset(report.out)


def train(*, progress=None, **options) -> Report:
    """Zones and the Siamese zone classifier (``endoloc train``); writes a model folder."""
    return job("train", progress, options)


def map(*, progress=None, **options) -> Report:  # noqa: A001 - the command's name
    """Per-zone SURF maps of a trained model (``endoloc map``), written into the model folder."""
    return job("map", progress, options)


def localize(*, progress=None, **options) -> Report:
    """Localize every frame of a sequence (``endoloc localize``): writes ``trajectory.txt``
    (TUM), ``frames.csv`` and ``inliers.csv`` into ``out``; ``report.frames`` holds one
    ``FrameResult`` per frame (method ``endoloc``)."""
    return job("localize", progress, options)


def eval(*, progress=None, **options) -> Report:  # noqa: A001 - the command's name
    """Errors of an estimated trajectory against the truth (``endoloc eval``): writes
    ``metrics.json``, ``errors.csv``, ``report.md`` and plots; ``report.metrics`` is
    ``metrics.json`` as a dict."""
    return job("eval", progress, options)


def classify(*, progress=None, **options) -> Report:
    """Per-frame zones and scores of a sequence with temporal filters (``endoloc classify``)."""
    return job("classify", progress, options)


def view(*, progress=None, **options) -> Report:
    """The self-contained HTML page of a localization run (``endoloc view``)."""
    return job("view", progress, options)


def features(*, progress=None, **options) -> Report:
    """SURF keypoints of one image (``endoloc features``)."""
    return job("features", progress, options)


def pretrain(*, progress=None, **options) -> Report:
    """Start weights for ``train(pretrained=...)``, learnt on simulated colons
    (``endoloc pretrain``)."""
    return job("pretrain", progress, options)


def demo(*, progress=None, **options) -> Report:
    """The whole method on the built-in colon, from nothing to a report (``endoloc demo``)."""
    return job("demo", progress, options)


def run(config, *, force: bool = False, progress=None) -> Report:
    """The whole chain from one TOML file (``endoloc run --config FILE``)."""
    return _endoloc.run_config(config, force=force, progress=progress_callback(progress))
