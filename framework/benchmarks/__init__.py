"""Benchmarks of the project's hot paths and services (``inkmotion bench``); each figure's
unit, meaning and target are in :mod:`inkmotion.benchmarks.figures`."""
