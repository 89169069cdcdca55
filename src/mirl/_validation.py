"""Options declared once: a spec per field — its default, the values it takes, what it means and
the flag that sets it — validated in one place, with one error.

An options type is a frozen dataclass deriving from :class:`Options` whose every field is
declared with :func:`option`::

    class LearnOptions(Options):
        max_iterations: int = option(Interval(int, 1, 100), default=5,
                                     doc="relabelling rounds at most", flag="--max-iterations")

Constructing one checks every field against its constraints (a value is accepted when it meets
any one of them; ``None`` in the list accepts None), then the type's own rules between fields
(:meth:`Options._check`). Whatever is wrong raises :class:`OptionError`, one line that names
the option in backquotes — ```max_iterations``` must be an integer in [1, 100], got 0 — which
the command line rewrites to the flag, and an unknown option's name gets the nearest known ones.
The command line builds its flags from the same specs (:meth:`Spec.parse` for a flag's text),
so a bound, a choice, a default and a help text are written once.

Why by hand: this follows scikit-learn's ``utils._param_validation`` (a list of constraints per
parameter, checked by one function, one error type that is both a ValueError and a TypeError),
which is private to scikit-learn; what mirl adds is the flag beside each declaration, so the
parser is built from it. The module imports nothing heavy, so the parser can read the option
types at start-up.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar, Protocol, TypeVar, dataclass_transform

from mirl._registry import Registry, did_you_mean

__all__ = [
    "OptionError",
    "Constraint",
    "Interval",
    "OneOf",
    "Boolean",
    "Instance",
    "Satisfies",
    "SEED",
    "Spec",
    "option",
    "same_option",
    "Options",
    "check_argument",
    "unknown_name",
    "parse_number",
]

OptionsT = TypeVar("OptionsT", bound="Options")

_INTEGER = re.compile(r"\s*[+-]?\d+\s*", re.ASCII)
_DECIMAL = re.compile(
    r"\s*[+-]?(?:(?P<mantissa>\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf|infinity|nan)\s*",
    re.IGNORECASE | re.ASCII,
)


def parse_number(text: str, kind: type = float) -> int | float:
    """A number as a command line or a data file writes one.

    Python's ``int`` and ``float`` also read ``0.7_5`` as 0.75 and ``1e-400`` as 0.0; the CSV
    readers refuse the first, and the second is a setting the user did not give. Both are
    refused here, so that a flag reads numbers as mirl's files do.

    Parameters
    ----------
    text : str
        The text: an optional sign, digits with an optional point and exponent (``inf`` and
        ``nan`` for a float); surrounding spaces are allowed.
    kind : {float, int}, default float
        What it must be.

    Returns
    -------
    int or float
        The number.

    Raises
    ------
    ValueError
        ``'0.7_5' is not a number``; ``'1e-400' is too small for a float, which would read it
        as 0``.
    """
    if kind is int:
        if not _INTEGER.fullmatch(text):
            raise ValueError(f"'{text}' is not an integer")
        return int(text)
    match = _DECIMAL.fullmatch(text)
    if match is None:
        raise ValueError(f"'{text}' is not a number")
    value = float(text)
    mantissa = match.group("mantissa") or ""
    if value == 0.0 and mantissa.strip("0.") != "":
        raise ValueError(f"'{text.strip()}' is too small for a float, which would read it as 0")
    return value


class OptionError(ValueError, TypeError):
    """An option or argument that cannot work, or an option that does not exist.

    Its text is one line naming the option in backquotes (```p``` must be a number in [0, 1],
    got 1.5). A ValueError and a TypeError, as scikit-learn's ``InvalidParameterError``: a wrong
    type and a wrong value are one mistake to the caller.

    Parameters
    ----------
    option : str
        The option's (or argument's) name.
    problem : str
        What is wrong, the text after the name, which the command line puts after the flag.
    owner : str, default ""
        The options type that declares the option ("" for a function's argument).
    """

    def __init__(self, option: str, problem: str, *, owner: str = "") -> None:
        # a name no table holds reads as the tables' own sentence, after the option's name
        sep = ": " if problem.startswith("unknown ") else " "
        super().__init__(f"`{option}`{sep}{problem}")
        self.option, self.problem, self.owner = option, problem, owner


class Constraint(Protocol):
    """What a field accepts, a phrase for messages and the conversion of a flag's text."""

    def accepts(self, value: Any) -> bool:
        """Whether ``value`` meets the constraint.

        Parameters
        ----------
        value : object
            A value given for the option.

        Returns
        -------
        bool
            True when it is accepted.
        """
        ...

    def describe(self) -> str:
        """The requirement in words, for messages.

        Returns
        -------
        str
            A phrase such as "an integer in [1, 100]".
        """
        ...

    def convert(self, text: str) -> Any:
        """A flag's text as a value the constraint checks.

        Parameters
        ----------
        text : str
            The flag's text.

        Returns
        -------
        object
            The value (ValueError, one line, for text that is not one).
        """
        ...


def _show(v: float) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


@dataclass(frozen=True)
class Interval(Constraint):
    """A number between two bounds. A bool is not a number here; a float must be finite.

    Parameters
    ----------
    kind : type
        ``int`` or ``float``.
    low, high : float, optional
        The bounds (None: unbounded), included unless open.
    open_low, open_high : bool, default False
        Whether the bound is left out.
    text : str, optional
        The phrase for messages, when the bounds read badly (2^63 - 1).
    """

    kind: type
    low: float | None = None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False
    text: str | None = None  # the phrase for messages, when the bounds read badly (2^63 - 1)

    def __post_init__(self) -> None:
        if self.kind not in (int, float):
            raise ValueError(f"an interval of int or float, not {self.kind}")

    def accepts(self, value: Any) -> bool:
        if isinstance(value, bool):
            return False
        if self.kind is int and not isinstance(value, numbers.Integral):
            return False
        if not isinstance(value, numbers.Real) or not math.isfinite(value):
            return False
        if self.kind is float:
            value = float(value)
        left, right = not self.open_low, not self.open_high
        if self.low is not None and not (value >= self.low if left else value > self.low):
            return False
        return self.high is None or (value <= self.high if right else value < self.high)

    def describe(self) -> str:
        if self.text is not None:
            return self.text
        what = "an integer" if self.kind is int else "a number"
        left, right = not self.open_low, not self.open_high
        if self.low is not None and self.high is not None:
            return (f"{what} in {'[' if left else '('}{_show(self.low)}, {_show(self.high)}"
                    f"{']' if right else ')'}")  # fmt: skip
        if self.low is not None:
            return f"{what} {'>=' if left else '>'} {_show(self.low)}"
        if self.high is not None:
            return f"{what} {'<=' if right else '<'} {_show(self.high)}"
        return what if self.kind is int else "a finite number"

    def convert(self, text: str) -> Any:
        return parse_number(text, self.kind)


SEED = Interval(int, 0, 2**63 - 1, text="an integer in [0, 2^63 - 1]")
"""A seed: what :class:`numpy.random.SeedSequence` takes, within a signed 64-bit integer."""


@dataclass(frozen=True)
class OneOf(Constraint):
    """One of the names of a table. A name it does not hold is refused in the table's own
    sentence, with the nearest names (:meth:`~mirl._registry.Registry.unknown`).

    Parameters
    ----------
    names : Registry, iterable of str or callable
        The table, its names, or a callable returning either, read when a value other than the
        option's default is checked (a table whose module is heavy: the light option types do
        not import it to be made).
    kind : str, default "choice"
        What a name is, for messages, when the table is not a Registry.
    """

    names: Iterable[str] | Callable[[], Iterable[str]]
    kind: str = "choice"

    @property
    def lazy(self) -> bool:
        """Whether the table is read only when needed."""
        return callable(self.names)

    def table(self) -> Registry[Any]:
        """The table, read now.

        Returns
        -------
        Registry
            The table itself, or its names as one.
        """
        names = self.names() if callable(self.names) else self.names
        if isinstance(names, Registry):
            return names
        return Registry(self.kind, tuple(names), name=str)

    def known(self) -> tuple[str, ...]:
        """The names, read now.

        Returns
        -------
        tuple of str
            In the table's order.
        """
        return self.table().names

    def unknown(self, value: str) -> str:
        """The refusal of ``value``, in the table's sentence.

        Parameters
        ----------
        value : str
            A name the table does not hold.

        Returns
        -------
        str
            ``unknown KIND 'value' (did you mean …? known: …)``.
        """
        return str(self.table().unknown(value))

    def accepts(self, value: Any) -> bool:
        return isinstance(value, str) and value in self.known()

    def describe(self) -> str:
        return f"one of {', '.join(self.known())}"

    def convert(self, text: str) -> Any:
        return text


@dataclass(frozen=True)
class Boolean(Constraint):
    """True or False (not 0 and 1: a number where a switch belongs is a mistake)."""

    def accepts(self, value: Any) -> bool:
        return isinstance(value, bool)

    def describe(self) -> str:
        return "True or False"

    def convert(self, text: str) -> Any:  # a switch is a flag without a value
        raise ValueError("a switch takes no value")


@dataclass(frozen=True)
class Instance(Constraint):
    """An instance of a type (a mapping of an estimator's further options, say).

    Parameters
    ----------
    kind : type
        The type.
    what : str
        What it is, for messages.
    """

    kind: type
    what: str

    def accepts(self, value: Any) -> bool:
        return isinstance(value, self.kind)

    def describe(self) -> str:
        return self.what

    def convert(self, text: str) -> Any:
        raise ValueError(f"{self.what} cannot be given as text")


@dataclass(frozen=True)
class Satisfies(Constraint):
    """A string for which a predicate holds.

    Parameters
    ----------
    predicate : callable
        ``predicate(text) -> bool``.
    what : str
        Which strings it accepts, for messages.
    """

    predicate: Callable[[str], bool]
    what: str

    def accepts(self, value: Any) -> bool:
        return isinstance(value, str) and bool(self.predicate(value))

    def describe(self) -> str:
        return self.what

    def convert(self, text: str) -> Any:
        return text


def _shown(value: Any) -> str:
    return repr(value) if isinstance(value, str) else str(value)


def _problem(value: Any, constraints: tuple[Constraint | None, ...]) -> str:
    """What is wrong with ``value``: a name a table does not hold in the table's sentence,
    with the nearest names; anything else the requirement and the value."""
    choices = [c for c in constraints if isinstance(c, OneOf)]
    if isinstance(value, str) and choices:
        return choices[0].unknown(value)
    requirement = " or ".join("None" if c is None else c.describe() for c in constraints)
    return f"must be {requirement}, got {_shown(value)}"


def unknown_name(kind: str, value: Any, known: Iterable[str]) -> str:
    """The refusal of a name in the tables' own sentence.

    Parameters
    ----------
    kind : str
        What a name is ("method").
    value : object
        The name given.
    known : iterable of str
        The names it may be.

    Returns
    -------
    str
        ``unknown method 'mirl_t' (did you mean 'mirl-t' or 'mirl'? known: …)``.
    """
    return str(Registry(kind, tuple(known), name=str).unknown(str(value)))


def _accepts(value: Any, constraints: tuple[Constraint | None, ...]) -> bool:
    return any(value is None if c is None else c.accepts(value) for c in constraints)


def check_argument(name: str, value: Any, *constraints: Constraint | None) -> None:
    """Refuse a function's argument that meets none of its constraints, as an option's field is
    refused.

    Parameters
    ----------
    name : str
        The argument's name.
    value : object
        Its value.
    *constraints : Constraint or None
        What it may be (None: None).

    Raises
    ------
    OptionError
        The value meets none of them.
    """
    if not _accepts(value, constraints):
        raise OptionError(name, _problem(value, constraints))


@dataclass(frozen=True)
class Spec:
    """One option's declaration.

    Parameters
    ----------
    default : object
        The option's default.
    constraints : tuple of Constraint or None
        The values it takes (any one of them; None: None).
    doc : str
        What it means, one sentence: the flag's help.
    flag : str, optional
        The flag that sets it on the command line (None: none).
    metavar : str, optional
        The flag's metavar.
    name, owner : str, default ""
        The option's name and its options type, filled in by the type.
    """

    default: Any
    constraints: tuple[Constraint | None, ...]
    doc: str
    flag: str | None = None
    metavar: str | None = None
    name: str = ""  # filled in by the options type
    owner: str = ""

    def accepts(self, value: Any) -> bool:
        """Whether ``value`` meets one of the constraints.

        Parameters
        ----------
        value : object
            A value for the option.

        Returns
        -------
        bool
            True when it is accepted.
        """
        return _accepts(value, self.constraints)

    def is_default(self, value: Any) -> bool:
        """Whether ``value`` is the declared default.

        Parameters
        ----------
        value : object
            A value for the option.

        Returns
        -------
        bool
            True for the default itself, of its type (True is not 1).
        """
        return type(value) is type(self.default) and value == self.default

    @property
    def lazy(self) -> bool:
        """Whether a constraint reads its table only when needed (:class:`OneOf`)."""
        return any(isinstance(c, OneOf) and c.lazy for c in self.constraints)

    def check(self, value: Any) -> None:
        """Refuse a value that meets none of the constraints. The declared default passed where
        it was declared (or, read from a table when needed, is the table's: a test checks every
        default), so it is not checked again.

        Parameters
        ----------
        value : object
            A value for the option.

        Raises
        ------
        OptionError
            Naming this option.
        """
        if self.is_default(value):
            return
        if not self.accepts(value):
            raise OptionError(self.name, _problem(value, self.constraints), owner=self.owner)

    def requirement(self) -> str:
        """The constraints in words ("an integer in [1, 100] or None").

        Returns
        -------
        str
            The phrase.
        """
        return " or ".join("None" if c is None else c.describe() for c in self.constraints)

    @property
    def choices(self) -> tuple[str, ...] | None:
        """The names the option takes, if it is a choice (of a table read now)."""
        for c in self.constraints:
            if isinstance(c, OneOf) and not c.lazy:
                return c.known()
        return None

    def parse(self, text: str) -> Any:
        """A flag's text as this option's value, checked.

        Parameters
        ----------
        text : str
            The flag's text.

        Returns
        -------
        object
            The value.

        Raises
        ------
        OptionError
            Text that is not a value the option takes (a flag cannot say None, so the message
            does not offer it).
        """
        given = tuple(c for c in self.constraints if c is not None)
        try:
            value = given[0].convert(text)
        except ValueError as exc:
            raise OptionError(self.name, str(exc), owner=self.owner) from None
        if not _accepts(value, given):
            raise OptionError(self.name, _problem(value, given), owner=self.owner)
        return value


def option(
    *constraints: Constraint | None,
    default: Any,
    doc: str,
    flag: str | None = None,
    metavar: str | None = None,
) -> Any:
    """Declare a field of an :class:`Options` type (see the module docstring).

    Parameters
    ----------
    *constraints : Constraint or None
        The values it takes (any one of them; None: None).
    default : object
        Its default, checked where it is declared.
    doc : str
        What it means, one sentence: the flag's help.
    flag : str, optional
        The flag that sets it (None: none).
    metavar : str, optional
        The flag's metavar.

    Returns
    -------
    dataclasses.Field
        The field, its :class:`Spec` in its metadata.
    """
    spec = Spec(default, constraints, doc, flag, metavar)
    return dataclasses.field(default=default, metadata={_SPEC: spec})


def same_option(owner: type[Options], name: str) -> Any:
    """Declare a field as another type's option, for an options type that passes that option
    on: declared once, read twice.

    Parameters
    ----------
    owner : type
        The options type that declares it.
    name : str
        The option's name there.

    Returns
    -------
    dataclasses.Field
        A field of the same constraints, default, doc and flag.
    """
    spec = owner.spec(name)
    return dataclasses.field(default=spec.default, metadata={_SPEC: spec})


_SPEC = "mirl.option"


@dataclass_transform(kw_only_default=True, frozen_default=True, field_specifiers=(option,))
class Options:
    """The base of mirl's option types: a frozen, keyword-only dataclass whose fields are
    declared with :func:`option` and checked when it is made (module docstring).

    ``__options__`` maps each field's name to its :class:`Spec`.
    """

    __options__: ClassVar[Mapping[str, Spec]] = MappingProxyType({})

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        dataclasses.dataclass(frozen=True, kw_only=True)(cls)
        specs: dict[str, Spec] = {}
        for f in dataclasses.fields(cls):  # type: ignore[arg-type]
            spec = f.metadata.get(_SPEC)
            if spec is None:
                raise TypeError(f"{cls.__name__}.{f.name} is not declared with option()")
            specs[f.name] = dataclasses.replace(spec, name=f.name, owner=cls.__name__)
            if not spec.lazy and not spec.accepts(spec.default):  # fails at import, where declared
                raise OptionError(
                    f.name, _problem(spec.default, spec.constraints), owner=cls.__name__
                )
        cls.__options__ = MappingProxyType(specs)
        made = cls.__init__

        @functools.wraps(made)
        def __init__(self: Options, *args: Any, **values: Any) -> None:
            for name in values:
                if name not in specs:
                    raise cls._unknown(name)
            made(self, *args, **values)

        cls.__init__ = __init__  # type: ignore[method-assign,assignment]

    def __post_init__(self) -> None:
        for name, spec in self.__options__.items():
            spec.check(getattr(self, name))
        self._check()

    def _check(self) -> None:
        """The type's rules between fields; raise :meth:`refuse` for a combination that cannot
        work."""

    def refuse(self, name: str, problem: str) -> OptionError:
        """The error for one of this type's options.

        Parameters
        ----------
        name : str
            The option.
        problem : str
            What is wrong, after its name.

        Returns
        -------
        OptionError
            To raise.
        """
        return OptionError(name, problem, owner=type(self).__name__)

    @classmethod
    def _unknown(cls, name: str) -> OptionError:
        near = did_you_mean(str(name), cls.__options__)
        hint = f"did you mean {' or '.join(repr(n) for n in near)}? " if near else ""
        return OptionError(
            str(name),
            f"is not an option of {cls.__name__} ({hint}known: {', '.join(cls.__options__)})",
            owner=cls.__name__,
        )

    @classmethod
    def spec(cls, name: str) -> Spec:
        """The declaration of an option.

        Parameters
        ----------
        name : str
            The option.

        Returns
        -------
        Spec
            Its declaration (:class:`OptionError` for a name that is no option).
        """
        if name not in cls.__options__:
            raise cls._unknown(name)
        return cls.__options__[name]

    @classmethod
    def default(cls, name: str) -> Any:
        """An option's declared default.

        Parameters
        ----------
        name : str
            The option.

        Returns
        -------
        object
            Its default.
        """
        return cls.spec(name).default

    @classmethod
    def of(cls: type[OptionsT], options: OptionsT | Mapping[str, Any] | None) -> OptionsT:
        """Options of this type, from what a caller gave.

        Parameters
        ----------
        options : Options, mapping or None
            The options, a mapping of option names to values (unknown names refused with the
            nearest known ones), or None for the defaults.

        Returns
        -------
        Options
            Of this type.
        """
        if options is None:
            return cls()
        if isinstance(options, cls):
            return options
        if isinstance(options, Mapping):
            return cls(**options)
        raise OptionError(
            "options", f"must be a {cls.__name__}, a mapping or None, got {type(options).__name__}"
        )

    def replace(self: OptionsT, **changes: Any) -> OptionsT:
        """A copy with some options changed, checked like a new one.

        Parameters
        ----------
        **changes : object
            New values by option name.

        Returns
        -------
        Options
            The copy.
        """
        for name in changes:
            if name not in self.__options__:
                raise self._unknown(name)
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def changed(self) -> dict[str, Any]:
        """The options that differ from their declared defaults.

        Returns
        -------
        dict
            Their values by name.
        """
        return {
            name: getattr(self, name)
            for name, spec in self.__options__.items()
            if getattr(self, name) != spec.default
        }

    def to_dict(self) -> dict[str, Any]:
        """Every option by name.

        Returns
        -------
        dict
            The values by name, in the declaration's order.
        """
        return {name: getattr(self, name) for name in self.__options__}
