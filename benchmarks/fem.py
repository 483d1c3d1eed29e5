"""Benchmark of the finite-element stage for each beam: time and peak memory of each step, CalculiX beside it.

Steps, each in a fresh process on a mesh made beforehand (``geometry.beams.make_beam``): assemble K and M; 16
tied-interface modes (tie and shift-invert, assembly excluded); the bolt preload with frictionless contact;
stress stiffness and the prestressed tied modes; CalculiX C3D10 on the same tied mesh (16 modes, one thread)
and CalculiX's preload with node-to-surface frictionless contact (``fem.calculix.preload_contact_deck``), each
deck written beforehand and the ccx run (with its writing of the deck file) timed. The times are each step's
own (model set-up excluded), the memory the peak of its whole process (for CalculiX, of ccx itself, run from a
small process of its own). The last rows compare the two codes on the steps they share, from the mesh: the tied
modal analysis and the preload, CalculiX's run against our assembly plus solve, as a ratio (> 1: ours faster).
Run: ``python -m benchmarks.fem`` (default meshes, more than 17 min) or ``--coarse`` (about 3.5 min here).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from benchmarks.peak import measure
from benchmarks.table import row, show
from geometry.parameters import BEAM_NAMES

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


def assemble_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    from fem.elasticity import mass_matrix, stiffness_matrix

    _, mesh, _, material = _model(msh)
    start = time.perf_counter()
    stiffness, _ = stiffness_matrix(mesh, material), mass_matrix(mesh, material)
    return time.perf_counter() - start, f"{stiffness.shape[0]:,} DOF"


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


def prestressed_step(beam: str, msh: str, folder: str) -> tuple[float, str]:
    from fem.prestress import prestressed_beam
    from geometry.beam_mesh import read_beam_mesh
    from geometry.parameters import BEAMS

    start = time.perf_counter()
    model = prestressed_beam(read_beam_mesh(Path(msh)), BEAMS[beam], n_modes=N_MODES)
    return time.perf_counter() - start, (f"first bending {model.frequencies[6]:.2f} -> "
                                         f"{model.prestressed_frequencies[6]:.2f} Hz with K_sigma (whole "
                                         f"prestress solve: assembly, contact, K_sigma, two modal solves)")


def calculix_modes_deck(beam: str, msh: str, folder: str) -> tuple[str, dict]:
    """Write the tied frequency deck (``fem.calculix.tied_frequency_deck``); returns its name and no extras."""
    from fem.calculix import tied_frequency_deck

    _, mesh, (lower, upper), material = _model(msh)
    name = f"{beam}_modes"
    (Path(folder) / f"{name}.inp").write_text(tied_frequency_deck(mesh, material, lower, upper, N_MODES))
    return name, {}


def calculix_preload_deck(beam: str, msh: str, folder: str) -> tuple[str, dict]:
    """Write CalculiX's node-to-surface preload deck (``fem.calculix.preload_contact_deck``), its springs started
    from our solution's bolt shortening; returns its name and the springs' initial forces (N) and stiffness
    (N/m), from which the run reports the clamp forces."""
    import numpy as np

    from fem.calculix import bolt_elongations, in_plane_support, preload_contact_deck, spring_initial_forces
    from fem.contact import frictionless_contact, support_321
    from geometry.parameters import BEAMS

    (beam_mesh, mesh, material, couplings, bolt, stiffness, forces, lower, upper, supported,
     coordinates) = _preload(beam, msh)
    ours = frictionless_contact(stiffness, forces, lower, upper, supported)
    initial_forces = spring_initial_forces(bolt, bolt_elongations(couplings, ours.displacement))
    upper_support = in_plane_support(support_321(coordinates, np.unique(beam_mesh.volumes["upper_half"][:, :4])))
    name = f"{beam}_preload"
    (Path(folder) / f"{name}.inp").write_text(preload_contact_deck(
        mesh, beam_mesh, BEAMS[beam], material, bolt, initial_forces, np.concatenate([supported, upper_support])))
    return name, {"initial_forces": initial_forces.tolist(), "spring_stiffness": bolt.axial_stiffness}


def calculix_run(folder: str, name: str, extras: dict) -> tuple[float, float, str]:
    """Run ccx on folder/name.inp from this small process, so that its children's peak memory is ccx's own
    (a child forked from a large process inherits that process's peak). Returns (seconds, ccx peak MiB,
    result): the first bending frequency of a frequency deck, the clamp force of each bolt spring of a preload
    deck (``extras``: initial_forces, spring_stiffness)."""
    import resource

    import numpy as np

    from fem.calculix import read_frequencies, read_node_values, run_calculix

    deck = (Path(folder) / f"{name}.inp").read_text()
    start = time.perf_counter()
    dat = run_calculix(deck, Path(folder), name)
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    if not extras:
        return seconds, peak, f"first bending {read_frequencies(dat)[6]:.2f} Hz (ccx, one thread)"
    _, references = read_node_values(dat, "displacements", "REFERENCES")
    springs = np.asarray(extras["initial_forces"]) + extras["spring_stiffness"] * (references[1::2, 2]
                                                                                   - references[0::2, 2])
    return seconds, peak, (f"bolt clamp forces {', '.join(f'{force:.1f}' for force in springs)} N (ccx, one "
                           f"thread, node-to-surface penalty contact)")


STEPS = (("assemble K, M", assemble_step), ("tied modes", modes_step), ("preload contact", contact_step),
         ("prestressed", prestressed_step))
CALCULIX_STEPS = (("CalculiX modes", calculix_modes_deck), ("CalculiX preload", calculix_preload_deck))
SHARED_STEPS = (("tied modes", "CalculiX modes", ("assemble K, M", "tied modes")),
                ("preload", "CalculiX preload", ("assemble K, M", "preload contact")))  # compared: ccx, ours


def rows(coarse: bool = False, beams=BEAM_NAMES) -> Iterator[dict]:
    """A row per beam and step (``STEPS``, then ``CALCULIX_STEPS`` where ccx is installed): the step's own wall
    time (s) and its process's peak memory (MiB); then per beam the CalculiX / ours time ratio of each analysis
    both codes make from the mesh (> 1: ours faster). ``coarse``: the coarse test mesh (``COARSE``) instead of
    the default sizes."""
    from fem.calculix import calculix_available
    from geometry.beams import make_beam
    from geometry.parameters import BEAMS, MeshParameters

    sizes = "coarse" if coarse else "default"
    with tempfile.TemporaryDirectory() as folder:
        for beam in beams:
            msh = str(make_beam(BEAMS[beam], MeshParameters(**(COARSE if coarse else {})), folder,
                                render=False).with_suffix(".msh"))
            times = {}
            for name, step in STEPS:
                _, peak, (seconds, result) = measure(step, beam, msh, folder)
                times[name] = seconds
                yield row("fem", f"{beam} {name}", seconds, peak, note=f"{sizes} mesh: {result}")
            if not calculix_available():
                yield row("fem", f"{beam} CalculiX", note="ccx not installed (calculix-ccx): comparison skipped")
                continue
            for name, write_deck in CALCULIX_STEPS:
                _, _, (deck, extras) = measure(write_deck, beam, msh, folder)
                _, _, (seconds, peak, result) = measure(calculix_run, folder, deck, extras)
                times[name] = seconds
                yield row("fem", f"{beam} {name}", seconds, peak, note=f"{sizes} mesh: {result}")
            for shared, theirs, ours in SHARED_STEPS:
                mine = sum(times[name] for name in ours)
                yield row("fem", f"{beam} CalculiX / ours: {shared}", rate=times[theirs] / mine, unit="x",
                          note=f"{shared} from the mesh: ccx {times[theirs]:.1f} s, ours {mine:.1f} s "
                               f"({' + '.join(ours)}); > 1: ours faster")


def main(argv: list[str] | None = None) -> None:
    from geometry.parameters import BEAMS

    arguments = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    arguments.add_argument("--coarse", action="store_true", help="the coarse test mesh instead of the default")
    arguments.add_argument("--beams", nargs="+", default=list(BEAMS), choices=list(BEAMS))
    options = arguments.parse_args(argv)
    show(rows(options.coarse, options.beams))


if __name__ == "__main__":
    main()
