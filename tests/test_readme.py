"""The README's Python examples run as written."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)


def test_readme_has_python_examples():
    assert len(BLOCKS) >= 2


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_example_runs(index, capsys):
    exec(compile(BLOCKS[index], f"README.md python block {index}", "exec"), {})


DEMO = "synthetic:?places=200&query=winter&seed=0&sync=1&stops=2"
TEXT = " ".join(README.read_text().split())


@pytest.mark.parametrize(
    ("method", "param", "said"),
    [
        ("weighted-node-haar", {"local_gain": 0}, "0.955 with `local_gain=0`"),
        ("weighted-node-lbp", {"still_decay": 0}, "0.980 with `still_decay=0`"),
        ("weighted-node-lowres", {"contrast": 0}, "from 0.80 (`contrast=0`;"),
    ],
)
def test_the_demo_routes_figures_without_a_term_are_the_runs(method, param, said):
    # "takes the winter query from 0.83": the paper preset's figure, not contrast=0's
    from ppaloc.evaluate.config import EvaluateConfig
    from ppaloc.evaluate.run import run_evaluation

    assert said in TEXT
    config = EvaluateConfig(
        dataset=DEMO, methods=(method,), params={method: param}, record_weights=False
    )
    f1 = run_evaluation(config, progress=False).runs[method].metrics.f1_max
    shown = re.search(r"\d\.\d+", said)[0]
    assert f"{f1:.{len(shown) - 2}f}" == shown
