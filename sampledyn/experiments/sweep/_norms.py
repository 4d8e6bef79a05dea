"""What a cell measures: one norm of the local errors of one rule on one measured
trajectory, over some of the state components and some of the samples.

A norm is written as a string::

    [noise:]KIND[(ARG, ...)][[UNIT, ...]][@MASK[(ARG, ...)]]

* ``KIND``: a norm of :data:`sampledyn._local_errors.ERROR_NORMS` (``rms``, ``max``,
  ``l2_over_n``, ``l2``, ``mean``) of the per-sample Euclidean error norm, or
  ``exceeds(A, B)``: the number of samples whose position/angle error exceeds ``A``
  or whose rate error exceeds ``B`` (used to check a bound sample by sample).
* ``noise:``: the norm of the noise contribution, the disturbed local error minus
  the undisturbed one at the same sample (the same rule on the exact samples).
* ``[UNIT, ...]``: only the state components in these units (e.g. ``[rad]`` for the
  Euler angles of a vehicle).
* ``@MASK``: only the samples the mask keeps (:func:`available_masks`):
  ``away_from_jumps`` (the prediction's history holds no input jump),
  ``smooth`` (also no zero crossing of a state inside ``|.|``), ``pitch_deg(LO, HI)``
  (the largest |theta| over the prediction window lies in [LO, HI) deg).

Every cell stores three numbers of its norm: over the position/angle components
(eta: units m and rad), over the rate components (v: m/s and rad/s), and over all
components (:func:`component_groups`). Samples before ``after`` (s) and samples
without a prediction never count.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from ..._local_errors import (
    ERROR_NORMS,
    ErrorWindow,
    error_window,
    local_errors,
    sums_of_squares,
)
from ..._noise import NOISE_REFERENCE
from ...methods import Predictor, available_methods, get_method
from ...models import Model

__all__ = [
    "ErrorPair",
    "NormSpec",
    "available_masks",
    "away_from_jumps",
    "away_from_kinks",
    "component_groups",
    "measure",
    "parse_norm",
    "smooth_history",
]


def smooth_history() -> int:
    """HISTORY of the masks ``away_from_jumps`` and ``smooth``: 1 + the longest history
    among the registered predictors (their listed orders; 7 with AB6, ABu6, ABj6,
    ABe6), so a kept sample's prediction uses no jump whichever rule made it, and
    every rule's norms count the same samples."""
    rules = (get_method(name) for name in available_methods())
    return 1 + max(m.history for m in rules if isinstance(m, Predictor))


_PARTS = ("disturbed", "noise")
_COUNT_KINDS = {"exceeds": 2}  # kinds this module counts itself, with their arity

_SPEC = re.compile(
    r"^(?:(?P<part>noise):)?"
    r"(?P<kind>[a-z_0-9]+)(?:\((?P<kargs>[^()]*)\))?"
    r"(?:\[(?P<units>[^\[\]]*)\])?"
    r"(?:@(?P<mask>[a-z_]+)(?:\((?P<margs>[^()]*)\))?)?$"
)


def away_from_jumps(u: np.ndarray, history: int) -> np.ndarray:
    """True at samples k whose prediction uses no input jump: u[k-history-1..k-1] constant.

    Parameters
    ----------
    u : ndarray, shape (N, nu)
    history : int
        The longest history among the methods compared (s of the highest AB_s).
    """
    n = u.shape[0]
    jump = np.zeros(n, dtype=bool)
    jump[1:] = (np.diff(u, axis=0) != 0).any(axis=1)  # u[k] differs from u[k-1]
    ok = np.zeros(n, dtype=bool)
    # k is fine when no jump happens at k-history..k-1.
    csum = np.concatenate([[0], np.cumsum(jump)])
    k = np.arange(n)
    lo = np.clip(k - history, 0, n)
    ok[:] = (csum[k] - csum[lo]) == 0
    ok[: history + 1] = False
    return ok


def away_from_kinks(x: np.ndarray, kink_states: tuple[int, ...], history: int) -> np.ndarray:
    """True at samples k with no zero crossing of a kink state in samples k-history..k.

    Where a state inside ``|.|`` (e.g. y in y|y|) crosses zero, f is not smooth and
    every method of order > 2 drops to about order 2 there.
    """
    n = x.shape[0]
    cross = np.zeros(n, dtype=bool)
    for k in kink_states:
        sign = np.sign(x[:, k])
        cross[1:] |= sign[1:] != sign[:-1]
    window = np.convolve(cross.astype(np.int64), np.ones(history + 1, dtype=np.int64))[:n]
    return window == 0


def _mask_jumps(clean: Any, model: Model, history: float | None = None) -> np.ndarray:
    return away_from_jumps(clean.u, smooth_history() if history is None else int(history))


def _mask_smooth(clean: Any, model: Model, history: float | None = None) -> np.ndarray:
    kinks = tuple(getattr(model, "kink_states", ()) or ())
    n = smooth_history() if history is None else int(history)
    return away_from_jumps(clean.u, n) & away_from_kinks(clean.x, kinks, n)


def _mask_pitch(clean: Any, model: Model, lo: float, hi: float, window: float = 5) -> np.ndarray:
    names = tuple(getattr(clean, "state_names", ()) or getattr(model, "state_names", ()))
    if "theta" not in names:
        raise ValueError(
            f"the mask pitch_deg needs a state named 'theta' (pitch, rad); the model's states "
            f"are {', '.join(names) or 'unnamed'}."
        )
    theta = np.degrees(np.abs(clean.x[:, names.index("theta")]))
    w = int(window)
    # Row k predicts sample k from samples k-1 .. k-w+1: its largest |theta| over them
    # (one running maximum: memory of one array whatever the window).
    worst = theta.copy()
    for j in range(1, w):
        np.maximum(worst, np.roll(theta, j), out=worst)
    return (worst >= lo) & (worst < hi)


#: Longest history or window (samples) a mask takes: a prediction's history is at most
#: MAX_AB_ORDER + 1 samples; a thousand is far beyond any rule's.
MAX_MASK_WINDOW = 1000


def _window(value: float, what: str) -> str | None:
    if not float(value).is_integer() or not 1 <= value <= MAX_MASK_WINDOW:
        return (
            f"{what} must be a whole number of samples in 1..{MAX_MASK_WINDOW}, got {value:g}"
            + (" (it would be read as " + f"{int(value)})" if not float(value).is_integer()
               else "")
        )  # fmt: skip
    return None


def _check_history(args: tuple[float, ...]) -> str | None:
    return _window(args[0], "HISTORY") if args else None


def _check_pitch(args: tuple[float, ...]) -> str | None:
    lo, hi = args[0], args[1]
    if not 0 <= lo < hi:
        return f"needs 0 <= LO < HI (deg), got LO = {lo:g}, HI = {hi:g}"
    return _window(args[2], "WINDOW") if len(args) > 2 else None


@dataclass(frozen=True)
class _Mask:
    function: Callable[..., np.ndarray]
    arity: tuple[int, int]  # least and most arguments
    text: str  # "{history}" stands for smooth_history()
    check: Callable[[tuple[float, ...]], str | None] = _check_history

    @property
    def description(self) -> str:
        return self.text.format(history=smooth_history()) if "{history}" in self.text else self.text


_MASKS: dict[str, _Mask] = {
    "away_from_jumps": _Mask(
        _mask_jumps,
        (0, 1),
        "samples whose history (the last HISTORY = {history} samples) holds no input jump",
    ),
    "smooth": _Mask(
        _mask_smooth,
        (0, 1),
        "samples away from input jumps and from zero crossings of the states inside |.| "
        "(last HISTORY = {history} samples)",
    ),
    "pitch_deg": _Mask(
        _mask_pitch,
        (2, 3),
        "samples whose largest |theta| over the last WINDOW = 5 samples is in [LO, HI) deg",
        _check_pitch,
    ),
}


def available_masks() -> dict[str, str]:
    """Mask name -> what it keeps."""
    return {name: m.description for name, m in _MASKS.items()}


def _numbers(text: str | None, where: str) -> tuple[float, ...]:
    if text is None or not text.strip():
        return ()
    out = []
    for part in text.split(","):
        try:
            value = float(part)
        except ValueError:
            raise ValueError(f"{where}: {part.strip()!r} is not a number.") from None
        if not math.isfinite(value):
            raise ValueError(f"{where}: {part.strip()!r} is not finite.")
        out.append(value)
    return tuple(out)


def _fmt(values: Sequence[float]) -> str:
    return ",".join(f"{v:g}" if float(v).is_integer() else repr(float(v)) for v in values)


@dataclass(frozen=True)
class NormSpec:
    """A parsed norm (see the module docstring); :attr:`text` is its canonical form."""

    kind: str
    part: str = "disturbed"
    kind_args: tuple[float, ...] = ()
    units: tuple[str, ...] | None = None
    mask: str | None = None
    mask_args: tuple[float, ...] = ()

    @property
    def text(self) -> str:
        out = "noise:" if self.part == "noise" else ""
        out += self.kind + (f"({_fmt(self.kind_args)})" if self.kind_args else "")
        if self.units is not None:
            out += f"[{','.join(self.units)}]"
        if self.mask is not None:
            out += "@" + self.mask + (f"({_fmt(self.mask_args)})" if self.mask_args else "")
        return out

    @property
    def counts(self) -> bool:
        """True for norms that count samples (``exceeds``) instead of measuring them."""
        return self.kind in _COUNT_KINDS

    def mask_of(self, clean: Any, model: Model) -> np.ndarray | None:
        """The samples this norm keeps, shape (N,), or None for all."""
        if self.mask is None:
            return None
        return np.asarray(_MASKS[self.mask].function(clean, model, *self.mask_args), dtype=bool)


def parse_norm(text: Any) -> NormSpec:
    """A :class:`NormSpec` from its string.

    Raises
    ------
    ValueError
        naming what is wrong and the valid choices.
    """
    if isinstance(text, NormSpec):
        return text
    if not isinstance(text, str):
        raise ValueError(f"a norm must be a string such as 'rms', got {text!r}.")
    m = _SPEC.match(text.replace(" ", ""))
    valid = ", ".join((*ERROR_NORMS, *(f"{k}(A,B)" for k in _COUNT_KINDS)))
    if m is None:
        raise ValueError(
            f"norm {text!r} is not of the form [noise:]KIND[(ARGS)][[UNITS]][@MASK[(ARGS)]], "
            f"e.g. 'rms', 'max[rad]', 'rms@away_from_jumps'; kinds: {valid}."
        )
    kind = m["kind"]
    kargs = _numbers(m["kargs"], f"norm {text!r}")
    if kind in ERROR_NORMS:
        if m["kargs"] is not None:
            raise ValueError(f"norm {text!r}: {kind!r} takes no arguments.")
    elif kind in _COUNT_KINDS:
        if len(kargs) != _COUNT_KINDS[kind]:
            raise ValueError(
                f"norm {text!r}: {kind!r} takes {_COUNT_KINDS[kind]} numbers, e.g. "
                f"'{kind}(0.1,0.2)' (eta limit, v limit)."
            )
    else:
        raise ValueError(f"norm {text!r}: unknown kind {kind!r}; valid: {valid}.")
    units = None
    if m["units"] is not None:
        units = tuple(u.strip() for u in m["units"].split(",") if u.strip())
        bad = [u for u in units if u not in NOISE_REFERENCE]
        if not units or bad:
            raise ValueError(
                f"norm {text!r}: units must be some of {', '.join(NOISE_REFERENCE)}, got "
                f"{m['units']!r}."
            )
    mask = m["mask"]
    margs = _numbers(m["margs"], f"norm {text!r}")
    if mask is not None:
        if mask not in _MASKS:
            raise ValueError(f"norm {text!r}: unknown mask {mask!r}; valid: {', '.join(_MASKS)}.")
        lo, hi = _MASKS[mask].arity
        if not lo <= len(margs) <= hi:
            raise ValueError(
                f"norm {text!r}: mask {mask!r} takes {lo} to {hi} numbers, got {len(margs)}."
            )
        problem = _MASKS[mask].check(margs)
        if problem is not None:
            raise ValueError(f"norm {text!r}: mask {mask!r} {problem}.")
    part = "noise" if m["part"] else "disturbed"
    return NormSpec(kind, part, kargs, units, mask, margs)


@lru_cache(maxsize=64)
def _groups(state_units: tuple[str, ...]) -> dict[str, Any]:
    """:func:`component_groups`, shared (callers read it only)."""
    groups = component_groups(state_units)
    for comps in groups.values():
        if isinstance(comps, np.ndarray):
            comps.setflags(write=False)
    return groups


@lru_cache(maxsize=64)
def _unit_groups(state_units: tuple[str, ...], units: tuple[str, ...]) -> dict[str, Any]:
    """:func:`component_groups` restricted to the components in ``units`` (shared)."""
    keep = np.isin(np.asarray(state_units), units)
    n = len(state_units)
    return {name: _restrict(c, keep, n) for name, c in _groups(state_units).items()}


def component_groups(state_units: Sequence[str]) -> dict[str, Any]:
    """Index sets of the stored groups: "eta" (units m, rad), "v" (m/s, rad/s) and
    "all"; a contiguous set as a slice (numbers as with a slice of the array)."""
    kind = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in state_units])
    groups = {
        "eta": np.flatnonzero(kind == "eta"),
        "v": np.flatnonzero(kind == "v"),
        "all": np.arange(len(state_units)),
    }
    return {name: _as_slice(idx) for name, idx in groups.items()}


def _as_slice(idx: np.ndarray) -> Any:
    if idx.size and (idx.size == 1 or (np.diff(idx) == 1).all()):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def _restrict(comps: Any, keep: np.ndarray, n: int) -> Any:
    idx = np.arange(n)[comps] if isinstance(comps, slice) else comps
    return _as_slice(idx[keep[idx]])


def _empty(comps: Any) -> bool:
    return isinstance(comps, np.ndarray) and comps.size == 0


def _counts(
    n: int, t: np.ndarray, spec: NormSpec, after: float, groups: Mapping[str, Any],
    where: np.ndarray | None, squares: Callable[[Any], np.ndarray],
) -> dict[str, float]:  # fmt: skip
    keep = np.ones(n, dtype=bool) if where is None else where.copy()
    keep &= t >= after - 1e-9 * max(1.0, abs(after))
    over = {}
    for name, limit in zip(("eta", "v"), spec.kind_args, strict=True):
        comps = groups[name]
        if _empty(comps):
            over[name] = np.zeros(n, dtype=bool)
            continue
        sq = squares(comps)
        keep &= ~np.isnan(sq)
        over[name] = np.sqrt(np.where(np.isnan(sq), 0.0, sq)) > limit
    if not keep.any():
        raise ValueError(f"no samples with a prediction at t >= after={after}.")
    return {
        "eta": float((over["eta"] & keep).sum()),
        "v": float((over["v"] & keep).sum()),
        "all": float(((over["eta"] | over["v"]) & keep).sum()),
    }


class ErrorPair:
    """Local errors ``a - b`` (e.g. the measured samples minus a rule's prediction, or
    the disturbed minus the undisturbed local errors), both shape (N, nx): the norms
    of a window of samples are summed from the pair in one pass
    (:meth:`~sampledyn._local_errors.ErrorWindow.norms_of_sets`); the array of the
    errors is formed (:func:`sampledyn.local_errors`, once) only where a norm needs it.

    With ``hw`` the prediction is not an array: ``b`` is f at the samples ``a`` and the
    prediction of row k ``a[k-1] + sum_i hw[., i] b[k-1-i]`` (an Adams-type rule's
    :meth:`sample_filter`), and ``prediction()`` forms it where a norm needs the
    errors as an array.
    """

    def __init__(
        self,
        a: np.ndarray,
        b: np.ndarray,
        hw: np.ndarray | None = None,
        prediction: Callable[[], np.ndarray] | None = None,
    ) -> None:
        self.a, self.b, self.hw = a, b, hw
        self._prediction = prediction
        self._array: np.ndarray | None = None

    def array(self) -> np.ndarray:
        """``a`` minus the prediction, shape (N, nx) (read-only)."""
        if self._array is None:
            b = self.b if self._prediction is None else self._prediction()
            self._array = local_errors(b, self.a)
            self._array.setflags(write=False)
        return self._array


def _noise(noise_err: Callable[[], ErrorPair] | None) -> ErrorPair:
    if noise_err is None:
        raise ValueError("a noise: norm needs the undisturbed local errors.")
    return noise_err()


def _set_key(comps: Any) -> tuple[int, ...]:
    return tuple(range(comps.start, comps.stop)) if isinstance(comps, slice) else tuple(comps)


class _Squares:
    """The per-sample sums of squares of one error array over every component set the
    norms ask for, all computed in one pass over the samples on first use
    (:func:`sampledyn.errors.sums_of_squares`)."""

    def __init__(self, data: Callable[[], np.ndarray]) -> None:
        self._data = data
        self._sets: dict[tuple[int, ...], Any] = {}
        self._sq: dict[tuple[int, ...], np.ndarray] | None = None

    def want(self, comps: Any) -> None:
        if not _empty(comps):
            self._sets.setdefault(_set_key(comps), comps)

    def __call__(self, comps: Any) -> np.ndarray:
        if self._sq is None:
            keys = list(self._sets)
            rows = sums_of_squares(self._data(), [self._sets[k] for k in keys])
            self._sq = dict(zip(keys, rows, strict=True))
        return self._sq[_set_key(comps)]


def _in_one_pass(
    batches: Mapping[tuple[Any, ...], list[NormSpec]],
    uses: Mapping[tuple[Any, ...], Mapping[str, Any]],
    pairs: Mapping[str, Callable[[], ErrorPair]],
    windows: Mapping[Any, ErrorWindow],
) -> dict[tuple[Any, ...], dict[str, dict[str, float]]]:
    """Batch key -> group name -> kind -> value, for the batches (not counts) whose
    norms one pass over each (errors, window) gives; those it cannot give (the kinds
    "max" and "mean", a mask that keeps scattered samples, a NaN, a non-uniform grid)
    are left out."""
    together: dict[tuple[Any, ...], list[tuple[Any, ...]]] = {}
    for key, batch in batches.items():
        if not batch[0].counts:
            together.setdefault((batch[0].part, key[-1]), []).append(key)
    found: dict[tuple[Any, ...], dict[str, dict[str, float]]] = {}
    for (part, wkey), keys in together.items():
        sets = {_set_key(c): c for k in keys for c in uses[k].values() if not _empty(c)}
        if not sets or wkey not in windows:
            continue
        kinds = tuple(dict.fromkeys(s.kind for k in keys for s in batches[k]))
        pair = pairs[part]()
        got = windows[wkey].norms_of_sets(pair.a, pair.b, tuple(sets), kinds, pair.hw)
        if got is None:
            continue
        by_set = dict(zip(sets, got, strict=True))
        for k in keys:
            found[k] = {
                name: dict.fromkeys(kinds, math.nan) if _empty(c) else by_set[_set_key(c)]
                for name, c in uses[k].items()
            }
    return found


def _of_squares(
    batch: list[NormSpec], use: Mapping[str, Any], window: ErrorWindow, sq: _Squares
) -> dict[str, dict[str, float]]:
    """Group name -> kind -> value of ``batch`` from the per-sample sums of squares
    (where :func:`_in_one_pass` does not apply)."""
    kinds = tuple(dict.fromkeys(s.kind for s in batch))
    return {
        name: dict.fromkeys(kinds, math.nan)
        if _empty(comps)
        else window.norms_of_squares(sq(comps), kinds)
        for name, comps in use.items()
    }


def _batches(
    specs: Sequence[NormSpec],
    t: np.ndarray,
    after: float,
    masks: Mapping[NormSpec, np.ndarray | None],
    windows: dict[Any, ErrorWindow],
) -> dict[tuple[Any, ...], list[NormSpec]]:
    """The specs by what they measure: norms over the same data, components and samples
    (the last entry of the key: their window's, made here if it can be) share a pass."""
    batches: dict[tuple[Any, ...], list[NormSpec]] = {}
    for spec in specs:
        where = masks.get(spec)
        wkey = (id(t), id(where), after)
        key = (spec.part, spec.units, spec.mask, spec.mask_args, spec.counts, spec.kind_args,
               wkey)  # fmt: skip
        if key not in batches and not spec.counts and wkey not in windows:
            try:
                windows[wkey] = error_window(t, after, where)
            except ValueError:
                pass  # said by measure, per batch
        batches.setdefault(key, []).append(spec)
    return batches


def measure(
    specs: Sequence[NormSpec],
    err: ErrorPair,
    t: np.ndarray,
    after: float,
    state_units: Sequence[str],
    masks: Mapping[NormSpec, np.ndarray | None],
    noise_err: Callable[[], ErrorPair] | None = None,
    windows: dict[Any, ErrorWindow] | None = None,
) -> dict[NormSpec, tuple[dict[str, float], str]]:
    """The numbers of every norm in ``specs`` for one rule on one measured trajectory.

    Parameters
    ----------
    specs : sequence of NormSpec
    err : ErrorPair
        Disturbed local errors, shape (N, nx) (NaN rows: no prediction): the samples
        and the prediction.
    t : ndarray, shape (N,)
        Sample times (s).
    after : float
        Samples with t >= after count (s).
    state_units : sequence of str
        Units of the state components (they define the eta/v groups).
    masks : mapping NormSpec -> bool array (N,) or None
        Each spec's samples (:meth:`NormSpec.mask_of` on the exact samples).
    noise_err : callable, optional
        Returns the noise contributions (disturbed minus undisturbed local errors, as
        an ErrorPair); called only if a ``noise:`` norm is asked for.
    windows : dict, optional
        Kept by the caller across calls on the same ``t`` and masks (objects that stay
        alive meanwhile): the samples each mask counts are found once.

    Returns
    -------
    dict spec -> ({"eta": value, "v": value, "all": value}, error message or "").
    A norm that has no sample to measure gets NaN and the reason.
    """
    groups = _groups(tuple(state_units))
    out: dict[NormSpec, tuple[dict[str, float], str]] = {}
    windows = {} if windows is None else windows  # the samples the norms count
    batches = _batches(specs, t, after, masks, windows)
    noise_pair: list[ErrorPair] = []

    def noise() -> ErrorPair:
        if not noise_pair:
            noise_pair.append(_noise(noise_err))
        return noise_pair[0]

    pairs = {"disturbed": lambda: err, "noise": noise}
    squares = {"disturbed": _Squares(err.array), "noise": _Squares(lambda: noise().array())}
    uses = {}
    for key, batch in batches.items():
        use = groups
        if batch[0].units is not None:
            use = _unit_groups(tuple(state_units), tuple(batch[0].units))
        uses[key] = use
        for comps in use.values():
            squares[batch[0].part].want(comps)
    try:
        found = _in_one_pass(batches, uses, pairs, windows)
    except ValueError:
        found = {}  # each batch says why below
    for key, batch in batches.items():
        first = batch[0]
        sq = squares[first.part]
        use = uses[key]
        where = masks.get(first)
        try:
            if first.counts:
                out[first] = (_counts(err.a.shape[0], t, first, after, use, where, sq), "")
                continue
            per_group = found.get(key)
            if per_group is None:
                if key[-1] not in windows:
                    windows[key[-1]] = error_window(t, after, where)
                per_group = _of_squares(batch, use, windows[key[-1]], sq)
            for spec in batch:
                out[spec] = ({name: v[spec.kind] for name, v in per_group.items()}, "")
        except ValueError as exc:
            reason = str(exc)
            if first.mask is not None:
                reason = (
                    f"no sample at t >= after={after:g} s is kept by the mask {first.mask} "
                    f"({_MASKS[first.mask].description})"
                )
            for spec in batch:
                out[spec] = (dict.fromkeys(groups, math.nan), reason)
    return out
