"""The Examples in the evaluate docstrings run and give what they show."""

from __future__ import annotations

import doctest

import pytest

import ppaloc.evaluate.columns
import ppaloc.evaluate.config
import ppaloc.evaluate.difference
import ppaloc.evaluate.figures
import ppaloc.evaluate.metrics
import ppaloc.evaluate.results


@pytest.mark.parametrize(
    "module",
    [
        ppaloc.evaluate.metrics,
        ppaloc.evaluate.config,
        ppaloc.evaluate.columns,
        ppaloc.evaluate.difference,
        ppaloc.evaluate.figures,
        ppaloc.evaluate.results,
    ],
)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
