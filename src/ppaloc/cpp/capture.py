"""A program's standard output and error, kept within a bound while it runs.

A device program that prints in a loop which never ends (a ``printf`` left in for
debugging) writes gigabytes before its timeout stops it; written to a temporary file and
read back whole, that filled the disk and the memory of the machine. Each stream here is a
pipe drained by a thread as the program writes: the first :data:`MAX_OUTPUT_BYTES` are kept
(and, where asked, the last as many: the end of standard error holds a crash's report), the
bytes between them only counted.
"""

from __future__ import annotations

import collections
import os
import select
import threading
import time

__all__ = ["CLOSE_WAIT_S", "MAX_OUTPUT_BYTES", "Capture", "finish_all"]

MAX_OUTPUT_BYTES = 16 << 20
"""Bytes of a program's output kept from its start (16 MiB; as many again from its end
where the end is kept)."""

CLOSE_WAIT_S = 1.0
"""Seconds the captures wait, together, for their pipes to close once the program has
ended: its last output is in the pipes by then; a process it left running that holds
them open is not waited for longer."""

_POLL_S = 0.05  # how often a drain looks whether it was told to stop


class Capture:
    """Drain the read end ``fd`` of a pipe in a thread, keeping its first ``limit`` bytes
    (default :data:`MAX_OUTPUT_BYTES`) and, with ``tail``, its last ``limit`` bytes; the
    rest is counted in :attr:`dropped`.

    Examples
    --------
    >>> r, w = os.pipe()
    >>> c = Capture(r, limit=4, tail=True)
    >>> _ = os.write(w, b"0123456789"); os.close(w)
    >>> c.finish(time.monotonic() + 1); c.head, c.tail, c.dropped
    (b'0123', b'6789', 2)
    """

    def __init__(self, fd: int, *, limit: int | None = None, tail: bool = False) -> None:
        self.limit = MAX_OUTPUT_BYTES if limit is None else limit
        self.dropped = 0
        self._fd = fd
        self._head = bytearray()
        self._tail: collections.deque[bytes] = collections.deque()
        self._tail_size = 0
        self._keep_tail = tail
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._drain, name="ppaloc-capture", daemon=True)
        self._thread.start()

    def _drain(self) -> None:
        try:
            while not self._stop.is_set():
                if not select.select([self._fd], [], [], _POLL_S)[0]:
                    continue
                data = os.read(self._fd, 1 << 16)
                if not data:
                    break
                with self._lock:
                    self._keep(data)
        except OSError:
            pass
        finally:
            os.close(self._fd)

    def _keep(self, data: bytes) -> None:
        room = self.limit - len(self._head)
        if room > 0:
            self._head += data[:room]
            data = data[room:]
        if not data:
            return
        if not self._keep_tail:
            self.dropped += len(data)
            return
        self._tail.append(data)
        self._tail_size += len(data)
        excess = self._tail_size - self.limit
        while excess > 0:  # drop the oldest bytes beyond the last `limit`
            first = self._tail[0]
            cut = min(len(first), excess)
            if cut == len(first):
                self._tail.popleft()
            else:
                self._tail[0] = first[cut:]
            self._tail_size -= cut
            self.dropped += cut
            excess -= cut

    def finish(self, deadline: float) -> None:
        """Wait for the pipe to close (every writer gone) until ``deadline`` (a
        ``time.monotonic()`` time), then stop reading and close it: a process the program
        left running with the pipe open is not waited for beyond it."""
        self._thread.join(max(0.0, deadline - time.monotonic()))
        self._stop.set()
        self._thread.join()

    @property
    def head(self) -> bytes:
        """The first bytes kept."""
        with self._lock:
            return bytes(self._head)

    @property
    def tail(self) -> bytes:
        """The last bytes, after :attr:`head` and the :attr:`dropped` ones (with ``tail``
        only; at most ``limit``)."""
        with self._lock:
            return b"".join(self._tail)


def finish_all(captures: tuple[Capture, ...], wait: float = CLOSE_WAIT_S) -> None:
    """:meth:`Capture.finish` every capture by one deadline, ``wait`` seconds from now."""
    deadline = time.monotonic() + wait
    for capture in captures:
        capture.finish(deadline)
