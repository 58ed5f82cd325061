"""IMU-rate propagation of the nominal state and the error covariance.

Per IMU interval k (length dt_k, raw mean rates ω̃_k = dθ_k/dt_k, f̃_k = dv_k/dt_k, with the
previous interval's rates carried along; for a mission's first sample the caller passes the
current rates as the previous ones):

1. nominal state: ``x_k = strapdown.propagate(x_{k-1}, ω̃_{k-1}, f̃_{k-1}, ω̃_k, f̃_k, dt_k)``
   (docs/mechanization.md, 'Mechanization step'), which also returns the step's midpoint
   values;
2. error dynamics at that midpoint: ``F = errorstate.system_matrix(...)``, ``G``
   (docs/filters.md, 'Error-state model');
3. ``Φ = I + F T + (F T)²/2``, ``Qd = ½ (Φ G Q Gᵀ Φᵀ + G Q Gᵀ) T`` (T = dt_k);
4. ``P_k = Φ P_{k-1} Φᵀ + Qd`` (docs/filters.md, 'Propagation'; paper eq. (11)).

:func:`propagate_numpy` and :func:`propagate_partial_numpy` are the readable NumPy twins;
:func:`propagate` and :func:`propagate_partial` run the same equations compiled
(:mod:`adaptnav.compiled.propagation`, a few hundred times faster) and, like the twins, never modify
their arguments.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adaptnav.compiled import propagation as kernels
from adaptnav.models import errorstate, strapdown
from adaptnav.models.errorstate import N_NOISE, N_STATES
from adaptnav.models.strapdown import NOM_SIZE

Array = NDArray[np.float64]


def _vec(a: ArrayLike, n: int, name: str) -> Array:
    out = np.array(a, dtype=np.float64)  # always a copy
    if out.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {out.shape}")
    return out


def _state_inputs(
    x: ArrayLike, P: ArrayLike, w_prev: ArrayLike, f_prev: ArrayLike, q_psd: ArrayLike
) -> tuple[Array, Array, Array, Array, Array]:
    """Validated float64 copies of (x, P, w_prev, f_prev, q_psd); with m declared states
    (errorstate.StateLayout) x has 16 + m numbers, P is (15 + m)², and q_psd 12 + m PSDs (the
    declared states random walks) or 12 + 2m (then their 1/τ as well:
    errorstate.StateLayout.kernel_psd), returned as 12 + 2m for m > 0."""
    Pa = np.array(P, dtype=np.float64)
    if Pa.ndim != 2 or Pa.shape[0] != Pa.shape[1] or Pa.shape[0] < N_STATES:
        raise ValueError(f"P must be n×n with n >= {N_STATES}, got {Pa.shape}")
    m = Pa.shape[0] - N_STATES
    q = np.array(q_psd, dtype=np.float64).ravel()
    if m > 0 and q.shape == (N_NOISE + m,):
        q = np.concatenate([q, np.zeros(m)])
    return (
        _vec(x, NOM_SIZE + m, "x"),
        Pa,
        _vec(w_prev, 3, "w_prev"),
        _vec(f_prev, 3, "f_prev"),
        _vec(q, N_NOISE + 2 * m if m else N_NOISE, "q_psd"),
    )


def _imu_inputs(dtheta: ArrayLike, dvel: ArrayLike, dt: ArrayLike) -> tuple[Array, Array, Array]:
    """Contiguous float64 (dθ (N, 3), dv (N, 3), dt (N,)); not written to by the callers."""
    # C-contiguous and writeable (read-only arrays would cost Numba another compilation)
    dth = np.require(dtheta, np.float64, ["C", "W"])
    dv = np.require(dvel, np.float64, ["C", "W"])
    if dth.ndim != 2 or dth.shape[1] != 3 or dv.shape != dth.shape:
        raise ValueError(f"dtheta and dvel must be (N, 3), got {dth.shape} and {dv.shape}")
    dts = np.array(np.broadcast_to(np.asarray(dt, np.float64), (dth.shape[0],)))
    if not np.all(dts > 0.0):
        raise ValueError("dt must be > 0")
    return dth, dv, dts


def _check_interval(dt: float, ta: float, tb: float) -> None:
    if not 0.0 <= ta < tb <= dt:
        raise ValueError(f"need 0 <= ta < tb <= dt, got ta={ta}, tb={tb}, dt={dt}")


def low_pass(f_lp: Array, f: Array, T: float, tau_f: float) -> Array:
    """The specific force F is evaluated with: ``f_lp ← e f_lp + (1 - e) f``, ``e = exp(-T/τ_f)``
    (τ_f = 0: f itself); NaN f_lp starts at f. ``f_lp`` is updated in place and returned.

    F's ``[f_n×]`` couples attitude into velocity error (Groves 14.64). Evaluated with the
    *measured* f, its white noise makes the heading error look observable at rest and the filter
    claims a heading σ it does not have (tests/unit/test_align.py); the motion F must see is slow.
    Twin of :func:`adaptnav.compiled.propagation._low_pass`.
    """
    if np.isnan(f_lp[0]):
        f_lp[:] = f
    else:
        e = math.exp(-T / tau_f) if tau_f > 0.0 else 0.0
        f_lp[:] = e * f_lp + (1.0 - e) * f
    return f_lp


def _f_state(f_lp: Array | None) -> Array:
    if f_lp is None:
        return np.full(3, np.nan)
    if not (isinstance(f_lp, np.ndarray) and f_lp.shape == (3,) and f_lp.dtype == np.float64):
        raise ValueError("f_lp must be a float64 array of shape (3,) (updated in place)")
    return f_lp


class CovarianceBlock:
    """The covariance over a block of steps (docs/filters.md, 'Covariance blocks'; readable twin
    of the compiled engine's): each step adds ``A += F_k T_k`` and ``S += G_k Q G_kᵀ T_k``; the
    block closes with ``Φ = I + A + A²/2`` and ``Qd = ½ (Φ S Φᵀ + S)``, ``P ← Φ P Φᵀ + Qd``. A
    block of one step is steps 2-4 of the module docstring (``block_s = 0``: every step). The
    declared states move over the block's whole span (errorstate.augment; their nominal values
    decay with it: :meth:`close`'s ``x``)."""

    def __init__(self, q: Array, tau_a: float, tau_g: float) -> None:
        self.q, self.tau_a, self.tau_g = q, tau_a, tau_g
        self.A = np.zeros((N_STATES, N_STATES))
        self.S = np.zeros((N_STATES, N_STATES))
        self.T = 0.0

    def add(self, mid: strapdown.StepMidpoint, T: float) -> None:
        """One step's F T and G Q Gᵀ T, F at the step's midpoint."""
        F = errorstate.system_matrix(
            mid.lat, mid.h, mid.v_n, mid.C_nb, mid.f_n, self.tau_a, self.tau_g
        )
        G = errorstate.noise_input_matrix(mid.C_nb)
        self.A += F * T
        self.S += (G * self.q[:N_NOISE]) @ G.T * T
        self.T += T

    def close(self, P: Array, x: Array) -> Array:
        """P propagated over the block; the block emptied. With declared states their nominal
        values in ``x`` (16 + m) decay with their Gauss-Markov transition, in place: the nominal
        follows the process's mean, ``b̂' = -b̂/τ``, so that the error obeys the same model."""
        Phi = errorstate.transition(self.A, 1.0)
        Qd = 0.5 * (Phi @ self.S @ Phi.T + self.S)
        Qd = 0.5 * (Qd + Qd.T)
        m = P.shape[0] - N_STATES
        if m > 0:  # declared blocks (errorstate.StateLayout)
            psd, inv_tau = self.q[N_NOISE : N_NOISE + m], self.q[N_NOISE + m :]
            Phi, Qd = errorstate.augment(Phi, Qd, psd, self.T, inv_tau)
            x[NOM_SIZE:] *= np.diag(Phi)[N_STATES:]
        self.A[:] = 0.0
        self.S[:] = 0.0
        self.T = 0.0
        return errorstate.predict_covariance(P, Phi, Qd)


def propagate_numpy(
    x: ArrayLike,
    P: ArrayLike,
    dtheta: ArrayLike,
    dvel: ArrayLike,
    dt: ArrayLike,
    w_prev: ArrayLike,
    f_prev: ArrayLike,
    q_psd: ArrayLike,
    tau_a: float = np.inf,
    tau_g: float = np.inf,
    *,
    f_lp: Array | None = None,
    tau_f: float = 0.0,
    block_s: float = 0.0,
) -> tuple[Array, Array, Array, Array]:
    """Propagate x (16) and P (15×15) over N IMU increments (readable NumPy twin).

    ``dtheta``, ``dvel``: (N, 3) increments (rad, m/s); ``dt``: scalar or (N,); ``w_prev``,
    ``f_prev``: raw mean rates of the interval before the first one; ``q_psd``: the 12 PSDs of
    :func:`errorstate.noise_psd`; ``tau_a``, ``tau_g``: bias correlation times (inf: random walk).
    Per sample the four steps of the module docstring (docs/filters.md, 'Propagation'; paper eqs.
    (10), (11)), F with the specific force low-passed with time constant ``tau_f``
    (:func:`low_pass`; its state ``f_lp`` (3), NaN to start, is the one argument updated in place,
    so that a run can go on in the next call). Returns new ``(x, P, w_prev, f_prev)``, the last two
    being the last interval's rates for the next call. ``block_s > 0``: P moves in blocks of that
    many seconds of steps and a last, shorter one (:class:`CovarianceBlock`).
    """
    xa, Pa, wp, fp, q = _state_inputs(x, P, w_prev, f_prev, q_psd)
    dth, dv, dts = _imu_inputs(dtheta, dvel, dt)
    flp = _f_state(f_lp)
    block = CovarianceBlock(q, tau_a, tau_g)
    for k in range(dth.shape[0]):
        T = float(dts[k])
        wc, fc = dth[k] / T, dv[k] / T
        xa[:NOM_SIZE], mid = strapdown.propagate(
            xa[:NOM_SIZE], wp, fp, wc, fc, T, 0.0, T, tau_a, tau_g
        )
        block.add(replace(mid, f_n=low_pass(flp, mid.f_n, T, tau_f).copy()), T)
        if kernels.block_full(block.T, block_s) or k == dth.shape[0] - 1:
            Pa = block.close(Pa, xa)
        wp, fp = wc, fc
    return xa, Pa, wp.copy(), fp.copy()


def propagate_partial_numpy(
    x: ArrayLike,
    P: ArrayLike,
    w_prev: ArrayLike,
    f_prev: ArrayLike,
    w_cur: ArrayLike,
    f_cur: ArrayLike,
    dt: float,
    ta: float,
    tb: float,
    q_psd: ArrayLike,
    tau_a: float = np.inf,
    tau_g: float = np.inf,
    *,
    f_lp: Array | None = None,
    tau_f: float = 0.0,
) -> tuple[Array, Array]:
    """Propagate x and P over the part [ta, tb] of one IMU interval of length dt (NumPy twin).

    Used to stop at a measurement's own time inside an interval: ``0 <= ta < tb <= dt`` are offsets
    from the interval's start, ``w_*``/``f_*`` the raw mean rates of the previous and current
    interval (the linear-rate model of :mod:`adaptnav.models.strapdown`; docs/mechanization.md,
    'Splitting an interval'). The state follows ``strapdown.propagate(..., dt, ta, tb)``; Φ and Qd
    are taken over T = tb - ta at that sub-step's midpoint (docs/filters.md, 'Propagation'; paper
    eqs. (10), (11)), F's specific force as in :func:`propagate_numpy` (``f_lp`` in place). Returns
    new ``(x, P)``.
    """
    _check_interval(dt, ta, tb)
    xa, Pa, wp, fp, q = _state_inputs(x, P, w_prev, f_prev, q_psd)
    wc, fc = _vec(w_cur, 3, "w_cur"), _vec(f_cur, 3, "f_cur")
    flp = _f_state(f_lp)
    xa[:NOM_SIZE], mid = strapdown.propagate(
        xa[:NOM_SIZE], wp, fp, wc, fc, dt, ta, tb, tau_a, tau_g
    )
    block = CovarianceBlock(q, tau_a, tau_g)
    block.add(replace(mid, f_n=low_pass(flp, mid.f_n, tb - ta, tau_f).copy()), tb - ta)
    Pa = block.close(Pa, xa)
    return xa, Pa


def propagate(
    x: ArrayLike,
    P: ArrayLike,
    dtheta: ArrayLike,
    dvel: ArrayLike,
    dt: ArrayLike,
    w_prev: ArrayLike,
    f_prev: ArrayLike,
    q_psd: ArrayLike,
    tau_a: float = np.inf,
    tau_g: float = np.inf,
    *,
    f_lp: Array | None = None,
    tau_f: float = 0.0,
    block_s: float = 0.0,
) -> tuple[Array, Array, Array, Array]:
    """Compiled :func:`propagate_numpy` (same arguments and results; inputs but ``f_lp`` not
    modified).

    Runs :func:`adaptnav.compiled.propagation.propagate_run` on copies. The returned P is exactly
    symmetric.
    """
    xa, Pa, wp, fp, q = _state_inputs(x, P, w_prev, f_prev, q_psd)
    dth, dv, dts = _imu_inputs(dtheta, dvel, dt)
    kernels.propagate_run(
        xa, Pa, dth, dv, dts, wp, fp, q, float(tau_a), float(tau_g), _f_state(f_lp), float(tau_f),
        float(block_s),
    )  # fmt: skip
    return xa, Pa, wp, fp


def propagate_partial(
    x: ArrayLike,
    P: ArrayLike,
    w_prev: ArrayLike,
    f_prev: ArrayLike,
    w_cur: ArrayLike,
    f_cur: ArrayLike,
    dt: float,
    ta: float,
    tb: float,
    q_psd: ArrayLike,
    tau_a: float = np.inf,
    tau_g: float = np.inf,
    *,
    f_lp: Array | None = None,
    tau_f: float = 0.0,
) -> tuple[Array, Array]:
    """Compiled :func:`propagate_partial_numpy` (same arguments and results; inputs but ``f_lp``
    unchanged).

    Runs :func:`adaptnav.compiled.propagation.propagate_partial` on copies.
    """
    _check_interval(dt, ta, tb)
    xa, Pa, wp, fp, q = _state_inputs(x, P, w_prev, f_prev, q_psd)
    wc, fc = _vec(w_cur, 3, "w_cur"), _vec(f_cur, 3, "f_cur")
    kernels.propagate_partial(
        xa, Pa, wp, fp, wc, fc, float(dt), float(ta), float(tb), q, float(tau_a), float(tau_g),
        _f_state(f_lp), float(tau_f),
    )  # fmt: skip
    return xa, Pa
