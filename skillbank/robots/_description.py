"""Robots from description files (URDF or MJCF): the kinematic chain, limits, names and collision capsules.

MuJoCo's own compiler reads both formats (``mujoco.MjSpec``; extra ``sim``,
imported when a description is read, so ``skillbank.robots`` stays numpy
only). MuJoCo opens no file of a description: skillbank reads the file and
every file it names, confined to its folder and within bounds, and MuJoCo
compiles from memory (``_description_files``). The compiled model at zero
joint angles gives the joints' anchors and axes, the tool frame's pose, the
limits and every collision geom; each body's collision geoms become one
capsule that contains them (the smallest found over three axes and a range
of radii; MuJoCo collides a mesh as its convex hull, and a capsule contains
the hull exactly when it contains the vertices).
docs/robots.md records the choices.
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

import numpy as np

from ._bodies import Capsule
from ._chain import KinematicChain, self_collision_skip
from ._description_files import Described, read_description

__all__ = ["load_description", "enclosing_capsule", "check_description_files"]

#: Points per rim when a cylinder is enclosed: the polygon is grown to contain the circle.
_RIM = 32
#: Most vertices of MuJoCo's convex hull of a mesh (``maxhullvert``). skillbank fits its capsules to every
#: vertex and never uses the hull, whose making grows faster than quadratically: 63,000 vertices on a
#: sphere (a 1 MB STL) took 15 s, 250,000 (4 MB) 213 s; capped at 4096 they take 0.2 s.
_MAX_HULL = 4096


def check_description_files(path) -> str:
    """Read a description and every file it names, confined to its folder; return its format.

    Every file is resolved with MuJoCo 3.3.7's rules (URDF meshes after ``strippath`` and the
    ``<mujoco><compiler>`` block; MJCF includes, each parsed once, and every file of meshes,
    skins, height fields and textures, cube faces included, after ``meshdir`` / ``texturedir`` /
    ``assetdir`` in document order) and read as the bytes of a regular file inside the
    description's folder; a file outside it, a FIFO or a device, a DOCTYPE, a non-finite number,
    a URDF limit with lower above upper, or a description over a bound (docs/robots.md) is refused.

    Returns
    -------
    str
        ``"urdf"`` or ``"mjcf"``.

    Examples
    --------
    >>> check_description_files(robot_model("panda").chain.source)  # doctest: +SKIP
    'mjcf'
    """
    return read_description(path).kind


def enclosing_capsule(points, radii=None, *, margin=1e-6):
    """A small capsule ``(a, b, radius)`` containing balls at ``points (m, 3)`` of ``radii`` (default 0).

    Tries the points' three principal axes; on each, the axis line is centred by the smallest
    enclosing circle of the projected balls (Badoiu-Clarkson iterations) and the radius is swept
    from that circle's up to 1.6 times it (a wider capsule is shorter); the smallest volume wins.

    Examples
    --------
    >>> a, b, r = enclosing_capsule([[0, 0, 0], [1, 0, 0], [0.5, 0.1, 0]])
    >>> round(float(r), 3) <= 0.1 + 1e-3
    True
    """
    P = np.asarray(points, float).reshape(-1, 3)
    rad = np.zeros(P.shape[0]) if radii is None else np.asarray(radii, float).reshape(-1)
    centre = P.mean(axis=0)
    X = P - centre
    _, _, Vt = np.linalg.svd(X, full_matrices=False) if P.shape[0] > 1 else (None, None, np.eye(3))
    axes = list(Vt) + [v for v in np.eye(3) if Vt.shape[0] < 3]
    best = None
    for u in axes[:3]:
        u = u / np.linalg.norm(u)
        t = X @ u
        perp = X - t[:, None] * u
        c = (perp.min(axis=0) + perp.max(axis=0)) / 2  # the box's middle, then towards the smallest circle
        c -= (c @ u) * u  # in the plane: the box's middle of points in a tilted plane is off it
        for k in range(2, 60):  # Badoiu-Clarkson: the smallest circle (in the plane) around the balls
            far = np.argmax(np.linalg.norm(perp - c, axis=1) + rad)
            gap = perp[far] - c
            dist = np.linalg.norm(gap)
            if dist > 0:  # step towards the farthest ball's far side
                c = c + (perp[far] + rad[far] * gap / dist - c) / (k + 1)
        d = np.linalg.norm(perp - c, axis=1)
        r0 = float((d + rad).max())
        for f in np.linspace(1.0, 1.6, 13):
            r = r0 * f + margin
            h = np.sqrt(np.maximum((r - rad) ** 2 - d**2, 0.0))
            ta, tb = float((t - h).max()), float((t + h).min())  # the segment must reach [ta, tb]...
            lo, hi = (tb, ta) if tb <= ta else ((ta + tb) / 2,) * 2
            volume = np.pi * r * r * (hi - lo) + 4 / 3 * np.pi * r**3
            if best is None or volume < best[0]:
                base = centre + c
                best = (volume, base + lo * u, base + hi * u, r)
    _, a, b, r = best
    return tuple(map(float, a)), tuple(map(float, b)), float(r)


def _hull(P: np.ndarray, radii: np.ndarray):
    """The balls on the convex hull of the centres, with every ball of nonzero radius: a capsule (convex)
    contains the points exactly when it contains the hull's vertices, and a mesh has thousands."""
    from scipy.spatial import ConvexHull, QhullError  # heavy: only when a description's links are fitted

    plain = radii == 0
    if plain.sum() < 5:
        return P, radii
    try:
        keep = ConvexHull(P[plain]).vertices
    except QhullError:  # flat or degenerate: keep them all
        return P, radii
    return (np.concatenate([P[plain][keep], P[~plain]]), np.concatenate([radii[plain][keep], radii[~plain]]))


def _volume(capsule) -> float:
    a, b, r = capsule
    return float(np.pi * r * r * np.linalg.norm(np.subtract(b, a)) + 4 / 3 * np.pi * r**3)


def _capsules(P: np.ndarray, radii: np.ndarray, depth: int = 2) -> list:
    """Capsules around a link's balls: one, or the halves' when two hold it in under 3/4 of the volume.

    A bent link (a wrist's elbow-shaped housing) in one capsule is mostly empty room that
    collides with its neighbours; split across its principal axes (each half again, ``depth``
    times: at most four capsules) it keeps to its shape.
    """
    one = enclosing_capsule(*_hull(P, radii))
    best, best_volume = [one], 0.75 * _volume(one)
    if P.shape[0] < 8 or depth == 0:
        return best
    halves = None
    X = P - P.mean(axis=0)
    _, _, Vt = np.linalg.svd(X, full_matrices=False)
    for u in Vt[:2]:
        t = X @ u
        for cut in np.quantile(t, (0.35, 0.5, 0.65)):
            left = t <= cut
            if left.sum() < 2 or (~left).sum() < 2:
                continue
            # each half's own hull: the whole's hull vertices alone would leave its inside points out
            pair = [enclosing_capsule(*_hull(P[left], radii[left])),
                    enclosing_capsule(*_hull(P[~left], radii[~left]))]
            volume = sum(map(_volume, pair))
            if volume < best_volume:
                best, best_volume, halves = pair, volume, left
    if halves is None:
        return best
    return (_capsules(P[halves], radii[halves], depth - 1) + _capsules(P[~halves], radii[~halves], depth - 1))


def _geom_balls(m, d, g):
    """The balls (centres ``(k, 3)`` in the world, radii) whose hull contains geom ``g``."""
    import mujoco  # extra "sim": only a description's geoms need it

    R, p = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g]
    size = m.geom_size[g]
    kind = m.geom_type[g]
    T = mujoco.mjtGeom
    if kind == T.mjGEOM_MESH:
        mesh = m.geom_dataid[g]
        start, count = m.mesh_vertadr[mesh], m.mesh_vertnum[mesh]
        local = m.mesh_vert[start:start + count]
        return local @ R.T + p, np.zeros(count)
    if kind == T.mjGEOM_SPHERE:
        return p[None], np.array([size[0]])
    if kind == T.mjGEOM_CAPSULE:
        ends = np.array([[0, 0, -size[1]], [0, 0, size[1]]])
        return ends @ R.T + p, np.full(2, size[0])
    if kind in (T.mjGEOM_BOX, T.mjGEOM_ELLIPSOID):
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * size[:3]
        return corners @ R.T + p, np.zeros(8)
    if kind == T.mjGEOM_CYLINDER:
        a = np.linspace(0, 2 * np.pi, _RIM, endpoint=False)
        ring = size[0] / np.cos(np.pi / _RIM)  # the polygon around the circle, not inside it
        local = np.concatenate([np.column_stack([ring * np.cos(a), ring * np.sin(a), np.full(_RIM, z)])
                                for z in (-size[1], size[1])])
        return local @ R.T + p, np.zeros(local.shape[0])
    raise ValueError(f"geom {m.geom(g).name or g}: a {mujoco.mjtGeom(kind).name[7:].lower()} cannot be part "
                     "of a robot's links; give it a mesh, box, sphere, capsule or cylinder")


def _perpendicular(z: np.ndarray, hint: np.ndarray) -> np.ndarray:
    x = hint - (hint @ z) * z
    if np.linalg.norm(x) < 1e-6:
        x = np.eye(3)[int(np.argmin(np.abs(z)))]
        x = x - (x @ z) * z
    return x / np.linalg.norm(x)


@contextmanager
def _stdout_to_stderr():
    """MuJoCo prints its warnings on the standard output, which ``--json`` keeps for JSON: send them to
    the standard error."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _compile(path: Path, described: Described):
    import mujoco  # extra "sim": MuJoCo's compiler reads both formats

    kind = described.kind
    try:
        with _stdout_to_stderr():
            # from memory: the XML names no path, every file is an asset's bytes (_description_files)
            spec = mujoco.MjSpec.from_string(described.xml, assets=described.assets)
            for mesh in spec.meshes:
                if mesh.maxhullvert < 0 or mesh.maxhullvert > _MAX_HULL:
                    mesh.maxhullvert = _MAX_HULL
            # a URDF's fixed links are its tool frames: keep them as bodies (MuJoCo fuses them by default)
            spec.compiler.fusestatic = False
            # kinematics needs no inertia; a description without it (common in URDF) still compiles
            spec.compiler.boundmass = 1e-6
            spec.compiler.boundinertia = 1e-9
            return spec.compile()
    except ValueError as e:  # MuJoCo's parser and compiler errors
        first = str(e).strip().splitlines()
        raise ValueError(f"robot description {path}: MuJoCo cannot read this {kind.upper()} "
                         f"({' '.join(first[:2])})") from None


def _ancestors(m, b: int) -> list[int]:
    out = []
    while b > 0:
        out.append(b)
        b = int(m.body_parentid[b])
    return out[::-1]


def _body_joints(m, b: int) -> list[int]:
    return list(range(int(m.body_jntadr[b]), int(m.body_jntadr[b]) + int(m.body_jntnum[b])))


def _tool(m, tool_frame, path):
    """The tool frame: ``(body, site or None, name)``; by default the last link of the longest chain."""
    import mujoco  # extra "sim"

    if tool_frame is not None:
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, tool_frame)
        if b > 0:
            return b, None, tool_frame
        s = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, tool_frame)
        if s >= 0:
            return int(m.site_bodyid[s]), s, tool_frame
        names = [m.body(i).name for i in range(1, m.nbody) if m.body(i).name]
        raise ValueError(f"tool frame: {path} has no link, body or site {tool_frame!r}; its links are "
                         f"{', '.join(names[:12])}{' ...' if len(names) > 12 else ''}")
    children = np.bincount(m.body_parentid[1:], minlength=m.nbody)
    leaves = [b for b in range(1, m.nbody) if children[b] == 0]
    depth = {b: sum(len(_body_joints(m, a)) for a in _ancestors(m, b)) for b in leaves}
    most = max(depth.values(), default=0)
    last = [b for b in leaves if depth[b] == most]
    if len(last) != 1:
        names = ", ".join(repr(m.body(b).name) for b in last)
        raise ValueError(f"tool frame: {path} ends in several links with {most} joints before them "
                         f"({names}); name the tool frame (--tool-frame LINK, or tool_frame=...)")
    return last[0], None, m.body(last[0]).name


@lru_cache(maxsize=16)
def _load(path: str, stamp: float, tool_frame, name):
    import mujoco  # extra "sim"

    file = Path(path)
    m = _compile(file, read_description(file))
    d = mujoco.MjData(m)
    d.qpos[:] = 0.0
    mujoco.mj_kinematics(m, d)
    tool_body, site, tool_name = _tool(m, tool_frame, file)
    chain_bodies = _ancestors(m, tool_body)
    joints = [j for b in chain_bodies for j in _body_joints(m, b)]
    if not joints:
        raise ValueError(f"robot description {file}: no joint moves the tool frame {tool_name!r}; name a "
                         "link at the end of the arm (--tool-frame)")
    for j in joints:
        if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
            kind_name = mujoco.mjtJoint(m.jnt_type[j]).name[6:].lower()
            raise ValueError(f"robot description {file}: joint {m.joint(j).name or j!r} is a {kind_name} "
                             "joint; skillbank's robot models chain revolute joints only (a prismatic joint, "
                             "a mobile base or a ball joint is not supported yet)")
    # frames at zero: joint i's frame (origin its anchor, z its axis), then the tool frame
    frames = []
    for j in joints:
        body = int(m.jnt_bodyid[j])
        z = d.xaxis[j] / np.linalg.norm(d.xaxis[j])
        x = _perpendicular(z, d.xmat[body].reshape(3, 3)[:, 0])
        F = np.eye(4)
        F[:3, :3] = np.column_stack([x, np.cross(z, x), z])
        F[:3, 3] = d.xanchor[j]
        frames.append(F)
    tool = np.eye(4)
    if site is None:
        tool[:3, :3], tool[:3, 3] = d.xmat[tool_body].reshape(3, 3), d.xpos[tool_body]
    else:
        tool[:3, :3], tool[:3, 3] = d.site_xmat[site].reshape(3, 3), d.site_xpos[site]
    frames = np.array(frames + [tool])
    n = len(joints)
    # the frame each body is fixed in: the number of chain joints above it, if no other joint moves it
    chain_set = set(joints)
    frame_of = {}
    for b in range(1, m.nbody):
        above = [j for a in _ancestors(m, b) for j in _body_joints(m, a)]
        if any(j not in chain_set for j in above) or above != joints[:len(above)]:
            continue  # moved by a joint off the chain (a finger, a head): not part of the arm's links
        frame_of[b] = len(above)
    inv = np.linalg.inv(frames)
    bodies, masses = [], np.zeros(n + 1)
    used = set()
    for b, k in frame_of.items():
        masses[k] += float(m.body_mass[b]) if m.body_mass[b] > 1e-5 else 0.0
        geoms = [g for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b]) + int(m.body_geomnum[b]))
                 if (m.geom_contype[g] or m.geom_conaffinity[g])]
        if not geoms:
            continue
        balls = [_geom_balls(m, d, g) for g in geoms]
        P = np.concatenate([p for p, _ in balls])
        radii = np.concatenate([r for _, r in balls])
        P = P @ inv[k][:3, :3].T + inv[k][:3, 3]
        label = m.body(b).name or f"body{b}"
        while label in used:
            label += "_"
        used.add(label)
        caps = _capsules(P, radii)
        for i, (a, bb, r) in enumerate(caps):
            bodies.append(Capsule(label if i == 0 else f"{label}_{i + 1}", k, a, bb, r))
    lower = tuple(float(m.jnt_range[j, 0]) if m.jnt_limited[j] else -np.inf for j in joints)
    upper = tuple(float(m.jnt_range[j, 1]) if m.jnt_limited[j] else np.inf for j in joints)
    qpos0 = np.array([m.qpos0[m.jnt_qposadr[j]] for j in joints])
    lo, hi = np.asarray(lower), np.asarray(upper)
    bounded = np.isfinite(lo) & np.isfinite(hi)
    middle = np.where(bounded, (np.where(bounded, lo, 0.0) + np.where(bounded, hi, 0.0)) / 2, 0.0)
    home = np.where((qpos0 > lo) & (qpos0 < hi), qpos0, middle)  # a reference pose strictly inside
    joint_names = tuple(m.joint(j).name or f"joint{i + 1}" for i, j in enumerate(joints))
    chain = KinematicChain(name=name or (m.names[:m.names.find(b"\0")].decode() or file.stem),
                           joint_names=joint_names, lower=lower, upper=upper, frames=frames,
                           bodies=tuple(bodies), masses=tuple(masses), home=tuple(home),
                           source=str(file), tool_frame=tool_name)
    skip = self_collision_skip(chain.bodies, _frames_function(chain), np.column_stack([lower, upper]))
    return chain._replace(self_collision_skip=skip)


def _frames_function(chain: KinematicChain):
    from ._chain import ChainModel  # same module family; the model computes the frames

    model = ChainModel(chain)
    return model._frames


def load_description(path, *, tool_frame=None, name=None) -> KinematicChain:
    """Read a robot description (URDF or MJCF) into a :class:`KinematicChain`.

    Parameters
    ----------
    path : path-like
        The description file; every file it names must lie in its folder.
    tool_frame : str, optional
        The link (body) or site that is the flange; default the last link of the longest chain of
        joints (an error when several links end chains equally long, as a gripper's fingers do).
    name : str, optional
        The robot's name (default the description's model name, else the file's stem).

    Returns
    -------
    KinematicChain

    Raises
    ------
    ValueError
        A file that is not URDF or MJCF, names a file outside its folder, that MuJoCo cannot
        compile, without a joint before the tool frame, or with a joint that is not revolute.
    """
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"robot: {path} is neither a registered robot nor a description file (URDF or MJCF) "
                         "that exists")
    return _load(str(file.resolve()), file.stat().st_mtime, tool_frame, name)
