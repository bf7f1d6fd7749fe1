"""Command line: ``topojax graph``, ``topojax demo``, ``topojax route``,
``topojax route-graph``, ``topojax rooms``, ``topojax replay``, ``topojax batch``,
``topojax view``."""

from __future__ import annotations

import argparse
import contextlib
import difflib
import errno
import os
import re
import signal
import sys
import warnings

from .. import __version__
from . import batch, graph, replay, rooms, route, route_graph, view
from ._signals import sigterm_stops

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The ``topojax`` argument parser; building it imports no JAX, numba or readers."""
    parser = argparse.ArgumentParser(
        prog="topojax",
        description="Topology (route) graphs from 2-D robot maps via Gaussian distance maps.",
        epilog="Compiled JAX kernels are kept in $XDG_CACHE_HOME/topojax/jax (default "
        "~/.cache/topojax/jax) unless JAX_COMPILATION_CACHE_DIR is set; "
        "TOPOJAX_NO_JAX_CACHE=1 turns that off.",
    )
    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}", help="print the version"
    )
    sub = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=_CommandParser
    )

    graph.add_commands(sub)
    route.add_command(sub)
    route_graph.add_command(sub)
    rooms.add_command(sub)
    replay.add_command(sub)
    batch.add_command(sub)
    view.add_command(sub)
    return parser


class _CommandParser(argparse.ArgumentParser):
    """The parser of one command: an argument it does not know is an error under the
    command's own usage line and name (``topojax route-graph: error: ...``, not the
    ``topojax`` ones), which suggests the command's closest option to a mistyped one."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # a word that writes a negative number in any notation is a value, taken verbatim
        self._negative_number_matcher = _NEGATIVE

    def parse_known_args(self, args=None, namespace=None):
        namespace, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(_unrecognized_text(extras, self._option_string_actions))
        for action in self._actions:
            if action.dest in _PATHS and getattr(namespace, action.dest, None) == "":
                name = "/".join(action.option_strings) or action.metavar or action.dest
                self.error(f"argument {name}: expected a path, received an empty one ('')")
        return namespace, extras


#: The arguments that name a file or folder and that nothing else checks to be a word:
#: ``-o ""`` would be the current folder, ``route -o ""`` or ``--map ""`` no file at all,
#: each taken without a word said (``--mcap`` and the inputs say it themselves).
_PATHS = frozenset({"out", "map", "graph", "folder", "source", "animate"})


#: A negative number in any notation ``float`` reads: ``-1e-05``, ``-3E+5``, ``-5.``,
#: ``-.5``, ``-1_000``, ``-1e500``, ``-inf``, ``-nan``.  argparse's own pattern takes only
#: ``-5`` and ``-0.5`` for numbers, and any other word that starts with a dash for an
#: option (``--start -1e-05 2`` failed with ``expected 2 arguments``).
_NEGATIVE = re.compile(
    r"-(\d[\d_]*\.?[\d_]*|\.\d[\d_]*)([eE][-+]?\d[\d_]*)?\Z|-(inf|infinity|nan)\Z", re.IGNORECASE
)


def _unrecognized_text(extras: list[str], options) -> str:
    """The error of the arguments ``extras`` that no option or positional argument took,
    with the closest of ``options`` (a command's option strings) to each that looks like
    an option (``--snapm 1``: ``did you mean --snap-m?``)."""
    hints = []
    for word in extras:
        name = word.split("=", 1)[0]
        if name.startswith("--"):  # compared without the dashes that every one has
            close = difflib.get_close_matches(
                name[2:], [o[2:] for o in options if o[:2] == "--"], 1
            )
            hints += [f"{name}: did you mean --{close[0]}?"] if close else []
    text = f"unrecognized arguments: {' '.join(extras)}"
    return f"{text} ({'; '.join(hints)})" if hints else text


def _use_compilation_cache() -> None:
    """Keep the compiled JAX kernels on disk between runs of the command.

    Each run of the command is a fresh process; without a persistent cache it compiles
    the kernels again (about half a second of a ``topojax graph`` run).  JAX's own
    settings win: ``JAX_COMPILATION_CACHE_DIR`` chooses the directory (default
    ``$XDG_CACHE_HOME/topojax/jax``, i.e. ``~/.cache/topojax/jax``) and
    ``JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS`` the threshold (default here 0: every
    kernel is kept); ``TOPOJAX_NO_JAX_CACHE=1`` turns the cache off.  Library calls never
    change JAX's settings; only the command does.
    """
    if os.environ.get("TOPOJAX_NO_JAX_CACHE", "") not in ("", "0"):
        return
    import jax

    if not os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        jax.config.update("jax_compilation_cache_dir", os.path.join(base, "topojax", "jax"))
    if not os.environ.get("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"):
        # the kernels compile in well under JAX's default threshold of one second, so
        # without this nothing would be cached
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


#: The errors of a disk that is full or fails (no space, quota, file size, I/O): the
#: command ends with status 1, as out of memory, not the usage status 2.
_DISK_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO})


def _message(exc: Exception) -> str:
    """The text of a command's error: an ``OSError`` made from a number and a message
    that names the option (``--out: cannot make the folder ...``) without the number's
    ``[Errno 30]`` before it."""
    if isinstance(exc, OSError) and exc.filename is None and isinstance(exc.strerror, str):
        return exc.strerror
    return str(exc)


def _out_of_memory(exc: Exception) -> bool:
    """Whether ``exc`` says the process could not get memory: a MemoryError (numpy's
    "Unable to allocate ..."), or OpenCV's "Insufficient memory" error (OpenCV is looked
    up, not imported: building the parser imports no reader)."""
    if isinstance(exc, MemoryError):
        return True
    cv2 = sys.modules.get("cv2")
    error = getattr(cv2, "error", None)
    return isinstance(error, type) and isinstance(exc, error) and "Insufficient memory" in str(exc)


def _drop_tracebacks(exc: BaseException | None) -> None:
    """Let go of the frames of ``exc`` and of the exceptions it was raised from or
    during, and with them of what the failed work held."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        exc.__traceback__ = None
        exc = exc.__cause__ or exc.__context__


def _out_of_memory_message(exc: Exception) -> str:
    from .._cpus import MemoryRefusal

    if isinstance(exc, MemoryRefusal):  # refused before the work: it says what to do
        return str(exc)
    detail = str(exc).strip().splitlines()[-1:] or [type(exc).__name__]
    return (
        f"out of memory ({detail[0]}): the work grows with the map's pixels "
        "(bytes per pixel: docs/performance.md); free memory, or crop or coarsen the map "
        "(the topology graph of a map larger than memory: topojax graph --tiled, "
        "docs/large-maps.md)"
    )


@contextlib.contextmanager
def _warnings_as_lines(command: str):
    """Within: a warning shown is one line on standard error, ``topojax COMMAND: warning:
    MESSAGE``, as the command's errors are (not Python's ``file:line: Category:`` form
    with the source line).  Which warnings are shown is left to the filters
    (``-W``, ``PYTHONWARNINGS``)."""

    def show(message, category, filename, lineno, file=None, line=None):
        stream = sys.stderr if file is None else file
        if stream is not None:
            with contextlib.suppress(OSError, ValueError):  # closed: nowhere to say it
                print(f"topojax {command}: warning: {message}", file=stream)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``topojax`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    stopped: list[signal.Signals] = []
    try:
        with sigterm_stops(stopped), _warnings_as_lines(args.command):
            if getattr(args, "runs_kernels", True):  # route only reads a graph: no JAX
                _use_compilation_cache()  # imports JAX: seconds a Ctrl-C may come in
            return int(args.handler(args) or 0)
    except (ValueError, TypeError, FileNotFoundError, OSError) as exc:
        print(f"topojax {args.command}: error: {_message(exc)}", file=sys.stderr)
        # 2 is a usage error (argparse's status); a disk that filled or failed is not one
        return 1 if isinstance(exc, OSError) and exc.errno in _DISK_ERRNOS else 2
    except Exception as exc:
        if not _out_of_memory(exc):
            raise
        _drop_tracebacks(exc)  # their frames hold the memory of the work that failed
        print(f"topojax {args.command}: error: {_out_of_memory_message(exc)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # the command's clean-up has run; no traceback
        if stopped:
            print(f"topojax {args.command}: stopped by SIGTERM", file=sys.stderr)
            return 128 + signal.SIGTERM
        print(f"topojax {args.command}: interrupted (Ctrl-C)", file=sys.stderr)
        return 130
