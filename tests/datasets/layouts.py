"""Small dataset folders in their published layouts, written by the tests themselves."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flylog.datasets.images import write_png
from flylog.datasets.pfm import write_pfm

# A synthetic Middlebury scene: a textured fronto-parallel plane at DISPARITY px.
WIDTH, HEIGHT = 96, 64
FOCAL, CX, CY, DOFFS, BASELINE_MM = 120.0, 47.25, 31.5, 4.5, 160.0
DISPARITY = 8


def calib_text(
    f: float,
    cx: float,
    cy: float,
    doffs: float,
    baseline_mm: float,
    width: int,
    height: int,
    ndisp: int = 32,
) -> str:
    return (
        f"cam0=[{f} 0 {cx}; 0 {f} {cy}; 0 0 1]\n"
        f"cam1=[{f} 0 {cx + doffs}; 0 {f} {cy}; 0 0 1]\n"
        f"doffs={doffs}\nbaseline={baseline_mm}\nwidth={width}\nheight={height}\n"
        f"ndisp={ndisp}\nisint=0\nvmin=1\nvmax={ndisp - 1}\n"
    )


def plane_pair(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, right, disparity): the right image is the left shifted by DISPARITY px, the
    disparity unknown (inf) in the columns the right camera does not see and in one block."""
    rng = np.random.default_rng(seed)
    wide = rng.integers(0, 256, size=(HEIGHT, WIDTH + DISPARITY, 3), dtype=np.uint8)
    left = np.ascontiguousarray(wide[:, :WIDTH])  # left pixel u sees wide[u] ...
    right = np.ascontiguousarray(wide[:, DISPARITY:])  # ... which the right sees at u − D
    disparity = np.full((HEIGHT, WIDTH), float(DISPARITY), dtype=np.float32)
    disparity[:, :DISPARITY] = np.inf
    disparity[10:20, 40:60] = np.inf
    return left, right, disparity


def write_middlebury_scene(folder: Path, seed: int = 0, *, truth: bool = True) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    left, right, disparity = plane_pair(seed)
    write_png(folder / "im0.png", left)
    write_png(folder / "im1.png", right)
    (folder / "calib.txt").write_text(calib_text(FOCAL, CX, CY, DOFFS, BASELINE_MM, WIDTH, HEIGHT))
    if truth:
        write_pfm(folder / "disp0.pfm", disparity)


# ---- KITTI, written from simulated frames --------------------------------------------------


def kitti_projections(rig) -> tuple[np.ndarray, np.ndarray]:
    """P2, P3 of a rig with camera 0 at the pair's midpoint (P = K [I | −C])."""
    half = rig.baseline / 2.0
    p2, p3 = np.zeros((3, 4)), np.zeros((3, 4))
    p2[:, :3], p3[:, :3] = rig.intrinsics("left"), rig.intrinsics("right")
    p2[0, 3], p3[0, 3] = rig.focal_px * half, -rig.focal_px * half
    return p2, p3


def _kitti_line(key: str, m: np.ndarray) -> str:
    return key + ": " + " ".join(f"{v:.6e}" for v in m.ravel()) + "\n"


def kitti_disparity_png(disparity: np.ndarray) -> np.ndarray:
    """KITTI's uint16 encoding: round(d · 256), 0 where unknown."""
    known = np.isfinite(disparity) & (disparity > 0)
    out = np.zeros(disparity.shape, dtype=np.uint16)
    out[known] = np.clip(np.rint(disparity[known] * 256.0), 1, 65535).astype(np.uint16)
    return out


def _grey(image: np.ndarray) -> np.ndarray:
    return image if image.ndim == 2 else np.rint(image.mean(axis=2)).astype(np.uint8)


def write_kitti_stereo(root: Path, rig, pairs, *, calib: str = "2015") -> None:
    """training/ in a stereo benchmark's layout, one scene NNNNNN per pair (its frame 10):
    "2015": image_2, image_3, calib_cam_to_cam (P_rect_02/03), disp_occ_0; "2015-calib":
    the same with calib (P2/P3); "2012": the grey image_0, image_1 and the colour
    colored_0, colored_1 (calib's P0/P1 and P2/P3: here the same cameras), disp_occ."""
    write_kitti_multiview(
        root,
        rig,
        [[(10, left, right)] for left, right, _ in pairs],
        [d for *_, d in pairs],
        calib=calib,
    )


def write_kitti_multiview(root: Path, rig, scenes, truths, *, calib: str = "2015") -> None:
    """``scenes``: per scene, its frames (k, left, right), written NNNNNN_kk.png; ``truths``:
    per scene, frame 10's disparity (NaN unknown) or None."""
    training = root / "training"
    grey = calib == "2012"
    sides = ("image_0", "image_1", "colored_0", "colored_1") if grey else ("image_2", "image_3")
    folder = "calib_cam_to_cam" if calib == "2015" else "calib"
    truth_dir = "disp_occ" if grey else "disp_occ_0"
    for sub in (*sides, folder, truth_dir):
        (training / sub).mkdir(parents=True, exist_ok=True)
    p2, p3 = kitti_projections(rig)
    keys = {"2015": ("P_rect_02", "P_rect_03"), "2015-calib": ("P2", "P3")}.get(calib)
    lines = [_kitti_line(k, p2 if k in ("P0", "P2") else p3) for k in ("P0", "P1", "P2", "P3")]
    if keys is not None:
        lines = [_kitti_line(keys[0], p2), _kitti_line(keys[1], p3)]
    for n, (frames, disparity) in enumerate(zip(scenes, truths, strict=True)):
        name = f"{n:06d}"
        for k, left, right in frames:
            file = f"{name}_{k:02d}.png"
            if grey:
                write_png(training / "image_0" / file, _grey(left))
                write_png(training / "image_1" / file, _grey(right))
            for side, image in zip(sides[-2:], (left, right), strict=True):
                write_png(training / side / file, image)
        text = "calib_time: 09-Jan-2012 13:57:47\n" + "".join(lines)
        (training / folder / f"{name}.txt").write_text(text)
        if disparity is not None:
            png = kitti_disparity_png(disparity)
            write_png(training / truth_dir / f"{name}_10.png", png)


def kitti_pose(pose) -> np.ndarray:
    """A planar pose (x forward, y left, θ) → camera 0's [R | t] (x right, y down, z forward)."""
    c, s = np.cos(pose.theta), np.sin(pose.theta)
    r = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    return np.column_stack([r, [-pose.y, 0.0, pose.x]])


def write_kitti_sequence(root: Path, rig, frames, poses, seq: str = "00") -> None:
    """sequences/NN/image_2, image_3, calib.txt, times.txt and poses/NN.txt."""
    folder = root / "sequences" / seq
    for sub in ("image_2", "image_3"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    (root / "poses").mkdir(exist_ok=True)
    p2, p3 = kitti_projections(rig)
    p0 = np.column_stack([rig.intrinsics("left"), np.zeros(3)])
    lines = [_kitti_line(k, m) for k, m in (("P0", p0), ("P1", p0), ("P2", p2), ("P3", p3))]
    (folder / "calib.txt").write_text("".join(lines))
    times = []
    for k, (stamp_ns, left, right) in enumerate(frames):
        write_png(folder / "image_2" / f"{k:06d}.png", left)
        write_png(folder / "image_3" / f"{k:06d}.png", right)
        times.append(f"{stamp_ns / 1e9:.6e}\n")
    (folder / "times.txt").write_text("".join(times))
    rows = [" ".join(f"{v:.6e}" for v in kitti_pose(p).ravel()) + "\n" for p in poses]
    (root / "poses" / f"{seq}.txt").write_text("".join(rows))


# ---- EuRoC, written from simulated frames --------------------------------------------------


def _yaml_list(values) -> str:
    return "[" + ", ".join(repr(float(v)) for v in np.ravel(values)) + "]"


def sensor_yaml(t_bs: np.ndarray, rig, distortion=(0.0, 0.0, 0.0, 0.0)) -> str:
    return (
        "# General sensor definitions.\nsensor_type: camera\ncomment: simulated\n\n"
        "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n  cols: 4\n  rows: 4\n"
        f"  data: {_yaml_list(t_bs)}\n\n"
        f"rate_hz: {rig.frame_rate}\nresolution: [{rig.width}, {rig.height}]\n"
        "camera_model: pinhole\n"
        f"intrinsics: {_yaml_list([rig.focal_px, rig.focal_px, rig.cx, rig.cy])} #fu, fv, cu, cv\n"
        "distortion_model: radial-tangential\n"
        f"distortion_coefficients: {_yaml_list(distortion)}\n"
    )


def camera_in_body(rig, side: str) -> np.ndarray:
    """T_BS of a simulated camera: base_link is the body."""
    t = np.eye(4)
    t[:3, :3] = rig.rotation()
    t[:3, 3] = rig.camera_position(side)
    return t


def write_euroc(root: Path, rig, frames, truth) -> None:
    """mav0/cam0, cam1 (data.csv, data/, sensor.yaml) and state_groundtruth_estimate0:
    ``frames`` (stamp ns, left, right) in grey, ``truth`` (stamp ns, Pose2D) of the body."""
    mav = root / "mav0"
    for k, side in enumerate(("left", "right")):
        cam = mav / f"cam{k}"
        (cam / "data").mkdir(parents=True)
        (cam / "sensor.yaml").write_text(sensor_yaml(camera_in_body(rig, side), rig))
        lines = ["#timestamp [ns],filename\n"]
        for stamp, *images in frames:
            image = images[k]
            grey = image if image.ndim == 2 else np.rint(image.mean(axis=2)).astype(np.uint8)
            write_png(cam / "data" / f"{stamp}.png", grey)
            lines.append(f"{stamp},{stamp}.png\n")
        (cam / "data.csv").write_text("".join(lines))
    gt = mav / "state_groundtruth_estimate0"
    gt.mkdir()
    rows = [
        "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
        "q_RS_y [], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], "
        "b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], "
        "b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n"
    ]
    for stamp, pose in truth:
        q = (np.cos(pose.theta / 2), 0.0, 0.0, np.sin(pose.theta / 2))
        values = [pose.x, pose.y, 0.0, *q] + [0.0] * 9
        rows.append(f"{stamp}," + ",".join(f"{v:.9f}" for v in values) + "\n")
    (gt / "data.csv").write_text("".join(rows))
