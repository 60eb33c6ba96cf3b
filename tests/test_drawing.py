"""The drawing process: figures sent to it are written; its errors come back; without it the
same figures are drawn here."""

import sys

import pytest

from symrl import drawing
from symrl.world import load_map

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forked on Linux")


def _figures(folder):
    world = load_map("hailu2001")
    path = [[0.0, 0.0], [1.0, -0.5], [2.0, -0.8]]
    return [
        ("plot_paths", (world, [("a path", [path], [path])], folder / "paths.png"), {}),
        ("plot_curves", ({"steps": [[30.0, 28.0, 27.0]]}, folder / "curves.png"), {}),
    ]


@pytest.fixture
def drawing_process():
    drawing.start()
    yield drawing._process
    drawing.stop()


@linux
def test_the_drawing_process_writes_the_figures_it_is_sent(tmp_path, drawing_process):
    assert drawing_process.is_alive()
    drawing.draw(_figures(tmp_path))
    assert (tmp_path / "paths.png").stat().st_size > 10_000
    assert (tmp_path / "curves.png").stat().st_size > 10_000
    assert drawing_process.is_alive()  # and waits for more


@linux
def test_an_error_in_the_drawing_process_is_raised_here_with_its_traceback(
    tmp_path, drawing_process
):
    with pytest.raises(RuntimeError, match="(?s)drawing the figures failed.*Traceback"):
        drawing.draw(
            [("plot_paths", (None, [("x", [[[0, 0], [1, 1]]], [])], tmp_path / "x.png"), {})]
        )
    drawing.draw(_figures(tmp_path))  # still serving
    assert (tmp_path / "paths.png").is_file()


@linux
def test_a_drawing_process_that_died_is_replaced_by_drawing_here(tmp_path, drawing_process):
    drawing_process.kill()
    drawing_process.join()
    drawing.draw(_figures(tmp_path))
    assert (tmp_path / "paths.png").is_file() and drawing._process is None


def test_without_a_drawing_process_the_figures_are_drawn_here(tmp_path):
    assert drawing._process is None
    drawing.draw(_figures(tmp_path))
    assert (tmp_path / "paths.png").is_file() and (tmp_path / "curves.png").is_file()


@linux
def test_closing_the_pipe_ends_the_drawing_process_by_itself():
    drawing.start()
    process = drawing._process
    drawing.stop()  # closes the pipe, waits up to 5 s, then terminates
    assert process.exitcode == 0  # it ended on its own: not terminated (-15)
