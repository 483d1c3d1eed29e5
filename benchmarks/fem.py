"""Benchmark of the finite-element stage on the BRB: time and peak memory of each step, CalculiX for comparison.

Steps (each in a fresh process): assemble K and M; 16 tied-interface modes (shift-invert); bolt preload with
frictionless contact; CalculiX C3D10 on the same tied mesh (when ccx is installed).
Run: ``python -m benchmarks.fem`` (coarse mesh, about a minute) or ``python -m benchmarks.fem --default-mesh``.
"""

from __future__ import annotations

import argparse
import os
import tempfile

from benchmarks.peak import measure

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

COARSE = {"size": 0.0127, "lap_size": 0.0064, "hole_size": 0.0032}


def _model(sizes: dict, folder: str):
    from fem.elasticity import Material, solid_mesh
    from fem.modes import interface_quadratic_pairs
    from geometry.beam_mesh import interface_partners, read_beam_mesh
    from geometry.beams import make_beam
    from geometry.parameters import BEAMS, MeshParameters

    beam_mesh = read_beam_mesh(make_beam(BEAMS["BRB"], MeshParameters(**sizes), folder, render=False)
                               .with_suffix(".msh"))
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    return beam_mesh, mesh, interface_quadratic_pairs(mesh, *interface_partners(beam_mesh)), Material()


def assemble_step(sizes: dict, folder: str) -> str:
    from fem.elasticity import mass_matrix, stiffness_matrix

    _, mesh, _, material = _model(sizes, folder)
    stiffness, _ = stiffness_matrix(mesh, material), mass_matrix(mesh, material)
    return f"{stiffness.shape[0]} DOF"


def modes_step(sizes: dict, folder: str) -> str:
    from fem.elasticity import mass_matrix, stiffness_matrix
    from fem.modes import tie_transformation, tied_modes
    from fem.solver import factorization_name

    _, mesh, (lower, upper), material = _model(sizes, folder)
    stiffness, mass = stiffness_matrix(mesh, material), mass_matrix(mesh, material)
    frequencies, _ = tied_modes(stiffness, mass, tie_transformation(stiffness.shape[0], lower, upper), 16)
    return f"first bending {frequencies[6]:.2f} Hz ({factorization_name()}, includes assembly)"


def contact_step(sizes: dict, folder: str) -> str:
    import numpy as np

    from fem.bolts import Bolt, bolts_stiffness, preload_forces, washer_couplings
    from fem.contact import frictionless_contact, support_321
    from fem.elasticity import quadratic_node_coordinates, stiffness_matrix
    from geometry.parameters import BEAMS

    beam_mesh, mesh, (lower, upper), material = _model(sizes, folder)
    couplings, bolt = washer_couplings(mesh, beam_mesh, BEAMS["BRB"]), Bolt()
    stiffness = stiffness_matrix(mesh, material) + bolts_stiffness(couplings, bolt, axial=False)
    supported = support_321(quadratic_node_coordinates(mesh), np.unique(beam_mesh.volumes["lower_half"][:, :4]))
    solution = frictionless_contact(stiffness, preload_forces(couplings, bolt), lower, upper, supported)
    return (f"contact force {solution.normal_force.sum():.1f} N, {solution.active.mean():.0%} of pairs closed, "
            f"{solution.iterations} active-set iterations (includes assembly)")


def calculix_step(sizes: dict, folder: str) -> str:
    from fem.calculix import read_frequencies, run_calculix, tied_frequency_deck

    _, mesh, (lower, upper), material = _model(sizes, folder)
    frequencies = read_frequencies(run_calculix(tied_frequency_deck(mesh, material, lower, upper, 16), folder))
    return f"first bending {frequencies[6]:.2f} Hz (ccx, one thread, includes deck writing)"


def main(argv: list[str] | None = None) -> None:
    from fem.calculix import calculix_available

    arguments = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    arguments.add_argument("--default-mesh", action="store_true", help="the default mesh sizes instead of coarse")
    sizes = {} if arguments.parse_args(argv).default_mesh else COARSE
    steps = [("assemble K, M", assemble_step), ("tied modes", modes_step), ("preload contact", contact_step)]
    if calculix_available():
        steps.append(("CalculiX modes", calculix_step))
    print(f"fem: BRB, {'default' if not sizes else 'coarse'} mesh, OPENBLAS_NUM_THREADS=1")
    print(f"{'step':16} {'time s':>8} {'peak MiB':>9}  result")
    times = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, step in steps:
            seconds, peak, result = measure(step, sizes, folder)
            times[name] = seconds
            print(f"{name:16} {seconds:8.2f} {peak:9.0f}  {result}")
    if "CalculiX modes" in times:
        print(f"CalculiX / scikit-fem time for the tied modes: {times['CalculiX modes'] / times['tied modes']:.2f}")


if __name__ == "__main__":
    main()
