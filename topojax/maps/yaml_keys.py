"""Reading a map YAML with PyYAML's safe loader, but refusing a key given twice (PyYAML
keeps the last value silently, so ``resolution: 0.05`` then ``resolution: 0.1`` read 0.1)."""

from __future__ import annotations

import functools
from collections.abc import Hashable
from typing import Any

__all__ = ["DuplicateKeyError", "safe_load_unique"]


class DuplicateKeyError(ValueError):
    """A mapping of the document gives ``key`` twice, first on line ``first`` then on
    line ``again`` (1-based)."""

    def __init__(self, key: Any, first: int, again: int) -> None:
        super().__init__(f"key {key!r} is given twice (lines {first} and {again})")
        self.key, self.first, self.again = key, first, again


@functools.cache
def _loader() -> type:
    import yaml

    class UniqueKeyLoader(yaml.SafeLoader):
        def construct_mapping(self, node, deep=False):
            seen: dict[Any, int] = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":  # "<<": merged keys may repeat
                    continue
                key = self.construct_object(key_node, deep=deep)
                if not isinstance(key, Hashable):
                    continue  # the safe loader refuses it itself
                line = key_node.start_mark.line + 1
                if key in seen:
                    raise DuplicateKeyError(key, seen[key], line)
                seen[key] = line
            return super().construct_mapping(node, deep=deep)

    return UniqueKeyLoader


def safe_load_unique(text: str) -> Any:
    """``yaml.safe_load(text)``, raising :class:`DuplicateKeyError` where a mapping gives
    a key twice (PyYAML's own errors are raised as they are)."""
    import yaml

    return yaml.load(text, Loader=_loader())  # noqa: S506 - a SafeLoader subclass
