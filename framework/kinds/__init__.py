"""The built-in job kinds' work, one module per kind (fit, generation for tag and abstract,
simulate, evaluate) over one optimisation core (:mod:`inkmotion.kinds.optimisation`).

A kind's plugin (``inkmotion.plugins.<kind>``) declares it — name, queue, inputs,
parameters, examples — and calls its module here. This layer may import the engines,
the plugin host and the job shell; no engine imports it.
"""
