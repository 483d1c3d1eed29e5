"""The superelement: the reduced linear model of two unjoined halves, as the nonlinear stage sees it.

One interface for the project's own Hurty/Craig-Bampton superelements (docs/design.md section 4) and for the
external ASB models (``asb-reduced-models/`` of the public data, ``pipeline.public_data``). The joint acts on relative
patch motions only, so the nonlinear stage needs: the mass and stiffness in the reduced coordinates, the map
from reduced coordinates to the relative (top minus bottom) virtual-node motion of every patch, and the
patch layout.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import scipy.io
import scipy.linalg

from fem.bolts import BOLT_PRELOAD
from fem.elasticity import rigid_body_modes

DOFS_PER_PATCH = 6  # x, y, normal translations, then rotations about x, y, normal
ASB_CONFIGURATIONS = ("C1", "C2", "C3", "C4", "C4a", "CD1")  # the ASB's reduced models and measured backbones
TIED_MODES = 6  # tied modes searched for a measured one


@dataclass(frozen=True)
class Superelement:
    """Reduced linear model of two halves that the joint elements connect.

    mass, stiffness: (n, n) symmetric, kg and N/m in the reduced coordinates q (any mix of physical and modal
        coordinates; rigid-body or relative rigid-body zero-energy modes are allowed).
    patch_motion: (6 n_patches, n), the relative virtual-node motion of patch p (top minus bottom) is
        patch_motion[6p:6p+6] @ q = (x, y, normal translations in m, rotations in rad). Joint forces act
        through its transpose, so the joint stiffness is patch_motion.T @ K_joint @ patch_motion.
    patch_areas: (n_patches,) m^2.
    patch_groups: (n_patches,) symmetry group index of each patch (0-based); patches in one group share joint
        parameters. The BRB's five patches are (0, 1, 2, 1, 0).
    sensors: (n_sensors, n) recovery of the sensor displacements (m) from q.
    preload: (n,) generalised force of the bolt preload (N), or None; the nonlinear stage with linear normal
        springs does not use it.
    name: label for reports.
    patch_second_moments: (n_patches, 2, 2) m^4, the second moments of area J of each patch about its virtual
        node (``geometry.properties.face_second_moments``, interface in a plane z = const), or None where the
        patch geometry is not known (the ASB's files). With them the joint's normal springs, spread over the
        patch, also act on the relative patch rotations (``joint_motion``).
    """

    mass: np.ndarray
    stiffness: np.ndarray
    patch_motion: np.ndarray
    patch_areas: np.ndarray
    patch_groups: tuple[int, ...]
    sensors: np.ndarray
    preload: np.ndarray | None = None
    name: str = "superelement"
    patch_second_moments: np.ndarray | None = None

    def __post_init__(self):
        n = self.mass.shape[0]
        if self.mass.shape != (n, n) or self.stiffness.shape != (n, n):
            raise ValueError(f"mass {self.mass.shape} and stiffness {self.stiffness.shape} must both be (n, n)")
        for matrix, label in [(self.mass, "mass"), (self.stiffness, "stiffness")]:
            if not np.allclose(matrix, matrix.T, rtol=0.0, atol=1e-12 * np.abs(matrix).max()):
                raise ValueError(f"{label} matrix is not symmetric")
        n_patches = len(self.patch_areas)
        if self.patch_motion.shape != (DOFS_PER_PATCH * n_patches, n):
            raise ValueError(f"patch_motion must be ({DOFS_PER_PATCH * n_patches}, {n}) for {n_patches} patches; "
                             f"got {self.patch_motion.shape}")
        if len(self.patch_groups) != n_patches or min(self.patch_groups) != 0:
            raise ValueError(f"patch_groups {self.patch_groups} must give a 0-based group for each of "
                             f"{n_patches} patches")
        if self.sensors.shape[1] != n:
            raise ValueError(f"sensors must have {n} columns; got {self.sensors.shape}")
        if self.patch_second_moments is not None and (
                self.patch_second_moments.shape != (n_patches, 2, 2)
                or np.any(np.linalg.eigvalsh(self.patch_second_moments) <= 0.0)):
            raise ValueError(f"patch_second_moments must be ({n_patches}, 2, 2) symmetric positive definite; got "
                             f"shape {self.patch_second_moments.shape}")

    @property
    def n_patches(self) -> int:
        return len(self.patch_areas)

    @property
    def relative_translation(self) -> np.ndarray:
        """(3 n_patches, n) map to the relative translations (x, y, normal per patch), where the joint acts."""
        rows = np.arange(self.n_patches)[:, None] * DOFS_PER_PATCH + np.arange(3)
        return self.patch_motion[rows.ravel()]

    @property
    def joint_motion(self) -> np.ndarray:
        """(m, n) map to the relative patch motions the joint's springs act on (m, per unit q): the 3 n_patches
        translations (``relative_translation``), then, where the second moments are known, two rows per patch
        (``normal_rotation_rows``): the patch's normal springs spread over its area (stiffness K_z / A_p per
        unit area) resist a relative rotation theta = (theta_x, theta_y) with the energy
        K_z theta^T J_p theta / (2 A_p), i.e. as one spring K_z on each of the rows
        rho_i e_i^T theta, J_p / A_p = sum_i rho_i^2 e_i e_i^T (principal axes e_i, radii of gyration rho_i):
        the normal motion of the patch at its radii of gyration (docs/design.md section 4).
        m = 3 n_patches without second moments, 5 n_patches with them."""
        if self.patch_second_moments is None:
            return self.relative_translation
        rotations = self.patch_motion.reshape(self.n_patches, DOFS_PER_PATCH, -1)[:, 3:5]
        scaled = normal_rotation_rows(self.patch_second_moments, self.patch_areas)
        return np.vstack([self.relative_translation, (scaled @ rotations).reshape(2 * self.n_patches, -1)])


def normal_rotation_rows(second_moments: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """(n_patches, 2, 2) R_p with R_p^T R_p = J_p / A_p (m^2): rows rho_i e_i^T of the principal axes e_i and
    radii of gyration rho_i of each patch (second_moments (n_patches, 2, 2) m^4, areas (n_patches,) m^2), so that a
    normal spring K_z on R_p theta stores K_z theta^T J_p theta / (2 A_p), that of normal springs K_z / A_p per
    unit area over the patch under the rotation theta = (theta_x, theta_y)."""
    squares, axes = np.linalg.eigh(second_moments / np.asarray(areas)[:, None, None])
    return np.sqrt(squares)[:, :, None] * axes.transpose(0, 2, 1)


def superelement_arrays(superelement: Superelement) -> dict[str, np.ndarray]:
    """One array per field, ``preload`` and ``patch_second_moments`` empty when absent: the content of the
    superelement ``.npz``."""
    preload = np.empty(0) if superelement.preload is None else superelement.preload
    moments = np.empty(0) if superelement.patch_second_moments is None else superelement.patch_second_moments
    return dict(mass=superelement.mass, stiffness=superelement.stiffness, patch_motion=superelement.patch_motion,
                patch_areas=superelement.patch_areas, patch_groups=np.asarray(superelement.patch_groups),
                sensors=superelement.sensors, preload=preload, name=np.asarray(superelement.name),
                patch_second_moments=moments)


def save_superelement(superelement: Superelement, path: Path | str) -> None:
    """Write a superelement as ``.npz`` (no pickles, ``superelement_arrays``). The reduction stage's file format
    (build/rom/<beam>.npz, which holds further arrays beside these; ``load_superelement`` ignores them)."""
    np.savez(path, **superelement_arrays(superelement))


def load_superelement(path: Path | str) -> Superelement:
    """Read a superelement written by :func:`save_superelement`."""
    with np.load(path, allow_pickle=False) as data:
        preload = data["preload"]
        moments = data["patch_second_moments"] if "patch_second_moments" in data.files else np.empty(0)
        return Superelement(mass=data["mass"], stiffness=data["stiffness"], patch_motion=data["patch_motion"],
                            patch_areas=data["patch_areas"], patch_groups=tuple(int(g) for g in data["patch_groups"]),
                            sensors=data["sensors"], preload=preload if preload.size else None, name=str(data["name"]),
                            patch_second_moments=moments if moments.size else None)


def read_asb_superelement(path: Path | str, coupling: str = "distributed", patch_groups=None) -> Superelement:
    """Read an ASB ``MAT_NULLRED_<conf>.mat`` (Hurty/Craig-Bampton, relative patch coordinates, rigid-body
    modes removed by a null-space projection; source: Nidish96/Computational-Work-For-ASB-Project).

    coupling: how the joint sees a patch.
      "distributed" (default): patch motion = the area-weighted average of the relative interface-node
        motion, ``LamT.T @ q``, and joint forces distributed over the patch nodes by ``LamT`` (its
        transpose): symmetric and energy-consistent.
      "virtual_node": the relative virtual-node DOFs, rows of ``L``. In these files the virtual nodes are
        tied to the interface by a penalty (``cnum`` = 1e10 times the patch shape integrals) that is soft
        compared with the structure: a joint spring on them acts in series with it, and even a rigid joint
        leaves C1's first bending mode at 80.9 Hz, below the measured 93.7 Hz. (The authors' code measured
        with ``L`` and loaded with ``LamT``, a non-symmetric pairing: 96.0 Hz rigid.)
    patch_groups: default all patches in one group (the square patches of C1-C4a share parameters by the
        symmetry of the bolted square; CD1's five patches in a row use the BRB layout (0, 1, 2, 1, 0)).
    Sensors: ``R`` (6 accelerometer points); preload: 11,580 N times ``Fv``.
    """
    data = scipy.io.loadmat(str(path))
    n_patches = int(np.asarray(data["Npatches"]).ravel()[0])
    n_reduced_dofs = int(np.asarray(data["dofred"]).ravel()[0])
    if n_reduced_dofs != DOFS_PER_PATCH:
        raise ValueError(f"{path}: expected {DOFS_PER_PATCH} DOFs per patch, got {n_reduced_dofs}")
    if coupling == "distributed":
        patch_motion = data["LamT"].T
    elif coupling == "virtual_node":
        patch_motion = data["L"][: DOFS_PER_PATCH * n_patches]
    else:
        raise ValueError(f"coupling must be 'distributed' or 'virtual_node'; got {coupling!r}")
    if patch_groups is None:
        patch_groups = (0, 1, 2, 1, 0) if n_patches == 5 else (0,) * n_patches
    mass, stiffness = data["M"], data["K"]
    return Superelement(
        mass=0.5 * (mass + mass.T),
        stiffness=0.5 * (stiffness + stiffness.T),
        patch_motion=np.ascontiguousarray(patch_motion),
        patch_areas=np.asarray(data["PatchAreas"], dtype=float).ravel(),
        patch_groups=tuple(int(g) for g in patch_groups),
        sensors=np.asarray(data["R"], dtype=float),
        preload=BOLT_PRELOAD * np.asarray(data["Fv"], dtype=float).ravel(),
        name=Path(path).stem.removeprefix("MAT_NULLRED_") + ("" if coupling == "distributed" else f" ({coupling})"),
    )


def tied_modal_eigenpairs(eigenvalues, joint_modes, n_modes: int = 1, rigid_frequency: float = 1.0) -> tuple:
    """The lowest flexible modes with every relative patch translation held at zero, in the unjoined modal
    coordinates: eigenvalues (n_modal,) rad^2/s^2 and joint_modes (3 n_patches, n_modal) m, the relative
    translations per unit modal coordinate. The stiffness is diagonal there, so the held problem (projected on
    the null space of joint_modes) keeps the accuracy of the unjoined eigenvalues.

    Returns (eigenvalues (n_modes,) rad^2/s^2, shapes (n_modal, n_modes), unit norm = mass-normalised); modes
    below ``rigid_frequency`` Hz (rigid motions the tied joint leaves free) are skipped.
    """
    null_basis = scipy.linalg.null_space(joint_modes)
    tied_eigenvalues, tied_shapes = np.linalg.eigh(null_basis.T @ (eigenvalues[:, None] * null_basis))
    flexible = np.flatnonzero(tied_eigenvalues > (2 * np.pi * rigid_frequency) ** 2)[:n_modes]
    return tied_eigenvalues[flexible], null_basis @ tied_shapes[:, flexible]


def stuck_joint_modes(superelement: Superelement, n_modes: int = 1,
                      rigid_frequency: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The lowest flexible modes with the joint stuck: every relative patch motion the joint's springs act on
    (``Superelement.joint_motion``) held at zero, the upper bound of any joint design's low-amplitude frequencies
    (``tied_modal_eigenpairs`` on the unjoined modes).

    Returns (frequencies (n_modes,) Hz, shapes (n, n_modes) in the superelement's coordinates, mass-normalised);
    modes below ``rigid_frequency`` Hz (rigid motions the stuck joint leaves free) are skipped.
    """
    eigenvalues, modes = scipy.linalg.eigh(superelement.stiffness, superelement.mass)
    tied_eigenvalues, shapes = tied_modal_eigenpairs(eigenvalues, superelement.joint_motion @ modes, n_modes,
                                                     rigid_frequency)
    return np.sqrt(tied_eigenvalues) / (2 * np.pi), modes @ shapes


class StructureError(ValueError):
    """A structure's measurement or model is unusable; the message names the file and the field."""


def target_mode(superelement: Superelement, frequency_hz: float) -> tuple[int, np.ndarray, str]:
    """The mode a measurement at ``frequency_hz`` saw: its 0-based index among the flexible tied modes, its tied
    shape (n,) in the superelement's coordinates, and a sentence stating the choice.

    Never silently mode 1: the measured low-amplitude frequency f_m is compared with the modes with every relative
    patch translation tied (``stuck_joint_modes``): a finite joint only softens the structure, so the k-th mode of
    any joint design lies at or below the k-th tied mode (eigenvalue interlacing). The measured mode is therefore
    at least the lowest mode whose tied frequency is not below f_m, and that mode is taken; the choice and the tied
    frequencies are stated in the study's output (``Structure.mode_choice``). The ASB's C2, C4 and C4a measure
    250-298 Hz, above their first tied mode (174-201 Hz): their target is the second mode.
    """
    frequencies, shapes = stuck_joint_modes(superelement, TIED_MODES)
    above = np.flatnonzero(frequencies >= frequency_hz)
    if above.size == 0:
        raise StructureError(f"{superelement.name}: measured {frequency_hz:.2f} Hz lies above the {TIED_MODES} "
                             f"lowest tied modes ({frequencies.round(1).tolist()} Hz)")
    index = int(above[0])
    choice = (f"{superelement.name}: measured {frequency_hz:.2f} Hz -> mode {index + 1} (tied {frequencies[index]:.2f}"
              f" Hz; tied modes {', '.join(f'{f:.1f}' for f in frequencies[:index + 2])} Hz)")
    return index, shapes[:, index], choice


def beam_superelement(path: Path, prestress: bool = True) -> Superelement:
    """A beam's superelement from the reduction stage (``build/rom/<beam>.npz``): with ``prestress`` (the
    default) the stiffness K_A + K_bolt (the clamped halves' stress stiffness and the preloaded shanks' string
    term, docs/design.md sections 3-4), without it the unstressed K of the two halves.

    The prestressed free halves are indefinite (BRB: modes at -245, -230, -22 Hz: the preload's geometric
    stiffness without the joint that balances it); the joint restrains every one of them, the relative twist about
    the line of patch centres through the normal springs' action on the patch rotations
    (``Superelement.joint_motion``), so a joint stiff enough to carry the preload's softening makes the
    assembly definite, and a softer one is flagged unstable by the condensation
    (``nonlinear.condensation.stuck_modes``)."""
    path = Path(path)
    if not path.exists():
        raise StructureError(f"{path}: missing (run `make rom` to build the beams' superelements)")
    superelement = load_superelement(path)
    if superelement.patch_second_moments is None:
        raise StructureError(f"{path}: no field 'patch_second_moments' (a superelement of an older reduction "
                             "stage); rerun `make rom`")
    if not prestress:
        return superelement
    with np.load(path, allow_pickle=False) as data:
        stiffness = data["stiffness_prestressed"] + data["bolt_stress_stiffness"]
        rigid = rigid_reduced_coordinates(data["virtual_node_coordinates"][:superelement.n_patches],
                                          len(stiffness))
    return replace(superelement, stiffness=balanced_stiffness(stiffness, superelement.mass, rigid))


def virtual_rigid_motion(references: np.ndarray) -> np.ndarray:
    """Virtual-node motion of rigid motions, (6 n_nodes, 6): column j is (t + theta x c_p, theta) at each reference
    point c_p (n_nodes, 3) m, for the unit rigid motion j of ``fem.elasticity.rigid_body_modes`` about the origin."""
    motion = np.zeros((len(references), DOFS_PER_PATCH, DOFS_PER_PATCH))
    motion[:, :3, :] = rigid_body_modes(references, centre=np.zeros(3)).reshape(len(references), 3, DOFS_PER_PATCH)
    motion[:, 3:, 3:] = np.eye(3)
    return motion.reshape(-1, DOFS_PER_PATCH)


def rigid_reduced_coordinates(references: np.ndarray, n_reduced: int) -> np.ndarray:
    """Reduced coordinates (n_reduced, 6) of the rigid motions of the whole beam about the origin: both sides'
    virtual nodes at their references (n_patches, 3) m move as ``virtual_rigid_motion``, modal coordinates at zero
    (the constraint modes reproduce rigid motions exactly)."""
    coordinates = np.zeros((n_reduced, DOFS_PER_PATCH))
    virtual = virtual_rigid_motion(references)
    coordinates[:2 * len(virtual)] = np.vstack([virtual, virtual])
    return coordinates


def balanced_stiffness(stiffness: np.ndarray, mass: np.ndarray, rigid: np.ndarray) -> np.ndarray:
    """P^T K_s P, P = I - R (R^T M R)^-1 R^T M, the symmetric part K_s of ``stiffness`` (n, n) N/m with the
    rigid motions R (n, 6) of the whole assembly made exact zero-energy modes (mass (n, n) kg).

    The clamp's prestress is self-equilibrated (the halves' K_sigma and the shanks' strings balance), so a rigid
    motion of the whole assembly carries neither energy nor force. The reduced K_A + K_bolt gives it the energy
    but not quite the force (|K R| about 3e-6 of |K| |R| for the rotations about x and y), which mixes the assembly's
    rotations into the halves' relative modes that the joint moves. P leaves the stiffness between motions
    M-orthogonal to R unchanged (P u = u there) and only removes that coupling."""
    projector = np.eye(len(mass)) - rigid @ np.linalg.solve(rigid.T @ mass @ rigid, rigid.T @ mass)
    symmetric = 0.5 * (stiffness + stiffness.T)
    balanced = projector.T @ symmetric @ projector
    return 0.5 * (balanced + balanced.T)
