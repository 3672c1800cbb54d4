"""The report: built from result files only, self-contained, every figure decodes."""

from __future__ import annotations

import base64
import io
import json
import re
import shutil

import numpy as np
import pytest
from PIL import Image

from ppaloc.evaluate.bench import run_bench, save_bench
from ppaloc.evaluate.config import BenchConfig, EvaluateConfig
from ppaloc.evaluate.report import comparison_table, write_report
from ppaloc.evaluate.results import save_results
from ppaloc.evaluate.run import run_evaluation

IMG = re.compile(r"<img src='data:image/png;base64,([A-Za-z0-9+/=]+)' alt='([^']*)'>")


@pytest.fixture
def results_dir(mean_match, standin, monkeypatch, tiny, tmp_path):
    other = standin.register(monkeypatch, "mean-match-shifted", offset=1, modelled=True)
    cfg = EvaluateConfig(methods=(mean_match, other))
    save_results(run_evaluation(cfg, dataset=tiny, progress=False), tmp_path / "run")
    bench = run_bench(BenchConfig(methods=(mean_match,), sizes=(4, 16), queries=2, warmup=0))
    save_bench(bench, tmp_path / "run" / "bench.json")
    return tmp_path / "run"


def test_report_is_self_contained_and_every_figure_decodes(results_dir):
    page = write_report(results_dir).read_text()
    images = IMG.findall(page)
    titles = [alt for _, alt in images]
    assert titles == [
        "Precision-recall curves",
        "Difference matrix",
        "Position estimate along the route",
        "Weights over time",
        "Registers of mean-match-shifted after the last frame",
        "Host time per frame in this run",
        "Latency against map size",
    ]
    for data, alt in images:
        im = Image.open(io.BytesIO(base64.b64decode(data)))
        im.load()
        assert im.format == "PNG" and im.width >= (100 if "Registers" in alt else 600), alt
    assert page.count("<img") == len(images)  # nothing but embedded PNGs
    assert not re.search(r"(src|href)=['\"]?(https?:|file:|//)", page)
    assert "mean-match-shifted" in page and "Recall A" in page


def test_markdown_twin_links_existing_pngs(results_dir):
    write_report(results_dir)
    md = (results_dir / "report.md").read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert len(links) == 7
    for rel in links:
        assert (results_dir / rel).is_file()
    assert "| mean-match |" in md


def test_table_shape_and_values(results_dir):
    summary = json.loads((results_dir / "results.json").read_text())
    header, rows = comparison_table(summary)
    assert header[:3] == ["Method", "Representation", "F1 max"]
    assert [r[0] for r in rows] == ["mean-match", "mean-match-shifted"]
    assert rows[0][2] == "1.000"  # F1 of the exact stand-in
    assert rows[0][10] == "-" and rows[1][10] == "0.25"  # modelled ms only where modelled


def test_report_without_weights_or_bench(mean_match, tiny, tmp_path):
    cfg = EvaluateConfig(methods=(mean_match,), record_weights=False)
    save_results(run_evaluation(cfg, dataset=tiny, progress=False), tmp_path)
    titles = [alt for _, alt in IMG.findall(write_report(tmp_path).read_text())]
    assert "Weights over time" not in titles and "Latency against map size" not in titles


def test_report_from_files_only(results_dir, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(results_dir, copy)
    for f in copy.glob("report.*"):
        f.unlink()
    assert write_report(copy).is_file()
    z = np.load(copy / "arrays" / "mean-match.npz")
    assert {"node", "score", "moved", "ranking", "latency_ms", "ref_index"} <= set(z.files)


_CHECK = """
<script>
window.addEventListener('load', () => {
  const imgs = Array.from(document.images);
  const ok = imgs.filter(i => i.complete && i.naturalWidth > 0).length;
  document.body.setAttribute('data-images', ok + '/' + imgs.length);
});
</script>
"""


@pytest.mark.slow
def test_chromium_loads_every_figure(results_dir, tmp_path, dump_dom):
    page = write_report(results_dir).read_text()
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", _CHECK + "</body>"))
    n = len(IMG.findall(page))
    out = dump_dom(probe.as_uri(), 5000)
    assert f'data-images="{n}/{n}"' in out.stdout, out.stderr[-2000:]
