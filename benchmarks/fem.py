"""Benchmark of the finite-element stage for each beam: time and peak memory of each step, CalculiX beside it.

Steps, each in a fresh process on a mesh made beforehand (``geometry.beams.make_beam``): assemble K and M; 16
tied-interface modes (tie and shift-invert, assembly excluded); the bolt preload with frictionless contact;
stress stiffness and the prestressed tied modes; CalculiX C3D10 on the same tied mesh (16 modes, one thread,
the ccx run only, deck writing excluded) and CalculiX's preload with node-to-surface frictionless contact
(``fem.calculix.preload_contact_deck``). The times are each step's own (model set-up excluded), the memory the
peak of its whole process (for CalculiX, ccx's own peak is in the result column). The last rows compare the two codes on the steps they share, from the mesh: the tied
modal analysis and the preload, CalculiX's run against our assembly plus solve, as a ratio (> 1: ours faster).
Run: ``python -m benchmarks.fem`` (default meshes, about 15 min) or ``--coarse`` (about 3 min).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from benchmarks.peak import measure

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

COARSE = {"size": 0.0127, "lap_size": 0.0064, "hole_size": 0.0032}
N_MODES = 16


def _model(msh: str):
    from fem.elasticity import Material, solid_mesh
    from fem.modes import interface_quadratic_pairs
    from geometry.beam_mesh import interface_partners, read_beam_mesh

    beam_mesh = read_beam_mesh(Path(msh))
    mesh = solid_mesh(beam_mesh.points, beam_mesh.tetrahedra)
    return beam_mesh, mesh, interface_quadratic_pairs(mesh, *interface_partners(beam_mesh)), Material()


def _ccx_peak() -> str:
    """Peak resident memory of the finished ccx run (the step's only child process)."""
    import resource

    return f"ccx peak {resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024:.0f} MiB"


def assemble_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    from fem.elasticity import mass_matrix, stiffness_matrix

    _, mesh, _, material = _model(msh)
    start = time.perf_counter()
    stiffness, _ = stiffness_matrix(mesh, material), mass_matrix(mesh, material)
    return time.perf_counter() - start, f"{stiffness.shape[0]} DOF"


def modes_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    from fem.elasticity import mass_matrix, stiffness_matrix
    from fem.modes import tie_transformation, tied_modes
    from fem.solver import factorization_name

    _, mesh, (lower, upper), material = _model(msh)
    stiffness, mass = stiffness_matrix(mesh, material), mass_matrix(mesh, material)
    start = time.perf_counter()
    frequencies, _ = tied_modes(stiffness, mass, tie_transformation(stiffness.shape[0], lower, upper), N_MODES)
    return time.perf_counter() - start, f"first bending {frequencies[6]:.2f} Hz ({factorization_name()})"


def _preload(beam: str, msh: str):
    """The preload problem of ``fem.contact.frictionless_contact`` on a beam mesh, and what its CalculiX twin
    needs: (beam_mesh, mesh, material, couplings, bolt, stiffness, forces, lower, upper, supported, coordinates)."""
    import numpy as np

    from fem.bolts import Bolt, bolts_stiffness, preload_forces, washer_couplings
    from fem.contact import support_321
    from fem.elasticity import quadratic_node_coordinates, stiffness_matrix
    from geometry.parameters import BEAMS

    beam_mesh, mesh, (lower, upper), material = _model(msh)
    couplings, bolt = washer_couplings(mesh, beam_mesh, BEAMS[beam]), Bolt()
    stiffness = stiffness_matrix(mesh, material) + bolts_stiffness(couplings, bolt, axial=False)
    coordinates = quadratic_node_coordinates(mesh)
    supported = support_321(coordinates, np.unique(beam_mesh.volumes["lower_half"][:, :4]))
    return (beam_mesh, mesh, material, couplings, bolt, stiffness, preload_forces(couplings, bolt), lower, upper,
            supported, coordinates)


def contact_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    from fem.contact import frictionless_contact

    *_, stiffness, forces, lower, upper, supported, _ = _preload(beam, msh)
    start = time.perf_counter()
    solution = frictionless_contact(stiffness, forces, lower, upper, supported)
    return time.perf_counter() - start, (f"contact force {solution.normal_force.sum():.1f} N, "
                                         f"{solution.active.mean():.0%} of pairs closed, "
                                         f"{solution.iterations} active-set iterations")


def calculix_preload_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    """CalculiX's node-to-surface preload (``fem.calculix.preload_contact_deck``), its springs started from our
    solution's bolt shortening; the ccx run only is timed."""
    import numpy as np

    from fem.calculix import (bolt_elongations, in_plane_support, preload_contact_deck, read_node_values,
                              run_calculix, spring_initial_forces)
    from fem.contact import frictionless_contact, support_321
    from geometry.parameters import BEAMS

    (beam_mesh, mesh, material, couplings, bolt, stiffness, forces, lower, upper, supported,
     coordinates) = _preload(beam, msh)
    ours = frictionless_contact(stiffness, forces, lower, upper, supported)
    initial_forces = spring_initial_forces(bolt, bolt_elongations(couplings, ours.displacement))
    upper_support = in_plane_support(support_321(coordinates, np.unique(beam_mesh.volumes["upper_half"][:, :4])))
    deck = preload_contact_deck(mesh, beam_mesh, BEAMS[beam], material, bolt, initial_forces,
                                np.concatenate([supported, upper_support]))
    start = time.perf_counter()
    dat = run_calculix(deck, Path(folder), f"{beam}_preload")
    seconds = time.perf_counter() - start
    ids, values = read_node_values(dat, "displacements", "SOLID_NODES")
    displacement = np.zeros(stiffness.shape[0])
    displacement[3 * (ids - 1)[:, None] + np.arange(3)] = values
    contact_force = (stiffness @ displacement)[3 * upper + 2].sum()
    return seconds, (f"contact force {contact_force:.1f} N (ccx, one thread, node-to-surface penalty contact, "
                     f"{_ccx_peak()})")


def prestressed_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    from fem.prestress import prestressed_beam
    from geometry.beam_mesh import read_beam_mesh
    from geometry.parameters import BEAMS

    start = time.perf_counter()
    model = prestressed_beam(read_beam_mesh(Path(msh)), BEAMS[beam], n_modes=N_MODES)
    return time.perf_counter() - start, (f"first bending {model.frequencies[6]:.2f} -> "
                                         f"{model.prestressed_frequencies[6]:.2f} Hz with K_sigma (whole "
                                         f"prestress solve: assembly, contact, K_sigma, two modal solves)")


def calculix_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    from fem.calculix import read_frequencies, run_calculix, tied_frequency_deck

    _, mesh, (lower, upper), material = _model(msh)
    deck = tied_frequency_deck(mesh, material, lower, upper, N_MODES)
    start = time.perf_counter()
    frequencies = read_frequencies(run_calculix(deck, Path(folder), f"{beam}_modes"))
    return time.perf_counter() - start, f"first bending {frequencies[6]:.2f} Hz (ccx, one thread, {_ccx_peak()})"


STEPS = (("assemble K, M", assemble_step), ("tied modes", modes_step), ("preload contact", contact_step),
         ("prestressed", prestressed_step))


def main(argv: list[str] | None = None) -> None:
    from fem.calculix import calculix_available
    from geometry.beams import make_beam
    from geometry.parameters import BEAMS, MeshParameters

    arguments = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    arguments.add_argument("--coarse", action="store_true", help="the coarse test mesh instead of the default")
    arguments.add_argument("--beams", nargs="+", default=list(BEAMS), choices=list(BEAMS))
    options = arguments.parse_args(argv)
    sizes = COARSE if options.coarse else {}
    steps = STEPS + ((("CalculiX modes", calculix_step), ("CalculiX preload", calculix_preload_step))
                     if calculix_available() else ())
    print(f"fem: {'coarse' if sizes else 'default'} meshes, OPENBLAS_NUM_THREADS=1, each step's own time")
    print(f"{'beam':5} {'step':16} {'time s':>8} {'peak MiB':>9}  result")
    with tempfile.TemporaryDirectory() as folder:
        for beam in options.beams:
            msh = str(make_beam(BEAMS[beam], MeshParameters(**sizes), folder, render=False).with_suffix(".msh"))
            times = {}
            for name, step in steps:
                _, peak, (seconds, result) = measure(step, beam, msh, folder)
                times[name] = seconds
                print(f"{beam:5} {name:16} {seconds:8.2f} {peak:9.0f}  {result}", flush=True)
            if "CalculiX modes" in times:
                for shared, theirs, ours in (("tied modes", "CalculiX modes", ("assemble K, M", "tied modes")),
                                             ("preload", "CalculiX preload", ("assemble K, M", "preload contact"))):
                    mine = sum(times[name] for name in ours)
                    print(f"{beam:5} {'CalculiX / ours':16} {times[theirs] / mine:8.2f} {'':9}  {shared} from the "
                          f"mesh: ccx {times[theirs]:.1f} s, ours {mine:.1f} s ({' + '.join(ours)})")


if __name__ == "__main__":
    main()
