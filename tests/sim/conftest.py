"""The simulator tests' shared helper module (``_icws.py``), registered by name so that
test modules imported in importlib mode can import it."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

NAME = "ppaloc_tests_sim_icws"

if NAME not in sys.modules:
    _spec = importlib.util.spec_from_file_location(NAME, Path(__file__).with_name("_icws.py"))
    _module = importlib.util.module_from_spec(_spec)
    sys.modules[NAME] = _module
    _spec.loader.exec_module(_module)
