"""Named, validated parameters of the three Brake-Reuss beams and of their meshes.

Coordinates (metres): x along the beam, y across its width, z normal to the lap interface, which lies in the
plane z = 0 with the lap centre at the origin. The lower half occupies x in [-L/2 - body_length, L/2] with its
lap in z in [-H/2, 0]; the upper half is the lower one rotated 180 degrees about the y axis (the axis across
the width through the lap centre, vertical when the beam hangs in the test rig with its bolts horizontal).

Beams:
- BRB: the nominal beam, dimensions from the public ABAQUS deck (``pipeline.published.BRB_DECK``).
- LBRB: the same lap and section with a longer ``body_length`` on either side.
- SBRB: the BRB with a far-field "spring" in each body: a flexure, a length ``spring_length`` of the full-width
  section thinned symmetrically about the beam axis to ``spring_height``, centred ``spring_offset`` from the
  end of the lap. A thinned section is the simplest spring-like structure that is still one machined part and
  that changes the mode shape in the joint region (paper Fig. 8b) without touching the lap.

No drawings of the LBRB and SBRB are public. Their defaults below are tuned by the finite-element stage
(``surrogacy tune-frequencies``, ``fem/frequency_tuning.py``) on the default mesh: linear springs between the patch virtual
nodes, set so that the BRB's first out-of-plane bending is the measured 169.48 Hz, give with the same springs the
measured ratios 80.82/169.48 for a body length of 0.4856 m (LBRB) and 91.96/169.48 for a 25.4 mm long flexure of
4.874 mm height centred 0.15 m from the lap (SBRB), both within 1e-4. (First estimates from a free-free
Euler-Bernoulli beam with the lap tied were 0.4612 m and 6.1 mm.)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from pipeline.published import BRB_DECK


class GeometryError(ValueError):
    """A geometry or mesh parameter is outside its physical range."""


@dataclass(frozen=True)
class BeamParameters:
    """Dimensions of one Brake-Reuss beam (all lengths in m, density in kg/m^3).

    bolt_x: bolt axis positions relative to the lap centre along x.
    patch_cuts: fractions of the lap length at which the interface is cut into patches,
        increasing from 0 to 1 (five patches for six cuts).
    spring_*: the SBRB flexure; ``spring_height = None`` means no flexure.
    """

    name: str = "BRB"
    body_length: float = BRB_DECK["body_length"]
    lap_length: float = BRB_DECK["lap_length"]
    width: float = BRB_DECK["width"]
    height: float = BRB_DECK["height"]
    bolt_x: tuple[float, ...] = BRB_DECK["bolt_x"]
    hole_diameter: float = BRB_DECK["hole_diameter"]
    washer_outer_diameter: float = BRB_DECK["washer_outer_diameter"]
    patch_cuts: tuple[float, ...] = BRB_DECK["patch_cuts"]
    density: float = 7800.0
    spring_offset: float = 0.15
    spring_length: float = 0.0254
    spring_height: float | None = None

    def __post_init__(self) -> None:
        validate_beam(self)

    @property
    def lap_thickness(self) -> float:
        """Thickness of each half in the lap, m (half the section height)."""
        return self.height / 2

    @property
    def half_length(self) -> float:
        """Length of one half, body plus lap, m."""
        return self.body_length + self.lap_length

    @property
    def patch_bounds(self) -> list[tuple[float, float]]:
        """x interval of each interface patch, m, from -L/2 to +L/2."""
        x = [self.lap_length * (c - 0.5) for c in self.patch_cuts]
        return list(zip(x[:-1], x[1:]))

    def replace(self, **changes) -> "BeamParameters":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class MeshParameters:
    """Target element sizes (m) and element order of a beam mesh.

    size: far field; lap_size: the lap region of both halves; hole_size: on and near the bolt holes and
    washer footprints. order 1 writes 4-node tetrahedra (the FE stage raises them to quadratic with straight
    sides); order 2 writes gmsh's 10-node tetrahedra with straight-sided mid-nodes.
    """

    size: float = 0.00635
    lap_size: float = 0.0032
    hole_size: float = 0.0016
    order: int = 1

    def __post_init__(self) -> None:
        for field in ("size", "lap_size", "hole_size"):
            value = getattr(self, field)
            _require(0 < value < MAX_DIMENSION, field, f"a positive element size in m below {MAX_DIMENSION:g}", value)
        _require(self.order in (1, 2), "order", "1 or 2", self.order)


MAX_DIMENSION = 10.0  # m: no dimension or element size of a lab beam reaches it (catches inf and unit slips)
MAX_DENSITY = 1e5  # kg/m^3
MAX_ELEMENTS = 5_000_000  # tetrahedra: beyond it the FE stage would not fit in this machine's memory


def check_mesh_size(beam: BeamParameters, sizes: MeshParameters) -> None:
    """Refuse, before meshing, element sizes that would give more than MAX_ELEMENTS tetrahedra: about
    6 V / h^3 for a body of volume V at element size h (the bulk size; the lap and hole sizes refine locally)."""
    volume = 2 * beam.half_length * beam.width * beam.height
    estimate = 6 * volume / sizes.size ** 3
    _require(estimate <= MAX_ELEMENTS, "size", f"an element size giving at most {MAX_ELEMENTS:,} tetrahedra "
             f"(about {estimate:.2g} at this size for the {beam.name})", sizes.size)


def _require(condition: bool, field: str, expected: str, value) -> None:
    if not condition:
        raise GeometryError(f"parameter '{field}' = {value!r}: expected {expected}")


def validate_beam(beam: BeamParameters) -> None:
    """Raise GeometryError naming the first parameter that makes the beam unbuildable."""
    for field in ("body_length", "lap_length", "width", "height", "hole_diameter",
                  "washer_outer_diameter", "density", "spring_length", "spring_offset"):
        value = getattr(beam, field)
        _require(0 < value < (MAX_DENSITY if field == "density" else MAX_DIMENSION), field,
                 "a positive, finite value (m; kg/m^3 for density)", value)
    _require(beam.hole_diameter < min(beam.width, beam.height), "hole_diameter",
             f"smaller than the section ({min(beam.width, beam.height)} m)", beam.hole_diameter)
    _require(beam.hole_diameter < beam.washer_outer_diameter < beam.width, "washer_outer_diameter",
             f"between hole_diameter ({beam.hole_diameter} m) and width ({beam.width} m)",
             beam.washer_outer_diameter)
    cuts = beam.patch_cuts
    _require(len(cuts) >= 2 and all(0.0 <= c <= 1.0 for c in cuts), "patch_cuts",
             "fractions of the lap length inside [0, 1]", cuts)
    _require(cuts[0] == 0.0 and cuts[-1] == 1.0 and all(b > a for a, b in zip(cuts, cuts[1:])), "patch_cuts",
             "strictly increasing from 0 to 1", cuts)
    radius = beam.washer_outer_diameter / 2
    for x in beam.bolt_x:
        _require(abs(x) + radius < beam.lap_length / 2, "bolt_x",
                 f"washers inside the lap (|x| + washer radius < {beam.lap_length / 2} m)", beam.bolt_x)
        for lower, upper in beam.patch_bounds:
            _require(not (lower - radius < x - 0.0 < lower + radius) or lower == -beam.lap_length / 2, "bolt_x",
                     f"washers clear of the patch cut at x = {lower:.6g} m", beam.bolt_x)
    for a, b in zip(sorted(beam.bolt_x), sorted(beam.bolt_x)[1:]):
        _require(b - a > 2 * radius, "bolt_x", "bolt pitch larger than the washer diameter", beam.bolt_x)
    if beam.spring_height is not None:
        _require(0 < beam.spring_height < beam.height, "spring_height",
                 f"between 0 and the section height ({beam.height} m)", beam.spring_height)
        _require(beam.spring_length / 2 < beam.spring_offset < beam.body_length - beam.spring_length / 2,
                 "spring_offset", "a flexure lying wholly inside the body", beam.spring_offset)


BRB = BeamParameters()
LBRB = BRB.replace(name="LBRB", body_length=0.4856)
SBRB = BRB.replace(name="SBRB", spring_height=0.004874)
BEAMS = {beam.name: beam for beam in (BRB, LBRB, SBRB)}
BEAM_NAMES = tuple(BEAMS)  # the three Brake-Reuss beams, in the order every stage lists them
