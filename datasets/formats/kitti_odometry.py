"""KITTI odometry sequences (Geiger, Lenz, Urtasun, CVPR 2012) in KITTI's own layout.

A sequence ``<root>/sequences/NN`` holds::

    image_0/000000.png …   left grey images (rectified), frame k ↔ file k (six digits)
    image_1/000000.png …   right grey images (rectified with image_0), optional per frame
    calib.txt              ``P0: p11 … p34`` and ``P1: …``: 3 × 4 projection matrices, row-major;
                           P0 = K [I | 0], P1 = K [I | (−b, 0, 0)ᵀ]·… with P1[0, 3] = −fx · b (b the baseline [m])
    times.txt              one time [s] per line, frame k ↔ line k + 1

and ``<root>/poses/NN.txt`` (optional, sequences 00–10): per line the 3 × 4 matrix [R | t] row-major, the pose
``T_0←k`` of frame k's left camera in frame 0's left camera (x right, y down, z forward).

The frames read are the left images present from ``000000`` on without a gap (a copy may hold fewer images than
``times.txt`` has lines: the reader stops at the last image; ``meta`` says how many lines it left), or ``frames`` of
them from ``first`` on (frame ``first`` then has index 0; its time and pose are line ``first + 1`` of ``times.txt``
and of the pose file, the poses still ``T_0←k`` of the sequence's frame 0). A time or pose
file shorter than the images, a malformed line, a missing ``P0``/``P1``, or P0/P1 that are not one rectified pair
raise :class:`DataFormatError` naming the file and line. Images are never read here: :class:`Camera` reads one
when asked.

Catalogued: ``kitti:00`` (the staged 200 frames of sequence 00); any sequence: ``kitti:<root>/sequences/NN``.
"""

from __future__ import annotations

from pathlib import Path, PurePosixPath
from typing import ClassVar

import numpy as np

from slamarena.params import Field, Params, with_params

from ..errors import DataFormatError
from ..sequence import Camera, Sequence
from ..source import Layout, SourceParams, joined
from ._text import check_monotonic, numeric_table, record_values, records

__all__ = ["KittiParams", "KittiSource", "read", "read_calib", "read_poses"]


def read_calib(path: str | Path) -> tuple[np.ndarray, float]:
    """K (3, 3) and the stereo baseline b [m] from ``calib.txt`` (its P0 and P1)."""
    lines, tag = records(path, "a calibration record (P0: …)")
    P = {}
    for name in ("P0", "P1"):
        rows = np.flatnonzero(tag == f"{name}:")
        if not rows.size:
            raise DataFormatError(path, None, f"a {name}: line (12 numbers)", "none")
        P[name] = record_values(lines, rows[:1], 12, f"{name} (a 3 x 4 matrix)").reshape(3, 4)
        line = int(rows[0]) + 1
    K = P["P0"][:, :3]
    if np.any(P["P0"][:, 3] != 0) or not np.allclose(P["P1"][:, :3], K) or np.any(P["P1"][1:, 3] != 0):
        raise DataFormatError(path, line, "P0 = K [I | 0] and P1 = K [I | (-fx b, 0, 0)] (a rectified pair)")
    baseline = -float(P["P1"][0, 3]) / float(K[0, 0])
    if not baseline > 0 or K[2, 2] != 1 or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise DataFormatError(path, line, "a positive baseline and focal lengths, K[2, 2] = 1", str(P["P1"].tolist()))
    return K, baseline


def read_poses(path: str | Path, count: int) -> np.ndarray:
    """The first ``count`` poses (count, 4, 4) ``T_0←k`` of a KITTI pose file (each line [R | t], 12 numbers)."""
    values, lines = numeric_table(path, 12, "a pose (12 numbers: [R | t] row-major)")
    if len(values) < count:
        raise DataFormatError(path, int(lines[-1]), f"{count} poses (one per frame)", f"{len(values)} lines")
    values, lines = values[:count], lines[:count]
    T = np.tile(np.eye(4), (count, 1, 1))
    T[:, :3, :] = values.reshape(-1, 3, 4)
    R = T[:, :3, :3]
    bad = np.flatnonzero(
        ~np.isfinite(values).all(axis=1) | (np.abs(R @ R.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2)) > 1e-4)
    )
    if bad.size:
        raise DataFormatError(path, int(lines[bad[0]]), "a finite pose with a rotation matrix", str(values[bad[0]]))
    return T


def _frames(directory: Path) -> list[Path]:
    """The images ``000000.png``, ``000001.png`` … of ``directory`` up to the first missing one."""
    names = {p.name for p in directory.glob("*.png")}
    out = []
    while f"{len(out):06d}.png" in names:
        out.append(directory / f"{len(out):06d}.png")
    return out


class KittiParams(Params):
    """Options of the KITTI odometry reader."""

    first: int = Field(0, ge=0, description="the first frame read (frames before it are left out)")
    frames: int | None = Field(None, ge=2, description="read only `frames` frames from `first` (None: every image)")


class KittiSource(KittiParams, SourceParams):
    """Where a KITTI odometry sequence is, and the reader's options."""

    location: ClassVar[tuple[str, ...]] = ("path",)
    path: str = Field(
        description="a sequence directory <root>/sequences/NN (with image_0/, calib.txt, times.txt; the ground truth, "
        "where there is one, at <root>/poses/NN.txt)"
    )

    def layout(self) -> Layout:
        sequence = PurePosixPath(self.path)
        return Layout(
            {
                "first_image": (joined(self.path, "image_0/000000.png"),),
                "calib": (joined(self.path, "calib.txt"),),
                "times": (joined(self.path, "times.txt"),),
                "poses": (str(sequence.parent.parent / "poses" / f"{sequence.name}.txt"),),
            },
            frozenset({"poses"}),
        )


@with_params(KittiSource)
def read(files: dict, name: str, /, *, params: KittiSource) -> Sequence:
    """The family reader: ``files`` has roles first_image, calib, times and (optional) poses."""
    sequence = Path(files["calib"]).parent
    left = _frames(Path(files["first_image"]).parent)
    end = len(left) if params.frames is None else min(len(left), params.first + params.frames)
    if end - params.first < 2:
        raise DataFormatError(left[0].parent, None, f"two or more images from image {params.first}", f"{len(left)}")
    first, left = params.first, left[params.first : end]
    n = len(left)
    right = [sequence / "image_1" / p.name for p in left]
    right_names = np.array([str(p) if p.is_file() else "" for p in right], dtype=str)
    K, baseline = read_calib(files["calib"])
    times, lines = numeric_table(files["times"], 1, "a time [s]")
    if len(times) < first + n:
        raise DataFormatError(
            files["times"], int(lines[-1]), f"{first + n} times (one per image)", f"{len(times)} lines"
        )
    unused = len(times) - n
    times, lines = times[first : first + n], lines[first : first + n]
    check_monotonic(str(files["times"]), times[:, 0], lines, "frame times")
    truth = read_poses(files["poses"], first + n)[first:] if "poses" in files else None
    width, height = _png_size(left[0])
    meta = {
        "dataset": "KITTI odometry",
        "files": [str(files[r]) for r in ("calib", "times", "poses") if r in files],
        "images": str(left[0].parent),
        "first_frame": first,
        "frames": n,
        "stereo_frames": int((right_names != "").sum()),
        "time_lines_unused": int(unused),
        "ground_truth_kind": "KITTI's poses (GPS/INS), T_0<-k of the left camera" if truth is not None else "none",
    }
    camera = Camera(
        t=times[:, 0],
        left=np.array([str(p) for p in left], dtype=str),
        K=K,
        width=width,
        height=height,
        right=right_names if meta["stereo_frames"] else None,
        baseline=baseline if meta["stereo_frames"] else None,
        ground_truth=truth,
    )
    return Sequence(name=name, camera=camera, meta=meta)


def _png_size(path: Path) -> tuple[int, int]:
    """(width, height) of a PNG from its IHDR chunk (the image itself is not decoded)."""
    with open(path, "rb") as f:
        head = f.read(24)
    if len(head) < 24 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise DataFormatError(path, None, "a PNG file", head[:8].hex())
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
