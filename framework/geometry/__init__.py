"""Geometry: input traces, Bézier conversion, distances."""
