"""The public API is frozen: every name of ``topojax.__all__`` and the signature of every
public function, class, method and property.  A deliberate change updates
``tests/data/public_api.json`` (run this file as a script to rewrite it) and says so in the
changelog of the commit."""

from __future__ import annotations

import inspect
import json
import sys
from pathlib import Path

import topojax as tj

FROZEN = Path(__file__).parent / "data" / "public_api.json"


def _describe(obj) -> dict:
    if inspect.isclass(obj):
        members = {}
        for name, value in sorted(vars(obj).items()):
            if name.startswith("_") and name != "__init__":
                continue
            if isinstance(value, property):
                members[name] = "property"
            elif isinstance(value, (classmethod, staticmethod)):
                members[name] = f"{type(value).__name__} {inspect.signature(value.__func__)}"
            elif inspect.isfunction(value):
                members[name] = str(inspect.signature(value))
        try:
            signature = str(inspect.signature(obj))
        except ValueError:  # an exception class with the built-in constructor
            signature = "(*args)"
        bases = [b.__name__ for b in obj.__mro__[1:] if b is not object]
        return {"kind": "class", "bases": bases, "signature": signature, "members": members}
    if callable(obj):
        return {"kind": "function", "signature": str(inspect.signature(obj))}
    return {"kind": type(obj).__name__}


def public_api() -> dict:
    return {name: _describe(getattr(tj, name)) for name in sorted(tj.__all__)}


def test_all_names_are_frozen():
    frozen = json.loads(FROZEN.read_text())
    assert sorted(tj.__all__) == sorted(frozen)


def test_every_name_resolves():
    for name in tj.__all__:
        assert getattr(tj, name) is not None, name


def test_signatures_are_frozen():
    frozen = json.loads(FROZEN.read_text())
    now = public_api()
    changed = {k: (frozen.get(k), now.get(k)) for k in now if frozen.get(k) != now.get(k)}
    assert not changed, json.dumps(changed, indent=1)


if __name__ == "__main__":  # rewrite the frozen file after a deliberate change
    FROZEN.write_text(json.dumps(public_api(), indent=1, sort_keys=True) + "\n")
    sys.exit(0)
