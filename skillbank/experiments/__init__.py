"""Reproducible experiments and the main demo job."""

from ._demo import run_segmentation_demo, synthetic_multistream

__all__ = ["run_segmentation_demo", "synthetic_multistream"]
