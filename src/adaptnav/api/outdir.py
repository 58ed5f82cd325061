"""Output folders written atomically: every command that writes a folder goes through here.

:func:`output_folder` checks the target before any long computation (a file in the way, a
file as a parent, a folder that cannot be written in, a non-empty folder without ``force``),
gives a temporary folder beside the target to write into, and renames it into place when the
block ends without an error. A non-empty target is refused unless ``force``, which replaces
it whole, so no file of an earlier run survives next to the new ones. On an error the
temporary folder is removed and the target is left as it was. docs/robustness.md.
"""

from __future__ import annotations

import os
import secrets
import shutil
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["OutputError", "check_output", "output_folder"]

TMP_TAG = ".tmp-"
"""Temporary folders are ``.<name>.tmp-<random>`` beside the target (hidden, easy to spot)."""
OLD_TAG = ".old-"
"""A folder being replaced (``force``) is moved to ``.<name>.old-<random>`` until the new one
is in place, then removed."""


class OutputError(ValueError):
    """An output folder that cannot be written as asked; the message names the path."""

    def __init__(self, message: str, *, path: Path | None = None) -> None:
        super().__init__(message)
        self.path = path


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def check_output(
    target: str | Path, *, force: bool = False, inputs: Iterable[str | Path] = ()
) -> Path:
    """Check that ``target`` can be written as an output folder; returns it (absolute).

    Refused (:class:`OutputError`): a symbolic link; an existing file; a path under a file;
    a non-empty folder unless ``force``; with or without ``force``, a folder that holds one
    of ``inputs`` (the mission being read) or the current working directory, or a filesystem
    root. Whether the parent can be written in is found by :func:`output_folder` creating
    its temporary folder there.
    """
    final = Path(os.path.abspath(Path(target).expanduser()))
    shown = str(target)
    if final == final.parent:
        raise OutputError(f"{shown}: a filesystem root cannot be an output folder", path=final)
    if final.is_symlink():
        raise OutputError(
            f"{shown}: is a symbolic link; give the folder it points to, or another path",
            path=final,
        )
    for parent in final.parents:
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                raise OutputError(
                    f"{shown}: {parent} is a file, not a folder, so nothing can be written under "
                    "it",
                    path=final,
                )
            break
    if final.exists():
        if not final.is_dir():
            raise OutputError(
                f"{shown}: exists and is a file, not a folder (remove it or choose another --out)",
                path=final,
            )
        resolved = final.resolve()
        for source in inputs:
            src = Path(os.path.abspath(Path(source).expanduser()))
            if _inside(src, final) or _inside(src.resolve(), resolved):
                raise OutputError(
                    f"{shown}: holds the input {source}; writing here would replace it (choose "
                    "another --out)",
                    path=final,
                )
        if _inside(Path.cwd().resolve(), resolved):
            raise OutputError(
                f"{shown}: is (or holds) the current folder; choose another --out", path=final
            )
        try:
            entries = sorted(p.name for p in final.iterdir())
        except OSError as exc:
            raise OutputError(
                f"{shown}: cannot list the folder ({exc.strerror})", path=final
            ) from None
        if entries and not force:
            more = f" and {len(entries) - 3} more" if len(entries) > 3 else ""
            raise OutputError(
                f"{shown}: folder is not empty ({', '.join(entries[:3])}{more}); give --force to "
                "replace it whole, or choose another --out",
                path=final,
            )
    return final


def _new_sibling(final: Path, tag: str) -> Path:
    return final.with_name(f".{final.name}{tag}{os.getpid()}-{secrets.token_hex(4)}")


@contextmanager
def output_folder(
    target: str | Path, *, force: bool = False, inputs: Iterable[str | Path] = ()
) -> Iterator[Path]:
    """Write an output folder atomically: ``with output_folder(out) as tmp: <write into tmp>``.

    Before the block: :func:`check_output`, the missing parents created, and the temporary
    folder ``.<name>.tmp-*`` made beside the target (an unwritable parent fails here, before
    any computation). After the block: the temporary folder renamed to ``target`` (an empty
    target folder, or with ``force`` a non-empty one, is replaced). If the block raises, the
    temporary folder is removed and the target is untouched.
    """
    final = check_output(target, force=force, inputs=inputs)
    shown = str(target)
    created = [p for p in reversed(final.parents) if not p.exists()]
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = _new_sibling(final, TMP_TAG)
        tmp.mkdir()
    except OSError as exc:
        _remove_empty(created)
        where = exc.filename or final.parent
        raise OutputError(
            f"{shown}: cannot write in {where} ({exc.strerror or exc})", path=final
        ) from None
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        _remove_empty(created)
        raise
    _commit(tmp, final, shown, force)


def _remove_empty(folders: list[Path]) -> None:
    """Remove the parents this module created (deepest first) if they are still empty."""
    for folder in reversed(folders):
        try:
            folder.rmdir()
        except OSError:
            return


def _commit(tmp: Path, final: Path, shown: str, force: bool) -> None:
    """Rename ``tmp`` to ``final``, replacing an empty folder, or any folder with ``force``."""
    old: Path | None = None
    if final.is_symlink() or (final.exists() and not final.is_dir()):
        raise OutputError(
            f"{shown}: something else appeared there while running; the output is in {tmp}",
            path=final,
        )
    if final.is_dir():
        if any(final.iterdir()) and not force:
            raise OutputError(
                f"{shown}: files appeared in the folder while running; the output is in {tmp}",
                path=final,
            )
        old = _new_sibling(final, OLD_TAG)
        try:
            final.rename(old)
        except OSError as exc:
            raise OutputError(
                f"{shown}: cannot replace the folder ({exc.strerror}); the output is in {tmp}",
                path=final,
            ) from None
    try:
        tmp.rename(final)
    except OSError as exc:
        if old is not None:
            old.rename(final)
        raise OutputError(
            f"{shown}: cannot move the output into place ({exc.strerror}); it is in {tmp}",
            path=final,
        ) from None
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
