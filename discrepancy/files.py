"""The discrepancy loop's files: what it writes for a verdict (the backbone it reads is any backbone format of
``experiment.measured_files``): ``discrepancy.md`` (the effect found at each step, the evidence, the errors before
and after), ``discrepancy.png`` (measurement and the model before and after) and ``discrepancy.json`` (the same
numbers and the fitted parameters); the final one-mode model read back from discrepancy.json and its curve with
the band written as CSV."""

from __future__ import annotations

import json
from pathlib import Path

from matplotlib.ticker import NullFormatter

import numpy as np

from discrepancy.fitted_model import check_record, evaluate
from discrepancy.loop import EVIDENCE, Verdict, residual_features
from discrepancy.nominal import nominal_statement
from pipeline.files import atomic_path, write_json
from study.figures import plt, save
from study.structures import DAMPING_FLOOR, FREQUENCY_FLOOR, BackboneLevels


def assumed_noise(measurement: BackboneLevels) -> list[str]:
    """A sentence saying at how many levels the measurement states no uncertainty and what the fit divided by
    there (the floors of ``study.structures.BackboneLevels``); nothing where every level states one."""
    silent = np.isnan(measurement.frequency_uncertainty_hz) | np.isnan(measurement.damping_uncertainty)
    if not silent.any():
        return []
    return [f"The measurement states no uncertainty at {int(silent.sum())} of {silent.size} levels: there the fit "
            f"assumed a standard uncertainty of {FREQUENCY_FLOOR:.0e} of the frequency and "
            f"{100 * DAMPING_FLOOR:.0f} % of the damping.", ""]


def findings_markdown(findings: list, checked: list) -> list[str]:
    """The signal checks' findings as Markdown lines: each named with its summary, and whether it is outside the
    effect library (the verdict cannot be "explained" with it)."""
    if not checked:
        return ["Signal checks: none apply (a backbone without its ring-down: no second mode, drift or record "
                "check).", ""]
    lines = [f"Signal checks beside the backbone ({', '.join(checked)}): "
             + ("nothing found." if not findings else f"{len(findings)} finding(s)."), ""]
    if findings:
        lines += ["| finding | outside the library | what the signals show |", "|---|---|---|"]
        lines += [f"| {entry['name']} | {'yes: unexplained' if entry['outside_library'] else 'no: a caveat'} | "
                  f"{entry['summary']} |" for entry in findings] + [""]
    return lines


def drift_markdown(corrections: dict) -> list[str]:
    """The drift within each hit taken out of the backbone before the fit (``experiment.signal_checks
    .drift_corrected``: quantity -> rate, its standard error and the largest shift of a point), as Markdown lines."""
    if not corrections:
        return []
    return ["Drift within each hit taken out of the backbone before the fit (the backbone as at each hit's impact, "
            "the rate's standard error added to each point's): " + "; ".join(
                f"{quantity} {entry['rate_per_s']:.4g} +- {entry['standard_error']:.2g} per s, points moved by up "
                f"to {entry['largest_shift']:.3g}" + (f" (the finding's reading: the data cannot tell it from a drift "
                                                      f"over the {entry['confounded_with']})"
                                                      if "confounded_with" in entry else "")
                for quantity, entry in corrections.items()) + ".", ""]


def outside_caveat(findings: list, drift: dict | None) -> str:
    """What the effects named may stand for beside the ``findings`` outside the library: a drift within each hit
    taken out of the backbone (``drift``, :func:`drift_markdown`'s) is not in it; anything else is."""
    left = [entry["name"] for entry in findings if entry["outside_library"] and not (
        drift and entry["name"] == "drift" and entry["evidence"].get("clock") == "time since each hit's impact")]
    said = ["the drift within each hit is taken out of the backbone (above)"] if drift else []
    if left:
        said.append(f"the backbone holds the {', '.join(left)}, so the effects named may stand for part of it")
    return "; ".join(said) + "."


def verdict_markdown(verdict: Verdict, source: str, features: dict, measurement: BackboneLevels,
                     checked: list = (), nominal: list = (), drift: dict | None = None) -> str:
    """The nominal's lines (``discrepancy.nominal.nominal_statement``), the noise the fit assumed where the
    measurement states none, the signal checks' findings and the drift taken out of the backbone
    (:func:`drift_markdown`), then the loop's
    steps as a Markdown table with the evidence and the errors before and after, after the features of the
    reference model's residual (``discrepancy.loop.residual_features``)."""
    lines = [f"Discrepancy loop on {source}.", "", *nominal, *assumed_noise(measurement),
             *findings_markdown(verdict.findings, list(checked)), *drift_markdown(drift or {}),
             "Residual of the reference model, in units of the measurement's uncertainty:", "",
             "| | offset | slope / decade | curvature / decade^2 | sign changes | largest kink |", "|---|---|---|---|---|---|"]
    lines += [f"| {name} | {f['offset']:.3g} | {f['slope_per_decade']:.3g} | {f['curvature_per_decade2']:.3g} | "
              f"{f['sign_changes']} | {f['largest_kink']:.3g} |" for name, f in features.items()]
    lines += ["",
             "| step | effect added | chi^2/dof | BIC | L-inf f (Hz) | RMS f (Hz) | L-inf zeta | RMS zeta |",
             "|---|---|---|---|---|---|---|---|"]
    for number, step in enumerate(verdict.steps):
        e = step.errors
        reference = (f"reference: {step.fit.parameters['design']}" if "design" in step.fit.parameters
                     else "reference (Jenkins, nominal f_0 and zeta_0)")
        lines.append(f"| {number} | {step.effect or reference} | "
                     f"{step.reduced_chi_squared:.3g} | {step.fit.bic:.4g} | {e['frequency_linf_hz']:.4g} | "
                     f"{e['frequency_rms_hz']:.4g} | {e['damping_linf']:.3g} | {e['damping_rms']:.3g} |")
    stopped = [str(number) for number, step in enumerate(verdict.steps) if not step.fit.converged]
    if stopped:
        lines += ["", f"NOT CONVERGED: the fit of step {', '.join(stopped)} stopped on its evaluation budget, not on "
                      "its tolerances; its chi^2 is an upper bound of the model's optimum."]
    on_drop = [f"step {number}, the {element}: {reason}" for number, step in enumerate(verdict.steps)
               for element, reason in step.fit.on_drop.items()]
    if on_drop:
        lines += ["", "ON A STICTION DROP (its optimum puts the drop on a level, where the residuals jump; its "
                      "covariance takes the slope of the level's side and the drop anywhere between the levels "
                      "around it): " + "; ".join(on_drop) + "."]
    last = verdict.steps[-1]
    if last.candidates:
        lines += ["", "Candidates at the last decision (BIC; an effect is added when it lowers the BIC by more "
                      "than 10): " + ", ".join(f"{k} {v:.4g}" for k, v in sorted(last.candidates.items(),
                                                                                  key=lambda item: item[1]))]
    if last.rejected:
        lines += ["", "Not accepted whatever their BIC: " + "; ".join(f"{effect}: {reason}" for effect, reason
                                                                      in sorted(last.rejected.items()))]
    if verdict.alternatives:
        lines += ["", "Within the selection's noise: " + "; ".join(
            f"{effects or 'the reference'} (BIC {value:.4g})" for effects, value in verdict.alternatives.items())
                  + f" fit as well (BIC within {EVIDENCE:g} of the lowest, none holding another such model); the data "
                    "do not tell them from the answer below."]
    if verdict.better_not_accepted:
        lines += ["", f"Fit better (BIC lower by more than {EVIDENCE:g}) but not accepted: " + "; ".join(
            f"{effects} ({why})" for effects, why in verdict.better_not_accepted.items()) + "."]
    outside = [entry["name"] for entry in verdict.findings if entry["outside_library"]]
    lines += ["", f"Verdict: {verdict_summary(verdict.joint_law, verdict.added, verdict.alternatives)}. " + (
        f"UNEXPLAINED: the signals show {', '.join(outside)}, which no effect of the library fitted to the backbone "
        "stands for (chi^2/dof of the backbone's fit in the table above); " + outside_caveat(verdict.findings, drift)
        if outside else
        "A residual above the measurement's noise remains UNEXPLAINED by the library." if verdict.unexplained else
        "The residual is at the measurement's noise.")]
    return "\n".join(lines) + "\n"


def verdict_summary(joint_law, added, alternatives) -> str:
    """A verdict in one line (the printed line, discrepancy.md, the report): the joint law (macroslip where the
    loop named none), the effects added outside the joint and the models as good within the noise (a verdict's or
    discrepancy.json's ``joint_law``, ``added``, ``alternatives``)."""
    line = f"joint law {', '.join(joint_law) or 'macroslip'}; added outside the joint {', '.join(added) or 'none'}"
    return line + ("; as good within the noise: " + " or ".join(alternatives) if alternatives else "")


EXTRAPOLATION = 3.0  # the figure draws a one-mode final model up to this factor above the fitted range


def acceleration(amplitude, frequency_hz, unit: str | None):
    """The acceleration amplitude (m/s^2) of a harmonic motion of displacement ``amplitude`` at ``frequency_hz``,
    (2 pi f)^2 x, where the amplitude is a displacement in metres (``unit`` "m": a ring-down's sensor, as FreeVib
    writes it); None for any other unit (a mass-normalised modal amplitude has no acceleration of its own)."""
    if unit != "m":
        return None
    return (2 * np.pi * np.asarray(frequency_hz, dtype=float)) ** 2 * np.asarray(amplitude, dtype=float)


def extrapolation_markdown(final_model: dict | None) -> str:
    """Where the one-mode final model holds (its fitted range) and what it predicts beyond, with its 95 % band:
    at 1.5, 2 and ``EXTRAPOLATION`` times the largest fitted amplitude (empty without a one-mode model); where the
    amplitude is a sensor's displacement in m, each row also gives its acceleration amplitude (``acceleration``),
    the unit hammer and shaker tests state their levels in."""
    if final_model is None:
        return ""
    low, high = final_model["fitted_range"]
    unit = final_model.get("amplitude_unit")
    amplitude = high * np.array([1.0, 1.5, 2.0, EXTRAPOLATION])
    curve = evaluate(final_model, amplitude)
    accelerations = acceleration(amplitude, curve["frequency_hz"], unit)
    top = "" if accelerations is None else f" ({accelerations[0]:.3g} m/s^2 at the top)"
    lines = ["", f"The final model is fitted over amplitudes {low:.4g} to {high:.4g} "
                 f"{unit or '(the measurement unit)'}{top}: the measured range. Beyond that it is EXTRAPOLATION, "
                 "carried by the model's form, not by points; the 95 % band is that of its parameters' uncertainty "
                 "alone, within that form (`surrogacy discrepancy-model` evaluates it anywhere):", "",
             "| amplitude" + ("" if accelerations is None else " | acceleration (m/s^2)")
             + " | | frequency (Hz) | 95 % band | damping ratio | 95 % band |",
             "|---|---|---|---|---|---|" + ("" if accelerations is None else "---|")]
    shown = [None] * amplitude.size if accelerations is None else accelerations
    lines += [f"| {q:.4g}" + ("" if a is None else f" | {a:.3g}")
              + f" | {'extrapolation' if out else 'fitted range'} | {f:.5g} | {fl:.5g} to {fh:.5g} | "
              f"{z:.4g} | {zl:.4g} to {zh:.4g} |"
              for q, a, out, f, fl, fh, z, zl, zh in zip(amplitude, shown, curve["extrapolated"],
                                                         curve["frequency_hz"], *curve["frequency_band"],
                                                         curve["damping"], *curve["damping_band"])]
    return "\n".join(lines) + "\n"


def plot_verdict(verdict: Verdict, measurement, destination: Path, final_model: dict | None = None) -> None:
    """Measured frequency and damping (with their uncertainties) against the reference model and the final one;
    a one-mode final model (``final_model``, ``discrepancy.fitted_model``) is drawn with its 95 % band from the
    lowest fitted amplitude to ``EXTRAPOLATION`` times the largest, the fitted range marked and the rest
    labelled extrapolation."""
    figure, axes = plt.subplots(1, 2, figsize=(10, 4))
    label = "with " + (", ".join(verdict.effects) or "nothing added")
    if final_model is not None:
        low, high = final_model["fitted_range"]
        extended = np.geomspace(low, EXTRAPOLATION * high, 200)
        curve = evaluate(final_model, extended)
    for axis, measured, sigma, attribute, name, key in (
            (axes[0], measurement.frequency_hz, measurement.sigma_frequency, "frequency_hz", "natural frequency (Hz)",
             "frequency"),
            (axes[1], measurement.damping, measurement.sigma_damping, "damping", "damping ratio (-)", "damping")):
        axis.errorbar(measurement.amplitude, measured, sigma, fmt="ko", ms=3, label="measurement")
        axis.semilogx(measurement.amplitude, getattr(verdict.steps[0].fit, attribute), "C0--", label="reference model")
        if final_model is None:
            axis.semilogx(measurement.amplitude, getattr(verdict.steps[-1].fit, attribute), "C3-", label=label)
        else:
            axis.semilogx(extended, curve[attribute], "C3-", label=label)
            axis.fill_between(extended, *curve[f"{key}_band"], color="C3", alpha=0.25, lw=0,
                              label="95 % band (parameters' uncertainty)")
            axis.axvspan(high, extended[-1], color="0.9", zorder=0, label="extrapolation (beyond the fitted range)")
            axis.axvline(high, color="0.5", lw=0.8)
            top = acceleration(high, evaluate(final_model, [high])["frequency_hz"][0],
                               final_model.get("amplitude_unit"))
            axis.text(high, 0.98, " top of the measured range" + ("" if top is None else f"\n {top:.3g} m/s^2"),
                      transform=axis.get_xaxis_transform(), va="top", ha="left", fontsize=7, color="0.3")
        unit = (final_model or {}).get("amplitude_unit")
        axis.set(xlabel="amplitude" + (f" ({unit})" if unit else ""), ylabel=name)
        axis.xaxis.set_minor_formatter(NullFormatter())  # decade labels only: the minor ones overlap
    axes[0].legend(fontsize=7)
    figure.tight_layout()
    save(figure, destination)


def write_verdict(out: Path, verdict: Verdict, measurement, source: str, record: dict) -> None:
    """discrepancy.md, .png and .json (``record`` and the steps with their evidence) into ``out``."""
    features = residual_features(measurement, verdict.steps[0].fit)
    with atomic_path(out / "discrepancy.md") as temporary:
        temporary.write_text(verdict_markdown(verdict, source, features, measurement,
                                              record.get("signal_checks", []), nominal_statement(record),
                                              record.get("drift_correction"))
                             + extrapolation_markdown(record.get("final_model")))
    plot_verdict(verdict, measurement, out / "discrepancy.png", record.get("final_model"))
    write_json(out / "discrepancy.json", {
        **record, "effects": verdict.effects, "unexplained": verdict.unexplained, "findings": verdict.findings,
        "joint_law": verdict.joint_law, "added": verdict.added, "alternatives": verdict.alternatives,
        "better_not_accepted": verdict.better_not_accepted, "evaluated_models": verdict.evaluated,
        "reference_residual_features": features,
        "steps": [{"effect": step.effect, "parameters": {k: v if isinstance(v, str) else float(v)
                                                         for k, v in step.fit.parameters.items()},
                   "reduced_chi_squared": step.reduced_chi_squared, "bic": step.fit.bic, "errors": step.errors,
                   "candidates": step.candidates, "not_accepted": step.rejected,
                   "undetermined_parameters": step.fit.undetermined, "held_parameters": step.fit.held,
                   "on_drop": step.fit.on_drop, "converged": step.fit.converged}
                  for step in verdict.steps]})


def read_final_model(path: Path) -> dict:
    """The final one-mode model (``final_model``, ``discrepancy.fitted_model``) of the discrepancy.json at
    ``path``; ValueError naming the file and the field where it holds none or not the record written."""
    try:
        record = json.loads(Path(path).read_text())["final_model"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ValueError(f"{path}: field final_model: expected the discrepancy.json of a one-mode run of "
                         f"surrogacy discrepancy ({type(error).__name__}: {error})") from None
    check_record(record, str(path))
    return record


def write_model_curve(record: dict, source: Path, amplitude, destination: Path) -> dict:
    """The final model ``record`` (read from ``source``) at ``amplitude`` (n,) in its unit, with its 95 % bands
    and whether each amplitude is extrapolation (``discrepancy.fitted_model.evaluate``), written as CSV to
    ``destination``; returns the curve."""
    curve = evaluate(record, amplitude)
    table = np.column_stack([amplitude, curve["frequency_hz"], *curve["frequency_band"], curve["damping"],
                             *curve["damping_band"], curve["extrapolated"]])
    with atomic_path(destination) as temporary:
        np.savetxt(temporary, table, delimiter=",", fmt="%.10g", comments="",
                   header=f"# model of {source} (effects: {', '.join(record['effects']) or 'none'}), fitted over "
                          f"amplitudes {record['fitted_range'][0]:.6g} to {record['fitted_range'][1]:.6g}; bands: "
                          "95 % of the parameters' uncertainty, linearised\n"
                          "amplitude,frequency [Hz],frequency low [Hz],frequency high [Hz],damping ratio [-],"
                          "damping low [-],damping high [-],extrapolation")
    return curve
