"""The package's speed over commits (asv): ``asv run --python=same --quick``
in a checkout (docs/benchmarks.md)."""
