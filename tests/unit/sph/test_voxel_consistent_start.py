"""Water started in a voxel tank: the lattice fills the concave edges, and the hydrostatic start consistent with
the walls (``initial_pressure = "hydrostatic-consistent"``) against a direct lattice sum."""

import numpy as np
import pytest

from erosim.kernels.sph_kernels import kernel_w
from erosim.sph.boundaries.voxel_wall import VoxelWall
from erosim.sph.params import SPHParams
from erosim.sph.solver import SPHSolver
from erosim.terrain.voxel import HalfSpace, VoxelTerrain

DX = 0.02
L, W, D = 0.16, 0.1, 0.12  # tank length and width, water depth (m)


def box() -> VoxelTerrain:
    """Floor z = 0 and walls x = 0, x = L, y = 0, y = W on 2 cm voxels."""
    walls = [HalfSpace((0, 0, 0), (0, 0, 1)), HalfSpace((0, 0, 0), (1, 0, 0)), HalfSpace((L, 0, 0), (-1, 0, 0)),
             HalfSpace((0, 0, 0), (0, 1, 0)), HalfSpace((0, W, 0), (0, -1, 0))]  # fmt: skip
    return VoxelTerrain.from_shapes(walls, (-0.1, -0.1, -0.1), (L + 0.1, W + 0.1, D + 0.1), DX)


def test_the_lattice_fills_the_concave_edges():
    """A point Δx/2 from two walls reads l = Δx/4 by trilinear interpolation across the crease (the field is
    max(ramp₁, ramp₂), kinked there), so the distance test alone refused every row along the tank's edges;
    the sphere test keeps them: the box holds its whole lattice, 8 × 5 × 6 points. A point truly closer than
    Δx/2 to a wall is still refused."""
    vt = box()
    corner = np.array([[DX / 2, DX / 2, 0.05], [DX / 2, 0.05, DX / 2]])
    l, _ = vt.distance(corner)
    assert l == pytest.approx([DX / 8**0.5] * 2, rel=1e-4)  # the crease's interpolation error
    assert vt.clear_of_solid(corner, DX / 2).all()
    assert not vt.clear_of_solid([[0.3 * DX, 0.05, 0.05]], DX / 2)[0]  # 0.3Δx from the wall x = 0
    pts = vt.fluid_points(DX, below=D)
    assert len(pts) == 8 * 5 * 6


def _solver(start: str) -> tuple[SPHSolver, VoxelWall]:
    vt = box()
    wall = VoxelWall(vt)
    prm = SPHParams(dim=3, spacing=DX, walls="reflect", initial_pressure=start)
    return SPHSolver(prm, vt.fluid_points(DX, below=D), domain_lo=vt.lo, domain_hi=vt.hi, boundaries=[wall]), wall


def test_kernel_shortfall_against_a_direct_lattice_sum():
    """The shortfall S_i − S_ref of every particle deeper than h equals Z(l_i) − m Σ_k W(r_ik), the curve's wall
    share less the share of the lattice continued into the solid (a direct sum: fluid plus solid lattice is the
    whole lattice, whose sum is S_ref), to rounding. On a flat wall the two agree to 1.1 kg/m³ (the curve is
    averaged over the probe's offsets across a wall cell; held to 0.2 % of ρ₀); at a 90° edge the one-distance
    wall counts one wall (at 0.35Δx) and falls short by tens of kg/m³."""
    s, wall = _solver("hydrostatic")
    short = s._kernel_shortfall()
    pos = s.state.pos[: s.n_fluid].copy()
    l, _ = wall.distances(s)
    zshare = np.array([wall.curves.at(x)[0] if x < s.h else 0.0 for x in l])  # FAR beyond the ramp
    k = np.arange(-3, 12)  # the lattice continued 3Δx into the solid (h = 2Δx) around the tank
    lat = np.stack([g.ravel() for g in np.meshgrid(k, k, k, indexing="ij")], axis=1)
    lat = (lat + 0.5) * DX
    solid = lat[(lat[:, 0] < 0) | (lat[:, 0] > L) | (lat[:, 1] < 0) | (lat[:, 1] > W) | (lat[:, 2] < 0)]
    r = np.linalg.norm(pos[:, None, :] - solid[None, :, :], axis=2)
    direct = zshare - s.m * np.where(r < s.h, kernel_w(np.minimum(r, s.h), s.h, 3, "wendland"), 0.0).sum(axis=1)
    deep = pos[:, 2] < D - s.h
    assert np.allclose(short[deep], direct[deep], rtol=0, atol=1e-6)
    side = np.minimum.reduce([pos[:, 0], L - pos[:, 0], pos[:, 1], W - pos[:, 1]])
    floor_mid = deep & (pos[:, 2] < DX) & (side > s.h)
    edge = deep & (pos[:, 2] < DX) & (side < DX)
    assert floor_mid.any() and edge.any()
    assert np.abs(short[floor_mid]).max() < 2.0
    assert short[edge].max() < -20.0


def test_consistent_start_lowers_the_deep_particles_by_their_shortfall():
    """``hydrostatic-consistent`` starts every particle deeper than h at the hydrostatic density plus its
    shortfall, the shallower ones at the hydrostatic density; ``hydrostatic`` (the default) is unchanged."""
    plain, _ = _solver("hydrostatic")
    cons, _ = _solver("hydrostatic-consistent")
    nf = plain.n_fluid
    pos = plain.state.pos[:nf]
    assert np.array_equal(pos, cons.state.pos[:nf])
    deep = (pos[:, 2].max() + DX / 2) - pos[:, 2] >= plain.h
    diff = cons.state.rho[:nf] - plain.state.rho[:nf]
    assert np.allclose(diff[deep], plain._kernel_shortfall()[deep], rtol=0, atol=1e-9)
    assert np.all(diff[~deep] == 0.0) and (~deep).any()
