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
``sampledyn.report`` (``plot_crossing``, ``plot_pitch``, ..., and
``sensitivity_report``, which writes the numbers and figures of
``docs/sensitivity.md``).

Norms: the spectral norm for matrices; for errors and noise, the Euclidean norm over
the six eta components (m and rad mixed) or the six v components (m/s and rad/s
mixed) at one sample, bounded over all samples.
"""

from ._bound import BoundParts as BoundParts
from ._bound import ErrorBound as ErrorBound
from ._bound import assemble_bound as assemble_bound
from ._bound import block_error_norms as block_error_norms
from ._bound import block_noise as block_noise
from ._bound import disturbed_error_bound as disturbed_error_bound
from ._bound import domain_maxima as domain_maxima
from ._bound import exact_reference as exact_reference
from ._bound import jacobian_pair as jacobian_pair
from ._bound import period_ratio as period_ratio
from ._bound import reference_at as reference_at
from ._bound import state_blocks as state_blocks
from ._bound import subsample as subsample
from ._bound import truncation_errors as truncation_errors
from ._bound import truncation_estimate as truncation_estimate
from ._curves import RANK_BY as RANK_BY
from ._curves import ErrorCurves as ErrorCurves
from ._curves import check_tolerance as check_tolerance
from ._curves import error_curves as error_curves
from ._curves import h_grid as h_grid
from ._curves import largest_h as largest_h
from ._curves import rank_key as rank_key
from ._curves import samples_needed as samples_needed
from ._curves import usable_periods as usable_periods
from ._domain import Domain as Domain
from ._domain import check_vehicle as check_vehicle
from ._domain import pitch_guard as pitch_guard
from ._floor import FLOOR_FACTOR as FLOOR_FACTOR
from ._floor import noise_floor_squares as noise_floor_squares
from ._gains import error_constant as error_constant
from ._gains import first_order_gain as first_order_gain
from ._gains import noise_gain as noise_gain
from ._gains import supported_method as supported_method
from ._inputs import gentle_input as gentle_input
from ._inputs import pitch_input as pitch_input
from ._jacobians import BlockMaximum as BlockMaximum
from ._jacobians import J_norm as J_norm
from ._jacobians import JacobianReport as JacobianReport
from ._jacobians import attitude_jacobian as attitude_jacobian
from ._jacobians import dJ_norm as dJ_norm
from ._jacobians import jacobian_bounds as jacobian_bounds
from ._jacobians import jacobian_norms as jacobian_norms
from ._jacobians import spectral_norm as spectral_norm
from ._path import PathPrediction as PathPrediction
from ._path import path_prediction as path_prediction
from ._rates import fastest_time_constant as fastest_time_constant
from ._stability import StabilityLimit as StabilityLimit
from ._stability import jacobian_eigenvalues as jacobian_eigenvalues
from ._stability import stability_limits as stability_limits
from ._sweeps import PitchSensitivity as PitchSensitivity
from ._sweeps import pitch_sensitivity as pitch_sensitivity
from ._sweeps import scaled_inertia as scaled_inertia
from ._validate import measured_errors as measured_errors
from ._validate import raw_errors as raw_errors

__all__ = [
    "RANK_BY",
    "BlockMaximum",
    "BoundParts",
    "Domain",
    "ErrorBound",
    "ErrorCurves",
    "J_norm",
    "JacobianReport",
    "PathPrediction",
    "PitchSensitivity",
    "assemble_bound",
    "attitude_jacobian",
    "block_error_norms",
    "block_noise",
    "check_tolerance",
    "check_vehicle",
    "dJ_norm",
    "disturbed_error_bound",
    "domain_maxima",
    "error_constant",
    "error_curves",
    "exact_reference",
    "fastest_time_constant",
    "first_order_gain",
    "gentle_input",
    "h_grid",
    "jacobian_bounds",
    "jacobian_norms",
    "jacobian_pair",
    "largest_h",
    "measured_errors",
    "noise_gain",
    "path_prediction",
    "period_ratio",
    "pitch_guard",
    "pitch_input",
    "pitch_sensitivity",
    "rank_key",
    "raw_errors",
    "reference_at",
    "scaled_inertia",
    "spectral_norm",
    "state_blocks",
    "subsample",
    "supported_method",
    "truncation_errors",
    "truncation_estimate",
    "samples_needed",
    "usable_periods",
]
