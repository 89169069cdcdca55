"""The parameter protocol of mirl's estimators, as scikit-learn's: ``get_params``, ``set_params``
and a ``repr`` of the settings that differ from the defaults.

An estimator's settings are the keyword arguments of its ``__init__``, kept under the same names
and validated there (one place); what ``fit`` learns ends in ``_``. Written here rather than
taken from scikit-learn's ``BaseEstimator``, which mirl does not depend on; ``sklearn.base.clone``
works on these estimators all the same, for it asks only for ``get_params`` and the
constructor.
"""

from __future__ import annotations

import inspect
from typing import Any

from mirl._registry import did_you_mean

__all__ = ["EstimatorParams"]


class EstimatorParams:
    """``get_params`` / ``set_params`` / ``repr`` from ``__init__``'s signature."""

    @classmethod
    def _param_names(cls) -> list[str]:
        """The names of ``__init__``'s parameters, in order."""
        params = inspect.signature(cls.__init__).parameters.values()
        return [
            p.name
            for p in params
            if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        ]

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The estimator's settings.

        Parameters
        ----------
        deep : bool, default True
            Accepted for scikit-learn's signature; mirl's estimators hold no estimators.

        Returns
        -------
        dict of str to object
            Each ``__init__`` parameter's value.
        """
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params: Any) -> EstimatorParams:
        """Change settings, validated as ``__init__`` validates them.

        Parameters
        ----------
        **params : dict
            New values of ``__init__`` parameters.

        Returns
        -------
        self
            The estimator, its settings changed (what it learned is kept until the next
            ``fit``).

        Raises
        ------
        ValueError
            An unknown parameter (with the nearest names), or a value ``__init__`` refuses;
            nothing is changed then.
        """
        names = self._param_names()
        for name in params:
            if name not in names:
                near = did_you_mean(name, names, n=1)
                hint = f"did you mean '{near[0]}'? " if near else ""
                raise ValueError(
                    f"{type(self).__name__} has no parameter '{name}' ({hint}known: "
                    f"{', '.join(names)})"
                )
        checked = type(self)(**{**self.get_params(), **params})  # __init__ validates
        for name in params:
            setattr(self, name, getattr(checked, name))
        return self

    def __repr__(self) -> str:
        signature = inspect.signature(type(self).__init__).parameters
        shown = []
        for name, value in self.get_params().items():
            default = signature[name].default
            if default is inspect.Parameter.empty or not _same(value, default):
                shown.append(f"{name}={_short(value)}")
        return f"{type(self).__name__}({', '.join(shown)})"


def _same(value: Any, default: Any) -> bool:
    """Whether a setting is its default (by identity, or equal for plain values)."""
    if value is default:
        return True
    try:
        return bool(type(value) is type(default) and value == default)
    except (TypeError, ValueError):  # an array's ambiguous truth value
        return False


def _short(value: Any) -> str:
    """A setting in a repr: an object with a long or address-bearing repr by its type's name."""
    text = repr(value)
    plain = len(text) <= 60 and not text.startswith("<") and " at 0x" not in text
    return text if plain else f"<{type(value).__name__}>"
