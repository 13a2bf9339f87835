"""``@message``: the project's immutable records (``@dataclass(frozen=True, slots=True)``)
with a cheaper constructor.

Why: a frozen dataclass's generated ``__init__`` stores each field through
``object.__setattr__(self, "name", value)`` (a name lookup through the class per field),
about 0.2 us a field; the loop builds a dozen such records per step (PlantState,
SensorReadings, SensorFrame, NavState, ...). A plain slot store (``self.x = x``) is
several times cheaper, but the interpreter's fast path for it needs the class's own
``__setattr__``, which a frozen class replaces by one that raises. So each record class
has a mutable twin: a sibling class with the same slots and nothing else. The record's
``__new__`` (a factory: the class has no ``__init__`` of its own) makes a twin, stores
the fields with plain slot stores and turns it into the record (one ``__class__``
assignment): the same immutability (``__setattr__`` still raises
``FrozenInstanceError``), the same signature (names, order, defaults, default
factories); for a record of 8 fields, 3.9 k instructions against the 5.0 k of an
``__init__`` that turned the new record into its twin and back. ``copy`` and ``pickle`` rebuild a record through its constructor
(``__reduce__``). A record class cannot be subclassed (the twin's layout is its own).

``Record.make(...)`` is the same constructor (the same generated body) as a plain
function: a class call first goes through ``type.__call__`` and the ``__new__`` slot,
about 1 k instructions of a record's 3-4 k; the link's per-step builders use it.
"""
from __future__ import annotations

import dataclasses
from dataclasses import MISSING


def message(cls=None, /):
    """Class decorator: ``@dataclass(frozen=True, slots=True)`` with the fast constructor
    (module docstring). Records with ``__post_init__``, ``InitVar`` or ``init=False``
    fields are refused (the fast constructor does not run them)."""
    if cls is None:
        return message
    cls = dataclasses.dataclass(frozen=True, slots=True)(cls)
    if hasattr(cls, "__post_init__"):
        raise TypeError(f"{cls.__name__}: @message does not run __post_init__")
    fs = dataclasses.fields(cls)
    if any(not f.init for f in fs):
        raise TypeError(f"{cls.__name__}: @message needs every field in __init__")
    if any(f.name == "make" for f in fs):
        raise TypeError(f"{cls.__name__}: 'make' is the record's constructor, not a field name")
    ns: dict = {"_FACTORY": object(), "_CLS": cls,
                "_MUT": type(f"{cls.__name__}_mutable", cls.__bases__,
                             {"__slots__": cls.__slots__, "__module__": cls.__module__})}
    params, factories, stores = [], [], []
    for f in fs:
        name = f.name
        if f.default is not MISSING:
            ns[f"_d_{name}"] = f.default
            params.append(f"{name}=_d_{name}")
        elif f.default_factory is not MISSING:
            ns[f"_f_{name}"] = f.default_factory
            params.append(f"{name}=_FACTORY")
            factories.append(f"    if {name} is _FACTORY:\n        {name} = _f_{name}()\n")
        else:
            params.append(name)
        stores.append(f"    self.{name} = {name}\n")
    # the default factories run first: nothing can raise while the object is the twin
    body = ("".join(factories)
            + "    self = _MUT()\n"
            + "".join(stores)
            + "    self.__class__ = _CLS\n"
            + "    return self\n")
    signature = ", ".join(params)
    src = (f"def __new__(cls, {signature}):\n{body}"
           f"def make({signature}):\n{body}"
           "def __reduce__(self):\n"
           f"    return _CLS, ({''.join(f'self.{f.name}, ' for f in fs)})\n")
    exec(src, ns)
    for name in ("__new__", "make", "__reduce__"):
        ns[name].__qualname__ = f"{cls.__qualname__}.{name}"
    cls.__new__ = staticmethod(ns["__new__"])
    cls.make = staticmethod(ns["make"])
    cls.__reduce__ = ns["__reduce__"]
    del cls.__init__        # object's, which lets the arguments through to __new__
    cls.__init_subclass__ = classmethod(_no_subclass)
    return cls


def _no_subclass(cls, **kwargs):
    raise TypeError(f"{cls.__name__}: a @message record cannot be subclassed")
