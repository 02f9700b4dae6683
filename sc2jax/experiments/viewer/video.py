"""Writing frames as a video with imageio: MP4 (H.264, through imageio-ffmpeg's bundled
ffmpeg: `pip install 'sc2jax[video]'`) or GIF (through Pillow, always installed).

The file is written to a temporary name beside the target and renamed over it when
complete, so a video is whole or absent.
"""

from __future__ import annotations

import importlib.util
import os
import tempfile
from collections.abc import Sequence

import numpy as np

FORMATS = ("gif", "mp4")


def check_format(video_format: str) -> None:
    """Raises ValueError for an unknown format, or MP4 without imageio-ffmpeg."""
    if video_format not in FORMATS:
        raise ValueError(f"unknown video format {video_format!r}; allowed: {list(FORMATS)}")
    if video_format == "mp4" and importlib.util.find_spec("imageio_ffmpeg") is None:
        raise ValueError("MP4 videos need imageio-ffmpeg: pip install 'sc2jax[video]' "
                         "(or write GIFs: --video_format=gif)")


def write_video(path: str | os.PathLike, frames: Sequence[np.ndarray], fps: float = 8.0
                ) -> None:
    """Writes uint8[H, W, 3] frames (all of one shape) to `path`, whose extension (.gif
    or .mp4) picks the format, at `fps` frames per second.

    Raises:
      ValueError: for another extension, no frames, frames of different shapes, or MP4
        without imageio-ffmpeg.
    """
    import imageio.v3 as iio

    path = os.fspath(path)
    video_format = os.path.splitext(path)[1].lstrip(".").lower()
    check_format(video_format)
    if not len(frames):
        raise ValueError(f"no frames to write to {path!r}")
    shapes = {np.shape(f) for f in frames}
    if len(shapes) != 1:
        raise ValueError(f"frames of different shapes {sorted(shapes)} for {path!r}")
    stack = np.stack([np.asarray(f, np.uint8) for f in frames])
    if video_format == "mp4":  # H.264 in yuv420p needs even sides.
        h, w = stack.shape[1:3]
        stack = np.pad(stack, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)))
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".video.", suffix="." + video_format)
    os.close(fd)
    try:
        if video_format == "gif":
            iio.imwrite(tmp, stack, extension=".gif", duration=1000.0 / fps, loop=0)
        else:
            iio.imwrite(tmp, stack, extension=".mp4", plugin="FFMPEG", fps=fps,
                        codec="libx264", quality=7, macro_block_size=1)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
