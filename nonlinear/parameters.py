"""Physical ranges of the friction-element parameters (paper Table 3) and the error raised outside them.

Stiffnesses (N/m) and slip forces (N) must be positive and finite, Segalman's exponent chi lies in (-1, 0)
(dissipation power law u^(chi + 3) between 2 and 3), the macroslip-spike ratio beta is non-negative and the
stiction ratio theta = F_S^dynamic / F_S^static lies in [0, 1] (paper Eq. 20).
"""

from __future__ import annotations

import math

import numpy as np


class FrictionParameterError(ValueError):
    """A friction-element parameter is outside its physical range."""


def _require(condition, name: str, requirement: str, values) -> None:
    """Raise FrictionParameterError naming the parameter when ``condition`` (a boolean array or numpy bool, the
    comparison of the values as arrays) fails anywhere."""
    if not condition.all():
        bad = np.asarray(values, dtype=float)[~np.broadcast_to(condition, np.shape(values))]
        raise FrictionParameterError(f"{name} must be {requirement}; got {bad.ravel()[:3].tolist()}")


def check_positive(value, name: str) -> None:
    """Stiffnesses and slip forces: finite and > 0."""
    value = np.asarray(value, dtype=float)
    _require(np.isfinite(value) & (value > 0.0), name, "finite and positive", value)


def check_non_negative(value, name: str) -> None:
    """A stiffness that may vanish (a core spring K_c: 0 is no core): finite and >= 0."""
    value = np.asarray(value, dtype=float)
    _require(np.isfinite(value) & (value >= 0.0), name, "finite and >= 0", value)


def check_jenkins(stiffness, slip_force) -> None:
    """Jenkins element (K_T, F_S)."""
    check_positive(stiffness, "tangential stiffness K_T")
    check_positive(slip_force, "slip force F_S")


def check_iwan(slip_force, stiffness, chi, beta, theta=1.0) -> None:
    """Four- or five-parameter Iwan element (F_S, K_T, chi, beta[, theta])."""
    check_jenkins(stiffness, slip_force)
    chi = np.asarray(chi, dtype=float)
    _require((chi > -1.0) & (chi < 0.0), "Iwan exponent chi", "in the open interval (-1, 0)", chi)
    beta = np.asarray(beta, dtype=float)
    _require(np.isfinite(beta) & (beta >= 0.0), "Iwan macroslip ratio beta", "finite and >= 0", beta)
    check_stiction_ratio(theta)


def check_stiction_ratio(theta) -> None:
    """The stiction ratio theta = F_S^dynamic / F_S^static of an element's law: in [0, 1]."""
    theta = np.asarray(theta, dtype=float)
    _require((theta >= 0.0) & (theta <= 1.0), "stiction ratio theta", "in [0, 1]", theta)


def in_range(slip_force, stiffness, chi, beta, theta, iwan) -> bool:
    """Whether one element's parameters (scalars) lie in their ranges: ``check_iwan``'s conditions for an Iwan
    element (``iwan`` True), ``check_jenkins``'s and ``check_stiction_ratio``'s for a Jenkins one (chi and beta
    unused). Written for numba to compile inside a kernel, whose caller raises the error of those checks where it
    is False."""
    if not (math.isfinite(stiffness) and stiffness > 0.0 and math.isfinite(slip_force) and slip_force > 0.0
            and 0.0 <= theta <= 1.0):
        return False
    return not iwan or (-1.0 < chi < 0.0 and math.isfinite(beta) and beta >= 0.0)
