"""Pen plotters: a plan on paper in mm, timed for the machine, as G-code whose feed follows
the ΣΛ speed (:mod:`.timing`, :mod:`.gcode`), with the machine's own planner estimated
(:mod:`.planner`), strokes ordered (:mod:`.order`) and drawn for people (:mod:`.preview`)."""
