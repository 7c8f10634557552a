#!/usr/bin/env python3
"""Cross-check `endoloc eval` against evo (https://github.com/MichaelGrupp/evo).

Subcommands:
  fixtures  DIR        write the seeded fixture pair DIR/gt.txt, DIR/est.txt (numpy only)
  evo-stats DIR        run evo_ape / evo_rpe on DIR/gt.txt, DIR/est.txt and write
                       DIR/evo_stats.json (statistics + error arrays, evo version noted);
                       the Rust test `tests/evo_fixtures.rs` compares against this file
  compare GT EST       run evo and `endoloc eval` on the same files and compare the
                       statistics; exits 1 if any differs by more than --tol (default 1e-6)

Needs `pip install evo` (1.38 was used) for evo-stats and compare, and the endoloc binary
for compare (--endoloc PATH, default: `cargo run -q --release -p endoloc --`).

Relations compared: APE trans_part (= our position_mm), angle_deg (= orientation_deg),
rot_part and full (library-only, in the Rust test), with and without SE(3)/Sim(3) Umeyama
alignment (evo -a, -as); RPE trans_part and angle_deg for delta 1 (and 3 in the fixtures).
"""

import argparse
import io
import json
import shlex
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

SEED = 20240611


def quat_from_rotvec(v):
    """Hamilton quaternion (x, y, z, w) of a rotation vector (rad)."""
    angle = np.linalg.norm(v)
    if angle < 1e-15:
        return np.array([0.0, 0.0, 0.0, 1.0])
    axis = v / angle
    return np.concatenate([axis * np.sin(angle / 2), [np.cos(angle / 2)]])


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ])


def quat_rotate(q, v):
    qv = np.concatenate([v, [0.0]])
    qc = np.array([-q[0], -q[1], -q[2], q[3]])
    return quat_mul(quat_mul(q, qv), qc)[:3]


def write_tum(path, rows):
    with open(path, "w") as f:
        f.write("# timestamp[s] tx ty tz[mm] qx qy qz qw; T_wc (seeded fixture, evo_crosscheck.py)\n")
        for t, p, q in rows:
            f.write(f"{t:.6f} {p[0]:.9f} {p[1]:.9f} {p[2]:.9f} "
                    f"{q[0]:.12f} {q[1]:.12f} {q[2]:.12f} {q[3]:.12f}\n")


def make_fixtures(out: Path):
    """48 ground-truth poses at 30 fps along a curved path (mm, coronal world: x left,
    y cranial); the estimate is noisy (σ 2 mm, 2°), placed in a slightly rotated and shifted
    world frame (so alignment matters), misses 6 frames, has ±3 ms time-stamp jitter, one
    pose outside the ground truth's time range, and some quaternions with qw < 0."""
    rng = np.random.default_rng(SEED)
    n = 48
    gt = []
    for k in range(n):
        s = k / (n - 1)
        p = np.array([60 * np.sin(2.2 * s), 150 * s, 20 * np.sin(5 * s)])
        q = quat_mul(quat_from_rotvec(np.array([0, 0, 1.8 * s])),
                     quat_from_rotvec(np.array([-np.pi / 2, 0, 0])))
        gt.append((k / 30.0, p, q))
    world_q = quat_from_rotvec(np.deg2rad(np.array([1.0, -2.0, 4.0])))
    world_t = np.array([6.0, -4.0, 2.5])
    missing = {0, 7, 8, 21, 33, 47}
    est = []
    for k, (t, p, q) in enumerate(gt):
        if k in missing:
            continue
        pn = p + rng.normal(0.0, 2.0, 3)
        qn = quat_mul(q, quat_from_rotvec(np.deg2rad(rng.normal(0.0, 2.0, 3))))
        pe = quat_rotate(world_q, pn) + world_t
        qe = quat_mul(world_q, qn)
        qe /= np.linalg.norm(qe)
        if k % 5 == 0:
            qe = -qe  # same rotation, other sign
        est.append((t + rng.uniform(-0.003, 0.003), pe, qe))
    est.append((gt[-1][0] + 1.0, gt[-1][1], gt[-1][2]))  # no ground truth near it
    out.mkdir(parents=True, exist_ok=True)
    write_tum(out / "gt.txt", gt)
    write_tum(out / "est.txt", est)
    print(f"wrote {out / 'gt.txt'} ({len(gt)} poses) and {out / 'est.txt'} ({len(est)} poses)")


def run_evo(tool, gt, est, args):
    with tempfile.TemporaryDirectory() as d:
        z = Path(d) / "r.zip"
        cmd = [tool, "tum", str(gt), str(est), *args, "--save_results", str(z), "--no_warnings", "--silent"]
        subprocess.run(cmd, check=True)
        with zipfile.ZipFile(z) as zf:
            stats = json.loads(zf.read("stats.json"))
            errors = np.load(io.BytesIO(zf.read("error_array.npy")))
            stamps = np.load(io.BytesIO(zf.read("timestamps.npy"))) if "timestamps.npy" in zf.namelist() else None
    return {
        "command": " ".join(shlex.quote(c) for c in [tool, "tum", Path(gt).name, Path(est).name, *args]),
        "stats": stats,
        "errors": errors.tolist(),
        "est_timestamps": None if stamps is None else stamps.tolist(),
    }


CASES = {
    # name: (tool, evo arguments)
    "ape_trans_part": ("evo_ape", ["-r", "trans_part"]),
    "ape_angle_deg": ("evo_ape", ["-r", "angle_deg"]),
    "ape_rot_part": ("evo_ape", ["-r", "rot_part"]),
    "ape_full": ("evo_ape", ["-r", "full"]),
    "ape_trans_part_se3": ("evo_ape", ["-r", "trans_part", "-a"]),
    "ape_angle_deg_se3": ("evo_ape", ["-r", "angle_deg", "-a"]),
    "ape_trans_part_sim3": ("evo_ape", ["-r", "trans_part", "-a", "-s"]),
    "rpe_trans_part": ("evo_rpe", ["-r", "trans_part", "--delta", "1", "--delta_unit", "f"]),
    "rpe_angle_deg": ("evo_rpe", ["-r", "angle_deg", "--delta", "1", "--delta_unit", "f"]),
    "rpe_rot_part": ("evo_rpe", ["-r", "rot_part", "--delta", "1", "--delta_unit", "f"]),
    "rpe_trans_part_d3": ("evo_rpe", ["-r", "trans_part", "--delta", "3", "--delta_unit", "f"]),
    "rpe_trans_part_d3_all": ("evo_rpe", ["-r", "trans_part", "--delta", "3", "--delta_unit", "f", "--all_pairs"]),
}


def evo_version():
    import evo
    return evo.__version__


def evo_stats(d: Path):
    out = {
        "evo_version": evo_version(),
        "numpy_version": np.__version__,
        "generated_by": "crates/eval/scripts/evo_crosscheck.py evo-stats",
        "gt": "gt.txt",
        "est": "est.txt",
        "cases": {},
    }
    for name, (tool, args) in CASES.items():
        out["cases"][name] = run_evo(tool, d / "gt.txt", d / "est.txt", args)
    path = d / "evo_stats.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path} (evo {out['evo_version']}, {len(CASES)} cases)")


def compare(gt, est, endoloc, tol):
    """Our metrics.json fields against evo's statistics for the same files."""
    ok = True
    for align, evo_flags in (("none", []), ("se3", ["-a"]), ("sim3", ["-a", "-s"])):
        with tempfile.TemporaryDirectory() as d:
            cmd = [*shlex.split(endoloc), "eval", "--gt", str(gt), "--est", str(est), "--out", d,
                   "--no-plots"]
            if align != "none":
                cmd += ["--align", align]
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            ours = json.loads((Path(d) / "metrics.json").read_text())
        pairs = [
            (ours["position_mm"], ("evo_ape", ["-r", "trans_part", *evo_flags])),
            (ours["orientation_deg"], ("evo_ape", ["-r", "angle_deg", *evo_flags])),
        ]
        if ours.get("rpe"):
            pairs += [
                (ours["rpe"]["translation_mm"], ("evo_rpe", ["-r", "trans_part", *evo_flags])),
                (ours["rpe"]["rotation_deg"], ("evo_rpe", ["-r", "angle_deg", *evo_flags])),
            ]
        for mine, (tool, args) in pairs:
            ref = run_evo(tool, gt, est, args)
            for key in ("rmse", "mean", "median", "std", "min", "max"):
                diff = abs(mine[key] - ref["stats"][key])
                status = "ok" if diff <= tol else "DIFFERS"
                ok &= diff <= tol
                print(f"{status:7} {ref['command']:60} {key:6} endoloc={mine[key]:.12g} evo={ref['stats'][key]:.12g} |diff|={diff:.2e}")
    print("all within tolerance" if ok else f"some statistics differ by more than {tol}")
    return 0 if ok else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fixtures")
    f.add_argument("dir", type=Path)
    e = sub.add_parser("evo-stats")
    e.add_argument("dir", type=Path)
    c = sub.add_parser("compare")
    c.add_argument("gt", type=Path)
    c.add_argument("est", type=Path)
    c.add_argument("--endoloc", default="cargo run -q --release -p endoloc --")
    c.add_argument("--tol", type=float, default=1e-6)
    a = ap.parse_args()
    if a.cmd == "fixtures":
        make_fixtures(a.dir)
    elif a.cmd == "evo-stats":
        evo_stats(a.dir)
    else:
        sys.exit(compare(a.gt, a.est, a.endoloc, a.tol))


if __name__ == "__main__":
    main()
