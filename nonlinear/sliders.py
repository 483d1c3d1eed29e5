"""Discretised hysteretic elements: a finite set of parallel Jenkins sliders, for time-domain simulation.

A slider j is a spring k_j (N/m) in series with a Coulomb slider of static strength f_j (N) that carries
theta f_j while sliding (stiction ratio, paper Eq. 20; theta = 1 is plain Coulomb). Its state is the slider
position p_j (m) and the direction d_j in {-1, 0, +1} in which it last slid (0: never). The element force is
sum_j k_j (u - p_j).

- A Jenkins element (paper 4.3.1) is one slider; a linear spring is a slider of infinite strength.
- An Iwan element (paper Eq. 16) is discretised into sliders that split the continuous part of the
  slip-displacement density R phi^chi into intervals, each slider placed at the stiffness-weighted mean
  slip displacement of its interval (so the macroslip force is exact), plus one slider for the spike
  S delta(phi - phi_max) when beta > 0.

Arrays broadcast: sliders are the last axis, any leading axes are elements.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from nonlinear.iwan import segalman_constants
from nonlinear.parameters import check_iwan, check_jenkins


class Sliders(NamedTuple):
    """Parallel sliders of one element: stiffness (..., n) N/m, static strength (..., n) N, stiction ratio."""

    stiffness: np.ndarray
    strength: np.ndarray
    theta: float | np.ndarray = 1.0


def jenkins_sliders(stiffness, slip_force) -> Sliders:
    """A Jenkins element (K_T, F_S) as a single slider."""
    check_jenkins(stiffness, slip_force)
    return Sliders(np.asarray(stiffness, float)[..., None],
                   np.asarray(slip_force, float)[..., None], 1.0)


def iwan_sliders(slip_force, stiffness, chi, beta, theta=1.0, count: int = 200, relative_spacing: float = 4e-3,
                 smallest: float = 1e-4) -> Sliders:
    """A four- (theta = 1) or five-parameter Iwan element as a few thousand sliders (scalar parameters).

    The scaled slip displacement y = phi / phi_max in (0, 1) is cut at the union of ``count`` intervals of
    equal stiffness, b = (j / count)^(1 / (chi + 1)), and a geometric grid of ratio 1 + ``relative_spacing``
    from ``smallest`` to 1. Interval [a, b] becomes one slider of stiffness r (b^(chi+1) - a^(chi+1)) /
    (phi_max (chi + 1)) at y = (chi+1)/(chi+2) (b^(chi+2) - a^(chi+2)) / (b^(chi+1) - a^(chi+1)), the
    stiffness-weighted mean, so the macroslip force is exact. The geometric grid bounds the relative spacing of
    the sliders, which sets the error of the loop area: with stiction (theta < 1) each slider adds a finite
    4 (1 - theta) k phi^2 when it breaks loose, so the dissipation is a staircase of relative step
    ~ ``relative_spacing``. Amplitudes below ``smallest`` phi_max are not resolved.
    """
    check_iwan(slip_force, stiffness, chi, beta, theta)
    phi_max, r, s = segalman_constants(slip_force, stiffness, chi, beta)
    equal_stiffness = (np.arange(count + 1) / count) ** (1.0 / (chi + 1.0))
    geometric = smallest * (1.0 + relative_spacing) ** np.arange(np.ceil(np.log(1.0 / smallest)
                                                                          / np.log1p(relative_spacing)))
    bounds = np.unique(np.concatenate([equal_stiffness, geometric[geometric < 1.0]]))
    a, b = bounds[:-1], bounds[1:]
    share = b ** (chi + 1.0) - a ** (chi + 1.0)
    position = (chi + 1.0) / (chi + 2.0) * (b ** (chi + 2.0) - a ** (chi + 2.0)) / share
    slider_stiffness = np.append(r * share / (phi_max * (chi + 1.0)), s / phi_max)
    slip_displacement = phi_max * np.append(position, 1.0)
    present = slider_stiffness > 0.0  # beta = 0: no spike
    return Sliders(slider_stiffness[present], (slider_stiffness * slip_displacement)[present], theta)


def with_linear_spring(sliders: Sliders, stiffness: float) -> Sliders:
    """An element's sliders with a linear spring of ``stiffness`` (N/m) in parallel: one more slider of infinite
    strength, which never slips (a stuck core)."""
    return Sliders(np.append(sliders.stiffness, stiffness), np.append(sliders.strength, np.inf), sliders.theta)


def initial_state(sliders: Sliders):
    """Virgin state: slider positions (m) and last sliding directions (0: never slipped), all zero."""
    return np.zeros_like(sliders.stiffness), np.zeros_like(sliders.stiffness)


def slider_response(displacement, position, direction, sliders: Sliders):
    """Return mapping of every slider for a new element displacement u (m), following Masing's rules.

    displacement: (...,) relative displacement of each element; position, direction: (..., n) state.
    Returns force (...,) N, tangent (...,) N/m, and the new position and last sliding direction.

    A virgin slider breaks loose when |k (u - p)| exceeds its static strength f and then slides at theta f.
    Once it has slid in direction d it slides again in that direction as soon as d k (u - p) reaches theta f
    (Masing's second rule: rejoin the previous curve) and breaks loose backwards when the force has changed
    by 2 f from theta f d (Masing's first rule: the reversal curve is the backbone doubled, paper Eq. 12).
    This Masing stiction slider is what the paper's Eqs. (21)-(22) describe; a slider that breaks loose at
    |force| = f in both directions dissipates less than Eq. (22) whenever theta < 1. For theta = 1 both are
    the ordinary Coulomb slider.
    """
    k, f, theta = sliders
    u = np.asarray(displacement, dtype=float)[..., None]
    trial = k * (u - position)
    forward = direction * trial
    virgin = direction == 0.0
    slides_on = ~virgin & (forward >= theta * f)
    slides_back = ~virgin & (forward < (theta - 2.0) * f)
    breaks_virgin = virgin & (np.abs(trial) > f)
    new_direction = np.where(slides_back, -direction, np.where(breaks_virgin, np.sign(trial), direction))
    sliding = slides_on | slides_back | breaks_virgin
    slider_force = np.where(sliding, new_direction * theta * f, trial)
    new_position = np.where(sliding, u - slider_force / k, position)
    tangent = np.where(sliding, 0.0, k)
    return slider_force.sum(axis=-1), tangent.sum(axis=-1), new_position, new_direction
