"""The run-off flux Q on cases with known answers (docs/model.md §7.1), on the numpy flow
(``maps.runoff_flow``): a uniform inclined plane, water conserved on a closed mesh, a ledge over
a wall, a V-groove, a flat roof, a bowl, a sphere; the same Q for one quad and a fine grid, and
for millimetres and metres."""

import numpy as np
import pytest

from meshes import border_edges, box, facing, grid, merge, quad, ray_caster, sphere
from porous_weathering.maps import runoff_flow

VERTICAL = np.array([0.0, 0.0, -1.0])


def vertical_rain(vertices, triangles):
    """E of vertical rain on an unoccluded surface: the cosine of the normal with +Z."""
    normals = np.cross(
        vertices[triangles[:, 1]] - vertices[triangles[:, 0]], vertices[triangles[:, 2]] - vertices[triangles[:, 0]]
    )
    exposure = np.clip(normals[:, 2] / np.maximum(np.linalg.norm(normals, axis=1), 1e-300), 0.0, None)
    return lambda owner, weights: exposure[owner]


def surface_of(vertices, triangles, spacing, rain=None):
    rain = rain or vertical_rain(vertices, triangles)
    return runoff_flow.sample_surface(vertices, triangles, spacing, border_edges(vertices, triangles), rain)


def routed(vertices, triangles, spacing, rain=None, **options):
    surface = surface_of(vertices, triangles, spacing, rain)
    options.setdefault("land", ray_caster(vertices, triangles))
    return surface, runoff_flow.route(surface, surface.values, **options)


def inclined_plane(n=1, tilt=30.0, size=1.0):
    """A square plane, its slope along +y, falling from z = 0 at y = 0."""
    t = np.radians(tilt)
    return quad((0, 0, 0), (size, 0, 0), (0, size * np.cos(t), -size * np.sin(t)), n, normal=(0, np.sin(t), np.cos(t)))


def down_slope(surface, tilt=30.0):
    return surface.positions[:, 1] / np.cos(np.radians(tilt))


def inner(surface, size=1.0, margin=0.1):
    x = surface.positions[:, 0] / size
    s = down_slope(surface) / size
    return (x > margin) & (x < 1 - margin) & (s > margin) & (s < 1 - margin)


def relative_rms(values, expected):
    return float(np.sqrt(np.mean(((values - expected) / expected) ** 2)))


def test_a_uniform_inclined_plane_collects_its_rain_linearly_down_the_slope():
    surface, flow = routed(*inclined_plane(), 1 / 96)
    rain = np.cos(np.radians(30.0))
    middle = inner(surface)
    assert relative_rms(flow.flux[middle], rain * down_slope(surface)[middle]) < 0.04


def test_with_absorption_the_flux_saturates_as_e_l_1_minus_exp_minus_s_over_l():
    length = 0.25
    surface, flow = routed(*inclined_plane(), 1 / 96, absorption_length=length)
    rain, s = np.cos(np.radians(30.0)), down_slope(surface)
    middle = inner(surface)
    assert relative_rms(flow.flux[middle], (rain * length * -np.expm1(-s / length))[middle]) < 0.04
    assert flow.absorbed > 0.5 * flow.rain


@pytest.mark.parametrize("absorption_length", [np.inf, 0.3])
def test_water_is_conserved_on_a_closed_mesh(absorption_length):
    """Rain in = absorbed + what leaves (dripping from the undersides onto nothing)."""
    vertices, triangles = merge(box((-0.5, -0.5, 0.0), (0.5, 0.5, 0.3), 4), box((-0.2, -0.2, 0.3), (0.2, 0.2, 0.6), 4))
    _, flow = routed(vertices, triangles, 1 / 64, absorption_length=absorption_length)
    assert flow.rain > 0.9
    assert flow.absorbed + flow.left == pytest.approx(flow.rain, rel=0.01)
    assert (flow.absorbed == 0.0) == np.isinf(absorption_length)


def ledge_over_a_wall():
    """A wall facing -y (x, z in [0, 1]) with a slab-shaped ledge out to y = -0.2 at z 0.60-0.65,
    over a floor falling from z = 0 at the wall: the wall running on above the ledge."""
    toward = (0, -1, 0)
    return merge(
        quad((0, 0, 0), (1, 0, 0), (0, 0, 0.6), 8, toward),
        quad((0, 0, 0.65), (1, 0, 0), (0, 0, 0.35), 8, toward),
        quad((0, -0.2, 0.65), (1, 0, 0), (0, 0.2, 0), 8, (0, 0, 1)),
        quad((0, -0.2, 0.6), (1, 0, 0), (0, 0.2, 0), 8, (0, 0, -1)),
        quad((0, -0.2, 0.6), (1, 0, 0), (0, 0, 0.05), 8, toward),
        quad((0, -1, -0.1), (1, 0, 0), (0, 1, 0.1), 8, (0, -0.1, 1)),  # falling away from the wall
    )


def test_a_ledge_drips_straight_below_its_front_edge_and_the_wall_behind_its_drip_stays_dry():
    spacing = 1 / 64
    vertices, triangles = ledge_over_a_wall()
    on_the_ledge = vertices[triangles].mean(1)[:, 2] > 0.62  # rain on the ledge's top only
    rain = vertical_rain(vertices, triangles)
    surface, flow = routed(
        vertices, triangles, spacing, lambda owner, weights: rain(owner, weights) * on_the_ledge[owner]
    )
    p, n = surface.positions, surface.normals
    middle = np.abs(p[:, 0] - 0.5) < 0.3
    wall_below = middle & (n[:, 1] < -0.9) & (p[:, 1] > -spacing) & (p[:, 2] > 0.05) & (p[:, 2] < 0.55)
    assert flow.flux[wall_below].max() == 0.0
    # the floor: the ledge's water lands in a strip straight below the front edge (y = -0.2)
    floor = middle & (n[:, 2] > 0.9) & (p[:, 2] < spacing) & (p[:, 2] > -0.1 - spacing)
    landed = floor & (np.abs(p[:, 1] + 0.2) < 2 * spacing)
    elsewhere = floor & (np.abs(p[:, 1] + 0.2) > 4 * spacing) & (p[:, 1] > -0.15)
    assert flow.flux[landed].mean() > 10 * max(flow.flux[elsewhere].max(), 1e-9)


def test_a_v_groove_gathers_the_water_of_its_two_faces():
    """Two faces sloping 20 degrees into a groove along x, which itself falls 10 degrees."""
    fall, side = np.tan(np.radians(10.0)), np.tan(np.radians(20.0))

    def face(sign):
        return grid(24, 24, lambda u, v: np.column_stack([u, sign * 0.5 * v, -fall * u + side * 0.5 * v]))

    left, right = face(1.0), face(-1.0)
    vertices, triangles = merge(left, right)
    triangles = facing(vertices, triangles, lambda centres: np.broadcast_to((0, 0, 1), centres.shape))
    surface, flow = routed(vertices, triangles, 1 / 96)
    p = surface.positions
    groove = (np.abs(p[:, 1]) < 1.5 / 96) & (p[:, 0] > 0.8) & (p[:, 0] < 0.9)
    faces = (np.abs(p[:, 1]) > 0.2) & (p[:, 0] > 0.8) & (p[:, 0] < 0.9)
    assert flow.flux[groove].mean() > 5 * flow.flux[faces].mean()
    # what leaves at the groove's low end is all the rain the two faces took
    assert flow.left == pytest.approx(flow.rain, rel=1e-6)


def test_a_flat_roof_drains_over_all_of_its_edges():
    surface, flow = routed(*box((0, 0, 0), (1, 1, 0.5), 8), 1 / 48)
    p, n = surface.positions, surface.normals
    tops_of_walls = (np.abs(n[:, 2]) < 0.1) & (p[:, 2] > 0.45)
    for axis, value in ((0, 0.0), (0, 1.0), (1, 0.0), (1, 1.0)):
        side = tops_of_walls & (np.abs(p[:, axis] - value) < 1e-6 + 1 / 48)
        middle = side & (np.abs(p[:, 1 - axis] - 0.5) < 0.25)
        assert flow.flux[middle].min() > 0.05, (axis, value)
    assert flow.left == pytest.approx(flow.rain, rel=1e-6)


def test_a_bowl_fills_and_overflows_at_its_lowest_rim():
    """A square basin in the rain whose rim is lower on one side (z 0.3 at x = 1, 0.5 elsewhere):
    the water it takes leaves over the low rim and runs down the outside of that wall."""
    inner_x, low, high = 0.95, 0.3, 0.5
    parts = [
        quad((0, 0, 0.1), (inner_x, 0, 0), (0, 1, 0), (12, 12), (0, 0, 1)),  # the floor
        quad((0, 0, 0.1), (0, 1, 0), (0, 0, high - 0.1), (12, 8), (1, 0, 0)),  # the high walls
        quad((0, 0, 0.1), (inner_x, 0, 0), (0, 0, high - 0.1), (12, 8), (0, 1, 0)),
        quad((0, 1, 0.1), (inner_x, 0, 0), (0, 0, high - 0.1), (12, 8), (0, -1, 0)),
        quad((inner_x, 0, 0.1), (0, 1, 0), (0, 0, low - 0.1), (12, 4), (-1, 0, 0)),  # the low wall's inside,
        quad((inner_x, 0, low), (1 - inner_x, 0, 0), (0, 1, 0), (2, 12), (0, 0, 1)),  # its rim,
        quad((1, 0, 0), (0, 1, 0), (0, 0, low), (12, 4), (1, 0, 0)),  # and its outside
    ]
    surface, flow = routed(*merge(*parts), 1 / 48)
    p, n = surface.positions, surface.normals
    outside = (n[:, 0] > 0.9) & (p[:, 0] > 1 - 1e-6) & (p[:, 2] < low - 0.05) & (np.abs(p[:, 1] - 0.5) < 0.3)
    assert flow.flux[outside].mean() > 0.5 * inner_x  # the basin's rain over the wall's width of 1
    assert flow.left == pytest.approx(flow.rain, rel=1e-6)


def test_a_sphere_flows_along_its_meridians():
    """Vertical rain on a unit sphere: Q = sin(theta) / 2 at the polar angle theta of the upper
    half (the rain on the cap above, pi sin^2 theta, over the circle 2 pi sin theta)."""
    vertices, triangles = sphere(64)
    surface, flow = routed(vertices, triangles, 1 / 32)
    p = surface.positions
    theta = np.arccos(np.clip(p[:, 2] / np.linalg.norm(p, axis=1), -1.0, 1.0))
    for degrees in (30, 50, 70, 85):
        band = np.abs(theta - np.radians(degrees)) < 0.02
        assert flow.flux[band].mean() == pytest.approx(np.sin(np.radians(degrees)) / 2, rel=0.05), degrees


def test_one_quad_and_a_fine_grid_give_the_same_flux():
    coarse, coarse_flow = routed(*inclined_plane(1), 1 / 64, absorption_length=0.5)
    fine, fine_flow = routed(*inclined_plane(64), 1 / 64, absorption_length=0.5)
    points = coarse.positions[inner(coarse)]
    at = runoff_flow.interpolate
    a = at(coarse, coarse_flow.flux, points, coarse.normals[inner(coarse)])
    b = at(fine, fine_flow.flux, points, coarse.normals[inner(coarse)])
    length = 0.05  # R of a run-off length of 5% of the size
    assert np.abs(runoff_flow.runoff_map(a, length) - runoff_flow.runoff_map(b, length)).max() < 0.02


def test_millimetres_and_metres_give_the_same_map():
    """A sphere over a plate it drips onto, in metres and in millimetres (the lengths with it)."""
    ball = sphere(48, 0.3)
    vertices, triangles = merge(
        (ball[0] + (0.5, 0.5, 0.5), ball[1]), quad((0, 0, 0), (1, 0, 0), (0, 1, 0), 16, (0, 0, 1))
    )
    metres, metres_flow = routed(vertices, triangles, 1 / 64, absorption_length=0.3)
    mm, mm_flow = routed(vertices * 1000.0, triangles, 1000 / 64, absorption_length=300.0)
    points, normals = metres.positions, metres.normals
    at_metres = runoff_flow.interpolate(metres, metres_flow.flux, points, normals)
    at_mm = runoff_flow.interpolate(mm, mm_flow.flux, points * 1000.0, normals)
    assert np.abs(runoff_flow.runoff_map(at_metres, 0.05) - runoff_flow.runoff_map(at_mm, 50.0)).max() < 0.02
