"""Jobs: the spec shared by run and submit, job kinds, and the shell that runs one."""

from inkmotion.jobs.spec import JobSpec

__all__ = ["JobSpec"]
