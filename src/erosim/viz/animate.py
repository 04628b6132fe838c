"""Animations of map frames: GIF via imageio's Pillow plugin (MP4 when imageio-ffmpeg exists)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from erosim.core.atomic import atomic_path
from erosim.core.errors import InputError


def _frame(f: np.ndarray) -> np.ndarray:
    a = np.asarray(f)
    if a.dtype != np.uint8:
        a = np.clip(np.rint(np.nan_to_num(a.astype(np.float64)) * 255.0), 0, 255).astype(np.uint8)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    return a[..., :3]


def save_animation(path: str | os.PathLike, frames, fps: float = 10.0) -> str:
    """Write ``frames`` (float [0, 1] or uint8; gray or RGB; one shape) as a looping GIF or MP4."""
    import imageio.v3 as iio

    p = Path(path)
    ext = p.suffix.lower()
    if ext not in (".gif", ".mp4"):
        raise InputError(f"Cannot write animation '{p}': use a .gif or .mp4 file name.")
    frames = [_frame(f) for f in frames]
    if not frames:
        raise InputError(f"Animation '{p}' has no frames; record at least one frame.")
    if any(f.shape != frames[0].shape for f in frames):
        raise InputError(f"Animation '{p}': frames differ in size; give frames of one shape.")
    if not fps > 0:
        raise InputError(f"Animation frame rate {fps!r} is not valid; give a positive number of frames per second.")
    stack = np.stack(frames)
    with atomic_path(p) as tmp:
        if ext == ".gif":
            iio.imwrite(tmp, stack, extension=".gif", plugin="pillow", duration=1000.0 / fps, loop=0)
        else:
            try:
                iio.imwrite(tmp, stack, extension=".mp4", plugin="FFMPEG", fps=fps)
            except Exception as exc:  # no ffmpeg backend installed
                raise InputError(
                    f"Cannot write MP4 '{p}' ({exc}); install imageio-ffmpeg or use a .gif file name."
                ) from None
    return str(p)
