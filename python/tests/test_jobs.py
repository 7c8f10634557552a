"""Jobs from Python: the command line's options as keyword arguments, progress to a callback,
and the GIL released while they run."""

from __future__ import annotations

import ast
import re
import subprocess
import threading
import time
from pathlib import Path

import pytest

import endoloc

JOBS = {
    "simulate": "simulate",
    "train": "train",
    "map": "map",
    "localize": "localize",
    "eval": "eval",
    "classify": "classify",
    "view": "view",
    "features": "features",
    "pretrain": "pretrain",
    "demo": "demo",
    "experiment.benchmark": "experiment benchmark",
    "experiment.changes": "experiment changes",
    "experiment.compare": "experiment compare",
    "experiment.zones": "experiment zones",
    "experiment.expert": "experiment expert",
    "experiment.perturb": "experiment perturb",
}
# Options of the command line that are no job setting: logging, the thread pool, printing.
CLI_ONLY = {"help", "version", "verbose", "quiet", "threads", "print_config"}
# The live view's server (`localize --serve`) runs from the command line only.
CLI_ONLY_BY_JOB = {"localize": {"serve", "train_data", "exit_at_end"}}
# Positional arguments of the command line, keyword arguments in Python.
POSITIONAL = {"view": {"run"}, "features": {"image"}}

PACKAGE = Path(endoloc.__file__).parent


def stub_options(stub: Path, name: str) -> list[str]:
    tree = ast.parse(stub.read_text())
    fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name)
    return [a.arg for a in fn.args.kwonlyargs if a.arg != "progress"]


@pytest.mark.parametrize("job", list(JOBS))
def test_type_stubs_list_every_option_of_every_job(job):
    stub = PACKAGE / ("experiment.pyi" if job.startswith("experiment.") else "__init__.pyi")
    assert sorted(stub_options(stub, job.split(".")[-1])) == sorted(endoloc.options(job))


@pytest.mark.parametrize("job", list(JOBS))
def test_keyword_arguments_are_the_command_line_options(job, cli):
    text = subprocess.run(
        [str(cli.binary), *JOBS[job].split(), "--help"], capture_output=True, text=True, check=True
    ).stdout
    flags = {m.replace("-", "_") for m in re.findall(r"^\s{2,6}(?:-\w, )?--([a-z0-9-]+)(?=[\s<=]|$)", text, re.M)}
    python = {o.rstrip("_") for o in endoloc.options(job)}  # from_: `from` is a Python keyword
    assert flags - CLI_ONLY - CLI_ONLY_BY_JOB.get(job, set()) == python - POSITIONAL.get(job, set())


@pytest.mark.parametrize("job, field", [("localize", "confirm"), ("simulate", "depth")])
def test_a_no_option_comes_with_its_field(job, field):
    # `no_x=True` is `x=False`, as `--no-x` and `--x` are on the command line.
    assert {field, "no_" + field} <= set(endoloc.options(job))


def test_zones_are_a_count_or_anatomical(tiny, tmp_path):
    data = tiny / "data"
    uniform = endoloc.train(data=data, zones=8, pretrained="builtin-joint", epochs=0, out=tmp_path / "u")
    assert "zones = 8\n" in uniform.settings
    assert endoloc.Model.load(tmp_path / "u").zone_count == 8
    expert = endoloc.train(data=data, zones="expert:9", pretrained="builtin-joint", epochs=0, out=tmp_path / "e")
    assert 'zones = "expert:9"' in expert.settings
    assert endoloc.Model.load(tmp_path / "e").zone_count == 9
    with pytest.raises(ValueError, match="expert:N"):
        endoloc.train(data=data, zones="many", out=tmp_path / "x")


def test_progress_reaches_the_callback_from_worker_threads(tiny, tmp_path):
    events = []
    endoloc.localize(
        model=tiny / "model",
        seq=tiny / "data" / "test",
        out=tmp_path / "run",
        progress=lambda *e: events.append(e),
    )
    kinds = [e[0] for e in events]
    assert kinds[0] == "start" and kinds[-1] == "finish"
    last = [e for e in events if e[0] == "progress"][-1]
    assert last[2:] == (30, 30)


def test_an_exception_in_the_callback_is_raised_after_the_job(tiny, tmp_path):
    def stop(event, text, done, total):
        if event == "progress":
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        endoloc.localize(model=tiny / "model", seq=tiny / "data" / "test", out=tmp_path / "r", progress=stop)


def test_print_progress_writes_notes(tiny, tmp_path, capsys):
    endoloc.map(model=tiny / "model", data=tiny / "data", threshold=20, force=True, progress=endoloc.PrintProgress())
    assert capsys.readouterr().err.strip()


def test_jobs_release_the_gil(tiny, tmp_path):
    ticks = []
    done = threading.Event()

    def tick():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.005)

    t = threading.Thread(target=tick)
    t.start()
    try:
        start = time.perf_counter()
        endoloc.localize(model=tiny / "model", seq=tiny / "data" / "test", out=tmp_path / "r", live=True)
        took = time.perf_counter() - start
    finally:
        done.set()
        t.join()
    # Another Python thread kept running while the job ran.
    assert took > 0.05 and len([x for x in ticks if start < x < start + took]) >= 5


def test_simulate_returns_the_dataset_and_report_text(tmp_path):
    ds = endoloc.simulate(preset="small", train_frames=12, test_frames=6, width=96, height=72, out=tmp_path / "d", no_depth=True)
    assert isinstance(ds, endoloc.Dataset) and len(ds["test"]) == 6
    assert not ds["test"].has_depth
    again = endoloc.simulate(preset="small", train_frames=12, test_frames=6, width=96, height=72, out=tmp_path / "e", no_depth=True)
    import numpy as np

    assert np.array_equal(again["test"][3], ds["test"][3])  # seeded: the same frames


def test_report_text_is_what_the_command_prints(tiny, tmp_path):
    r = endoloc.map(model=tiny / "model", data=tiny / "data", threshold=20, force=True)
    assert r.job == "map" and Path(r.out) == tiny / "model"
    assert "threshold = 20.0" in r.settings
    assert str(r) == r.text and r.text


def test_a_video_with_its_tracker_log_imports_as_a_dataset(tiny, tmp_path):
    # The tiny training pass as an H.264 video, its poses as a TUM tracker log whose clock is
    # 0.1 s ahead of the video's.
    import shutil

    import numpy as np

    if shutil.which("ffmpeg") is None:
        pytest.skip("import video needs ffmpeg (Debian: apt install ffmpeg)")
    source = endoloc.Dataset(tiny / "data")
    train = source["train"]
    video = tmp_path / "pass.mp4"
    subprocess.run(
        ["ffmpeg", "-v", "error", "-framerate", "30", "-i", str(tiny / "data/train/images/%06d.png"),
         "-c:v", "libx264", "-pix_fmt", "yuv420p", str(video)],
        check=True,
    )
    times, poses = endoloc.read_tum(tiny / "data/train/poses.txt")
    log = tmp_path / "tracker.txt"
    endoloc.write_tum(log, times + 0.1, poses)
    c = source.camera
    imported = endoloc.import_video(
        video, poses=log, time_offset=0.1, out=tmp_path / "data",
        camera=f"{c.width},{c.height},{c.fx},{c.fy},{c.cx},{c.cy}",
    )
    seq = imported["train"]
    assert len(seq) == len(train)
    np.testing.assert_allclose(seq.poses, train.poses, atol=1e-6)
    # Without a log, into the same dataset: a pass of frame times only, beside the other.
    added = endoloc.import_video(
        video, out=tmp_path / "data", seq="recorded",
        camera=f"{c.width},{c.height},{c.fx},{c.fy},{c.cx},{c.cy}",
    )
    assert (added.sequences, added.unposed) == (["train"], ["recorded"])
    assert len((tmp_path / "data/recorded/frames.txt").read_text().splitlines()) == 1 + len(train)
    with pytest.raises(endoloc.EndolocError, match="camera"):
        endoloc.import_video(video, poses=log, out=tmp_path / "other")
