"""Where the compiled functions are cached (adaptnav/compiled/__init__.py): a folder keyed on
the kernels' sources, so that a change to any of them compiles afresh. Numba keys its cache on
each function's own file only: the engine's loop kept an old copy of a changed epoch (found on
this project's own checkout, 2026-12-04, when a GNSS bias added to compiled/update.py was not
seen by the cached engine)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numba
import numba.core.config
import pytest

from adaptnav import compiled
from adaptnav.compiled import KERNEL_FOLDERS, PACKAGE, cache_dir, kernel_fingerprint
from adaptnav.engine import batch


def _copy(tmp_path: Path) -> Path:
    root = tmp_path / "adaptnav"
    for folder in (*KERNEL_FOLDERS, "mission"):
        shutil.copytree(
            PACKAGE / folder, root / folder, ignore=shutil.ignore_patterns("__py*"),
            dirs_exist_ok=True,
        )  # fmt: skip
    return root


def test_the_fingerprint_follows_the_kernels_sources_and_nothing_else(tmp_path: Path) -> None:
    root = _copy(tmp_path)
    first = kernel_fingerprint(root)
    assert first == kernel_fingerprint(PACKAGE) and len(first) == 16
    loader = root / "mission" / "loader.py"
    loader.write_text(loader.read_text() + "\n# a change outside the kernels\n")
    assert kernel_fingerprint(root) == first
    for changed in (
        "compiled/update.py", "sensors/kind.py", "models/errorstate.py",
        "estimation/health.py", "estimation/noise/process.py",  # constants the kernels freeze
    ):  # fmt: skip
        path = root / changed
        text = path.read_text()
        path.write_text(text + "\n# changed\n")
        assert kernel_fingerprint(root) != first, changed
        path.write_text(text)
    assert kernel_fingerprint(root) == first


def test_the_cache_folder_is_keyed_and_in_use() -> None:
    fp = "0123456789abcdef"
    assert cache_dir(fp, {"NUMBA_CACHE_DIR": "/n"}) == Path("/n/kernels-0123456789abcdef")
    assert cache_dir(fp, {"XDG_CACHE_HOME": "/x"}) == Path("/x/adaptnav/numba/kernels-" + fp)
    assert cache_dir(fp, {}).parent.name == "numba"
    # a child process inherits the keyed folder and keeps it
    assert cache_dir(fp, {"NUMBA_CACHE_DIR": "/n/kernels-" + fp}) == Path("/n/kernels-" + fp)
    assert cache_dir(fp, {"NUMBA_CACHE_DIR": "/n/kernels-0"}) == Path("/n/kernels-0/kernels-" + fp)
    here = cache_dir(kernel_fingerprint())
    assert Path(numba.config.CACHE_DIR) == here  # type: ignore[attr-defined]
    assert compiled.cache_dir is cache_dir
    # the engine's loop is cached there, not beside its source
    assert Path(batch._navigate._cache._cache_path).is_relative_to(here)


def test_the_cache_folder_survives_numba_rereading_its_environment(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Found in CI, 2026-12-04: dask's nanny sets NUMBA_NUM_THREADS in the parent when a worker
    starts, Numba's next compilation re-read every setting from the environment, and the
    folder set only in numba.config was gone (kernels defined later cached beside their
    sources)."""
    here = cache_dir(kernel_fingerprint())
    monkeypatch.setenv("NUMBA_DEBUG_CACHE", "0")  # any change to a NUMBA_* variable will do
    numba.core.config.reload_config()
    assert Path(numba.config.CACHE_DIR) == here  # type: ignore[attr-defined]
