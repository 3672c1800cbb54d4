"""The wire protocol between a compiled SCAMP-5d program and the simulator serving it.

One source of truth for both ends: :func:`ppaloc.cpp.shimgen.constants_header` writes
these numbers into the C++ shim. Little-endian binary framing over two pipes.

Program -> simulator, one message each::

    u8 op, u32 payload length, payload

- ``HELLO``: ``u32 version``; answered with ``u16 rows, u16 cols``.
- ``DEF``: ``u32 id, u32 line, u8 dynamic, u32 n``, then ``n`` macro calls, each ``u8 name length,
  name, u32 line, u8 n_args, args``. Sent once per distinct kernel body; never answered.
- ``RUN``: ``u32 id``. The first run records the kernel on the simulator (and runs it),
  later runs replay it. Never answered, so runs stream.
- ``CALL``: ``u8 wants_reply, u8 name length, name, u32 line, u8 n_args, args``: a
  controller, output, GUI or loop call, served by name. Only calls with ``wants_reply``
  (readouts, sliders, the frame loop, the stopwatch) are answered.
- ``EXIT``: empty; the program is ending.
- ``FILE``: ``u32 id, u8 name length, name``: the source file (its name, not its folder)
  that locations with this ``id`` were written in; sent once per file before its first use.

A ``line`` on the wire is a location: the file's ``id`` in the top 12 bits
(:data:`LINE_BITS` up), the line in the low 20, so a call in a second source file or an
included header is reported with that file's name and line.

An argument is ``u8 tag, i32 value``; a string (tag ``STR``) is followed by its bytes
(``value`` = length), a list (tag ``LIST``, e.g. the destinations of ``bus({a, b}, {x})``)
by its ``value`` arguments, a byte block (tag ``BYTES``: the data of ``vs_post_int16``,
``scamp5_display_image``, ...) by its ``value`` bytes. Register arguments carry the
register's code (its index in :data:`REGISTER_NAMES`).

Simulator -> program, one reply per answered message::

    u32 status (0 ok, else the program stops), u32 length, payload

The answer to ``vs_frame_loop_control`` is its ``i32`` (1 to run the next frame, 0 at the
end) followed by ``i32 handle, i32 value`` pairs: the sliders and switches a live view
(:mod:`ppaloc.cpp.live`) changed since the last frame, which the shim applies as the device
applies the host's GUI messages (value, writeback variable, ``vs_on_gui_update`` callback).
A slider's or switch's ``CALL`` carries the handle the shim gave it after its initial value.
The handle :data:`DEVICE_ERRORS` (no GUI item has it) carries the device's error flags
instead, as ``vs_device_error_bits`` holds them (bit 7: the ICW stack overflowed).

The program buffers messages (64 KiB) and writes them only when it needs an answer, when
the buffer is full, or at exit: a replayed kernel costs 9 bytes and no round trip.
"""

from __future__ import annotations

__all__ = [
    "DEVICE_ERRORS",
    "ICW_STACK_OVERFLOW",
    "LINE_BITS",
    "LINE_MASK",
    "OPS",
    "REGISTER_NAMES",
    "TAGS",
    "VERSION",
]

#: Protocol version (HELLO checks it).
VERSION = 5  # 5: a kernel's call count is a u32 (a u16 wrapped at 65,536 calls)

#: Message opcodes.
OPS: dict[str, int] = {"HELLO": 1, "DEF": 2, "RUN": 3, "CALL": 4, "EXIT": 5, "FILE": 6}

#: The handle of the device's error flags in the frame loop's answer, and the flag of an
#: overflow of the ICW stack (``vs_device_error_bits_t::icw_stack_overflow``, bit 7).
DEVICE_ERRORS = -1
ICW_STACK_OVERFLOW = 1 << 7

#: Bits of a wire location that hold the line (the rest hold the file's id).
LINE_BITS = 20
#: The line of a wire location: ``code & LINE_MASK``; its file: ``code >> LINE_BITS``.
LINE_MASK = (1 << LINE_BITS) - 1

#: Argument tags.
TAGS: dict[str, int] = {"INT": 0, "AREG": 1, "DREG": 2, "DIR": 3, "STR": 4, "LIST": 5, "BYTES": 6}

#: Register codes, in order: the C++ constants carry these indices.
REGISTER_NAMES: tuple[str, ...] = (
    "A", "B", "C", "D", "E", "F", "NEWS", "PIX", "IN", "XN", "XE", "XS", "XW",
    "R0", "R1", "R2", "R3", "R4", "R5", "R6", "R7", "R8", "R9", "R10", "R11", "R12",
    "FLAG", "SELECT", "RECT",
)  # fmt: skip

#: The program's exit code when the shim stops it on a usage error it found itself
#: (the message is its last line on stderr, prefixed ``ppaloc-shim:``).
SHIM_EXIT = 65
#: The program's exit code when the simulator answered with an error status.
SERVER_EXIT = 66
