"""The store: where a skill library's demonstrations, primitives, clusterings and labels live.

The store only stores (see :class:`Store`); the pipeline
(:class:`skillbank.pipeline.Library`) segments, featurises and clusters, and
hands it the results. :class:`SQLiteStore` is the embedded backend, one file
in WAL mode. :data:`STORES` maps URL schemes to backends and
:func:`open_store` picks one from a location, so a new backend is one
:class:`Store` subclass and one line in :data:`STORES`.

Examples
--------
>>> import numpy as np, os, tempfile
>>> from skillbank import Demonstration
>>> t = np.linspace(0.0, 1.0, 40)
>>> with open_store(os.path.join(tempfile.mkdtemp(), "skills.db")) as store:
...     did, pids = store.add_demonstration(Demonstration.from_array(np.column_stack([t, t]), t),
...                                         [(0, 20), (20, 40)])
...     [p.n_steps for p in store.primitives(load=False)]
[20, 20]
"""

from ._base import Primitive, Store
from ._registry import STORES, open_store
from ._schema import SCHEMA_VERSION
from ._sqlite import SQLiteStore

__all__ = ["Store", "SQLiteStore", "Primitive", "STORES", "open_store", "SCHEMA_VERSION"]
