"""Registries: the planners, controllers and navigation methods that a scenario or a command can name.

Each kind has one :class:`Registry`. An implementation registers itself with a decorator::

    @register_planner("straight", params=StraightParams)
    class StraightPlanner:
        def __init__(self, world, params): ...
        def plan(self, request): ...

after which ``planner: {name: straight, ...}`` in a scenario file builds it, with the settings
read into ``StraightParams`` (a frozen dataclass deriving from
:class:`~nodnav.scenario.params.PlannerParams`) and checked when the scenario is loaded. A planner
or controller names its parameter dataclass; the built-in ones declare theirs in
:mod:`nodnav.scenario.params`, so that a scenario is validated without importing any planner. A
navigation method has no parameters of its own: it reads the scenario.

Third-party packages register through entry points, loaded the first time a name is not found
or the names are listed: groups ``nodnav.planners``, ``nodnav.controllers`` and
``nodnav.methods``. An entry point names a module that registers its implementations when it is
imported, or an implementation itself, which is then registered under the entry point's name::

    [project.entry-points."nodnav.planners"]
    straight = "my_package.straight"
"""

from __future__ import annotations

import logging
import re
import types
from collections.abc import Callable
from dataclasses import dataclass, is_dataclass
from importlib.metadata import entry_points
from typing import Any, TypeVar

from nodnav.errors import NodnavError, nearest_hint, shown

log = logging.getLogger(__name__)

T = TypeVar("T", bound=Callable[..., Any])
C = TypeVar("C", bound=type)

_NAME = re.compile(r"[a-z0-9][a-z0-9_.-]{0,39}")


class RegistryError(NodnavError, ValueError):
    """A name that is not registered, or a registration that cannot be accepted."""


@dataclass(frozen=True)
class Entry:
    """One registered implementation."""

    name: str
    """The name a scenario file or a command uses."""
    factory: Callable[..., Any] | None
    """What builds it (usually the class); ``None`` while only its parameters are declared."""
    params: type | None
    """Its parameter dataclass (planners and controllers), else ``None``."""
    help: str
    """One line saying what it is, for the command line's help and listings."""


class Registry:
    """Implementations of one kind, by name.

    Parameters
    ----------
    kind : str
        What is registered, in the singular (``planner``), for messages.
    group : str
        The entry-point group third-party packages register in (``nodnav.planners``).
    """

    def __init__(self, kind: str, group: str):
        self.kind = kind
        self.group = group
        self._entries: dict[str, Entry] = {}
        self._plugins_loaded = False
        self._broken: dict[str, str] = {}
        self._declared_by: dict[str, str] = {}  # name -> the package whose implementation fills it

    def register(self, name: str, *, params: type | None = None, help: str | None = None) -> Callable[[T], T]:
        """A decorator registering an implementation (a class or a factory function) under ``name``.

        Parameters
        ----------
        name : str
            Lower-case letters, digits, ``-``, ``_`` and ``.``, at most 40 characters.
        params : type, optional
            The implementation's parameter dataclass (frozen). May be left out when it was
            declared with :meth:`declare` already.
        help : str, optional
            One line for listings; by default the first line of the implementation's docstring.

        Returns
        -------
        Callable
            The decorator, which returns the implementation unchanged.
        """
        def decorate(factory: T) -> T:
            known = self._entries.get(name)
            if known is not None and known.factory is not None and known.factory is not factory:
                raise RegistryError(f"{self.kind} {name!r} is registered already (by {_where(known.factory)})")
            owner = self._declared_by.get(name)
            if known is not None and known.factory is None and owner and _package(factory) != owner:
                raise RegistryError(f"{self.kind} {name!r} is declared already by {owner} "
                                    f"({_where(known.params)}); register yours under another name")
            if known is not None and params is not None and known.params not in (None, params):
                raise RegistryError(f"{self.kind} {name!r}: its parameters are declared already as "
                                    f"{known.params.__name__}")
            text = help or (known.help if known else "") or _first_line(factory)
            self._put(Entry(name, factory, params or (known.params if known else None), text))
            return factory

        return decorate

    def declare(self, name: str, *, params: type | None = None, help: str = "") -> Callable[[C], C]:
        """A decorator declaring a built-in name and its parameter dataclass before its
        implementation registers (which happens in a higher layer). Use it on the dataclass.

        The name is kept for an implementation from the dataclass's own top-level package
        (nodnav's for the built-ins): a plugin loaded first cannot take it."""
        def decorate(cls: C) -> C:
            known = self._entries.get(name)
            self._put(Entry(name, known.factory if known else None, params or cls, help))
            self._declared_by[name] = _package(cls)
            return cls

        return decorate

    def get(self, name: str) -> Entry:
        """The entry of ``name``, loading the entry points first when it is not known.

        Raises
        ------
        RegistryError
            One line naming the unknown name, the closest known one or the known ones.
        """
        if name not in self._entries:
            self.load_plugins()
        if name not in self._entries:
            if name in self._broken:
                raise RegistryError(f"{self.kind} {name!r} could not be loaded: {self._broken[name]}")
            raise RegistryError(f"unknown {self.kind} {shown(name)}{nearest_hint(name, self.names(), self.kind + 's')}")
        return self._entries[name]

    def params(self, name: str) -> type | None:
        """The parameter dataclass of ``name`` (see :meth:`get`)."""
        return self.get(name).params

    def create(self, name: str, *args: Any, **kwargs: Any) -> Any:
        """Build the implementation ``name`` with ``args``.

        Raises
        ------
        RegistryError
            When ``name`` is unknown or only its parameters were declared (its implementation's
            module has not been imported).
        """
        entry = self.get(name)
        if entry.factory is None:
            raise RegistryError(f"{self.kind} {name!r} has parameters but no implementation registered")
        return entry.factory(*args, **kwargs)

    def names(self) -> tuple[str, ...]:
        """Every registered name (entry points included), in registration order."""
        self.load_plugins()
        return tuple(self._entries)

    def entries(self) -> tuple[Entry, ...]:
        """Every entry, in registration order."""
        self.load_plugins()
        return tuple(self._entries.values())

    def __iter__(self):
        return iter(self.names())

    def __len__(self) -> int:
        return len(self.names())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self.names()

    def help_text(self) -> str:
        """``name: help`` for every entry, separated by semicolons (for ``--help``)."""
        return "; ".join(f"{e.name}: {e.help}" if e.help else e.name for e in self.entries())

    def load_plugins(self) -> None:
        """Import what the entry points of :attr:`group` name, once; a plugin that fails to
        load, or that names an implementation under a name taken already, is logged and left out
        (asking for its name then says why)."""
        if self._plugins_loaded:
            return
        self._plugins_loaded = True
        for point in entry_points(group=self.group):
            try:
                loaded = point.load()
            except Exception as exc:  # a broken plugin must not break nodnav
                self._broken[point.name] = f"{type(exc).__name__}: {exc}"
                log.warning("%s plugin %r (%s) failed to load: %s", self.kind, point.name, point.value, exc)
                continue
            if callable(loaded) and not isinstance(loaded, types.ModuleType):
                try:  # an implementation, registered under the entry point's name
                    self.register(point.name)(loaded)
                except RegistryError as exc:  # a name taken already: the first registration stays
                    self._broken[point.name] = str(exc)
                    log.warning("%s plugin %r (%s) not registered: %s", self.kind, point.name, point.value, exc)

    def _put(self, entry: Entry) -> None:
        if not isinstance(entry.name, str) or not _NAME.fullmatch(entry.name):
            raise RegistryError(f"{self.kind} name {entry.name!r}: use lower-case letters, digits, '-', '_' and '.' "
                                "(at most 40 characters)")
        settings = getattr(entry.params, "__dataclass_params__", None)  # how @dataclass was applied
        if entry.params is not None and not (is_dataclass(entry.params) and settings is not None and settings.frozen):
            raise RegistryError(f"{self.kind} {entry.name!r}: its parameters must be a frozen dataclass, "
                                f"got {entry.params!r}")
        self._entries[entry.name] = entry


def _first_line(obj: Any) -> str:
    doc = (getattr(obj, "__doc__", None) or "").strip()
    return doc.splitlines()[0].rstrip(".") if doc else ""


def _package(obj: Any) -> str:
    """The top-level package an object is defined in (``nodnav``)."""
    return str(getattr(obj, "__module__", "") or "").partition(".")[0]


def _where(obj: Any) -> str:
    return f"{getattr(obj, '__module__', '?')}.{getattr(obj, '__qualname__', repr(obj))}"


PLANNERS = Registry("planner", "nodnav.planners")
"""Multi-robot path planners (:class:`~nodnav.planning.base.Planner`), named by ``planner.name``."""
CONTROLLERS = Registry("controller", "nodnav.controllers")
"""Motion controllers (:class:`~nodnav.control.base.Controller`), named by ``controller.name``."""
METHODS = Registry("method", "nodnav.methods")
"""Navigation methods (:class:`~nodnav.sim.methods.Method`), named by ``nodnav run --method``."""

register_planner = PLANNERS.register
register_controller = CONTROLLERS.register
register_method = METHODS.register
