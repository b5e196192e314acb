"""Reproducible experiments and the main demo job."""

from ._composition import COMPOSITIONS, check_options, composition_experiment
from ._demo import run_segmentation_demo, synthetic_multistream, synthetic_ur5e
from ._library_demo import run_library_demo
from ._planning_demo import button_task, rail_task, reach_task, run_planning_demo
from ._rail import (
    PAPER_REPRESENTATIVES,
    RailExperimentResult,
    composition,
    count_misclustered,
    plot_rail_experiment,
    rail_experiment,
    run_rail_experiment,
)

__all__ = [
    "run_segmentation_demo", "run_library_demo", "synthetic_multistream", "synthetic_ur5e",
    "run_planning_demo", "button_task", "rail_task", "reach_task",
    "PAPER_REPRESENTATIVES",
    "RailExperimentResult",
    "composition", "count_misclustered",
    "composition_experiment", "check_options", "COMPOSITIONS",
    "plot_rail_experiment", "rail_experiment", "run_rail_experiment",
]
