#!/usr/bin/env bash
# Writes the seed corpora of the fuzz targets into fuzz/seeds/<target>/: small valid files of
# every format, from the repository's committed fixtures and written here. Needs python3
# (standard library only). Run from anywhere; rewrites fuzz/seeds/.
set -euo pipefail
fuzz="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$fuzz/.." && pwd)"
rm -rf "$fuzz/seeds"
mkdir -p "$fuzz/seeds"
FUZZ="$fuzz" ROOT="$root" python3 - <<'PY'
import json, os, struct, zlib

fuzz, root = os.environ["FUZZ"], os.environ["ROOT"]


def put(target, name, data):
    d = os.path.join(fuzz, "seeds", target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def fixture(rel, max_lines=None):
    with open(os.path.join(root, rel), "rb") as f:
        data = f.read()
    if max_lines is not None:
        data = b"".join(data.splitlines(keepends=True)[:max_lines])
    return data


# --- text formats -------------------------------------------------------------------------
put("tum", "poses.txt", "# timestamp tx ty tz qx qy qz qw\n0.0 1 2 3 0 0 0 1\n0.033 1.5 2 3 0 0 0.7071068 0.7071068\n")
put("tum", "evo_gt.txt", fixture("crates/eval/tests/fixtures/evo/gt.txt", 8))
put("tracker_log", "em.csv", "time_ms,x [mm],y,z,qx,qy,qz,qw,missing\n0,1,2,3,0,0,0,1,0\n10,,,,,,,,1\n20,1.5,2,3,0,0,0.7071068,0.7071068,0\n")
put("tracker_log", "matrix.csv", "t;px;py;pz;r11;r12;r13;r21;r22;r23;r31;r32;r33;valid\n0.5;1;2;3;1;0;0;0;1;0;0;0;1;true\n")
put("tracker_log", "tum.txt", "# t x y z qx qy qz qw\n0.0 1 2 3 0 0 0 1\n0.01 1.5 2 3 0 0 0.7071068 0.7071068\n")

put("dataset_toml", "dataset.toml", """# endoloc dataset, format version 1: lengths in mm, poses T_wc (camera-to-world)
name = "fuzz"
format_version = 1
units = "mm"

[source]
generator = "endoloc simulate"

[camera]
model = "pinhole"
width = 64
height = 48
fx = 30.5
fy = 30.5
cx = 31.5
cy = 23.5
mask = "mask.png"

[camera.distortion]
model = "fisheye"
k1 = -0.03
k2 = 0.004
k3 = 0.0
k4 = 0.0

[simulation]
depth = false
seed = 0
""")
put("dataset_toml", "plain.toml", 'name = "d"\nformat_version = 1\nunits = "mm"\n\n[camera]\nwidth = 8\nheight = 8\nfx = 4.0\nfy = 4.0\ncx = 3.5\ncy = 3.5\n')

put("sections_csv", "sections.csv", "frame,section\n0,rectum\n1,sigmoid\n2,descending\n3,transverse\n4,ascending\n5,caecum\n")

put("mesh_vtk", "colon.vtk", """# vtk DataFile Version 3.0
colon
ASCII
DATASET POLYDATA
POINTS 4 float
0 0 0 1 0 0 0 1 0
0 0 1
POLYGONS 2 9
3 0 1 2
4 0 1 2 3
""")
put("mesh_obj", "colon.obj", "# colon\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nf 1 2 3\nf 1/1/1 2//2 3 4\nf -1 -2 -3\n")
put("mesh_ply", "ascii.ply", "ply\nformat ascii 1.0\ncomment colon\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
hdr = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
body = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<B3i", 3, 0, 1, 2)
put("mesh_ply", "binary_le.ply", hdr + body)
hdr_be = hdr.replace(b"binary_little_endian", b"binary_big_endian").replace(b"float", b"double")
put("mesh_ply", "binary_be.ply", hdr_be + struct.pack(">9d", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack(">B3i", 3, 0, 1, 2))
put("mesh_stl", "ascii.stl", "solid colon\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid colon\n")
tri = struct.pack("<12f", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0) + b"\0\0"
put("mesh_stl", "binary.stl", b"binary colon".ljust(80, b" ") + struct.pack("<I", 2) + tri + tri)

put("mid_line", "path.jsn", json.dumps({"n": 3, "points": [[0, 0, 0], [1, 0, 0], [2, 0.5, 0]], "tangents": [], "normals": []}))
put("mid_line", "path_nan.jsn", '{"n": 2, "points": [[0, 0, 0], [NaN, Infinity, -Infinity]]}')
put("mid_line", "path.csv", "# mid-line\nx,y,z\n0,0,0\n1;0;0\n2 0.5 0\n")

landmarks = {"landmarks": [
    {"anatomy": [{"abbreviated_name": "anus", "text": "Anus"}], "paths": ["P1"], "position": [0]},
    {"anatomy": [{"abbreviated_name": "rsj", "text": "Rectosigmoid junction"}], "paths": ["P1"], "position": [150]},
    {"anatomy": [{"abbreviated_name": "sdj"}], "paths": ["P1"], "position": [400]},
    {"anatomy": [{"abbreviated_name": "lcf"}], "paths": ["P1"], "position": [600]},
    {"anatomy": [{"abbreviated_name": "rcf"}], "paths": ["P1"], "position": [900]},
    {"anatomy": [{"abbreviated_name": "icv"}], "paths": ["P1", "P2"], "position": [1100]},
    {"anatomy": [{"abbreviated_name": "caecum"}], "paths": ["P1"], "position": [1200]},
]}
put("gca_landmarks", "model.json", json.dumps(landmarks, indent=1))

put("c3vd_pose", "pose.txt", "1,0,0,0,0,1,0,0,0,0,1,0,10.5,-3,2,1\n0,1,0,0,-1,0,0,0,0,0,1,0,11,-3,2.5,1\n\n")

put("simcol3d", "cam.txt", "227.60416 0 227.60416 0 237.5 237.5 0 0 1\n")
put("simcol3d", "poses.txt", "1.0 2.0 3.0\n1.1,2.0,3.0\n\0" "0 0 0 1\n0 0.7071068 0 0.7071068\n")

put("endoslam_table", "exvivo.xlsx", fixture("crates/data/tests/fixtures/endoslam_exvivo_openpyxl.xlsx"))
put("endoslam_table", "unity.csv", "tX,tY,tZ,rX,rY,rZ,rW,time(s)\n0.1,0.2,0.3,0,0,0,1,0.0\n0.2,0.2,0.3,0,0,0,1,0.033\n")
put("endoslam_table", "exvivo.csv", "\ufeffImageFrame;Pose_Index;trans_x;trans_y;trans_z;quot_x;quot_y;quot_z;quot_w\n1;0;1;2;3;0;0;0;1\n\"2.0\";1;1;2;3;0;0;0;1\n")

put("model_toml", "model.toml", """# endoloc zone-classifier model (format 1)
format_version = 1
dataset = "fuzz"
sequence = "train"
frames = 30
whitening = 0.25

[score]
rule = "nearest"

[camera]
width = 64
height = 48
fx = 32.0
fy = 32.0
cx = 31.5
cy = 23.5

[backbone]
kind = "compact"
channels = [2]
descriptor_dim = 4
stem_stride = 2
pooling = "average"

[backbone.input]
width = 16
height = 16

[zones]
kind = "uniform"
count = 3
by = "arc_length"
min_frames = 3

[temporal]
stay = 0.95
step1 = 0.02
step2 = 0.003
temperature = 0.25

[track]
max_speed = 3
speed_change = 0.02
max_step = 3
step_scale = 1.0
jump = 0.001
temperature = 0.3

[train]
margin = 1.0
seed = 0
device = "cpu"

[train.backbone]
kind = "compact"
channels = [2]
descriptor_dim = 4

[train.backbone.input]
width = 16
height = 16
""")

put("zones_csv", "eval_zones.csv", "frame,zone\n0,0\n1,0\n2,1\n3,\n")

put("frames_csv", "frames.csv", "frame,zone,zone_score,status,reason,source,inliers,reprojection_rms_px,position_std_mm,orientation_std_deg,time_ms\n"
    "0,0,0.41,refined,,model,11,1.36,0.5,1.2,17.9\n1,,,lost,no zone,,0,,,,3.0\n")
put("frames_csv", "frames_v1.csv", "frame,zone,zone_score,status,reason,inliers,reprojection_rms_px,time_ms\n0,0,0.408,refined,,11,1.36,17.95\n1,0,0.40,refined,,9,1.48,17.7\n")

put("inliers_csv", "inliers.csv", b"\x04" + b"frame,x_px,y_px\n0,10.5,20.25\n0,11,21\n3,1,2\n")

put("run_config", "experiment.toml", """out = "experiments/paper50"
data = "data/paper"
[train]
zones = "50"
schedule = "fast"
pretrained = "builtin-joint"
pairs = "zone"
[map]
images_per_zone = 8
threshold = 25.0
[localize]
live = false
candidate_zones = 3
neighbours = 1
""")
put("run_config", "simulate.toml", 'out = "o"\n[simulate]\npreset = "small"\nseed = 0\n[train]\npairs = "track"\n')

# --- binary formats -----------------------------------------------------------------------
def png(width, height, color_type, bit_depth, rows):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    raw = b"".join(b"\0" + r for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))

grey8 = png(8, 8, 0, 8, [bytes((x * 30 + y) % 256 for x in range(8)) for y in range(8)])
rgb8 = png(4, 4, 2, 8, [bytes(range(y * 12, y * 12 + 12)) for y in range(4)])
depth16 = png(4, 4, 0, 16, [b"".join(struct.pack(">H", 1000 * (x + 1) + y) for x in range(4)) for y in range(4)])
put("dataset_png", "mask.png", grey8)
put("dataset_png", "rgb.png", rgb8)
put("dataset_png", "depth.png", depth16)
put("source_image", "color.png", rgb8)
put("source_image", "depth16.png", depth16)


def tiff16(width, height, values):
    data = b"".join(struct.pack("<H", v) for v in values)
    entries = [(256, 3, 1, width), (257, 3, 1, height), (258, 3, 1, 16), (259, 3, 1, 1),
               (262, 3, 1, 1), (273, 4, 1, 0), (277, 3, 1, 1), (278, 3, 1, height),
               (279, 4, 1, len(data))]
    ifd_off = 8
    data_off = ifd_off + 2 + 12 * len(entries) + 4
    out = b"II*\0" + struct.pack("<I", ifd_off) + struct.pack("<H", len(entries))
    for tag, typ, count, val in entries:
        if tag == 273:
            val = data_off
        if typ == 3:
            out += struct.pack("<HHIHH", tag, typ, count, val, 0)
        else:
            out += struct.pack("<HHII", tag, typ, count, val)
    return out + struct.pack("<I", 0) + data

put("source_image", "0000_depth.tiff", tiff16(4, 3, [0, 100, 65535, 2000, 3, 4, 5, 6, 7, 8, 9, 10]))

# database.bin: 1 byte of zone count for the target, then the file.
n, dim = 3, 2
db = b"EDLCDB01" + struct.pack("<II", n, dim) + struct.pack("<3I", 0, 1, 1) + struct.pack("<6f", 1, 0, 0.6, 0.8, 0, 1)
put("database_bin", "database.bin", b"\x02" + db)
# The same frames with a zoom-blurred view each: rows carry their training frame.
n = 6
db2 = (b"EDLCDB02" + struct.pack("<II", n, dim) + struct.pack("<6I", 0, 1, 1, 0, 1, 1)
       + struct.pack("<6I", 0, 1, 2, 0, 1, 2) + struct.pack("<12f", 1, 0, 0.6, 0.8, 0, 1, 0.9, 0.1, 0.5, 0.8, 0.1, 1))
put("database_bin", "database_views.bin", b"\x02" + db2)

dim = 2
wh = b"ELWHITE1" + struct.pack("<If", dim, 0.25) + struct.pack("<6f", 0.1, -0.2, 1, 0, 0, 1)
put("whitening_bin", "whitening.bin", wh)

# map.bin for the target's built-in map.toml: 2 zones, one with a point.
m = b"ENDOLOCMAP" + struct.pack("<II", 1, 2)
m += struct.pack("<II", 0, 2) + struct.pack("<2I", 0, 1) + struct.pack("<II", 1, 2)
m += struct.pack("<4d", 1, 2, 30, 0.5) + struct.pack("<b", 1) + struct.pack("<2f", 0.6, 0.8)
m += struct.pack("<I", 2) + struct.pack("<Idd", 0, 10.5, 20.5) + struct.pack("<Idd", 1, 11, 21)
m += struct.pack("<II", 1, 1) + struct.pack("<I", 2) + struct.pack("<II", 0, 4)
put("map_bin", "map.bin", m)
with open(os.path.join(fuzz, "fuzz_targets", "map.toml"), "rb") as f:
    put("map_bin", "map_toml_and_bin", f.read() + b"\0" + m)

# weights.safetensors of the targets' tiny compact backbone (one 2-channel block, 4-d head).
tensors = {
    "blocks.0.bn.beta": [2], "blocks.0.bn.gamma": [2], "blocks.0.bn.running_mean": [2],
    "blocks.0.bn.running_var": [2], "blocks.0.conv.weight": [2, 1, 5, 5],
    "head.bias": [4], "head.weight": [2, 4],
}
header, blob = {"__metadata__": {"format": "safetensors", "producer": "burn"}}, b""
for name, shape in sorted(tensors.items()):
    count = 1
    for s in shape:
        count *= s
    data = struct.pack(f"<{count}f", *[0.01 * (i % 7) + 0.5 for i in range(count)])
    header[name] = {"dtype": "F32", "shape": shape, "data_offsets": [len(blob), len(blob) + len(data)]}
    blob += data
h = json.dumps(header, separators=(",", ":")).encode()
h += b" " * (-len(h) % 8)
put("weights_safetensors", "weights.safetensors", struct.pack("<Q", len(h)) + h + blob)
PY
# The net zone table: the first zones of a model folder's table (ZoneTable::save's format).
cat > "$fuzz/seeds/zones_csv/model_zones.csv" <<'CSV'
# endoloc zone table; median poses T_wc in mm
# config: {"kind":"uniform","count":2,"by":"arc_length","min_frames":1}
zone,first_frame,last_frame,frame_count,path_length_mm,section,tx,ty,tz,qx,qy,qz,qw
0,0,9,10,66.0200,rectum,267.126719,353.579203,99.698969,-0.174294073,0.047055780,-0.749004208,0.637495118
1,10,18,9,56.4845,sigmoid,261.280944,336.770618,142.177118,0.779330647,0.088026341,-0.458641423,0.417783617
CSV
du -sh "$fuzz/seeds"
