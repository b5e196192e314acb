"""What holds a placed object in a robosuite scene, and the turns of it that change nothing.

A carry that lets its object go near no other object puts it on what the scene holds fixed: a peg, a
bin, the table. Its demonstration shows one orientation of the object there, but the fixture often
accepts others: a square nut fits its square peg at any quarter turn, an object lies in a rectangular
bin either way round. One demonstration cannot show that; the fixture's own collision geometry can.
Turned about the vertical through the object's place by a turn under which the fixture's geometry is
unchanged, the object stands to the fixture as before, so the executor may take the turn nearest the
wrist it has (a nut picked up the other way round is turned by a few degrees, not half a turn).
"""

from __future__ import annotations

import math

import numpy as np

from ..io import reported_body
from ..robots._description import _geom_balls
from ._robosuite import _box, _gripper

__all__ = ["fixtures", "object_extents", "object_symmetry", "pad_half_width", "support", "vertical_symmetry"]

#: Turns tried, most first: quarter, half (whole turns always hold).
TURNS = (4, 2)
#: How far (m) a turned point may be from the nearest point of the fixture and still match it, at least.
MATCH = 0.002
#: And as a fraction of the fixture's horizontal size (meshes are not exact).
MATCH_FRACTION = 0.02


def vertical_symmetry(points, radii, centre, *, turns=TURNS) -> int:
    """The largest ``k`` of ``turns`` such that turning ``points`` (with their ``radii``) by ``2 pi / k``
    about the vertical through ``centre`` maps them onto themselves; 1 if none.

    Parameters
    ----------
    points : array of shape (n, 3)
        The geometry as points (a box's corners, a mesh's vertices, a cylinder's rims), m.
    radii : array of shape (n,)
        A ball about each point (a capsule's or a sphere's radius; 0 for a corner).
    centre : array of shape (2,) or (3,)
        A point of the vertical axis; only its horizontal coordinates count.

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (0, 1)], float)
    >>> vertical_symmetry(square, np.zeros(8), [0, 0])
    4
    >>> vertical_symmetry(square * [2, 1, 1], np.zeros(8), [0, 0])
    2
    >>> vertical_symmetry(square * [2, 1, 1], np.zeros(8), [1, 0])
    1
    """
    from scipy.spatial import cKDTree  # only a place on a fixture needs it

    P = np.asarray(points, float)
    r = np.asarray(radii, float)
    c = np.asarray(centre, float)[:2]
    size = float(np.ptp(P[:, :2], axis=0).max()) if len(P) else 0.0
    tol = max(MATCH, MATCH_FRACTION * size)
    # a ball's radius is matched as a fourth coordinate: a sphere is not a corner
    tree = cKDTree(np.column_stack([P, r]))
    for k in turns:
        a = 2 * math.pi / k
        turn = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        turned = np.column_stack([(P[:, :2] - c) @ turn.T + c, P[:, 2], r])
        if float(tree.query(turned)[0].max()) <= tol:
            return k
    return 1


def _robot_bodies(env, m) -> set:
    """The bodies of the scene's arms, their grippers and mounts: never what an object is put on."""
    roots = {m.body(r.robot_model.root_body).id for r in env.robots}
    return {b for b in range(m.nbody) if _root(m, b) in roots}


def _root(m, b) -> int:
    while m.body_parentid[b] != 0:
        b = m.body_parentid[b]
    return b


def fixtures(env) -> dict:
    """The scene's fixtures: ``{body name: its collision geoms' ids}`` of every body welded to the world (a
    peg, a bin, the table) that is not an arm's, its gripper's or its mount's."""
    m = env.sim.model._model
    robots = _robot_bodies(env, m)
    out = {}
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        if b == 0 or b in robots or m.body_weldid[b] != 0 or not (m.geom_contype[g] or m.geom_conaffinity[g]):
            continue
        out.setdefault(m.body(b).name, []).append(g)
    return out


def support(env, point):
    """``(name, k)``: the fixture of the scene ``env`` under or around ``point`` (a placed object's centre,
    m) and the quarter (4) or half (2) turns about the vertical that leave it unchanged (else 1); None
    where no fixture's footprint holds the point.

    Of the :func:`fixtures` whose collision geometry's horizontal footprint holds the point, the
    smallest: a peg on the table, not the table.
    """
    sim = env.sim
    p = np.asarray(point, float)
    best = None
    for b, gs in fixtures(env).items():
        lo, hi = _box(sim, gs)
        if not (np.all(p[:2] >= lo[:2]) and np.all(p[:2] <= hi[:2])):
            continue
        area = float(np.prod(hi[:2] - lo[:2]))
        if best is None or area < best[0]:
            best = (area, b, gs, (lo + hi) / 2)
    if best is None:
        return None
    _, b, gs, centre = best
    return b, vertical_symmetry(*_points(sim, gs), centre)


def _points(sim, geoms) -> tuple:
    """``(points (n, 3), radii (n,))``: the collision geoms ``geoms`` (ids) as they lie now, as balls
    whose hull holds them (robots' one reading of a geom)."""
    m, d = sim.model._model, sim.data._data
    balls = [_geom_balls(m, d, g) for g in geoms]
    return np.concatenate([c for c, _ in balls]), np.concatenate([r for _, r in balls])


def _object(env, name):
    """``(geom ids, body id)`` of the scene object ``name``'s collision geometry; None if not modelled."""
    sim = env.sim
    model = next((o for o in env.model.mujoco_objects if o.name == name), None)
    if model is None or not model.contact_geoms:
        return None
    gs = [sim.model.geom_name2id(g) for g in model.contact_geoms]
    return gs, int(sim.model._model.geom_bodyid[gs[0]])


def object_symmetry(env, name) -> int:
    """The quarter (4) or half (2) turns about the vertical through the scene object ``name``'s centre that
    leave its collision geometry unchanged (a cube: 4; a nut with its handle: 1); 1 for an object the
    scene does not model."""
    found = _object(env, name)
    if found is None:
        return 1
    gs, body = found
    return vertical_symmetry(*_points(env.sim, gs), env.sim.data._data.xpos[body])


def object_extents(env, name):
    """The half sizes (m) of the scene object ``name``'s collision geometry along its own axes, about its
    centre; None for an object the scene does not model."""
    found = _object(env, name)
    if found is None:
        return None
    gs, body = found
    d = env.sim.data._data
    points, radii = _points(env.sim, gs)
    local = (points - d.xpos[body]) @ np.asarray(d.xmat[body], float).reshape(3, 3)
    return np.abs(local).max(axis=0) + radii.max(initial=0.0)


def articulated(env, obs, name) -> bool:
    """Whether the object ``name`` the observations ``obs`` report is a part of an articulated object: a
    body that joints other than a free one attach to the world (a door's panel on its hinge, its handle on
    the latch), read from the simulator's model. A part is moved about its joints, never carried through
    free space; a loose object (a free joint) or one the model does not show is not one.
    """
    b = reported_body(env, obs, name)
    if b is None:
        return False
    m = env.sim.model._model
    jointed = False
    while b != 0:
        for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
            if m.jnt_type[j] == 0:  # mjJNT_FREE: a loose object
                return False
            jointed = True
        b = m.body_parentid[b]
    return jointed


def object_top(env, name):
    """The height (m, world) of the top of the scene object ``name``'s collision geometry as it lies now
    (its geoms' world-aligned box, as every top in the simulation is read); None for an object the scene
    does not model."""
    found = _object(env, name)
    return None if found is None else float(_box(env.sim, found[0])[1][2])


def pad_half_width(env, closing) -> float:
    """Half the width (m) of the gripper's finger pads across the horizontal closing direction
    ``closing`` (world): how far a pad reaches sideways on the face it closes on."""
    sim = env.sim
    closing = np.asarray(closing, float)
    up = np.array([0.0, 0.0, 1.0])
    across = np.cross(up, closing)
    across /= max(float(np.linalg.norm(across)), 1e-12)
    widths = []
    for side in ("left", "right"):
        for name in _gripper(env).important_geoms[f"{side}_fingerpad"]:
            g = sim.model.geom_name2id(name)
            points, radii = _points(sim, [g])
            along = (points - sim.data.geom_xpos[g]) @ across
            widths.append(float(np.abs(along).max() + radii.max(initial=0.0)))
    return min(widths)
