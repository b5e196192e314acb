"""The pipeline: demonstrations in, skills out, over a store.

:class:`Library` runs add -> segment -> featurise -> assign or cluster ->
label -> reuse, and keeps the results in a :class:`skillbank.store.Store`
(by default one SQLite file).

Examples
--------
>>> import numpy as np, os, tempfile
>>> from skillbank import Demonstration
>>> t = np.linspace(0.0, 1.0, 40)
>>> lib = Library(os.path.join(tempfile.mkdtemp(), "skills.db"))
>>> ids = lib.add_many([Demonstration.from_array(np.column_stack([t, a * t]), t) for a in (1, 2)],
...                    segment=False)
>>> lib.summary()["n_demonstrations"]
2
>>> lib.close()
"""

from ._library import Library, carry_labels

__all__ = ["Library", "carry_labels"]
