"""Per-frame overhead of localizing from Python over the Rust call it wraps.

For every frame of a sequence (live, in order, as `endoloc localize --live`), the Python call
`Localizer.localize(frame)` is timed with `time.perf_counter`, and the library call inside it
(`Localizer::localize_live` on the converted image) with Rust's clock (`FrameResult.wall_ms`):
the difference is what Python adds — argument conversion (a copy of the frame), releasing
and retaking the GIL, and building the result. A second pass times the same library calls
from a Rust loop (no Python between frames) for comparison.

    python python/bench/overhead.py --data DATASET --model MODEL [--seq test] [--frames N]
    python python/bench/overhead.py --setup DIR      # simulate the small preset, index, map
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import endoloc
from endoloc import _endoloc


def setup(root: Path) -> tuple[Path, Path]:
    data, model = root / "data", root / "model"
    if not (data / "dataset.toml").is_file():
        endoloc.simulate(preset="small", out=data)
    if not (model / "map.toml").is_file():
        endoloc.train(data=data, zones=50, out=model, pretrained="builtin-joint", epochs=0, force=True)
        endoloc.map(model=model, data=data, force=True)
    return data, model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path)
    ap.add_argument("--model", type=Path)
    ap.add_argument("--setup", type=Path, help="simulate/index/map the small preset here first")
    ap.add_argument("--seq", default="test")
    ap.add_argument("--frames", type=int, default=0, help="first N frames (0: all)")
    a = ap.parse_args()
    if a.setup:
        a.data, a.model = setup(a.setup)
    if not (a.data and a.model):
        ap.error("give --data and --model, or --setup DIR")

    seq = endoloc.Dataset(a.data)[a.seq]
    n = len(seq) if a.frames <= 0 else min(a.frames, len(seq))
    frames = [seq[i] for i in range(n)]
    model = endoloc.Model.load(a.model)

    loc = endoloc.Localizer(model, live=True)
    py_s, lib_s = [], []
    for f in frames:
        t = time.perf_counter()
        r = loc.localize(f)
        py_s.append(time.perf_counter() - t)
        lib_s.append(r.wall_ms / 1e3)
    over_ms = [1e3 * (p - l) for p, l in zip(py_s, lib_s)]

    loc.reset()
    rust_s = _endoloc.time_rust_calls(loc, frames)

    q = lambda v, p: float(np.percentile(v, p))  # noqa: E731
    print(f"frames               {n} of {seq.path} ({frames[0].shape[1]}x{frames[0].shape[0]}), live")
    print(f"Python call          median {1e3 * statistics.median(py_s):.2f} ms per frame, total {sum(py_s):.2f} s")
    print(f"Rust call (inside)   median {1e3 * statistics.median(lib_s):.2f} ms per frame, total {sum(lib_s):.2f} s")
    print(f"Rust loop            median {1e3 * statistics.median(rust_s):.2f} ms per frame, total {sum(rust_s):.2f} s")
    print(
        f"overhead per frame   median {statistics.median(over_ms):.3f} ms, mean {statistics.mean(over_ms):.3f} ms, "
        f"p95 {q(over_ms, 95):.3f} ms, max {max(over_ms):.3f} ms"
    )


if __name__ == "__main__":
    main()
