"""The discrepancy loop's final one-mode model as a record a user can evaluate at any amplitude, with a band from
its parameters' uncertainty, and the range it was fitted over.

Record (``model_record``, written as ``final_model`` in discrepancy.json): the effects, the parameters, the
fitted variables (``discrepancy.loop.TRANSFORMS`` of them: log of a positive parameter, logit of a bounded one)
with their covariance (``discrepancy.loop.parameter_covariance``), the parameters held at their law's limit and
the elements whose stiction drop sits on a level (``discrepancy.loop.stiction_drops``), the nominal low-amplitude
frequency f_0 (Hz) and linear damping zeta_0 the model was fitted with, the amplitude scale q_max that the effects
outside the joint are written in (``discrepancy.loop.outside_joint``: c q / q_max, gamma (q / q_max)^2), and the
amplitude range of the points fitted, in the measurement's amplitude unit.

Band (``evaluate``): linearised propagation of the variables' covariance C, y +- 1.96 sqrt(g^T C g) at each
amplitude, g the gradient of the frequency or damping there with respect to the variables (central differences;
one side's where the other crosses a jump of the model, ``discrepancy.loop.across_jumps``): a pointwise 95 % band of
the parameters' uncertainty. Amplitudes outside the fitted range are extrapolation: the model's form carries them,
not the points.
"""

from __future__ import annotations

import numpy as np

from discrepancy.effects import EFFECTS
from discrepancy.loop import BASE, Fit, _to_parameters, _to_vector, across_jumps, model_backbone
from study.structures import BackboneLevels

KIND = {name: kind for name, kind, _ in (*BASE, *(p for effect in EFFECTS.values() for p in effect.parameters))}
"""Parameter of the one-mode model -> the kind of its fitted variable (``discrepancy.loop.TRANSFORMS``)."""
Z_95 = 1.959963984540054  # two-sided 95 % point of the standard normal
STEP = 1e-6  # central-difference step of the gradient, relative to each variable (at least 1e-6 absolute)


def model_record(final: Fit, measurement: BackboneLevels, nominal_frequency_hz: float, nominal_damping: float) -> dict:
    """The JSON-ready record of a final one-mode fit (module docstring)."""
    variables = [(name, KIND[name], None) for name in final.parameters]
    return {"effects": list(final.effects),
            "parameters": {name: float(final.parameters[name]) for name, _, _ in variables},
            "variables": [[name, kind] for name, kind, _ in variables],
            "vector": _to_vector(final.parameters, variables).tolist(),
            "covariance": np.asarray(final.covariance, dtype=float).tolist(),
            "held": dict(final.held), "on_drop": dict(final.on_drop),
            "nominal_frequency_hz": float(nominal_frequency_hz), "nominal_damping": float(nominal_damping),
            "amplitude_scale": float(measurement.amplitude[-1]),
            "fitted_range": [float(measurement.amplitude[0]), float(measurement.amplitude[-1])]}


def check_record(record: dict, source: str) -> None:
    """Raise ValueError naming ``source`` and the field where a record is not what ``model_record`` writes."""
    for name in ("effects", "parameters", "variables", "vector", "covariance", "nominal_frequency_hz",
                 "nominal_damping", "amplitude_scale", "fitted_range"):
        if name not in record:
            raise ValueError(f"{source}: field final_model.{name} is missing; expected the record surrogacy "
                             "discrepancy writes for a one-mode model")
    p = len(record["variables"])
    try:
        vector, covariance = (np.array(record[name], dtype=float) for name in ("vector", "covariance"))
    except (TypeError, ValueError):
        raise ValueError(f"{source}: field final_model.vector/covariance: expected numbers (null is not one)") from None
    if vector.shape != (p,) or covariance.shape != (p, p) or not np.all(np.isfinite(covariance)):
        raise ValueError(f"{source}: field final_model.vector/covariance: expected {p} values and {p}x{p} finite")
    names = [variable[0] for variable in record["variables"]]
    if not set(names) <= set(KIND) or not {"kappa", "slip_force"} <= set(names) or not np.all(np.isfinite(vector)):
        raise ValueError(f"{source}: field final_model.variables: expected finite values of the one-mode model's "
                         f"parameters ({', '.join(KIND)}), kappa and slip_force among them")
    for name, low in (("amplitude_scale", 0.0), ("nominal_frequency_hz", 0.0), ("nominal_damping", -np.inf)):
        if not isinstance(record[name], (int, float)) or not np.isfinite(record[name]) or not record[name] > low:
            raise ValueError(f"{source}: field final_model.{name} = {record[name]!r}: expected a finite number"
                             + (" > 0" if low == 0 else ""))
    fitted = record["fitted_range"]
    if (not isinstance(fitted, list) or len(fitted) != 2 or not all(isinstance(v, (int, float)) for v in fitted)
            or not 0 < fitted[0] <= fitted[1] < np.inf):
        raise ValueError(f"{source}: field final_model.fitted_range = {fitted!r}: expected [low, high], 0 < low <= high")


def evaluate(record: dict, amplitude) -> dict:
    """The record's backbone at ``amplitude`` (n,) (its unit): frequency_hz, damping (n,), their 95 % bands
    frequency_band, damping_band (2, n) (module docstring), and extrapolated (n,) bool: outside the fitted
    range."""
    amplitude = np.asarray(amplitude, dtype=float)
    variables = [(name, KIND[name], None) for name, _ in record["variables"]]
    scale = (record["nominal_frequency_hz"], record["nominal_damping"], record["amplitude_scale"])
    vector = np.asarray(record["vector"], dtype=float)

    def backbone(point):
        with np.errstate(all="ignore"):
            return np.concatenate(model_backbone(_to_parameters(point, variables), amplitude, *scale))

    curve = backbone(vector)
    steps = STEP * np.maximum(1.0, np.abs(vector))
    shifts = steps[:, None] * np.eye(vector.size)
    forward = np.column_stack([backbone(vector + shift) - curve for shift in shifts]) / steps
    backward = np.column_stack([curve - backbone(vector - shift) for shift in shifts]) / steps
    gradient = across_jumps((forward + backward) / 2.0, forward, backward)
    covariance = np.asarray(record["covariance"], dtype=float)
    spread = Z_95 * np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", gradient, covariance, gradient), 0.0))
    band = np.array([curve - spread, curve + spread])
    low, high = record["fitted_range"]
    n = amplitude.size
    return {"frequency_hz": curve[:n], "damping": curve[n:], "frequency_band": band[:, :n],
            "damping_band": band[:, n:], "extrapolated": (amplitude < low) | (amplitude > high)}
