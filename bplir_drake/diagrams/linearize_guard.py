"""Drake's ``Linearize`` on a hybrid diagram answered in one line.

``pydrake.systems.primitives.Linearize`` (and
``FirstOrderTaylorApproximation``) stop the process (a failed
``DRAKE_DEMAND``, SIGABRT) on a context with both continuous and discrete
state, which every swing diagram has: the plant's continuous state, the
robot's computer's and the driver's ticks.  :func:`guard` replaces the two
functions in ``pydrake.systems.primitives`` (once, when this package's
diagrams are imported) with ones that raise :class:`HybridLinearizeError`
naming what to use instead, and call Drake's for every other context; a
name bound before the package was imported still calls Drake's own."""
from __future__ import annotations


class HybridLinearizeError(ValueError):
    """``Linearize`` asked of a hybrid context."""


def hybrid_reason(context) -> str | None:
    """Why Drake cannot linearise at ``context``, or None where it can: its
    own test, stateless, continuous state only, or one group of discrete
    state only."""
    n_c = context.num_continuous_states()
    n_d = context.num_discrete_state_groups()
    n_a = context.num_abstract_states()
    if n_a or (n_d and (n_c or n_d > 1)):
        return (f"{n_c} continuous states, {n_d} discrete state groups, "
                f"{n_a} abstract states")
    return None


def _guarded(original, name: str):
    def call(system, context, *args, **kwargs):
        why = hybrid_reason(context)
        if why is not None:
            raise HybridLinearizeError(
                f"{name} cannot take {system.get_name() or 'this system'}: it is hybrid ({why}); "
                "the swing's tracker loop at a frozen time is "
                "bplir_drake.analysis.model.closed_loop.linearize_closed_loop(params, t), the plant alone "
                "bplir_drake.diagrams.build_plant_with_friction(params)")
        return original(system, context, *args, **kwargs)

    call.__doc__ = original.__doc__
    call.__name__ = name
    call._bplir_guarded = original
    return call


def guard() -> None:
    """Install the guarded ``Linearize`` and ``FirstOrderTaylorApproximation``
    in ``pydrake.systems.primitives`` (once)."""
    import pydrake.systems.primitives as primitives

    for name in ("Linearize", "FirstOrderTaylorApproximation"):
        fn = getattr(primitives, name)
        if not hasattr(fn, "_bplir_guarded"):
            setattr(primitives, name, _guarded(fn, name))
