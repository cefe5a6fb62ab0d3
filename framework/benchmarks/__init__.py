"""Micro-benchmarks of the project's hot paths, each against the shared baseline when present."""
