"""QSMA against EPMC over Table 3: how far QSMA's frequency and damping are from the nonlinear mode by harmonic
balance, by regime, on a beam's superelement.

Run as ``python -m benchmarks.epmc_qsma [--beam BRB] [--models jenkins iwan4 ...] [--designs N] [--seed S]
[--out FILE.csv]``. Designs are drawn uniformly in Table 3's box (``nonlinear.joint.random_designs``); those
whose stuck target mode has a negative stiffness (prestressed halves on too soft a joint) are left out; each is
evaluated at ``LEVELS`` modal amplitudes from 0.01 to 2 times its slip amplitude (``nonlinear.epmc.slip_amplitude``:
where its first element reaches macroslip in the stuck mode), by QSMA (``qsma_reference``) and by EPMC
(``nonlinear_mode``) at a harmonic count chosen per model by ``converged_harmonics`` on its first designs (the
largest count they needed), neither with linear damping. A level counts where both converged (QSMA's flagged levels
and EPMC's failed corrections are counted apart). Regimes by QSMA's largest slip ratio s of the level (|r| over the
element's macroslip displacement): stuck s < 0.01, microslip 0.01 <= s < 0.5, near macroslip 0.5 <= s < 2,
macroslip s >= 2. Per model and regime: the levels, the median, 95th percentile and largest |f_QSMA / f_EPMC - 1|
and |zeta_QSMA / zeta_EPMC - 1| (damping where EPMC's exceeds 1e-9), the share within 0.15 % and 5 %, and the CPU
time (``time.process_time``). Writes every level to ``--out``. ``--harmonics`` fixes the count instead of the
check.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from nonlinear.condensation import joint_space  # noqa: E402
from nonlinear.epmc import converged_harmonics, joint_system, nonlinear_mode, slip_amplitude  # noqa: E402
from nonlinear.joint import patch_elements, random_designs, stuck_stiffness  # noqa: E402
from nonlinear.qsma import qsma_reference, stuck_target_mode  # noqa: E402
from reduction.superelement import beam_superelement  # noqa: E402

LEVELS = np.geomspace(0.01, 2.0, 8)  # amplitudes in slip amplitudes
CHECK_LEVELS = np.array([0.3, 1.0, 2.0])  # slip amplitudes of the harmonic convergence check
COUNTS = (1, 3, 5, 7)  # harmonic counts tried
REGIMES = (("stuck", 0.0, 0.01), ("microslip", 0.01, 0.5), ("near macroslip", 0.5, 2.0), ("macroslip", 2.0, np.inf))
FREQUENCY_BOUND, DAMPING_BOUND = 1.5e-3, 5e-2  # the agreement asked of QSMA
CHECKED_DESIGNS = 4  # designs per model whose harmonic convergence sets the model's count


def design_levels(space, model: str, design, harmonics: int) -> pd.DataFrame:
    """QSMA and EPMC of one design at LEVELS slip amplitudes: one row per level."""
    slip = slip_amplitude(space, model, design)
    amplitudes = slip * LEVELS
    qsma = qsma_reference(space, model, design, amplitudes=amplitudes)
    try:
        mode = nonlinear_mode(joint_system(space, model, design), amplitudes, harmonics)
        epmc_frequency, epmc_damping, epmc_converged = mode.frequency, mode.damping, mode.converged
    except (RuntimeError, np.linalg.LinAlgError):  # no start at the first level: the design counts as failed
        epmc_frequency = epmc_damping = np.full(amplitudes.size, np.nan)
        epmc_converged = np.zeros(amplitudes.size, dtype=bool)
    return pd.DataFrame({"amplitude": amplitudes, "slip_ratio": np.nanmax(qsma.slip_ratio, axis=1),
                         "qsma_frequency": qsma.frequency, "qsma_damping": qsma.damping,
                         "qsma_converged": qsma.converged, "epmc_frequency": epmc_frequency,
                         "epmc_damping": epmc_damping, "epmc_converged": epmc_converged})


def model_harmonics(space, model: str, designs) -> int:
    """The largest harmonic count ``converged_harmonics`` chose among COUNTS on these designs (at CHECK_LEVELS)."""
    counts = [converged_harmonics(joint_system(space, model, design), slip_amplitude(space, model, design)
                                  * CHECK_LEVELS, COUNTS).harmonics for design in designs]
    return max(counts)


def regime_table(levels: pd.DataFrame) -> pd.DataFrame:
    """Per model and regime: levels, median / 95th percentile / largest relative differences, shares within the
    bounds (module docstring)."""
    both = levels[levels.qsma_converged & levels.epmc_converged].copy()
    both["frequency_difference"] = np.abs(both.qsma_frequency / both.epmc_frequency - 1)
    damped = both.epmc_damping > 1e-9
    both["damping_difference"] = np.where(damped, np.abs(both.qsma_damping / both.epmc_damping - 1), 0.0)
    rows = []
    for model, group in both.groupby("model", sort=False):
        for regime, low, high in REGIMES:
            inside = group[(group.slip_ratio >= low) & (group.slip_ratio < high)]
            if inside.empty:
                continue
            f, z = inside.frequency_difference, inside.damping_difference
            rows.append({"model": model, "regime": regime, "levels": len(inside),
                         "designs": inside.design.nunique(),
                         "df median": f.median(), "df p95": f.quantile(0.95), "df max": f.max(),
                         "dzeta median": z.median(), "dzeta p95": z.quantile(0.95), "dzeta max": z.max(),
                         "within bounds": float(np.mean((f <= FREQUENCY_BOUND) & (z <= DAMPING_BOUND)))})
    return pd.DataFrame(rows)


def markdown(table: pd.DataFrame) -> str:
    """The regime table as Markdown: counts as integers, differences in % to two significant digits."""
    def cell(name, value):
        if name in ("levels", "designs"):
            return f"{int(value)}"
        if isinstance(value, str):
            return value
        return f"{100 * value:.0f} %" if name == "within bounds" else f"{100 * value:.2g} %"
    lines = ["| " + " | ".join(table.columns) + " |", "|" + " --- |" * len(table.columns)]
    lines += ["| " + " | ".join(cell(name, value) for name, value in row.items()) + " |"
              for _, row in table.iterrows()]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--beam", default="BRB")
    parser.add_argument("--rom", type=Path, default=Path("build/rom"))
    parser.add_argument("--models", nargs="+", default=["jenkins", "iwan4"])
    parser.add_argument("--designs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=41)
    parser.add_argument("--harmonics", type=int, help="harmonic count for every model (default: the check's)")
    parser.add_argument("--out", type=Path, default=Path("results/epmc/epmc_qsma.csv"))
    arguments = parser.parse_args()
    superelement = beam_superelement(arguments.rom / f"{arguments.beam}.npz")
    space = joint_space(superelement)
    n_groups = max(superelement.patch_groups) + 1
    frames = []
    for model in arguments.models:
        designs = random_designs(model, arguments.designs, n_groups, np.random.default_rng(arguments.seed))
        slips = np.array([slip_amplitude(space, model, design) for design in designs])
        stable = np.array([stuck_target_mode(space, stuck_stiffness(patch_elements(
            model, design, superelement.patch_groups))[0]).eigenvalue > 0.0 for design in designs])
        designs = designs[np.isfinite(slips) & stable]
        started = time.process_time()
        harmonics = (model_harmonics(space, model, designs[:CHECKED_DESIGNS]) if arguments.harmonics is None
                     else arguments.harmonics)
        checked = time.process_time() - started
        for index, design in enumerate(designs):
            frame = design_levels(space, model, design, harmonics)
            frame.insert(0, "design", index)
            frame.insert(0, "model", model)
            frame["harmonics"] = harmonics
            frames.append(frame)
        seconds = time.process_time() - started
        levels = pd.concat([frame for frame in frames if frame.model.iloc[0] == model])
        arguments.out.parent.mkdir(parents=True, exist_ok=True)
        pd.concat(frames, ignore_index=True).to_csv(arguments.out, index=False)  # each model's levels kept at once
        print(f"{arguments.beam} {model}: {len(designs)} designs ({arguments.designs - len(designs)} without a "
              f"slipping element or unstable stuck), {harmonics} harmonics (check {checked:.0f} s), {seconds:.0f} s CPU; levels: "
              f"QSMA flagged {int((~levels.qsma_converged).sum())}, EPMC not converged "
              f"{int((~levels.epmc_converged).sum())} of {len(levels)}", flush=True)
    print(markdown(regime_table(pd.concat(frames, ignore_index=True))))


if __name__ == "__main__":
    main()
