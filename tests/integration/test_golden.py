"""Every filter kind on the golden mission reproduces the pinned run to 1e-9.

The golden run is :mod:`helpers.golden` (tests/helpers/golden.py). This is the test a
behaviour-preserving change (the redesign, a faster kernel) must pass. If a change is meant to
alter the numbers, rewrite the golden run with ``tests/helpers/golden.py --write`` (from the
repository root) and say why in the commit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from helpers import golden

REWRITE = "the pinned run differs; if this change is meant to, run tests/helpers/golden.py --write"


@pytest.fixture(scope="module")
def now(tmp_path_factory: pytest.TempPathFactory) -> dict[str, np.ndarray]:
    return golden.runs(golden.mission(tmp_path_factory.mktemp("golden") / "mission"))


@pytest.fixture(scope="module")
def pinned() -> dict[str, np.ndarray]:
    with np.load(golden.FILE) as z:
        return {k: z[k] for k in z.files}


def test_the_golden_run_covers_every_kind(pinned: dict[str, np.ndarray]) -> None:
    assert {k.split("/")[0] for k in pinned} == {*golden.KINDS, "initial"}
    for kind in golden.KINDS:
        fates = set(pinned[f"{kind}/fates"])
        assert "dvl:used" in fates and len(pinned[f"{kind}/solution"]) > 200


def test_the_initial_state_is_the_pinned_one(
    now: dict[str, np.ndarray], pinned: dict[str, np.ndarray]
) -> None:
    np.testing.assert_allclose(now["initial/x0"], pinned["initial/x0"], rtol=1e-9, atol=0)
    np.testing.assert_allclose(now["initial/P0"], pinned["initial/P0"], rtol=1e-9, atol=1e-300)


@pytest.mark.parametrize("kind", golden.KINDS)
def test_each_kind_reproduces_the_pinned_run(
    kind: str, now: dict[str, np.ndarray], pinned: dict[str, np.ndarray]
) -> None:
    assert list(now[f"{kind}/columns"]) == list(pinned[f"{kind}/columns"]), REWRITE
    assert list(now[f"{kind}/fates"]) == list(pinned[f"{kind}/fates"]), REWRITE
    a, b = now[f"{kind}/solution"], pinned[f"{kind}/solution"]
    assert a.shape == b.shape, REWRITE
    # 1e-9 of each column's scale: latitude in radians, covariances near zero, times.
    scale = np.maximum(np.nanmax(np.abs(b), axis=0), 1e-300)
    assert np.all(np.abs(a - b) <= 1e-9 * scale), REWRITE
    s, t = now[f"{kind}/statistic"], pinned[f"{kind}/statistic"]
    np.testing.assert_allclose(s, t, rtol=1e-9, atol=1e-12, equal_nan=True, err_msg=REWRITE)


def test_the_golden_file_is_small() -> None:
    assert Path(golden.FILE).stat().st_size < 1024 * 1024
