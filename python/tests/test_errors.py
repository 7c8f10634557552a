"""Bad input raises a Python exception with endoloc's message: the file, the line and what
was expected."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import endoloc


def test_a_missing_dataset_names_the_file():
    with pytest.raises(endoloc.EndolocError, match=r"nowhere: no such folder"):
        endoloc.Dataset("nowhere")


def test_a_bad_dataset_toml_names_file_line_and_expectation(tiny, tmp_path):
    copy = tmp_path / "ds"
    shutil.copytree(tiny / "data", copy)
    text = (copy / "dataset.toml").read_text()
    (copy / "dataset.toml").write_text(text.replace("units = \"mm\"", "units = \"cm\""))
    with pytest.raises(endoloc.EndolocError, match=r"dataset.toml.*units = \"cm\"; expected \"mm\""):
        endoloc.Dataset(copy)
    lines = text.splitlines()
    k = next(i for i, l in enumerate(lines) if l.startswith("width"))
    lines[k] = "width = \"wide\""
    (copy / "dataset.toml").write_text("\n".join(lines))
    with pytest.raises(endoloc.EndolocError, match=rf"dataset.toml:{k + 1}: invalid type: string \"wide\", expected u32"):
        endoloc.Dataset(copy)


def test_a_bad_poses_line_is_named(tiny, tmp_path):
    seq = tmp_path / "test"
    shutil.copytree(tiny / "data" / "test", seq)
    lines = (seq / "poses.txt").read_text().splitlines()
    k = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    lines[k] = "0.0 1 2 three 0 0 0 1"
    (seq / "poses.txt").write_text("\n".join(lines) + "\n")
    with pytest.raises(endoloc.EndolocError, match=rf"poses.txt:{k + 1}: column 4 \(tz\): \"three\" is not a number"):
        endoloc.Sequence(seq)


def test_a_folder_that_is_no_model_is_refused(tiny):
    with pytest.raises(endoloc.EndolocError, match=r"loading model .*data.*model.toml"):
        endoloc.Model.load(tiny / "data")
    with pytest.raises(endoloc.EndolocError, match="loading model"):
        endoloc.Localizer(tiny / "data")


def test_images_of_another_size_or_type_are_refused(tiny):
    model = endoloc.Model.load(tiny / "model")
    loc = endoloc.Localizer(model, live=True)
    with pytest.raises(endoloc.EndolocError, match=r"image is 64x48 but the model was trained on 160x120"):
        loc.localize(np.zeros((48, 64), np.uint8))
    with pytest.raises(TypeError, match="uint8.*float64"):
        loc.localize(np.zeros((120, 160)))
    with pytest.raises(ValueError, match=r"shape \(H, W\)"):
        loc.localize(np.zeros((120, 160, 2), np.uint8))
    with pytest.raises(TypeError, match="NumPy array of uint8"):
        model.classify("frame.png")
    assert loc.frames == 0  # refused frames do not advance the live stream


def test_job_options_are_checked_before_anything_runs(tmp_path):
    with pytest.raises(TypeError, match=r"unexpected keyword argument \"epoch\".*epochs"):
        endoloc.train(data=tmp_path, out=tmp_path / "m", epoch=3)
    with pytest.raises(ValueError, match=r"(?s)line 2.*images_per_zone = \"many\".*expected usize"):
        endoloc.map(model=tmp_path, data=tmp_path, images_per_zone="many")
    with pytest.raises(TypeError, match="option seed: expected"):
        endoloc.simulate(out=tmp_path / "d", seed=object())
    with pytest.raises(ValueError, match="unknown variant `sideways`"):
        endoloc.localize(model=tmp_path, seq=tmp_path, out=tmp_path / "r", method="sideways")
    assert list(tmp_path.iterdir()) == []


def test_a_job_error_carries_every_cause(tiny, tmp_path):
    out = tmp_path / "run"
    endoloc.localize(model=tiny / "model", seq=tiny / "data" / "test", out=out)
    with pytest.raises(endoloc.EndolocError, match=r"trajectory.txt exists; `force` replaces it"):
        endoloc.localize(model=tiny / "model", seq=tiny / "data" / "test", out=out)
    endoloc.localize(model=tiny / "model", seq=tiny / "data" / "test", out=out, force=True)
    with pytest.raises(endoloc.EndolocError, match=r"no sequence \"validation\" in this dataset; it has: test, train"):
        endoloc.map(model=tiny / "model", data=tiny / "data", seq="validation", force=True)
