"""Type stubs of ``endoloc.experiment``."""

import os
from collections.abc import Callable, Sequence as Seq
from typing import Literal

from ._endoloc import Report

StrPath = str | os.PathLike[str]
ProgressArg = bool | Callable[[str, str, int, int], object] | None

def benchmark(
    *,
    out: StrPath = ...,
    preset: str = ...,
    seeds: Seq[int] = ...,
    dev_seeds: Seq[int] = ...,
    gca: Seq[StrPath] = ...,
    inflation: float | None = ...,
    changes: Literal["none", "mild", "moderate", "severe"] | None = ...,
    train_frames: int | None = ...,
    test_frames: int | None = ...,
    zones: int | str = ...,
    pretrained: str = ...,
    epochs: int | None = ...,
    seed: int = ...,
    smoothed_level: float | None = ...,
    index_zoom_blur: str | None = ...,
    index_view_penalty: float | None = ...,
    methods: Seq[str] = ...,
    colon: str | None = ...,
    print_jobs: bool = ...,
    merge: bool = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """The whole chain over several colons; each method's mean ± 95 % interval across them.

    Options (the command's, ``-`` as ``_``):

    - ``out``: Output folder.
    - ``preset``: Simulator preset of every colon.
    - ``seeds``: Procedural colons: simulator seeds (default 1 to 8).
    - ``dev_seeds``: Development colons (settings were chosen on them): reported as their
      own rows, left out of the mean ± interval.
    - ``gca``: CT colons: GCA model folders.
    - ``inflation``: Lumen inflation of the CT colons.
    - ``changes``: How each colon changes between its training and test pass (default
      ``none``); the figures are then against the anatomical truth.
    - ``train_frames``: Frames of each training pass (default: the preset's).
    - ``test_frames``: Frames of each test pass (default: the preset's).
    - ``zones``: Zones: a count (uniform), or `expert` / `expert:N` (anatomical).
    - ``pretrained``: Start weights of the zone network (`builtin-joint`); empty: train
      from scratch on each colon.
    - ``epochs``: Training epochs (default: 0 with ``pretrained``, else the schedule's own).
    - ``seed``: Seed of every training.
    - ``smoothed_level``: σ of each map's smoothed level, pixels (`endoloc.map`'s
      ``smoothed_level``; default: 1.5 per 320 pixels of image width; 0 = none).
    - ``index_zoom_blur``: Zoom-blurred views of every training frame in each zone index
      (`endoloc.train`'s ``index_zoom_blur``; default none); a colon's model made earlier is
      used only when it has them.
    - ``index_view_penalty``: With ``index_zoom_blur``: `endoloc.train`'s
      ``index_view_penalty`` (default 0).
    - ``methods``: Methods (default: endoloc-paper, endoloc, endoloc-confirm, endoloc-live,
      endoloc-live-confirm, classify).
    - ``colon``: Run only this colon (`seed-N`, `dev-seed-N` or `ct-<folder>`).
    - ``print_jobs``: Print one command per colon and the merge command, and stop.
    - ``merge``: Run nothing: write the tables from the finished colons.
    - ``force``: Use an output folder that holds something else.
    """
    ...

def changes(
    *,
    out: StrPath = ...,
    preset: str = ...,
    seeds: Seq[int] = ...,
    gca: Seq[StrPath] = ...,
    inflation: float | None = ...,
    factors: Seq[str] = ...,
    severities: Seq[Literal["mild", "moderate", "severe"]] = ...,
    train_frames: int | None = ...,
    test_frames: int | None = ...,
    zones: int | str = ...,
    pretrained: str = ...,
    seed: int = ...,
    smoothed_level: float | None = ...,
    index_zoom_blur: str | None = ...,
    index_view_penalty: float | None = ...,
    keep_data: bool = ...,
    wall_motion_mm: float = ...,
    colon: str | None = ...,
    print_jobs: bool = ...,
    merge: bool = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """Each factor of a colon that changes between the passes, alone at each severity, over
    several colons: where endoloc stops holding.

    Options (the command's, ``-`` as ``_``):

    - ``out``: Output folder.
    - ``preset``: Simulator preset of every colon (default ``small``).
    - ``seeds``: Procedural colons: simulator seeds (default 1 to 5).
    - ``gca``: CT colons: GCA model folders.
    - ``inflation``: Lumen inflation of the CT colons.
    - ``factors``: Conditions, each a factor alone or factors together (default: every
      factor alone, and ``all``): shift, insufflation, deform, exposure, colour, light,
      specular, texture, residue, bubbles, blur, fov; the groups ``shape``, ``look``,
      ``scope``; ``all``; several joined by ``+`` change together (``shape+texture``).
    - ``severities``: Severities of each factor (default mild, moderate, severe).
    - ``train_frames``: Frames of each training pass (default: the preset's).
    - ``test_frames``: Frames of each test pass (default: the preset's).
    - ``zones``: Zones: a count (uniform), or `expert` / `expert:N` (anatomical).
    - ``pretrained``: Start weights of the zone network (`builtin-joint`); ``none``: train
      from scratch on each colon.
    - ``seed``: Seed of every training.
    - ``smoothed_level``: σ of each map's smoothed level, pixels (`endoloc.map`'s
      ``smoothed_level``; default: 1.5 per 320 pixels of image width; 0 = none).
    - ``index_zoom_blur``: Zoom-blurred views of every training frame in each zone index
      (`endoloc.train`'s ``index_zoom_blur``; default none); a colon's model made earlier is
      used only when it has them.
    - ``index_view_penalty``: With ``index_zoom_blur``: `endoloc.train`'s
      ``index_view_penalty`` (default 0).
    - ``keep_data``: Keep each condition's dataset (deleted once its figures are written).
    - ``wall_motion_mm``: How far the colon wall may have moved since the mapping pass, mm
      (`endoloc.localize`'s ``wall_motion_mm``; 0: a rigid colon); a folder's finished
      conditions keep the value they were localized with: another value needs another
      ``out``.
    - ``colon``: Run only this colon (`seed-N` or `ct-<folder>`).
    - ``print_jobs``: Print one command per colon and the merge command, and stop.
    - ``merge``: Run nothing: write the tables from the finished conditions.
    - ``force``: Use an output folder that holds something else.
    """
    ...

def compare(
    *,
    data: StrPath = ...,
    train: str = ...,
    test: str = ...,
    out: StrPath = ...,
    zones: int | str = ...,
    epochs: int | None = ...,
    seed: int = ...,
    threshold: float = ...,
    smoothed_level: float | None = ...,
    model: StrPath | None = ...,
    methods: Seq[str] = ...,
    wall_motion_mm: float = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """Every method on one dataset against the baselines, as the paper's Table I.

    Options (the command's, ``-`` as ``_``):

    - ``data``: Dataset with a training and a test sequence.
    - ``train``: Training sequence (default ``train``).
    - ``test``: Test sequence (default ``test``).
    - ``out``: Output folder.
    - ``zones``: Zones: a count (uniform), or `expert` / `expert:N` (anatomical).
    - ``epochs``: Training epochs of the learned models (default: each schedule's own).
    - ``seed``: Seed of every training.
    - ``threshold``: SURF threshold of the maps; test frames keep their strongest keypoints
      above 0.4 times it (a budget per frame, as the localize job does by default)
    - ``smoothed_level``: σ of the map's smoothed level, pixels (`endoloc.map`'s
      ``smoothed_level``; default: 1.5 per 320 pixels of image width; 0 = none). The map
      of a given ``model`` is used as it is, and refused when this names another level.
    - ``model``: Use this trained Siamese model (with or without a map) instead of
      training one.
    - ``methods``: Methods to run (default: all).
    - ``wall_motion_mm``: How far the colon wall may have moved since the mapping pass, mm
      (`endoloc.localize`'s ``wall_motion_mm``; 0: a rigid colon).
    - ``force``: Use an output folder that holds something else.
    """
    ...

def zones(
    *,
    data: StrPath = ...,
    train: str = ...,
    test: str = ...,
    out: StrPath = ...,
    from_: int = ...,
    to: int = ...,
    step: int = ...,
    runs: int = ...,
    epochs: int = ...,
    threshold: float = ...,
    candidate_zones: int = ...,
    keep_models: bool = ...,
    pretrained: StrPath | None = ...,
    cell: str | None = ...,
    print_jobs: bool = ...,
    merge: bool = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """Monte-Carlo sweep of the zone count (the paper's Fig. 4).

    Options (the command's, ``-`` as ``_``):

    - ``data``: Dataset with a training and a test sequence.
    - ``train``: Training sequence (default ``train``).
    - ``test``: Test sequence (default ``test``).
    - ``out``: Output folder.
    - ``from_``: Smallest zone count.
    - ``to``: Largest zone count.
    - ``step``: Step between zone counts.
    - ``runs``: Runs (training seeds 0, 1, …) per zone count.
    - ``epochs``: Training epochs per run (the `fast` schedule with fewer epochs, to fit
      a night).
    - ``threshold``: SURF threshold of the maps; test frames keep their strongest keypoints
      above 0.4 times it (a budget per frame, as the localize job does by default)
    - ``candidate_zones``: Zones tried per frame (1 = the paper's rule).
    - ``keep_models``: Keep each run's model folder (weights, descriptors) instead of
      deleting it once the run is recorded.
    - ``pretrained``: Start weights of every run (a file, or `builtin-joint`…); with
      ``epochs=0`` a run only indexes the pass with them.
    - ``cell``: Run only this cell, ``"COUNT:RUN"``; the tables are not written.
    - ``print_jobs``: Print one command per cell and the merge command, and stop.
    - ``merge``: Run nothing: write the tables from the finished cells.
    - ``force``: Use an output folder that holds something else.
    """
    ...

def expert(
    *,
    data: StrPath = ...,
    train: str = ...,
    test: str = ...,
    out: StrPath = ...,
    count: int = ...,
    uniform: int | None = ...,
    sweep: StrPath | None = ...,
    epochs: int | None = ...,
    seed: int = ...,
    threshold: float = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """Anatomical zones against the best uniform zone count.

    Options (the command's, ``-`` as ``_``):

    - ``data``: Dataset with a training and a test sequence.
    - ``train``: Training sequence (default ``train``).
    - ``test``: Test sequence (default ``test``).
    - ``out``: Output folder.
    - ``count``: Anatomical zones in all (the sections, long ones subdivided).
    - ``uniform``: Uniform zone count to compare with.
    - ``sweep``: Take the uniform count from a finished zone sweep (its best median).
    - ``epochs``: Training epochs (default: the `fast` schedule's).
    - ``seed``: Training seed.
    - ``threshold``: SURF threshold of the maps; test frames keep their strongest keypoints
      above 0.4 times it (a budget per frame, as the localize job does by default)
    - ``force``: Use an output folder that holds something else.
    """
    ...

def perturb(
    *,
    data: StrPath = ...,
    train: str = ...,
    test: str = ...,
    out: StrPath = ...,
    max: int = ...,
    every: int = ...,
    neighbours: int = ...,
    model: StrPath | None = ...,
    zones: int | str = ...,
    epochs: int | None = ...,
    seed: int = ...,
    threshold: float = ...,
    force: bool = ...,
    progress: ProgressArg = None,
) -> Report:
    """The zone forced k ± e away, errors against e (the paper's Fig. 7).

    Options (the command's, ``-`` as ``_``):

    - ``data``: Dataset with a training and a test sequence.
    - ``train``: Training sequence (default ``train``).
    - ``test``: Test sequence (default ``test``).
    - ``out``: Output folder.
    - ``max``: Largest zone offset e.
    - ``every``: Use every n-th test frame.
    - ``neighbours``: Map points also come from this many zones on each side of the
      forced one (0: the
    - ``model``: Trained model to use (trained into OUT/models/siamese when absent).
    - ``zones``: Zones when training a model.
    - ``epochs``: Training epochs when training a model.
    - ``seed``: Training seed.
    - ``threshold``: SURF threshold of a map built here and of the test frames.
    - ``force``: Use an output folder that holds something else.
    """
    ...
