"""A damaged bench.json is one DataError naming the file, never a crash of the report."""

from __future__ import annotations

import pytest

from ppaloc.errors import DataError
from ppaloc.evaluate.bench import load_bench

GOOD_ROW = (
    '{"method": "m", "n_nodes": 8, "latency_ms_median": 1, "latency_ms_p95": 2, "build_s": 0}'
)


@pytest.mark.parametrize(
    ("content", "fragment"),
    [
        (b"[" * 100_000, "nested too deeply"),
        (b"\xff\xfe{}", "UnicodeDecodeError"),
        (b"{not json", "JSONDecodeError"),
        (b"[]", "has no 'rows' list"),
        (b'{"rows": 5}', "has no 'rows' list"),
        (b'{"rows": [5]}', "row 0 is not a bench row"),
        (b'{"rows": [{"method": "m", "n_nodes": -1}]}', "row 0 is not a bench row"),
        (b'{"rows": [{"method": "m", "n_nodes": true}]}', "row 0 is not a bench row"),
        (b'{"rows": [{"method": "m", "n_nodes": 8}]}', "row 0 lacks its timings"),
        (('{"rows": [' + GOOD_ROW.replace("1,", '"x",') + "]}").encode(), "lacks its timings"),
        # save_bench never writes them; the report's log-scaled figure failed on Infinity
        (('{"rows": [' + GOOD_ROW.replace("1,", "Infinity,") + "]}").encode(), "Infinity"),
        (('{"rows": [' + GOOD_ROW.replace("2,", "NaN,") + "]}").encode(), "holds NaN"),
    ],
)
def test_damaged_bench_file_is_one_data_error(tmp_path, content, fragment):
    path = tmp_path / "bench.json"
    path.write_bytes(content)
    with pytest.raises(DataError, match=fragment):
        load_bench(path)


def test_good_and_skipped_rows_load(tmp_path):
    path = tmp_path / "bench.json"
    skipped = '{"method": "m", "n_nodes": 9, "skipped": "too big"}'
    path.write_text('{"rows": [' + GOOD_ROW + ", " + skipped + "]}")
    assert len(load_bench(path)["rows"]) == 2
