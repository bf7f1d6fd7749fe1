"""The package's layout rules, checked on the source text (no import of topojax).

* a library module never imports the command line (:mod:`topojax.cli`); only
  ``topojax/__main__.py`` starts it;
* no underscore name is imported from another package: a helper that two packages share
  gets a plain name;
* modules stay under :data:`MAX_MODULE_LINES` lines and functions under
  :data:`MAX_FUNCTION_LINES` (``def`` line to last line, docstring included);
* a type check whose error is the one of ``topojax._validate.instance_of`` calls it
  instead of repeating it;
* no import circle among the modules, imports inside functions and for type checkers
  included;
* the repository passes README.md's lint and format commands, ``ruff check .`` and
  ``ruff format --check .`` (the notebooks' cells included).

Each exception in the ``KNOWN_*`` sets below is one to remove, not to add to.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "topojax"
MAX_MODULE_LINES = 800
MAX_FUNCTION_LINES = 120

#: ``(module, function)`` pairs allowed to be longer: a numba kernel kept in one piece.
KNOWN_LONG_FUNCTIONS = {("topojax.graph.trace", "_trace")}
#: Modules allowed to be longer.
KNOWN_LONG_MODULES: set[str] = set()
#: ``(importer, imported)`` pairs of a private name across packages.
KNOWN_PRIVATE_IMPORTS: set[tuple[str, str]] = set()


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _package_of(path: Path) -> str:
    """The dotted package a module belongs to (a package's own ``__init__``: itself)."""
    name = _module_name(path)
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


def _is_module(dotted: str) -> bool:
    where = ROOT.joinpath(*dotted.split("."))
    return where.is_dir() or where.with_suffix(".py").is_file()


def _modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _imported(path: Path, text: str | None = None) -> list[str]:
    """Every ``topojax`` name a module imports, at any level, as a dotted path: a module,
    or ``module.name`` for a name taken from one.  ``text``: the module's source, default
    the file's."""
    package = _package_of(path)
    if text is None:
        text = path.read_text(encoding="utf-8")
    found = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if a.name.split(".")[0] == "topojax"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if module.split(".")[0] == "topojax":
                found += [f"{module}.{a.name}" for a in node.names]
    return found


def _private_owner(dotted: str) -> tuple[str, str] | None:
    """``(package, private part)`` of the first underscore name in ``dotted``: the package
    the private name belongs to, or None when there is none."""
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        if part.startswith("_") and not part.startswith("__"):
            owner = ".".join(parts[:i])
            if not ROOT.joinpath(*parts[:i]).is_dir():  # a name inside a module
                owner = owner.rpartition(".")[0]
            return owner, ".".join(parts[: i + 1])
    return None


def _private_imports(path: Path, text: str | None = None) -> list[str]:
    """The underscore names ``path`` takes from another package.  A private *module* of an
    enclosing package (``topojax._validate`` from ``topojax.graph``) is that package's
    shared internals, with plain names, and allowed."""
    package = _package_of(path)
    bad = []
    for dotted in _imported(path, text):
        found = _private_owner(dotted)
        if found is None:
            continue
        owner, private = found
        inside = package == owner or private == package or package.startswith(private + ".")
        shared = _is_module(private) and package.startswith(owner + ".")
        if not (inside or shared):
            bad.append(private)
    return bad


def test_library_modules_never_import_the_cli() -> None:
    bad = []
    for path in _modules():
        name = _module_name(path)
        if name == "topojax.__main__" or name.startswith("topojax.cli"):
            continue
        bad += [f"{name} imports {d}" for d in _imported(path) if d.startswith("topojax.cli")]
    assert not bad, "\n".join(bad)


def test_no_private_name_is_imported_from_another_package() -> None:
    bad = []
    for path in _modules():
        name = _module_name(path)
        for private in _private_imports(path):
            if (name, private) not in KNOWN_PRIVATE_IMPORTS:
                bad.append(f"{name} imports {private}")
    assert not bad, "\n".join(bad)


def _module_imports() -> dict[str, set[str]]:
    """Each module's dotted name -> the modules it imports (at any level)."""
    modules = {_module_name(p): p for p in _modules()}
    out: dict[str, set[str]] = {}
    for name, path in modules.items():
        targets = set()
        for dotted in _imported(path):
            while dotted and dotted not in modules:  # ``module.name`` -> the module
                dotted = dotted.rpartition(".")[0]
            if dotted and dotted != name:
                targets.add(dotted)
        out[name] = targets
    return out


def test_no_import_circles() -> None:
    import networkx as nx

    graph = nx.DiGraph([(a, b) for a, targets in _module_imports().items() for b in targets])
    circles = [sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1]
    assert not circles, circles


@pytest.mark.parametrize("command", [["check"], ["format", "--check"]], ids=" ".join)
def test_the_repository_passes_ruff(command: list[str]) -> None:
    pytest.importorskip("ruff")  # in the test extra
    done = subprocess.run(
        [sys.executable, "-m", "ruff", *command, "."],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_modules_are_short() -> None:
    bad = []
    for path in _modules():
        lines = len(path.read_text(encoding="utf-8").splitlines())
        if lines > MAX_MODULE_LINES and _module_name(path) not in KNOWN_LONG_MODULES:
            bad.append(f"{path.relative_to(ROOT)}: {lines} lines")
    assert not bad, "\n".join(bad)


def test_functions_are_short() -> None:
    bad = []
    for path in _modules():
        name = _module_name(path)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            lines = node.end_lineno - node.lineno + 1
            if lines > MAX_FUNCTION_LINES and (name, node.name) not in KNOWN_LONG_FUNCTIONS:
                bad.append(f"{name}.{node.name} (line {node.lineno}): {lines} lines")
    assert not bad, "\n".join(bad)


def _repeats_instance_of(node: ast.AST) -> bool:
    """Whether ``node`` is ``if not isinstance(...): raise TypeError(f"NAME: expected A,
    received {type(X).__name__}")``, the check and message of ``instance_of``."""
    if not (isinstance(node, ast.If) and not node.orelse and len(node.body) == 1):
        return False
    test, body = node.test, node.body[0]
    if not (isinstance(test, ast.UnaryOp) and isinstance(test.op, ast.Not)):
        return False
    call = test.operand
    if not (isinstance(call, ast.Call) and getattr(call.func, "id", None) == "isinstance"):
        return False
    if not (isinstance(body, ast.Raise) and isinstance(body.exc, ast.Call)):
        return False
    exc = body.exc
    if getattr(exc.func, "id", None) != "TypeError" or len(exc.args) != 1:
        return False
    message = exc.args[0]
    if not isinstance(message, ast.JoinedStr):
        return False
    text = "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in message.values)
    last = message.values[-1]
    return (
        ": expected a" in text
        and text.endswith(", received {}")
        and isinstance(last, ast.FormattedValue)
        and ast.unparse(last.value).startswith("type(")
        and ast.unparse(last.value).endswith(").__name__")
    )


def test_type_checks_use_the_validator() -> None:
    bad = []
    for path in _modules():
        if path.name == "_validate.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if _repeats_instance_of(node):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not bad, "use topojax._validate.instance_of:\n" + "\n".join(bad)


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        (
            'if not isinstance(s, str):\n    raise TypeError(f"s: expected a str, received '
            '{type(s).__name__}")',
            True,
        ),
        (  # more than instance_of says
            'if not isinstance(s, str):\n    raise TypeError(f"s: expected a str, received '
            '{type(s).__name__} {s!r}")',
            False,
        ),
        ('instance_of("s", s, str)', False),
    ],
)
def test_instance_of_rule(source: str, expected: bool) -> None:
    # the check above is only as good as its reading of a type check
    found = any(_repeats_instance_of(n) for n in ast.walk(ast.parse(source)))
    assert found is expected


@pytest.mark.parametrize(
    ("importer", "source", "expected"),
    [
        (
            "outofcore/build.py",
            "from ..maps.tiled import _array_map",
            ["topojax.maps.tiled._array_map"],
        ),
        ("outofcore/build.py", "from ..maps.tiled import array_map", []),
        ("outofcore/build.py", "from .._validate import flag", []),
        ("outofcore/build.py", "from .blocks import _private", []),
        ("cli/view.py", "from ..view._window import checked_window", ["topojax.view._window"]),
        ("view/__init__.py", "from ._window import checked_window", []),
        ("graph/build.py", "from ..playback import _helper", ["topojax.playback._helper"]),
    ],
)
def test_private_import_rule(importer: str, source: str, expected: list[str]) -> None:
    # the check above is only as good as its reading of an import
    assert _private_imports(PACKAGE / importer, source) == expected


def test_property_tests_set_no_deadline() -> None:
    """Every hypothesis test sets ``deadline=None``: the suite's timing varies with the
    machine's load, and ``conftest.py`` leaves out hypothesis's garbage-collector timing,
    which only deadlines use (its callback could swallow a signal test's Ctrl-C)."""
    missing = []
    for path in sorted((ROOT / "tests").glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            names = {ast.unparse(d).split("(")[0] for d in node.decorator_list}
            if "given" not in names and "hypothesis.given" not in names:
                continue
            settings = [
                d
                for d in node.decorator_list
                if isinstance(d, ast.Call) and ast.unparse(d.func).endswith("settings")
            ]
            if not any(
                kw.arg == "deadline" and ast.unparse(kw.value) == "None"
                for d in settings
                for kw in d.keywords
            ):
                missing.append(f"{path.name}:{node.lineno} {node.name}")
    assert not missing, missing
