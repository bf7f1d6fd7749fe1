"""How a replay names the scans the mapper refused (skipped, the replay goes on): each by
its index in the log, and the summary by the bounds the refusals met."""

from __future__ import annotations

import re
from pathlib import Path

from topojax.cli import main
from topojax.incremental import IncrementalMapper
from topojax.playback import replay
from topojax.scans import read_scans

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"
#: Bytes of one of the default mapper's tiles.
TILE_BYTES = IncrementalMapper()._tiles.tile_nbytes


def test_each_skipped_scan_is_named_by_its_index_in_the_log(tmp_path):
    """Refused scans after the first are not the mapper's (it counts the scans it added),
    so each refusal names the scan by its index in the log: the scan with that index
    has the refusal's timestamp, and no two refusals name the same scan."""
    summary = replay(INTEL_EXCERPT, out_dir=tmp_path / "o", progress=False, max_extent_m=46)
    skipped = summary["skipped_scans"]
    assert len(skipped) > 1 and summary["n_scans"] == 40 - len(skipped)
    stamps = [s.timestamp for s in read_scans(INTEL_EXCERPT)]
    named = []
    for refusal in skipped:
        index, stamp = re.match(
            r"scan (\d+) of the log \(timestamp ([\d.]+) s\): ", refusal
        ).groups()
        assert f"{stamps[int(index)]:.6f}" == stamp
        named.append(int(index))
    assert len(set(named)) == len(named)


def test_the_skipped_scans_line_names_the_bound_they_met(tmp_path, capsys):
    """Scans refused for the memory of the mapper's tiles (``max_tile_bytes``) are said
    to be so in the summary's line, not blamed on ``max_extent_m``."""
    out = tmp_path / "o"
    summary = replay(INTEL_EXCERPT, out_dir=out, progress=False, max_tile_bytes=50 * TILE_BYTES)
    assert len(summary["skipped_scans"]) > 1
    line = next(m for m in summary["messages"] if m.startswith("skipped"))
    assert "bounds (max_tile_bytes) and not mapped" in line
    assert "max_extent_m" not in line and "--max-extent-m" not in line


def test_the_skipped_scans_line_of_the_command_names_its_option(tmp_path, capsys):
    """``topojax replay`` words the line of scans refused as beyond ``--max-extent-m`` with
    its option, as before, and names the scans by their index in the log."""
    args = ["replay", str(INTEL_EXCERPT), "-o", str(tmp_path / "o"), "--no-progress"]
    assert main([*args, "--max-extent-m", "46"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("skipped"))
    assert "bounds (--max-extent-m) and not mapped" in line
    assert re.search(r"the first: scan \d+ of the log \(timestamp", line)
