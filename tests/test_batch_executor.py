"""A given executor runs the CPU stages wherever its workers are: they may run in another
folder than the caller (a Dask worker started elsewhere), and must still write into the
caller's output folder."""

from __future__ import annotations

import json
import os
import warnings
from concurrent.futures import Executor, Future
from pathlib import Path

import pytest

from topojax import build_graphs

MAP = Path(__file__).resolve().parents[1] / "topojax" / "data" / "a_scan.png"


class _Elsewhere(Executor):
    """Runs each task at once, in the folder ``cwd``, as a worker started there would."""

    def __init__(self, cwd: Path) -> None:
        self.cwd = cwd

    def submit(self, fn, /, *args, **kwargs):
        future: Future = Future()
        here = os.getcwd()
        os.chdir(self.cwd)
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # the batch reads it from the future
            future.set_exception(exc)
        finally:
            os.chdir(here)
        return future


def test_a_relative_out_dir_is_the_callers_for_workers_in_another_folder(tmp_path, monkeypatch):
    (tmp_path / "caller").mkdir()
    (tmp_path / "worker").mkdir()
    monkeypatch.chdir(tmp_path / "caller")
    kw = dict(out_dir="out", formats="json", progress=False)
    [rec] = build_graphs([MAP], executor=_Elsewhere(tmp_path / "worker"), **kw)
    assert rec.status == "ok", rec.message
    assert not (tmp_path / "worker" / "out").exists()
    manifest = json.loads(Path("out/a_scan.manifest.json").read_text(encoding="utf-8"))
    assert all(Path("out", rel).is_file() for rel in manifest["files"])
    # so a resumed run finds the files, and skips the map
    [again] = build_graphs([MAP], executor=_Elsewhere(tmp_path / "worker"), resume=True, **kw)
    assert again.status == "skipped", again.message


def test_workers_given_with_an_executor_are_warned_of(tmp_path):
    """The executor's own workers run the maps: a count given beside it does nothing,
    which the caller is told, as the command line tells --workers beside --scheduler."""
    with pytest.warns(UserWarning, match=r"workers: not used with executor= \(received 3\)"):
        [rec] = build_graphs([MAP], executor=_Elsewhere(tmp_path), workers=3, progress=False)
    assert rec.status == "ok", rec.message
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        [rec] = build_graphs([MAP], executor=_Elsewhere(tmp_path), progress=False)


@pytest.mark.parametrize("kind", ["thread", "process"])
def test_an_executor_that_is_shut_down_is_refused_before_any_map(tmp_path, kind):
    """An executor that takes no more tasks (shut down, or a closed Dask client) is refused
    naming ``executor``, not turned into one error row per map after the kernels ran."""
    from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

    executor = (ThreadPoolExecutor if kind == "thread" else ProcessPoolExecutor)(1)
    executor.shutdown()
    out = tmp_path / "out"
    with pytest.raises(ValueError, match=r"^executor: expected an executor that takes tasks"):
        build_graphs([MAP], executor=executor, out_dir=out, progress=False)
    assert not out.exists() or not any(out.iterdir())
