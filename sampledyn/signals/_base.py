"""Input signals: a piecewise-constant part held over sampling intervals plus a
continuous sum of sinusoids.

    u(t) = hold(t_n) + offset + sum_k amp_k sin(2 pi freq_k t + phase_k),  t in [t_n, t_{n+1})

This one form covers the paper's random multilevel input (hold only) and the Fig. 6
thruster rpm (sinusoids only). Because the held part is looked up at the start of
the sampling interval, integrators and Runge-Kutta stages never see an input jump
inside an interval; the compiled simulator evaluates the same form (see
:class:`InputSpec`).

A signal whose held part also jumps *between* sample times (a zero-order hold of
commands logged at other instants) lists those instants in :meth:`Signal.breakpoints`;
:func:`sampledyn.simulate` then stops its integration there, so the samples stay exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["InputSpec", "Signal"]

# Times per block when a signal is evaluated on a long grid.
_BLOCK = 1 << 16


@dataclass(frozen=True)
class InputSpec:
    """Arrays that describe a signal on a sample grid, for compiled code.

    Attributes
    ----------
    hold : ndarray, shape (N, nu)
        Held value on ``[t_n, t_{n+1})``.
    offset : ndarray, shape (nu,)
    amp, freq_hz, phase_rad : ndarray, shape (nu, K)
        Sinusoid amplitudes (input units), frequencies (Hz) and phases (rad).
    """

    hold: np.ndarray
    offset: np.ndarray
    amp: np.ndarray
    freq_hz: np.ndarray
    phase_rad: np.ndarray


class Signal:
    """Base class of inputs. Subclasses override :meth:`hold_values` and/or set the
    sinusoid arrays ``offset``, ``amp``, ``freq_hz``, ``phase_rad``."""

    nu: int = 1
    names: tuple[str, ...] = ()
    units: tuple[str, ...] = ()

    def hold_values(self, t: np.ndarray) -> np.ndarray:
        """Piecewise-constant part at times t (right-continuous), shape (len(t), nu)."""
        return np.zeros((np.shape(t)[0], self.nu))

    def _sinusoids(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        z = np.zeros((self.nu, 0))
        return np.zeros(self.nu), z, z, z

    def continuous_values(self, t: np.ndarray) -> np.ndarray:
        """Continuous (sinusoidal) part at times t, shape (len(t), nu)."""
        t = np.asarray(t, dtype=float)
        out = np.empty((t.shape[0], self.nu))
        self._continuous_into(t, out)
        return out

    def _continuous_into(self, t: np.ndarray, out: np.ndarray) -> None:
        offset, amp, freq, phase = self._sinusoids()
        out[:] = offset
        # One channel at a time: temporaries of shape (len(t), K), not (len(t), nu, K).
        # The arithmetic and the order of the sum over k are those of the batched form
        # offset + sum_k amp sin(2 pi f t + phase), so the values are bit-identical.
        for j in range(amp.shape[0] if amp.shape[1] else 0):
            arg = 2.0 * np.pi * freq[None, j, :] * t[:, None] + phase[None, j, :]
            np.sin(arg, out=arg)
            arg *= amp[None, j, :]
            out[:, j] += arg.sum(axis=1)

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Input at times t (s); returns shape (len(t), nu).

        Evaluated in blocks of ``_BLOCK`` times written into the result, so that the
        temporaries stay small beside it (memory about 1x the returned array)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1:
            raise ValueError(f"`t` must be 1-dimensional, got shape {t.shape}.")
        out = np.empty((t.shape[0], self.nu))
        held = type(self).hold_values is not Signal.hold_values  # a held part exists
        for a in range(0, t.shape[0], _BLOCK):
            block = out[a : a + _BLOCK]
            self._continuous_into(t[a : a + _BLOCK], block)
            if held:
                block += self.hold_values(t[a : a + _BLOCK])  # + commutes: bit-identical
        return out

    def breakpoints(self, t: np.ndarray) -> np.ndarray:
        """Times strictly inside the sampling intervals of the grid ``t`` (s) at which
        the held part jumps, sorted; empty if it jumps at sample times only (the
        default, and the contract of :meth:`hold_values` for signals that do not
        override this). Shape (M,)."""
        return np.empty(0)

    def intersample(self, t_start: np.ndarray, tau: float) -> np.ndarray:
        """Input at ``t_start + tau`` inside the sampling interval that starts at
        ``t_start``: the held part stays that of ``t_start`` even at ``tau = h``."""
        t_start = np.atleast_1d(np.asarray(t_start, dtype=float))
        return self.hold_values(t_start) + self.continuous_values(t_start + tau)

    def check_sampling(self, h: float) -> None:
        """Raise ``ValueError`` if the signal cannot be sampled with period h."""

    def spec(self, t: np.ndarray) -> InputSpec:
        """The compiled-code description of this signal on the sample grid t."""
        offset, amp, freq, phase = self._sinusoids()
        return InputSpec(
            hold=np.ascontiguousarray(self.hold_values(np.asarray(t, dtype=float))),
            offset=np.ascontiguousarray(offset, dtype=float),
            amp=np.ascontiguousarray(amp, dtype=float),
            freq_hz=np.ascontiguousarray(freq, dtype=float),
            phase_rad=np.ascontiguousarray(phase, dtype=float),
        )
