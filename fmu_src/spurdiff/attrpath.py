"""Records and their attributes: dotted attribute paths (``"mesh_forces.F_A1"``) read and written on
a model, what an FMU variable's ``bind`` names (:mod:`spurdiff.fmi.binding`) and a native step's slots
(:mod:`spurdiff.native_step`) address; and :func:`record`, the package's dataclass decorator.

:func:`record` is ``dataclasses.dataclass`` (plain or ``frozen=True``) with the same ``__repr__``,
``__eq__`` and ``__hash__`` (none for a mutable record, as dataclasses sets), and for a frozen record
the same ``__setattr__`` and ``__delattr__``, made from shared functions over the fields instead of
from source compiled for each class: compiling those methods was a third of the package's import at
an FMU's start, and a frozen record's two more were another 9 ms (docs/performance.md, start-up). The
classes are the same records otherwise (``dataclasses.fields``, ``replace``, ``__init__``, frozen
assignment refused: tests/physics/test_records.py). A frozen record's ``__init__`` is the one
dataclasses makes for a mutable class (``self.a = a``), which its ``__setattr__`` lets through by its
frame: a field assigned through ``__setattr__`` costs about 0.4 us more than dataclasses' direct
``object.__setattr__`` (one MeshForces per Python step: 2-3 us of a 55-90 us step)."""
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
        cls = dataclasses.dataclass(cls, repr=False, eq=False, frozen=frozen and not shared)
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
