"""scikit-learn's parameter protocol (``get_params``, ``set_params``, ``clone``), without importing it.

The representations and the segmenter follow scikit-learn's estimator
contract, but the command line uses them for one quick edit or segmentation,
and importing scikit-learn costs about 0.55 s (it pulls in scipy.stats): more
than the work itself. :class:`Params` implements the protocol the way
``sklearn.base.BaseEstimator`` does (parameter names from the signature of
``__init__``, nested ``a__b`` names, a repr showing the parameters that differ
from their defaults), so ``sklearn.base.clone`` and ``GridSearchCV``-style
tools work on these classes unchanged. Estimators that need scikit-learn's
machinery anyway (the clusterers and featurisers) subclass ``BaseEstimator``.
"""

from __future__ import annotations

import inspect

__all__ = ["Params", "NotFittedError"]


class NotFittedError(ValueError, AttributeError):
    """Raised when a model is used before ``fit``; a ValueError and an AttributeError, as in scikit-learn."""


_EMPTY = inspect.Parameter.empty


class Params:
    """``get_params`` / ``set_params`` / ``repr`` from the keyword arguments of ``__init__``.

    Subclasses store every ``__init__`` argument unchanged under its own name.

    Examples
    --------
    >>> class Model(Params):
    ...     def __init__(self, *, alpha=1.0, beta=None):
    ...         self.alpha, self.beta = alpha, beta
    >>> m = Model(alpha=2.0)
    >>> m, m.get_params()
    (Model(alpha=2.0), {'alpha': 2.0, 'beta': None})
    >>> m.set_params(beta=3)
    Model(alpha=2.0, beta=3)
    """

    @classmethod
    def _param_signature(cls) -> list[inspect.Parameter]:
        init = cls.__init__
        if init is object.__init__:
            return []
        params = list(inspect.signature(init).parameters.values())[1:]
        if any(p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in params):
            raise TypeError(f"{cls.__name__}.__init__ must name its parameters (no *args or **kwargs)")
        return sorted(params, key=lambda p: p.name)

    @classmethod
    def _get_param_names(cls) -> list[str]:
        return [p.name for p in cls._param_signature()]

    def get_params(self, deep: bool = True) -> dict:
        """The parameters, by name; with ``deep``, those of nested estimators as ``name__param``."""
        out = {}
        for name in self._get_param_names():
            value = getattr(self, name)
            if deep and hasattr(value, "get_params") and not isinstance(value, type):
                out.update((f"{name}__{k}", v) for k, v in value.get_params().items())
            out[name] = value
        return out

    def set_params(self, **params):
        """Set parameters by name (``name__param`` for nested estimators); returns self."""
        valid = self.get_params(deep=True)
        nested: dict = {}
        for key, value in params.items():
            name, sep, sub = key.partition("__")
            if name not in valid:
                raise ValueError(f"set_params: {type(self).__name__} has no parameter {name!r}; "
                                 f"valid parameters are {sorted(self._get_param_names())}")
            if sep:
                nested.setdefault(name, {})[sub] = value
            else:
                setattr(self, name, value)
                valid[name] = value
        for name, sub in nested.items():
            valid[name].set_params(**sub)
        return self

    def __repr__(self) -> str:
        changed = []
        for p in self._param_signature():
            value = getattr(self, p.name)
            default = p.default
            same = default is not _EMPTY and (value is default or (
                type(value) is type(default) and _equal(value, default)))
            if not same:
                changed.append(f"{p.name}={value!r}")
        return f"{type(self).__name__}({', '.join(changed)})"


def _equal(a, b) -> bool:
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # arrays and other values without a plain truth value
        return False
