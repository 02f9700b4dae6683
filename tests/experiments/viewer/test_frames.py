"""Frames and videos: the layout of a frame, layer names, and the video files."""

import importlib.util

import imageio.v3 as iio
import numpy as np
import pytest

from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES
from sc2jax.environment.interface.palettes import colorize, legend, palette
from sc2jax.experiments.viewer import frames, video


def test_layer_names_are_checked():
    assert frames.parse_layers(["screen/unit_type", "minimap/camera"]) == (
        SCREEN_FEATURES.unit_type, MINIMAP_FEATURES.camera)
    for bad in ("screen/nope", "unit_type", "world/unit_type"):
        with pytest.raises(ValueError, match="unknown layer"):
            frames.parse_layers([bad])
    fmt = frames.layer_format((32, 32), (16, 16), frames.parse_layers(["minimap/camera"]))
    assert [f.name for f in fmt.screen_layers] == ["player_relative"]
    assert [f.name for f in fmt.minimap_layers] == ["camera"]


def test_palettes_follow_the_layer_table():
    pr = SCREEN_FEATURES.player_relative
    assert palette(pr).shape == (5, 3)
    assert tuple(palette(pr)[1]) == (0, 142, 0) and tuple(palette(pr)[4]) == (200, 30, 30)
    assert [label for _, _, label in legend(pr, [1, 3, 4])] == ["self", "neutral", "enemy"]
    unit_type = palette(SCREEN_FEATURES.unit_type)
    assert unit_type.shape == (SCREEN_FEATURES.unit_type.scale, 3) and not unit_type[0].any()
    assert len({tuple(c) for c in unit_type[1:200]}) > 150  # Distinct colours.
    hot = palette(SCREEN_FEATURES.unit_hit_points_ratio)
    assert not hot[0].any() and (hot[-1] == 255).all()
    assert np.all(np.diff(hot.astype(int).sum(axis=1)) >= 0)  # Brighter with the value.
    np.testing.assert_array_equal(colorize(np.array([[0, 9999]]), SCREEN_FEATURES.unit_density),
                                  palette(SCREEN_FEATURES.unit_density)[[[0, -1]]])
    with pytest.raises(ValueError, match="scalar"):
        legend(SCREEN_FEATURES.unit_density, [1])


def test_a_frame_holds_the_view_the_panels_and_the_text():
    view = np.full((100, 120, 3), 77, np.uint8)
    layers = frames.parse_layers(["screen/player_relative", "screen/unit_density"])
    values = [np.array([[0, 1], [4, 4]]), np.array([[0, 3], [15, 1]])]
    panels = [np.asarray(colorize(v, f)) for v, f in zip(values, layers)]
    frame = frames.compose(view, panels, layers, "line one\nline two", values, panel_size=64)
    np.testing.assert_array_equal(frame[:100, :120], view)
    # The first panel, scaled 32 times, right of the view under its caption.
    x, y = 124, 16
    assert tuple(frame[y + 5, x + 5]) == (0, 0, 0)  # Value 0.
    assert tuple(frame[y + 5, x + 40]) == tuple(palette(layers[0])[1])
    assert tuple(frame[y + 40, x + 5]) == tuple(palette(layers[0])[4])
    # Two panels in one column, the text below them: 2 x (64 + 32) + 2 lines.
    assert frame.shape == (2 * (64 + 32) + 2 * 14 + 6, 124 + 72, 3)


def test_videos_are_written_whole(tmp_path):
    clip = [np.full((30, 41, 3), i * 20, np.uint8) for i in range(5)]
    video.write_video(tmp_path / "a.gif", clip, fps=10)
    back = iio.imread(tmp_path / "a.gif")
    assert back.shape[:3] == (5, 30, 41)
    assert [p.name for p in tmp_path.iterdir()] == ["a.gif"]  # No temporary file left.
    with pytest.raises(ValueError, match="unknown video format 'avi'"):
        video.write_video(tmp_path / "a.avi", clip)
    with pytest.raises(ValueError, match="different shapes"):
        video.write_video(tmp_path / "b.gif", clip + [np.zeros((2, 2, 3), np.uint8)])
    with pytest.raises(ValueError, match="no frames"):
        video.write_video(tmp_path / "b.gif", [])
    if importlib.util.find_spec("imageio_ffmpeg") is None:
        pytest.skip("MP4 needs imageio-ffmpeg (pip install 'sc2jax[video]')")
    video.write_video(tmp_path / "a.mp4", clip, fps=10)  # Odd width: padded to even.
    assert iio.imread(tmp_path / "a.mp4", plugin="FFMPEG").shape[:3] == (5, 30, 42)
