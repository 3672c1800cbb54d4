"""The input options FFmpeg takes for an input format and its decoder, so that one
neither takes is refused rather than ignored, and the decoder's reach the decoder.

FFmpeg hands an input the options it knows and leaves the rest unused without a word (and
PyAV drops what is left), so ``--stream-option video_sise=640x480`` would run the camera at
its default size. The names are read from the option tables of the FFmpeg libraries PyAV
loaded (``av_opt_next`` through :mod:`ctypes`, the same tables ``ffmpeg -h demuxer=NAME``
prints): the format's own options, FFmpeg's general input (``AVFormatContext``) options,
which every input takes, and where the format reads through a protocol (a file,
``http://``, ``udp://``) every input protocol's options, as protocols hand options on to
the ones below them, and those every protocol takes (``rw_timeout``).

An option the input does not take is the decoder's where a decoder takes it: FFmpeg's
general decoding (``AVCodecContext``) options (``threads``, ``lowres``) and the decoder's
own (mjpeg's ``extern_huff``; :func:`decoder_options`), checked once the input is open and
its decoder known, and given to the decoder the frames come from, as ``ffmpeg -NAME VALUE
-i`` gives them (PyAV hands them only to the decoder it opens while probing the input).

The libraries are the ones of the versions PyAV reports (another FFmpeg may be loaded in
the process too). Where they cannot be read so (a build of PyAV whose libraries are not
found), nothing is refused and the options go to the input alone, as given.
"""

from __future__ import annotations

import ctypes
import difflib
import functools
import glob
import os
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from ppaloc.errors import DataError

__all__ = ["InputOptions", "check_input_options", "decoder_options", "input_options"]

#: ``AV_OPT_SEARCH_CHILDREN``: the object's children are searched too.
_CHILDREN = 1
#: ``AV_OPT_SEARCH_FAKE_OBJ``: the object given is a pointer to an ``AVClass`` pointer.
_FAKE_OBJ = 2
#: ``AV_OPT_FLAG_DECODING_PARAM``: an option for decoding.
_DECODING = 2


@dataclass(frozen=True)
class InputOptions:
    """The options an input format takes: its ``own`` and FFmpeg's ``general`` ones, and
    the general ``decoding`` ones every decoder takes (those the input takes too are the
    input's)."""

    format: str
    own: frozenset[str]
    general: frozenset[str]
    decoding: frozenset[str] = frozenset()

    def __contains__(self, name: object) -> bool:
        return name in self.own or name in self.general or name in self.decoding

    def for_decoder(self, options: dict[str, str]) -> dict[str, str]:
        """The ``options`` that are the decoder's: those the input does not take."""
        return {k: v for k, v in options.items() if k not in self.own and k not in self.general}


class _Option(ctypes.Structure):  # the start of FFmpeg's AVOption
    _fields_ = [("name", ctypes.c_char_p)]


class _InputFormat(ctypes.Structure):  # the public start of AVInputFormat (FFmpeg 4 to 8)
    _fields_ = [
        ("name", ctypes.c_char_p),
        ("long_name", ctypes.c_char_p),
        ("flags", ctypes.c_int),
        ("extensions", ctypes.c_char_p),
        ("codec_tag", ctypes.c_void_p),
        ("priv_class", ctypes.c_void_p),
    ]


def _candidates(name: str) -> Iterator[str]:
    """Paths that may hold FFmpeg's library ``name`` (``avformat``): those mapped into this
    process, then those shipped beside the ``av`` package."""
    import av

    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            for line in maps:
                path = line.split(maxsplit=5)[-1].strip()
                if os.path.basename(path).startswith(f"lib{name}"):
                    yield path
    except OSError:
        pass
    base = os.path.dirname(os.path.dirname(av.__file__))
    for pattern in (f"av.libs/lib{name}*", f"av/.dylibs/lib{name}*", f"av.libs/{name}-*.dll"):
        yield from sorted(glob.glob(os.path.join(base, pattern)))


def _library(name: str) -> Any:
    """FFmpeg's library ``name`` (``avformat``) as PyAV loaded it: the first candidate
    (:func:`_candidates`) of the version PyAV reports, else None. Another FFmpeg may be
    mapped into the process too (one another package bundles), and its tables are not the
    ones PyAV's FFmpeg reads."""
    import av

    major, minor, micro = av.library_versions[f"lib{name}"]
    wanted = (major << 16) | (minor << 8) | micro
    for path in dict.fromkeys(_candidates(name)):
        try:
            lib = ctypes.CDLL(path)
            version = getattr(lib, f"{name}_version")
        except (OSError, AttributeError):
            continue
        version.restype, version.argtypes = ctypes.c_uint, []
        if version() == wanted:
            return lib
    return None


@functools.cache
def _libraries() -> tuple[Any, Any, Any] | None:
    """FFmpeg's avformat, avcodec and avutil as PyAV loaded them, or None."""
    try:
        fmt, codec, util = (_library(n) for n in ("avformat", "avcodec", "avutil"))
    except (KeyError, TypeError, ValueError):  # a PyAV that reports no such version
        return None
    if fmt is None or codec is None or util is None:
        return None
    try:
        util.av_opt_next.restype = ctypes.c_void_p
        util.av_opt_next.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        util.av_opt_find.restype = ctypes.c_void_p
        util.av_opt_find.argtypes = [
            ctypes.c_void_p,
            ctypes.c_char_p,
            ctypes.c_char_p,
            ctypes.c_int,
            ctypes.c_int,
        ]
        fmt.avformat_get_class.restype = ctypes.c_void_p
        fmt.av_find_input_format.restype = ctypes.c_void_p
        fmt.av_find_input_format.argtypes = [ctypes.c_char_p]
        fmt.avio_enum_protocols.restype = ctypes.c_char_p
        fmt.avio_enum_protocols.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_int]
        fmt.avio_protocol_get_class.restype = ctypes.c_void_p
        fmt.avio_protocol_get_class.argtypes = [ctypes.c_char_p]
        codec.avcodec_get_class.restype = ctypes.c_void_p
        codec.avcodec_find_decoder_by_name.restype = ctypes.c_void_p
        codec.avcodec_find_decoder_by_name.argtypes = [ctypes.c_char_p]
        codec.avcodec_alloc_context3.restype = ctypes.c_void_p
        codec.avcodec_alloc_context3.argtypes = [ctypes.c_void_p]
        codec.avcodec_free_context.restype = None
        codec.avcodec_free_context.argtypes = [ctypes.POINTER(ctypes.c_void_p)]
        util.av_opt_child_next.restype = ctypes.c_void_p
        util.av_opt_child_next.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    except (OSError, AttributeError):
        return None
    for name in ("av_opt_child_class_iterate", "av_opt_child_class_next"):  # FFmpeg 4.4+, 4
        if hasattr(util, name):
            getattr(util, name).restype = ctypes.c_void_p
    return fmt, codec, util


def _child_class(util: Any, parent: int, name: bytes) -> int | None:
    """The child ``AVClass`` named ``name`` of the one at ``parent`` (an ``AVClass``
    begins with its name), or None."""
    for child in _children(util, parent):
        if ctypes.c_char_p.from_address(child).value == name:
            return child
    return None


def _children(util: Any, parent: int) -> Iterator[int]:
    """The child classes of the ``AVClass`` at ``parent``."""
    if hasattr(util, "av_opt_child_class_iterate"):  # FFmpeg 4.4 and later
        state = ctypes.c_void_p()
        while child := util.av_opt_child_class_iterate(
            ctypes.c_void_p(parent), ctypes.byref(state)
        ):
            yield child
    elif hasattr(util, "av_opt_child_class_next"):  # before
        child = None
        while child := util.av_opt_child_class_next(
            ctypes.c_void_p(parent), ctypes.c_void_p(child)
        ):
            yield child


def _names(util: Any, cls: int | None, flags: int = 0) -> set[str]:
    """The option names of the ``AVClass`` at ``cls``: its options (of all the ``flags``,
    ``AV_OPT_FLAG_*``), not the named constants of their values (``av_opt_find`` without a
    unit finds only options)."""
    if not cls:
        return set()
    obj = ctypes.c_void_p(cls)
    out: set[str] = set()
    prev = None
    while prev := util.av_opt_next(ctypes.byref(obj), prev):
        raw = _Option.from_address(prev).name
        if raw and util.av_opt_find(ctypes.byref(obj), raw, None, flags, _FAKE_OBJ) == prev:
            out.add(raw.decode("utf-8", "replace"))
    return out


@functools.cache
def input_options(format: str) -> InputOptions | None:
    """The options FFmpeg's input format ``format`` (``v4l2``, ``lavfi``, ``mov``) takes,
    or None where FFmpeg has no such input or its tables cannot be read."""
    libs = _libraries()
    if libs is None or not format or not format.isascii():  # FFmpeg's names are ASCII
        return None
    fmt, codec, util = libs
    pointer = fmt.av_find_input_format(format.split(",")[0].encode())
    if not pointer:
        return None
    found = _InputFormat.from_address(pointer)
    names = (found.name or b"").decode("utf-8", "replace").split(",")
    if format.split(",")[0] not in names:  # not the layout read above: take nothing on trust
        return None
    general = _names(util, fmt.avformat_get_class())
    if not found.flags & 1:  # AVFMT_NOFILE unset: it reads through a protocol
        opaque = ctypes.c_void_p()
        while protocol := fmt.avio_enum_protocols(ctypes.byref(opaque), 0):
            general |= _names(util, fmt.avio_protocol_get_class(protocol))
        # and every protocol's general ones (rw_timeout): FFmpeg's URLContext, a child of
        # AVIOContext, itself the first child of AVFormatContext
        avio = _child_class(util, fmt.avformat_get_class(), b"AVIOContext")
        general |= _names(util, avio and _child_class(util, avio, b"URLContext"))
    own = _names(util, found.priv_class)
    decoding = _names(util, codec.avcodec_get_class(), _DECODING)
    return InputOptions(
        format.split(",")[0], frozenset(own), frozenset(general - own), frozenset(decoding)
    )


@functools.cache
def decoder_options(decoder: str) -> frozenset[str] | None:
    """The own options of FFmpeg's decoder ``decoder`` (``h264``; its private class's), or
    None where there is no such decoder or its tables cannot be read."""
    libs = _libraries()
    if libs is None or not decoder:
        return None
    _, codec, util = libs
    found = codec.avcodec_find_decoder_by_name(decoder.encode())
    context = ctypes.c_void_p(codec.avcodec_alloc_context3(found) if found else None)
    if not context:
        return None
    try:  # a context's first child is its private data, which begins with its class
        private = util.av_opt_child_next(context, None)
        cls = ctypes.c_void_p.from_address(private).value if private else None
        return frozenset(_names(util, cls, _DECODING))
    finally:
        codec.avcodec_free_context(ctypes.byref(context))


def _some_decoder_takes(name: str) -> bool:
    """Whether any decoder's own options hold ``name`` (or the tables cannot be read)."""
    libs = _libraries()
    if libs is None:
        return True
    if not name.isascii():  # FFmpeg's names are ASCII (a name of other bytes holds surrogates)
        return False
    _, codec, util = libs
    search = _CHILDREN | _FAKE_OBJ
    cls = ctypes.c_void_p(codec.avcodec_get_class())
    return bool(util.av_opt_find(ctypes.byref(cls), name.encode(), None, _DECODING, search))


#: FFmpeg's general input and decoding options a message names as examples.
_EXAMPLES = ("probesize", "analyzeduration", "fflags", "rtbufsize", "threads")


def check_input_options(
    options: dict[str, str] | None, format: str | None, what: str, decoder: str | None = None
) -> None:
    """Refuse an option neither FFmpeg's input ``format`` nor its ``decoder`` takes, in one
    line naming it, the closest names, the format's and the decoder's own options and
    examples of the general ones. Without ``decoder`` (before the input is opened) an
    option some decoder takes is left to the check that names the decoder.

    Nothing is refused where ``format`` is None or its options cannot be read
    (:func:`input_options`), nor is a decoder's option where the decoder's cannot.

    Raises
    ------
    DataError
        ``{what}: the lavfi input takes no option 'x'; its own options: dumpgraph, ...``.
    """
    if not options or format is None:
        return
    known = input_options(format)
    if known is None:
        return
    private = None if decoder is None else decoder_options(decoder)
    for name in options:
        if name in known:
            continue
        if decoder is None:
            if _some_decoder_takes(name):  # checked once the input's decoder is known
                continue
        elif private is None or name in private:  # (where its tables can be read)
            continue
        names = sorted(known.own | known.general | known.decoding | (private or set()))
        close = difflib.get_close_matches(name, names, n=2)
        hint = f" (did you mean {' or '.join(close)}?)" if close else ""
        general = ", ".join(e for e in _EXAMPLES if e in known.general | known.decoding)
        own = ", ".join(sorted(known.own)) or "none"
        if private is None:
            taker, held = f"the {known.format} input takes", f"its own options: {own}"
        else:
            taker = f"the {known.format} input and its {decoder} decoder take"
            held = (
                f"the input's own options: {own}; the decoder's: "
                f"{', '.join(sorted(private)) or 'none'}"
            )
        raise DataError(
            f"{what}: {taker} no option {name!r}{hint}; {held}; FFmpeg's general input and "
            f"decoding options are taken too ({general}, ...)"
        )
