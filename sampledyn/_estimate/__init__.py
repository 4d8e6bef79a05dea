"""Parameter estimation from one-step errors (paper, section 4.2), and the estimated
rules Ee and ABe_s (the method registry lists them as lazy entries that import this
package on first use).

* :func:`estimate`: parameters minimising an l_p norm of a fixed rule's one-step
  errors (exact l_p regression for models linear in their parameters).
* :func:`estimate_and_predict`: the estimate, then the rule's predictions with it.
* :class:`EstimatedAdamsBashforth`: the registered rules "Ee" and "ABe<s>".
"""

from ._estimate import EstimationResult as EstimationResult
from ._estimate import estimate as estimate
from ._estimate import estimate_and_predict as estimate_and_predict
from ._estimated import EstimatedAdamsBashforth as EstimatedAdamsBashforth

__all__ = [
    "EstimatedAdamsBashforth",
    "EstimationResult",
    "estimate",
    "estimate_and_predict",
]
