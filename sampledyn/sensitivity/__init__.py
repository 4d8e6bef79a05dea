"""Sensitivity of the disturbed local errors to noise: analysis only.

Paper section 5 (eqs. (11)-(25)) and beyond, for the 6-DoF vehicle of eqs. (5)-(7),
as functions of given data (nothing here simulates, runs a Monte Carlo loop or
plots):

* Jacobian block norms per sample and their maxima over a state :class:`Domain`,
  with the paper's closed forms (19)-(23) and its claim that the maxima sit on the
  domain boundary checked by interior and boundary sampling
  (:func:`jacobian_norms`, :func:`jacobian_bounds`);
* the bound (24)-(25) on the disturbed local errors, part by part, for AB_s (noise
  gain ``h a_s L``), Runge-Kutta and Tustin (their own gains), on given exact samples
  (:func:`disturbed_error_bound`), and a first-order prediction along a path
  (:func:`path_prediction`; any model whose states are positions/angles and rates,
  :func:`state_blocks`);
* truncation and noise against h from one reference run (:func:`error_curves`) and
  the largest h under a tolerance (:func:`largest_h`);
* sensitivity to the pitch (J singular at 90 deg, :func:`pitch_sensitivity`) and a
  vehicle of scaled inertia (:func:`scaled_inertia`);
* the noise floor: the one-step error measurement noise alone gives through a rule
  (:func:`noise_floor_squares`);
* stability before prediction: the largest step at which each rule is stable along
  sampled data, from the Jacobian's eigenvalues and the rule's own stability
  function or region (:func:`stability_limits`);
* the reference inputs of the analysis (:func:`gentle_input`, :func:`pitch_input`).

The studies that simulate and measure live in the experiment layer, on its engine:
``sampledyn.experiments.advise`` (also ``sd.advise``), ``monte_carlo_check``,
``inertia_sensitivity`` and ``sensitivity_study``; the figures in
``sampledyn.report`` (``sensitivity_report`` writes the numbers and figures of
``docs/sensitivity.md``).

Norms: the spectral norm for matrices; for errors and noise, the Euclidean norm over
the six eta components (m and rad mixed) or the six v components (m/s and rad/s
mixed) at one sample, bounded over all samples.
"""

from ._bound import disturbed_error_bound as disturbed_error_bound
from ._bound import state_blocks as state_blocks
from ._bound import subsample as subsample
from ._curves import error_curves as error_curves
from ._curves import largest_h as largest_h
from ._domain import Domain as Domain
from ._floor import noise_floor_squares as noise_floor_squares
from ._gains import error_constant as error_constant
from ._gains import first_order_gain as first_order_gain
from ._gains import noise_gain as noise_gain
from ._inputs import gentle_input as gentle_input
from ._inputs import pitch_input as pitch_input
from ._jacobians import jacobian_bounds as jacobian_bounds
from ._jacobians import jacobian_norms as jacobian_norms
from ._path import path_prediction as path_prediction
from ._rates import fastest_time_constant as fastest_time_constant
from ._stability import stability_limits as stability_limits
from ._sweeps import pitch_sensitivity as pitch_sensitivity
from ._sweeps import scaled_inertia as scaled_inertia

__all__ = [
    "Domain",
    "disturbed_error_bound",
    "error_constant",
    "error_curves",
    "fastest_time_constant",
    "first_order_gain",
    "gentle_input",
    "jacobian_bounds",
    "jacobian_norms",
    "largest_h",
    "noise_floor_squares",
    "noise_gain",
    "path_prediction",
    "pitch_input",
    "pitch_sensitivity",
    "scaled_inertia",
    "stability_limits",
    "state_blocks",
    "subsample",
]
