"""Constants that light modules share with the heavy packages that own them, importing neither.

The store checks a stored clustering's ``features`` against the kinds
:mod:`skillbank.clustering` knows, and :class:`skillbank.pipeline.Library`
takes reuse's shortlist (:mod:`skillbank.selection`) and the planner's time
limit (:mod:`skillbank.planning`) as its defaults. Those packages import
scikit-learn and scipy (about 0.9 s of start-up), which ``skillbank library
list``, ``show``, ``init`` and ``export`` never use. Each value is defined here
once and its owner re-exports it under the same name.
"""

from __future__ import annotations

__all__ = ["FEATURE_KINDS", "SHORTLIST", "TIME_LIMIT"]

#: The per-primitive features a library clusters on (:func:`skillbank.clustering.primitive_features`).
FEATURE_KINDS = ("default", "position")
#: Candidates the paper's curve-length criterion chooses among by default (``selection.reuse``).
SHORTLIST = 3
#: Seconds the planner's search may run before it gives up (a button task takes well under one). With up to
#: ``planning.MAX_GROUNDINGS`` actions an expansion under LM-cut can take tens of milliseconds, so
#: ``planning.MAX_EXPANSIONS`` alone could keep a hard problem searching for hours.
TIME_LIMIT = 600.0
