"""Hostile map files: every one is refused in one line naming the file and the field, with
sizes bounded before anything is allocated; the same map always gives the same bytes."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from ppaloc.errors import MapFormatError
from ppaloc.topomap import TopoMap, load_map, read_header
from ppaloc.topomap.io import _checksum


@pytest.fixture
def small() -> TopoMap:
    rng = np.random.default_rng(3)
    return TopoMap(
        "lbp",
        rng.integers(0, 2**32, 6, dtype=np.uint32),
        frame_index=np.arange(6),
        params={"n_frames": 6},
        provenance={"method_params": {"preset": "paper", "alpha": 2.0}},
    )


def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as z:
        return {i.filename: z.read(i) for i in z.infolist()}


def _write(path: Path, members: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    return path


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, a)
    return buf.getvalue()


def _resigned(path: Path, header: dict, arrays: dict[str, np.ndarray]) -> Path:
    """A map with this header and these arrays and a valid checksum: only the field checks
    can refuse it."""
    header = dict(header)
    header["sha256"] = _checksum(header, arrays)
    blob = np.frombuffer(json.dumps(header).encode(), np.uint8)
    return _write(
        path, {"header.npy": _npy(blob), **{f"{k}.npy": _npy(v) for k, v in arrays.items()}}
    )


def _parts(small: TopoMap, tmp_path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    saved = small.save(tmp_path / "ok.npz")
    with np.load(saved) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(arrays.pop("header").tobytes())
    return header, arrays


def test_a_header_nested_100000_deep(tmp_path):
    deep = b'{"format": "ppaloc.topomap", "params": ' + b"[" * 100_000 + b"]" * 100_000 + b"}"
    path = _write(tmp_path / "deep.npz", {"header.npy": _npy(np.frombuffer(deep, np.uint8))})
    with pytest.raises(MapFormatError, match=rf"^cannot load map {path}: header is nested deeper"):
        load_map(path)
    with pytest.raises(MapFormatError, match="nested deeper than 32 levels"):
        read_header(path)


def test_a_header_nested_40_deep_names_the_field(small, tmp_path):
    header, arrays = _parts(small, tmp_path)
    nested: list = []
    for _ in range(40):
        nested = [nested]
    header["params"]["extra"] = nested
    path = _resigned(tmp_path / "nested.npz", header, arrays)
    with pytest.raises(MapFormatError, match=r"header\.params\.extra(\[0\])* is nested deeper"):
        load_map(path)


def test_a_member_claiming_10_to_the_12_elements_is_refused_before_allocating(small, tmp_path):
    members = _members(small.save(tmp_path / "ok.npz"))
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": "<u4", "fortran_order": False, "shape": (10**12,)}
    )
    members["descriptors.npy"] = buf.getvalue() + b"\0" * 24
    path = _write(tmp_path / "huge.npz", members)
    with pytest.raises(
        MapFormatError,
        match=rf"^cannot load map {path}: member 'descriptors.npy' claims shape \(1000000000000,\)",
    ):
        load_map(path)


def test_a_member_claiming_more_than_the_archive_holds(small, tmp_path):
    path = small.save(tmp_path / "m.npz")
    data = bytearray(path.read_bytes())
    # the central directory entry of the member: its uncompressed size, 4 bytes at +24
    at = bytes(data).index(b"PK\x01\x02")
    while data[at + 46 : at + 46 + 15] != b"descriptors.npy":
        at = bytes(data).index(b"PK\x01\x02", at + 4)
    data[at + 24 : at + 28] = (0xFFFF0000).to_bytes(4, "little")
    path.write_bytes(bytes(data))
    with pytest.raises(
        MapFormatError,
        match=rf"^cannot load map {path}: member 'descriptors.npy' claims 4294901760",
    ):
        load_map(path)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            lambda h, a: a.__setitem__("frame_index", np.array([0, 1, -5, 3, 4, 5])),
            r"frame_index\[2\] is -5",
        ),
        (
            lambda h, a: a.__setitem__("frame_index", np.arange(6) + 10),
            r"frame_index\[5\] is 15, beyond params.n_frames = 6",
        ),
        (lambda h, a: a.__setitem__("frame_index", np.arange(6.0)), r"frame_index holds float64"),
        (
            lambda h, a: h.__setitem__("n_nodes", 7),
            r"descriptors has 6 entries, header.n_nodes is 7",
        ),
        (lambda h, a: h.__setitem__("n_nodes", "6"), r"header.n_nodes is '6', expected a int"),
        (  # an array the format does not have is named in one line
            lambda h, a: a.__setitem__("extra", np.zeros(6)),
            r"header.arrays names \['descriptors', 'extra', 'frame_index'\], expected",
        ),
        (lambda h, a: h.__setitem__("kind", ["lbp"]), r"header.kind is \['lbp'\], expected a str"),
        (
            lambda h, a: h["provenance"]["method_params"].__setitem__("alpha", float("nan")),
            r"header.provenance.method_params.alpha is nan, not a finite number",
        ),
        (
            lambda h, a: h["provenance"]["method_params"].__setitem__("alpha", -1e308),
            r"header.provenance.method_params.alpha is -1e\+308, outside \+-2\^53",
        ),
        (
            lambda h, a: h["params"].__setitem__("gain", float("-inf")),
            r"header.params.gain is -inf",
        ),
    ],
)
def test_fields_out_of_range_are_named(small, tmp_path, change, message):
    header, arrays = _parts(small, tmp_path)
    change(header, arrays)
    for name, a in arrays.items():
        header["arrays"][name] = {"dtype": a.dtype.str, "shape": list(a.shape)}
    path = _resigned(tmp_path / "bad.npz", header, arrays)
    with pytest.raises(MapFormatError, match=rf"^cannot load map {path}: {message}"):
        load_map(path)


def test_nan_positions_are_refused(small, tmp_path):
    header, arrays = _parts(small, tmp_path)
    arrays["positions"] = np.array([[0.0], [1.0], [np.nan], [3.0], [4.0], [5.0]])
    header["arrays"]["positions"] = {"dtype": "<f8", "shape": [6, 1]}
    path = _resigned(tmp_path / "nan.npz", header, arrays)
    with pytest.raises(MapFormatError, match=r"positions\[2\] holds a NaN or infinite value"):
        load_map(path)


def test_the_same_map_gives_the_same_bytes(small, tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    a = small.save(tmp_path / "a.npz").read_bytes()
    small.provenance["created"] = "2020-01-01T00:00:00+00:00"  # an old stamp is not kept
    b = small.save(tmp_path / "b.npz").read_bytes()
    assert a == b
    assert "created" not in read_header(tmp_path / "a.npz")["provenance"]


def test_source_date_epoch_is_recorded(small, tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    path = small.save(tmp_path / "a.npz")
    assert read_header(path)["provenance"]["created"] == "2023-11-14T22:13:20+00:00"
    with zipfile.ZipFile(path) as z:
        assert {i.date_time for i in z.infolist()} == {(2023, 11, 14, 22, 13, 20)}
    assert load_map(path).equals(small)


def test_two_map_runs_with_the_same_seed_give_the_same_bytes(tmp_path, monkeypatch):
    import time

    from ppaloc.cli import main

    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    spec = "synthetic:?places=12&size=32&sync=1&seed=2"
    for name in ("a", "b"):
        assert (
            main(["map", spec, "-m", "weighted-node-lbp", "--out", str(tmp_path / name), "-q"]) == 0
        )
        if name == "a":
            time.sleep(1.1)  # a clock time in the file (in seconds) would now differ
    assert (tmp_path / "a").read_bytes() == (tmp_path / "b").read_bytes()


def test_patch_values_no_tile_can_hold_are_refused(tmp_path):
    # finite but near float32's limit, they made the filter's distances infinite (an
    # internal IndexError of ppaloc localise); a real patch-normalised image loads
    from ppaloc.place import PATCH_SHAPE, patch_image
    from ppaloc.topomap import PATCH_LIMIT

    rng = np.random.default_rng(5)
    frames = [rng.integers(0, 256, (256, 256), dtype=np.uint8) for _ in range(3)]
    frames[1][:128] = 0  # a constant half: tiles of zeros beside the rest
    real = TopoMap("patch", np.stack([patch_image(f) for f in frames]))
    assert np.abs(real.descriptors).max() <= PATCH_LIMIT
    assert load_map(real.save(tmp_path / "real.npz")).equals(real)
    header, arrays = _parts(real, tmp_path)
    for value in (1e37, -47.0):
        desc = real.descriptors.copy()
        desc[2, 5, 7] = value
        with pytest.raises(ValueError, match=r"descriptors\[2\] holds .*, outside \+-46"):
            TopoMap("patch", desc)  # made in Python
        path = _resigned(tmp_path / "big.npz", header, {**arrays, "descriptors": desc})
        with pytest.raises(MapFormatError, match=r"descriptors\[2\] holds .*, outside \+-46"):
            load_map(path)  # altered on disk, checksum and all
    extreme = np.zeros((1, *PATCH_SHAPE), np.float32)  # one bright pixel in a dark image
    extreme[0, 0, 0] = np.sqrt(2048) - 1e-3
    assert len(load_map(TopoMap("patch", extreme).save(tmp_path / "edge.npz"))) == 1


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: TopoMap("patch", np.full((2, 32, 64), np.nan, np.float32)), r"descriptors\[0\]"),
        (lambda: TopoMap("other", np.array([[0.0], [np.inf]])), r"descriptors\[1\] holds a NaN"),
        (lambda: TopoMap("lbp", np.zeros(3, np.uint32), frame_index=[-5, -1, 7]), r"frame_index"),
        (
            lambda: TopoMap("lbp", np.zeros(3, np.uint32), positions=[0, np.nan, 2]),
            r"positions\[1\]",
        ),
        (lambda: TopoMap(None, np.zeros(3, np.uint32)), r"kind must name what a node holds"),
        (lambda: TopoMap("", np.zeros(3, np.uint32)), r"kind must name what a node holds"),
        (  # an OverflowError before
            lambda: TopoMap("lbp", np.zeros(3, np.uint32), frame_index=[0, 1, 2**70]),
            r"frame_index must hold one reference frame number per node \(integers\)",
        ),
    ],
)
def test_a_map_no_file_could_hold_is_refused_when_made(make, message):
    # each was made and saved, and the file then refused by load_map (a good file saved
    # over is lost); the filters read NaN descriptors as an internal IndexError, and the
    # baselines returned estimates from them without a word
    with pytest.raises(ValueError, match=message):
        make()
