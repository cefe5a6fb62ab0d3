"""Fitting: loss terms and the optimiser loop."""
