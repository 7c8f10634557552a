#!/usr/bin/env python3
"""OpenCV reference for endoloc's PnP: solvePnPRansac + solvePnPRefineLM on the scenes written by
`cargo run --release -p endoloc-geometry --example pnp_scene -- scenes.json`.

    pip install opencv-contrib-python==4.12.0.88 numpy
    python3 crates/geometry/scripts/opencv_pnp_reference.py scenes.json

Prints OpenCV's position/orientation errors, ours (stored in the file by the example) and the
ratio ours / OpenCV. Poses are T_wc (camera-to-world, mm); OpenCV returns T_cw.
"""
import json
import sys
import time

import cv2
import numpy as np


def quat_xyzw_to_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def rotation_angle_deg(r):
    # Geodesic angle via the quaternion-free robust formula atan2(|vee(R - R^T)|/2, (tr R - 1)/2).
    s = np.linalg.norm([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2
    c = (np.trace(r) - 1) / 2
    return np.degrees(np.arctan2(s, c))


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "scenes.json"
    threshold = float(sys.argv[2]) if len(sys.argv) > 2 else 4.0
    data = json.load(open(path))
    cv2.setRNGSeed(0)
    pos, rot, ours_pos, ours_rot, failures = [], [], [], [], 0
    seconds = 0.0
    for s in data["scenes"]:
        k = np.array([[s["fx"], 0, s["cx"]], [0, s["fy"], s["cy"]], [0, 0, 1]], dtype=np.float64)
        obj = np.array(s["points_world"], dtype=np.float64)
        img = np.array(s["pixels"], dtype=np.float64)
        t0 = time.perf_counter()
        ok, rvec, tvec, inliers = cv2.solvePnPRansac(
            obj, img, k, None, reprojectionError=threshold, confidence=0.999,
            iterationsCount=2000)
        if not ok or inliers is None or len(inliers) < 4:
            failures += 1
            pos.append(np.inf)
            rot.append(np.inf)
        else:
            idx = inliers.ravel()
            rvec, tvec = cv2.solvePnPRefineLM(obj[idx], img[idx], k, None, rvec, tvec)
            seconds += time.perf_counter() - t0
            r_cw, _ = cv2.Rodrigues(rvec)
            r_wc = r_cw.T
            t_wc = -r_wc @ tvec.ravel()
            r_true = quat_xyzw_to_matrix(s["q_wc_xyzw"])
            pos.append(float(np.linalg.norm(t_wc - np.array(s["t_wc"]))))
            rot.append(float(rotation_angle_deg(r_wc.T @ r_true)))
        ours_pos.append(s["ours"]["position_mm"])
        ours_rot.append(s["ours"]["orientation_deg"])
    pos, rot = np.array(pos), np.array(rot)
    ours_pos, ours_rot = np.array(ours_pos), np.array(ours_rot)
    n = len(pos)
    print(f"{n} scenes, {data['config']}, OpenCV {cv2.__version__}, threshold {threshold} px,"
          f" OpenCV failures {failures}, OpenCV time {1e3 * seconds / n:.3f} ms/scene")
    for name, p, r in [("opencv solvePnPRansac+RefineLM", pos, rot), ("ours RANSAC P3P+GN", ours_pos, ours_rot)]:
        print(f"{name:32s} position mean {np.mean(p):.4f} median {np.median(p):.4f} mm;"
              f" orientation mean {np.mean(r):.4f} median {np.median(r):.4f} deg")
    print(f"ratio ours/opencv: position mean {np.mean(ours_pos) / np.mean(pos):.3f}"
          f" median {np.median(ours_pos) / np.median(pos):.3f};"
          f" orientation mean {np.mean(ours_rot) / np.mean(rot):.3f}"
          f" median {np.median(ours_rot) / np.median(rot):.3f}")


if __name__ == "__main__":
    main()
