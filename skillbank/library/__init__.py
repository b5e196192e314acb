"""The motion-primitive library: demonstrations, primitives, skills and labels in one SQLite file.

Examples
--------
>>> import numpy as np, os, tempfile
>>> from skillbank import Demonstration
>>> from skillbank.library import Library
>>> t = np.linspace(0.0, 1.0, 40)
>>> lib = Library(os.path.join(tempfile.mkdtemp(), "skills.db"))
>>> ids = lib.add_many([Demonstration.from_array(np.column_stack([t, a * t]), t) for a in (1, 2)],
...                    segment=False)
>>> lib.summary()["n_demonstrations"]
2
>>> lib.close()
"""

from ._arrays import flat_features, from_npy, to_npy
from ._library import Library
from ._records import Primitive
from ._schema import SCHEMA_VERSION

__all__ = ["Library", "Primitive", "SCHEMA_VERSION", "flat_features", "to_npy", "from_npy"]
