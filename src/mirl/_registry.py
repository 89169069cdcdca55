"""One table type for everything mirl looks up by name: methods, worlds, input formats, reward
kinds, experiments, go rules, belief modes, motion models.

A :class:`Registry` is a read-only mapping from a row's name to the row, in the order the rows
were given. Looking up a name it does not hold raises :class:`UnknownNameError`, one line that
names what was asked for, suggests the nearest known names ("did you mean") and lists them all,
so every table answers a typo the same way. A row that cannot work is refused where the table is
defined: ``check`` runs on every row as it is registered, so a bad row fails at import, in the
module that wrote it, not in the run that first uses it.

Why a class of our own: :mod:`difflib` gives the suggestions and :class:`collections.abc.Mapping`
the dictionary behaviour; what no library gives is one error shape for every table of the
package, and the check at definition. The module imports nothing heavy, so the command line can
build its parser from the tables at start-up.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from importlib import import_module
from typing import Any, Generic, TypeVar

__all__ = [
    "Choice",
    "Registry",
    "Strategy",
    "UnknownNameError",
    "check_entry_point",
    "did_you_mean",
    "resolve",
]

T = TypeVar("T")


class UnknownNameError(KeyError, ValueError):
    """A name a table does not hold.

    A :class:`ValueError` (a bad argument value) and a :class:`KeyError` (so a :class:`Registry`
    behaves as a mapping); its text is one line.

    Parameters
    ----------
    message : str
        The one-line message.
    name : str
        The name asked for.
    known : tuple of str
        The names that would have been accepted.
    """

    def __init__(self, message: str, *, name: str, known: tuple[str, ...]) -> None:
        super().__init__(message)
        self.message, self.name, self.known = message, name, known

    def __str__(self) -> str:  # KeyError would quote the message
        return self.message


def did_you_mean(name: str, known: Iterable[str], n: int = 3) -> list[str]:
    """The known names closest to ``name``, nearest first.

    Parameters
    ----------
    name : str
        The name asked for.
    known : iterable of str
        The names to choose from.
    n : int, default 3
        At most this many suggestions.

    Returns
    -------
    list of str
        The close matches (difflib's ratio at least 0.6), then the names that start with
        ``name``.
    """
    known = list(known)
    close = difflib.get_close_matches(name, known, n=n, cutoff=0.6)
    starts = [k for k in known if name and k.startswith(name) and k not in close]
    return (close + starts)[:n]


@dataclass(frozen=True)
class Choice:
    """A row that is a name and what it means.

    The row of a table whose choices the code of its own module carries out (an estimator's
    objectives, an initialisation).

    Parameters
    ----------
    name : str
        The choice's name, as a user writes it.
    description : str
        What it does, for help texts.
    """

    name: str
    description: str


class Registry(Mapping[str, T], Generic[T]):
    """A read-only, ordered table of rows by name.

    Parameters
    ----------
    kind : str
        What a row is, for messages ("method", "world", "input format").
    rows : iterable
        The rows, in the order ``names`` and iteration give them.
    name : callable, default ``row.name``
        A row's name.
    check : callable, optional
        Called on every row as it is registered; raises ValueError (one line) for a row that
        cannot work.

    Raises
    ------
    ValueError
        Two rows of one name, or a row ``check`` refuses.
    """

    def __init__(
        self,
        kind: str,
        rows: Iterable[T],
        *,
        name: Callable[[T], str] | None = None,
        check: Callable[[T], None] | None = None,
    ) -> None:
        self.kind = kind
        self._name: Callable[[T], str] = name or (lambda row: row.name)  # type: ignore[attr-defined]
        self._check = check
        self._rows: dict[str, T] = {}
        for row in rows:
            self.register(row)

    @classmethod
    def of_choices(cls, kind: str, descriptions: Mapping[str, str]) -> Registry[Choice]:
        """A table of :class:`Choice` rows from ``{name: description}``, in its order.

        Parameters
        ----------
        kind : str
            What a row is, for messages.
        descriptions : mapping of str to str
            Every choice's name and description.

        Returns
        -------
        Registry of Choice
            The table.
        """
        return Registry(kind, (Choice(n, d) for n, d in descriptions.items()))

    def register(self, row: T) -> T:
        """Add ``row``, checked first.

        Parameters
        ----------
        row : object
            The row; its name must be new to the table.

        Returns
        -------
        object
            ``row`` itself (so a definition can register as it assigns).

        Raises
        ------
        ValueError
            A row of the same name is already registered, or ``check`` refuses the row.
        """
        key = self._name(row)
        if key in self._rows:
            raise ValueError(f"{self.kind} '{key}' is registered twice")
        if self._check is not None:
            self._check(row)
        self._rows[key] = row
        return row

    @property
    def names(self) -> tuple[str, ...]:
        """Every row's name, in order."""
        return tuple(self._rows)

    def unknown(self, name: str, *, known: Iterable[str] | None = None) -> UnknownNameError:
        """The error for ``name`` among ``known``.

        Parameters
        ----------
        name : str
            The name asked for.
        known : iterable of str, optional
            The acceptable names; every row's name by default.

        Returns
        -------
        UnknownNameError
            Its message names ``name``, suggests the nearest known names and lists them all.
        """
        known = tuple(self._rows if known is None else known)
        near = did_you_mean(str(name), known)
        hint = f"did you mean {' or '.join(repr(k) for k in near)}? " if near else ""
        message = f"unknown {self.kind} '{name}' ({hint}known: {', '.join(known)})"
        return UnknownNameError(message, name=str(name), known=known)

    def lookup(self, name: str, *, among: Iterable[str] | None = None) -> T:
        """The row of ``name``.

        Parameters
        ----------
        name : str
            The row's name.
        among : iterable of str, optional
            Narrows the acceptable names (for instance the methods that learn).

        Returns
        -------
        object
            The row.

        Raises
        ------
        UnknownNameError
            ``name`` is not a row's name, or not among ``among``.
        """
        if among is not None:
            among = tuple(among)
            if name not in among:
                raise self.unknown(name, known=among)
        if name not in self._rows:
            raise self.unknown(name)
        return self._rows[name]

    def __getitem__(self, name: str) -> T:
        return self.lookup(name)

    def __contains__(self, name: object) -> bool:
        return name in self._rows

    def __iter__(self) -> Iterator[str]:
        return iter(self._rows)

    def __len__(self) -> int:
        return len(self._rows)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self._rows)})"


# A row whose strategy lives in a heavy module (a world's class, a go rule's) names it by an
# entry point, "package.module:name", as gymnasium's registry names environments: reading the
# table imports nothing, and the strategy is imported when a row is used.
def check_entry_point(value: str | None, what: str) -> None:
    """Refuse a malformed entry point, importing nothing.

    Parameters
    ----------
    value : str or None
        The entry point, ``"package.module:name"``.
    what : str
        What it is, for the message (``"world 'fog': entry point"``).

    Raises
    ------
    ValueError
        If ``value`` is not ``"package.module:name"`` with identifiers for names.
    """
    module, sep, attr = (value or "").partition(":")
    parts = module.split(".") if module else []
    if not sep or not attr.isidentifier() or not parts or not all(p.isidentifier() for p in parts):
        raise ValueError(f"{what} {value!r} is not 'package.module:name'")


def resolve(entry_point: str) -> Any:
    """The object an entry point ``"module:attr"`` names (importing its module).

    Parameters
    ----------
    entry_point : str
        ``"package.module:name"``.

    Returns
    -------
    object
        The module's attribute.
    """
    module, _, attr = entry_point.partition(":")
    return getattr(import_module(module), attr)


@dataclass(frozen=True)
class Strategy:
    """A row that is a name, what it means and the entry point of the code that carries it
    out, imported when the row is used (its table checks the entry point with
    :func:`check_entry_point`).

    Parameters
    ----------
    name : str
        The row's name, as a user writes it.
    description : str
        What it does, for help texts.
    entry_point : str
        ``"package.module:name"`` of what carries it out.
    """

    name: str
    description: str
    entry_point: str

    def load(self) -> Any:
        """What carries the row out.

        Returns
        -------
        object
            The object its entry point names.
        """
        return resolve(self.entry_point)
