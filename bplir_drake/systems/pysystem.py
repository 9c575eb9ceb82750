"""The base of the package's Python systems: callbacks that do not make the
system immortal.

pydrake (1.51) keeps a Python system alive for as long as a callback that
C++ holds (an output port's or a cache entry's calc) references it, and the
system holds C++ alive in turn: a cycle through C++ that Python's
collector cannot see, so every diagram built with such a system stays in
memory (about 3 MB a swing diagram).  :func:`weak_callback` gives C++ only
a function that finds the callback through a weak reference to the system
(:class:`PySystem` does it for every output port it declares), and
:func:`release_system` drops a system's references once its diagram is
discarded (:meth:`~bplir_drake.diagrams.parts.Built.release`)."""
from __future__ import annotations

import contextlib
import inspect
import sys
import weakref

from pydrake.systems.framework import LeafSystem


def weak_callback(system, fn):
    """``fn`` as C++ may hold it: a function that calls ``fn`` through a
    weak reference to ``system``, which keeps ``fn``."""
    store = system.__dict__.setdefault("_callbacks", [])
    store.append(fn)
    index, ref = len(store) - 1, weakref.ref(system)

    def call(*args):
        return ref()._callbacks[index](*args)

    return call


def release_system(system) -> None:
    """Drop every reference a system of this package holds (ports,
    callbacks, parameters): it will not run again.  The package's systems
    it holds as parts, outside any diagram (the onboard computer's), are
    released with it.  Other systems are left alone."""
    if not type(system).__module__.startswith("bplir_drake."):
        return
    for part in list(system.__dict__.values()):
        if isinstance(part, LeafSystem) and part is not system:
            release_system(part)
    system.__dict__.clear()


class PySystem(LeafSystem):
    """A ``LeafSystem`` whose output ports' calcs are held by the system,
    not by C++ (:func:`weak_callback`)."""

    def DeclareVectorOutputPort(self, name, size, calc, *args, **kwargs):
        """``LeafSystem.DeclareVectorOutputPort`` with ``calc`` held weakly."""
        return super().DeclareVectorOutputPort(name, size, weak_callback(self, calc),
                                               *args, **kwargs)


@contextlib.contextmanager
def quick_template_scopes():
    """While active, pydrake's ``TemplateSystem`` names the module of a new
    system class's ``ToScalarType`` methods from the calling frame itself:
    pydrake (1.51) finds that frame with ``inspect.stack()``, which reads the
    source of every frame of the call stack (about 30 ms a call during an
    import, two calls a class).  The same frame, the same module."""
    from pydrake.common import cpp_template

    slow = getattr(cpp_template, "_get_module_from_stack", None)
    if slow is None:   # another pydrake: leave it alone
        yield
        return

    def from_frame(frame=2):
        return inspect.getmodule(sys._getframe(frame))

    cpp_template._get_module_from_stack = from_frame
    try:
        yield
    finally:
        cpp_template._get_module_from_stack = slow
