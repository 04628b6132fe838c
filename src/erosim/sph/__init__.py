"""Weakly compressible SPH fluid (SPEC SPH-1 … SPH-13): settings, physics and the solver.

Interface (what the run loop, scenarios and validation code against)::

    from erosim.sph.params import SPHParams
    from erosim.sph.solver import SPHSolver

    s = SPHSolver(params, fluid_pos,                   # (n, dim) initial fluid positions
                  boundary_pos=None,                   # (m, dim) fixed boundary particles, or None
                  domain_lo=lo, domain_hi=hi,          # (dim,) box; no particle ever leaves it
                  obstacles=[(lo, hi), ...],           # axis-aligned solid boxes
                  fluid_vel=None, seed=0)
    dt = s.step()                                      # one step; InstabilityError on NaN/explosion
    s.t, s.steps, s.n_fluid, s.n_boundary, s.dim
    s.fluid_positions(), s.fluid_velocities(), s.fluid_density(), s.fluid_pressure()
                                                       # copies, in the order fluid_pos was given
    s.boundary_positions()
    s.state_dict(); s.load_state_dict(d)              # exact resume
    s.dt_limit()                                       # current stable step (CFL, force, viscous, density diffusion)
    s.neighbour_stats()                                # {"mean": ..., ...}

With ``walls = "particles"`` the solver lays ``wall_layers`` of fixed boundary particles outside
every face of the domain box except the top, and inside every obstacle's surface, in addition to
any ``boundary_pos`` given; velocity reflection at the box and obstacles is always enforced, so no
particle passes a wall. A fixed ``dt`` above :meth:`SPHSolver.dt_limit` is refused at build time
with :class:`erosim.core.errors.ConfigError` naming the limit.
"""
