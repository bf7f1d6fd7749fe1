"""Stops of a command that Python drops (``topojax.cli._signals``)."""

from __future__ import annotations

import signal
import time

from topojax.cli._signals import sigterm_stops


def test_two_ctrl_cs_dropped_stop_the_command_once():
    """Two Ctrl-Cs dropped (pressed again while the first did nothing) are one stop: sent
    again, each stopped the command anew, the second part way through the clean-up of the
    first."""

    class DropsTheStop:
        def __del__(self):  # the handler runs here: its exception is dropped
            signal.raise_signal(signal.SIGINT)

    stops = 0
    try:
        with sigterm_stops([]):
            DropsTheStop()
            DropsTheStop()
            end = time.monotonic() + 2
            while time.monotonic() < end:  # the first stop's clean-up
                try:
                    time.sleep(0.01)
                except KeyboardInterrupt:
                    stops += 1
    except KeyboardInterrupt:  # not sent again before the block ended: it stands
        stops += 1
    assert stops == 1
