"""Every exception sampledyn raises, in one module (layer 0: no sampledyn imports).

Catch by kind::

    import sampledyn as sd
    try:
        sd.simulate(model, signal, T=10.0, h=0.1)
    except sd.exceptions.NumericalError as exc:  # a method failed on these inputs
        ...

* :class:`ArgumentError` (a ``ValueError``): a value that cannot be used; its
  ``argument`` names the argument, file entry or log column it came from, so that a
  caller (the command line) can name its own option for it. Its kinds:
  :class:`LogFormatError`, :class:`VehicleParameterError`, :class:`SweepConfigError`,
  :class:`WorkLimitError` (work or memory beyond a stated limit), :class:`FileContentError`,
  :class:`MissingArgumentError` (an argument this input needs was not given).
* :class:`NotAStoreError`, :class:`SingularPitchError` (``ValueError``).
* :class:`NumericalError` (a ``RuntimeError``): a numerical method failed on these
  inputs; its kinds :class:`IntegrationError` (and its :class:`JumpRefused`: f jumps
  where the motion is not defined) and :class:`ConvergenceError`.
* :class:`EnvelopeExceeded` (a ``RuntimeError``): a sampled loop diverged.
* :class:`JacobianUnavailableError` (a ``NotImplementedError``).
* :class:`UnsafeCacheError` (a ``PermissionError``): a kernel cache others could write.
* :class:`UsageError`: command-line options that do not apply (exit status 2).
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "ArgumentError",
    "ConvergenceError",
    "FileContentError",
    "EnvelopeExceeded",
    "IntegrationError",
    "JacobianUnavailableError",
    "JumpRefused",
    "LogFormatError",
    "MissingArgumentError",
    "NotAStoreError",
    "NumericalError",
    "SingularPitchError",
    "SweepConfigError",
    "UnsafeCacheError",
    "UsageError",
    "VehicleParameterError",
    "WorkLimitError",
]


class ArgumentError(ValueError):
    """A value that cannot be used; the message names it, the value that came and the
    fix, and ``argument`` names where it came from (a function argument such as
    ``"h"``, an entry of a file, a log column), so that a caller can name its own
    option for it (the command line maps it to its option in one place)."""

    def __init__(self, argument: str, message: str) -> None:
        super().__init__(message)
        self.argument = argument

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:  # survives a worker process
        return type(self), (self.argument, str(self))


class LogFormatError(ArgumentError):
    """A log that cannot be used as it is; ``argument`` names the culprit (a column,
    "t", or the option to change)."""


class MissingArgumentError(ArgumentError):
    """An argument this input needs was not given (a ROS bag read without a
    ``mapping``); ``argument`` names it. The command line ends with exit status 2, as
    for any missing option."""


class VehicleParameterError(ArgumentError):
    """A bad vehicle parameter; ``argument`` names the constructor argument."""


class SweepConfigError(ArgumentError):
    """A bad sweep grid (file or typed config); ``key`` (= ``argument``) names the
    offending entry."""

    @property
    def key(self) -> str:
        """The offending entry of the grid (the same as ``argument``)."""
        return self.argument


class WorkLimitError(ArgumentError):
    """A computation refused before it started: its estimated memory (or work) is
    beyond the stated limit, or a bound with a stated reason (the smallest period, the
    largest order); the message names the argument, the estimate, the limit and how
    to raise it where it can be raised."""


class FileContentError(ArgumentError):
    """A file that cannot be what it should be (not a regular file of a bounded size,
    not UTF-8 text, nested too deep, not TOML or JSON); ``argument`` is the file, and
    the message names it."""


class NotAStoreError(ValueError):
    """A file that is not a sampledyn results store; it was left untouched."""


class SingularPitchError(ValueError):
    """A pitch angle within the tolerance of +-90 deg, where the Euler-angle
    kinematics J(eta) of eq. (6) is singular.

    Attributes
    ----------
    theta : float
        The pitch angle (rad).
    sample : int
        Its index in the batch of states that was checked.
    tolerance_deg : float
    """

    def __init__(self, message: str, theta: float, sample: int, tolerance_deg: float) -> None:
        super().__init__(message)
        self.theta = theta
        self.sample = sample
        self.tolerance_deg = tolerance_deg

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:  # survives a worker process
        return type(self), (str(self), self.theta, self.sample, self.tolerance_deg)


class NumericalError(RuntimeError):
    """A numerical method failed on these inputs (an implicit rule's Newton iteration
    did not converge, the exact-sample integrator could not meet its tolerance); the
    message says what to change (a smaller h, another rule, a looser tolerance)."""


class IntegrationError(NumericalError):
    """The exact-sample integrator could not meet its tolerance."""


class JumpRefused(IntegrationError):
    """f jumps across a switching surface and the motion there is not defined: both
    sides push the state away (non-unique solutions), or it would slide on the
    intersection of two surfaces. The message names the surface, time and state."""


class ConvergenceError(NumericalError):
    """An implicit rule's Newton iteration did not converge."""


class EnvelopeExceeded(RuntimeError):
    """The sampled loop left the state envelope given to
    :func:`sampledyn.run_loop` (it is diverging); the message names the time and the
    states."""


class JacobianUnavailableError(NotImplementedError):
    """The model has no exact Jacobian (sampledyn never falls back to finite
    differences); the message says how to supply one."""


class UnsafeCacheError(PermissionError):
    """A kernel-cache folder or file that another user could have written: refused,
    never used (the message names the reason and the variable to set)."""


class UsageError(Exception):
    """An option that does not apply, or a combination of options that does not
    make sense (exit status 2 of the ``sampledyn`` command)."""
