"""Rendering: rgb_array frames and the reusable drawing helpers."""

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from symrl.world import load_map
from symrl.world.env import Hailu2001Env
from symrl.world.render import draw_path, draw_robot, draw_world


def test_rgb_array_is_hwc_uint8_of_the_figure_size():
    env = Hailu2001Env(render_mode="rgb_array", noise=False)
    env.reset(seed=0)
    first = env.render()
    width, height = env._renderer.fig.canvas.get_width_height()
    # the figure's pixels, rounded up to even sizes (H.264 video needs them)
    assert first.shape == (height + height % 2, width + width % 2, 3) and first.dtype == np.uint8
    assert first.shape[0] % 2 == 0 and first.shape[1] % 2 == 0
    assert len(np.unique(first.reshape(-1, 3), axis=0)) > 5  # walls, goal, robot drawn
    for _ in range(3):
        env.step(np.array([0.0], np.float32))
    second = env.render()
    assert second.shape == first.shape
    assert np.any(second != first)  # the robot moved
    env.close()


def test_render_without_mode_returns_none():
    env = Hailu2001Env()
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.render() is None


def test_helpers_draw_on_any_axes():
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    world = load_map("hailu2001")
    draw_world(ax, world)
    draw_path(ax, [(0, 0), (1, 0), (2, -1)], label="path")
    draw_robot(ax, (0.0, 0.0, 0.0))
    assert len(ax.lines) >= 2 + len(world.regions.lines)
    assert ax.get_xlim() == (-1.8, 5.85)


def test_human_mode_draws_on_a_non_interactive_backend():
    import matplotlib

    matplotlib.use("Agg")  # no window in CI; the same code opens one on a desktop backend
    env = Hailu2001Env(render_mode="human", noise=False)
    env.reset(seed=0)
    assert env.step(np.array([0.0], np.float32))[0]["sonar"].shape == (24,)
    assert env.render() is None
    env.close()


@pytest.mark.parametrize("world", ["hailu2001", "maze", "l_corridor"])
def test_rgb_array_frames_have_even_width_and_height(world):
    env = Hailu2001Env(map=world, render_mode="rgb_array", noise=False)
    env.reset(seed=0)
    height, width, channels = env.render().shape
    assert height % 2 == 0 and width % 2 == 0 and channels == 3
    env.close()


@pytest.mark.parametrize("clockwise", [False, True])
def test_every_obstacle_is_filled_whatever_its_corners_and_winding(clockwise):
    """A triangle and a square, either winding: each drawn solid at its centroid."""
    triangle = [[1.0, 1.0], [3.0, 1.0], [1.0, 3.0]]
    square = [[5.0, 5.0], [7.0, 5.0], [7.0, 7.0], [5.0, 7.0]]
    if clockwise:
        triangle, square = triangle[::-1], square[::-1]
    world = load_map(
        {
            "name": "solids",
            "boundary": [[0, 0], [8, 0], [8, 8], [0, 8]],
            "obstacles": [triangle, square],
            "start": {"x": 0.5, "y": 7.0, "heading": 0.0},
            "goal": {"x": 7.0, "y": 1.0, "radius": 0.4},
        }
    )
    fig = Figure(figsize=(4, 4), dpi=50)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    draw_world(ax, world, regions=False, goal=False)
    canvas.draw()
    pixels = np.asarray(canvas.buffer_rgba())[..., :3]
    to_pixel = ax.transData.transform
    height = pixels.shape[0]
    for x, y in ((5 / 3, 5 / 3), (6.0, 6.0), (4.0, 2.0)):
        px, py = to_pixel((x, y))
        shade = pixels[int(height - py), int(px)]
        solid = (x, y) != (4.0, 2.0)
        assert (tuple(shade) == (204, 204, 204)) == solid, (x, y, shade)
