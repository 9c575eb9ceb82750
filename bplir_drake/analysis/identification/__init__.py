"""Identification from logs: friction, dead band and the CPFL plant family
fitted to measured or synthetic swings."""
