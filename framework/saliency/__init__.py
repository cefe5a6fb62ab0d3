"""Saliency maps (image -> [0, 1]) behind the saliency plugins."""
