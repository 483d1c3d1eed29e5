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
import time
from pathlib import Path

import numpy as np

from experiment.backbone import Backbone, ModeBackbone
from experiment.backbone_files import write_backbone
from nonlinear.condensation import joint_space
from nonlinear.epmc import HARMONICS, SAMPLES, compare_with_qsma, slip_amplitude
from nonlinear.friction_models import MODEL_NAMES
from nonlinear.joint import parameter_names
from pipeline.files import check_output_folder, stage_folder
from reduction.superelement import TIED_MODES, beam_superelement, read_asb_superelement, stuck_joint_modes


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


def read_superelement(path: Path):
    """The superelement of option --rom by its suffix: a beam's .npz or an ASB .mat."""
    if not path.is_file():
        raise ValueError(f"option --rom = {path}: no such file (expected build/rom/<beam>.npz or an ASB "
                         "MAT_NULLRED_<configuration>.mat)")
    if path.suffix == ".npz":
        return beam_superelement(path)
    if path.suffix == ".mat":
        return read_asb_superelement(path)
    raise ValueError(f"option --rom = {path}: expected a .npz (surrogacy rom) or an ASB .mat superelement")


def backbone(name: str, method: str, amplitude, frequency, damping, source: str, settings: dict) -> ModeBackbone:
    """A virtual backbone of one method at the levels it reached (finite frequency and damping)."""
    unknown = np.full(len(amplitude), np.nan)
    curve = Backbone(np.asarray(amplitude), frequency / (2 * np.pi), unknown, unknown, damping, unknown, unknown,
                     np.ones(len(amplitude), dtype=int))
    return ModeBackbone(f"{name} ({method})", float(frequency[0] / (2 * np.pi)), "m kg^0.5", "virtual", source,
                        curve, settings)


def run(arguments: argparse.Namespace) -> None:
    """Solve EPMC and QSMA of the design and write both backbones."""
    if not 1 <= arguments.mode <= TIED_MODES:
        raise ValueError(f"option --mode = {arguments.mode}: expected a tied mode from 1 to {TIED_MODES}")
    if not 0 < arguments.start < arguments.stop or arguments.levels < 2:
        raise ValueError(f"options --from {arguments.start}, --to {arguments.stop}, --levels {arguments.levels}: "
                         "expected 0 < from < to and at least 2 levels")
    if arguments.harmonics is not None and not 1 <= arguments.harmonics < arguments.samples / 2:
        raise ValueError(f"option --harmonics = {arguments.harmonics}: expected 1 to fewer than half of --samples "
                         f"({arguments.samples})")
    check_output_folder(arguments.out)
    superelement = read_superelement(arguments.rom)
    design = read_design(arguments.design, arguments.model, max(superelement.patch_groups) + 1)
    space = joint_space(superelement, reference_mode=stuck_joint_modes(superelement, arguments.mode)[1][:, -1])
    slip = slip_amplitude(space, arguments.model, design)
    if not np.isfinite(slip):
        raise ValueError(f"option --design: no tangential element of the {arguments.model} design moves in the mode "
                         "or can slip; nothing to follow")
    amplitudes = slip * np.geomspace(arguments.start, arguments.stop, arguments.levels)
    counts = HARMONICS if arguments.harmonics is None else (arguments.harmonics,)
    started = time.perf_counter()
    comparison = compare_with_qsma(space, arguments.model, design, amplitudes, counts, arguments.samples)
    seconds = time.perf_counter() - started
    mode, qsma = comparison.mode, comparison.qsma
    stem = f"{arguments.rom.stem}_{arguments.model}"
    source = f"{arguments.model} design {design.tolist()} on {arguments.rom.name}, tied mode {arguments.mode}"
    settings = {"harmonics": mode.harmonics, "samples": mode.samples, "harmonics_converged":
                comparison.harmonics.converged, "slip_amplitude": slip}
    reached = {"epmc": mode.converged, "qsma": qsma.converged}
    curves = {"epmc": (mode.frequency, mode.damping), "qsma": (qsma.frequency, qsma.damping)}
    with stage_folder(arguments.out):
        for method, kept in reached.items():
            if not kept.any():
                print(f"{method}: no level reached; nothing written")
                continue
            frequency, damping = (values[kept] for values in curves[method])
            path = Path(arguments.out) / f"{stem}_{method}.csv"
            write_backbone(backbone(superelement.name, method, amplitudes[kept], frequency, damping, source,
                                    settings if method == "epmc" else {}), path)
            print(f"wrote {path}")
    changes = ", ".join(f"{c:.1e}/{d:.1e}" for c, d in zip(comparison.harmonics.frequency_change,
                                                            comparison.harmonics.damping_change))
    print(f"harmonics: {mode.harmonics} ({'converged' if comparison.harmonics.converged else 'NOT converged'}; "
          f"largest relative change of frequency/damping between counts: {changes or 'none checked'}), "
          f"{mode.samples} samples per period, {seconds:.1f} s")
    print(f"{'q [m kg^0.5]':>14} {'slip':>8} {'f EPMC [Hz]':>12} {'f QSMA [Hz]':>12} {'df [%]':>8} "
          f"{'zeta EPMC':>10} {'zeta QSMA':>10} {'dzeta [%]':>9}")
    for level, q in enumerate(amplitudes):
        f_epmc, f_qsma = mode.frequency[level] / (2 * np.pi), qsma.frequency[level] / (2 * np.pi)
        z_epmc, z_qsma = mode.damping[level], qsma.damping[level]
        damping_change = f"{100 * (z_qsma / z_epmc - 1):9.3f}" if abs(z_epmc) > 1e-12 else f"{'-':>9}"
        print(f"{q:14.4e} {q / slip:8.3g} {f_epmc:12.6f} {f_qsma:12.6f} {100 * (f_qsma / f_epmc - 1):8.4f} "
              f"{z_epmc:10.3e} {z_qsma:10.3e} {damping_change}")
    for method, kept in reached.items():
        if not kept.all():
            print(f"{method}: {int((~kept).sum())} level(s) not reached: {json.dumps(amplitudes[~kept].tolist())}")


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
