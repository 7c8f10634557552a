"""Datasets, images and poses: what Python reads is what endoloc reads, and poses survive a
round trip through a TUM file."""

from __future__ import annotations

import numpy as np
import pytest

import endoloc


def test_dataset_exposes_camera_sequences_and_frames(tiny):
    ds = endoloc.Dataset(tiny / "data")
    assert ds.sequences == ["test", "train"]
    assert "test" in ds and "nope" not in ds
    cam = ds.camera
    assert (cam.width, cam.height) == (160, 120)
    assert np.allclose(cam.K, [[cam.fx, 0, cam.cx], [0, cam.fy, cam.cy], [0, 0, 1]])
    assert ds.simulation is not None and "seed" in ds.simulation
    test = ds["test"]
    assert len(test) == 30
    img = test[0]
    assert img.dtype == np.uint8 and img.shape == (120, 160)
    assert np.array_equal(test[-1], test[29])
    assert test.image(3, rgb=True).shape == (120, 160, 3)
    assert test.poses.shape == (30, 4, 4) and test.timestamps.shape == (30,)
    assert np.array_equal(test.pose(5), test.poses[5])
    assert len(test.sections) == 30
    with pytest.raises(IndexError, match="out of range"):
        test[30]
    with pytest.raises(KeyError, match="no sequence"):
        ds["validation"]


def test_poses_are_rigid_camera_to_world_in_mm(tiny):
    poses = endoloc.Dataset(tiny / "data")["train"].poses
    r = poses[:, :3, :3]
    assert np.allclose(r @ r.transpose(0, 2, 1), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(r), 1.0)
    assert np.array_equal(poses[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (len(poses), 1)))
    # The scope moves millimetres between frames at 30 fps, not metres or micrometres.
    steps = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    assert 0.05 < np.median(steps) < 20.0


def test_poses_round_trip_through_a_tum_file(tiny, tmp_path):
    seq = endoloc.Dataset(tiny / "data")["test"]
    t, poses = endoloc.read_tum(seq.path / "poses.txt")
    assert np.array_equal(t, seq.timestamps) and np.array_equal(poses, seq.poses)
    out = tmp_path / "copy.txt"
    endoloc.write_tum(out, t, poses)
    t2, poses2 = endoloc.read_tum(out)
    assert np.array_equal(t2, t)
    assert np.abs(poses2 - poses).max() < 1e-9  # 9 decimals in mm, 12 in the quaternion
    # What endoloc writes is what it read: the file is the same, line for line.
    assert out.read_text().splitlines()[1:] == [
        line for line in open(seq.path / "poses.txt").read().splitlines() if not line.startswith("#")
    ]


def test_a_pose_from_python_is_checked(tmp_path):
    good = np.eye(4)
    good[:3, 3] = [1.0, 2.0, 3.0]
    endoloc.write_tum(tmp_path / "ok.txt", np.array([0.0]), [good])  # lists of arrays work too
    bad = good.copy()
    bad[0, 0] = 2.0
    with pytest.raises(ValueError, match="pose 0: .*not a rotation"):
        endoloc.write_tum(tmp_path / "bad.txt", np.array([0.0]), bad[None])
    reflection = np.diag([1.0, 1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match="not a rotation"):
        endoloc.write_tum(tmp_path / "bad.txt", np.array([0.0]), reflection[None])
    with pytest.raises(ValueError, match="bottom row"):
        shear = good.copy()
        shear[3, 0] = 1.0
        endoloc.write_tum(tmp_path / "bad.txt", np.array([0.0]), shear[None])
    with pytest.raises(ValueError, match="one time stamp per pose"):
        endoloc.write_tum(tmp_path / "bad.txt", np.array([0.0, 1.0]), good[None])
    with pytest.raises(ValueError, match="4×4"):
        endoloc.write_tum(tmp_path / "bad.txt", np.array([0.0]), np.eye(3)[None])
    assert not (tmp_path / "bad.txt").exists()


def test_images_round_trip_and_colour_is_converted_as_endoloc_does(tiny):
    model = endoloc.Model.load(tiny / "model")
    seq = endoloc.Dataset(tiny / "data")["test"]
    grey = seq[4]
    d = model.describe(grey)
    # Equal channels convert back to the same grey level: same descriptor.
    assert np.array_equal(model.describe(np.dstack([grey] * 3)), d)
    assert np.array_equal(model.describe(np.dstack([grey, grey, grey, np.full_like(grey, 255)])), d)
    # A strided view is read as its values, not its memory.
    wide = np.zeros((120, 320), np.uint8)
    wide[:, ::2] = grey
    assert np.array_equal(model.describe(wide[:, ::2]), d)
    # The RGB frame converts to the grey frame endoloc loads from the file.
    rgb = seq.image(4, rgb=True)
    assert np.array_equal(model.describe(rgb), d)
