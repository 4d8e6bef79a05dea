"""Sensitivity of the disturbed local errors to noise, and which model to use.

Paper section 5 (eqs. (11)-(25)) and beyond, for the 6-DoF vehicle of eqs. (5)-(7):

* Jacobian block norms per sample and their maxima over a state :class:`Domain`,
  with the paper's closed forms (19)-(23) and its claim that the maxima sit on the
  domain boundary checked by interior and boundary sampling
  (:func:`jacobian_norms`, :func:`jacobian_bounds`);
* the bound (24)-(25) on the disturbed local errors, part by part, for AB_s (noise
  gain ``h a_s L``), Runge-Kutta and Tustin (their own gains)
  (:func:`disturbed_error_bound`), a first-order prediction along a path
  (:func:`path_prediction`) and a Monte Carlo check of both
  (:func:`monte_carlo_check`);
* sensitivity to the pitch (J singular at 90 deg, :func:`pitch_sensitivity`) and to
  the inertia (:func:`inertia_sensitivity`);
* advice: rules ranked for a vehicle, h and noise level, the largest h under a
  tolerance, and the h where truncation and noise cross (:func:`advise`,
  :func:`plot_crossing`); the report behind ``docs/sensitivity.md``
  (:func:`sensitivity_report`).

Norms: the spectral norm for matrices; for errors and noise, the Euclidean norm over
the six eta components (m and rad mixed) or the six v components (m/s and rad/s
mixed) at one sample, bounded over all samples.
"""

from ._advise import DEFAULT_METHODS as DEFAULT_METHODS
from ._advise import Advice as Advice
from ._advise import AdviceRow as AdviceRow
from ._advise import advise as advise
from ._advise import largest_h as largest_h
from ._bound import BoundParts as BoundParts
from ._bound import ErrorBound as ErrorBound
from ._bound import block_error_norms as block_error_norms
from ._bound import disturbed_error_bound as disturbed_error_bound
from ._bound import truncation_errors as truncation_errors
from ._curves import ErrorCurves as ErrorCurves
from ._curves import error_curves as error_curves
from ._curves import h_grid as h_grid
from ._domain import Domain as Domain
from ._gains import error_constant as error_constant
from ._gains import first_order_gain as first_order_gain
from ._gains import noise_gain as noise_gain
from ._inputs import gentle_input as gentle_input
from ._inputs import pitch_input as pitch_input
from ._jacobians import BlockMaximum as BlockMaximum
from ._jacobians import J_norm as J_norm
from ._jacobians import JacobianReport as JacobianReport
from ._jacobians import dJ_norm as dJ_norm
from ._jacobians import jacobian_bounds as jacobian_bounds
from ._jacobians import jacobian_norms as jacobian_norms
from ._jacobians import spectral_norm as spectral_norm
from ._path import PathPrediction as PathPrediction
from ._path import path_prediction as path_prediction
from ._plots import plot_boundary_map as plot_boundary_map
from ._plots import plot_crossing as plot_crossing
from ._plots import plot_inertia as plot_inertia
from ._plots import plot_noise_growth as plot_noise_growth
from ._plots import plot_pitch as plot_pitch
from ._plots import plot_tightness as plot_tightness
from ._report import sensitivity_report as sensitivity_report
from ._sweeps import InertiaSensitivity as InertiaSensitivity
from ._sweeps import PitchSensitivity as PitchSensitivity
from ._sweeps import inertia_sensitivity as inertia_sensitivity
from ._sweeps import pitch_sensitivity as pitch_sensitivity
from ._sweeps import scaled_inertia as scaled_inertia
from ._validate import MonteCarloRow as MonteCarloRow
from ._validate import measured_errors as measured_errors
from ._validate import monte_carlo_check as monte_carlo_check

__all__ = [
    "DEFAULT_METHODS",
    "Advice",
    "AdviceRow",
    "BlockMaximum",
    "BoundParts",
    "Domain",
    "ErrorBound",
    "ErrorCurves",
    "InertiaSensitivity",
    "J_norm",
    "JacobianReport",
    "MonteCarloRow",
    "PathPrediction",
    "PitchSensitivity",
    "advise",
    "block_error_norms",
    "dJ_norm",
    "disturbed_error_bound",
    "error_constant",
    "error_curves",
    "first_order_gain",
    "gentle_input",
    "h_grid",
    "inertia_sensitivity",
    "jacobian_bounds",
    "jacobian_norms",
    "largest_h",
    "measured_errors",
    "monte_carlo_check",
    "noise_gain",
    "path_prediction",
    "pitch_input",
    "pitch_sensitivity",
    "plot_boundary_map",
    "plot_crossing",
    "plot_inertia",
    "plot_noise_growth",
    "plot_pitch",
    "plot_tightness",
    "scaled_inertia",
    "sensitivity_report",
    "spectral_norm",
    "truncation_errors",
]
