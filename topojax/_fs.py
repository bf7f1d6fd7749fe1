"""File-system helpers shared by every writer: atomic writes, output folders, and the rule
that no output replaces an input map."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from ._filekind import LOOP, loop_in, non_file_kind, the_non_file
from ._validate import no_file_above, path_like

__all__ = [
    "atomic_write",
    "atomic_write_bytes",
    "default_file_mode",
    "input_files",
    "output_file",
    "output_file_in_folder",
    "output_folder",
    "refuse_overwriting_inputs",
    "refuse_suffix_only",
    "yaml_image",
]

#: Suffixes of map_server YAML files (the same as :data:`topojax.maps.YAML_SUFFIXES`).
_YAML_SUFFIXES = (".yaml", ".yml")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def default_file_mode() -> int:
    """The permissions an ordinary new file gets (0666 less the process umask), for
    files made with :func:`tempfile.mkstemp`, which makes them 0600."""
    return 0o666 & ~_umask()


def output_folder(path: str | Path, *, name: str = "out_dir") -> Path:
    """Create the folder ``path`` (and its parents) for outputs and return it.

    Raises NotADirectoryError naming ``name`` when ``path``, or a folder above it, is an
    existing file (``mkdir`` itself only says "File exists" / "Not a directory"), and an
    OSError naming it when the folder cannot be made (no permission, a read-only or full
    file system), or when a file cannot be created in it (tried with an empty one); a
    TypeError naming it when ``path`` is not a path, a ValueError when it is empty
    (:func:`~topojax._validate.path_like`)."""
    folder = path_like(name, path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise NotADirectoryError(
            f"{name}: expected a folder to write into, but {folder} or a folder above it is "
            "an existing file"
        ) from None
    except OSError as exc:
        raise OSError(
            exc.errno, f"{name}: cannot make the folder {folder} ({exc.strerror})"
        ) from None
    _try_writing(folder, f"{name}: cannot write into the folder {folder}")
    return folder


def output_file(path: str | Path, *, name: str = "path") -> Path:
    """``path`` as a :class:`~pathlib.Path` after checking, before any work, that a file
    can be written there: it is not a folder (an ``IsADirectoryError``) nor anything else
    that is no regular file (a FIFO, socket or device: a ``ValueError``), no folder above
    it is an existing file (a ``NotADirectoryError``,
    :func:`~topojax._validate.no_file_above`), and the nearest folder above it that
    exists takes a new file (tried with an empty one; an ``OSError`` otherwise: no
    permission, a read-only or full file system).  Errors name ``name``; nothing is
    created."""
    p = path_like(name, path)
    if p.is_dir():
        raise IsADirectoryError(f"{name}: expected a file name, received the folder {p}")
    if non_file_kind(p) is not None:  # a FIFO, socket or device: not replaced by a file
        raise ValueError(
            f"{name}: expected a regular file or a new name, received {the_non_file(p)} {p}"
        )
    no_file_above(name, p)
    folder = next(f for f in p.parents if f.is_dir())  # "." or "/" at the latest
    why = (
        f"no file can be made in the folder {folder}"
        if folder == p.parent
        else f"its folder {p.parent} cannot be made in {folder}"
    )
    _try_writing(folder, f"{name}: cannot write {p}: {why}")
    return p


def refuse_non_files(targets: Iterable[Path], *, name: str) -> None:
    """Refuse a folder, or anything else that is no regular file (a FIFO, socket or
    device), where one of the files ``targets`` is to be written, naming ``name`` (the
    output folder's parameter or option): checked before any work, not when that file's
    turn comes after others were written.

    Raises
    ------
    IsADirectoryError
        If a target is an existing folder.
    ValueError
        If a target is a FIFO, socket or device, which the file would replace.
    """
    for target in targets:
        if Path(target).is_dir():
            raise IsADirectoryError(
                f"{name}: expected to write the file {target}, received a folder of that "
                "name; move it away or remove it first"
            )
        if non_file_kind(target) is not None:
            raise ValueError(
                f"{name}: expected to write the file {target}, received "
                f"{the_non_file(target)} of that name; move it away or remove it first"
            )


def refuse_suffix_only(name: str, path: Path, suffixes) -> None:
    """A ValueError naming ``name`` when ``path``'s file name is only one of ``suffixes``
    (``.json``): to :mod:`pathlib` that is a hidden file without a suffix, and the error
    would say the suffix is missing."""
    if path.name.lower() in {s.lower() for s in suffixes}:
        raise ValueError(
            f"{name}: a file named only {path.name!r} has no stem (the part before the "
            f"suffix); expected a name such as 'map{path.name}', received {str(path)!r}"
        )


def output_file_in_folder(path: str | Path, *, name: str = "path") -> Path:
    """:func:`output_file`, and ``path``'s folder exists (a ``FileNotFoundError`` naming
    ``name`` otherwise): for writers that make no folders, checked before their work."""
    p = output_file(path, name=name)
    if (loop := loop_in(p)) is not None:
        raise ValueError(
            f"{name}: expected a file in an existing folder, received {p}, whose folder "
            f"{loop} is {LOOP}"
        )
    if not p.parent.is_dir():
        raise FileNotFoundError(
            f"{name}: expected a file in an existing folder, received {p}, whose folder "
            f"{p.parent} does not exist"
        )
    return p


def _try_writing(folder: Path, message: str) -> None:
    """Make and remove an empty file in ``folder``; an ``OSError`` with ``message`` and
    the system's reason when it cannot be made."""
    try:  # before any work whose results would then be lost
        fd, probe = tempfile.mkstemp(prefix=".topojax-probe.", dir=folder)
    except OSError as exc:
        raise OSError(exc.errno, f"{message} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(probe)


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (:func:`atomic_write`).

    Parameters
    ----------
    path : str or Path
        Destination file. Its folder must exist.
    data : bytes
        File content.
    """
    atomic_write(path, lambda fh: fh.write(data))


def refuse_folder(dest: Path) -> None:
    """An ``IsADirectoryError`` when the output file ``dest`` a program chose (not a
    caller's argument) is a folder."""
    if dest.is_dir():
        raise IsADirectoryError(
            f"output file {dest} is a folder: expected a file path such as {dest / 'name'}"
        )


def atomic_write(path: str | Path, write: Callable[[BinaryIO], object]) -> None:
    """Write a file atomically: ``write(fh)`` fills a temporary file in the same folder,
    which is flushed, synced and then renamed over ``path`` with :func:`os.replace`;
    readers never see a partial file (and one that maps the old file keeps it).  Only a
    regular file is replaced: a FIFO, socket or device at ``path`` is refused.

    Parameters
    ----------
    path : str or Path
        Destination file. Its folder must exist.
    write : callable
        Called with the temporary file, open for binary writing.
    """
    dest = Path(path)
    refuse_folder(dest)
    if non_file_kind(dest) is not None:  # os.replace would put a file in its place
        raise ValueError(
            f"cannot write over {the_non_file(dest)} {dest}: expected a regular file or a new name"
        )
    folder = dest.parent if str(dest.parent) else Path(".")
    if not folder.is_dir():
        no_file_above(f"folder for output file {dest}", dest)
        raise FileNotFoundError(f"folder for output file {dest} does not exist: {folder}")
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", suffix=".tmp", dir=folder)
    with naming_file(dest):
        try:
            # mkstemp creates the file 0600; give the result the permissions any ordinary
            # new file would get (0666 less the process umask).
            os.fchmod(fd, default_file_mode())
            with os.fdopen(fd, "wb") as fh:
                write(fh)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, dest)
        except BaseException:
            try:
                os.unlink(tmp)
            except FileNotFoundError:
                pass
            raise


@contextlib.contextmanager
def naming_file(dest) -> Iterator[None]:
    """Re-raise a built-in OSError that names no file (a full disk says only "No space
    left on device") as one of its type saying it could not write ``dest``."""
    try:
        yield
    except OSError as exc:
        if _unnamed_os_error(exc):
            raise type(exc)(exc.errno, f"cannot write {dest} ({exc.strerror})") from exc
        raise


def _unnamed_os_error(exc: BaseException) -> bool:
    """Whether ``exc`` is a built-in OSError with an error number and no file name."""
    return (
        isinstance(exc, OSError)
        and type(exc).__module__ == "builtins"
        and exc.filename is None
        and exc.errno is not None
        and isinstance(exc.strerror, str)
    )


def input_files(path: Path) -> list[Path]:
    """A map's files: the file itself and, for a YAML, the image it refers to."""
    files = [Path(path)]
    if Path(path).suffix.lower() in _YAML_SUFFIXES:
        img = yaml_image(Path(path))
        if img is not None:
            files.append(img)
    return files


def yaml_image(path: Path) -> Path | None:
    """The image a map_server YAML refers to (as :func:`load_map` resolves it), or None."""
    try:
        import yaml

        if not path.is_file():  # reading a FIFO would wait for a writer forever
            return None
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
        image = doc.get("image") if isinstance(doc, dict) else None
        if not isinstance(image, str) or not image.strip():
            return None
        img = Path(image.strip())
        if img.is_absolute():
            return img if img.is_file() else path.parent / img.name
        return path.parent / img
    except Exception:  # an unreadable YAML is reported when the map is loaded
        return None


def refuse_overwriting_inputs(
    inputs, targets, *, option: str, what: str = "an input map", instead: str = "output folder"
) -> None:
    """Raise ValueError naming ``option`` if a file of ``targets`` is one of the map files
    ``inputs`` or an image one of their YAMLs refers to (checked before any work); the
    message calls the input ``what`` and asks for another ``instead``."""
    taken = {os.path.realpath(f) for path in inputs for f in input_files(Path(path))}
    for target in targets:
        if os.path.realpath(target) in taken:
            raise ValueError(
                f"{option}: writing {target} would overwrite {what}; choose another {instead}"
            )
