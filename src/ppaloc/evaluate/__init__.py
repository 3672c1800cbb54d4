"""Evaluation: metrics, runs of methods over datasets, result files and the report.

See ``docs/evaluate-cli.md`` for the metric definitions and the result file formats.
"""

from ppaloc.evaluate.metrics import RECALL_DEFINITIONS, Metrics, PRCurve, evaluate_estimates

__all__ = ["RECALL_DEFINITIONS", "Metrics", "PRCurve", "evaluate_estimates"]
