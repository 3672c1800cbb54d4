"""A user's own ground truth for folder: and video:: positions, matrices and the checks."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from ppaloc.datasets import load_dataset
from ppaloc.errors import DataError, DatasetSpecError

from .test_loaders import _write_video


@pytest.fixture
def folders(write_frames, tmp_path):
    """Five reference images and four query images (flat grey: no same-place groups)."""
    write_frames(tmp_path / "ref", [10, 20, 30, 40, 50])
    write_frames(tmp_path / "qry", [11, 21, 31, 41])
    return tmp_path


def _spec(root, **keys):
    query = "&".join(f"{k}={v}" for k, v in keys.items())
    return f"folder:{root / 'ref'},{root / 'qry'}" + (f"?{query}" if query else "")


def test_positions_in_metres_with_queries_that_have_no_match(folders):
    (folders / "ref.csv").write_text("x,y\n0,0\n10,0\n20,0\n30,0\n40,0\n")
    (folders / "qry.csv").write_text("x,y\n1,0\n24,3\n100,0\n41,0\n")
    ds = load_dataset(
        _spec(folders, ref_positions=folders / "ref.csv", query_positions=folders / "qry.csv",
              tolerance_m=5)
    )  # fmt: skip
    assert [g.tolist() for g in ds.ground_truth] == [[0], [2], [], [4]]  # (24,3): 5 m from 20
    assert ds.tolerance == 0 and ds.tolerance_m == 5.0
    assert ds.reference_positions.tolist()[1] == [10, 0] and ds.query_positions.shape == (4, 2)
    rule = ds.meta["ground_truth_rule"]
    assert rule["kind"] == "metres" and rule["source"] == "positions"
    assert (rule["tolerance"], rule["tolerance_unit"]) == (5.0, "metres")
    assert rule["files"]["ref_positions"]["name"] == "ref.csv"
    assert len(rule["files"]["query_positions"]["sha256"]) == 64
    assert rule["positions"] == {"units": "x/y metres", "columns": ["x", "y"]}
    assert rule["same_place"] == {
        "rule": "positions", "params": {"radius_m": 1.0}, "groups": 0, "grouped_frames": 0,
        "queries_changed": 0,
    }  # fmt: skip
    assert ds.meta["roles"] == {
        "database": f"images in {folders / 'ref'}", "query": f"images in {folders / 'qry'}"
    }  # fmt: skip


def test_positions_beyond_a_million_kilometres_are_refused(folders):
    # coordinates near 1e154 metres overflowed the k-d tree's squared distances: an internal
    # error (scipy's ValueError "Encountering floating point overflow") for any tolerance
    (folders / "ref.csv").write_text("x,y\n0,0\n1e300,0\n20,0\n30,0\n40,0\n")
    (folders / "qry.csv").write_text("x,y\n1,0\n24,3\n100,0\n41,0\n")
    spec = _spec(folders, ref_positions=folders / "ref.csv", query_positions=folders / "qry.csv",
                 tolerance_m=5)  # fmt: skip
    with pytest.raises(DataError) as err:
        load_dataset(spec)
    assert str(err.value) == (
        f"ref_positions={folders / 'ref.csv'}, line 3: x 1e+300 is not a position in "
        "-1e+09..1e+09 metres (a million kilometres); give positions in metres"
    )


def test_soft_tolerance_and_same_place_from_positions(folders):
    # reference frames 1-3 stand at one place (within 0.5 m); the query at x = 75.3 reaches
    # frames 1 and 2 (24.7 m, 24.9 m) but not 3 (25.1 m): closed, it accepts all three
    (folders / "ref.csv").write_text("x,y\n0,0\n100,0\n100.2,0\n100.4,0.1\n200,0\n")
    (folders / "qry.csv").write_text("x,y\n0,0\n75.3,0\n150,0\n300,0\n")
    spec = _spec(folders, ref_positions=folders / "ref.csv",
                 query_positions=folders / "qry.csv", tolerance_m=24.95)  # fmt: skip
    ds = load_dataset(spec)
    assert [g.tolist() for g in ds.ground_truth] == [[0], [1, 2, 3], [], []]
    assert ds.reference_groups.tolist() == [[1, 4]]
    assert ds.meta["ground_truth_rule"]["same_place"]["queries_changed"] == 1
    off = load_dataset(spec + "&same_place=off")
    assert off.ground_truth[1].tolist() == [1, 2]
    soft = load_dataset(spec + "&soft_tolerance_m=60")
    assert [g.tolist() for g in soft.soft_ground_truth] == [[0], [1, 2, 3], [1, 2, 3, 4], []]
    assert soft.meta["ground_truth_rule"]["soft_tolerance"] == 60.0
    tight = load_dataset(spec + "&same_place_m=0.25")  # 1-2 within 0.25 m, 3 is not
    assert tight.reference_groups.tolist() == [[1, 3]]


def test_latitude_and_longitude(folders):
    (folders / "ref.csv").write_text(
        "name,lat,lon\n"
        + "".join(f"Image{k:03d}.png,52.0,{13 + k * 0.0001:.4f}\n" for k in range(5))
    )
    (folders / "qry.csv").write_text("lat,lon\n52,13\n52.00001,13.0002\n52.01,13\n52,13.0004\n")
    ds = load_dataset(
        _spec(folders, ref_positions=folders / "ref.csv", query_positions=folders / "qry.csv",
              tolerance_m=4)
    )  # fmt: skip
    # references are 6.86 m apart along the parallel at 52 N; 0.00001 deg north is 1.11 m
    assert [g.tolist() for g in ds.ground_truth] == [[0], [2], [], [4]]
    assert ds.reference_positions.shape == (5, 3)
    assert np.linalg.norm(ds.reference_positions[1]) == pytest.approx(6.86, abs=0.01)
    assert ds.meta["ground_truth_rule"]["positions"]["units"] == "lat/lon degrees"


def test_hard_and_soft_matrices(folders):
    hard = np.zeros((4, 5), bool)
    hard[0, 0] = hard[1, 1] = hard[3, 4] = True
    soft = hard.copy()
    soft[1, 2] = soft[2, 3] = True
    np.save(folders / "hard.npy", hard)
    np.savetxt(folders / "soft.csv", soft.astype(int), fmt="%d", delimiter=",")
    ds = load_dataset(_spec(folders, gt=folders / "hard.npy", gt_soft=folders / "soft.csv"))
    assert [g.tolist() for g in ds.ground_truth] == [[0], [1], [], [4]]
    assert [g.tolist() for g in ds.soft_ground_truth] == [[0], [1, 2], [3], [4]]
    rule = ds.meta["ground_truth_rule"]
    assert (rule["kind"], rule["source"], rule["tolerance"]) == ("matrix", "matrix", 0)
    assert set(rule["files"]) == {"gt", "gt_soft"}
    assert rule["same_place"]["rule"] == "off"  # the file's word
    np.savez(folders / "GT.npz", GThard=hard.T, GTsoft=soft.T)
    both = load_dataset(_spec(folders, gt=folders / "GT.npz", gt_transpose=1))
    assert [g.tolist() for g in both.soft_ground_truth] == [[0], [1, 2], [3], [4]]
    assert both.meta["ground_truth_rule"]["layout"] == "references x queries"
    widened = load_dataset(_spec(folders, gt=folders / "hard.npy", tolerance=1, step=1))
    assert [g.tolist() for g in widened.ground_truth] == [[0, 1], [0, 1, 2], [], [3, 4]]


def test_swapped_soft_and_hard_are_caught(folders):
    hard = np.eye(4, 5, dtype=bool)
    soft = hard.copy()
    soft[2, 2] = False
    np.save(folders / "hard.npy", hard)
    np.save(folders / "soft.npy", soft)
    with pytest.raises(DataError, match=r"soft ground truth .*soft\.npy lacks the hard match "
                       r"\(query 2, reference 2\); .* are gt and gt_soft swapped\?"):  # fmt: skip
        load_dataset(_spec(folders, gt=folders / "hard.npy", gt_soft=folders / "soft.npy"))


@pytest.mark.parametrize(
    ("keys", "message"),
    [
        ({"ref_positions": "r.csv"}, r"ref_positions needs query_positions too"),
        ({"tolerance_m": 5}, r"tolerance_m is a distance between positions: add ref_positions="),
        ({"same_place_m": 2}, r"same_place_m is a distance between positions"),
        ({"gt_soft": "s.npy"}, r"gt_soft needs gt \(the hard matrix\) too"),
        ({"gt_transpose": 1}, r"gt_transpose applies to gt= and gt_soft=; give gt="),
        ({"ref_positions": "r.csv", "query_positions": "q.csv"},
         r"positions give the ground truth in metres: add tolerance_m="),
        ({"ref_positions": "r.csv", "query_positions": "q.csv", "tolerance_m": 5, "tolerance": 2},
         r"mixed units: tolerance counts frames but the ground truth is in metres"),
        ({"ref_positions": "r.csv", "query_positions": "q.csv", "tolerance_m": 5,
          "soft_tolerance": 2}, r"mixed units: soft_tolerance counts frames"),
        ({"ref_positions": "r.csv", "query_positions": "q.csv", "tolerance_m": 5,
          "soft_tolerance_m": 2},
         r"soft_tolerance_m=2 is below tolerance_m=5; .* soft_tolerance_m >= tolerance_m"),
        ({"gt": "h.npy", "ref_positions": "r.csv", "query_positions": "q.csv",
          "tolerance_m": 5}, r"gt= gives the ground truth, tolerance_m applies to positions"),
        ({"gt": "h.npy", "gt_soft": "s.npy", "soft_tolerance": 3},
         r"gt_soft and soft_tolerance both give soft ground truth: drop one"),
    ],
)  # fmt: skip
def test_key_combinations_are_refused_before_any_file_is_read(tmp_path, keys, message):
    # the folders do not even exist: the spec is refused first
    with pytest.raises(DatasetSpecError, match=message) as info:
        load_dataset(_spec(tmp_path, **keys))
    assert "\n" not in str(info.value)


def test_unequal_folders_need_their_own_ground_truth(folders):
    with pytest.raises(DataError, match=r"has 5 images but query .* has 4; ground truth by index"):
        load_dataset(_spec(folders))


def test_a_missing_or_foreign_file_is_named(folders):
    with pytest.raises(DataError, match=r"gt=.*absent\.npy does not exist"):
        load_dataset(_spec(folders, gt=folders / "absent.npy"))
    np.save(folders / "gt.npy", np.zeros((5, 4), bool))  # written for references x queries
    with pytest.raises(DataError, match=r"has shape \(5, 4\); expected 4 x 5 .* gt_transpose=1"):
        load_dataset(_spec(folders, gt=folders / "gt.npy"))
    (folders / "ref.csv").write_text(
        "name,x,y\n" + "".join(f"Image{k:03d}.png,{k},0\n" for k in (0, 2, 1, 3, 4))
    )
    (folders / "qry.csv").write_text("x,y\n0,0\n1,0\n2,0\n3,0\n")
    with pytest.raises(DataError, match=r"line 3: name is 'Image002\.png' but frame 1 is "
                       r"'Image001\.png'; sort the rows in frame order"):  # fmt: skip
        load_dataset(
            _spec(folders, ref_positions=folders / "ref.csv", query_positions=folders / "qry.csv",
                  tolerance_m=1)
        )  # fmt: skip


def test_video_with_positions(tmp_path):
    rng = np.random.default_rng(0)
    coarse = rng.uniform(0, 255, (6, 4, 6)).astype(np.float32)
    scenes = [
        np.asarray(Image.fromarray(c, mode="F").resize((48, 32), Image.Resampling.BILINEAR))
        .clip(0, 255)
        .astype(np.uint8)
        for c in coarse
    ]
    _write_video(tmp_path / "ref.mp4", scenes)
    _write_video(tmp_path / "qry.mp4", scenes[:4])
    (tmp_path / "ref.csv").write_text("x,y\n" + "".join(f"{10 * k},0\n" for k in range(6)))
    (tmp_path / "qry.csv").write_text("x,y\n0,0\n21,0\n29,0\n80,0\n")
    ds = load_dataset(
        f"video:{tmp_path / 'ref.mp4'},{tmp_path / 'qry.mp4'}?ref_positions={tmp_path / 'ref.csv'}"
        f"&query_positions={tmp_path / 'qry.csv'}&tolerance_m=2"
    )
    assert [g.tolist() for g in ds.ground_truth] == [[0], [2], [3], []]
    assert ds.meta["roles"]["database"] == f"frames of {tmp_path / 'ref.mp4'}"
    with pytest.raises(DatasetSpecError, match=r"align applies to ground truth by frame index"):
        load_dataset(
            f"video:{tmp_path / 'ref.mp4'},{tmp_path / 'qry.mp4'}?gt={tmp_path / 'x.npy'}"
            "&align=proportional"
        )


def test_positions_beside_a_matrix_give_metres_and_groups_on_request(folders):
    (folders / "ref.csv").write_text("x,y\n0,0\n10,0\n10.5,0\n20,0\n30,0\n")
    (folders / "qry.csv").write_text("x,y\n0,0\n10,0\n20,0\n30,0\n")
    hard = np.zeros((4, 5), bool)
    hard[0, 0] = hard[1, 1] = hard[2, 3] = hard[3, 4] = True
    np.save(folders / "gt.npy", hard)
    spec = _spec(folders, gt=folders / "gt.npy", ref_positions=folders / "ref.csv",
                 query_positions=folders / "qry.csv")  # fmt: skip
    ds = load_dataset(spec)
    assert [g.tolist() for g in ds.ground_truth] == [[0], [1], [3], [4]]  # the matrix's word
    assert (
        ds.reference_positions.shape == (5, 2) and ds.meta["ground_truth_rule"]["kind"] == "matrix"
    )
    closed = load_dataset(spec + "&same_place=positions")
    assert closed.ground_truth[1].tolist() == [1, 2] and closed.reference_groups.tolist() == [
        [1, 3]
    ]
