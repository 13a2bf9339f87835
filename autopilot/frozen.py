"""``@message``: the project's immutable records (``@dataclass(frozen=True, slots=True)``)
with a cheaper constructor.

Why: a frozen dataclass's generated ``__init__`` stores each field through
``object.__setattr__(self, "name", value)`` (a name lookup through the class per field),
about 0.2 us a field; the loop builds a dozen such records per step (PlantState,
SensorReadings, SensorFrame, NavState, ...). Here ``__init__`` stores each field through
its slot's own descriptor, bound once in a closure: the same object, the same
immutability (``__setattr__`` still raises ``FrozenInstanceError``), the same signature
(names, order, defaults, default factories); about a third cheaper.
"""
from __future__ import annotations

import dataclasses
from dataclasses import MISSING


def message(cls=None, /):
    """Class decorator: ``@dataclass(frozen=True, slots=True)`` with the fast ``__init__``
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
    ns: dict = {"_FACTORY": object()}
    params, body = [], []
    for f in fs:
        name = f.name
        ns[f"_set_{name}"] = cls.__dict__[name].__set__      # the slot's member descriptor
        if f.default is not MISSING:
            ns[f"_d_{name}"] = f.default
            params.append(f"{name}=_d_{name}")
        elif f.default_factory is not MISSING:
            ns[f"_f_{name}"] = f.default_factory
            params.append(f"{name}=_FACTORY")
            body.append(f"    if {name} is _FACTORY:\n        {name} = _f_{name}()\n")
        else:
            params.append(name)
        body.append(f"    _set_{name}(self, {name})\n")
    # a closure over the setters (LOAD_DEREF: as cheap as a local), so that the
    # signature is the dataclass's own
    setters = [f"_set_{f.name}" for f in fs]
    src = (f"def _make({', '.join(setters)}):\n"
           f"  def __init__(self, {', '.join(params)}):\n"
           + "".join("  " + line for line in "".join(body).splitlines(keepends=True))
           + "  return __init__\n")
    exec(src, ns)
    init = ns["_make"](*(ns[k] for k in setters))
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__doc__ = cls.__init__.__doc__
    cls.__init__ = init
    return cls
