"""``surrogacy epmc``: the nonlinear mode of one joint design by harmonic balance (EPMC, ``nonlinear.epmc``) beside
its QSMA backbone, on a reduced model.

Reads a superelement (``build/rom/<beam>.npz`` of ``surrogacy rom``, or an ASB ``MAT_NULLRED_<conf>.mat``), a
friction model and one design (its parameters in the model's order, N and N/m). The mode followed is the tied mode
``--mode`` (1: the first elastic mode with every joint motion tied). The amplitudes span ``--from`` to ``--to``
times the design's slip amplitude (the modal amplitude at which its first element reaches macroslip in the stuck
mode), from stuck into macroslip. The number of harmonics is chosen by a convergence check at three of them
(``--harmonics`` fixes it instead) and printed.

Writes two backbone CSVs (docs/formats.md), labelled virtual, at the same modal amplitudes:
<out>/<rom>_<model>_epmc.csv and <out>/<rom>_<model>_qsma.csv (QSMA without linear damping, as EPMC); a level
that a method did not reach (a corrector that failed, a level QSMA flags) is left out of that method's file and
printed.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from nonlinear.epmc import HARMONICS, SAMPLES
from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import parameter_names
from pipeline.files import check_output_folder
from virtual_experiment.nonlinear_mode import METHODS, follow_mode, read_superelement, write_backbones


def read_design(text: str, model: str, n_groups: int) -> np.ndarray:
    """The design of option --design: comma-separated numbers, as many as the model's parameters. Raises
    ValueError naming the option, what it got and the parameters expected."""
    names = parameter_names(model, n_groups)
    try:
        values = np.array([float(value) for value in text.split(",")])
    except ValueError:
        raise ValueError(f"option --design = {text!r}: expected {len(names)} comma-separated numbers "
                         f"({', '.join(names)})") from None
    if values.size != len(names) or not np.all(np.isfinite(values)):
        raise ValueError(f"option --design = {text!r}: expected {len(names)} finite numbers ({', '.join(names)}); "
                         f"got {values.size}")
    return values


def print_levels(followed) -> None:
    """The harmonic count chosen and, per level, the amplitude, EPMC's and QSMA's frequency and damping and their
    differences; the levels a method did not reach."""
    mode, harmonics = followed.comparison.mode, followed.comparison.harmonics
    changes = ", ".join(f"{c:.1e}/{d:.1e}" for c, d in zip(harmonics.frequency_change, harmonics.damping_change))
    print(f"harmonics: {mode.harmonics} ({'converged' if harmonics.converged else 'NOT converged'}; "
          f"largest relative change of frequency/damping between counts: {changes or 'none checked'}), "
          f"{mode.samples} samples per period, {followed.seconds:.1f} s")
    print(f"{'q [m kg^0.5]':>14} {'slip':>8} {'f EPMC [Hz]':>12} {'f QSMA [Hz]':>12} {'df [%]':>8} "
          f"{'zeta EPMC':>10} {'zeta QSMA':>10} {'dzeta [%]':>9}")
    (omega_epmc, z_epmc), (omega_qsma, z_qsma) = (followed.curve(method) for method in METHODS)
    for level, q in enumerate(followed.amplitudes):
        f_epmc, f_qsma = omega_epmc[level] / (2 * np.pi), omega_qsma[level] / (2 * np.pi)
        damping_change = (f"{100 * (z_qsma[level] / z_epmc[level] - 1):9.3f}" if abs(z_epmc[level]) > 1e-12
                          else f"{'-':>9}")
        print(f"{q:14.4e} {q / followed.slip:8.3g} {f_epmc:12.6f} {f_qsma:12.6f} {100 * (f_qsma / f_epmc - 1):8.4f} "
              f"{z_epmc[level]:10.3e} {z_qsma[level]:10.3e} {damping_change}")
    for method in METHODS:
        kept = followed.reached(method)
        if not kept.all():
            print(f"{method}: {int((~kept).sum())} level(s) not reached: "
                  f"{json.dumps(followed.amplitudes[~kept].tolist())}")


def run(arguments: argparse.Namespace) -> None:
    """Solve EPMC and QSMA of the design, write both backbones and print the levels."""
    check_output_folder(arguments.out)
    if not arguments.rom.is_file():
        raise ValueError(f"option --rom = {arguments.rom}: no such file (expected build/rom/<beam>.npz or an ASB "
                         "MAT_NULLRED_<configuration>.mat)")
    superelement = read_superelement(arguments.rom)
    design = read_design(arguments.design, arguments.model, max(superelement.patch_groups) + 1)
    followed = follow_mode(superelement, arguments.model, design, arguments.mode, arguments.start, arguments.stop,
                           arguments.levels, arguments.harmonics, arguments.samples)
    source = f"{arguments.model} design {design.tolist()} on {arguments.rom.name}, tied mode {arguments.mode}"
    written = write_backbones(followed, arguments.out, f"{arguments.rom.stem}_{arguments.model}", superelement.name,
                              source)
    for method, path in written.items():
        print(f"wrote {path}" if path is not None else f"{method}: no level reached; nothing written")
    print_levels(followed)


def register(subparsers) -> None:
    """Add the ``epmc`` subcommand."""
    command = subparsers.add_parser(
        "epmc", help="nonlinear mode of one joint design by harmonic balance (EPMC) beside QSMA: two backbone CSVs",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.add_argument("--rom", type=Path, required=True, help="superelement: build/rom/<beam>.npz or an ASB .mat")
    command.add_argument("--model", choices=MODEL_NAMES, required=True, help="friction model")
    command.add_argument("--design", required=True,
                         help="the design's parameters in the model's order, comma-separated (N, N/m; e.g. jenkins "
                              "on a beam: F_S[0],K_T[0],K_z[0],F_S[1],...)")
    command.add_argument("--mode", type=int, default=1, help="tied mode to follow (1: first elastic; default 1)")
    command.add_argument("--from", dest="start", type=float, default=0.05,
                         help="lowest amplitude, in slip amplitudes (default 0.05)")
    command.add_argument("--to", dest="stop", type=float, default=20.0,
                         help="highest amplitude, in slip amplitudes (default 20)")
    command.add_argument("--levels", type=int, default=12, help="amplitudes, log-spaced (default 12)")
    command.add_argument("--harmonics", type=int,
                         help=f"number of harmonics (default: by a convergence check over {HARMONICS})")
    command.add_argument("--samples", type=int, default=SAMPLES,
                         help=f"samples per period of the AFT time loop (default {SAMPLES})")
    command.add_argument("--out", type=Path, default=Path("results/epmc"), help="output folder")
    command.set_defaults(run=run)
