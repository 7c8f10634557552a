"""endoloc from Python, in one script: simulate a colonoscopy, localize it frame by frame,
plot the trajectory and evaluate it with evo.

    pip install ./python matplotlib evo
    python docs/tutorial.py                  # writes tutorial/ in the current folder

Every step is the library the `endoloc` command runs; nothing here goes through files that
Python has to parse, except for handing the trajectory to evo as a TUM file (as any evo user
would). Poses are T_wc (camera-to-world) 4×4 matrices in millimetres.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import endoloc  # noqa: E402

root = Path("tutorial")
data_dir, model_dir = root / "data", root / "model"

# 1. A dataset: the simulator's small preset (300 training + 300 test frames at 320×240).
#    Any endoloc dataset works the same, e.g. one made by `endoloc import c3vd`.
if not (data_dir / "dataset.toml").is_file():
    endoloc.simulate(preset="small", out=data_dir, progress=True)
data = endoloc.Dataset(data_dir)
test = data["test"]
print(data, "—", len(test), "test frames")

# 2. A model: the training pass cut into 50 zones, indexed with the shipped classifier (no
#    training), then the per-zone SURF maps triangulated with the known training poses.
if not (model_dir / "map.toml").is_file():
    endoloc.train(data=data_dir, zones=50, out=model_dir, pretrained="builtin-joint", epochs=0, force=True)
    endoloc.map(model=model_dir, data=data_dir, force=True, progress=True)
model = endoloc.Model.load(model_dir)

# 3. Localize frame by frame, live: frames could come from any reader (a video, a PyTorch
#    data loader) as uint8 NumPy arrays of the model's image size.
loc = endoloc.Localizer(model, live=True)
results = []
for i in range(len(test)):
    frame = test[i]  # uint8, H×W (an RGB H×W×3 array works too)
    results.append(loc.localize(frame))
status = np.array([r.status for r in results])
print({s: int((status == s).sum()) for s in ("refined", "init_only", "rejected")})

# 4. Plot the estimated trajectory over the true one (top view, mm), frames by status.
truth = test.poses[:, :3, 3]
est = np.array([r.position if r.pose is not None else [np.nan] * 3 for r in results])
fig, ax = plt.subplots(figsize=(7, 6))
ax.plot(truth[:, 0], truth[:, 1], "k-", lw=1, label="true (test pass)")
for s, colour in (("refined", "tab:green"), ("init_only", "tab:orange"), ("rejected", "tab:red")):
    sel = status == s
    ax.scatter(est[sel, 0], est[sel, 1], s=6, c=colour, label=s)
ax.set_xlabel("x (mm)")
ax.set_ylabel("y (mm)")
ax.set_aspect("equal")
ax.legend()
fig.tight_layout()
fig.savefig(root / "trajectory.png", dpi=120)
print("wrote", root / "trajectory.png")

# 5. Hand the trajectory to evo: endoloc writes TUM files, which evo reads as they are.
has_pose = [i for i, r in enumerate(results) if r.pose is not None]
endoloc.write_tum(root / "estimate.txt", test.timestamps[has_pose], np.stack([results[i].pose for i in has_pose]))
try:
    from evo.core import metrics, sync
    from evo.tools import file_interface
except ImportError:
    print("evo is not installed; the same with its command line:")
    print(f"  evo_ape tum {test.path}/poses.txt {root / 'estimate.txt'} -r trans_part")
else:
    ref = file_interface.read_tum_trajectory_file(f"{test.path}/poses.txt")
    est_traj = file_interface.read_tum_trajectory_file(str(root / "estimate.txt"))
    ref, est_traj = sync.associate_trajectories(ref, est_traj)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est_traj))
    stats = ape.get_all_statistics()
    print(f"evo APE (mm): mean {stats['mean']:.2f}, median {stats['median']:.2f}, rmse {stats['rmse']:.2f}")

# endoloc's own evaluation gives the same numbers (and per-status tables, plots, a report).
report = endoloc.eval(gt=f"{test.path}/poses.txt", est=root / "estimate.txt", out=root / "eval", force=True)
pos = report.metrics["position_mm"]
print(f"endoloc eval (mm): mean {pos['mean']:.2f}, median {pos['median']:.2f}, rmse {pos['rmse']:.2f}")
