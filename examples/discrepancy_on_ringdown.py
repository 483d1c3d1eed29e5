"""The discrepancy loop on your own ring-down: which effects does a one-mode joint model need to follow it?

    python examples/discrepancy_on_ringdown.py data/chen2022-brb-hammer/HammerImpact.mat --mode-hz 80.5
    python examples/discrepancy_on_ringdown.py

Without a file it writes a virtual ring-down (labelled virtual in the file) of a jointed beam whose joint slips
with microslip (an Iwan element), which the loop is to find, and runs on that.

Any ring-down the measured-data stage reads works (CSV with ``name [unit]`` headers, MATLAB .mat, UFF 58); give
the mode's frequency, and the model's nominal low-amplitude frequency and linear damping when you have them (else
they are estimated from the ring-down's lowest decade of amplitude, ``discrepancy.nominal``).
"""

import argparse
import tempfile
from pathlib import Path

from discrepancy.effects import effect
from discrepancy.loop import discrepancy_loop, with_findings
from discrepancy.nominal import nominal_record
from discrepancy.virtual_data import REFERENCE_DAMPING, REFERENCE_FREQUENCY_HZ, write_undeclared_ringdown
from experiment.measured_files import read_ringdown, stated_provenance
from experiment.ringdown_analysis import analyse_ringdown
from experiment.signal_checks import drift_corrected
from study.structures import measured_levels

KNOWN_EFFECT = effect("microslip")
"""The effect the virtual ring-down is written with, from the effect registry (which refuses a name it lacks)."""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ringdown", type=Path, nargs="?", help="ring-down file (default: a virtual one, written here)")
    parser.add_argument("--mode-hz", type=float, help="the mode's frequency guess, Hz (needed with a file)")
    parser.add_argument("--nominal-frequency-hz", type=float)
    parser.add_argument("--nominal-damping", type=float)
    arguments = parser.parse_args(argv)
    if arguments.ringdown is None:  # the virtual beam's nominal frequency and damping are known: give them
        arguments.ringdown = Path(tempfile.mkdtemp()) / "virtual_ringdown.csv"
        write_undeclared_ringdown(arguments.ringdown, (KNOWN_EFFECT.name,))
        arguments.mode_hz = arguments.nominal_frequency_hz = REFERENCE_FREQUENCY_HZ
        arguments.nominal_damping = REFERENCE_DAMPING
        print(f"virtual ring-down ({KNOWN_EFFECT.name} put in): {arguments.ringdown}")
    elif arguments.mode_hz is None:
        parser.error("a ring-down file needs --mode-hz")
    measured, _ = analyse_ringdown(read_ringdown(arguments.ringdown), arguments.mode_hz, arguments.ringdown.stem,
                                   stated_provenance(arguments.ringdown))  # the provenance as the file states it
    measured, drift = drift_corrected(measured)  # a drift within each hit taken out, as surrogacy discrepancy does
    if drift:
        print(f"drift within each hit taken out of the backbone: {drift}")
    measurement = measured_levels(measured, path=str(arguments.ringdown))
    nominal = nominal_record(measurement, arguments.nominal_frequency_hz, arguments.nominal_damping)  # else estimated
    print(f"nominal: f_0 {nominal['nominal_frequency_hz']:.6g} Hz, zeta_0 {nominal['nominal_damping']:.4g}; "
          f"{nominal['nominal_source']}")
    verdict = with_findings(discrepancy_loop(measurement, nominal["nominal_frequency_hz"], nominal["nominal_damping"],
                                             nominal_uncertainty=(nominal["nominal_frequency_standard_error_hz"],
                                                                  nominal["nominal_damping_standard_error"])),
                            measured.findings["found"])
    for entry in verdict.findings:
        print(f"signal finding {entry['name']}: {entry['summary']}")
    for step in verdict.steps:
        print(f"{step.effect or 'reference model':<22} chi^2/dof {step.reduced_chi_squared:8.3g}   "
              f"L-inf f {step.errors['frequency_linf_hz']:.4f} Hz   L-inf zeta {step.errors['damping_linf']:.2e}")
    print("effects found:", verdict.effects or "none", "(unexplained)" if verdict.unexplained else "")
    return verdict


if __name__ == "__main__":
    main()
