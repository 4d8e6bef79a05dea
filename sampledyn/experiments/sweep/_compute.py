"""What a worker runs: the exact samples of one simulation, then chunks of cells on
them. This is the one cell function of every study (sweeps, Figs. 2, 3 and 7, the
Monte Carlo of ``advise``, the bound validation).

Both functions are pure (same arguments, same numbers, on any worker) and return
plain picklable values; only the client writes the results store.

A deterministic failure of a cell (e.g. the vehicle pitching through 90 deg, where
J(eta) is singular) is returned as a row with status "error" and the message, so the
sweep goes on and a rerun does not retry it (``--retry-failed`` does).

Which model and which input a rule predicts with
------------------------------------------------
This is the one place that decides it (:func:`prediction_inputs`).

* Open loop: every rule predicts with the model and the sampled input; the rules
  that evaluate f between samples (RK_s, Tustin: ``method.intersample``) take the
  input between samples from the signal.
* Closed loop (a plant closed by a feedback law): the data are what a log records,
  the states and the plant input the law applied (the measured input n_delta of the
  paper's Fig. 1). Rules that use f at the samples only (E, AB_s, ABu_s, the
  estimated rules, ...) predict with the plant and that applied input; they need
  nothing else. Rules that evaluate f between samples need the plant input between
  samples, which only the loop knows: they predict with the closed-loop model, fed
  with the reference input at the samples and, between them, from the signal.
"""

from __future__ import annotations

import os
import pickle
import socket
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..._local_errors import local_errors
from ..._noise import add_noise
from ..._predict import check_measured, predict
from ..._simulate import simulate
from ..._trajectory import Trajectory
from ...exceptions import ConvergenceError, IntegrationError
from ...methods import get_method
from ...models import ClosedLoop, Model
from ._cells import Chunk, Group, Setup, SimPlan
from ._norms import ErrorPair, NormSpec, measure, parse_norm
from ._summaries import summarize_trajectory

__all__ = [
    "ChunkResult",
    "SimResult",
    "compute_chunk",
    "exact_samples",
    "prediction_inputs",
    "simulate_trajectory",
]

# Failures that are a property of the cell (deterministic), recorded as its result.
CELL_ERRORS = (ValueError, ArithmeticError, IntegrationError, ConvergenceError)
_MAX_MESSAGE = 400


@dataclass(frozen=True)
class SimResult:
    """The exact samples of one trajectory (``traj`` None if simulation failed).

    ``traj`` holds what a log records (states and the plant input; in a closed loop
    the input the law applied); ``reference_u`` the reference input at the samples of
    a closed loop (None in open loop); ``input_index`` the study input it came from;
    ``data`` what a study of another cell kind shares between the cells of the
    trajectory (picklable).
    """

    traj_key: str
    traj: Trajectory | None
    meta: dict[str, Any] = field(default_factory=dict)
    reference_u: np.ndarray | None = None
    input_index: int = 0
    data: Any = None


@dataclass(frozen=True)
class ChunkResult:
    """Rows of one chunk: dicts with the key, status, norms, timing and messages."""

    traj_key: str
    sim_meta: dict[str, Any]
    rows: list[dict[str, Any]]


def _worker() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _messages(caught: list[warnings.WarningMessage]) -> str:
    text = "; ".join(dict.fromkeys(str(w.message) for w in caught))
    return text[:_MAX_MESSAGE]


def exact_samples(
    model: Model, signal: Any, T: float, h: float, x0: Any = None, rtol: float = 1e-12
) -> Trajectory:
    """The engine's exact samples of ``model`` under ``signal``: :func:`sampledyn.simulate`
    with ``rtol`` = ``atol``, certified. Studies that need the samples in hand (the
    analysis of ``advise``) take them from here and give them to the engine as
    ``reference``, so they are simulated once."""
    return simulate(model, signal, T=T, h=h, x0=x0, rtol=rtol, atol=rtol)


def simulate_trajectory(setup: Setup, sim: SimPlan) -> dict[str, SimResult]:
    """The exact samples of ``sim`` (simulated once, or taken from the study's
    reference samples) for each of its trajectories: every k-th sample, with the
    certificate and the summaries kept in ``meta`` only.

    Returns
    -------
    dict traj_key -> SimResult
    """
    t0 = time.perf_counter()
    worker = _worker()
    signal = setup.signals[sim.input_index]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if setup.reference is not None:
                base = setup.reference
            else:
                base = exact_samples(setup.model, signal, setup.T, sim.h, setup.x0, setup.rtol)
        except CELL_ERRORS as exc:
            failed = {
                "worker": worker,
                "status": "error",
                "error": f"exact samples failed: {exc}"[:_MAX_MESSAGE],
                "seconds": time.perf_counter() - t0,
                "warnings": _messages(caught),
                "simulated_h": sim.h,
            }
            return {
                key: SimResult(key, None, {**failed, "h": h}, None, sim.input_index)
                for key, h, _k in sim.members
            }
        seconds = time.perf_counter() - t0
        out = {}
        for i, (key, h, k) in enumerate(sim.members):
            exact = base if k == 1 else base.subsample(k)
            cert = exact.certificate
            meta: dict[str, Any] = {
                "h": h,
                "worker": worker,
                "status": "ok",
                "error": "",
                "seconds": seconds if i == 0 else 0.0,
                "n_samples": exact.n_samples,
                "certificate": cert.max_error if cert is not None else float("nan"),
                "simulated_h": sim.h,
            }
            try:
                meta["summary"] = summarize_trajectory(setup.summaries, setup.model, exact)
            except CELL_ERRORS as exc:
                meta["summary"] = {}
                warnings.warn(f"trajectory summary failed: {exc}", stacklevel=1)
            reference_u = None
            if setup.closed_loop:
                plant = setup.plant
                applied = cast(ClosedLoop, setup.model).applied_input(exact.t, exact.x, exact.u)
                reference_u = exact.u
                exact = exact.replace(
                    u=applied,
                    input_names=tuple(plant.input_names),
                    input_units=tuple(getattr(plant, "input_units", ()) or ()),
                )
            # The certificate's per-interval arrays are summarised above; do not ship them.
            out[key] = SimResult(
                key, exact.replace(certificate=None, clean=None), meta, reference_u,
                sim.input_index,
            )  # fmt: skip
    msgs = _messages(caught)
    for res in out.values():
        res.meta["warnings"] = msgs
    return out


def prediction_inputs(
    model: Model, method: Any, measured: Trajectory, reference: Trajectory | None, signal: Any
) -> tuple[Any, Trajectory, Any]:
    """(model, data, signal) ``method`` predicts with (see the module docstring).

    Parameters
    ----------
    model : Model
        The simulated model: a :class:`sampledyn.models.ClosedLoop` (plant and law)
        or an open-loop model.
    method : method object
    measured : Trajectory
        The log: states and the plant input (the applied one, in a closed loop).
    reference : Trajectory or None
        The same samples with the reference input of a closed loop (None in open loop).
    signal : Signal
        The input between samples (the reference, in a closed loop).
    """
    if not isinstance(model, ClosedLoop):
        return model, measured, signal
    if method.intersample:
        return model, reference if reference is not None else measured, signal
    return model.plant, measured, None


#: Stage inputs of the last grids this process computed, by signal (its pickle: a task
#: brings its own copy of the same signal) and grid; a worker's chunks of one
#: trajectory ask for the same ones. A few entries of (N - 1, nu) floats.
_STAGE_INPUTS: dict[tuple[bytes, int, float, float, float], np.ndarray] = {}
_STAGE_INPUTS_KEPT = 8


class _MemoSignal:
    """A signal whose stage inputs are computed once per grid: every seed of a chunk,
    and every chunk of the trajectory on this worker, asks for the same
    ``intersample(t, tau)`` (signals are pure: the same state, the same inputs)."""

    def __init__(self, signal: Any) -> None:
        self._signal = signal
        self.nu = signal.nu
        try:
            self._name = pickle.dumps(signal)
            self._cache = _STAGE_INPUTS
        except (pickle.PicklingError, TypeError, AttributeError):  # a serial run: own memo
            self._name, self._cache = b"", {}

    def __call__(self, t: Any) -> np.ndarray:
        return self._signal(t)

    def intersample(self, t_start: np.ndarray, tau: float) -> np.ndarray:
        key = (self._name, t_start.shape[0], float(t_start[0]), float(t_start[-1]), float(tau))
        if key not in self._cache:
            while len(self._cache) >= _STAGE_INPUTS_KEPT:
                del self._cache[next(iter(self._cache))]  # the oldest
            u = np.asarray(self._signal.intersample(t_start, tau), dtype=float)
            u.setflags(write=False)
            self._cache[key] = u
        return self._cache[key]


class _Context:
    """What the groups of one chunk share: the exact samples, the signal, the masks
    and the undisturbed local errors of each rule."""

    def __init__(self, setup: Setup, sim: SimResult) -> None:
        assert sim.traj is not None
        self.setup = setup
        self.traj = sim.traj
        self.reference_u = sim.reference_u
        self.signal = _MemoSignal(setup.signals[sim.input_index])
        self._specs: dict[str, NormSpec] = {}
        self._masks: dict[NormSpec, np.ndarray | None] = {}
        self._clean: dict[str, np.ndarray] = {}
        self._methods: dict[str, Any] = {}
        self.windows: dict[Any, Any] = {}  # samples counted per (t, mask): measure's

    def method(self, name: str) -> Any:
        """The method object of ``name`` (built once per chunk, not per group)."""
        if name not in self._methods:
            self._methods[name] = get_method(name)
        return self._methods[name]

    def spec(self, norm: str) -> NormSpec:
        if norm not in self._specs:
            self._specs[norm] = parse_norm(norm)
        return self._specs[norm]

    def masks(self, specs: list[NormSpec]) -> Mapping[NormSpec, np.ndarray | None]:
        for s in specs:
            if s not in self._masks:
                self._masks[s] = s.mask_of(self.traj, self.setup.model)
        return self._masks

    def with_reference(self, data: Trajectory) -> Trajectory | None:
        return None if self.reference_u is None else data.replace(u=self.reference_u)

    def clean_errors(self, method: Any) -> np.ndarray:
        """Undisturbed local errors of ``method`` (on the exact samples)."""
        if method.name not in self._clean:
            clean = self.traj
            model, data, signal = prediction_inputs(
                self.setup.model, method, clean, self.with_reference(clean), self.signal
            )
            x_hat = predict(method, model, data, signal)
            self._clean[method.name] = local_errors(x_hat, clean)
        return self._clean[method.name]


def _noise_part(ctx: _Context, method: Any, err: ErrorPair) -> Callable[[], ErrorPair]:
    """The noise contributions (disturbed minus undisturbed local errors), on demand."""

    def part() -> ErrorPair:
        return ErrorPair(err.array(), ctx.clean_errors(method))

    return part


def _errors(
    method: Any, model: Any, data: Trajectory, signal: Any, measured: Trajectory, cache: dict
) -> ErrorPair:
    """The disturbed local errors of ``method`` predicting ``measured`` from ``data``
    (its samples, with the input the rule uses). A rule that is a filter over f at the
    samples (``sample_filter``: the Adams rules) hands over f and its weights, and the
    norms form the rows they count in one pass; any other is :func:`predict`-ed."""

    def prediction() -> np.ndarray:
        return predict(method, model, data, signal, cache=cache)

    sample_filter = getattr(method, "sample_filter", None)
    if sample_filter is not None and data.x is measured.x:
        try:
            check_measured(model, data)
            f, hw = sample_filter(model, data, cache=cache)
        except CELL_ERRORS:
            pass  # predict() raises it, in its words
        else:
            return ErrorPair(measured.x, f, hw, prediction)
    return ErrorPair(measured.x, prediction())


def _group_rows(ctx: _Context, group: Group) -> list[dict[str, Any]]:
    setup = ctx.setup
    t_group = time.perf_counter()
    seq = np.random.SeedSequence([setup.base_seed, group.seed])
    measured = add_noise(ctx.traj, group.eta_pct, group.v_pct, seq, distribution=setup.distribution)
    reference = ctx.with_reference(measured)
    cache: dict[Any, Any] = {}  # f at the samples, shared by every AB-type rule
    by_method: dict[str, list[tuple[str, str]]] = {}
    for key, name, norm in group.cells:
        by_method.setdefault(name, []).append((key, norm))
    rows: list[dict[str, Any]] = []
    shared = time.perf_counter() - t_group
    for method_name, cells in by_method.items():
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                method = ctx.method(method_name)
                model, data, signal = prediction_inputs(
                    setup.model, method, measured, reference, ctx.signal
                )
                err = _errors(method, model, data, signal, measured, cache)
                specs = [ctx.spec(norm) for _key, norm in cells]
                found = measure(
                    specs,
                    err,
                    measured.t,
                    setup.after,
                    measured.state_units,
                    ctx.masks(specs),
                    noise_err=_noise_part(ctx, method, err),
                    windows=ctx.windows,
                )
                values = [(key, *found[ctx.spec(norm)]) for key, norm in cells]
            except CELL_ERRORS as exc:
                message = f"{type(exc).__name__}: {exc}"[:_MAX_MESSAGE]
                values = [(key, {}, message) for key, _norm in cells]
        seconds = (time.perf_counter() - t0 + shared / len(by_method)) / len(cells)
        msgs = _messages(caught)
        for key, norms, error in values:
            rows.append(
                {
                    "key": key,
                    "status": "error" if error else "ok",
                    "values": {
                        "err_eta": norms.get("eta", float("nan")),
                        "err_v": norms.get("v", float("nan")),
                        "err_all": norms.get("all", float("nan")),
                    },
                    "seconds": seconds,
                    "error": error[:_MAX_MESSAGE],
                    "warnings": msgs,
                }
            )
    return rows


def compute_chunk(setup: Setup, sim: SimResult, chunk: Chunk) -> ChunkResult:
    """Every cell of ``chunk`` on the exact samples ``sim``."""
    worker = _worker()
    rows: list[dict[str, Any]] = []
    if sim.traj is None:
        for group in chunk.groups:
            for key, _method, _norm in group.cells:
                rows.append(
                    {
                        "key": key,
                        "status": "error",
                        "values": {},
                        "seconds": 0.0,
                        "error": sim.meta.get("error", "exact samples failed"),
                        "warnings": sim.meta.get("warnings", ""),
                    }
                )
    else:
        ctx = _Context(setup, sim)
        for group in chunk.groups:
            rows.extend(_group_rows(ctx, group))
    for r in rows:
        r["worker"] = worker
    return ChunkResult(chunk.traj_key, sim.meta, rows)
