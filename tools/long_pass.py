#!/usr/bin/env python3
"""Writes a synthetic localization run of any length, to measure `endoloc eval` on passes
longer than any simulated one (memory, time).

    python3 tools/long_pass.py --frames 1000000 --out /tmp/pass1m
    /usr/bin/time -v endoloc eval --gt /tmp/pass1m/gt.txt --est /tmp/pass1m/trajectory.txt \
        --gt-zones /tmp/pass1m/zones.csv --out /tmp/pass1m/eval

Files (docs/CONVENTIONS.md): `gt.txt` and `trajectory.txt` (TUM, T_wc, mm, 30 frames per
second along a helix), `frames.csv` (endoloc's per-frame table: statuses, predicted zones,
5 % of frames rejected without a pose) and `zones.csv` (true zone: --zones equal runs of
frames, as a model's zone count does not grow with the pass).
Deterministic for a given --seed.
"""

import argparse
import math
import os
import random

HEADER = ("frame,zone,zone_score,status,reason,source,inliers,reprojection_rms_px,"
          "position_std_mm,orientation_std_deg,time_ms")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=100_000)
    ap.add_argument("--out", required=True)
    ap.add_argument("--zones", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rng = random.Random(a.seed)
    with open(os.path.join(a.out, "gt.txt"), "w") as gt, \
            open(os.path.join(a.out, "trajectory.txt"), "w") as est, \
            open(os.path.join(a.out, "frames.csv"), "w") as fr, \
            open(os.path.join(a.out, "zones.csv"), "w") as zs:
        fr.write(HEADER + "\n")
        zs.write("frame,zone\n")
        for i in range(a.frames):
            t = i / 30.0
            s = 0.02 * i
            x, y, z = 40 * math.cos(s / 40), 40 * math.sin(s / 40), 0.5 * s
            h = 0.5 * s / 40  # yaw about z, as a unit quaternion (0, 0, sin, cos)
            qz, qw = math.sin(h), math.cos(h)
            gt.write(f"{t:.6f} {x:.6f} {y:.6f} {z:.6f} 0 0 {qz:.9f} {qw:.9f}\n")
            zone = i * a.zones // a.frames
            zs.write(f"{i},{zone}\n")
            u = rng.random()
            if u < 0.05:
                fr.write(f"{i},-1,,rejected,unreadable_image,none,,,,,1.0\n")
                continue
            status = "refined" if u < 0.9 else "init_only"
            e = rng.gauss(0, 0.5 if status == "refined" else 3.0)
            d = rng.gauss(0, 0.01)
            n = math.hypot(qz, qw + d)
            est.write(f"{t:.6f} {x + e:.6f} {y - e:.6f} {z:.6f} 0 0 "
                      f"{qz / n:.9f} {(qw + d) / n:.9f}\n")
            pz = zone + (1 if rng.random() < 0.03 else 0)
            fr.write(f"{i},{pz},0.9,{status},,{'refined' if status == 'refined' else 'zone_median'},"
                     f"40,0.8,0.3,0.2,12.5\n")


if __name__ == "__main__":
    main()
