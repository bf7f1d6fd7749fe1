"""The benchmark scripts in ``bench/`` import only names that topojax has.

The scripts are not run by the test suite (they need ``../shared/data`` and minutes each),
so a module moved or renamed in the package would otherwise be found only by the next
person who follows ``bench/README.md``.  Their imports are read from the source text and
resolved, without running the scripts.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"


def _topojax_imports(path: Path) -> list[tuple[int, str, str | None]]:
    """``(line, module, name)`` of every import from topojax in a script (``name`` None for
    ``import topojax.x``), those inside functions included."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name, None) for a in node.names if _ours(a.name)]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and _ours(node.module):
            found += [(node.lineno, node.module, a.name) for a in node.names]
    return found


def _ours(module: str | None) -> bool:
    return module is not None and (module == "topojax" or module.startswith("topojax."))


def _resolves(module: str, name: str | None) -> bool:
    try:
        imported = importlib.import_module(module)
    except ImportError:
        return False
    if name is None or hasattr(imported, name):
        return True
    try:  # a submodule not yet imported
        importlib.import_module(f"{module}.{name}")
    except ImportError:
        return False
    return True


@pytest.mark.parametrize("path", sorted(BENCH.glob("*.py")), ids=lambda p: p.name)
def test_bench_scripts_import_names_that_exist(path: Path) -> None:
    missing = [
        f"{path.name}:{line}: " + (f"from {module} import {name}" if name else f"import {module}")
        for line, module, name in _topojax_imports(path)
        if not _resolves(module, name)
    ]
    assert not missing, "\n".join(missing)


def test_the_import_reader_sees_imports_inside_functions(tmp_path: Path) -> None:
    script = tmp_path / "s.py"
    script.write_text("def f():\n    from topojax import no_such_module, pipeline\n")
    found = _topojax_imports(script)
    assert found == [(2, "topojax", "no_such_module"), (2, "topojax", "pipeline")]
    assert [_resolves(m, n) for _, m, n in found] == [False, True]
