"""Sums of sinusoids, continuous in time (the Fig. 6 thruster rpm)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._base import Signal

__all__ = ["Sinusoidal"]


class Sinusoidal(Signal):
    """u_j(t) = offset_j + sum_k amplitude_jk sin(2 pi frequency_jk t + phase_jk).

    Parameters
    ----------
    offset : array_like, shape (nu,)
        Mean value of each channel (input units).
    amplitude, frequency_hz : array_like, shape (nu,) or (nu, K)
        Amplitudes (input units) and frequencies (Hz), K sinusoids per channel.
    phase_rad : array_like, same shape as amplitude, optional
        Phases (rad); zero by default.
    names, units : tuple of str, optional
        Channel names and units.
    """

    def __init__(
        self,
        offset: Any,
        amplitude: Any,
        frequency_hz: Any,
        phase_rad: Any = None,
        *,
        names: tuple[str, ...] = (),
        units: tuple[str, ...] = (),
    ) -> None:
        offset = np.atleast_1d(np.asarray(offset, dtype=float))
        if offset.ndim != 1:
            raise ValueError(f"`offset` must have shape (nu,), got {offset.shape}.")
        nu = offset.shape[0]

        def as2d(name: str, a: Any) -> np.ndarray:
            a = np.asarray(a, dtype=float)
            if a.ndim == 1:
                a = a[:, None]
            if a.ndim != 2 or a.shape[0] != nu:
                raise ValueError(f"`{name}` must have shape ({nu},) or ({nu}, K), got {a.shape}.")
            if not np.isfinite(a).all():
                raise ValueError(f"`{name}` holds NaN or inf.")
            return a

        amp = as2d("amplitude", amplitude)
        freq = as2d("frequency_hz", frequency_hz)
        phase = as2d("phase_rad", np.zeros_like(amp) if phase_rad is None else phase_rad)
        if not (amp.shape == freq.shape == phase.shape):
            raise ValueError(
                "`amplitude`, `frequency_hz` and `phase_rad` need the same shape, got "
                f"{amp.shape}, {freq.shape}, {phase.shape}."
            )
        if not np.isfinite(offset).all():
            raise ValueError("`offset` holds NaN or inf.")
        self.nu = nu
        self.offset = offset
        self.amp = amp
        self.freq_hz = freq
        self.phase_rad = phase
        self.names = tuple(names) or tuple(f"u{i + 1}" for i in range(nu))
        self.units = tuple(units) or ("",) * nu

    def _sinusoids(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return self.offset, self.amp, self.freq_hz, self.phase_rad
