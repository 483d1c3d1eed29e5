"""QSMA against EPMC over Table 3: how far QSMA's frequency and damping are from the nonlinear mode by harmonic
balance, by regime, on a beam's superelement or an ASB configuration's reduced model.

Run as ``python -m benchmarks.epmc_qsma [--structure BRB] [--models jenkins iwan4 ...] [--designs N] [--seed S]
[--out FILE.csv]``. The structure (``sampled_structure``) is a beam's prestressed superelement (``--rom``) with
its first tied elastic mode as the target, or an ASB configuration's reduced model (``--structure "ASB CD1"``, from
``--data``: every patch in one parameter group, the target mode the one its measured backbone saw, as the ASB
study takes them); one whose files are absent is skipped with a line saying so. Designs are drawn uniformly in
Table 3's box (``nonlinear.joint.random_designs``); those whose stuck target mode has a negative stiffness
(prestressed halves on too soft a joint) are left out; each is
evaluated at ``LEVELS`` modal amplitudes from 0.01 to 2 times its slip amplitude (``nonlinear.epmc.slip_amplitude``:
where its first element reaches macroslip in the stuck mode), by QSMA (``qsma_reference``) and by EPMC
(``nonlinear_mode``, the Iwan elements' sliders resolving the design's lowest amplitude, ``nonlinear.epmc
.joint_system``) at a harmonic count chosen per model by ``converged_harmonics`` on its first designs (the largest
count they needed), neither with linear damping. A level counts where both converged (QSMA's flagged levels
and EPMC's failed corrections are counted apart). Regimes by QSMA's largest slip ratio s of the level (|r| over the
element's macroslip displacement): stuck s < 0.01, microslip 0.01 <= s < 0.5, near macroslip 0.5 <= s < 2,
macroslip s >= 2. Per model and regime: the levels, the median, 95th percentile and largest |f_QSMA / f_EPMC - 1|
and |zeta_QSMA / zeta_EPMC - 1| (damping where EPMC's exceeds 1e-9), the share within 0.15 % and 5 %, and the CPU
time (``time.process_time``). Writes every level to ``--out``. ``--harmonics`` fixes the count instead of the
check.

With ``--study DIR`` (an analysed surrogacy study, ``surrogacy study``) it compares instead the study's
representative designs: on each structure (``--structures``, default all) and for each friction model of the
registry the structure can carry, the ``--representatives`` designs spread along the model's sample front on that
structure (``study.analysis.representative_designs``, the designs of the study's Figs. 9-11), or, for a model the
study did not run, as many Table 3 designs (seed ``--seed``; those whose stuck target mode is unstable or that
have no slipping element left out); each at ``--levels`` of the structure's measured amplitudes (the first, the
last and evenly between), EPMC with the harmonic count of its own convergence check (``nonlinear.epmc
.compare_with_qsma``, counts ``STUDY_COUNTS``) beside QSMA, neither with linear damping. One row per level is
appended to ``--out`` (default ``results/epmc/study_<dataset>.csv``, the file ``report.epmc`` reads) as each design
finishes; a design already there is not computed again.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from experiment.backbone_files import read_asb_backbone  # noqa: E402
from experiment.measured_files import read_mode_backbone  # noqa: E402
from nonlinear.condensation import joint_space  # noqa: E402
from nonlinear.epmc import (compare_with_qsma, converged_harmonics, joint_system, nonlinear_mode,  # noqa: E402
                            slip_amplitude)
from nonlinear.friction_models import models_for  # noqa: E402
from nonlinear.joint import parameter_names, patch_elements, random_designs, stuck_stiffness  # noqa: E402
from nonlinear.qsma import qsma_reference, stuck_target_mode  # noqa: E402
from geometry.parameters import BEAM_NAMES  # noqa: E402
from reduction.superelement import ASB_CONFIGURATIONS, StructureError, beam_superelement  # noqa: E402
from study.analysis import Front, design_rows, representative_designs  # noqa: E402
from study.structures import asb_superelement, structure  # noqa: E402

LEVELS = np.geomspace(0.01, 2.0, 8)  # amplitudes in slip amplitudes
CHECK_LEVELS = np.array([0.3, 1.0, 2.0])  # slip amplitudes of the harmonic convergence check
COUNTS = (1, 3, 5, 7)  # harmonic counts tried
REGIMES = (("stuck", 0.0, 0.01), ("microslip", 0.01, 0.5), ("near macroslip", 0.5, 2.0), ("macroslip", 2.0, np.inf))
FREQUENCY_BOUND, DAMPING_BOUND = 1.5e-3, 5e-2  # the agreement asked of QSMA
CHECKED_DESIGNS = 4  # designs per model whose harmonic convergence sets the model's count
STUDY_COUNTS = (1, 3, 5, 7, 9, 11)  # harmonic counts tried per design with --study
STUDY_COLUMNS = ("dataset", "structure", "model", "source", "design", "parameters", "amplitude", "slip_ratio",
                 "qsma_frequency_hz", "qsma_damping", "qsma_converged", "epmc_frequency_hz", "epmc_damping",
                 "epmc_converged", "harmonics", "harmonics_converged", "seconds", "note")
"""The columns of the --study file, one row per design and level (frequencies in Hz; seconds: the design's CPU)."""


def sampled_structure(name: str, rom: Path, data: Path):
    """(superelement, joint space) of the structure ``name`` for the Table 3 sampling (module docstring): a beam
    of BEAM_NAMES from ``rom`` (``<beam>.npz``), or ``"ASB <configuration>"`` from the ASB data folder ``data``
    (``asb-reduced-models/MAT_NULLRED_<configuration>.mat`` and ``asb-backbones/ASB_<configuration>_20Nm_BB.mat``,
    whose low-amplitude frequency, Hz, picks the target mode: ``study.structures.structure``). Raises
    StructureError naming a missing file, or a name that is neither."""
    if name in BEAM_NAMES:
        superelement = beam_superelement(rom / f"{name}.npz")
        return superelement, joint_space(superelement)
    configuration = name.removeprefix("ASB ")
    if not name.startswith("ASB ") or configuration not in ASB_CONFIGURATIONS:
        raise StructureError(f"{name}: not a structure (expected one of {', '.join(BEAM_NAMES)} or "
                             f"{', '.join(f'ASB {c}' for c in ASB_CONFIGURATIONS)})")
    backbone = data / "asb-backbones" / f"ASB_{configuration}_20Nm_BB.mat"
    if not backbone.exists():
        raise StructureError(f"{backbone}: missing (the ASB measured backbones: surrogacy data fetch downloads them)")
    superelement = asb_superelement(data / "asb-reduced-models" / f"MAT_NULLRED_{configuration}.mat")
    return superelement, structure(name, superelement, read_asb_backbone(backbone), 0.0).space


def design_levels(space, model: str, design, harmonics: int) -> pd.DataFrame:
    """QSMA and EPMC of one design at LEVELS slip amplitudes: one row per level."""
    slip = slip_amplitude(space, model, design)
    amplitudes = slip * LEVELS
    qsma = qsma_reference(space, model, design, amplitudes=amplitudes)
    try:
        mode = nonlinear_mode(joint_system(space, model, design, lowest_amplitude=amplitudes[0]), amplitudes,
                              harmonics)
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
    counts = []
    for design in designs:
        amplitudes = slip_amplitude(space, model, design) * CHECK_LEVELS
        counts.append(converged_harmonics(joint_system(space, model, design, lowest_amplitude=amplitudes[0]),
                                          amplitudes, COUNTS).harmonics)
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


def usable(space, model: str, design) -> bool:
    """Whether EPMC can follow the design: a stuck target mode of positive stiffness and an element that slips."""
    stable = stuck_target_mode(space, stuck_stiffness(patch_elements(
        model, design, space.superelement.patch_groups))[0]).eigenvalue > 0.0
    return bool(stable and np.isfinite(slip_amplitude(space, model, design)))


def study_designs(study: Path, structure, index: int, model: str, count: int, seed: int):
    """(source, design indices (k,), designs (k, n_parameters)) of ``model`` on the study's structure ``index``:
    the representative designs of its sample front (``fronts_<model>.csv``), or ``count`` Table 3 designs where
    the study has no front of the model (indices -1)."""
    n_groups = max(structure.space.superelement.patch_groups) + 1
    names = parameter_names(model, n_groups)
    path = study / "analysis" / f"fronts_{model}.csv"
    if path.exists():
        fronts = pd.read_csv(path)
        rows = fronts[(fronts.structure == structure.name) & (fronts.source == "sample")]
        front = Front(rows.design.to_numpy(), rows.frequency_error_hz.to_numpy(), rows.damping_error.to_numpy())
        acceptance = json.loads((study / "study.json").read_text())["configuration"]["acceptance"]
        chosen = front.design[representative_designs(front, acceptance["frequency_tolerance_hz"],
                                                     acceptance["damping_tolerance"], count)]
        return "front", chosen, design_rows(study / "designs", model, chosen, names)
    drawn = random_designs(model, 20 * count, n_groups, np.random.default_rng([seed, index]))
    kept = [design for design in drawn if usable(structure.space, model, design)][:count]
    return "table3", np.full(len(kept), -1), np.array(kept).reshape(len(kept), len(names))


def study_rows(structure, model: str, source: str, index: int, design, levels: int, counts) -> pd.DataFrame:
    """EPMC (its harmonic count by its own convergence check) and QSMA of one design at ``levels`` of the
    structure's measured amplitudes: one row per level (frequencies in Hz)."""
    measured = structure.measurement.amplitude
    amplitudes = measured[np.unique(np.linspace(0, measured.size - 1, levels).round().astype(int))]
    started = time.process_time()
    row = {"structure": structure.name, "model": model, "source": source, "design": int(index),
           "parameters": json.dumps(np.asarray(design).tolist())}
    if not usable(structure.space, model, design):
        return pd.DataFrame([{**row, "amplitude": q, "epmc_converged": False, "qsma_converged": False,
                              "seconds": time.process_time() - started,
                              "note": "unstable stuck mode or no slipping element"} for q in amplitudes])
    comparison = compare_with_qsma(structure.space, model, design, amplitudes, counts)
    mode, qsma = comparison.mode, comparison.qsma
    return pd.DataFrame({**row, "amplitude": amplitudes, "slip_ratio": np.nanmax(qsma.slip_ratio, axis=1),
                         "qsma_frequency_hz": qsma.frequency / (2 * np.pi), "qsma_damping": qsma.damping,
                         "qsma_converged": qsma.converged, "epmc_frequency_hz": mode.frequency / (2 * np.pi),
                         "epmc_damping": mode.damping, "epmc_converged": mode.converged,
                         "harmonics": mode.harmonics, "harmonics_converged": comparison.harmonics.converged,
                         "seconds": time.process_time() - started, "note": ""})


def study_structures(study: Path, dataset: str, rom: Path, data: Path, n_levels: int, prestress: bool) -> list:
    """The study's structures (``study.structures.structure``) from its measurement files: the beams on their
    superelements in ``rom`` (prestressed as the study ran them), the ASB configurations on their reduced models
    in ``data``, every patch in one group (``study.structures.asb_superelement``)."""
    structures = []
    names = list(BEAM_NAMES) if dataset == "beams" else [f"ASB {name}" for name in ASB_CONFIGURATIONS]
    for name in names:
        path = study / "measurements" / f"{name.replace(' ', '_')}.csv"
        measured = read_mode_backbone(path)
        if dataset == "beams":
            superelement = beam_superelement(rom / f"{name}.npz", prestress)
        else:
            configuration = name.removeprefix("ASB ")
            superelement = asb_superelement(data / "asb-reduced-models" / f"MAT_NULLRED_{configuration}.mat")
        structures.append(structure(name, superelement, measured, 0.0, n_levels, str(path)))
    return structures


def compare_study(study: Path, structures, models, representatives: int, levels: int, seed: int, out: Path,
                  rom: Path, data: Path) -> pd.DataFrame:
    """The --study comparison (module docstring), appended to ``out`` design by design; returns every row."""
    configuration = json.loads((study / "study.json").read_text())["configuration"]["study"]
    dataset = configuration["dataset"]
    every = study_structures(study, dataset, rom, data, configuration["n_levels"], configuration["prestress"])
    done = pd.read_csv(out) if out.exists() else pd.DataFrame(columns=["structure", "model", "design", "parameters"])
    out.parent.mkdir(parents=True, exist_ok=True)
    for index, chosen in enumerate(every):
        if structures and chosen.name not in structures:
            continue
        n_groups = max(chosen.space.superelement.patch_groups) + 1
        for model in models or models_for(n_groups):
            source, indices, designs = study_designs(study, chosen, index, model, representatives, seed)
            for design_index, design in zip(indices, designs):
                text = json.dumps(np.asarray(design).tolist())
                if ((done.structure == chosen.name) & (done.model == model) & (done.parameters == text)).any():
                    continue
                frame = study_rows(chosen, model, source, design_index, design, levels, STUDY_COUNTS)
                frame.insert(0, "dataset", dataset)
                frame = frame.reindex(columns=STUDY_COLUMNS)
                frame.to_csv(out, mode="a", header=not out.exists(), index=False)
                done = pd.concat([done, frame], ignore_index=True)
                print(f"{chosen.name} {model} {source} {design_index}: {frame.harmonics.iloc[0]} harmonics, "
                      f"{frame.seconds.iloc[0]:.0f} s CPU", flush=True)
    return done


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--structure", "--beam", dest="structure", default="BRB",
                        help="the sampled structure: BRB, LBRB, SBRB (from --rom) or 'ASB <configuration>' (from "
                             "--data)")
    parser.add_argument("--rom", type=Path, default=Path("build/rom"))
    parser.add_argument("--models", nargs="+", default=["jenkins", "iwan4"])
    parser.add_argument("--designs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=41)
    parser.add_argument("--harmonics", type=int, help="harmonic count for every model (default: the check's)")
    parser.add_argument("--out", type=Path, help="levels CSV (default results/epmc/epmc_qsma.csv; with --study "
                                                 "results/epmc/study_<dataset>.csv)")
    parser.add_argument("--study", type=Path, help="an analysed study folder: compare its representative designs")
    parser.add_argument("--structures", nargs="+", help="with --study: the structures (default all)")
    parser.add_argument("--representatives", type=int, default=3, help="with --study: designs per front")
    parser.add_argument("--levels", type=int, default=5, help="with --study: measured amplitudes per design")
    parser.add_argument("--data", type=Path, default=Path("../shared/data"),
                        help="the ASB data (asb-reduced-models/, asb-backbones/) for --study or --structure 'ASB ...'")
    arguments = parser.parse_args()
    if arguments.study is not None:
        dataset = json.loads((arguments.study / "study.json").read_text())["configuration"]["study"]["dataset"]
        out = arguments.out or Path(f"results/epmc/study_{dataset}.csv")
        models = [] if arguments.models == parser.get_default("models") else arguments.models
        compare_study(arguments.study, arguments.structures, models, arguments.representatives, arguments.levels,
                      arguments.seed, out, arguments.rom, arguments.data)
        return
    arguments.out = arguments.out or Path("results/epmc/epmc_qsma.csv")
    try:
        superelement, space = sampled_structure(arguments.structure, arguments.rom, arguments.data)
    except StructureError as error:
        print(f"{arguments.structure}: skipped: {error}")
        return
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
        print(f"{arguments.structure} {model}: {len(designs)} designs ({arguments.designs - len(designs)} without a "
              f"slipping element or unstable stuck), {harmonics} harmonics (check {checked:.0f} s), {seconds:.0f} s CPU; levels: "
              f"QSMA flagged {int((~levels.qsma_converged).sum())}, EPMC not converged "
              f"{int((~levels.epmc_converged).sum())} of {len(levels)}", flush=True)
    print(markdown(regime_table(pd.concat(frames, ignore_index=True))))


if __name__ == "__main__":
    main()
