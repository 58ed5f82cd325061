"""The mirror fit of mission/gnss_mirror.py on synthetic tracks: a GNSS track mirrored (its
fixes' north + i east conjugated, as a longitude whose sign is lost gives) is told from the
DVL's dead reckoning where the vehicle turns, and not on a straight line, where a mirror is a
rotation (docs/robustness.md, 'A GNSS track mirrored')."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from adaptnav.mission import gnss_mirror

SIGMA_M = 2.9  # the simulated GPS's σ per axis


def _track(turns: bool) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """A dead-reckoned track at 2 Hz over 20 min at 2 m/s: turning 90° every 200 s (a lawn
    mower), or along one line with its speed stepping between 1 and 3 m/s."""
    t = np.arange(0.0, 1200.0, 0.5)
    if turns:
        heading = np.deg2rad(90.0) * np.floor(t / 200.0) * (-1.0) ** np.floor(t / 400.0)
        v = 2.0 * np.exp(1j * heading)
    else:
        v = (2.0 + np.sign(np.sin(t / 40.0))) * np.exp(1j * 0.3)
    p = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * 0.5)])
    return t, np.asarray(p, dtype=complex)


def _fixes(
    track: tuple[NDArray[np.float64], NDArray[np.complex128]], turn: complex, mirrored: bool
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """1-Hz fixes of the track seen from a start heading ``turn`` (a unit complex), white
    noise of :data:`SIGMA_M`, conjugated when ``mirrored``."""
    t, p = track
    rng = np.random.default_rng(7)
    tf = np.arange(0.3, t[-1], 1.0)
    z = turn * (np.interp(tf, t, p.real) + 1j * np.interp(tf, t, p.imag))
    z = np.conj(z) if mirrored else z
    z = z + SIGMA_M * (rng.standard_normal(tf.size) + 1j * rng.standard_normal(tf.size))
    return tf, z.real, z.imag


def test_a_mirrored_track_that_turns_is_told_and_a_right_one_is_not() -> None:
    track = _track(turns=True)
    turn = np.exp(1j * np.deg2rad(40.0))
    right = gnss_mirror.mirror_fit(*_fixes(track, turn, False), 1.0, track)
    mirror = gnss_mirror.mirror_fit(*_fixes(track, turn, True), 1.0, track)
    assert right is not None and mirror is not None
    assert not right.mirrored() and right.log_lr < 0.0, right
    assert mirror.mirrored() and mirror.log_lr > gnss_mirror.MIN_LOG_LR, mirror
    # The fixes' scale is the track's: 1 for the model that fits.
    assert abs(right.k_direct - 1.0) < 0.05 and abs(mirror.k - 1.0) < 0.05


def test_a_straight_track_cannot_tell_a_mirror() -> None:
    """On a line b_k = e^{iθ} r_k, r_k real: |Σ conj(b) a| = |Σ b a|, so both fits leave the
    same residual (V = 1), whatever the speed does."""
    track = _track(turns=False)
    for mirrored in (False, True):
        m = gnss_mirror.mirror_fit(*_fixes(track, 1j, mirrored), 1.0, track)
        assert m is not None  # the speed's steps give the fit a signal
        assert not m.mirrored() and abs(m.ratio - 1.0) < 1e-9, m
