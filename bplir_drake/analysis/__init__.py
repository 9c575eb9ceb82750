"""Analysis: compute data first (functions returning result objects,
numbers and arrays), plot second (functions or ``plot`` methods that draw
that data on matplotlib axes and return the figure; saving is the caller's
job).

* :mod:`.model` -- energy, pendulum periods, linearisation, free swings,
  the friction table;
* :mod:`.estimation` -- EKF studies, observability;
* :mod:`.control` -- QFT design and verification, CPFL loop studies, zero
  dynamics;
* :mod:`.swing` -- running, comparing and planning a swing;
* :mod:`.montecarlo` -- studies (schema, sampling, store, executors,
  statistics), the benchmark;
* :mod:`.identification` -- calibration from logs;
* :mod:`.plotting` -- figure and axes helpers shared by the plots.
"""
