"""Physics simulation of a joint trajectory in a scene's world (MuJoCo, extra ``skillbank[sim]``).

:func:`build_world` writes the MJCF world of a :class:`~skillbank.planning.Scene`
for a robot model; :func:`simulate` replays a trajectory's ``joints`` (and
``gripper``) in it and reports tracking, contacts, buttons, objects and the
scene's goal facts (:class:`SimulationResult`). :func:`execute_plan` plans a task over a
library's described skills and carries it out in a robosuite scene, checking each step's effect.
docs/simulation.md describes
the world, the rules and the JSON contract. MuJoCo is imported when a world
is compiled, not when this package is imported.
"""

from ._compose import COMPOSED, STEP_REASONS, execute_plan, observe
from ._evaluate import BASELINES, REASONS, binomial_interval, evaluate
from ._human import HumanDemonstrator
from ._human_file import command_statistics, record_human
from ._mujoco import MISSING, import_mujoco
from ._robosuite import TASKS, record
from ._run import GRIPPER_RANGE, SimulationResult, simulate
from ._servo import SERVO_GAINS
from ._world import GRIP_FORCE, LINK_MASSES, PRESS_FORCE, World, build_world

__all__ = ["simulate", "SimulationResult", "GRIPPER_RANGE", "build_world", "World", "LINK_MASSES",
           "PRESS_FORCE", "GRIP_FORCE", "SERVO_GAINS", "MISSING", "import_mujoco", "record", "TASKS",
           "evaluate", "REASONS", "BASELINES", "binomial_interval", "execute_plan", "COMPOSED",
           "STEP_REASONS", "observe", "HumanDemonstrator", "record_human",
           "command_statistics"]
