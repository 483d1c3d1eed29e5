"""The geometry stage: the meshed beams have the volumes, areas, interface and groups the parameters say."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from geometry import properties
from geometry.beam_mesh import interface_partners, read_beam_mesh
from geometry.beams import make_beam
from geometry.parameters import BEAMS, BRB, GeometryError, MeshParameters
from cli.console import main as surrogacy

BEAM_NAMES = sorted(BEAMS)
SIDES = ("lower", "upper")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The three beams meshed once at the default sizes: name -> (sidecar record, BeamMesh, folder)."""
    folder = tmp_path_factory.mktemp("beams")
    result = {}
    for name in BEAM_NAMES:
        sidecar = make_beam(BEAMS[name], MeshParameters(), folder)
        result[name] = (json.loads(sidecar.read_text()), read_beam_mesh(folder / f"{name}.msh"), folder)
    return result


def _relative(a, b):
    return abs(a - b) / abs(b)


@pytest.mark.parametrize("name", BEAM_NAMES)
def test_cad_volume_and_mass_equal_analytic(built, name):
    record, _, _ = built[name]
    beam = BEAMS[name]
    for side in SIDES:
        assert _relative(record["cad"]["volume_m3"][f"{side}_half"], properties.half_volume(beam)) < 1e-9
    cad_mass = beam.density * sum(record["cad"]["volume_m3"].values())
    assert _relative(cad_mass, properties.beam_mass(beam)) < 1e-9


@pytest.mark.parametrize("name", BEAM_NAMES)
def test_mesh_volume_is_analytic_with_holes_replaced_by_their_meshed_polyhedra(built, name):
    """Straight-sided tetrahedra fill the solid exactly except where the hole walls are faceted."""
    _, mesh, _ = built[name]
    beam = BEAMS[name]
    cylinder = properties.hole_area(beam) * beam.lap_thickness
    for side in SIDES:
        holes = [properties.hole_volume(mesh.points, mesh.faces[f"{side}_hole_wall_{b}"], x)
                 for b, x in enumerate(sorted(beam.bolt_x), start=1)]
        meshed = properties.tetrahedron_volumes(mesh.points, mesh.volumes[f"{side}_half"]).sum()
        assert _relative(meshed, properties.solid_half_volume(beam) - sum(holes)) < 1e-10
        for hole in holes:  # inscribed polyhedron: smaller than the cylinder by the chord error (~16 facets)
            assert 0 < (cylinder - hole) / cylinder < 0.05


@pytest.mark.parametrize("name", BEAM_NAMES)
def test_patch_areas_equal_analytic(built, name):
    record, mesh, _ = built[name]
    beam = BEAMS[name]
    analytic = properties.patch_areas(beam)
    lap_area = beam.lap_length * beam.width - len(beam.bolt_x) * properties.hole_area(beam)
    assert analytic.sum() == pytest.approx(lap_area, rel=1e-12)
    radius = beam.hole_diameter / 2
    for side in SIDES:
        for p, (lower, upper) in enumerate(beam.patch_bounds, start=1):
            name_p = f"{side}_patch_{p}"
            assert _relative(record["cad"]["patch_area_m2"][name_p], analytic[p - 1]) < 1e-9
            # The meshed patch is the strip minus the polygon inscribed in each of its holes: exact.
            polygons = sum(properties.hole_polygon_area(mesh.points, mesh.face_nodes(name_p), (x, 0.0), radius)
                           for x in beam.bolt_x if lower < x < upper)
            meshed = properties.triangle_areas(mesh.points, mesh.faces[name_p]).sum()
            holes = sum(lower < x < upper for x in beam.bolt_x)
            assert _relative(meshed, (upper - lower) * beam.width - polygons) < 1e-10
            assert _relative(meshed, analytic[p - 1]) < 5e-3 * holes + 1e-10


def test_patch_fractions_of_the_lap():
    """Patches 1 and 5 are 1/8, patches 2-4 are 1/4 of the lap, each of 2-4 less one hole."""
    beam = BRB
    strip = beam.lap_length * beam.width
    expected = np.array([strip / 8, strip / 4 - properties.hole_area(beam), strip / 4 - properties.hole_area(beam),
                         strip / 4 - properties.hole_area(beam), strip / 8])
    np.testing.assert_allclose(properties.patch_areas(beam), expected, rtol=1e-12)


@pytest.mark.parametrize("name", BEAM_NAMES)
def test_interface_nodes_pair_exactly(built, name):
    _, mesh, _ = built[name]
    lower, upper = interface_partners(mesh)
    assert np.abs(mesh.points[lower] - mesh.points[upper]).max() < 1e-9
    assert len(np.intersect1d(lower, upper)) == 0, "the halves must not share nodes"
    assert np.abs(mesh.points[lower, 2]).max() < 1e-12, "interface lies in z = 0"
    for p in range(1, 6):
        assert np.array_equal(np.sort(mesh.points[mesh.face_nodes(f"lower_patch_{p}")], axis=0),
                              np.sort(mesh.points[mesh.face_nodes(f"upper_patch_{p}")], axis=0))


@pytest.mark.parametrize("name", BEAM_NAMES)
def test_each_bolt_axis_inside_its_patch(built, name):
    _, mesh, _ = built[name]
    beam = BEAMS[name]
    bounds = beam.patch_bounds
    for side in SIDES:
        for b, x in enumerate(sorted(beam.bolt_x), start=1):
            wall = mesh.points[mesh.face_nodes(f"{side}_hole_wall_{b}")]
            # circle through the wall nodes (linear least squares: x^2 + y^2 = 2 a x + 2 b y + c)
            design = np.column_stack([2 * wall[:, 0], 2 * wall[:, 1], np.ones(len(wall))])
            a, b_, c = np.linalg.lstsq(design, (wall[:, :2] ** 2).sum(axis=1), rcond=None)[0]
            axis = np.array([a, b_])
            assert np.allclose(axis, [x, 0.0], atol=1e-9)
            assert math.sqrt(c + a * a + b_ * b_) == pytest.approx(beam.hole_diameter / 2, rel=1e-9)
            lower, upper = bounds[b]  # bolt b sits in patch b + 1
            assert lower < axis[0] < upper
            washer = mesh.points[mesh.face_nodes(f"{side}_washer_{b}")]
            assert np.allclose(washer[:, 2], -beam.height / 2 if side == "lower" else beam.height / 2)
            assert np.hypot(washer[:, 0] - x, washer[:, 1]).max() == pytest.approx(beam.washer_outer_diameter / 2)


@pytest.mark.parametrize("name", BEAM_NAMES)
def test_every_physical_group_present_and_non_empty(built, name):
    record, mesh, _ = built[name]
    expected = {f"{side}_{group}" for side in SIDES for group in
                ["half", "interface"] + [f"patch_{p}" for p in range(1, 6)] +
                [f"washer_{b}" for b in range(1, 4)] + [f"hole_wall_{b}" for b in range(1, 4)]}
    assert set(record["physical_groups"]) == expected
    assert set(mesh.volumes) | set(mesh.faces) == expected
    for group in expected:
        assert len(mesh.volumes.get(group, mesh.faces.get(group, []))) > 0, group


def test_sbrb_flexure_is_thinned_section():
    """The SBRB differs from the BRB only by the flexures: volume deficit = 2 x length x width x depth."""
    sbrb = BEAMS["SBRB"]
    deficit = properties.half_volume(BRB) - properties.half_volume(sbrb)
    assert deficit == pytest.approx(sbrb.spring_length * sbrb.width * (sbrb.height - sbrb.spring_height), rel=1e-12)


def test_remeshing_gives_an_identical_file_and_a_cache_hit(built, tmp_path):
    record, _, folder = built["BRB"]
    sidecar = make_beam(BRB, MeshParameters(), tmp_path, render=False)
    assert (tmp_path / "BRB.msh").read_bytes() == (folder / "BRB.msh").read_bytes()
    assert json.loads(sidecar.read_text())["files"]["msh"]["sha256"] == record["files"]["msh"]["sha256"]
    before = sidecar.stat().st_mtime_ns, (tmp_path / "BRB.msh").stat().st_mtime_ns
    make_beam(BRB, MeshParameters(), tmp_path, render=False)
    assert (sidecar.stat().st_mtime_ns, (tmp_path / "BRB.msh").stat().st_mtime_ns) == before


def test_a_changed_parameter_remeshes(tmp_path):
    sizes = MeshParameters(size=0.0127, lap_size=0.0064, hole_size=0.0032)
    first = json.loads(make_beam(BRB, sizes, tmp_path, render=False).read_text())
    second = json.loads(make_beam(BRB.replace(body_length=0.25), sizes, tmp_path, render=False).read_text())
    assert first["input_hash"] != second["input_hash"]
    assert second["cad"]["volume_m3"]["lower_half"] == pytest.approx(
        properties.half_volume(BRB.replace(body_length=0.25)), rel=1e-9)


@pytest.mark.parametrize("name", BEAM_NAMES)
def test_render_shows_the_coloured_patches(built, name):
    from matplotlib import colormaps
    from PIL import Image

    _, _, folder = built[name]
    image = np.asarray(Image.open(folder / f"{name}.png").convert("RGB")).reshape(-1, 3).astype(int)
    assert (np.abs(image - 255).sum(axis=1) > 30).mean() > 0.05, "image is blank"
    for p in range(5):  # every patch colour is present (lit faces shade it, so allow a band)
        colour = np.array(colormaps["tab10"](p)[:3]) * 255
        assert (np.abs(image - colour).max(axis=1) < 40).sum() > 200, f"patch {p + 1} not visible"


def test_quadratic_mesh_has_straight_sided_ten_node_tetrahedra(tmp_path):
    sizes = MeshParameters(size=0.0127, lap_size=0.0064, hole_size=0.0032, order=2)
    make_beam(BRB, sizes, tmp_path, render=False)
    mesh = read_beam_mesh(tmp_path / "BRB.msh")
    tetrahedra = mesh.tetrahedra
    assert tetrahedra.shape[1] == 10
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)]  # gmsh's order of nodes 4..9
    for k, (i, j) in enumerate(edges):
        midpoint = (mesh.points[tetrahedra[:, i]] + mesh.points[tetrahedra[:, j]]) / 2
        assert np.abs(mesh.points[tetrahedra[:, 4 + k]] - midpoint).max() < 1e-12
    lower, upper = interface_partners(mesh)
    assert np.abs(mesh.points[lower] - mesh.points[upper]).max() < 1e-9
    assert len(lower) == len(np.unique(mesh.faces["lower_interface"]))


@pytest.mark.parametrize("setting, parameter", [
    ("BRB.body_length=-0.1", "body_length"),
    ("LBRB.lap_length=-0.12", "lap_length"),
    ("SBRB.hole_diameter=0.03", "hole_diameter"),
    ("BRB.patch_cuts=[0.0, 0.125, 0.375, 0.625, 1.2]", "patch_cuts"),
    ("BRB.patch_cuts=[-0.1, 0.125, 0.375, 0.625, 1.0]", "patch_cuts"),
    ("mesh.size=0", "size"),
    ("SBRB.spring_height=0.03", "spring_height"),
])
def test_bad_input_names_the_parameter_and_writes_nothing(tmp_path, capsys, setting, parameter):
    out = tmp_path / "beams"
    assert surrogacy(["beams", "--out", str(out), "--set", setting]) == 2
    message = capsys.readouterr().err
    assert f"'{parameter}'" in message and "expected" in message
    assert not out.exists() or not any(out.iterdir())


def test_bad_configuration_file_names_the_file_and_field(tmp_path, capsys):
    config = tmp_path / "beams.toml"
    config.write_text("[LBRB]\nbody_lenght = 0.5\n")
    assert surrogacy(["beams", "--out", str(tmp_path / "out"), "--config", str(config)]) == 2
    message = capsys.readouterr().err
    assert str(config) in message and "body_lenght" in message and "[LBRB]" in message


def test_interrupted_build_leaves_nothing_half_written(tmp_path, monkeypatch):
    import geometry.beams

    def failing_render(*_args, **_kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(geometry.beams, "render_patches", failing_render)
    with pytest.raises(KeyboardInterrupt):
        make_beam(BRB, MeshParameters(size=0.0127, lap_size=0.0064, hole_size=0.0032), tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_geometry_errors_are_value_errors():
    with pytest.raises(GeometryError, match="washer_outer_diameter"):
        BRB.replace(washer_outer_diameter=0.005)
    assert issubclass(GeometryError, ValueError)
    assert math.isclose(BRB.patch_bounds[2][0], -BRB.lap_length / 8)
