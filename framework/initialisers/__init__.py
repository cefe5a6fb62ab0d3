"""Initialisers that build motor plans from an image or nothing: stippling, tours, lines."""
