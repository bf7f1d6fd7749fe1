"""The scans a replay skipped, each refused as beyond the mapper's bounds
(:class:`~topojax.incremental.ExtentError`): how many, how many met each bound, and the
refusals of the first :data:`KEPT_REFUSALS` and of the latest, so that what a replay
keeps of them (in memory, in each state it saves, in its summary) stays bounded however
long the log stays beyond the bounds; and the checks of what a saved state records of
them and of the scans it took."""

from __future__ import annotations

from ._constants import MAX_LOG_SCANS
from .incremental import EXTENT_BOUNDS

#: The skipped scans whose refusals a replay keeps, besides the latest one's: 100
#: refusals of about 300 bytes take some 30 kB (in memory, in each saved state, in
#: ``timings.json``), little beside a mapper's state, and at 40 scans/s they span the
#: first 2.5 s of the log beyond the bounds: enough to see how a glitch starts (the
#: scans' indices, times and poses) and whether it ended; the latest shows where the
#: log stood at its last skipped scan.  The others are counted, not kept.
KEPT_REFUSALS = 100

#: The key of :attr:`SkippedScans.per_bound` that counts refusals whose bound is not
#: known (listed by a state saved by an older topojax, which did not record it).
UNKNOWN_BOUND = "unknown"


class SkippedScans:
    """The scans a replay skipped: ``count`` in all, ``per_bound`` (bound met ->
    scans; :data:`UNKNOWN_BOUND` where not known), and the refusals (``texts``) and
    bounds (``bounds``, None where not known) of the first :data:`KEPT_REFUSALS` and of
    the latest; ``left_out`` counts the refusals between, not kept."""

    __slots__ = ("_first", "_latest", "count", "per_bound")

    def __init__(self) -> None:
        self.count = 0
        self.per_bound: dict[str, int] = {}
        self._first: list[tuple[str, str | None]] = []
        self._latest: tuple[str, str | None] | None = None  # once one is left out

    def skip(self, refusal: str, bound: str | None) -> None:
        """Count a skipped scan: its ``refusal`` and the ``bound`` it met (None: not
        known)."""
        self.count += 1
        key = UNKNOWN_BOUND if bound is None else bound
        self.per_bound[key] = self.per_bound.get(key, 0) + 1
        if self._latest is None and len(self._first) < KEPT_REFUSALS:
            self._first.append((refusal, bound))
        else:
            self._latest = (refusal, bound)

    @property
    def _kept(self) -> list[tuple[str, str | None]]:
        return self._first + ([] if self._latest is None else [self._latest])

    @property
    def texts(self) -> list[str]:
        """The refusals kept: of the first :data:`KEPT_REFUSALS` skipped scans, then of
        the latest."""
        return [text for text, _ in self._kept]

    @property
    def bounds(self) -> list[str | None]:
        """The bound each refusal of :attr:`texts` met (None: not known)."""
        return [bound for _, bound in self._kept]

    @property
    def left_out(self) -> int:
        """The skipped scans whose refusals are not kept (those between the first and
        the latest)."""
        return self.count - len(self._first) - (self._latest is not None)

    @property
    def first_kept(self) -> int:
        """The skipped scans kept from the first: all kept but the latest, where some
        are left out."""
        return len(self._first)

    def record(self) -> dict:
        """What a saved state records of the skipped scans (:meth:`from_record`)."""
        return {
            "skipped": self.texts,
            "skipped_bounds": self.bounds,
            "n_skipped": self.count,
            "skipped_per_bound": ordered(self.per_bound),
        }

    @classmethod
    def from_record(cls, record: dict) -> SkippedScans:
        """The skipped scans a saved state's replay ``record`` holds: ``skipped`` (the
        refusals kept), ``skipped_bounds`` (the bound of each; absent or None where not
        known), ``n_skipped`` and ``skipped_per_bound``; in a state saved by an older
        topojax only ``skipped``, every refusal, and perhaps their bounds.  Raises
        ValueError naming the field, what was expected and what was received."""
        texts = record["skipped"]
        if not isinstance(texts, list) or not all(isinstance(t, str) for t in texts):
            raise ValueError(f"skipped: expected a list of refusals (text), received {texts!r}")
        bounds = _checked_bounds(record.get("skipped_bounds"), len(texts))
        skipped = cls()
        if "n_skipped" not in record:  # every refusal listed
            for text, bound in zip(texts, bounds, strict=True):
                skipped.skip(text, bound)
            return skipped
        count = scan_count(record, "n_skipped")
        if len(texts) > count or (count and not texts):
            raise ValueError(
                f"skipped: expected at most n_skipped ({count}) refusals, at least one if "
                f"any, received {len(texts)}"
            )
        skipped.count = count
        skipped.per_bound = _checked_per_bound(record.get("skipped_per_bound"), count)
        kept = list(zip(texts, bounds, strict=True))
        if len(texts) == count:  # none left out (or kept by a topojax that kept more)
            skipped._first = kept[:KEPT_REFUSALS]
            skipped._latest = kept[-1] if count > KEPT_REFUSALS else None
        else:
            skipped._first, skipped._latest = kept[:-1][:KEPT_REFUSALS], kept[-1]
        return skipped


def ordered(per_bound: dict[str, int]) -> dict[str, int]:
    """``per_bound`` in the order of :data:`EXTENT_BOUNDS`, :data:`UNKNOWN_BOUND` last."""
    keys = (*EXTENT_BOUNDS, UNKNOWN_BOUND)
    return {key: per_bound[key] for key in keys if key in per_bound}


def scan_count(record: dict, key: str) -> int:
    """``record[key]``, a count of scans of a log: an integer from 0 to
    :data:`MAX_LOG_SCANS`, else a ValueError naming ``key``."""
    return _count(key, record[key])


def _count(key: str, value) -> int:
    if type(value) is not int or not 0 <= value <= MAX_LOG_SCANS:
        raise ValueError(
            f"{key}: expected an integer from 0 to 10**12 (scans of a log; more would be "
            f"800 years of a laser at 40 scans/s), received {value!r}"
        )
    return value


def _checked_bounds(bounds, n: int) -> list[str | None]:
    """The bounds a record lists for its ``n`` refusals; None for each where it lists
    none (a state saved by an older topojax)."""
    if bounds is None:
        return [None] * n
    if not isinstance(bounds, list):
        raise ValueError(f"skipped_bounds: expected a list of bounds, received {bounds!r}")
    if len(bounds) != n:
        raise ValueError(
            f"skipped_bounds: expected as many bounds as refusals ({n}), received {len(bounds)}"
        )
    if not all(b is None or b in EXTENT_BOUNDS for b in bounds):
        raise ValueError(
            f"skipped_bounds: expected each one of {EXTENT_BOUNDS} or null, received {bounds!r}"
        )
    return bounds


def _checked_per_bound(per_bound, count: int) -> dict[str, int]:
    """The counts per bound a record holds, which add up to its ``count`` of skipped
    scans."""
    if not isinstance(per_bound, dict):
        raise ValueError(
            f"skipped_per_bound: expected an object of counts per bound, received {per_bound!r}"
        )
    known = (*EXTENT_BOUNDS, UNKNOWN_BOUND)
    for key, value in per_bound.items():
        if key not in known:
            raise ValueError(f"skipped_per_bound: expected the bounds {known}, received {key!r}")
        _count(f"skipped_per_bound[{key!r}]", value)
    if sum(per_bound.values()) != count:
        raise ValueError(
            f"skipped_per_bound: expected counts that add up to n_skipped ({count}), "
            f"received {per_bound!r}"
        )
    return ordered(per_bound)


def check_replay_counts(record: dict, n_scans: int) -> None:
    """Check the counts a saved state's replay ``record`` holds against each other and
    against its mapper's ``n_scans``: the scans taken from the log (``consumed``), those
    mapped (``mapped``, the mapper's; absent in an older state) and the skipped scans
    (:meth:`SkippedScans.from_record`); each scan taken was mapped or skipped.  Also
    ``checkpoint``, true or false where present.  Raises ValueError naming the field,
    what was expected and what was received."""
    consumed = scan_count(record, "consumed")
    mapped = scan_count(record, "mapped") if "mapped" in record else n_scans
    if mapped != n_scans:
        raise ValueError(
            f"mapped: expected the n_scans of the saved mapper ({n_scans}), received {mapped}"
        )
    skipped = SkippedScans.from_record(record)
    if consumed != mapped + skipped.count:
        raise ValueError(
            f"consumed: expected the scans mapped (mapped, {mapped}) and skipped (n_skipped, "
            f"{skipped.count}), {mapped + skipped.count}, received {consumed}"
        )
    checkpoint = record.get("checkpoint", False)
    if type(checkpoint) is not bool:
        raise ValueError(f"checkpoint: expected true or false, received {checkpoint!r}")
