"""Ctrl-C and SIGTERM held by the batch's main loop (``topojax.batch.interrupts``)."""

from __future__ import annotations

import os
import signal

import pytest

from topojax.batch.interrupts import HeldInterrupts


def _terminate(signum, frame):  # as the command's SIGTERM handler: a stop
    raise KeyboardInterrupt


@pytest.fixture
def sigterm_stops():
    """SIGTERM raises ``KeyboardInterrupt`` within the test; the handlers are the
    test's own again after it."""
    handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    signal.signal(signal.SIGTERM, _terminate)
    yield
    signal.signal(signal.SIGINT, handlers[0])
    signal.signal(signal.SIGTERM, handlers[1])


def test_a_stop_while_the_handlers_are_set_leaves_none_held(sigterm_stops, monkeypatch):
    """A SIGTERM that comes once Ctrl-C's handler is replaced stops the block before it
    starts, and Ctrl-C's own handler is set again: the one that holds would keep every
    later Ctrl-C for a block that never ends."""
    getsignal = signal.getsignal

    def sigterm_comes(signum):
        if signum == signal.SIGTERM:
            os.kill(os.getpid(), signal.SIGTERM)
        return getsignal(signum)

    monkeypatch.setattr(signal, "getsignal", sigterm_comes)
    with pytest.raises(KeyboardInterrupt), HeldInterrupts():
        pytest.fail("the block ran")
    monkeypatch.undo()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.getsignal(signal.SIGTERM) is _terminate


def test_a_stop_while_the_handlers_are_set_back_leaves_none_held(sigterm_stops, monkeypatch):
    """A Ctrl-C that comes once its own handler is back, as SIGTERM's is set back, stops
    the caller, and SIGTERM's handler is set back too: the one that holds would keep
    every later SIGTERM for a block that has ended."""
    set_handler = signal.signal
    sent = []

    def ctrl_c_comes(signum, handler):
        if signum == signal.SIGTERM and handler is _terminate and not sent:
            sent.append(signum)
            os.kill(os.getpid(), signal.SIGINT)
        return set_handler(signum, handler)

    with pytest.raises(KeyboardInterrupt), HeldInterrupts():
        monkeypatch.setattr(signal, "signal", ctrl_c_comes)
    monkeypatch.undo()
    assert sent
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.getsignal(signal.SIGTERM) is _terminate


def test_a_ctrl_c_as_work_run_at_once_starts_stops_it(sigterm_stops, monkeypatch):
    """A Ctrl-C that comes just after the held ones are delivered, as work that takes
    signals as they come starts, stops that work: held, it waited until the work ended."""
    held = HeldInterrupts()
    check = held.check
    ran = []

    def ctrl_c_comes():
        check()
        os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt), held:
        monkeypatch.setattr(held, "check", ctrl_c_comes)
        with held.at_once():
            ran.append("the work")
    assert not ran


def test_a_second_ctrl_c_while_a_stopped_batch_cleans_up_leaves_no_temporary_files(
    tmp_path, monkeypatch
):
    """A Ctrl-C that comes while a stopped batch shuts its pools down waits until the
    temporary files of the maps in flight are removed (raised there, it left them), and
    is not raised again: the batch ends with the first stop, its handlers set back."""
    from pathlib import Path

    import topojax
    from topojax import build_graphs
    from topojax.batch import driver

    out, planted = tmp_path / "out", []
    office = Path(topojax.__file__).parent / "data" / "office.png"

    def interrupt(self, fut):  # Ctrl-C as the first map's CPU stage ends
        for item, _, _ in self._cpu.values():  # as a killed write leaves them
            planted.append(out / f".{item.name}.graphml.k1ll3d.tmp")
            planted[-1].write_bytes(b"cut short")
        shutdown = self._kernel_pool.shutdown

        def ctrl_c_again(*args, **kwargs):  # the second Ctrl-C, during the clean-up
            os.kill(os.getpid(), signal.SIGINT)
            return shutdown(*args, **kwargs)

        self._kernel_pool.shutdown = ctrl_c_again
        raise KeyboardInterrupt

    monkeypatch.setattr(driver._BatchRun, "_on_cpu_done", interrupt)
    handler = signal.getsignal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        build_graphs([office] * 3, out_dir=out, workers=2, progress=False)
    assert planted
    assert not any(p.exists() for p in planted)
    assert signal.getsignal(signal.SIGINT) is handler


def test_a_stopped_batch_removes_the_finished_files_of_the_maps_in_flight(tmp_path, monkeypatch):
    """A map stopped after some of its files were written whole, before its manifest:
    those files go as a failed map's do.  Left, they passed for outputs that no manifest
    vouches for, and a picture left in a batch's input folder (``-o`` the same folder)
    was taken for a map by the next run."""
    from pathlib import Path

    import topojax
    from topojax import build_graphs
    from topojax.batch import driver

    out, written = tmp_path / "out", []
    office = Path(topojax.__file__).parent / "data" / "office.png"

    def interrupt(self, fut):  # Ctrl-C as the first map's CPU stage ends
        for item, _, _ in self._cpu.values():  # files a worker wrote whole, no manifest
            for suffix in (".json", "_graph.png"):
                written.append(out / f"{item.name}{suffix}")
                written[-1].write_bytes(b"complete")
        raise KeyboardInterrupt

    monkeypatch.setattr(driver._BatchRun, "_on_cpu_done", interrupt)
    with pytest.raises(KeyboardInterrupt):
        build_graphs(
            [office] * 3, out_dir=out, formats="json", plot=True, workers=2, progress=False
        )
    assert written
    assert not [p.name for p in written if p.exists()]
    assert not list(out.glob("*.manifest.json"))


def test_a_ctrl_c_in_the_cpu_stage_run_here_removes_the_maps_files(tmp_path, monkeypatch):
    """With ``workers=0`` a Ctrl-C while a map writes its files stops it there; the files
    it had written (no manifest lists them) go, as those of a map in a worker do."""
    from pathlib import Path

    import topojax
    import topojax.io
    from topojax import build_graphs

    out = tmp_path / "out"
    scan = Path(topojax.__file__).parent / "data" / "a_scan.png"
    save_graph = topojax.io.save_graph

    def save_then_ctrl_c(graph, path, **kwargs):
        written = save_graph(graph, path, **kwargs)
        os.kill(os.getpid(), signal.SIGINT)  # delivered at once: the stage runs here
        return written

    monkeypatch.setattr(topojax.io, "save_graph", save_then_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        build_graphs([scan], out_dir=out, formats="graphml,json", workers=0, progress=False)
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == []
