"""How much of a SCAMP-5d device header set the C++ shim covers (``ppaloc.cpp.coverage``).

Not collected by pytest. Give the device's include folders, searched in order as a
compiler's ``-I`` path: the headers of the first and every header they include::

    PYTHONPATH=src .venv/bin/python benchmarks/cpp_coverage.py SDK/include/s5d_m0 SDK/include

Prints ``covered / total`` over every ``scamp5_*``/``vs_*`` name (any case) the headers
declare, the same over the first folder's own headers, one line per header, and then the
names the shim lacks, by header. The headers are read where they are; nothing is copied.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

from ppaloc.cpp.coverage import coverage
from ppaloc.errors import PpalocError


def main(argv: list[str] | None = None) -> int:
    """Print the shim's coverage of the headers in the folders given; 1 on a bad folder."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="include folders, in order")
    args = parser.parse_args(argv)
    try:
        c = coverage(args.folders)
    except PpalocError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    first = {f.name for f in args.folders[0].iterdir()}
    own = [n for n in c.declared if c.declared[n] in first]
    have = set(c.covered)
    print(f"all headers reached: {c.summary()}")
    print(f"{args.folders[0]} itself: {sum(n in have for n in own)} / {len(own)}")
    total = Counter(c.declared.values())
    covered = Counter(c.declared[n] for n in c.covered)
    for header in sorted(total):
        mark = "" if header in first else "  (included)"
        print(f"  {header:32} {covered[header]:3} / {total[header]:3}{mark}")
    print(f"missing ({len(c.missing)}):")
    for header in sorted(total):
        names = [n for n in c.missing if c.declared[n] == header]
        if names:
            print(f"  {header}: {' '.join(names)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
