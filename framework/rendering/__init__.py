"""Differentiable renderers' implementations (the plugins in ``inkmotion.plugins`` wrap them)."""
