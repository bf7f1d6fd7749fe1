"""Shared pytest fixtures."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

# The command keeps JAX's compiled kernels on disk (topojax.cli): tests that call it in
# this process must neither change JAX's settings for the tests after them nor write to
# the home directory.  The test of the cache runs the command in a subprocess.
os.environ.setdefault("TOPOJAX_NO_JAX_CACHE", "1")

# Hypothesis times the garbage collector with a gc callback from its first test on.  A
# Ctrl-C that a signal test sends to this process and that comes while the collector
# runs is raised inside that callback, where Python drops it, and the test then waits
# for a stop that never comes.  The timing serves deadlines, which no test here sets
# (every @settings has deadline=None), so the callback is not installed.
try:
    from hypothesis.internal.conjecture import junkdrawer as _hypothesis_internals
except ImportError:  # pragma: no cover - hypothesis is a test requirement
    pass
else:
    _hypothesis_internals._gc_initialized = True

# A suite started in the background of a shell without job control (``cmd &`` in a
# script, ``nohup``) inherits SIGINT ignored, and Python then leaves it ignored: the tests
# of what a Ctrl-C does, here and in the commands they start, would wait for a stop that
# never comes.  Ctrl-C is given back its Python handler, as in a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Root of the project's shared real-data folder (``../shared/data``); skip if absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data folder not found at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture(scope="session")
def paper_reference(shared_data: Path):
    """Loader for the original implementation's reference outputs, keyed by map name."""
    import numpy as np

    cache: dict[str, dict] = {}

    def load(name: str) -> dict:
        if name not in cache:
            path = shared_data / "reference" / f"original_{name}.npz"
            if not path.is_file():
                pytest.skip(f"reference file missing: {path}")
            with np.load(path) as z:
                cache[name] = {k: z[k] for k in z.files}
        return cache[name]

    return load


@pytest.fixture
def read_only_folder(tmp_path, monkeypatch) -> Path:
    """A folder that takes no new file or folder, as on a read-only file system (the
    tests may run as root, whom permissions do not stop): ``tempfile.mkstemp`` and
    ``tempfile.mkdtemp`` in it fail as the system would, with EROFS."""
    import errno
    import tempfile

    folder = tmp_path / "read_only"
    folder.mkdir()

    def refusing(real):
        def refuse(*args, dir=None, **kwargs):
            if dir is not None and Path(dir).resolve().is_relative_to(folder.resolve()):
                raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(dir))
            return real(*args, dir=dir, **kwargs)

        return refuse

    monkeypatch.setattr(tempfile, "mkstemp", refusing(tempfile.mkstemp))
    monkeypatch.setattr(tempfile, "mkdtemp", refusing(tempfile.mkdtemp))
    return folder
