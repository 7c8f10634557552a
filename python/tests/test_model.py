"""The zone classifier from Python."""

from __future__ import annotations

import numpy as np
import pytest

import endoloc


def test_classify_gives_the_zone_with_the_lowest_score(tiny):
    model = endoloc.Model.load(tiny / "model")
    assert model.zone_count == 6
    assert model.zone_poses.shape == (6, 4, 4)
    seq = endoloc.Dataset(tiny / "data")["train"]
    zone, scores = model.classify(seq[10])
    assert scores.shape == (6,) and scores.dtype == np.float32
    assert 0 <= zone < 6 and zone == int(np.argmin(scores))


def test_describe_batches_equal_single_frames(tiny):
    model = endoloc.Model.load(tiny / "model")
    seq = endoloc.Dataset(tiny / "data")["test"]
    frames = [seq[i] for i in range(5)]
    stack = model.describe(np.stack(frames))
    assert stack.shape == (5, model.descriptor_dim)
    assert np.allclose(np.linalg.norm(stack, axis=1), 1.0, atol=1e-5)
    assert np.array_equal(model.describe(frames), stack)
    assert np.allclose(model.describe(frames[2])[0], stack[2], atol=1e-6)
