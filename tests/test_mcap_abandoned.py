"""The hidden folder a recorder builds its recording in, left behind when its process is
killed (SIGKILL), is removed by the next recorder of the same file; the folder of a
recorder still recording is not."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rosbags")

from topojax.io.mcap import McapRecorder  # noqa: E402
from topojax.playback import replay  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
INTEL_EXCERPT = REPO / "tests" / "data" / "intel_first40.log.gz"
pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="flock: POSIX only")


def killed_recording(path: Path) -> None:
    """Open a recorder of ``path`` in another process and kill that process (SIGKILL)
    while it records."""
    code = (
        "import os, signal, sys\n"
        "from topojax.io.mcap import McapRecorder\n"
        "McapRecorder(sys.argv[1]).open()\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), *sys.path])}
    done = subprocess.run([sys.executable, "-c", code, str(path)], env=env, check=False)
    assert done.returncode == -9


def temporaries(path: Path) -> list[Path]:
    return sorted(path.parent.glob(f".{path.name}.*"))


def test_a_killed_recorders_folder_is_removed_by_the_next_recorder(tmp_path):
    path = tmp_path / "run.mcap"
    killed_recording(path)
    assert len(temporaries(path)) == 1
    foreign = tmp_path / ".run.mcap.not-a-recorders"  # no lock file: left as it is
    foreign.mkdir()
    with McapRecorder(path):
        pass
    assert path.is_file() and temporaries(path) == [foreign]


def test_an_abandoned_folder_of_another_file_is_left_to_that_files_recorder(tmp_path):
    other = tmp_path / "run.mcap.old.mcap"  # its folders start ".run.mcap." too
    killed_recording(other)
    (left,) = temporaries(other)
    with McapRecorder(tmp_path / "run.mcap"):
        pass
    assert left.is_dir()
    with McapRecorder(other):
        pass
    assert not left.exists()


def test_the_folder_of_a_recorder_still_recording_is_left(tmp_path):
    path = tmp_path / "run.mcap"
    first = McapRecorder(path).open()
    (live,) = temporaries(path)
    with McapRecorder(path):
        assert live.is_dir()
    assert live.is_dir()
    first.close()
    assert temporaries(path) == []


def test_a_replay_after_one_killed_while_recording_leaves_no_temporary(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    path = out / "run.mcap"
    killed_recording(path)
    replay(INTEL_EXCERPT, out_dir=out, progress=False, max_scans=10, mcap=path)
    assert path.is_file() and temporaries(path) == []
