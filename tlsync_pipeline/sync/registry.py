"""The registry of sync methods: name -> method (sync/methods.py's SyncMethod).

The project file's ``[sync] method`` choices and the method parameters'
keys come from here. Adding a method: one module with the method, and one
``register`` call (below for the built-in ones).
"""

from __future__ import annotations

from dataclasses import asdict, fields
from typing import Any

from tlsync_pipeline.sync.methods import SyncMethod
from tlsync_pipeline.sync.paper import PaperMethod
from tlsync_pipeline.sync.params import Preparation, SyncParams, parameter_fields
from tlsync_pipeline.sync.refined import RefinedMethod

METHODS: dict[str, SyncMethod] = {}


def register(method: SyncMethod) -> SyncMethod:
    """Add a method; ValueError when its name or one of its parameter names is taken."""
    if method.name in METHODS:
        raise ValueError(f"a sync method named {method.name!r} is already registered")
    taken = set(parameter_fields(SyncParams)) | {"method"}
    for other in METHODS.values():
        taken |= set(parameter_fields(other.params_type))
    clash = taken & set(parameter_fields(method.params_type))
    if clash:
        raise ValueError(f"sync method {method.name!r}: parameter(s) {', '.join(sorted(clash))} already used by another method or shared")
    METHODS[method.name] = method
    return method


def get_method(name: str) -> SyncMethod:
    """The registered method ``name``; ValueError listing the names otherwise."""
    if name not in METHODS:
        raise ValueError(f"unknown sync method {name!r}; methods: {', '.join(METHODS)}")
    return METHODS[name]


def method_options(params: SyncParams) -> Any:
    """The chosen method's own parameters: those given in ``params.options``, else its defaults."""
    method = get_method(params.method)
    return params.options.get(method.name) or method.params_type()


def params_table(params: SyncParams) -> dict[str, Any]:
    """The flat ``[sync]`` table of ``params``: shared keys, method, every registered method's keys (timeline.json, cache keys)."""
    table = {f.name: getattr(params, f.name) for f in fields(SyncParams) if f.name != "options"}
    for name, method in METHODS.items():
        table.update(asdict(params.options.get(name) or method.params_type()))
    return table


def preparation_of(params: SyncParams) -> Preparation:
    """What preparing the trajectory reads of ``params``: the method, its preparation options, logged_point_above_m."""
    method = get_method(params.method)
    return Preparation(method.name, method.preparation(method_options(params)), params.logged_point_above_m)


def params_from_table(table: dict[str, Any]) -> SyncParams:
    """SyncParams from a flat ``[sync]`` table (keys left out take their defaults)."""
    shared = {k: table[k] for k in list(parameter_fields(SyncParams)) + ["method"] if k in table}
    options = {}
    for name, method in METHODS.items():
        own = {k: table[k] for k in parameter_fields(method.params_type) if k in table}
        options[name] = method.params_type(**own)
    return SyncParams(**shared, options=options)


register(PaperMethod())
register(RefinedMethod())
