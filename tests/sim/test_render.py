"""Register rendering: grey scale, sizes, montage layout, atomic writes."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ppaloc.errors import SimulatorError
from ppaloc.sim import R5, A, Scamp5
from ppaloc.sim.render import plane_to_image, render_montage, render_register, save_png


def test_plane_to_image_fixed_scale():
    plane = np.array([[-200.0, -128.0, -0.5, 0.0, 0.49, 127.0, 300.0]])
    assert plane_to_image(plane).tolist() == [[0, 0, 128, 128, 128, 255, 255]]
    assert plane_to_image(np.array([[True, False]])).tolist() == [[255, 0]]
    with pytest.raises(SimulatorError, match="2-D"):
        plane_to_image(np.zeros(3))


def test_render_register_writes_png_of_the_right_size(tmp_path):
    sim = Scamp5(6, 10)
    sim.write(A, np.linspace(-128, 127, 60).reshape(6, 10))
    path = render_register(sim, A, tmp_path / "sub" / "a.png", scale=3)
    with Image.open(path) as img:
        assert img.size == (30, 18) and img.mode == "L"
        px = np.asarray(img)
    assert px[0, 0] == 0 and px[-1, -1] == 255
    assert (px[:3, :3] == px[0, 0]).all()  # nearest-neighbour enlargement
    assert list(tmp_path.joinpath("sub").iterdir()) == [path]  # no temporary left behind


def test_digital_register_is_black_and_white(tmp_path):
    sim = Scamp5(4, 4)
    sim.load_point(R5, 1, 2)
    with Image.open(render_register(sim, R5, tmp_path / "r5.png")) as img:
        px = np.asarray(img)
    assert set(np.unique(px)) == {0, 255} and px[1, 2] == 255 and px.sum() == 255


def test_montage_layout_and_labels(tmp_path):
    sim = Scamp5(8, 12)
    sim.write(A, np.full((8, 12), 127.0))
    path = render_montage(sim, tmp_path / "m.png", [A, R5], scale=2)
    with Image.open(path) as img:
        w, h = img.size
        px = np.asarray(img)
    assert (w, h) == (4 + 2 * (24 + 4), 4 + 16 + 14 + 4)
    assert (px[4 + 14 : 4 + 14 + 16, 4 : 4 + 24] == 255).all()  # tile A, white
    assert (px[4 + 14 : 4 + 14 + 16, 32 : 32 + 24] == 0).all()  # tile R5, black
    assert (px[4:14, 4:28] > 64).any()  # label text drawn above tile A
    path = render_montage(
        {"a": np.zeros((2, 2)), "b": np.ones((2, 2)), "c": np.zeros((2, 2))},
        tmp_path / "g.png",
        columns=2,
    )
    with Image.open(path) as img:
        assert img.size == (4 + 2 * 6, 4 + 2 * (2 + 14 + 4))


def test_montage_and_save_png_errors(tmp_path):
    with pytest.raises(SimulatorError, match="differ in shape"):
        render_montage({"a": np.zeros((2, 2)), "b": np.zeros((3, 2))}, tmp_path / "x.png")
    with pytest.raises(SimulatorError, match="name the registers"):
        render_montage(Scamp5(2, 2), tmp_path / "x.png")
    with pytest.raises(SimulatorError, match="scale=0 is invalid"):
        save_png(np.zeros((2, 2), np.uint8), tmp_path / "x.png", scale=0)
    with pytest.raises(SimulatorError, match="2-D uint8"):
        save_png(np.zeros((2, 2)), tmp_path / "x.png")
    assert not list(tmp_path.iterdir())
