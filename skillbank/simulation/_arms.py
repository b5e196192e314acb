"""The point of the robot a library's poses are of, on the robosuite arm that runs its skills.

robosuite's observations (``robot0_eef_pos``, ``robot0_eef_quat``) and its operational-space
controller speak of one point on every arm: its gripper's grip site (between the pads), with the
end-effector body's orientation (:func:`~skillbank.simulation._robosuite.robot_frames`). A library
recorded in robosuite has its poses of that point of the arm that recorded it
(``metadata["pose_of"]``: ``robotiq_2f85:grip_site`` on the UR5e, ``panda_hand:grip_site`` on the
Panda, the offset robosuite reports on its other arms). On another arm those poses are taken as *its*
gripper's grip site, as :func:`skillbank.robots.to_tool` takes a gripper's named point on a robot with
another gripper: where the hand holds is what a task depends on, not where another hand's flange was.
That is one rigid transform, the identity, and a note says so. A pose of another point (the flange, a
TCP) names no grip site, and a pose of an unknown point on another arm is never guessed: both are
errors that say what to do.
"""

from __future__ import annotations

from ..core import POSE_OF
from ..io import ROBOSUITE_POSE_OF
from ..robots import pose_point
from ..robots._points import HOW_TO_SAY

__all__ = ["pose_points", "check_pads"]


def _same(a, b) -> bool:
    return a is not None and b is not None and a.lower() == b.lower()


def pose_points(sources, robot: str) -> list:
    """Notes on the points the sources' poses are of, as robosuite's arm ``robot`` takes them.

    Parameters
    ----------
    sources : sequence
        The library's demonstrations as :func:`~skillbank.simulation._evaluate._sources` reads them:
        each with ``id``, ``robot`` (the arm it was recorded on, or None) and ``pose_of`` (its
        ``metadata["pose_of"]``, or None).
    robot : str
        robosuite's arm that runs them (its spelling: ``"Panda"``).

    Returns
    -------
    list of str
        One note per kind of conversion (none when every pose is of this arm's grip site already).

    Raises
    ------
    ValueError
        A demonstration recorded on another arm whose poses are of an unknown point, or one whose
        poses are of a point that is no grip site (the flange, a TCP).

    Examples
    --------
    >>> from types import SimpleNamespace as S
    >>> pose_points([S(id=1, robot="UR5e", pose_of="robotiq_2f85:grip_site")], "Panda")
    ["pose_of: poses of the robotiq_2f85's grip site (recorded on UR5e) taken as Panda's grip site \
(panda_hand:grip_site): where the hand holds is kept, not its flange"]
    >>> pose_points([S(id=1, robot="Panda", pose_of="panda_hand:grip_site")], "Panda")
    []
    """
    own = ROBOSUITE_POSE_OF.get(robot.lower())
    notes = {}
    for src in sources:
        stated = getattr(src, "pose_of", None)
        if stated is None:
            # an unknown point is robosuite's own only on the arm that recorded it (or where no arm is
            # said at all, as before arms were recorded: nothing tells it apart)
            if src.robot is not None and not _same(src.robot, robot):
                raise ValueError(f"{POSE_OF}: demonstration {src.id} was recorded on {src.robot} and its "
                                 f"poses are of an unknown point of the robot; {robot}, which runs it, needs "
                                 f"its grip site's: {HOW_TO_SAY}")
            continue
        point = pose_point(stated, name=f"pose_of of demonstration {src.id}")
        if point.kind in ("flange", "tcp"):
            raise ValueError(f"{POSE_OF}: demonstration {src.id}'s poses are of the {point.text}; robosuite "
                             f"drives {robot} by its gripper's grip site, which a {point.kind} is not: run "
                             "libraries of demonstrations recorded in robosuite (skillbank sim record), "
                             "whose poses are of the grip site")
        if point.text == own or (point.kind == "offset" and _same(src.robot, robot)):
            continue  # this arm's own grip site: nothing to convert
        if point.kind == "offset" and src.robot is None:
            raise ValueError(f"{POSE_OF}: demonstration {src.id}'s poses are of the offset {point.text} "
                             f"of an arm it does not name, so whether that is a grip site is unknown; "
                             f"{robot} needs its grip site's: {HOW_TO_SAY}")
        what = (f"the {point.gripper}'s grip site" if point.gripper is not None else
                f"{src.robot}'s grip site as robosuite reports it ({point.text})")
        where = f" (recorded on {src.robot})" if src.robot is not None and point.gripper is not None else ""
        target = f"{robot}'s grip site" + (f" ({own})" if own is not None else "")
        notes.setdefault((what, where), f"pose_of: poses of {what}{where} taken as {target}: where the hand "
                                        "holds is kept, not its flange")
    return list(notes.values())


def check_pads(env, robot: str) -> None:
    """Refuse an arm whose gripper names finger-pad geoms its model lacks.

    The executor reads which way the fingers close from the pads, and robosuite's own grasp check
    (a pick's effect, ``Stack3``'s success) looks for contacts with them. robosuite 1.5.2's XArm7
    gripper names ``finger1_pad_collision`` geoms its model does not have: without this check an
    episode would stop inside robosuite with a list of every geom of the scene.
    """
    gripper = env.robots[0].gripper
    gripper = gripper["right"] if isinstance(gripper, dict) else gripper
    names = set(env.sim.model.geom_names)
    missing = sorted({g for side in ("left_fingerpad", "right_fingerpad")
                      for g in gripper.important_geoms.get(side, []) if g not in names})
    if missing:
        raise ValueError(f"robot: robosuite's {robot} comes with a gripper ({type(gripper).__name__}) whose "
                         f"finger pads name geoms its model lacks ({', '.join(missing)}), so no grasp can be "
                         "seen or checked on it; choose another of robosuite's arms")
