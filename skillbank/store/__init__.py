"""The store: where a skill library's demonstrations, primitives, clusterings and labels live.

The store only stores (see :class:`Store`); the pipeline
(:class:`skillbank.pipeline.Library`) segments, featurises and clusters, and
hands it the results. :class:`SQLiteStore` is the embedded backend, one file
in WAL mode; :class:`PostgresStore` the shared one, a PostgreSQL database
(``postgresql://`` URLs; ``pip install 'skillbank[postgres]'``).
:data:`STORES` maps URL schemes to backends and :func:`open_store` picks one
from a location, so a new backend is one :class:`Store` subclass and one line
in :data:`STORES`. :func:`copy_library` copies a library between any two
stores, ids and versions kept; :func:`mask_url` shows a URL without its password.

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
from ._postgres import PostgresStore, mask_url
from ._registry import STORES, open_store
from ._schema import SCHEMA_VERSION
from ._sqlite import SQLiteStore
from ._transfer import copy_library

__all__ = ["Store", "SQLiteStore", "PostgresStore", "Primitive", "STORES", "open_store", "copy_library",
           "mask_url", "SCHEMA_VERSION"]
