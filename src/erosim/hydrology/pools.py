"""HY-2 flood: lakes that fill to their spill level, then drain toward the spill point.

Seed semantics (SimpleHydrology 2020, ``Drop::flood``): a particle that stops (slow-down in a strong
stream) or enters a pool raises a test plane over the 8-connected set of cells whose surface
h + pool lies below it. A cell of that set lower than the current water level is a *drain*: the
particle moves to the lowest one, the level is lowered slowly toward the drain's,
L ← (1 − r)·L + r·(h + pool)_drain with r = ``drainage`` (0.001), 10 % of the sediment is kept, and
the particle descends again. Without a drain the particle's volume fills the set: the level rises
by V / (volume_factor · set size) (the seed iterates a test plane with ``approach`` = 0.5 and up to
10 failures to find that level; here it is solved exactly).

Why not the seed's algorithm: every iteration re-runs a recursive flood fill of the whole lake and
clears a map-sized ``tried`` array, so one flood costs O(lake area) (plus O(map)) several times, and
lake filling dominated the seed's run time. Here each lake is kept **incrementally**:

* ``lake_of[c]`` — the lake a cell belongs to (−1 = dry); ``level[k]`` — lake k's flat water level;
  ``area[k]`` — its member count A. Every member has h ≤ L (wet, or exactly at the level), so the
  stored water is Σ (L − h)·Δx² and raising or lowering L by δ changes it by exactly A·δ·Δx².
* a **boundary min-heap** per lake holds the 8-neighbours of its members keyed by their surface
  (terrain h, another lake's level, the sea level; cells on the map edge, or beside a nodata cell of
  the DEM (``lake_of`` = OUTSIDE), add an *off-map* entry at the sea level, −∞ without a sea: HY-8,
  water leaves at the edges instead of meeting a wall);
* a **member max-heap** per lake, keyed by h, gives the members that fall dry when the level drops.

Both heaps are *leftist heaps* in one shared node pool, so merging two lakes' heaps costs
O(log n) and relabelling the smaller lake's cells is amortised O(log n) per cell (union by size).
Adding water (priority-flood in increasing surface order, Barnes et al. 2014, done lazily): while
the particle still has volume, look at the lowest boundary entry e. If e < L it is a drain (the lake
is full): lower L toward it as the seed does, hand the released water to the particle and move the
particle there. Otherwise raise L toward e; if the volume runs out first, L rises by V/(A·Δx²) and
the particle is spent; else L = e, the cell joins the lake (or, if it is another lake's
surface at the same level, the two lakes merge) and its neighbours are pushed. Keys are
re-validated when they reach the top of a heap (terrain changes by erosion), and every
``rebuild_every`` cycles the heaps are rebuilt from ``lake_of`` and ``level`` (:func:`rebuild`),
so a stale key (an outlet eroded lower) is corrected within those cycles; checkpoints hold the
heaps themselves, so a resumed run is bit-identical. The cost per droplet is O(log n) plus
O(log n) per cell the lake gains or loses — independent of the lake's area — instead of the
seed's O(area) per flood iteration.

Volumes: the particle's volume V is in m³ (a seed unit volume is ℓ³/volume_factor, see
:mod:`erosim.hydrology.params`), lake storage is Σ depth·Δx², so the seed's volume_factor is built
into the droplet volume and the exchange is exact: what a particle gives, the lake stores.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# indices into the int64 scratch array ``hs``
HS_BUMP = 0  # next never-used heap node
HS_FREE = 1  # head of the free-node list (-1: empty)
HS_NLAKES = 2  # lake ids in use (dead ones included until the next rebuild)

# indices into the float64 budget array ``B`` (shared with the droplet and cycle kernels)
B_RAINED = 0
B_EVAP = 1  # evaporated along the paths
B_RESID = 2  # residual volume of particles that ended (below minimum, spill limit)
B_LEFT = 3  # water that left the world (map edges, sea)
B_TO_LAKES = 4  # net water given to lakes (tracked)
B_ERODED = 5
B_DEPOSITED = 6
B_CARRIED = 7  # sediment that left the world
B_FLOOD_NS = 8  # nanoseconds spent in flood (when timing)
B_STEPS = 9  # descend steps
B_FLOODS = 10  # flood calls
B_CREPT = 11  # terrain volume moved by hillslope creep (hydrology/hillslope_creep_culling1960.py)
B_DISPLACED = 12  # lake water displaced by soil creeping in from the shore (:func:`settle_gains`)
B_SIZE = 13

OFF = -1  # heap cell code offset: off-map entries are stored as -(edge cell + 2)

# lake_of codes besides a lake's index
NO_LAKE = -1  # a dry cell
OUTSIDE = -2  # a nodata cell of the DEM: outside the world, like the map's edge (water reaching it leaves)
HALO = -3  # a tile's halo in a tiled build: water reaching it leaves to the neighbouring tile, over its own surface

# flood results
SPENT = 0  # volume went into a lake
DRAIN = 1  # particle moved to a drain cell; descend again
LEFT = 2  # particle left the world through a drain at the map edge or into the sea
FILLED = 3  # its sediment filled the lake it entered: the particle goes on from the entry, descending again
FILL_ROUND = 0.125  # a FILLED flood costs this share of a spill round (a spill round: DRAIN), so at most 8·spill


# ------------------------------------------------------------------------------ leftist heaps
@njit(cache=True)
def _alloc(key, cell, hkey, hcell, hleft, hright, hrank, hs):
    f = hs[HS_FREE]
    if f >= 0:
        hs[HS_FREE] = hleft[f]
        n = f
    else:
        n = hs[HS_BUMP]
        hs[HS_BUMP] = n + 1
    hkey[n] = key
    hcell[n] = cell
    hleft[n] = -1
    hright[n] = -1
    hrank[n] = 1
    return n


@njit(cache=True)
def _free(n, hleft, hs):
    hleft[n] = hs[HS_FREE]
    hs[HS_FREE] = n


@njit(cache=True)
def merge(a, b, hkey, hleft, hright, hrank, stack):
    """Meld two leftist min-heaps (roots a, b; −1 = empty) along their right spines: O(log n)."""
    if a < 0:
        return b
    if b < 0:
        return a
    if hkey[b] < hkey[a]:
        a, b = b, a
    root = a
    n = 0
    while True:
        stack[n] = a
        n += 1
        r = hright[a]
        if r < 0:
            hright[a] = b
            break
        if hkey[b] < hkey[r]:
            hright[a] = b
            a, b = b, r
        else:
            a = r
    for i in range(n - 1, -1, -1):
        x = stack[i]
        lft = hleft[x]
        rgt = hright[x]
        rl = hrank[lft] if lft >= 0 else 0
        rr = hrank[rgt] if rgt >= 0 else 0
        if rl < rr:
            hleft[x] = rgt
            hright[x] = lft
            rr = rl
        hrank[x] = rr + 1
    return root


@njit(cache=True)
def push(root, key, cell, hkey, hcell, hleft, hright, hrank, hs, stack):
    n = _alloc(key, cell, hkey, hcell, hleft, hright, hrank, hs)
    return merge(root, n, hkey, hleft, hright, hrank, stack)


@njit(cache=True)
def pop(root, hkey, hleft, hright, hrank, hs, stack):
    """Remove the root; returns the new root (the node goes back to the free list)."""
    new = merge(hleft[root], hright[root], hkey, hleft, hright, hrank, stack)
    _free(root, hleft, hs)
    return new


# ------------------------------------------------------------------------------ lake helpers
@njit(cache=True)
def surface(c, zf, lake_of, level, sea_level):
    """Water/terrain surface of cell c as another lake sees it: a lake's level, the sea, or h."""
    j = lake_of[c]
    if j >= 0:
        return level[j]
    h = zf[c]
    if h < sea_level:
        return sea_level
    return h


@njit(cache=True)
def walk_down(c, max_walk, zf, lake_of, level, sea_level, nx, ny):
    """Steepest-descent (D8) walk over the *surface* (lakes at their level) from cell c.

    Returns (cell, at_minimum) after at most ``max_walk`` moves. Used to move a droplet off a
    drain (so that it does not slide back onto the bed of the lake it just left) and to find the
    bottom of the depression a slow droplet sits in (``pit_flood``). A walk that steps into a tile's
    halo (``HALO``) ends there, as at a minimum: the caller passes the droplet on to the neighbour.
    """
    for _ in range(max_walk):
        iy = c // nx
        ix = c - iy * nx
        best = c
        hb = surface(c, zf, lake_of, level, sea_level)
        for j in range(max(iy - 1, 0), min(iy + 2, ny)):
            for i in range(max(ix - 1, 0), min(ix + 2, nx)):
                n = j * nx + i
                if lake_of[n] == OUTSIDE:
                    continue
                h = surface(n, zf, lake_of, level, sea_level)
                if h < hb:
                    hb = h
                    best = n
        if best == c:
            return c, True
        c = best
        if lake_of[c] == HALO:  # the walk left the tile: the caller passes the droplet on from there
            return c, True
    return c, False


@njit(cache=True)
def _push_neighbours(
    k, c, nx, ny, zf, lake_of, level, broot, sea_level, edge_key, hkey, hcell, hleft, hright, hrank, hs, stack
):
    iy = c // nx
    ix = c - iy * nx
    edge = False
    for dy in range(-1, 2):
        jy = iy + dy
        if jy < 0 or jy >= ny:
            edge = True
            continue
        for dx in range(-1, 2):
            if dx == 0 and dy == 0:
                continue
            jx = ix + dx
            if jx < 0 or jx >= nx:
                edge = True
                continue
            n = jy * nx + jx
            if lake_of[n] == OUTSIDE:  # a nodata cell drains the lake as the map's edge does
                edge = True
                continue
            if lake_of[n] == k:
                continue
            broot[k] = push(
                broot[k], surface(n, zf, lake_of, level, sea_level), n, hkey, hcell, hleft, hright, hrank, hs, stack
            )
    if edge:
        broot[k] = push(broot[k], edge_key, -(c + 2), hkey, hcell, hleft, hright, hrank, hs, stack)


@njit(cache=True)
def new_lake(
    c, nx, ny, zf, lake_of, level, area, mroot, broot, sea_level, edge_key, hkey, hcell, hleft, hright, hrank, hs, stack
):
    """A one-cell lake at c with level h[c] (no water yet)."""
    k = hs[HS_NLAKES]
    hs[HS_NLAKES] = k + 1
    level[k] = zf[c]
    area[k] = 1
    lake_of[c] = k
    mroot[k] = push(-1, -zf[c], c, hkey, hcell, hleft, hright, hrank, hs, stack)
    broot[k] = -1
    _push_neighbours(
        k, c, nx, ny, zf, lake_of, level, broot, sea_level, edge_key, hkey, hcell, hleft, hright, hrank, hs, stack
    )
    return k


@njit(cache=True)
def _relabel(root, old, new, lake_of, hcell, hleft, hright, walk):
    """Every member of heap ``root`` still in lake ``old`` moves to lake ``new`` (tree walk)."""
    if root < 0:
        return
    n = 1
    walk[0] = root
    while n > 0:
        n -= 1
        x = walk[n]
        c = hcell[x]
        if c >= 0 and lake_of[c] == old:
            lake_of[c] = new
        if hleft[x] >= 0:
            walk[n] = hleft[x]
            n += 1
        if hright[x] >= 0:
            walk[n] = hright[x]
            n += 1


@njit(cache=True)
def _merge_lakes(a, b, lake_of, area, mroot, broot, hkey, hcell, hleft, hright, hrank, stack, walk):
    """Union by size of two lakes at the same level; returns the surviving id."""
    if area[b] > area[a] or (area[b] == area[a] and b < a):
        a, b = b, a
    _relabel(mroot[b], b, a, lake_of, hcell, hleft, hright, walk)
    mroot[a] = merge(mroot[a], mroot[b], hkey, hleft, hright, hrank, stack)
    broot[a] = merge(broot[a], broot[b], hkey, hleft, hright, hrank, stack)
    area[a] += area[b]
    area[b] = 0
    mroot[b] = -1
    broot[b] = -1
    return a


@njit(cache=True)
def lower(
    k, new_level, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright, hrank, hs, stack
):
    """Lower lake k to ``new_level``; members above it fall dry. Returns the water released (m³)."""
    L = level[k]
    released = 0.0
    while area[k] > 0:
        top = mroot[k]
        if top < 0:
            break
        c = hcell[top]
        if lake_of[c] != k or zf[c] != -hkey[top]:
            mroot[k] = pop(top, hkey, hleft, hright, hrank, hs, stack)
            continue
        zc = zf[c]
        if zc <= new_level:
            break
        if zc < L:
            released += area[k] * (L - zc) * cell_area
            L = zc
        mroot[k] = pop(top, hkey, hleft, hright, hrank, hs, stack)
        lake_of[c] = -1
        area[k] -= 1
        broot[k] = push(broot[k], zc, c, hkey, hcell, hleft, hright, hrank, hs, stack)
    if area[k] > 0 and new_level < L:
        released += area[k] * (L - new_level) * cell_area
        L = new_level
    level[k] = L
    return released


@njit(cache=True, inline="always")
def reach(c, nx, ny, spread):
    """The cells within ``spread`` of cell c on an ny × nx map, a (2·spread + 1)² square clipped to
    it: (j_lo, j_hi, i_lo, i_hi)."""
    iy = c // nx
    ix = c - iy * nx
    return max(iy - spread, 0), min(iy + spread + 1, ny), max(ix - spread, 0), min(ix + spread + 1, nx)


@njit(cache=True, inline="always")
def count_in(lake_of, box, nx, mark):
    """How many cells of ``box`` (:func:`reach`) have ``lake_of`` = ``mark`` (a lake's id, or NO_LAKE)."""
    j_lo, j_hi, i_lo, i_hi = box
    n = 0
    for j in range(j_lo, j_hi):
        for i in range(i_lo, i_hi):
            if lake_of[j * nx + i] == mark:
                n += 1
    return n


@njit(cache=True)
def settle_dry(c, amount, zf, lake_of, level, sea_level, nx, cell_area, spread=0):
    """Sediment ``amount`` (m³) settles at dry cell c of a map ``nx`` cells wide: first into c, up to
    the lowest surface of its 8 neighbours (:func:`surface`), where c is a pit; the rest on the dry
    cells within ``spread`` cells of c (a (2·spread + 1)² square, clipped to the map) in equal
    heights; ``spread`` 0: all on c (the seed's one-cell droplets).

    A load settles where its water stopped: into the pit it stopped in, then as a layer over the
    droplet's reach (``spread`` = footprint // 2, as in a lake, :func:`settle_in_lake`), the same
    ~ℓ² area at any cell size. Dropped on c alone (before issue 38) it made a spike S/Δx² tall, 16
    times taller on 5 m cells than on 20 m cells for the same load, and left pits between the spikes
    where later droplets stopped and flooded, the more often the finer the grid. (A pyramid over
    the reach instead of a layer leaves c a mound at the bottom of its pit, and a closed bowl then
    kept 77 % of its rain in its lake instead of 94 %: `tests/scenarios/test_users_dems.py`.)
    """
    if amount <= 0.0:
        return
    if spread <= 0:
        zf[c] += amount / cell_area
        return
    ny = zf.shape[0] // nx
    j_lo, j_hi, i_lo, i_hi = reach(c, nx, ny, 1)
    rim = math.inf
    for j in range(j_lo, j_hi):
        for i in range(i_lo, i_hi):
            n = j * nx + i
            if n != c and lake_of[n] != OUTSIDE:
                rim = min(rim, surface(n, zf, lake_of, level, sea_level))
    if rim > zf[c]:  # a pit: filled first, up to its rim
        fill = min(amount, (rim - zf[c]) * cell_area)
        zf[c] += fill / cell_area
        amount -= fill
        if amount <= 0.0:
            return
    box = reach(c, nx, ny, spread)
    j_lo, j_hi, i_lo, i_hi = box
    dry = count_in(lake_of, box, nx, NO_LAKE)
    if dry == 0:  # c itself is not a plain dry cell (a caller's guard): on c
        zf[c] += amount / cell_area
        return
    dz = amount / (dry * cell_area)
    for j in range(j_lo, j_hi):
        for i in range(i_lo, i_hi):
            if lake_of[j * nx + i] == NO_LAKE:
                zf[j * nx + i] += dz


@njit(cache=True, inline="always")
def _share_under_water(k, box, amount, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright,
                       hrank, hs, stack, nx):  # fmt: skip
    """``amount`` (m³) of sediment in equal shares on lake k's cells in ``box`` (:func:`reach`), none above
    the water: a cell whose water is shallower than its share is filled to the surface and leaves the
    lake, and the rest is shared again. Returns (what did not fit, the water displaced) in m³."""
    j_lo, j_hi, i_lo, i_hi = box
    L = level[k]
    displaced = 0.0
    while amount > 0.0:  # each pass but the last empties at least one cell
        members = count_in(lake_of, box, nx, k)
        if members == 0:
            break
        share = amount / members
        full = 0
        for j in range(j_lo, j_hi):
            for i in range(i_lo, i_hi):
                n = j * nx + i
                if lake_of[n] == k and (L - zf[n]) * cell_area <= share:
                    full += 1
                    put = max(L - zf[n], 0.0) * cell_area
                    zf[n] = max(zf[n], L)
                    leave_lake(k, n, zf, lake_of, area, broot, hkey, hcell, hleft, hright, hrank, hs, stack)
                    displaced += put
                    amount -= put
        if full > 0:
            continue
        for j in range(j_lo, j_hi):
            for i in range(i_lo, i_hi):
                if lake_of[j * nx + i] == k:  # deeper than its share: stays under the water
                    displaced += settle_on_cell(
                        k, j * nx + i, share, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft,
                        hright, hrank, hs, stack,
                    )  # fmt: skip
        amount = 0.0
    return max(amount, 0.0), displaced


DELTA_GROWTH = 3  # a load that fills the reach's water spreads over squares 2, 4 and 8 times as wide (settle_in_lake)


@njit(cache=True)
def settle_in_lake(
    k, c, amount, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright, hrank, hs, stack,
    nx=1, spread=0, sea_level=-math.inf,
):  # fmt: skip
    """Sediment ``amount`` (m³) that entered lake k at its cell c settles on the lake's cells within
    ``spread`` cells of c (a (2·spread + 1)² square on a map ``nx`` cells wide), in equal shares, none
    above the water (:func:`_share_under_water`); what does not fit under the water there goes on over
    the lake's cells within 2, 4 and 8 times ``spread``, as a delta builds out into its lake, and what
    does not fit in those settles on the first square as on dry ground (:func:`settle_dry`). ``spread``
    0: all on c (the seed's one-cell droplets). Returns the water it displaces (m³).

    Settling where the water enters, over the reach of the droplet that brought it (``spread`` =
    footprint // 2, :func:`erosim.hydrology.params.kernel_constants`), builds a delta rather than a
    one-cell spike at each entry, which left the plains' small lakes as one-cell pits between spikes
    (issue 36: a third fewer one-cell lakes on the library terrain at 512²). A share is capped at its
    cell's water depth: a one-cell lake took a whole load on its one cell, up to 150 m on 20 m cells
    (a droplet may carry 6·10⁴ m³), and left a tower where the puddle was (issue 36). The wider
    squares keep a small lake's water in it: laid on the reach at once, what did not fit raised the
    reach out of the water, and the lake, emptied, sent its water on (a closed bowl kept 87 % of its
    rain instead of 94 %, ``tests/scenarios/test_users_dems.py``).
    """
    if amount <= 0.0:
        return 0.0
    if spread <= 0:
        return settle_on_cell(
            k, c, amount, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright, hrank, hs,
            stack,
        )  # fmt: skip
    ny = zf.shape[0] // nx
    displaced = 0.0
    r = spread
    for _ in range(DELTA_GROWTH + 1):
        amount, d = _share_under_water(
            k, reach(c, nx, ny, r), amount, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft,
            hright, hrank, hs, stack, nx,
        )  # fmt: skip
        displaced += d
        if amount <= 0.0 or area[k] == 0:
            break
        r *= 2
    if amount > 0.0:  # the water within reach is filled: the rest as on dry ground
        settle_dry(c, amount, zf, lake_of, level, sea_level, nx, cell_area, spread)
    return displaced


@njit(cache=True)
def settle_on_cell(
    k, c, amount, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright, hrank, hs, stack
):
    """Sediment ``amount`` (m³) settles on lake cell c. Returns the water it displaces (m³).

    The level is left as it is; the caller routes the displaced water (back through the fill, or
    with an ending droplet), so lake levels never rise past their spill point by displacement.
    If the deposit rises above the water the cell leaves the lake and its whole column is displaced.
    """
    if amount <= 0.0:
        return 0.0
    L = level[k]
    dz = amount / cell_area
    depth = L - zf[c]
    zf[c] += dz
    if dz < depth:
        mroot[k] = push(mroot[k], -zf[c], c, hkey, hcell, hleft, hright, hrank, hs, stack)
        return dz * cell_area
    leave_lake(k, c, zf, lake_of, area, broot, hkey, hcell, hleft, hright, hrank, hs, stack)
    return depth * cell_area


@njit(cache=True, inline="always")
def leave_lake(k, c, zf, lake_of, area, broot, hkey, hcell, hleft, hright, hrank, hs, stack):
    """Cell c, its bed at or above the water, leaves lake k: dry, and an entry of the lake's boundary."""
    lake_of[c] = NO_LAKE
    area[k] -= 1
    broot[k] = push(broot[k], zf[c], c, hkey, hcell, hleft, hright, hrank, hs, stack)


@njit(cache=True)
def settle_gains(
    cells, gains, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright, hrank, hs, stack
):
    """Heights ``gains`` (m) that lake ``cells`` received from outside the droplets (soil creeping in from
    the shore) made through the lake bookkeeping: each cell's bed back to where it was, then its gain
    settled on it (:func:`settle_on_cell`: a cell whose bed rises above the water leaves the lake). A cell no
    longer in a lake keeps its gain as dry land. Returns the water displaced (m³)."""
    displaced = 0.0
    for t in range(cells.shape[0]):
        g = gains[t]
        c = cells[t]
        k = lake_of[c]
        if g > 0.0 and k >= 0:
            zf[c] -= g
            displaced += settle_on_cell(
                k, c, g * cell_area, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright,
                hrank, hs, stack,
            )  # fmt: skip
    return displaced


@njit(cache=True)
def flood(
    c,
    V,
    S,
    nx,
    ny,
    zf,
    lake_of,
    level,
    area,
    mroot,
    broot,
    B,
    sea_level,
    edge_key,
    cell_area,
    drainage,
    hkey,
    hcell,
    hleft,
    hright,
    hrank,
    hs,
    stack,
    walk,
    spread=0,
):
    """HY-2 for a particle of volume V (m³) and sediment S (m³) at cell c (see module docstring).

    Returns (result, cell, V, S): SPENT (V went into the lake, S settled on its bed), DRAIN (the
    particle is at ``cell``, a drain, with V and the kept 10 % of S), FILLED (its sediment filled the
    lake it entered, which is gone: the particle is at c with its water and the kept 10 %) or LEFT
    (drained off the world; ``cell`` is c, or the halo cell it drained into in a tile of a tiled
    build). A FILLED particle walks on and descends again as a drained one does, but it did not spill
    over a full lake's rim: it costs only ``FILL_ROUND`` of its ``spill`` rounds. Counted as a whole
    round, droplets whose loads filled one puddle after another used up their rounds and ended on the
    way: a bowl draining through a nodata hole let 78 % of its rain leave there instead of 91 %
    (``tests/scenarios/test_users_dems.py``).

    A tile's halo cells (``lake_of`` = HALO) are boundary entries keyed by their own surface, like any
    dry cell beyond the lake, not off-map entries at −∞: a lake cut by a tile's border fills to the
    height of its lowest halo neighbour (the map's spill level on that side) before its water leaves
    there to the neighbouring tile, with the kept 10 % of the sediment; a halo cell never joins a lake.
    Sediment that settles in a lake spreads over its cells within ``spread`` of the entry, none above
    the water, and what does not fit under the water there as on dry ground (:func:`settle_in_lake`);
    at a dry cell it fills the pit there and spreads round it (:func:`settle_dry`) before the lake
    starts. (Carrying what does not fit on with the water that spills, instead, spread the loads over
    the plains as hummocks that held 1 200 lakes, and the rivers vanished: issue 36, docs/hydrology.md.)
    """
    # the seed keeps 10 % of the sediment when the particle drains on; the rest settles where it
    # entered the lake (the seed deletes it; settling keeps the sediment budget closed)
    dep = 0.9 * S
    k = lake_of[c]
    if k < 0 and zf[c] < sea_level:  # the sea takes it
        B[B_LEFT] += V
        B[B_CARRIED] += S
        return LEFT, c, 0.0, 0.0
    if k < 0:
        if dep > 0.0:  # dry cell: settle first, then the new lake starts at the raised bed
            settle_dry(c, dep, zf, lake_of, level, sea_level, nx, cell_area, spread)
            B[B_DEPOSITED] += dep
            S -= dep
            dep = 0.0
        k = new_lake(
            c,
            nx,
            ny,
            zf,
            lake_of,
            level,
            area,
            mroot,
            broot,
            sea_level,
            edge_key,
            hkey,
            hcell,
            hleft,
            hright,
            hrank,
            hs,
            stack,
        )
    if dep > 0.0:
        extra = settle_in_lake(
            k, c, dep, zf, lake_of, level, area, mroot, broot, cell_area, hkey, hcell, hleft, hright, hrank, hs, stack,
            nx, spread, sea_level,
        )  # fmt: skip
        B[B_DEPOSITED] += dep
        B[B_TO_LAKES] -= extra
        V += extra
        S -= dep
        if area[k] == 0:
            return FILLED, c, V, S
    n_iter = 0
    while True:
        n_iter += 1
        top = broot[k]
        if top < 0 or n_iter > 50_000_000:
            # no boundary at all (cannot happen with open edges): keep the water
            if area[k] > 0:
                level[k] += V / (area[k] * cell_area)
                B[B_TO_LAKES] += V
                V = 0.0
            break
        b = hcell[top]
        e = hkey[top]
        offmap = b < -1
        if offmap:
            if lake_of[-b - 2] != k:  # the edge cell fell dry: the entry is stale
                broot[k] = pop(top, hkey, hleft, hright, hrank, hs, stack)
                continue
        else:
            if lake_of[b] == k:
                broot[k] = pop(top, hkey, hleft, hright, hrank, hs, stack)
                continue
            cur = surface(b, zf, lake_of, level, sea_level)
            if cur != e:
                broot[k] = pop(top, hkey, hleft, hright, hrank, hs, stack)
                broot[k] = push(broot[k], cur, b, hkey, hcell, hleft, hright, hrank, hs, stack)
                continue
        L = level[k]
        sea = (not offmap) and lake_of[b] < 0 and zf[b] < sea_level
        halo = (not offmap) and lake_of[b] == HALO
        if offmap or sea or e < L or (halo and e <= L):
            # drain: lower the level slowly toward the drain's surface, the particle moves there
            if offmap:
                edge_cell = -b - 2
                target = sea_level if sea_level > -1e300 else zf[edge_cell]
                if target > L:
                    target = L
            else:
                target = min(e, L)  # a lake below the sea level does not rise toward it
            new_level = (1.0 - drainage) * L + drainage * target
            rel = lower(
                k,
                new_level,
                zf,
                lake_of,
                level,
                area,
                mroot,
                broot,
                cell_area,
                hkey,
                hcell,
                hleft,
                hright,
                hrank,
                hs,
                stack,
            )
            B[B_TO_LAKES] -= rel
            V += rel
            if offmap or sea or halo:
                B[B_LEFT] += V
                B[B_CARRIED] += S
                return LEFT, (b if halo and not sea else c), 0.0, 0.0
            return DRAIN, b, V, S
        need = area[k] * (e - L) * cell_area
        if V <= need:
            level[k] = L + V / (area[k] * cell_area)
            B[B_TO_LAKES] += V
            V = 0.0
            if S <= 0.0:
                break
            # spent: the rest of the sediment settles where the particle entered; the water it
            # displaces goes round the fill once more (it may reach the spill point)
            kc = lake_of[c]
            if kc < 0:
                settle_dry(c, S, zf, lake_of, level, sea_level, nx, cell_area, spread)
                B[B_DEPOSITED] += S
                S = 0.0
                break
            V = settle_in_lake(
                kc,
                c,
                S,
                zf,
                lake_of,
                level,
                area,
                mroot,
                broot,
                cell_area,
                hkey,
                hcell,
                hleft,
                hright,
                hrank,
                hs,
                stack,
                nx,
                spread,
                sea_level,
            )
            B[B_DEPOSITED] += S
            B[B_TO_LAKES] -= V
            S = 0.0
            k = kc
            if V <= 0.0:
                break
            if area[k] == 0:  # the lake vanished under its own sediment: the water it held runs on from c
                return FILLED, c, V, 0.0
            continue
        level[k] = e
        V -= need
        B[B_TO_LAKES] += need
        if halo:  # the lake is at its spill level into the halo: the next pass drains the rest there
            continue
        broot[k] = pop(top, hkey, hleft, hright, hrank, hs, stack)
        j = lake_of[b]
        if j >= 0:
            k = _merge_lakes(k, j, lake_of, area, mroot, broot, hkey, hcell, hleft, hright, hrank, stack, walk)
            continue
        lake_of[b] = k
        area[k] += 1
        mroot[k] = push(mroot[k], -zf[b], b, hkey, hcell, hleft, hright, hrank, hs, stack)
        _push_neighbours(
            k, b, nx, ny, zf, lake_of, level, broot, sea_level, edge_key, hkey, hcell, hleft, hright, hrank, hs, stack
        )
    return SPENT, c, 0.0, 0.0


@njit(cache=True)
def rebuild(
    nx,
    ny,
    zf,
    lake_of,
    level_old,
    sea_level,
    edge_key,
    level,
    area,
    mroot,
    broot,
    hkey,
    hcell,
    hleft,
    hright,
    hrank,
    hs,
    stack,
    stamp,
    order,
    start,
):
    """Renumber live lakes 0..K−1 (raster order of first cell) and rebuild both heaps of each.

    ``level`` receives the renumbered levels. Returns K. Heap node pool and scratch arrays are
    the caller's.
    """
    n = nx * ny
    nold = level_old.shape[0]
    remap = np.full(nold, -1, np.int64)
    K = 0
    for c in range(n):
        k = lake_of[c]
        if k >= 0:
            r = remap[k]
            if r < 0:
                r = K
                remap[k] = r
                level[r] = level_old[k]
                K += 1
            lake_of[c] = r
    hs[HS_BUMP] = 0
    hs[HS_FREE] = -1
    hs[HS_NLAKES] = K
    # counting sort of member cells by lake: order[start[k]:start[k+1]]
    for k in range(K + 1):
        start[k] = 0
    for c in range(n):
        k = lake_of[c]
        if k >= 0:
            start[k + 1] += 1
    for k in range(K):
        start[k + 1] += start[k]
    fill = start[:K].copy()
    for c in range(n):
        k = lake_of[c]
        if k >= 0:
            order[fill[k]] = c
            fill[k] += 1
    for k in range(K):
        area[k] = start[k + 1] - start[k]
        mroot[k] = -1
        broot[k] = -1
    for c in range(n):
        stamp[c] = -1
    for k in range(K):
        for t in range(start[k], start[k + 1]):
            c = order[t]
            mroot[k] = push(mroot[k], -zf[c], c, hkey, hcell, hleft, hright, hrank, hs, stack)
            iy = c // nx
            ix = c - iy * nx
            edge = ix == 0 or iy == 0 or ix == nx - 1 or iy == ny - 1
            for dy in range(-1, 2):
                jy = iy + dy
                if jy < 0 or jy >= ny:
                    continue
                for dx in range(-1, 2):
                    jx = ix + dx
                    if jx < 0 or jx >= nx or (dx == 0 and dy == 0):
                        continue
                    m = jy * nx + jx
                    if lake_of[m] == OUTSIDE:
                        edge = True
                        continue
                    if lake_of[m] == k or stamp[m] == k:
                        continue
                    stamp[m] = k
                    broot[k] = push(
                        broot[k],
                        surface(m, zf, lake_of, level, sea_level),
                        m,
                        hkey,
                        hcell,
                        hleft,
                        hright,
                        hrank,
                        hs,
                        stack,
                    )
            if edge:
                broot[k] = push(broot[k], edge_key, -(c + 2), hkey, hcell, hleft, hright, hrank, hs, stack)
    return K


def edge_key(sea_level: float) -> float:
    """Key of the off-map boundary entries: the sea level, or −∞ (open edges) without a sea."""
    return float(sea_level) if math.isfinite(sea_level) else -math.inf


def depth_map(lake_of: np.ndarray, level: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Pool depth (m): level of the cell's lake minus the terrain, 0 on dry cells."""
    lk = lake_of.reshape(z.shape)
    d = np.zeros(z.shape)
    wet = lk >= 0
    if wet.any():
        d[wet] = np.maximum(level[lk[wet]] - z[wet], 0.0)
    return d
