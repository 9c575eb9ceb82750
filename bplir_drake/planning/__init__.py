"""Planning: trajectory optimisation of swings, their tracking gains, the
plan caches and libraries.

* :mod:`.swing_plan` -- what a plan is (:class:`~.swing_plan.SwingPlan`, its
  target, limits and energy balance);
* :mod:`.solve` -- Drake's ``DirectCollocation`` of a swing from the line,
  from hanging or pumping, and the scenario's plan with its gains;
* :mod:`.library` -- the grids of plans and gains (shipped, or solved by
  ``bplir commission``) and a scenario's plan blended from them;
* :mod:`.cache` -- the disk cache and the shipped plans;
* :mod:`.file` -- a plan read from a CSV file;
* :mod:`.retry` -- a swing tried again from hanging;
* :mod:`.status` -- how a solve ended; :mod:`.figure` -- a plan's figure.

It plans on the nominal model only
(:func:`~bplir_drake.systems.symbolic_plant.symbolic_plant`) and sits
below :mod:`bplir_drake.diagrams`, whose swing diagram tracks its plans.
"""
