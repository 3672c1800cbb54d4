"""SCAMP-5d C++ in and out (docs/cpp.md).

- :func:`run_program`: compile a SCAMP-5d device program against ppaloc's header shim and
  run it with every call served by the simulator (``ppaloc cpp run``).
- :func:`to_cpp`: write a recorded kernel, or a run of the on-sensor pipeline traced by a
  :class:`Tracer` (an observer of the simulator), as SCAMP-5d C++ for the vendor's
  toolchain.
"""

from ppaloc.cpp.build import CompileError, UnmodelledCallError, compile_program, compiler
from ppaloc.cpp.export import Trace, Tracer, kernel_to_cpp, to_cpp
from ppaloc.cpp.frames import FrameSource
from ppaloc.cpp.run import FramesFailedError, RunResult, run_program

__all__ = [
    "CompileError",
    "FrameSource",
    "FramesFailedError",
    "RunResult",
    "Trace",
    "Tracer",
    "UnmodelledCallError",
    "compile_program",
    "compiler",
    "kernel_to_cpp",
    "run_program",
    "to_cpp",
]
