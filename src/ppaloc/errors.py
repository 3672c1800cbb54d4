"""Exception types a user can cause.

``PpalocError`` and its subclasses mean *the input was wrong*: the CLI prints their message
in one line and exits non-zero. Any other exception is a bug and is reported with a
traceback. Messages name the bad value and, where there is one, the fix.
"""

__all__ = [
    "DataError",
    "DatasetSpecError",
    "KernelError",
    "MapFormatError",
    "PpalocError",
    "RegisterMisuseError",
    "SimulatorError",
]


class PpalocError(Exception):
    """A mistake in what the user asked for or supplied (not a bug in ppaloc)."""


class DataError(PpalocError):
    """A dataset, folder, image or ground-truth file is missing, unreadable or inconsistent."""


class DatasetSpecError(DataError):
    """A dataset spec string (``KIND:PATH?key=value``) is malformed or names an unknown key."""


class MapFormatError(PpalocError):
    """A saved map is corrupt, truncated, foreign or from a newer format version."""


class SimulatorError(PpalocError):
    """A program asked the simulated PPA for something the hardware cannot do."""


class KernelError(SimulatorError):
    """A kernel is invalid, e.g. longer than the 1024-ICW instruction buffer."""


class RegisterMisuseError(SimulatorError):
    """An instruction or macro breaks a register rule (a register listed twice, a bad alias)."""
