"""Saving and loading maps: round trip, and every kind of bad file gives MapFormatError."""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ppaloc.errors import DataError, MapFormatError
from ppaloc.topomap import FORMAT_NAME, TopoMap, load_map, read_header, save_map


@pytest.fixture
def lowres_map() -> TopoMap:
    rng = np.random.default_rng(21)
    return TopoMap(
        "lowres",
        rng.integers(0, 256, (30, 8, 8), dtype=np.uint8),
        frame_index=np.arange(0, 60, 2),
        positions=rng.normal(size=(30, 2)),
        params={"keyframe_threshold": None, "shape": (8, 8)},
        provenance={"note": "test"},
    )


@pytest.fixture
def saved(tmp_path: Path, lowres_map: TopoMap) -> Path:
    return lowres_map.save(tmp_path / "map.npz", dataset="nordland")


def test_round_trip(saved: Path, lowres_map: TopoMap) -> None:
    loaded = TopoMap.load(saved)
    assert loaded.equals(lowres_map)
    assert loaded.descriptors.dtype == np.uint8
    assert loaded.params["shape"] == [8, 8]
    assert loaded.provenance["dataset"] == "nordland"
    assert loaded.provenance["note"] == "test"
    assert loaded.provenance["ppaloc_version"]
    header = read_header(saved)
    assert header["format"] == FORMAT_NAME and header["format_version"] == 1
    assert header["layout"]["capacity"] == 1024 and header["layout"]["n_tiles"] == 1
    assert len(header["sha256"]) == 64
    assert [p.name for p in saved.parent.iterdir()] == ["map.npz"]  # no temporary left


def test_round_trip_lbp_without_positions_and_an_empty_map(tmp_path: Path) -> None:
    m = TopoMap("lbp", np.array([0, 1, 0xFFFFFFFF], np.uint32))
    loaded = load_map(save_map(m, tmp_path / "lbp.npz"))
    assert loaded.equals(m) and loaded.positions is None
    empty = TopoMap("lowres", np.empty((0, 8, 8), np.uint8))
    assert load_map(empty.save(tmp_path / "empty.npz")).equals(empty)


def test_save_replaces_an_existing_file_atomically(saved: Path) -> None:
    m = TopoMap("lbp", np.array([7], np.uint32))
    m.save(saved)
    assert load_map(saved).equals(m)
    assert sorted(p.name for p in saved.parent.iterdir()) == ["map.npz"]


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nope.npz"
    with pytest.raises(MapFormatError, match=f"cannot load map {path}: no such file"):
        load_map(path)


def test_truncated_file(saved: Path) -> None:
    data = saved.read_bytes()
    for keep in (len(data) // 2, len(data) - 30, 10):
        saved.write_bytes(data[:keep])
        with pytest.raises(
            MapFormatError, match=f"cannot load map {saved}: corrupt or truncated .npz archive"
        ):
            load_map(saved)
    saved.write_bytes(b"")
    with pytest.raises(MapFormatError, match="not a ppaloc map"):
        load_map(saved)


def test_flipped_byte_in_the_descriptors(saved: Path) -> None:
    # Rewrite the archive with one descriptor byte flipped and valid zip CRCs, so only the
    # checksum can notice.
    with np.load(saved, allow_pickle=False) as npz:
        arrays = {name: npz[name] for name in npz.files}
    arrays["descriptors"][3, 4, 5] ^= 0x10
    np.savez(saved, **arrays)
    with pytest.raises(MapFormatError, match="checksum mismatch: the file was altered or damaged"):
        load_map(saved)


def test_flipped_byte_on_disk(saved: Path) -> None:
    data = bytearray(saved.read_bytes())
    with zipfile.ZipFile(saved) as z:
        info = z.getinfo("descriptors.npy")
    data[info.header_offset + 400] ^= 0xFF  # inside the stored descriptors' data
    saved.write_bytes(bytes(data))
    with pytest.raises(MapFormatError, match=r"corrupt or truncated archive .*Bad CRC-32"):
        load_map(saved)
    data[info.header_offset + 400] ^= 0xFF
    data[info.header_offset + 120] ^= 0xFF  # inside the descriptors' .npy header
    saved.write_bytes(bytes(data))
    with pytest.raises(MapFormatError, match=r"'descriptors.npy': Bad CRC-32"):
        load_map(saved)


def test_altered_header_is_caught_by_the_checksum(saved: Path) -> None:
    with np.load(saved, allow_pickle=False) as npz:
        arrays = {name: npz[name] for name in npz.files}
    header = json.loads(arrays["header"].tobytes())
    header["kind"] = "lowres2"
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    np.savez(saved, **arrays)
    with pytest.raises(MapFormatError, match="checksum mismatch"):
        load_map(saved)


def test_foreign_files(tmp_path: Path) -> None:
    other = tmp_path / "other.npz"
    np.savez(other, weights=np.zeros(3))
    with pytest.raises(
        MapFormatError, match=r"not a ppaloc map \(no 'header' entry; it holds \['weights'\]\)"
    ):
        load_map(other)
    text = tmp_path / "notes.npz"
    text.write_text("hello")
    with pytest.raises(MapFormatError, match=r"not a ppaloc map \(not an \.npz archive\)$"):
        load_map(text)
    single = tmp_path / "single.npy"
    np.save(single, np.zeros(3))
    with pytest.raises(MapFormatError, match=r"a single \.npy array"):
        load_map(single)
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, header=np.array([{"format": FORMAT_NAME}], dtype=object))
    with pytest.raises(MapFormatError, match=r"'header.npy' holds Python objects .*; refused"):
        load_map(pickled)
    wrong = tmp_path / "wrong.npz"
    np.savez(wrong, header=np.frombuffer(b'{"format": "evo.result"}', np.uint8))
    with pytest.raises(MapFormatError, match=r"format 'evo\.result', expected 'ppaloc\.topomap'"):
        load_map(wrong)


def test_newer_version(saved: Path) -> None:
    with np.load(saved, allow_pickle=False) as npz:
        arrays = {name: npz[name] for name in npz.files}
    header = json.loads(arrays["header"].tobytes())
    header["format_version"] = 3
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), np.uint8)
    np.savez(saved, **arrays)
    with pytest.raises(MapFormatError, match="format version 3 is newer than this ppaloc"):
        load_map(saved)
    with pytest.raises(MapFormatError, match="upgrade ppaloc"):
        read_header(saved)


def test_save_into_a_missing_folder(tmp_path: Path, lowres_map: TopoMap) -> None:
    with pytest.raises(DataError, match=r"folder .*missing does not exist; create it first"):
        lowres_map.save(tmp_path / "missing" / "map.npz")


def test_failed_save_leaves_no_temporary_and_keeps_the_old_file(
    saved: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    before = saved.read_bytes()

    def broken(*args: object, **kwargs: object) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError, match="disk full"):
        TopoMap("lbp", np.array([1], np.uint32)).save(saved)
    assert saved.read_bytes() == before
    assert [p.name for p in saved.parent.iterdir()] == ["map.npz"]


def test_a_map_with_places_round_trips_as_version_2(tmp_path: Path) -> None:
    """Places (runs of one place) are kept in version 2; a map without them is still
    written as version 1, which older readers take."""
    places = np.array([0, 1, 1, 1, 2], np.int64)
    with_runs = TopoMap("lbp", np.arange(5, dtype=np.uint32), places=places)
    back = load_map(save_map(with_runs, tmp_path / "runs.npz"))
    assert back.equals(with_runs) and back.has_runs
    assert read_header(tmp_path / "runs.npz")["format_version"] == 2
    plain = TopoMap("lbp", np.arange(5, dtype=np.uint32))
    save_map(plain, tmp_path / "plain.npz")
    assert read_header(tmp_path / "plain.npz")["format_version"] == 1
    assert load_map(tmp_path / "plain.npz").places is None


def test_round_trip_of_a_16x16_map_and_its_shape_checked(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    m = TopoMap("lowres16", rng.integers(0, 256, (5, 16, 16), dtype=np.uint8))
    loaded = load_map(save_map(m, tmp_path / "l16.npz"))
    assert loaded.equals(m) and loaded.kind == "lowres16"
    with pytest.raises(ValueError, match="lowres16"):
        TopoMap("lowres16", np.zeros((5, 8, 8), np.uint8))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    changes=st.lists(
        st.tuples(st.floats(0, 1, exclude_max=True), st.integers(0, 255)), min_size=1, max_size=5
    )
)
def test_any_changed_bytes_load_the_same_map_or_name_the_damage(changes, tmp_path_factory):
    """A map file with a few bytes changed anywhere (zip headers and directory included:
    a version, compression method or encryption flag the reader lacks) loads as the map
    it was or fails with MapFormatError; never another exception."""
    m = TopoMap("lbp", np.arange(7, dtype=np.uint32) * 0x01010101)
    path = m.save(tmp_path_factory.mktemp("fuzz") / "map.npz")
    data = bytearray(path.read_bytes())
    for where, value in changes:
        data[int(where * len(data))] = value
    path.write_bytes(bytes(data))
    try:
        loaded = load_map(path)
    except MapFormatError:
        return
    assert loaded.equals(m)
