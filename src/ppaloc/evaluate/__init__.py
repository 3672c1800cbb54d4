"""Evaluation: metrics, runs of methods over datasets, result files and the report.

See ``docs/evaluate-cli.md`` for the metric definitions and the result file formats;
``score_predictions`` measures any method's predictions read from CSV files (``ppaloc
score``) by the same code.
``write_report`` and ``run_bench`` are imported on first use (the report needs
matplotlib, which importing the metrics should not); so are the sweep's ``SweepConfig``,
``run_sweep`` and ``write_sweep_report`` (docs/sweep.md; a sweep runs on Dask, imported
only when one runs).
"""

from typing import Any

from ppaloc.evaluate.config import BenchConfig, EvaluateConfig
from ppaloc.evaluate.metrics import RECALL_DEFINITIONS, Metrics, PRCurve, evaluate_estimates
from ppaloc.evaluate.results import load_results, save_results
from ppaloc.evaluate.run import MethodRun, RunResult, run_evaluation
from ppaloc.evaluate.score import ScoreConfig, read_predictions, score_predictions

__all__ = [
    "RECALL_DEFINITIONS",
    "BenchConfig",
    "EvaluateConfig",
    "MethodRun",
    "Metrics",
    "PRCurve",
    "RunResult",
    "ScoreConfig",
    "SweepConfig",
    "evaluate_estimates",
    "load_results",
    "read_predictions",
    "run_bench",
    "run_evaluation",
    "run_sweep",
    "save_results",
    "score_predictions",
    "write_report",
    "write_sweep_report",
]

_SWEEP = {
    "SweepConfig": "ppaloc.evaluate.sweep",
    "run_sweep": "ppaloc.evaluate.sweep",
    "write_sweep_report": "ppaloc.evaluate.sweep_report",
}


def __getattr__(name: str) -> Any:
    if name == "write_report":
        from ppaloc.evaluate.report import write_report

        return write_report
    if name == "run_bench":
        from ppaloc.evaluate.bench import run_bench

        return run_bench
    if name in _SWEEP:
        import importlib

        return getattr(importlib.import_module(_SWEEP[name]), name)
    raise AttributeError(f"module 'ppaloc.evaluate' has no attribute {name!r}")
