"""Jobs: the spec shared by run and submit, and the runner that executes one."""

from inkmotion.jobs.spec import FitParams, JobSpec

__all__ = ["FitParams", "JobSpec"]
