"""A replay that skips many scans (each refused as beyond the mapper's bounds) keeps a
bounded record of them: the count, the count per bound met, and the refusals of the
first :data:`KEPT_REFUSALS` and of the latest, in memory, in its saved states and in its
summary, however long the log; a resume gives the summary of a replay that never
stopped.  A saved state whose counters are absurd is refused as it is loaded."""

from __future__ import annotations

import gzip
import json
import re
import zipfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import topojax._replay_skips
import topojax._replay_state
import topojax.scans
from topojax._replay_skips import KEPT_REFUSALS, SkippedScans
from topojax.cli import main
from topojax.playback import STATE_FILE, replay

INTEL_EXCERPT = Path(__file__).parent / "data" / "intel_first40.log.gz"
SETTINGS = {"graph_every": 7, "skeleton_every": 3}
OUTPUTS = ("graph.json", "graph.graphml", "graph.geojson", "map.pgm", "map.yaml")
#: Scans of :func:`far_log` near the start, then far off (refused), then near again.
NEAR, FAR, AFTER = 12, 150, 3
#: What a summary says of the skipped scans.
SKIPPED_KEYS = (
    "n_scans",
    "n_skipped",
    "skipped_scans",
    "skipped_bounds",
    "skipped_per_bound",
    "skipped_left_out",
    "vertices",
    "edges",
)


def far_log(path: Path, far: int = FAR) -> Path:
    """A CARMEN log of the excerpt's scans (cycled), ``NEAR`` where they were, then
    ``far`` with the pose 5 km off (each refused as beyond ``max_extent_m``), then
    ``AFTER`` where they were; a scan every 25 ms."""
    lines = gzip.open(INTEL_EXCERPT, "rt").read().splitlines()
    laser = [line.split() for line in lines if line.startswith("FLASER")]
    out = ["ODOM 0 0 0 0 0 0 0.000000 nohost 0.000000"]
    for i in range(NEAR + far + AFTER):
        fields = list(laser[i % len(laser)])
        n = int(fields[1])
        if NEAR <= i < NEAR + far:
            for k in (2 + n, 5 + n):  # x, and odometry x
                fields[k] = f"{float(fields[k]) + 5000.0:g}"
        fields[8 + n] = fields[10 + n] = f"{1 + i * 0.025:.6f}"
        out.append(" ".join(fields))
    path.write_text("\n".join(out) + "\n")
    return path


def named(refusal: str) -> int:
    """The index in the log of the scan a refusal names."""
    return int(re.match(r"scan (\d+) of the log ", refusal)[1])


def assert_same_outputs(a: Path, b: Path) -> None:
    for name in OUTPUTS:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.fixture(scope="module")
def far(tmp_path_factory):
    """The far log, and the folder and summary of its replay that did not stop."""
    folder = tmp_path_factory.mktemp("far")
    log = far_log(folder / "far.log")
    out = folder / "whole"
    return log, out, replay(log, out_dir=out, progress=False, **SETTINGS)


def test_a_long_skipping_replay_keeps_the_first_refusals_and_the_latest(far):
    log, out, summary = far
    assert summary["n_scans"] == NEAR + AFTER and summary["n_skipped"] == FAR
    assert summary["skipped_per_bound"] == {"max_extent_m": FAR}
    kept = summary["skipped_scans"]
    assert len(kept) == KEPT_REFUSALS + 1 < FAR
    assert [named(r) for r in kept] == [*range(NEAR, NEAR + KEPT_REFUSALS), NEAR + FAR - 1]
    assert summary["skipped_bounds"] == ["max_extent_m"] * len(kept)
    assert summary["skipped_left_out"] == FAR - KEPT_REFUSALS - 1
    written = json.loads((out / "timings.json").read_text())
    assert {k: written[k] for k in SKIPPED_KEYS} == {k: summary[k] for k in SKIPPED_KEYS}
    line = next(m for m in summary["messages"] if m.startswith("skipped"))
    total = NEAR + FAR + AFTER
    assert line.startswith(
        f"skipped {FAR} of {total} scans, each refused as beyond the mapper's bounds "
        "(max_extent_m) and not mapped; "
    )
    assert (
        f"the refusals of the first {KEPT_REFUSALS} and of the latest "
        f"(skipped_scans; the other {FAR - KEPT_REFUSALS - 1} are left out)" in line
    )
    assert f"the first: scan {NEAR} of the log" in line


def test_the_summary_and_the_state_stay_the_same_size_however_many_scans_are_skipped(
    tmp_path, monkeypatch
):
    """Three times as many skipped scans: the same refusals kept (but the latest), so
    the same size of ``timings.json``'s skipped scans and of the state's record."""
    sizes = []
    for n in (FAR, 3 * FAR):
        log = far_log(tmp_path / f"far{n}.log", far=n)
        stopped = tmp_path / f"stopped{n}"
        stop_at(monkeypatch, NEAR + n, KeyboardInterrupt)
        with pytest.warns(RuntimeWarning, match="resume"), pytest.raises(KeyboardInterrupt):
            replay(log, out_dir=stopped, progress=False, **SETTINGS)
        monkeypatch.undo()
        record = saved_record(stopped)
        assert record["n_skipped"] == n and len(record["skipped"]) == KEPT_REFUSALS + 1
        summary = replay(log, out_dir=tmp_path / f"o{n}", progress=False, **SETTINGS)
        text = json.dumps({k: summary[k] for k in SKIPPED_KEYS})
        sizes.append((len(json.dumps(record)), len(text)))
    (record_a, summary_a), (record_b, summary_b) = sizes
    assert abs(record_b - record_a) < 20 and abs(summary_b - summary_a) < 20


def stop_at(monkeypatch, after: int, stop: type[BaseException]) -> None:
    """Make replay's reader raise ``stop`` when asked for scan ``after`` (once)."""
    real = topojax.scans.read_scans

    def reader(source, **kw):
        monkeypatch.setattr(topojax.scans, "read_scans", real)
        for i, scan in enumerate(real(source, **kw)):
            if i == after:
                raise stop
            yield scan

    monkeypatch.setattr(topojax.scans, "read_scans", reader)


class Killed(BaseException):
    """A kill in the process: nothing the replay does on an error or interrupt runs."""


def saved_record(out: Path) -> dict:
    with np.load(out / STATE_FILE) as data:
        return json.loads(str(data["replay"]))


def rewrite_record(out: Path, change) -> None:
    """Rewrite the replay record of the state saved in ``out`` as ``change(record)``
    returns it (and the mapper's ``counters`` as ``change`` leaves ``record["_counters"]``)."""
    path = out / STATE_FILE
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    record = json.loads(str(arrays["replay"]))
    record["_counters"] = [int(v) for v in arrays["counters"]]
    record = change(record)
    arrays["counters"] = np.asarray(record.pop("_counters"), np.int64)
    arrays["replay"] = np.asarray(json.dumps(record))
    with zipfile.ZipFile(path, "w") as zf:
        for key, value in arrays.items():
            with zf.open(key + ".npy", "w") as fh:
                np.lib.format.write_array(fh, np.asarray(value), allow_pickle=False)


def test_a_resume_from_a_checkpoint_past_the_kept_refusals_gives_the_same_summary(
    tmp_path, monkeypatch, far
):
    """Killed after a checkpoint saved after scan 140 (128 skipped: more than kept),
    the resumed replay's summary and files are those of the replay that did not stop."""
    log, whole, full = far
    clock = SimpleNamespace(now=0.0)
    real = topojax.scans.read_scans

    def reader(source, **kw):
        monkeypatch.setattr(topojax.scans, "read_scans", real)
        for i, scan in enumerate(real(source, **kw)):
            if i == 150:
                raise Killed
            clock.now += 10
            yield scan

    monkeypatch.setattr(topojax.scans, "read_scans", reader)
    monkeypatch.setattr(topojax._replay_state, "time", SimpleNamespace(monotonic=lambda: clock.now))
    out = tmp_path / "out"
    with pytest.raises(Killed):
        replay(log, out_dir=out, progress=False, checkpoint_every_s=1395, **SETTINGS)
    monkeypatch.undo()
    record = saved_record(out)
    assert record["checkpoint"] is True and record["consumed"] == 140
    assert record["n_skipped"] == 140 - NEAR and record["mapped"] == NEAR
    assert record["skipped_per_bound"] == {"max_extent_m": 140 - NEAR}
    assert [named(r) for r in record["skipped"]] == [*range(NEAR, NEAR + KEPT_REFUSALS), 139]
    assert record["skipped_bounds"] == ["max_extent_m"] * (KEPT_REFUSALS + 1)
    summary = replay(log, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert summary["resumed_after"] == 140
    assert {k: summary[k] for k in SKIPPED_KEYS} == {k: full[k] for k in SKIPPED_KEYS}
    assert summary["messages"][-1] == full["messages"][-1]  # the skipped scans' line
    assert_same_outputs(whole, out)


def test_a_resume_from_a_state_that_lists_every_refusal_gives_the_same_summary(
    tmp_path, monkeypatch, far
):
    """A state in the older format, which lists every refusal (and no counts), resumes
    to the summary of a replay that did not stop."""
    log, whole, full = far
    out = tmp_path / "out"
    monkeypatch.setattr(topojax._replay_skips, "KEPT_REFUSALS", 10**6)  # keeps them all
    stop_at(monkeypatch, 140, KeyboardInterrupt)
    with pytest.warns(RuntimeWarning, match="resume"), pytest.raises(KeyboardInterrupt):
        replay(log, out_dir=out, progress=False, **SETTINGS)
    monkeypatch.undo()

    def older(record):
        del record["n_skipped"], record["skipped_per_bound"]
        assert [named(r) for r in record["skipped"]] == list(range(NEAR, 140))
        return record

    rewrite_record(out, older)
    summary = replay(log, out_dir=out, progress=False, resume=True, **SETTINGS)
    assert {k: summary[k] for k in SKIPPED_KEYS} == {k: full[k] for k in SKIPPED_KEYS}
    assert summary["messages"][-1] == full["messages"][-1]
    assert_same_outputs(whole, out)


def test_the_command_says_how_many_refusals_it_left_out(far, tmp_path, capsys):
    log = far[0]
    argv = ["replay", str(log), "-o", str(tmp_path / "o"), "--no-progress"]
    assert main([*argv, "--graph-every", "7", "--skeleton-every", "3"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("skipped"))
    assert f"skipped {FAR} of " in line and "(--max-extent-m) and not mapped" in line
    assert f"the other {FAR - KEPT_REFUSALS - 1} are left out" in line


def test_the_skipped_scans_kept_stay_bounded_however_many():
    skipped = SkippedScans()
    for i in range(10_000):
        skipped.skip(f"scan {i} of the log: refused", "max_tile_bytes" if i % 4 else "max_extent_m")
    assert skipped.count == 10_000 and skipped.left_out == 10_000 - KEPT_REFUSALS - 1
    assert skipped.per_bound == {"max_extent_m": 2500, "max_tile_bytes": 7500}
    assert len(skipped.texts) == len(skipped.bounds) == KEPT_REFUSALS + 1
    assert skipped.texts[-1] == "scan 9999 of the log: refused"
    assert skipped.texts[KEPT_REFUSALS - 1] == f"scan {KEPT_REFUSALS - 1} of the log: refused"


# ---- a saved state whose counters are absurd is refused as it is loaded


@pytest.fixture
def stopped(tmp_path, monkeypatch):
    """The state of a replay of the excerpt (scans beyond max_extent_m=46 skipped),
    stopped after 20 scans."""
    out = tmp_path / "out"
    stop_at(monkeypatch, 20, KeyboardInterrupt)
    with pytest.warns(RuntimeWarning, match="resume"), pytest.raises(KeyboardInterrupt):
        replay(INTEL_EXCERPT, out_dir=out, progress=False, max_extent_m=46, **SETTINGS)
    monkeypatch.undo()
    record = saved_record(out)
    assert record["consumed"] == 20 and 1 < record["n_skipped"] < 20
    return out


def _set(key, value):
    def change(record):
        record[key] = value
        return record

    return change


def _bounds(bounds):
    def change(record):
        record["skipped_bounds"] = bounds * len(record["skipped"])
        return record

    return change


def _far_off_mapper(record):  # the mapper's scan count and the record's, consistent
    record["_counters"][0] = record["mapped"] = 10**15
    record["consumed"] = 10**15 + record["n_skipped"]
    return record


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_set("consumed", 10**15), r"consumed: expected an integer from 0 to 10\*\*12 .*received 10{15}"),
        (_set("consumed", -1), r"consumed: expected an integer from 0 to .*received -1"),
        (_set("consumed", 12.5), r"consumed: expected an integer .*received 12\.5"),
        (_set("consumed", "20"), r"consumed: expected an integer .*received '20'"),
        (_set("consumed", True), r"consumed: expected an integer .*received True"),
        (_set("consumed", 19), r"consumed: expected the scans mapped \(mapped, \d+\) and skipped \(n_skipped, \d+\), \d+, received 19"),
        (_set("mapped", 10**15), r"mapped: expected an integer from 0 to .*received 10{15}"),
        (_set("mapped", 13), r"mapped: expected the n_scans of the saved mapper \(\d+\), received 13"),
        (_set("mapped", -2), r"mapped: expected an integer from 0 to .*received -2"),
        (_set("n_skipped", 10**15), r"n_skipped: expected an integer from 0 to .*received 10{15}"),
        (_set("n_skipped", 2.0), r"n_skipped: expected an integer .*received 2\.0"),
        (_set("n_skipped", None), r"n_skipped: expected an integer .*received None"),
        (_set("skipped_per_bound", {"max_extent_m": 10**15}), r"skipped_per_bound\['max_extent_m'\]: expected an integer from 0 to .*received 10{15}"),
        (_set("skipped_per_bound", {"max_extent_m": 1}), r"skipped_per_bound: expected counts that add up to n_skipped \(\d+\), received \{'max_extent_m': 1\}"),
        (_set("skipped_per_bound", {"max_extent_m": -1}), r"skipped_per_bound\['max_extent_m'\]: expected an integer from 0 to .*received -1"),
        (_set("skipped_per_bound", {"nowhere": 1}), r"skipped_per_bound: expected the bounds .*received 'nowhere'"),
        (_set("skipped_per_bound", [1]), r"skipped_per_bound: expected an object of counts .*received \[1\]"),
        (_set("skipped", "refused"), r"skipped: expected a list of refusals .*received 'refused'"),
        (_set("skipped", [1, 2]), r"skipped: expected a list of refusals .*received \[1, 2\]"),
        (_bounds(["nowhere"]), r"skipped_bounds: expected .*received \['nowhere'"),
        (_bounds([]), r"skipped_bounds: expected as many bounds as refusals \(\d+\), received 0"),
        (_set("checkpoint", "yes"), r"checkpoint: expected true or false, received 'yes'"),
    ],
)  # fmt: skip
def test_a_state_with_absurd_counters_is_refused_naming_the_field(stopped, change, message):
    rewrite_record(stopped, change)
    with pytest.raises(
        ValueError, match=f"resume: {re.escape(str(stopped / STATE_FILE))}: {message}"
    ):
        replay(
            INTEL_EXCERPT, out_dir=stopped, progress=False, resume=True, max_extent_m=46, **SETTINGS
        )


def test_a_state_whose_mapper_and_record_agree_on_too_many_scans_is_refused(stopped):
    """The record's counts are checked against the mapper's n_scans; a mapper's count
    beyond 10**12 is refused by the mapper's own load, naming its field."""
    rewrite_record(stopped, _far_off_mapper)
    with pytest.raises(
        ValueError,
        match=r"mapper state: counters \(n_scans\): expected an integer from 0 to "
        r"1000000000000 .*received 1\d{15}",
    ):
        replay(
            INTEL_EXCERPT, out_dir=stopped, progress=False, resume=True, max_extent_m=46, **SETTINGS
        )


def test_a_state_with_more_skipped_refusals_than_skipped_scans_is_refused(stopped):
    def more(record):
        record["n_skipped"] = len(record["skipped"]) - 1
        record["skipped_per_bound"] = {"max_extent_m": record["n_skipped"]}
        record["consumed"] = record["mapped"] + record["n_skipped"]
        return record

    rewrite_record(stopped, more)
    with pytest.raises(ValueError, match=r"skipped: expected at most n_skipped \(\d+\) refusals"):
        replay(
            INTEL_EXCERPT, out_dir=stopped, progress=False, resume=True, max_extent_m=46, **SETTINGS
        )


def test_the_untouched_state_resumes(stopped):
    """The rewriting itself leaves a state that resumes."""
    rewrite_record(stopped, lambda record: record)
    summary = replay(
        INTEL_EXCERPT, out_dir=stopped, progress=False, resume=True, max_extent_m=46, **SETTINGS
    )
    assert summary["n_scans"] + summary["n_skipped"] == 40
