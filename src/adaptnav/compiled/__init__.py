"""The Numba kernels of the hot paths: IMU-rate propagation
(:mod:`~adaptnav.compiled.propagation`) and the measurement epoch
(:mod:`~adaptnav.compiled.update`). Each has a readable NumPy twin
(:mod:`adaptnav.engine.propagation`, the models and sensors, and
``tests/helpers/engine_reference.py``) that the tests hold it equal to.

**Where the compiled code is cached.** Numba keys the on-disk cache of a function on its own
file only: the engine's loop (``engine/batch.py``) compiled with the epoch of
``compiled/update.py`` inlined stays in the cache when only ``update.py`` changes, and a
checkout updated in place (``git pull`` on an editable install) then runs the old kernels
without a word. So, before any kernel is defined, ``numba.config.CACHE_DIR`` is set here to a
folder named by a hash of every file the kernels are compiled from or freeze constants of
(:data:`KERNEL_FOLDERS`, :func:`kernel_fingerprint`): ``NUMBA_CACHE_DIR/kernels-<hash>`` when
that variable is set, else ``$XDG_CACHE_HOME`` (or ``~/.cache``) ``/adaptnav/numba/kernels-<hash>``.
Any change to those files compiles afresh; processes of one source (the cold start's second
process, dask workers) share one folder. The folder is also put in this process's
``NUMBA_CACHE_DIR``: Numba re-reads its settings from the environment before each compilation
once any ``NUMBA_*`` variable has changed (dask's nanny sets ``NUMBA_NUM_THREADS`` in the parent
when it starts a worker), and a setting made only in ``numba.config`` was then lost, so that
kernels defined afterwards were cached beside their sources again. A child process inherits the
variable and, its folder already being keyed on the same sources, uses it as it is.
docs/performance.md, 'Cold start'.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numba

PACKAGE = Path(__file__).resolve().parent.parent
KERNEL_FOLDERS = (
    "compiled", "engine", "sensors", "models", "core", "estimation", "estimation/noise",
)  # fmt: skip
"""The package's folders whose modules the compiled functions are, call or freeze constants of
(``sensors/kind.py``'s parameter layout, ``models/errorstate.py``'s reset modes, the earth
model, ``estimation/health.py``'s lockout constants, ``estimation/noise/process.py``'s; up to
0.4.5 the estimation folders were left out, and a change of a constant there ran the old
kernels from the cache)."""


def kernel_fingerprint(package: Path = PACKAGE) -> str:
    """16 hex digits of the SHA-256 of the ``*.py`` files of :data:`KERNEL_FOLDERS` under
    ``package`` (names and bytes, in sorted order)."""
    digest = hashlib.sha256()
    for folder in KERNEL_FOLDERS:
        for path in sorted((package / folder).glob("*.py")):
            digest.update(path.relative_to(package).as_posix().encode())
            digest.update(b"\0")
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def cache_dir(fingerprint: str, environ: Mapping[str, str] = os.environ) -> Path:
    """The folder of the compiled functions' cache (module docstring); ``NUMBA_CACHE_DIR``
    already naming this fingerprint's folder is that folder."""
    folder = f"kernels-{fingerprint}"
    root = environ.get("NUMBA_CACHE_DIR")
    if root and Path(root).name == folder:
        return Path(root)
    if not root:
        base = environ.get("XDG_CACHE_HOME")
        if not base:
            try:
                base = str(Path.home() / ".cache")
            except RuntimeError:  # no home directory to be found: the temporary folder
                base = tempfile.gettempdir()
        root = str(Path(base) / "adaptnav" / "numba")
    return Path(root) / folder


os.environ["NUMBA_CACHE_DIR"] = str(cache_dir(kernel_fingerprint()))
numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]  # type: ignore[attr-defined]
