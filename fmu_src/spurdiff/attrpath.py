"""Records and their attributes: dotted attribute paths (``"mesh_forces.F_A1"``) read and written on
a model, what an FMU variable's ``bind`` names (:mod:`spurdiff.fmi.binding`) and a native step's slots
(:mod:`spurdiff.native_step`) address; and :func:`record`, the package's dataclass decorator.

:func:`record` is ``dataclasses.dataclass`` (plain or ``frozen=True``) with the same ``__repr__``,
``__eq__`` and ``__hash__`` (none for a mutable record, as dataclasses sets), and for a frozen record
the same ``__setattr__`` and ``__delattr__``, made from shared functions over the fields instead of
from source compiled for each class: compiling those methods was a third of the package's import at
an FMU's start, and a frozen record's two more were another 9 ms (docs/performance.md, start-up). The
classes are the same records otherwise (``dataclasses.fields``, ``replace``, frozen assignment refused:
tests/physics/test_records.py). The ``__init__`` too is shared (:func:`_init`: the same binding of
arguments, defaults, factories, ``__post_init__``, signature and TypeErrors as dataclasses' compiled
one; a frozen record's sets its fields by ``object.__setattr__``, as dataclasses' does), except for a
record with its own ``__init__``, an ``InitVar`` or a keyword-only field: the 41 records the FMU's start
makes compiled one each, about 4 ms of its import (tests/physics/test_records.py compares every call
shape). A frozen record's ``__setattr__`` still lets a dataclasses-made ``__init__`` of the class assign
by its frame (a frozen record with its own ``__init__`` keeps dataclasses' path)."""
from __future__ import annotations

import dataclasses
import operator
import sys
from typing import Any


def resolve(obj: Any, path: str) -> Any:
    """The value at the dotted attribute ``path`` of ``obj``."""
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def assign(obj: Any, path: str, value: Any) -> None:
    """Set the dotted attribute ``path`` of ``obj`` to ``value``."""
    head, _, last = path.rpartition(".")
    setattr(resolve(obj, head) if head else obj, last, value)


def _values(names: list[str]):
    """A function of an object returning the tuple of its attributes ``names`` (as ``(o.a, o.b,)``)."""
    if len(names) >= 2:
        return operator.attrgetter(*names)
    if len(names) == 1:
        name = names[0]
        return lambda o: (getattr(o, name),)
    return lambda o: ()


def _methods(cls: type) -> dict:
    """``__repr__``, ``__eq__`` and ``__hash__`` of the dataclass ``cls`` as dataclasses writes them:
    the repr of the fields with ``repr``, ``...`` for a recursive call; equal when of the same class
    and the tuples of the fields with ``compare`` are (3.13: the same object, or each field equal in
    turn); the hash of the tuple of the fields with ``hash``, or ``compare`` where that is None."""
    fields = dataclasses.fields(cls)
    shown = [f.name for f in fields if f.repr]
    compared = _values([f.name for f in fields if f.compare])
    hashed = _values([f.name for f in fields if (f.compare if f.hash is None else f.hash)])
    running = set()
    from _thread import get_ident

    def __repr__(self):
        key = id(self), get_ident()
        if key in running:
            return "..."
        running.add(key)
        try:
            return (self.__class__.__qualname__ + "("
                    + ", ".join([f"{name}={getattr(self, name)!r}" for name in shown]) + ")")
        finally:
            running.discard(key)

    if sys.version_info < (3, 13):
        def __eq__(self, other):
            if other.__class__ is self.__class__:
                return compared(self) == compared(other)
            return NotImplemented
    else:                    # 3.13: the same object equal, then field by field (``a == b and ...``)
        names = [f.name for f in fields if f.compare]

        def __eq__(self, other):
            if self is other:
                return True
            if other.__class__ is self.__class__:
                result = True
                for name in names:
                    result = getattr(self, name) == getattr(other, name)
                    if not result:
                        return result
                return result
            return NotImplemented

    def __hash__(self):
        return hash(hashed(self))

    out = {"__repr__": __repr__, "__eq__": __eq__, "__hash__": __hash__}
    for name, fn in out.items():
        fn.__qualname__ = f"{cls.__qualname__}.{name}"
    return out


def _frozen_methods(cls: type) -> dict:
    """``__setattr__`` and ``__delattr__`` of the frozen dataclass ``cls`` as dataclasses writes them
    (assigning or deleting a field, or any attribute of an instance of ``cls`` itself, raises
    FrozenInstanceError), but letting ``cls``'s own ``__init__`` (made by dataclasses for a mutable
    class: ``self.a = a``) assign: the frame that assigns is that ``__init__``'s."""
    fields = frozenset(f.name for f in dataclasses.fields(cls))
    init = cls.__init__.__code__
    frame = sys._getframe
    # object's own, when no class after cls defines one (dataclasses' super(cls, self) finds it then)
    plain = not any("__setattr__" in b.__dict__ for b in cls.__mro__[1:-1])
    object_setattr = object.__setattr__

    def __setattr__(self, name, value):
        if frame(1).f_code is not init and (type(self) is cls or name in fields):
            raise dataclasses.FrozenInstanceError(f"cannot assign to field {name!r}")
        if plain:
            object_setattr(self, name, value)
        else:
            super(cls, self).__setattr__(name, value)

    def __delattr__(self, name):
        if type(self) is cls or name in fields:
            raise dataclasses.FrozenInstanceError(f"cannot delete field {name!r}")
        super(cls, self).__delattr__(name)

    out = {"__setattr__": __setattr__, "__delattr__": __delattr__}
    for name, fn in out.items():
        fn.__qualname__ = f"{cls.__qualname__}.{name}"
    return out


_UNSET = object()     # an argument the call did not give


def _plain_init(cls: type) -> bool:
    """Whether :func:`_init` can stand for dataclasses' ``__init__`` of ``cls`` (before it is processed):
    no ``__init__`` of its own, no ``InitVar`` and no keyword-only field (dataclasses' own then)."""
    if "__init__" in cls.__dict__:
        return False
    for klass in cls.__mro__[:-1]:
        notes = klass.__dict__.get("__annotations__", {})
        if any("InitVar" in str(a) or "KW_ONLY" in str(a) for a in notes.values()):
            return False
        if any(isinstance(v, dataclasses.Field) and v.kw_only is True for v in klass.__dict__.values()):
            return False
    return True


def _init(cls: type, frozen: bool):
    """``__init__`` of the dataclass ``cls`` as dataclasses writes it, without compiling one: the fields
    with ``init`` as parameters in their order (positional or keyword; a default or a default factory
    where the field has one), those without ``init`` set to their default (factory), each in field order,
    by ``object.__setattr__`` for a frozen record (dataclasses' way) or by assignment, then
    ``__post_init__`` if the class has one; the same TypeErrors for a missing, an unexpected or a
    repeated argument and for too many."""
    MISSING = dataclasses.MISSING
    fields = dataclasses.fields(cls)
    names = tuple(f.name for f in fields if f.init)
    n = len(names)
    index = {name: i for i, name in enumerate(names)}
    defaults = tuple((f.default, f.default_factory) for f in fields if f.init)
    # the fields in order: (the argument's index, or -1 and the default of a field without init)
    plan = []
    for f in fields:
        if f.init:
            plan.append((f.name, index[f.name], MISSING, MISSING))
        elif f.default is not MISSING or f.default_factory is not MISSING:
            plan.append((f.name, -1, f.default, f.default_factory))
    plan = tuple(plan)
    post = hasattr(cls, "__post_init__")
    qual = f"{cls.__qualname__}.__init__()"
    put = object.__setattr__ if frozen else setattr

    n_defaults = sum(1 for d, f in defaults if d is not MISSING or f is not MISSING)
    takes = (f"from {n + 1 - n_defaults} to {n + 1} positional arguments" if n_defaults
             else f"{n + 1} positional argument{'s' * (n > 0)}")

    def __init__(self, *args, **kwargs):
        # (in the interpreter's order: the keywords, then too many positional arguments, then the missing)
        given = len(args)
        values = list(args)
        if kwargs or given != n:
            values += [_UNSET] * (n - given)
            for key, value in kwargs.items():
                i = index.get(key)
                if i is None:
                    raise TypeError(f"{qual} got an unexpected keyword argument {key!r}")
                if values[i] is not _UNSET:
                    raise TypeError(f"{qual} got multiple values for argument {key!r}")
                values[i] = value
            if given > n:
                raise TypeError(f"{qual} takes {takes} but {given + 1} were given")
            missing = []
            for i, value in enumerate(values):
                if value is _UNSET:
                    default, factory = defaults[i]
                    if default is not MISSING:
                        values[i] = default
                    elif factory is not MISSING:
                        values[i] = factory()
                    else:
                        missing.append(repr(names[i]))
            if missing:
                k = len(missing)
                listed = (missing[0] if k == 1 else " and ".join(missing) if k == 2
                          else ", ".join(missing[:-1]) + ", and " + missing[-1])
                raise TypeError(f"{qual} missing {k} required positional argument{'s' * (k > 1)}: {listed}")
        for name, i, default, factory in plan:
            put(self, name, values[i] if i >= 0 else (factory() if factory is not MISSING else default))
        if post:
            self.__post_init__()

    __init__.__qualname__ = f"{cls.__qualname__}.__init__"
    __init__.__signature__ = _signature(fields)
    return __init__


class _Factory:
    def __repr__(self):
        return "<factory>"


_FACTORY = getattr(dataclasses, "_HAS_DEFAULT_FACTORY", _Factory())   # what dataclasses' signature shows


def _signature(fields):
    """The signature dataclasses' ``__init__`` has (``inspect.signature`` of the class shows it)."""
    import inspect      # (loaded: dataclasses imports it)

    P = inspect.Parameter
    params = [P("self", P.POSITIONAL_OR_KEYWORD)]
    for f in fields:
        if f.init:
            default = (f.default if f.default is not dataclasses.MISSING
                       else _FACTORY if f.default_factory is not dataclasses.MISSING else P.empty)
            params.append(P(f.name, P.POSITIONAL_OR_KEYWORD, default=default, annotation=f.type))
    return inspect.Signature(params, return_annotation=None)


def _class_signature(cls: type):
    """``inspect.signature(cls)``: its ``__init__``'s without ``self``."""
    sig = cls.__init__.__signature__
    return sig.replace(parameters=list(sig.parameters.values())[1:])


def _frozen_base(cls: type) -> bool:
    """Whether a base of ``cls`` is a frozen dataclass (dataclasses refuses a mutable subclass of one)."""
    return any(getattr(b, "__dataclass_params__", None) is not None and b.__dataclass_params__.frozen
               for b in cls.__mro__[1:])


def record(cls: type | None = None, /, *, frozen: bool = False):
    """``@record`` / ``@record(frozen=True)``: ``@dataclass`` / ``@dataclass(frozen=True)`` with the
    same methods (a method the class defines itself is kept, as dataclasses does), the repr, the
    equality, the hash and a frozen record's ``__setattr__``/``__delattr__`` not compiled per class
    (see the module)."""
    def wrap(cls: type) -> type:
        own = cls.__dict__
        class_hash = own.get("__hash__", dataclasses.MISSING)
        explicit_hash = not (class_hash is dataclasses.MISSING or (class_hash is None and "__eq__" in own))
        keep = {name for name in ("__repr__", "__eq__") if name in own}
        # dataclasses' own frozen record where the shared functions would not be its: a frozen base (a
        # frozen subclass is made by dataclasses alone), the class's own __init__ (whose assignments the
        # frame would let through), __setattr__ or __delattr__ (dataclasses refuses those)
        shared = (frozen and not _frozen_base(cls)
                  and not {"__init__", "__setattr__", "__delattr__"} & own.keys())
        plain = (shared or not frozen) and _plain_init(cls)     # our __init__, not one compiled for the class
        # a class without a docstring: dataclasses writes its name and its __init__'s signature, which
        # with our __init__ is set below (dataclasses would read the inherited one's, by parsing its text)
        undocumented = plain and not cls.__doc__
        if undocumented:
            cls.__doc__ = cls.__name__
        cls = dataclasses.dataclass(cls, init=not plain, repr=False, eq=False, frozen=frozen and not shared)
        if plain:
            cls.__init__ = _init(cls, frozen)
        if undocumented:
            cls.__doc__ = cls.__name__ + str(_class_signature(cls)).replace(" -> None", "")
        if shared:
            for name, fn in _frozen_methods(cls).items():
                setattr(cls, name, fn)
            # the record is frozen: its parameters say so, as dataclasses(frozen=True) would have (read by
            # dataclasses for a subclass, and by spurdiff.fmi.binding to replace rather than assign)
            cls.__dataclass_params__.frozen = True
        methods = _methods(cls)
        for name in ("__repr__", "__eq__"):
            if name not in keep:
                setattr(cls, name, methods[name])
        if not explicit_hash:          # dataclasses: eq and frozen, a hash of the fields; eq only, unhashable
            cls.__hash__ = methods["__hash__"] if frozen else None
        return cls
    return wrap if cls is None else wrap(cls)


__all__ = ["resolve", "assign", "record"]
