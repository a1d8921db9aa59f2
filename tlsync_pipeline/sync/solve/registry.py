"""The registry of sync methods' fits: name -> method (sync/solve/methods.py's SyncMethod).

A method's name, parameters and preparation are declared in
sync/model/methods.py (what every stage before the fit reads); its fit is
registered here. Adding a method: one module with the method, and one
``register`` call (below for the built-in ones).
"""

from __future__ import annotations

from tlsync_pipeline.sync.model.methods import METHODS, declare, declared
from tlsync_pipeline.sync.solve.methods import SyncMethod
from tlsync_pipeline.sync.solve.paper import PaperMethod
from tlsync_pipeline.sync.solve.refined import RefinedMethod


def register(method: SyncMethod) -> SyncMethod:
    """Add a method with its fit; ValueError when its name or one of its parameter names is taken.

    A built-in method extends its declaration (sync/model/methods.py), which it replaces; any other is declared.
    """
    known = METHODS.get(method.name)
    if known is not None and not isinstance(known, SyncMethod) and isinstance(method, type(known)):
        METHODS[method.name] = method
    else:
        declare(method)
    return method


def get_method(name: str) -> SyncMethod:
    """The registered method ``name`` with its fit; ValueError listing the names otherwise."""
    method = declared(name)
    if not isinstance(method, SyncMethod):
        raise ValueError(f"sync method {name!r} is declared without a fit (register it in sync/solve/registry.py)")
    return method


register(PaperMethod())
register(RefinedMethod())
