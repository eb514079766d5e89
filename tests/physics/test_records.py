"""spurdiff.attrpath.record is dataclasses.dataclass (plain and frozen) with the repr, equality and hash
made from shared functions (issue 44: compiling them per class was a third of the FMU's import): the
same class body under both decorators behaves the same in everything the package uses."""
from __future__ import annotations

import copy
import dataclasses
import math
import pickle

import pytest

from spurdiff.attrpath import record
from spurdiff.errors import Bound
from spurdiff.gears.geometry import GearTable

BODY = '''
from __future__ import annotations
from dataclasses import field

@deco
class Plain:
    """A mutable record."""
    a: float
    b: float = 1.0
    tags: list = field(default_factory=list)
    hidden: float = field(default=0.0, repr=False)
    ignored: float = field(default=0.0, compare=False)

@deco_frozen
class Frozen:
    """A frozen record."""
    a: float
    b: float | None = None
    not_hashed: float = field(default=0.0, hash=False)
    skipped: float = field(default=0.0, compare=False)

@deco_frozen
class One:
    x: float

@deco_frozen
class Empty:
    pass

@deco_frozen
class OwnEq:
    """A frozen record with its own equality (no hash of its own: the fields' then, as dataclasses)."""
    a: float
    def __eq__(self, other):
        return isinstance(other, OwnEq) and abs(self.a - other.a) < 1.0

@deco_frozen
class OwnHash:
    a: float
    def __hash__(self):
        return 7

@deco
class Child(Plain):
    c: int = 3

class Sub(Frozen):
    """A plain subclass: the parent's methods."""

@deco
class Node:
    value: float
    nxt: object = None

@deco_frozen
class FrozenPost:
    """A frozen record whose __post_init__ derives a field: through object.__setattr__ only."""
    a: float
    twice: float = field(init=False, default=0.0)
    def __post_init__(self):
        object.__setattr__(self, "twice", 2.0 * self.a)

@deco_frozen
class FrozenBadPost:
    a: float
    def __post_init__(self):
        self.a = 3.0

@deco_frozen
class FrozenFactory:
    a: float
    tags: tuple = field(default_factory=tuple)
    hidden: list = field(init=False, default_factory=list)

class SubInit(Frozen):
    """A plain subclass with its own __init__ calling the record's."""
    def __init__(self, a):
        super().__init__(a, 2.0)
        object.__setattr__(self, "extra", 1)

@deco_frozen
class FrozenOwnInit:
    """A frozen record with its own __init__: assigning through self there is refused, as dataclasses does."""
    a: float
    def __init__(self, a):
        self.a = a

@deco_frozen
class FrozenChild(Frozen):
    """A frozen record inheriting from a frozen record."""
    c: float = 0.0

@deco
class PlainPost:
    """A mutable record with a field without init (a factory) and a __post_init__ that reads them."""
    a: float
    b: float = 2.0
    log: list = field(init=False, default_factory=list)
    def __post_init__(self):
        self.log.append(self.a + self.b)

@deco
class Counting:
    """A mutable record with its own __setattr__: the __init__ assigns through it, as dataclasses' does."""
    a: float
    b: float = 0.0
    def __setattr__(self, name, value):
        object.__setattr__(self, "seen", getattr(self, "seen", ()) + (name,))
        object.__setattr__(self, name, value)
'''


def _classes(deco, deco_frozen) -> dict:
    ns = {"deco": deco, "deco_frozen": deco_frozen, "__name__": f"records_{id(deco)}"}
    import sys
    import types
    mod = types.ModuleType(ns["__name__"])
    sys.modules[mod.__name__] = mod
    try:
        mod.__dict__.update(ns)
        exec(BODY, mod.__dict__)
    finally:
        del sys.modules[mod.__name__]
    return mod.__dict__


DC = _classes(dataclasses.dataclass, dataclasses.dataclass(frozen=True))
REC = _classes(record, record(frozen=True))


def _both(name, *args, **kwargs):
    return DC[name](*args, **kwargs), REC[name](*args, **kwargs)


def _same_repr(x, y):
    assert repr(x) == repr(y).replace(type(y).__module__, type(x).__module__)


@pytest.mark.parametrize("name,args,kwargs", [
    ("Plain", (1.5,), {}), ("Plain", (1.5, 2.0, [1, 2]), {"hidden": 3.0, "ignored": 4.0}),
    ("Frozen", (1.0,), {"b": None}), ("Frozen", (math.nan, 2.0), {"not_hashed": 5.0}),
    ("One", (2.5,), {}), ("Empty", (), {}), ("OwnEq", (1.0,), {}), ("OwnHash", (1.0,), {}),
    ("Child", (1.0,), {"c": 4}), ("Sub", (1.0,), {}), ("Node", (1.0,), {})])
def test_the_methods_are_the_dataclasses(name, args, kwargs):
    d, r = _both(name, *args, **kwargs)
    d2, r2 = _both(name, *args, **kwargs)
    _same_repr(d, r)
    assert (d == d2) == (r == r2)
    assert (d != d2) == (r != r2)
    assert (d == "other") == (r == "other")
    assert (DC[name].__hash__ is None) == (REC[name].__hash__ is None)
    if DC[name].__hash__ is not None:
        assert hash(d) == hash(r) and hash(d2) == hash(r2)
    else:
        with pytest.raises(TypeError):
            hash(r)
    assert [f.name for f in dataclasses.fields(d)] == [f.name for f in dataclasses.fields(r)]
    assert dataclasses.is_dataclass(r) and r.__match_args__ == d.__match_args__
    assert DC[name].__dataclass_params__.frozen == REC[name].__dataclass_params__.frozen
    if dataclasses.fields(d):
        first = dataclasses.fields(d)[0].name
        _same_repr(dataclasses.replace(d, **{first: 9.0}), dataclasses.replace(r, **{first: 9.0}))
    assert dataclasses.asdict(d) == dataclasses.asdict(r)
    _same_repr(copy.deepcopy(d), copy.deepcopy(r))


def test_equality_compares_the_compared_fields_of_the_same_class():
    d, r = _both("Plain", 1.0, ignored=1.0)
    d2, r2 = _both("Plain", 1.0, ignored=2.0)
    assert d == d2 and r == r2
    d3, r3 = _both("Plain", 1.0, hidden=2.0)
    assert d != d3 and r != r3
    nan = math.nan      # the same object: as dataclasses of this Python (3.11, 3.12: equal through the
    # tuple's identity check; 3.13: each field compared with ==)
    assert (REC["One"](nan) == REC["One"](nan)) == (DC["One"](nan) == DC["One"](nan))
    assert (REC["One"](float("nan")) != REC["One"](float("nan"))) == (DC["One"](float("nan")) != DC["One"](float("nan")))
    r, d = REC["One"](float("nan")), DC["One"](float("nan"))
    assert (r == r) == (d == d)
    assert REC["Sub"](1.0) != REC["Frozen"](1.0) and DC["Sub"](1.0) != DC["Frozen"](1.0)
    assert REC["OwnEq"](1.0) == REC["OwnEq"](1.5) and hash(REC["OwnHash"](1.0)) == 7


def test_frozen_records_refuse_assignment_and_deletion():
    for ns in (DC, REC):
        f = ns["Frozen"](1.0)
        with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'a'"):
            f.a = 2.0
        with pytest.raises(dataclasses.FrozenInstanceError):
            del f.a
    p = REC["Plain"](1.0)
    p.a = 2.0
    assert p.a == 2.0


@pytest.mark.parametrize("name,args", [("FrozenPost", (1.5,)), ("FrozenFactory", (1.0, (1, 2))),
                                       ("SubInit", (1.0,)), ("FrozenChild", (1.0, 2.0))])
def test_frozen_records_are_made_and_refused_as_dataclasses_does(name, args):
    """What a frozen record's __init__ may assign (its fields, defaults, factories, a __post_init__
    through object.__setattr__, a subclass's own __init__ through the record's) and what nobody may
    afterwards, as dataclasses(frozen=True): the same values, the same errors."""
    d, r = _both(name, *args)
    assert vars(d) == vars(r)
    _same_repr(d, r)
    for obj in (d, r):
        for attr in ("a", "new_attribute"):
            try:
                setattr(obj, attr, 5.0)
                outcome = "set"
            except dataclasses.FrozenInstanceError as e:
                outcome = str(e)
            assert outcome == ("set" if type(obj).__name__ == "SubInit" and attr == "new_attribute"
                               else f"cannot assign to field {attr!r}"), (obj, attr)
        with pytest.raises(dataclasses.FrozenInstanceError):
            del obj.a
    assert vars(d) == vars(r)


@pytest.mark.parametrize("name", ["FrozenBadPost", "FrozenOwnInit"])
def test_a_frozen_records_post_init_or_own_init_cannot_assign_through_self(name):
    for ns in (DC, REC):
        with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'a'"):
            ns[name](1.0)


def test_frozen_records_compile_no_setattr_of_their_own():
    """The frozen records' __setattr__ and __delattr__ are shared functions (no source compiled per
    class: about 9 ms of an FMU's Python start, docs/performance.md), made once per record."""
    import spurdiff.attrpath as attrpath
    for name in ("Frozen", "One", "FrozenPost", "FrozenFactory"):
        cls = REC[name]
        assert cls.__setattr__.__code__.co_filename == attrpath.__file__, name
        assert cls.__delattr__.__code__.co_filename == attrpath.__file__, name
        assert cls.__setattr__.__qualname__ == f"{name}.__setattr__"
        assert DC[name].__setattr__.__code__.co_filename != attrpath.__file__


def test_a_recursive_repr_and_the_signature():
    import inspect
    d, r = _both("Node", 1.0)
    d.nxt, r.nxt = d, r
    _same_repr(d, r)
    assert "nxt=..." in repr(r)
    assert str(inspect.signature(REC["Plain"])) == str(inspect.signature(DC["Plain"]))
    assert REC["Plain"].__doc__ == DC["Plain"].__doc__ == "A mutable record."
    for name in ("One", "Empty", "OwnHash", "Node", "FrozenBadPost", "FrozenFactory"):   # without a docstring:
        assert REC[name].__doc__ == DC[name].__doc__, name          # dataclasses' (its name and signature)
    with pytest.raises(TypeError, match="missing 1 required positional argument: 'a'"):
        REC["Plain"]()


def test_package_records_keep_their_behaviour():
    """Records of the package as before: hashable frozen parameters, equal copies, pickling."""
    b = Bound(0.0, 1.0)
    assert b == Bound(0.0, 1.0) and hash(b) == hash(Bound(0.0, 1.0)) and b != Bound(0.0, 2.0)
    assert repr(b) == ("Bound(lo=0.0, hi=1.0, lo_open=False, hi_open=False, allowed=None, integer=False, "
                       "hint=None)")
    t = GearTable()
    assert pickle.loads(pickle.dumps(t)) == t and hash(copy.deepcopy(t)) == hash(t)


CALLS = [((1.0,), {}), ((1.0, 3.0), {}), ((), {"a": 1.0}), ((), {"b": 3.0, "a": 1.0}), ((1.0,), {"b": 3.0}),
         ((), {}), ((1.0, 2.0, [3]), {}), ((1.0,), {"a": 2.0}), ((1.0,), {"z": 2.0}), ((), {"b": 1.0}),
         ((1.0, 2.0, [], 0.0, 0.0, 9.0), {}), ((1.0, 2.0, None, 0.0, 0.0), {}), ((), {"tags": [1], "a": 0.5})]


@pytest.mark.parametrize("name", ["Plain", "Frozen", "One", "Empty", "PlainPost", "Counting", "FrozenPost",
                                  "FrozenFactory", "Child", "Node"])
@pytest.mark.parametrize("args,kwargs", CALLS)
def test_the_shared_init_binds_and_refuses_as_dataclasses_does(name, args, kwargs):
    """Every call shape (positional, keyword, defaults, factories, too many, missing, unexpected,
    repeated): the same fields, the same __post_init__ effects, the same assignments through an own
    __setattr__, or a TypeError with the same message; and no __init__ compiled for the class."""
    outcomes = []
    for classes in (DC, REC):
        try:
            obj = classes[name](*args, **copy.deepcopy(kwargs))
        except TypeError as e:
            outcomes.append(("TypeError", str(e)))
        else:
            outcomes.append(({f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)},
                             getattr(obj, "seen", None)))
    dc, rec = outcomes
    assert rec == dc
    assert REC[name].__init__.__code__ is REC["Plain"].__init__.__code__      # one shared, none compiled
    assert DC[name].__init__.__code__.co_filename == "<string>" != REC[name].__init__.__code__.co_filename


def test_the_shared_init_defaults_are_fresh_per_instance_and_the_signature_shows_them():
    import inspect

    x, y = REC["Plain"](1.0), REC["Plain"](1.0)
    assert x.tags == [] and x.tags is not y.tags                     # a factory's value per instance
    assert REC["PlainPost"](1.0).log == [3.0] and REC["PlainPost"](1.0).log is not REC["PlainPost"](1.0).log
    for name in ("Plain", "Frozen", "PlainPost", "FrozenFactory", "Child"):
        assert str(inspect.signature(REC[name])) == str(inspect.signature(DC[name])), name
    assert REC["FrozenOwnInit"].__init__ is not REC["Frozen"].__init__      # its own, kept
