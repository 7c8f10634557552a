"""The localizer from Python gives what `endoloc localize` gives, to the last digit."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import endoloc


def tum_line(t: float, r: endoloc.FrameResult) -> str:
    """A TUM line formatted as endoloc writes it (9 decimals in mm, 12 in the quaternion)."""
    x, y, z = r.position
    qx, qy, qz, qw = r.quaternion
    return f"{t:.6f} {x:.9f} {y:.9f} {z:.9f} {qx:.12f} {qy:.12f} {qz:.12f} {qw:.12f}"


def lines(path) -> list[str]:
    return [l for l in open(path).read().splitlines() if l and not l.startswith("#")]


def frames_csv(path) -> list[dict]:
    """frames.csv without its time column (wall time differs between runs)."""
    with open(path) as f:
        return [{k: v for k, v in row.items() if k != "time_ms"} for row in csv.DictReader(f)]


def row(i: int, r: endoloc.FrameResult) -> dict:
    """The frames.csv row of a Python result, as endoloc formats it."""
    return {
        "frame": str(i),
        "zone": "" if r.zone is None else str(r.zone),
        "status": r.status,
        "reason": r.reason or "",
        "inliers": "" if r.zone is None else str(r.inliers),
    }


def test_live_localization_equals_the_command_line_on_the_small_preset(small, cli, tmp_path):
    seq = endoloc.Dataset(small / "data")["test"]
    cli("localize", "--model", small / "model", "--seq", seq.path, "--out", tmp_path / "cli", "--live")
    loc = endoloc.Localizer(endoloc.Model.load(small / "model"), live=True)
    results = [loc.localize(seq[i]) for i in range(len(seq))]
    assert loc.frames == len(seq)

    # Poses: every line of the command's trajectory.txt, to the last printed digit.
    expected = lines(tmp_path / "cli" / "trajectory.txt")
    got = [tum_line(t, r) for t, r in zip(seq.timestamps, results) if r.pose is not None]
    assert len(got) == len(expected) > 0
    assert got == expected
    # Status, reason, zone and inliers of every frame.
    want = frames_csv(tmp_path / "cli" / "frames.csv")
    assert len(want) == len(results)
    for i, (w, r) in enumerate(zip(want, results)):
        mine = row(i, r)
        for k in ("frame", "zone", "status", "reason", "inliers"):
            assert mine[k] == w[k], (i, k, mine[k], w[k])
    # The method works: most frames of the small preset are refined, within millimetres.
    refined = [r for r in results if r.status == "refined"]
    assert len(refined) / len(results) > 0.9
    err = [np.linalg.norm(r.position - seq.poses[i][:3, 3]) for i, r in enumerate(results) if r.status == "refined"]
    assert np.median(err) < 2.0

    # The localize job from Python writes the same files as the command.
    report = endoloc.localize(model=small / "model", seq=seq.path, out=tmp_path / "py", live=True)
    assert open(tmp_path / "py" / "trajectory.txt").read() == open(tmp_path / "cli" / "trajectory.txt").read()
    assert frames_csv(tmp_path / "py" / "frames.csv") == want
    assert [tum_line(t, r) for t, r in zip(seq.timestamps, report.frames) if r.pose is not None] == expected

    # And evaluation from Python reads them back: metrics.json as a dict.
    ev = endoloc.eval(gt=seq.path / "poses.txt", est=tmp_path / "py" / "trajectory.txt", no_plots=True)
    m = ev.metrics
    assert m["frames"] == len(seq) and m["position_mm"]["median"] < 2.0
    assert m["status_counts"]["refined"] == len(refined)


def test_per_frame_localization_equals_the_job(tiny, tmp_path):
    seq = endoloc.Dataset(tiny / "data")["test"]
    report = endoloc.localize(model=tiny / "model", seq=seq.path, out=tmp_path / "run")
    assert len(report.frames) == len(seq)
    loc = endoloc.Localizer(tiny / "model")
    assert not loc.live and loc.frames == 0
    for i in range(len(seq)):
        r, j = loc.localize(seq[i]), report.frames[i]
        assert (r.status, r.reason, r.zone, r.inliers) == (j.status, j.reason, j.zone, j.inliers)
        if r.pose is None:
            assert j.pose is None
        else:
            assert np.array_equal(r.pose, j.pose)
        assert r.wall_ms is not None and r.wall_ms >= r.time_ms * 0.5
        assert j.wall_ms is None


def test_a_result_carries_what_frames_csv_carries(tiny):
    seq = endoloc.Dataset(tiny / "data")["test"]
    loc = endoloc.Localizer(tiny / "model", live=True)
    r = loc.localize(seq[0])
    assert r.status in ("refined", "init_only", "rejected")
    assert (r.reason is None) == (r.status == "refined")
    if r.pose is not None:
        p = r.pose
        assert p.shape == (4, 4) and np.allclose(p[:3, 3], r.position)
        assert r.quaternion[3] >= 0 and np.isclose(np.linalg.norm(r.quaternion), 1.0)
    assert set(r.times_ms) == {"zone", "surf", "matching", "refine"}
    assert np.isclose(sum(r.times_ms.values()), r.time_ms)
    assert r.inlier_px.shape == (r.inliers, 2) if r.status == "refined" else r.inlier_px.ndim == 2
    assert 0 <= r.zone < 6
    loc.reset()
    assert loc.frames == 0


def test_live_state_is_kept_between_calls_and_reset(tiny):
    seq = endoloc.Dataset(tiny / "data")["test"]
    loc = endoloc.Localizer(tiny / "model", live=True)
    first = [loc.localize(seq[i]) for i in range(10)]
    loc.reset()
    again = [loc.localize(seq[i]) for i in range(10)]
    assert [r.status for r in first] == [r.status for r in again]
    assert all(
        (a.pose is None and b.pose is None) or np.array_equal(a.pose, b.pose) for a, b in zip(first, again)
    )


def test_localizer_options_are_the_commands(tiny):
    seq = endoloc.Dataset(tiny / "data")["test"]
    loc = endoloc.Localizer(tiny / "model", candidate_zones=1, threshold=40.0, max_rms_px=3.0)
    assert "candidate_zones = 1" in loc.settings and "threshold = 40.0" in loc.settings
    loc.localize(seq[0])
    assert "confirm = true" in loc.settings
    for off in ({"no_confirm": True}, {"confirm": False}):
        assert "confirm = false" in endoloc.Localizer(tiny / "model", **off).settings
    with pytest.raises(ValueError, match="contradict"):
        endoloc.Localizer(tiny / "model", confirm=True, no_confirm=True)
    with pytest.raises(TypeError, match="unexpected keyword argument \"out\""):
        endoloc.Localizer(tiny / "model", out="runs/x")
    with pytest.raises(ValueError, match="candidate_zones"):
        endoloc.Localizer(tiny / "model", candidate_zones="three")


def write_gray_png(path, img):
    """An 8-bit grey PNG, written with the standard library only."""
    import struct
    import zlib

    h, w = img.shape
    raw = b"".join(b"\x00" + img[y].astype(np.uint8).tobytes() for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def test_a_masked_localizer_keeps_to_the_mask_and_says_which_file_does_not_fit(tiny, tmp_path):
    seq = endoloc.Dataset(tiny / "data")["test"]
    frame = seq[5]
    h, w = frame.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    inside = (xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2 <= (0.45 * w) ** 2
    path = tmp_path / "mask.png"
    write_gray_png(path, np.where(inside, 255, 0))
    masked = endoloc.Localizer(tiny / "model", mask=path)
    r = masked.localize(frame)
    # No inlier keypoint outside the mask.
    for x, y in r.inlier_px:
        assert inside[int(round(y)), int(round(x))]
    # The border does not change what the zone network sees.
    noisy = frame.copy()
    noisy[~inside] = 200
    assert masked.localize(noisy).zone == r.zone
    small = tmp_path / "small.png"
    write_gray_png(small, np.full((h // 2, w // 2), 255))
    with pytest.raises(endoloc.EndolocError, match="small.png"):
        endoloc.Localizer(tiny / "model", mask=small)


def test_a_video_feeds_the_localizer_as_localize_video_does(tiny, tmp_path):
    # The tiny test pass as an H.264 video: its frames from `VideoFrames` through a live
    # `Localizer` give the rows `localize(video=..., live=True)` writes.
    import shutil
    import subprocess

    if shutil.which("ffmpeg") is None:
        pytest.skip("a video is decoded with ffmpeg (Debian: apt install ffmpeg)")
    video = tmp_path / "pass.mp4"
    subprocess.run(
        ["ffmpeg", "-v", "error", "-framerate", "30", "-i", str(tiny / "data/test/images/%06d.png"),
         "-c:v", "libx264", "-pix_fmt", "yuv420p", str(video)],
        check=True,
    )
    loc = endoloc.Localizer(tiny / "model", live=True)
    frames = endoloc.VideoFrames(video, size=(160, 120))
    assert frames.native_size == (160, 120)
    results = [(i, t, loc.localize(image)) for i, t, image in frames]
    assert [i for i, _, _ in results] == list(range(30))
    assert results[1][1] == pytest.approx(1 / 30)
    report = endoloc.localize(model=tiny / "model", video=video, live=True, out=tmp_path / "run")
    streamed = frames_csv(tmp_path / "run/frames.csv")
    assert [{k: r[k] for k in ("frame", "zone", "status", "reason", "inliers")} for r in streamed] == [
        row(i, r) for i, _, r in results
    ]
    assert "stream.csv" in report.text
