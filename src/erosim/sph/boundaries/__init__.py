"""Boundary models of the SPH fluid, one protocol (:class:`~erosim.sph.boundaries.base.Boundary`).

* :class:`~erosim.sph.boundaries.box.BoxWalls` — the domain box and box obstacles by reflection (SPH-11);
* :class:`~erosim.sph.boundaries.particles.BoundaryParticles` — fixed (dynamic) boundary particles;
* walls known by a distance and a normal, through the wall-weight curves
  (:mod:`~erosim.sph.boundaries.wall_weight_harada2007`): :class:`~erosim.sph.boundaries.heightfield.HeightfieldGround`,
  :class:`~erosim.sph.boundaries.planes.PlaneWalls` and :class:`~erosim.sph.boundaries.voxel_wall.VoxelWall`
  (a voxel terrain's density field).

A boundary adds its own per-particle passes to the step, chosen when the solver is built; it never
adds a branch or an axis to the fused fluid pass.
"""

from erosim.sph.boundaries.base import Boundary

__all__ = ["Boundary"]
