"""Figures of segmentation results, drawn with matplotlib (no pyplot state)."""

from ._clustering import plot_cluster_comparison
from ._composed import plot_composed
from ._editing import draw_edit, plot_edit
from ._executable import plot_executable
from ._grid import plot_segment_grid
from ._library import plot_reuse, plot_skills
from ._planning import draw_plan, plot_plan
from ._segmentation import figure_path, plot_jerk_profile, plot_segments
from ._simulation import plot_simulation
from ._summary import plot_keypoint_probability, plot_segmentation_summary

__all__ = [
    "plot_jerk_profile", "plot_keypoint_probability", "plot_segments", "plot_segmentation_summary",
    "plot_cluster_comparison", "draw_edit", "plot_edit", "plot_executable",
    "plot_segment_grid", "figure_path", "draw_plan", "plot_plan", "plot_skills", "plot_reuse",
    "plot_simulation", "plot_composed",
]
