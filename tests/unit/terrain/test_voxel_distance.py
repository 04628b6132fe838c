"""Distance and normal from a voxel density field (SPEC VX-3) against analytic planes and spheres."""

import math

import numpy as np
import pytest

from erosim.kernels.voxel import FAR, wall_distance
from erosim.terrain.voxel import HalfSpace, Sphere, VoxelTerrain


def _query(vt: VoxelTerrain, pts: np.ndarray):
    pts = np.ascontiguousarray(pts, np.float64)
    l, n = np.empty(len(pts)), np.empty((len(pts), 3))
    ox, oy, oz = vt.origin
    wall_distance(vt.density, ox, oy, oz, 1.0 / vt.cell_size, vt.iso, pts, len(pts), l, n)
    return l, n


@pytest.mark.parametrize("tilt", [0.0, 30.0, 45.0, 63.0])
def test_tilted_plane_is_exact(tilt):
    """Inside the ramp the density is linear in space, which trilinear interpolation reproduces exactly:
    l and n are exact, out to b − √3Δ where the point's 8 nodes still lie in the ramp, but for float32
    densities (6e-8 of the range; over a ramp 2b = 0.24 m wide that is 1e-8 m in l, and 1e-6 in n as
    the differences of neighbouring nodes lose a factor 10): asserted to 1e-6 m and 1e-5.
    Sign: l > 0 on the fluid side, n points into the fluid."""
    a = math.radians(tilt)
    normal = np.array([math.sin(a) * 0.8, math.sin(a) * 0.6, math.cos(a)])
    plane = HalfSpace((0.5, 0.5, 0.5), tuple(normal))
    vt = VoxelTerrain.from_shapes(plane, (0, 0, 0), (1, 1, 1), 0.03)
    rng = np.random.default_rng(1)
    foot = 0.5 + (rng.random((500, 3)) - 0.5) * 0.4
    foot -= ((foot - 0.5) @ normal)[:, None] * normal  # on the plane
    s = (rng.random(500) * 2 - 1) * (vt.band - math.sqrt(3) * vt.cell_size)  # the cell's nodes in the ramp
    l, n = _query(vt, foot + s[:, None] * normal)
    assert np.abs(l - s).max() < 1e-6
    assert np.abs(n - normal).max() < 1e-5


def test_sphere_within_the_interpolation_error():
    """Solid ball of radius R, points within b/2 of its surface. The density is a ramp of r, so the
    Newton distance l = (ISO − d)/|∇d| is exact along the radius and the error is trilinear
    interpolation's: d is off by at most 3·Δ²/8·|∂²d| (|∂²d| ≤ 1/(2b r) per axis), |∇d| relatively by
    ε ≤ √3·Δ/2·|∂²d|/|∇d| = √3Δ/(2r), so |l − s| ≤ 3Δ²/(8r) + |s|·√3Δ/(2r) (3.2 mm here; measured
    1.2 mm) and the normal is off by at most ε (0.067 here; measured 0.047)."""
    R, cs = 0.3, 0.02
    ball = VoxelTerrain.from_shapes(Sphere((0.5, 0.5, 0.5), R), (0, 0, 0), (1, 1, 1), cs)
    rng = np.random.default_rng(2)
    u = rng.normal(size=(2000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    s = (rng.random(2000) * 2 - 1) * 0.5 * ball.band  # s > 0 outside the ball: in the fluid
    l, n = _query(ball, 0.5 + (R + s)[:, None] * u)
    rmin = R - 0.5 * ball.band
    err_l = np.abs(l - s).max()
    err_n = np.linalg.norm(n - u, axis=1).max()
    eps = math.sqrt(3) * cs / (2 * rmin)
    assert err_l < 3 * cs**2 / (8 * rmin) + 0.5 * ball.band * eps
    assert err_n < eps
    # a bowl: the same sphere as air in a solid block, normals now point to the centre
    bowl = ball.like(np.float32(1.0) - ball.density)
    l, n = _query(bowl, 0.5 + (R + s)[:, None] * u)
    assert np.abs(l + s).max() == pytest.approx(err_l, rel=1e-3)
    assert np.linalg.norm(n + u, axis=1).max() < eps


def test_far_from_any_surface_and_outside_the_grid():
    """Beyond the ramp (b = 0.2 m) the field is flat: l = ±FAR, n up; beyond the grid its edge continues."""
    vt = VoxelTerrain.from_shapes(HalfSpace((0, 0, 0.5), (0, 0, 1)), (0, 0, 0), (1, 1, 1), 0.05)
    l, n = _query(vt, np.array([[0.5, 0.5, 0.95], [0.5, 0.5, 0.05], [-3.0, 0.5, 0.55]]))
    assert l[0] == FAR and l[1] == -FAR and n[0].tolist() == [0.0, 0.0, 1.0]
    assert l[2] == pytest.approx(0.05, abs=1e-6)  # beyond the grid the edge continues: same plane


def test_terrain_distance_and_fluid_points():
    """The terrain's own helpers: l and n of points, and a lattice filling its hollow at Δx/2 from the walls."""
    floor = VoxelTerrain.from_shapes(HalfSpace((0, 0, 0.3), (0, 0, 1)), (0, 0, 0), (1, 1, 1), 0.05)
    l, n = floor.distance([[0.5, 0.5, 0.35], [0.5, 0.5, 0.28]])
    assert l == pytest.approx([0.05, -0.02], abs=1e-6) and n[:, 2] == pytest.approx([1.0, 1.0])
    pts = floor.fluid_points(0.1, below=0.6)
    assert pts[:, 2].min() == pytest.approx(0.35) and pts[:, 2].max() == pytest.approx(0.55)
    assert len(pts) == 10 * 10 * 3


@pytest.mark.parametrize("offset", [1 / 3, 2 / 3])
def test_a_concave_edge_is_felt_at_every_offset_of_the_grid(offset):
    """Two walls (floor z = 0, wall x = 0) on nodes that sit ``offset``·Δ off them: along the bisector through
    a node, the cell's polynomial is flat near that node and alone would read l → ∞ (no wall) in a pocket
    Δ/3 from both walls; the gradient blended towards the nodes' central differences reads a wall there, at
    most √2 times the true distance min(x, z) (the mean of the two walls' gradients, |∇d| = 1/√2 of one
    wall's, at the bisector; docstring of erosim.kernels.voxel). In the cell between the node and the walls
    trilinear interpolation rounds the corner and reads the wall closer than it is (down to 0.48 of it
    here), as it always has."""
    cs = 0.01
    o = -(3 + offset) * cs  # the grid's first node 3 + offset cells outside the walls
    edge = VoxelTerrain.from_shapes([HalfSpace((0, 0, 0), (0, 0, 1)), HalfSpace((0, 0, 0), (1, 0, 0))],
                                    (o, o, o), (0.2, 0.1, 0.2), cs)  # fmt: skip
    node = (1 - offset) * cs  # the first node inside, on the bisector x = z
    rng = np.random.default_rng(3)
    pts = np.column_stack([np.full(400, node), np.full(400, 0.05), np.full(400, node)])
    pts += (rng.random((400, 3)) - 0.5) * 0.2 * cs  # within a fifth of a cell of that node
    l, n = _query(edge, pts)
    true = np.minimum(pts[:, 0], pts[:, 2])
    assert np.all(l > 0.4 * true) and np.all(l <= np.sqrt(2) * true * (1 + 1e-6))
    assert np.all(n[:, [0, 2]] >= -1e-9) and np.abs(n[:, 1]).max() < 1e-6  # into the fluid, between the walls' normals
