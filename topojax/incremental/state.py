"""Saved mapper states: format name and version."""

from __future__ import annotations

#: ``format`` field of saved mapper states.
STATE_FORMAT = "topojax.IncrementalMapper"


#: Version of the saved-state layout; :meth:`IncrementalMapper.load` accepts only this one.
STATE_VERSION = 2
