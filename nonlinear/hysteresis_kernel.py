"""The AFT's time loop compiled: the registry's sliders stepped through whole periods until their state repeats.

The same return mapping as ``nonlinear.sliders.slider_response`` (Masing's rules with stiction, one slider at a
time), the same stopping rule and Jacobian as ``nonlinear.harmonic_balance.periodic_hysteresis_reference``, the
readable numpy oracle it is tested against; the loop over samples, which numpy runs one Python step per sample,
is here one compiled loop, and the Jacobian is summed as the sliders are stepped.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def slider_periods(displacement, position, direction, stiffness, strength, theta, element_stiffness, max_periods,
                   tolerance):
    """Step every slider through the periodic displacement (n_t, N) m from its state (position m, direction),
    arrays (n_t, n_sliders) (copied), until the state at a period's end equals that at its start (positions
    within ``tolerance`` m, directions exactly) or ``max_periods`` ran. theta: (n_t,) stiction ratios;
    element_stiffness: (n_t,) K_d, N/m.

    Returns the last period's element forces (n_t, N) N and the Jacobian dg(n)/du(m) (n_t, N, N) N/m of its slip
    deficit g = K_d u - f (``nonlinear.harmonic_balance.hysteresis_jacobian``: a slider stuck at n adds k_j at
    (n, m), m its last slip in this period or the ones before; K_d less the stuck sliders' stiffness on the
    diagonal), the periods run, whether the last was periodic, and the final position and direction."""
    n_elements, samples = displacement.shape
    n_sliders = stiffness.shape[1]
    position, direction = position.copy(), direction.copy()
    force = np.zeros((n_elements, samples))
    jacobian = np.zeros((n_elements, samples, samples))
    last_slip = -np.ones((n_elements, n_sliders), dtype=np.int64)
    periods, periodic = 0, False
    while periods < max_periods and not periodic:
        periodic = True
        force[:] = 0.0
        jacobian[:] = 0.0
        for e in range(n_elements):
            for n in range(samples):
                jacobian[e, n, n] = element_stiffness[e]
            for j in range(n_sliders):
                if stiffness[e, j] == 0.0:  # padding (``stacked_sliders``): never slides, carries nothing
                    continue
                k, f, p, d = stiffness[e, j], strength[e, j], position[e, j], direction[e, j]
                start_p, start_d, last = p, d, last_slip[e, j]
                for n in range(samples):
                    u = displacement[e, n]
                    trial = k * (u - p)
                    if d == 0.0:
                        slides = abs(trial) > f
                        new_d = np.sign(trial) if slides else d
                    else:
                        forward = d * trial
                        back = forward < (theta[e] - 2.0) * f
                        slides = back or forward >= theta[e] * f
                        new_d = -d if back else d
                    if slides:
                        slider_force = new_d * theta[e] * f
                        new_p = u - slider_force / k
                    else:
                        slider_force, new_p = trial, p
                    force[e, n] += slider_force
                    if new_p != p:
                        last = n
                    elif k > 0.0:
                        jacobian[e, n, n] -= k
                        if last >= 0:
                            jacobian[e, n, last] += k
                    p, d = new_p, new_d
                position[e, j], direction[e, j], last_slip[e, j] = p, d, last
                if abs(p - start_p) > tolerance or d != start_d:
                    periodic = False
        periods += 1
    return force, jacobian, periods, periodic, position, direction
