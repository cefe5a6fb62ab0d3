"""Image losses' implementations (the plugins in ``inkmotion.plugins`` wrap them)."""
