"""The numbers printed in the paper's Fig. 7 (facts quoted for comparison).

Keys: (h in s, eta %, v %). Values: ((position AB1, position AB4), (velocity AB1,
velocity AB4)), the paper's "quadratic norm" of the disturbed local errors.
"""

from __future__ import annotations

FIG7_NOISE_PAIRS: tuple[tuple[float, float], ...] = (
    (0, 0), (2, 0), (10, 0), (20, 0), (0, 2), (0, 10), (0, 20), (2, 2), (10, 10), (20, 20),
    (2, 20), (20, 2),
)  # fmt: skip

_H01 = (
    ((1.6e-5, 2.1e-7), (3.2e-5, 1.1e-5)),
    ((1.3e-4, 1.3e-4), (3.4e-5, 4.4e-5)),
    ((6.4e-4, 6.4e-4), (6.6e-5, 2.1e-5)),
    ((1.3e-3, 1.3e-3), (1.2e-4, 4.3e-4)),
    ((1.8e-5, 2.6e-5), (7.9e-5, 1.1e-4)),
    ((3.9e-5, 1.3e-4), (3.6e-4, 5.3e-4)),
    ((7.3e-5, 2.6e-4), (7.3e-4, 1.1e-3)),
    ((1.3e-4, 1.4e-4), (8.0e-5, 1.0e-4)),
    ((6.6e-4, 7.0e-4), (3.7e-4, 5.2e-4)),
    ((1.3e-3, 1.4e-3), (7.4e-4, 1.1e-3)),
    ((1.8e-4, 3.3e-4), (7.3e-4, 1.1e-3)),
    ((1.3e-3, 1.3e-3), (1.4e-4, 4.2e-4)),
)
_H05 = (
    ((7.9e-4, 4.2e-4), (2.2e-3, 1.2e-3)),
    ((8.3e-4, 5.0e-4), (2.2e-3, 1.3e-3)),
    ((1.5e-3, 1.4e-3), (2.2e-3, 2.5e-3)),
    ((2.7e-3, 2.8e-3), (2.4e-3, 4.4e-3)),
    # The paper prints 4.9e-5 for AB4 here, likely a typo for 4.9e-4 (its own ratio
    # line says "AB1 ~ 1.6xAB4"); kept as printed.
    ((7.9e-4, 4.9e-5), (2.2e-3, 1.5e-3)),
    ((8.6e-4, 1.4e-3), (2.5e-3, 4.3e-3)),
    ((1.1e-3, 2.7e-3), (3.4e-3, 8.6e-3)),
    ((8.5e-4, 6.1e-4), (2.2e-3, 1.5e-3)),
    ((1.7e-3, 2.3e-3), (2.6e-3, 4.8e-3)),
    ((3.1e-3, 4.5e-3), (3.7e-3, 9.5e-3)),
    ((1.2e-3, 2.8e-3), (3.4e-3, 8.6e-3)),
    ((2.7e-3, 2.9e-3), (2.5e-3, 4.5e-3)),
)

PAPER_FIG7: dict[tuple[float, float, float], tuple[tuple[float, float], tuple[float, float]]] = {
    **{(0.1, e, v): vals for (e, v), vals in zip(FIG7_NOISE_PAIRS, _H01, strict=True)},
    **{(0.5, e, v): vals for (e, v), vals in zip(FIG7_NOISE_PAIRS, _H05, strict=True)},
}
