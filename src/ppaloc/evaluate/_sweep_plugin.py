"""The worker plugin of a sweep's local cluster (imported only when a sweep starts one:
it needs ``distributed``)."""

from __future__ import annotations

import signal
import threading
from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["IgnoreSigint"]


class IgnoreSigint(WorkerPlugin):
    """The local cluster's worker processes ignore SIGINT.

    Ctrl-C in a terminal reaches every process of the foreground group; the client alone
    should handle it (cancel the cells in flight, rebuild the summary, close the cluster)
    instead of each worker printing a traceback as it dies. Registered for a cluster that
    ``ppaloc sweep`` starts itself, never on an existing scheduler's workers.
    """

    name = "ppaloc-ignore-sigint"

    def setup(self, worker: Any) -> None:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
