#!/usr/bin/env python3
"""COLMAP as a precision reference for endoloc's test poses.

COLMAP (Debian's `colmap` package, 3.8, CPU) registers the test frames of an endoloc dataset
against a map triangulated from the training frames' known poses, the same task endoloc's
two-step refinement solves; the script then compares COLMAP's and endoloc's errors on the
frames COLMAP registers, and their time per test frame.

    python3 tools/colmap_reference.py --data data/paper --run runs/live --out colmap/paper

Steps (all in --out; nothing else is written):
  1. `images/`: every --train-every-th training frame and every --test-every-th test frame
     (links); SIFT features of all of them (`colmap feature_extractor`, the dataset's pinhole
     camera, principal point shifted by +0.5 px to COLMAP's pixel convention).
  2. Pairs (`colmap matches_importer`): each training image with its --overlap successors
     along the pass; each test image with the --neighbours training images nearest to
     endoloc's own pose for that frame (from --run), so that COLMAP is spared a search
     across the colon and judged on precision only.
  3. `colmap point_triangulator` on the training images with their poses held fixed (T_wc
     from the dataset, mm), intrinsics fixed; then `colmap image_registrator` adds the test
     images.
  4. Errors against the ground truth: position ‖t_est − t_gt‖ (mm) and the geodesic angle of
     R_estᵀ R_gt (degrees), for COLMAP and for endoloc's trajectory on the same frames;
     `report.md` and `errors.csv` in --out.

Only the Python standard library is needed besides the `colmap` program.
"""

import argparse
import csv
import math
import os
import shutil
import sqlite3
import subprocess
import sys
import time
import tomllib
from pathlib import Path


def read_tum(path):
    """TUM lines `t tx ty tz qx qy qz qw` → list of (t, (tx, ty, tz), (qw, qx, qy, qz))."""
    poses = []
    for line in Path(path).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        v = [float(x) for x in line.split()]
        if len(v) != 8:
            sys.exit(f"{path}: expected 8 columns, got {len(v)}: {line}")
        poses.append((v[0], (v[1], v[2], v[3]), (v[7], v[4], v[5], v[6])))
    return poses


def quat_to_rot(q):
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def transpose(r):
    return [[r[j][i] for j in range(3)] for i in range(3)]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def matvec(a, v):
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]


def inverse_pose(q, t):
    """T_wc ↔ T_cw: (R, t) → (Rᵀ, −Rᵀ t), with R as a quaternion (w, x, y, z)."""
    w, x, y, z = q
    rt = transpose(quat_to_rot(q))
    return (w, -x, -y, -z), [-c for c in matvec(rt, t)]


def errors(est, gt):
    """(position mm, orientation degrees) of est against gt, both (t, q) with q = (w, x, y, z)."""
    (te, qe), (tg, qg) = est, gt
    pos = math.dist(te, tg)
    r = matmul(transpose(quat_to_rot(qe)), quat_to_rot(qg))
    c = max(-1.0, min(1.0, (r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0))
    return pos, math.degrees(math.acos(c))


def run(cmd, log):
    log.write("$ " + " ".join(str(c) for c in cmd) + "\n")
    log.flush()
    t = time.monotonic()
    p = subprocess.run([str(c) for c in cmd], stdout=log, stderr=subprocess.STDOUT)
    if p.returncode != 0:
        sys.exit(f"{cmd[0]} {cmd[1]} failed (exit {p.returncode}); see {log.name}")
    return time.monotonic() - t


def median(v):
    s = sorted(v)
    n = len(s)
    if n == 0:
        return float("nan")
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, type=Path, help="endoloc dataset (train/ and test/)")
    ap.add_argument("--run", required=True, type=Path, help="endoloc localize output folder (trajectory.txt)")
    ap.add_argument("--out", required=True, type=Path, help="working folder (must not exist, or --force)")
    ap.add_argument("--train-every", type=int, default=4)
    ap.add_argument("--test-every", type=int, default=26)
    ap.add_argument("--overlap", type=int, default=8, help="training successors matched per training image")
    ap.add_argument("--neighbours", type=int, default=12, help="training images matched per test image")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--force", action="store_true", help="replace an existing --out")
    a = ap.parse_args()

    if shutil.which("colmap") is None:
        sys.exit("colmap not found: install it (Debian: apt-get install colmap)")
    meta = tomllib.loads((a.data / "dataset.toml").read_text())
    cam = meta["camera"]
    if cam.get("model", "pinhole") != "pinhole":
        sys.exit(f"{a.data}/dataset.toml: camera model {cam.get('model')}; this script handles pinhole cameras")
    if a.out.exists():
        if not a.force:
            sys.exit(f"{a.out} exists; use --force to replace it")
        shutil.rmtree(a.out)
    (a.out / "images").mkdir(parents=True)
    log = open(a.out / "colmap.log", "w")

    train = read_tum(a.data / "train" / "poses.txt")
    test = read_tum(a.data / "test" / "poses.txt")
    est = {round(t, 6): (tv, q) for t, tv, q in read_tum(a.run / "trajectory.txt")}
    train_ids = list(range(0, len(train), a.train_every))
    test_ids = list(range(0, len(test), a.test_every))
    names = {}
    for split, ids in (("train", train_ids), ("test", test_ids)):
        for i in ids:
            name = f"{split}_{i:06d}.png"
            os.symlink((a.data / split / "images" / f"{i:06d}.png").resolve(), a.out / "images" / name)
            names[(split, i)] = name

    db = a.out / "database.db"
    params = f"{cam['fx']},{cam['fy']},{cam['cx'] + 0.5},{cam['cy'] + 0.5}"
    t_extract = run(["colmap", "feature_extractor", "--database_path", db, "--image_path", a.out / "images",
                     "--ImageReader.camera_model", "PINHOLE", "--ImageReader.single_camera", "1",
                     "--ImageReader.camera_params", params, "--SiftExtraction.use_gpu", "0",
                     "--SiftExtraction.num_threads", a.threads], log)

    pairs = []
    for k, i in enumerate(train_ids):
        for j in train_ids[k + 1:k + 1 + a.overlap]:
            pairs.append((names[("train", i)], names[("train", j)]))
    paired_tests = []
    for i in test_ids:
        e = est.get(round(test[i][0], 6))
        if e is None:
            continue
        near = sorted(train_ids, key=lambda j: math.dist(train[j][1], e[0]))[:a.neighbours]
        pairs += [(names[("test", i)], names[("train", j)]) for j in near]
        paired_tests.append(i)
    (a.out / "pairs.txt").write_text("".join(f"{p} {q}\n" for p, q in pairs))
    t_match = run(["colmap", "matches_importer", "--database_path", db, "--match_list_path", a.out / "pairs.txt",
                   "--match_type", "pairs", "--SiftMatching.use_gpu", "0",
                   "--SiftMatching.num_threads", a.threads], log)

    con = sqlite3.connect(db)
    ids = dict(con.execute("SELECT name, image_id FROM images"))
    cam_id = con.execute("SELECT camera_id FROM cameras").fetchone()[0]
    con.close()
    model_in = a.out / "model_in"
    model_in.mkdir()
    (model_in / "cameras.txt").write_text(f"{cam_id} PINHOLE {cam['width']} {cam['height']} {params.replace(',', ' ')}\n")
    lines = []
    for i in train_ids:
        _, t_wc, q_wc = train[i]
        q, t = inverse_pose(q_wc, t_wc)
        name = names[("train", i)]
        lines.append(f"{ids[name]} {q[0]} {q[1]} {q[2]} {q[3]} {t[0]} {t[1]} {t[2]} {cam_id} {name}\n\n")
    (model_in / "images.txt").write_text("".join(lines))
    (model_in / "points3D.txt").write_text("")
    fixed = ["--Mapper.ba_refine_focal_length", "0", "--Mapper.ba_refine_principal_point", "0",
             "--Mapper.ba_refine_extra_params", "0"]
    tri = a.out / "model_tri"
    tri.mkdir()
    t_tri = run(["colmap", "point_triangulator", "--database_path", db, "--image_path", a.out / "images",
                 "--input_path", model_in, "--output_path", tri] + fixed, log)
    reg = a.out / "model_reg"
    reg.mkdir()
    t_reg = run(["colmap", "image_registrator", "--database_path", db, "--input_path", tri,
                 "--output_path", reg] + fixed, log)
    txt = a.out / "model_txt"
    txt.mkdir()
    run(["colmap", "model_converter", "--input_path", reg, "--output_path", txt, "--output_type", "TXT"], log)

    registered = {}
    rows = (txt / "images.txt").read_text().splitlines()
    # Two lines per image after the comments: the pose, then its 2-D points (may be empty).
    body = [r for r in rows if not r.startswith("#")]
    for r in body[0::2]:
        v = r.split()
        name = v[9]
        if name.startswith("test_"):
            q_cw = tuple(float(x) for x in v[1:5])
            t_cw = [float(x) for x in v[5:8]]
            q, t = inverse_pose(q_cw, t_cw)
            registered[int(name[5:11])] = (t, q)

    out_rows = []
    for i in test_ids:
        gt = (list(test[i][1]), test[i][2])
        c = registered.get(i)
        e = est.get(round(test[i][0], 6))
        ce = errors(c, gt) if c else (None, None)
        ee = errors((list(e[0]), e[1]), gt) if e else (None, None)
        out_rows.append((i, *ce, *ee))
    with open(a.out / "errors.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["frame", "colmap_position_mm", "colmap_orientation_deg", "endoloc_position_mm", "endoloc_orientation_deg"])
        for r in out_rows:
            w.writerow([r[0]] + ["" if x is None else f"{x:.6f}" for x in r[1:]])

    both = [r for r in out_rows if r[1] is not None and r[3] is not None]
    n_test = len(test_ids)
    n_images = len(train_ids) + n_test
    per_test = (t_extract / n_images) + (t_match * a.neighbours / max(len(pairs), 1)) + t_reg / max(len(paired_tests), 1)
    report = [
        "# COLMAP reference",
        "",
        f"- dataset `{a.data}`, endoloc run `{a.run}`; {len(train_ids)} training images (every {a.train_every}th), "
        f"{n_test} test images (every {a.test_every}th); COLMAP {subprocess.run(['colmap', '-h'], capture_output=True, text=True).stdout.split()[1]} on the CPU, {a.threads} threads",
        f"- COLMAP registered {len(registered)} of {n_test} test images ({100 * len(registered) / n_test:.1f} %); "
        f"endoloc gave a pose to {sum(1 for r in out_rows if r[3] is not None)} of them",
        "",
        "| on the frames both posed | median position (mm) | median orientation (°) | mean position (mm) | mean orientation (°) |",
        "|---|---|---|---|---|",
    ]
    for label, k in (("COLMAP", 1), ("endoloc", 3)):
        p = [r[k] for r in both]
        o = [r[k + 1] for r in both]
        mean = lambda v: sum(v) / len(v) if v else float("nan")
        report.append(f"| {label} ({len(both)} frames) | {median(p):.3f} | {median(o):.3f} | {mean(p):.3f} | {mean(o):.3f} |")
    report += [
        "",
        f"COLMAP wall time: features {t_extract:.1f} s for {n_images} images, matching {t_match:.1f} s for {len(pairs)} pairs, "
        f"triangulation {t_tri:.1f} s, registration {t_reg:.1f} s; per test frame (its features, its {a.neighbours} "
        f"pairs, its registration) ≈ {1000 * per_test:.0f} ms.",
        "",
    ]
    (a.out / "report.md").write_text("\n".join(report))
    print("\n".join(report))


if __name__ == "__main__":
    main()
