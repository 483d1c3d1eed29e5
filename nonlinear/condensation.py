"""The superelement seen from the joint: unjoined modes, stuck modes and the exact joint-space compliance.

Joint stiffnesses span 1e2 to 1e14 N/m next to modal stiffnesses near 1e5 (docs/design.md section 5.1), so the
joined structure is never formed in the superelement's own coordinates. Instead:

1. Once per structure, the modes of the two unjoined halves, K psi = lambda M psi, mass-normalised. Modes
   below ``rigid_frequency`` are rigid-body modes, or, for prestressed halves, modes the preload's geometric
   stiffness makes negative; combinations of them that do not move the joint (rigid motion of the whole
   assembly, or, where the joint acts on translations only, a relative rotation about the line through collinear
   patch centres) are removed, so that any positive joint stiffness makes the unstressed structure positive
   definite; the rest are diagonalised again, their negative eigenvalues kept. In these coordinates eta
   (u = Psi eta) the mass is the identity, the stiffness diag(lambda), and the relative joint motions are
   r = Phi eta with Phi = B Psi (m x n_modes, B the superelement's ``joint_motion``: the 3 n_patches relative
   translations, then two rows per patch for the normal springs' action on its rotations where the superelement
   knows the patches' second moments).
2. Per design, with the stuck joint tangents k (3 n_patches), the stuck matrix
   A = diag(lambda) + Phi^T diag(k) Phi (identity mass: no Cholesky of an ill-conditioned mass matrix; the
   ASB models' mass matrices have condition numbers near 1e13) is never decomposed: a dense eigen-solve of
   it has a backward error of eps ||A||, at least eps lambda_max (7e14 rad^2/s^2 for CD1), i.e. up to 1e-7
   of lambda_1 and more for stiff joints. ``stuck_modes`` instead solves the small exact problem of
   ``nonlinear.stuck_modes``: the modes below a cutoff (``modal_split``) explicit, the others as a
   frequency-dependent flexibility in series with the joint, residual at round-off.
3. The joint-space compliance of the stuck structure, C = B (K + B^T K_d B)^+ B^T = (H + K_d)^-1, comes from
   the same split at mu = 0 as a sum of two positive semi-definite terms (no cancellation).

The target mode is chosen by shape, not index: the stuck mode with the largest modal assurance criterion
(mass-weighted) against a reference mode, by default the first elastic mode with all relative patch
translations tied (docs/design.md section 5.1: a third of Table 3's designs have a rigid rocking of the halves first).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg

from nonlinear.joint import joint_row_stiffness, tangential_rows as tangential_joint_rows
from nonlinear.compute_devices import kernels
from nonlinear.stuck_modes import flexibility_basis
from reduction.superelement import Superelement, tied_modal_eigenpairs

RIGID_FREQUENCY = 1.0  # Hz: no elastic mode of a jointed beam lies below it
# Above 0.5 only one mode can match the reference (the MACs of M-orthonormal modes against it sum to 1);
# below, the reference shape is shared by veering modes and the target is ambiguous.
UNAMBIGUOUS_MAC = 0.5
# The small stuck eigenproblem keeps the modes below CUTOFF_FACTOR times the reference's Rayleigh quotient
# explicitly (``modal_split``); the target is then always among them.
CUTOFF_FACTOR = 4.0


class JointSpace(NamedTuple):
    """Modal data of an unjoined superelement, reduced to what the joint needs.

    eigenvalues: (n_modes,) lambda of the unjoined halves, rad^2/s^2 (rigid-body modes exactly 0; negative for
        motions the preload's geometric stiffness softens more than the halves resist, which only the joint
        holds).
    modes: (n, n_modes) mass-normalised mode shapes Psi in the superelement's coordinates.
    joint_modes: (m, n_modes) Phi = B Psi, relative joint motions (m) per unit modal coordinate, rows as the
        superelement's ``joint_motion`` (the 3 n_patches translations first).
    reference: (n_modes,) unit reference mode shape for the target-mode MAC.
    superelement: the model it came from (patch layout, sensors).
    """

    eigenvalues: np.ndarray
    modes: np.ndarray
    joint_modes: np.ndarray
    reference: np.ndarray
    superelement: Superelement


def joint_space(superelement: Superelement, reference_mode: np.ndarray | None = None,
                rigid_frequency: float = RIGID_FREQUENCY) -> JointSpace:
    """Unjoined modes of ``superelement`` without the joint-free rigid-body modes, and the reference mode.

    reference_mode: (n,) shape in the superelement's coordinates to track; default the first elastic mode
    of the structure with every joint motion tied (``reduction.superelement.tied_modal_eigenpairs``).
    Raises ValueError where a motion of negative stiffness leaves the joint unstrained: no joint design holds it.
    """
    eigenvalues, modes = scipy.linalg.eigh(superelement.stiffness, superelement.mass)
    joint = superelement.joint_motion
    rigid_eigenvalue = (2.0 * np.pi * rigid_frequency) ** 2
    low = eigenvalues < rigid_eigenvalue
    _, singular_values, rotation = np.linalg.svd(joint @ modes[:, low], full_matrices=True)
    moves_joint = np.zeros(low.sum(), dtype=bool)
    moves_joint[: len(singular_values)] = singular_values > 1e-9 * np.linalg.norm(joint @ modes, axis=0).max()
    free = rotation[~moves_joint]  # (k, n_low) joint-free combinations of the low modes
    free_stiffness = np.einsum("kl,l,kl->k", free, eigenvalues[low], free)
    if np.any(free_stiffness < -rigid_eigenvalue):
        raise ValueError(f"{superelement.name}: a motion of negative stiffness "
                         f"({-np.sqrt(-free_stiffness.min()) / (2 * np.pi):.1f} Hz) leaves every joint spring "
                         "unstrained; no joint design holds it")
    if free.size:  # the low modes that move the joint, diagonalised again (prestress: not all of them rigid)
        kept = rotation[moves_joint].T
        low_eigenvalues, low_rotation = np.linalg.eigh(kept.T @ (eigenvalues[low][:, None] * kept))
        low_eigenvalues[np.abs(low_eigenvalues) < rigid_eigenvalue] = 0.0  # rigid-body motion: round-off
        modes = np.hstack([modes[:, low] @ kept @ low_rotation, modes[:, ~low]])
        eigenvalues = np.concatenate([low_eigenvalues, eigenvalues[~low]])
    joint_modes = joint @ modes
    if reference_mode is None:
        reference = tied_modal_eigenpairs(eigenvalues, joint_modes, rigid_frequency=rigid_frequency)[1][:, 0]
    else:
        reference = modes.T @ superelement.mass @ np.asarray(reference_mode, dtype=float)
    return JointSpace(eigenvalues, modes, joint_modes, reference / np.linalg.norm(reference), superelement)


class JointMechanisms(NamedTuple):
    """Relative rigid motions of the halves that move the joint only tangentially (a uniform slide in x or y,
    the twist about the normal; docs/design.md section 5.1, deep macroslip): with every tangential element in
    macroslip nothing but the slip forces holds them, so their equilibrium is a balance of slip forces.

    tangential: (k, 2 n_patches) orthonormal tangential joint motions d_j (m per unit coordinate), (x, y) per
    patch; rigid: (k, n_modes) the same motions in the joint space's modal coordinates (zero on the elastic
    modes), so that a design's mode shape psi loads mechanism j by alpha (rigid_j . psi) (paper Eq. 10 projected
    on the rigid motion: d_j^T f_t = alpha rigid_j^T psi, f_t the tangential element forces).
    """

    tangential: np.ndarray
    rigid: np.ndarray


def joint_mechanisms(space: JointSpace, rigid_frequency: float = RIGID_FREQUENCY) -> JointMechanisms:
    """The tangential mechanisms of ``space``: combinations of its rigid-body modes whose normal joint motions
    (normal translations and, where the joint acts on them, the patch rotations' rows) vanish (to 1e-9 of the
    largest joint motion), orthonormalised in the tangential joint motion."""
    rigid = np.flatnonzero(np.abs(space.eigenvalues) < (2.0 * np.pi * rigid_frequency) ** 2)
    tangential_rows = tangential_joint_rows(space.superelement.n_patches)
    normal_rows = np.setdiff1d(np.arange(space.joint_modes.shape[0]), tangential_rows)
    motion = space.joint_modes[:, rigid]
    scale = np.abs(motion).max() if motion.size else 1.0
    _, singular_values, right = np.linalg.svd(motion[normal_rows], full_matrices=True)
    rank = int(np.sum(singular_values > 1e-9 * scale))
    combinations = right[rank:].T  # (n_rigid, k): no normal joint motion
    tangential = motion[tangential_rows] @ combinations
    left, values, rotation = np.linalg.svd(tangential, full_matrices=False)
    keep = values > 1e-9 * scale
    orthonormal = combinations @ rotation[keep].T / values[keep]  # tangential motion of these: left[:, keep]
    modal = np.zeros((int(keep.sum()), space.eigenvalues.size))
    modal[:, rigid] = orthonormal.T
    return JointMechanisms(np.ascontiguousarray(left[:, keep].T), modal)


def stuck_stiffness_matrix(space: JointSpace, joint_stiffness) -> np.ndarray:
    """A = diag(lambda) + Phi^T diag(k) Phi, (..., n_modes, n_modes) N/m per unit modal mass, for joint
    tangents of shape (..., 3 n_patches) (``nonlinear.joint.stuck_stiffness``; k on every joint row by
    ``joint_row_stiffness``)."""
    k = joint_row_stiffness(joint_stiffness, space.joint_modes.shape[0])
    phi = space.joint_modes
    return np.diag(space.eigenvalues) + (phi.T * k[..., None, :]) @ phi


def modal_assurance(shapes, reference) -> np.ndarray:
    """Mass-weighted MAC of each column of ``shapes`` (..., n_modes, k) against ``reference`` (n_modes,)
    in mass-normalised modal coordinates: (psi . ref)^2 / (|psi|^2 |ref|^2)."""
    projection = np.einsum("...mk,m->...k", shapes, reference)
    return projection ** 2 / (np.sum(shapes ** 2, axis=-2) * (reference @ reference))


class ModalSplit(NamedTuple):
    """Unjoined modes split for the small stuck eigenproblem (``nonlinear.stuck_modes``).

    low, high: indices of the modes below and above the cutoff lambda_c (rad^2/s^2), the high ones by increasing
    eigenvalue; flexibility: ``nonlinear.stuck_modes.flexibility_basis`` of the high modes' joint motions, from
    which the flexibility F(mu) is one matrix-vector product.
    """

    low: np.ndarray
    high: np.ndarray
    cutoff: float
    flexibility: np.ndarray


def modal_split(space: JointSpace, cutoff_factor: float = CUTOFF_FACTOR) -> ModalSplit:
    """Split at lambda_c = cutoff_factor tau, tau = ref^T Lambda ref the reference's Rayleigh quotient.

    For the default (tied) reference Phi ref = 0, so ref^T (Lambda + Phi^T K Phi) ref = tau for every joint:
    expanding ref over the stuck modes, a mode with MAC c has mu <= tau / c. An unambiguous target
    (MAC > 0.5) therefore lies below 2 tau < lambda_c, and no mode above the cutoff can have a MAC above
    1 / cutoff_factor.
    """
    tau = space.reference @ (space.eigenvalues * space.reference)
    cutoff = cutoff_factor * tau
    low = np.flatnonzero(space.eigenvalues <= cutoff)
    high = np.flatnonzero(space.eigenvalues > cutoff)
    high = high[np.argsort(space.eigenvalues[high], kind="stable")]
    return ModalSplit(low, high, cutoff, flexibility_basis(space.eigenvalues[high], space.joint_modes[:, high]))


class StuckModes(NamedTuple):
    """Low-amplitude (stuck-joint) data per design, arrays with a leading design axis.

    eigenvalue: lambda_1 of the tracked mode, rad^2/s^2; shape: its mode in modal coordinates (unit norm,
    positive projection on the reference); joint_shape: b = Phi shape (relative joint motions per unit q, rows
    as ``JointSpace.joint_modes``); mac: its MAC against the reference; compliance: C = (H + K_d)^-1 (m/N),
    (m, m) for the m joint rows, or only the rows and columns asked for (``stuck_modes``' rows); found: False
    where no stuck mode was found below the split's cutoff (then the fields hold the best attempt); unstable:
    the number of stuck modes of negative stiffness (below -(2 pi RIGID_FREQUENCY)^2): prestressed halves on a
    joint too soft to carry the preload's geometric softening; where it is not 0 the other fields are undefined
    and ``found`` is False.
    """

    eigenvalue: np.ndarray
    shape: np.ndarray
    joint_shape: np.ndarray
    mac: np.ndarray
    compliance: np.ndarray
    found: np.ndarray
    unstable: np.ndarray


def stuck_modes(space: JointSpace, joint_stiffness, split: ModalSplit | None = None, rows=None,
                device: str = "cpu") -> StuckModes:
    """Tracked stuck mode and joint-space compliance for a batch of joint tangents (n_designs, 3 n_patches),
    N/m (``nonlinear.joint.stuck_stiffness``), by the small exact eigenproblem of ``nonlinear.stuck_modes`` (no
    n_modes x n_modes solve). rows: the joint rows (e.g. the tangential ones) whose compliance block is wanted;
    default all. The stuck structure's negative-stiffness modes are counted (``StuckModes.unstable``), from the
    signs of the small problem's estimates (Sylvester's law of inertia). device: where the designs are solved
    (``nonlinear.compute_devices``: "cpu" or "cuda").

    The target is the stuck mode with the largest MAC against the reference among those below the cutoff
    (every mode with MAC above 1 / CUTOFF_FACTOR is there, see ``modal_split``).
    """
    split = modal_split(space) if split is None else split
    phi, eigenvalues, reference = space.joint_modes, space.eigenvalues, space.reference
    k = np.ascontiguousarray(joint_row_stiffness(np.atleast_2d(joint_stiffness), phi.shape[0]), dtype=float)
    eigenvalue, shape_low, shape_high, joint_shape, mac, compliance, found, estimates = kernels(device).stuck_designs(
        k, eigenvalues[split.low], np.ascontiguousarray(phi[:, split.low]), eigenvalues[split.high],
        np.ascontiguousarray(phi[:, split.high]), split.flexibility, reference[split.low], reference[split.high],
        UNAMBIGUOUS_MAC, np.arange(k.shape[1]) if rows is None else np.asarray(rows, dtype=np.int64))
    shape = np.empty((len(k), len(eigenvalues)))
    shape[:, split.low], shape[:, split.high] = shape_low, shape_high
    unstable = np.count_nonzero(estimates < -(2.0 * np.pi * RIGID_FREQUENCY) ** 2, axis=1)
    return StuckModes(eigenvalue, shape, joint_shape, mac, compliance, found & (unstable == 0), unstable)


class StuckModeCache:
    """The stuck modes of one structure (``stuck_modes`` with its ``split`` and joint ``rows``) for each batch
    of joint tangents asked for, formed once per distinct batch: the friction models of a study take their stuck
    joint (K_T, K_z, K_c) from the same columns of the sample (``study.designs``), so that models with the same
    stuck joint share one solve per design and structure. A batch is found again only where it is equal to the
    last bit. Holds the batches of one chunk of designs; not for long-lived use. device: where they are solved
    (``nonlinear.compute_devices``)."""

    def __init__(self, space: JointSpace, split: ModalSplit | None = None, rows=None, device: str = "cpu"):
        self.space = space
        self.split = modal_split(space) if split is None else split
        self.rows = None if rows is None else np.asarray(rows, dtype=np.int64)
        self.device = device
        self._formed: dict[bytes, StuckModes] = {}

    def __call__(self, joint_stiffness) -> StuckModes:
        """``stuck_modes`` of the tangents (n_designs, 3 n_patches) N/m, formed where not formed before."""
        stiffness = np.ascontiguousarray(np.atleast_2d(joint_stiffness), dtype=float)
        key = np.asarray(stiffness.shape).tobytes() + stiffness.tobytes()
        if key not in self._formed:
            self._formed[key] = stuck_modes(self.space, stiffness, self.split, self.rows, self.device)
        return self._formed[key]

    def __len__(self) -> int:
        """The number of distinct batches solved so far."""
        return len(self._formed)

    def serves(self, space: JointSpace, rows, device: str) -> bool:
        """Whether this cache's modes are those of ``space`` with the compliance on ``rows``, solved on
        ``device``."""
        return (space is self.space and self.rows is not None and np.array_equal(self.rows, rows)
                and device == self.device)
